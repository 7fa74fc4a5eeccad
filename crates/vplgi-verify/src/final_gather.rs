//! `final_gather` (`--gi photon`): the GPU's gather at the CPU's sample points (the
//! representatives of the CPU's shading-point clusters), lit by the cut the CPU chose from its
//! own global photon map, against the CPU's: each point's irradiance, spherical harmonics and
//! 1 / R_j.

use crate::gather_radius::{ray_tie, MAX_TIE_CHECKS};
use crate::illumination_cut::global_photons;
use crate::inputs::{CpuClusters, CpuFrame};
use crate::segment::TieOracle;
use crate::tolerance::{gather_radius_bound, gather_radius_same_share, Disagreement, FINAL_GATHER_REL};
use crate::{count, interpolating, result, v3, Plan, StageResult, Twins, VerifyError, VerifyStage};
use glam::Vec3;
use vplgi_cpu::caustics::photon_map;
use vplgi_gpu::buffers::read_back;
use vplgi_gpu::GpuPoints;
use vplgi_shared::illumination_cut::GatherCut;
use vplgi_shared::sh::ShRgb;
use vplgi_types::interpolation::GatherParams;
use vplgi_types::Endpoint;

/// One backend's gather at every point: 1 / R_j, the irradiance and the spherical harmonics per
/// point, and the hits no kernel reached (lit by the fallback's wider kernels).
pub struct Gathered {
    pub inv_radius: Vec<f32>,
    pub irradiance: Vec<[f32; 3]>,
    pub sh: Vec<ShRgb>,
    pub fallback: u64,
}

/// The gather at `points` on both backends, CPU first.
pub fn both(twins: &Twins, points: &[Endpoint], cut: &GatherCut, params: &GatherParams) -> Result<(Gathered, Gathered), VerifyError> {
    let (cpu, cpu_counts) = vplgi_cpu::final_gather::final_gather(twins.cpu, points.to_vec(), cut, params);
    let (device, queue) = (twins.device(), twins.queue());
    let kernels = twins.gpu.kernels();
    let gpu_cut = kernels.illumination_cut.upload(device, cut);
    let g = kernels.final_gather.run(device, queue, twins.gpu.scene(), GpuPoints::upload(device, "sample points", points), &gpu_cut, params)?;
    let n = points.len();
    let inv = read_back::<f32>(device, queue, &g.samples.inv_radius, n)?;
    let e = read_back::<[f32; 4]>(device, queue, &g.samples.irradiance, n)?;
    let sh = match &g.samples.sh {
        Some(b) => read_back::<ShRgb>(device, queue, b, n)?,
        None => Vec::new(),
    };
    let counts = read_back::<[u32; 2]>(device, queue, &g.counts, n)?;
    let gpu = Gathered {
        inv_radius: inv,
        irradiance: e.iter().map(|v| [v[0], v[1], v[2]]).collect(),
        sh,
        fallback: counts.iter().map(|c| c[0] as u64).sum(),
    };
    let cpu = Gathered { inv_radius: cpu.inv_radius, irradiance: cpu.irradiance, sh: cpu.sh, fallback: cpu_counts.fallback };
    Ok((cpu, gpu))
}

/// The largest difference of two points' coefficients as a share of the largest coefficient of
/// either (0 when all are 0).
fn sh_difference(c: &ShRgb, g: &ShRgb) -> f64 {
    let flat = |s: &ShRgb| s.iter().flatten().copied().collect::<Vec<f32>>();
    let (c, g) = (flat(c), flat(g));
    let scale = c.iter().chain(&g).fold(0.0f32, |m, v| m.max(v.abs())) as f64;
    let diff = c.iter().zip(&g).fold(0.0f32, |m, (a, b)| m.max((a - b).abs())) as f64;
    if scale == 0.0 {
        0.0
    } else {
        diff / scale
    }
}

/// Compares the gather at `points` lit by `cut`: the share of points whose 1 / R_j is within
/// `gather_radius_bound` and whose irradiance is within [`FINAL_GATHER_REL`], judged as
/// `gather_radius`' share (a ray that meets another surface moves its point by a whole term),
/// and the same share with points one of whose rays the f64 oracle finds ambiguous set aside.
pub fn compare(twins: &Twins, points: &[Endpoint], cut: &GatherCut, params: &GatherParams) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu) = both(twins, points, cut, params)?;
    let (c_inv, c_e, c_fallback) = (&cpu.inv_radius, &cpu.irradiance, cpu.fallback);
    let (g_inv, g_e, g_fallback) = (&gpu.inv_radius, &gpu.irradiance, gpu.fallback);
    let extent = twins.cpu.extent as f64;
    let oracle = TieOracle::new(twins.scene);
    let ties_at = |j: usize, e: &Endpoint| ray_tie(twins, &oracle, e, j, params);
    let (mut same, mut same_or_tie, mut ties, mut checked) = (0usize, 0usize, 0usize, 0usize);
    let (mut worst, mut worst_at, mut worst_real) = (0.0f64, None, None);
    for j in 0..points.len() {
        let (ce, ge) = (Vec3::from(c_e[j]), Vec3::from(g_e[j]));
        let scale = ce.abs().max_element().max(ge.abs().max_element()) as f64;
        let e_share = if scale == 0.0 { 0.0 } else { (ce - ge).abs().max_element() as f64 / scale / FINAL_GATHER_REL };
        let (c, g) = (c_inv[j], g_inv[j]);
        let inv_share = if c == g { 0.0 } else { (c - g).abs() as f64 / gather_radius_bound(c as f64, extent).max(f64::MIN_POSITIVE) };
        let sh_share = match (cpu.sh.get(j), gpu.sh.get(j)) {
            (Some(c), Some(g)) => sh_difference(c, g) / FINAL_GATHER_REL,
            _ => f64::INFINITY,
        };
        let share = e_share.max(inv_share).max(sh_share);
        let agrees = share <= 1.0;
        let tie = !agrees && checked < MAX_TIE_CHECKS && {
            checked += 1;
            ties_at(j, &points[j])
        };
        same += agrees as usize;
        same_or_tie += (agrees || tie) as usize;
        ties += tie as usize;
        let at = || format!("sample point {j}: CPU E {}, 1/R {c:e}; GPU E {}, 1/R {g:e}", v3(c_e[j]), v3(g_e[j]));
        if share > worst || share.is_nan() {
            worst = share;
            worst_at = Some(at());
        }
        if !agrees && !tie && worst_real.is_none() {
            worst_real = Some(at());
        }
    }
    let n = points.len();
    let case = format!("{} sample points, {} gather rays each, a cut of {} nodes", count(n), params.rays, count(cut.nodes.len()));
    let share = |k: usize| if n == 0 { 1.0 } else { k as f64 / n as f64 };
    let what = format!("share of sample points with irradiance and harmonics within {FINAL_GATHER_REL:e} relative and 1/R within gather_radius' bound");
    let bound = gather_radius_same_share(params.rays);
    Ok(vec![
        Disagreement::at_least("final_gather", &what, share(same), bound).with_case(&case).with_worst(worst_at),
        Disagreement::at_least("final_gather", format!("{what}, apart from rounding ties"), share(same_or_tie), bound).with_case(&case).with_worst(worst_real),
        Disagreement::info("final_gather", "points that differ by a rounding tie of a ray (f64)", ties as f64).with_case(&case),
        Disagreement::info("final_gather", "gather hits no cut node's kernel reached, lit by the fallback's wider kernels (CPU)", c_fallback as f64).with_case(&case),
        Disagreement::info("final_gather", "the same on the GPU", g_fallback as f64).with_case(&case),
        Disagreement::info("final_gather", "largest difference as a share of its bound", worst).with_case(case),
    ])
}

pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = interpolating(&plan.config);
    let frame = CpuFrame::new(twins.cpu, &cfg);
    let clusters = CpuClusters::new(twins.cpu, &frame, &cfg);
    let photons = global_photons(twins, &cfg);
    let cut = vplgi_cpu::illumination_cut::cut_of(&photon_map(&photons, cfg.photon_leaf), &cfg.cut_params(twins.cpu.extent));
    let mut r = result(VerifyStage::FinalGather);
    r.checks = compare(twins, &clusters.rows, &cut, &cfg.gather_params())?;
    r.notes.push(format!(
        "the GPU's gather at the CPU's sample points, lit by the cut the CPU chose from its {} global photons",
        count(photons.len())
    ));
    Ok(r)
}
