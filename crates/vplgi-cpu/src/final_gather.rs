//! Stage `final_gather` (`--gi photon`, Wang et al. 2009, section 3.4): the irradiance at each
//! sample point s_j (a shading-point cluster's representative) from `rays` cosine-distributed
//! gather rays, each lit where it lands by the illumination cut. Eq. 1 makes the point's
//! reflected radiance ρ E, and with cosine-distributed rays
//!
//! ```text
//! E(s_j) = (π / N) Σ_k L(y_k),   L(y) = (ρ_y / π) Σ_j w_j E_{p_j} / Σ_j w_j,
//! w_j = K(|p_j − y| / r_j) max(0, n_j · n_y)   (Eq. 4),   K(u) = 1 − u² for u ≤ 1, else 0   (Eq. 5)
//! ```
//!
//! over the cut nodes p_j (representative position, normal, radius r_j and density estimate
//! E_{p_j}) whose kernels reach y. So E(s_j) = (1 / N) Σ_k ρ_{y_k} Ê(y_k). A ray that escapes, or
//! lands on a mirror or glass, adds nothing: light that reaches s_j through a mirror is the
//! caustic map's (`--caustics photons`). Emission at y is not gathered either: it is s_j's direct
//! light, which `shade` samples. A hit no kernel reaches (Σ w = 0) takes the same sum over
//! kernels twice as wide (`GATHER_FALLBACK_REACH`; none: nothing), and is counted.
//!
//! The rays are `gather_radius`' rays (stream `Gather`, point j), so the same pass also gives
//! 1 / R_j for the interpolation, and the spherical harmonics of each point's incident light
//! (`vplgi_shared::sh`) for glossy receivers. The lookup walks the tree above the cut
//! (`vplgi_shared::illumination_cut::for_gathering`) left child first, summing in the order it
//! meets the cut nodes, and stops after `GATHER_VISITS` nodes, as the GPU does.

use crate::gather_radius::rays;
use crate::interpolate::IrradianceSamples;
use crate::CpuScene;
use glam::Vec3;
use rayon::prelude::*;
use vplgi_frame::{FrameError, GatherCounts};
use vplgi_shared::illumination_cut::{kernel, GatherCut};
use vplgi_shared::photon_tree::{is_leaf, STACK};
use vplgi_shared::sh::{self, ShRgb};
use vplgi_types::interpolation::{inverse_radius, GatherParams};
use vplgi_types::params::{GATHER_FALLBACK_REACH, GATHER_VISITS};
use vplgi_types::pod::CUT_ABOVE;
use vplgi_types::{CutBound, Endpoint};

/// How a gather hit is lit: its irradiance, whether no Eq. 4 kernel reached it (so the wider
/// fallback kernels lit it, or nothing did), and whether a walk stopped at the visit budget.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HitLight {
    pub irradiance: Vec3,
    pub fallback: bool,
    pub truncated: bool,
}

/// Eq. 4's kernel-weighted irradiance of the cut at `y` (normal `n`): Σ w E / Σ w over the cut
/// nodes whose kernels reach it. Where none does (Σ w = 0: a gap between kernels, or a corner
/// where the near nodes lie on the other wall), the same sum with kernels twice as wide
/// (`GATHER_FALLBACK_REACH`), which is continuous in `y` as Eq. 4 is; zero where even those do
/// not reach, as behind a light a hand's breadth from the ceiling, where no photon lands. The
/// nearest facing node, as NEXT-STAGES A.3 suggests, lit such places from far away, and jumped
/// wherever the nearest changed (`make photons` and the property test measured both).
pub fn cut_irradiance(cut: &GatherCut, y: Vec3, n: Vec3) -> HitLight {
    let (sum, total, truncated) = kernel_sum(cut, &cut.bounds, 1.0, y, n);
    if total > 0.0 {
        return HitLight { irradiance: sum / total, fallback: false, truncated };
    }
    let (sum, total, cut_short) = kernel_sum(cut, &cut.wide_bounds, GATHER_FALLBACK_REACH, y, n);
    let irradiance = if total > 0.0 { sum / total } else { Vec3::ZERO };
    HitLight { irradiance, fallback: true, truncated: truncated || cut_short }
}

/// Σ w E and Σ w at `y` over the cut nodes whose kernels, `reach` times their radius wide, reach
/// it (found through `bounds`, built for that reach), in the order the walk meets them; and
/// whether the walk stopped at the visit budget.
fn kernel_sum(cut: &GatherCut, bounds: &[CutBound], reach: f32, y: Vec3, n: Vec3) -> (Vec3, f32, bool) {
    let len = bounds.len();
    let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
    if len == 0 {
        return (sum, total, false);
    }
    let mut stack = [0u32; STACK];
    let mut top = 1;
    let mut visits = 0;
    while top > 0 {
        if visits >= GATHER_VISITS {
            return (sum, total, true);
        }
        top -= 1;
        let i = stack[top] as usize;
        visits += 1;
        let b = &bounds[i];
        if y.cmplt(Vec3::from(b.lo)).any() || y.cmpgt(Vec3::from(b.hi)).any() {
            continue;
        }
        if b.slot == CUT_ABOVE {
            if !is_leaf(i, len) {
                stack[top] = 2 * i as u32 + 2;
                stack[top + 1] = 2 * i as u32 + 1;
                top += 2;
            }
            continue;
        }
        let node = &cut.nodes[b.slot as usize];
        let d = Vec3::from(node.position) - y;
        let r = node.radius * reach;
        let w = kernel((d.x * d.x + d.y * d.y + d.z * d.z) / (r * r)) * Vec3::from(node.normal).dot(n).max(0.0);
        if w > 0.0 {
            sum += w * Vec3::from(node.irradiance);
            total += w;
        }
    }
    (sum, total, false)
}

/// One sample point's gather: 1 / R, the irradiance E, the spherical harmonics of its
/// cosine-weighted incident light (`vplgi_shared::sh`), and what the hits counted.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointGather {
    pub inv_radius: f32,
    pub irradiance: Vec3,
    pub sh: ShRgb,
    pub counts: GatherCounts,
}

/// One sample point's gather with each non-specular hit lit by `light` (at a point with a
/// normal). Ray k adds ρ_y Ê(y_k) to N E and ρ_y Ê(y_k) Y(ω_k) to N g: both are (π / N) Σ L
/// times what cosine-distributed rays weigh by.
pub fn gather_with(cs: &CpuScene, e: &Endpoint, index: u32, params: &GatherParams, light: impl Fn(Vec3, Vec3) -> HitLight) -> PointGather {
    let (origin, dirs) = rays(e.p(), e.n(), cs.eps, index, params);
    let mut g = PointGather::default();
    let (mut inv_sum, mut sum) = (0.0f32, Vec3::ZERO);
    for dir in dirs {
        let Some(hit) = cs.trace_beyond(origin, dir, cs.eps) else {
            continue;
        };
        inv_sum += 1.0 / hit.t;
        if hit.surface.is_specular() {
            continue;
        }
        let l = light(hit.position, hit.ns);
        g.counts.truncated += l.truncated as u64;
        g.counts.fallback += l.fallback as u64;
        let c = hit.albedo * l.irradiance;
        sum += c;
        sh::accumulate(&mut g.sh, dir, c);
    }
    let n = params.rays.max(1) as f32;
    for k in g.sh.iter_mut() {
        *k = (Vec3::from(*k) / n).to_array();
    }
    g.inv_radius = inverse_radius(inv_sum, params.rays);
    g.irradiance = sum / n;
    g
}

/// [`gather_with`] at every sample point of `points` (point j drawing stream (seed, Gather, j)):
/// the irradiance samples, and what all their hits counted. `light` is the cut's lookup in the
/// frame; `make photons` also gathers with a density estimate at every hit, which the cut
/// replaces.
pub fn gather_all(cs: &CpuScene, points: Vec<Endpoint>, params: &GatherParams, light: impl Fn(Vec3, Vec3) -> HitLight + Sync) -> (IrradianceSamples, GatherCounts) {
    let each: Vec<PointGather> = points.par_iter().enumerate().map(|(j, e)| gather_with(cs, e, j as u32, params, &light)).collect();
    let counts = GatherCounts {
        fallback: each.iter().map(|g| g.counts.fallback).sum(),
        truncated: each.iter().map(|g| g.counts.truncated).sum(),
    };
    let samples = IrradianceSamples {
        inv_radius: each.iter().map(|g| g.inv_radius).collect(),
        irradiance: each.iter().map(|g| g.irradiance.to_array()).collect(),
        sh: each.iter().map(|g| g.sh).collect(),
        points,
    };
    (samples, counts)
}

/// The final gather at every sample point of `points`, lit by `cut`: the irradiance samples, and
/// what the lookups counted.
pub fn final_gather(cs: &CpuScene, points: Vec<Endpoint>, cut: &GatherCut, params: &GatherParams) -> (IrradianceSamples, GatherCounts) {
    gather_all(cs, points, params, |y, n| cut_irradiance(cut, y, n))
}

impl vplgi_frame::stages::FinalGather for CpuScene<'_> {
    fn final_gather(&self, points: Vec<Endpoint>, cut: &GatherCut, params: &GatherParams) -> Result<(IrradianceSamples, GatherCounts), FrameError> {
        Ok(final_gather(self, points, cut, params))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_shared::illumination_cut::for_gathering;
    use vplgi_types::CutNode;

    fn node(p: [f32; 3], n: [f32; 3], r: f32, e: f32) -> CutNode {
        CutNode { position: p, radius: r, normal: n, irradiance: [e; 3], ..Default::default() }
    }

    /// Eq. 4 and 5 by hand. A cut of two nodes under the root: at the origin (radius 2, E = 10,
    /// facing +z) and at (1, 0, 0) (radius 1, E = 4, normal 60° from +z). At y = (0.5, 0, 0) facing
    /// +z: u² = 0.0625 and 0.25, so w = 0.9375 and 0.75 · 0.5 = 0.375, and
    /// Ê = (0.9375 · 10 + 0.375 · 4) / 1.3125 = 8.2857. Beyond every kernel, the kernels twice as
    /// wide; beyond those, nothing.
    #[test]
    fn eq4_and_eq5_by_hand() {
        let turned = [3f32.sqrt() / 2.0, 0.0, 0.5];
        let estimates = vec![CutNode::default(), node([0.0; 3], [0.0, 0.0, 1.0], 2.0, 10.0), node([1.0, 0.0, 0.0], turned, 1.0, 4.0)];
        let e: Vec<Option<[f32; 3]>> = estimates.iter().map(|n| Some(n.irradiance)).collect();
        let cut = for_gathering(&estimates, &[1, 2], &e);
        let got = cut_irradiance(&cut, Vec3::new(0.5, 0.0, 0.0), Vec3::Z);
        let exact = (0.9375 * 10.0 + 0.375 * 4.0) / 1.3125;
        assert!(!got.truncated && !got.fallback);
        assert!((got.irradiance.x - exact).abs() < 1e-5, "{got:?} vs {exact}");
        // (1.9, 1.9, 0) is beyond both kernels (u² = 1.805 and 4.42); twice as wide, the origin's
        // reaches it (u² / 4 = 0.45) and the other's does not (1.105): the origin's lights it.
        let corner = cut_irradiance(&cut, Vec3::new(1.9, 1.9, 0.0), Vec3::Z);
        assert_eq!((corner.irradiance.x, corner.fallback), (10.0, true));
        // At x = 5, beyond both wide kernels (u² / 4 = 1.5625 and 4), nothing does.
        let far = cut_irradiance(&cut, Vec3::new(5.0, 0.0, 0.0), Vec3::Z);
        assert_eq!((far.irradiance, far.fallback), (Vec3::ZERO, true));
        // A surface facing away from both nodes takes no weight and no light from them.
        let away = cut_irradiance(&cut, Vec3::new(0.5, 0.0, 0.0), -Vec3::Z);
        assert_eq!((away.irradiance, away.fallback), (Vec3::ZERO, true));
    }
}
