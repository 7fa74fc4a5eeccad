//! `gather_radius` (`--shade interpolate`): the GPU's 1 / R_j of the CPU's sample points (the
//! representatives of the CPU's shading-point clusters) against the CPU's.

use crate::inputs::{CpuClusters, CpuFrame};
use crate::segment::TieOracle;
use crate::tolerance::{gather_radius_bound, gather_radius_same_share, Disagreement, GATHER_RADIUS_REL, SHADING_POINTS_POSITION_REL};
use crate::{count, interpolating, result, Plan, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_frame::prelude::*;
use vplgi_gpu::buffers::read_back;
use vplgi_gpu::GpuPoints;
use vplgi_types::interpolation::GatherParams;
use vplgi_types::Endpoint;

/// 1 / R_j of `points` on both backends.
pub fn both(twins: &Twins, points: &[Endpoint], params: &GatherParams) -> Result<(Vec<f32>, Vec<f32>), VerifyError> {
    let cpu = vplgi_cpu::gather_radius::gather_radius(twins.cpu, points, params);
    let out = twins.gpu.gather_radius(&GpuPoints::upload(twins.device(), "sample points", points), params)?;
    let gpu = read_back::<f32>(twins.device(), twins.queue(), &out, points.len())?;
    Ok((cpu, gpu))
}

/// Compares 1 / R_j of `points` (within `gather_radius_bound` for the share of points
/// `gather_radius_same_share` allows), and the same share with rounding ties set aside: points
/// one of whose rays the f64 oracle finds ambiguous (`segment::TieOracle::ray_is_tie`: a hit at
/// t ≈ eps, where one backend counts a term 1 / eps and the other none, a graze of an edge, a
/// near miss). Only points that differ are traced in f64.
pub fn compare(twins: &Twins, points: &[Endpoint], params: &GatherParams) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu) = both(twins, points, params)?;
    let extent = twins.cpu.extent as f64;
    let oracle = TieOracle::new(twins.scene);
    let ties_at = |j: usize, e: &Endpoint| ray_tie(twins, &oracle, e, j, params);
    // Each point's difference as a share of its bound (NaN if either side is).
    let (mut same, mut same_or_tie, mut ties, mut checked, mut unexamined) = (0usize, 0usize, 0usize, 0usize, 0usize);
    let (mut worst, mut worst_at, mut worst_real) = (0.0f64, None, None);
    for (j, (&c, &g)) in cpu.iter().zip(&gpu).enumerate() {
        let share = if c == g { 0.0 } else { (c - g).abs() as f64 / gather_radius_bound(c as f64, extent).max(f64::MIN_POSITIVE) };
        let agrees = share <= 1.0;
        let examined = !agrees && checked < MAX_TIE_CHECKS;
        let tie = examined && {
            checked += 1;
            ties_at(j, &points[j])
        };
        unexamined += (!agrees && !examined) as usize;
        same += agrees as usize;
        same_or_tie += (agrees || tie) as usize;
        ties += tie as usize;
        let at = || format!("sample point {j}: CPU 1/R {c:e}, GPU {g:e}");
        if share > worst || share.is_nan() {
            worst = share;
            worst_at = Some(at());
        }
        if !agrees && !tie && worst_real.is_none() {
            worst_real = Some(at());
        }
    }
    let n = points.len();
    let case = format!("{} sample points, {} gather rays each", count(n), params.rays);
    let share = |k: usize| if n == 0 { 1.0 } else { k as f64 / n as f64 };
    let what = format!("share of sample points with 1/R within {GATHER_RADIUS_REL:e} relative + the hits' {SHADING_POINTS_POSITION_REL:e} x extent");
    let bound = gather_radius_same_share(params.rays);
    Ok(vec![
        Disagreement::at_least("gather_radius", &what, share(same), bound).with_case(&case).with_worst(worst_at),
        Disagreement::at_least("gather_radius", format!("{what}, apart from rounding ties"), share(same_or_tie), bound).with_case(&case).with_worst(worst_real),
        Disagreement::info("gather_radius", format!("points that differ by a rounding tie of a ray (f64, within {:.1e})", oracle.tolerance()), ties as f64)
            .with_case(&case),
        Disagreement::info(
            "gather_radius",
            format!("points that differ, not traced in f64 (beyond the first {MAX_TIE_CHECKS}; counted as differing)"),
            unexamined as f64,
        )
        .with_case(&case),
        Disagreement::info("gather_radius", "largest difference of 1/R as a share of its bound", worst).with_case(case),
    ])
}

/// Whether one of the gather rays of sample point `j` at `e` is a rounding tie for the f64
/// `oracle` (a hit at t ≈ eps, a graze of an edge, a near miss). `final_gather` traces the same
/// rays.
pub fn ray_tie(twins: &Twins, oracle: &TieOracle, e: &Endpoint, j: usize, params: &GatherParams) -> bool {
    let (eps, reach) = (twins.cpu.eps, 4.0 * twins.cpu.extent as f64);
    let (origin, mut dirs) = vplgi_cpu::gather_radius::rays(e.p(), e.n(), eps, j as u32, params);
    let o = origin.as_dvec3();
    dirs.any(|d| oracle.ray_is_tie(o, d.as_dvec3(), eps as f64, reach + o.length()))
}

/// Sample points traced in f64 at most: each ray costs a pass over the triangles. Points that
/// differ beyond them are counted as differing, and how many is reported.
pub const MAX_TIE_CHECKS: usize = 2_000;

pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let cfg = interpolating(cfg);
    let frame = CpuFrame::new(twins.cpu, &cfg);
    let clusters = CpuClusters::new(twins.cpu, &frame, &cfg);
    let mut r = result(VerifyStage::GatherRadius);
    r.checks = compare(twins, &clusters.rows, &cfg.gather_params())?;
    r.notes.push("the GPU's gather rays from the CPU's sample points (its shading-point clusters' representatives)".into());
    Ok(r)
}
