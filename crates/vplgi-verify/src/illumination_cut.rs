//! `illumination_cut` (`--gi photon`): from the CPU's global photon map and the tree the host
//! built over it, the GPU's Eq. 3 estimates at every node and its density estimates at the cut
//! nodes the CPU asked for, against the CPU's; and the cut each backend's own numbers choose.
//! The photons themselves are `trace_vpls`' (its rows judge photon paths).

use crate::tolerance::{share_of_diverged, Disagreement, CUT_DIFFERING_NODES, CUT_REL};
use crate::{count, result, v3, Plan, StageResult, Twins, VerifyError, VerifyStage};
use glam::Vec3;
use vplgi_cpu::caustics::photon_map;
use vplgi_cpu::illumination_cut::{densities, node_estimates};
use vplgi_gpu::caustics::GpuPhotonMap;
use vplgi_shared::illumination_cut::{select, GatherCut};
use vplgi_types::{CutParams, Endpoint, FrameConfig, Vpl};

/// Global photons `vplgi verify` traces at most.
pub const VERIFY_PHOTONS: u32 = 50_000;

/// The CPU's global photons for `cfg` (at most [`VERIFY_PHOTONS`]).
pub fn global_photons(twins: &Twins, cfg: &FrameConfig) -> Vec<Vpl> {
    let trace = vplgi_types::TraceParams { count: cfg.global_photons.min(VERIFY_PHOTONS), ..cfg.global_trace_params() };
    vplgi_cpu::trace_vpls::trace_vpls(twins.cpu, &trace, &vplgi_cpu::NoProgress).vpls
}

/// Each channel's largest difference relative to the larger estimate's largest channel (0 where
/// both are 0).
fn relative(a: [f32; 3], b: [f32; 3]) -> f64 {
    let (a, b) = (Vec3::from(a), Vec3::from(b));
    let scale = a.abs().max_element().max(b.abs().max_element()) as f64;
    if scale == 0.0 {
        0.0
    } else {
        (a - b).abs().max_element() as f64 / scale
    }
}

/// Compares the two backends' work on the map of `photons` (leaves of at most `leaf`).
pub fn compare(twins: &Twins, photons: &[Vpl], leaf: u32, params: &CutParams) -> Result<Vec<Disagreement>, VerifyError> {
    let map = photon_map(photons, leaf);
    let (device, queue) = (twins.device(), twins.queue());
    let kernels = twins.gpu.kernels();
    let gpu_map: GpuPhotonMap = kernels.caustics.upload(device, &map.photons, &map.nodes);
    let nodes = map.nodes.len() as u32;
    let cpu = node_estimates(&map, params);
    let gpu = kernels.illumination_cut.node_estimates(device, queue, &gpu_map, nodes, params)?;

    // Eq. 3 at every node.
    let (mut differ, mut worst, mut worst_at) = (0usize, 0.0f64, None);
    for (i, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        let share = relative(c.irradiance, g.irradiance);
        let other_member = c.position != g.position || c.radius != g.radius;
        if other_member || share.is_nan() || share > CUT_REL {
            differ += 1;
        }
        if share > worst || share.is_nan() {
            worst = share;
            worst_at = Some(format!("node {i}: CPU Ẽ {}, GPU {}", v3(c.irradiance), v3(g.irradiance)));
        }
    }
    let case = format!("{} photons, {} tree nodes, cut target {}", count(map.photons.len()), count(cpu.len()), params.size);
    let mut checks = vec![
        share_of_diverged("illumination_cut", &format!("nodes whose Eq. 3 estimate differs beyond {CUT_REL:e} relative or whose representative differs"), (differ, cpu.len()), CUT_DIFFERING_NODES)
            .with_case(&case)
            .with_worst(worst_at),
        Disagreement::info("illumination_cut", "largest difference of Eq. 3's estimate, relative to its largest channel", worst).with_case(&case),
    ];

    // The density estimates at the points the CPU's selection asked for.
    let mut asked: Vec<Endpoint> = Vec::new();
    let cpu_cut: Result<GatherCut, std::convert::Infallible> = select(&cpu, params, |points| {
        asked.extend_from_slice(points);
        Ok(densities(&map, points, params))
    });
    let cpu_cut = cpu_cut.unwrap_or_else(|never| match never {});
    let cpu_d = densities(&map, &asked, params);
    let gpu_d = kernels.illumination_cut.densities(device, queue, &gpu_map, &asked, params)?;
    let (mut differ, mut lit, mut worst, mut worst_at) = (0usize, 0usize, 0.0f64, None);
    let mut cut_short = (0usize, 0usize);
    for (i, (c, g)) in cpu_d.iter().zip(&gpu_d).enumerate() {
        cut_short.0 += c.1 as usize;
        cut_short.1 += g.1 as usize;
        if c.0 == [0.0; 3] && g.0 == [0.0; 3] {
            continue;
        }
        lit += 1;
        let share = relative(c.0, g.0);
        if share.is_nan() || share > CUT_REL {
            differ += 1;
        }
        if share > worst || share.is_nan() {
            worst = share;
            worst_at = Some(format!("density estimate {i}: CPU {}, GPU {}", v3(c.0), v3(g.0)));
        }
    }
    let dcase = format!("{case}, {} density estimates, k = {}", count(asked.len()), params.k);
    checks.extend([
        share_of_diverged("illumination_cut", &format!("density estimates beyond {CUT_REL:e} relative (their k nearest differ)"), (differ, lit), CUT_DIFFERING_NODES)
            .with_case(&dcase)
            .with_worst(worst_at),
        Disagreement::at_most("illumination_cut", "density searches stopped at the visit budget, GPU minus CPU", cut_short.1.abs_diff(cut_short.0) as f64, 0.0).with_case(&dcase),
        Disagreement::info("illumination_cut", "largest difference of a density estimate, relative to its largest channel", worst).with_case(&dcase),
    ]);

    // The cut each backend's own numbers choose.
    let gpu_cut = select(&gpu, params, |points| kernels.illumination_cut.densities(device, queue, &gpu_map, points, params))?;
    let (a, b) = (&cpu_cut.tree_nodes, &gpu_cut.tree_nodes);
    let only_one = a.iter().filter(|i| b.binary_search(i).is_err()).count() + b.iter().filter(|i| a.binary_search(i).is_err()).count();
    let ccase = format!("{case}: the CPU's cut {} nodes (coarse {}), the GPU's {}", a.len(), cpu_cut.stats.coarse, b.len());
    checks.extend([
        share_of_diverged("illumination_cut", "cut nodes in one backend's cut only (from each backend's own estimates)", (only_one, a.len() + b.len()), CUT_DIFFERING_NODES).with_case(&ccase),
        Disagreement::info("illumination_cut", "cut nodes (CPU)", a.len() as f64).with_case(ccase),
    ]);
    Ok(checks)
}

pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::IlluminationCut);
    let photons = global_photons(twins, cfg);
    r.checks = compare(twins, &photons, cfg.photon_leaf, &cfg.cut_params(twins.cpu.extent))?;
    r.notes.push(format!(
        "the GPU's node and density estimates from the CPU's {} global photons, in the tree the host built; and the cut each backend's numbers choose",
        count(photons.len())
    ));
    Ok(r)
}
