//! `caustics` (`--caustics photons`): the GPU's caustic radiance at the CPU's shading points,
//! from the CPU's caustic photon map and the tree the host built over it, against the CPU's.
//! The photons themselves are `trace_vpls`' (its rows judge the caustic photons' paths).

use crate::tolerance::{share_of_diverged, Disagreement, CAUSTICS_DIFFERING_SETS, CAUSTICS_REL};
use crate::{count, result, v3, Plan, StageResult, Twins, VerifyError, VerifyStage};
use glam::Vec3;
use vplgi_cpu::caustics::{photon_map, PhotonMap};
use vplgi_types::{CausticParams, ShadingPoint, Vpl};

/// The map both backends estimated from, and each shading point's caustic radiance (rgb) and
/// truncation (w = 1) on each.
pub struct Estimates {
    pub map: PhotonMap,
    pub cpu: Vec<[f32; 4]>,
    pub gpu: Vec<[f32; 4]>,
}

/// The estimates at `sps` on the CPU and on the GPU, from the map the host built over `photons`.
pub fn both(twins: &Twins, photons: &[Vpl], leaf: u32, sps: &[ShadingPoint], params: &CausticParams) -> Result<Estimates, VerifyError> {
    let map = photon_map(photons, leaf);
    let materials = &twins.scene.materials;
    let cpu: Vec<[f32; 4]> = sps
        .iter()
        .map(|sp| {
            let (l, cut) = vplgi_cpu::caustics::estimate(&map, materials, sp, params);
            [l.x, l.y, l.z, cut as u32 as f32]
        })
        .collect();
    let (device, queue) = (twins.device(), twins.queue());
    let kernel = &twins.gpu.kernels().caustics;
    let gpu_map = kernel.upload(device, &map.photons, &map.nodes);
    let points = vplgi_gpu::buffers::storage(device, "shading points", sps);
    let samples = vplgi_gpu::caustics::Samples { buffer: &points, count: sps.len() as u32 };
    let gpu = kernel.run(device, queue, &gpu_map, &samples, &twins.gpu.scene().lobes, params)?;
    Ok(Estimates { map, cpu, gpu })
}

/// Compares the estimates at `sps`: the share that differ beyond [`CAUSTICS_REL`] (as a rate of
/// differing photon sets, among the estimates either side finds light in), the truncated walks,
/// and the largest difference.
pub fn compare(twins: &Twins, photons: &[Vpl], leaf: u32, sps: &[ShadingPoint], params: &CausticParams) -> Result<Vec<Disagreement>, VerifyError> {
    let Estimates { map, cpu, gpu } = both(twins, photons, leaf, sps, params)?;
    let (mut lit, mut differ, mut cut_cpu, mut cut_gpu) = (0usize, 0usize, 0usize, 0usize);
    let (mut worst, mut worst_at) = (0.0f64, None);
    for (i, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        cut_cpu += (c[3] != 0.0) as usize;
        cut_gpu += (g[3] != 0.0) as usize;
        let (cv, gv) = (Vec3::new(c[0], c[1], c[2]), Vec3::new(g[0], g[1], g[2]));
        let scale = cv.abs().max_element().max(gv.abs().max_element()) as f64;
        if scale == 0.0 {
            continue;
        }
        lit += 1;
        let share = (cv - gv).abs().max_element() as f64 / scale;
        if share.is_nan() || share > CAUSTICS_REL {
            differ += 1;
        }
        if share > worst || share.is_nan() {
            worst = share;
            worst_at = Some(format!("shading point {i}: CPU {}, GPU {}", v3(cv.to_array()), v3(gv.to_array())));
        }
    }
    let case = format!(
        "{} shading points, {} caustic photons, k = {}, radius {:.3e}",
        count(sps.len()),
        count(map.photons.len()),
        params.k,
        params.max_radius
    );
    let what = format!("estimates beyond {CAUSTICS_REL:e} relative (their k nearest differ)");
    Ok(vec![
        share_of_diverged("caustics", &what, (differ, lit), CAUSTICS_DIFFERING_SETS).with_case(&case).with_worst(worst_at),
        Disagreement::at_most("caustics", "walks stopped at the visit budget, GPU minus CPU", cut_gpu.abs_diff(cut_cpu) as f64, 0.0).with_case(&case),
        Disagreement::info("caustics", "walks stopped at the visit budget (CPU)", cut_cpu as f64).with_case(&case),
        Disagreement::info("caustics", "shading points with caustic light", lit as f64).with_case(&case),
        Disagreement::info("caustics", "largest difference, relative to the estimate's largest channel", worst).with_case(case),
    ])
}

/// Caustic photons `vplgi verify` traces at most: enough that most lit points find k.
pub const VERIFY_PHOTONS: u32 = 50_000;

pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::Caustics);
    if !twins.scene.has_specular() {
        r.checks.push(Disagreement::info("caustics", "caustic photons (the scene has no mirror or glass: nothing to compare)", 0.0));
        return Ok(r);
    }
    let trace = vplgi_types::TraceParams { count: cfg.caustic_photons.min(VERIFY_PHOTONS), ..cfg.caustic_trace_params() };
    let photons = vplgi_cpu::trace_vpls::trace_vpls(twins.cpu, &trace, &vplgi_cpu::NoProgress).vpls;
    let sps = vplgi_cpu::shading_points::shading_points(twins.cpu, &cfg.camera_params(twins.scene.camera));
    let params = cfg.caustic_params(twins.cpu.extent, 0);
    r.checks = compare(twins, &photons, cfg.photon_leaf, &sps, &params)?;
    r.notes.push(format!(
        "the GPU's estimates from the CPU's {} caustic photons, in the tree the host built, at the CPU's shading points",
        count(photons.len())
    ));
    Ok(r)
}
