//! Stage `illumination_cut` (`--gi photon`, Wang et al. 2009, section 3.3): the per-node
//! arithmetic of the global photon map's cut. The choices made from it (which nodes form the
//! cut, which are refined) are `vplgi_shared::illumination_cut`'s, shared with the GPU.
//!
//! Each node of the photon tree gets a representative, the member photon nearest the centre of
//! the node's box (just off it, `CUT_CENTRE_SKEW`; ties to the lower index), whose position and
//! surface normal stand for the
//! node, a radius r_p, the largest side of the node's box, and Eq. 3's estimate
//!
//! ```text
//! Ẽ_p = Σ_{i ∈ p} max(0, ω_i · n_p) Φ_i / r_p²
//! ```
//!
//! ω_i being the direction photon i came from and Φ_i its power: the node's light spread evenly
//! over a square the size of its box. The cosine is clamped at 0: a photon arriving from behind
//! the representative's surface (at a corner the node spans) lights another surface. Sums run
//! over the node's photons in map order, as the GPU's do.
//!
//! The refinement compares Ẽ_p with the density estimate at the representative, E_p = Σ Φ_i /
//! (π r²) over the k nearest photons whose normals are within 60° of its own (the search of
//! `caustics`, r the k-th's distance); E_p is also what a cut node lights final gathering with,
//! as the irradiance at its representative's place. That is why the place is the box's centre and
//! not a centroid of the photons: photons crowd where light is bright (their density is the
//! irradiance), so a flux-weighted centroid (NEXT-STAGES A.3's choice) leans toward the bright
//! part of every node, and gathering from it read 6 to 8 % bright on `cornell-glass` at cuts of
//! 4k nodes (`make photons`).

use crate::caustics::{nearest, PhotonMap};
use crate::CpuScene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use vplgi_frame::FrameError;
use vplgi_shared::illumination_cut::{Densities, GatherCut};
use vplgi_types::params::CUT_CENTRE_SKEW;
use vplgi_types::{CutNode, CutParams, Endpoint, Vpl};

/// The representative, radius and Eq. 3 estimate of every node of `map`'s tree.
pub fn node_estimates(map: &PhotonMap, params: &CutParams) -> Vec<CutNode> {
    map.nodes
        .par_iter()
        .map(|node| {
            let members = &map.photons[node.first as usize..(node.first + node.count) as usize];
            node_estimate(members, Vec3::from(node.lo), Vec3::from(node.hi), params.min_radius)
        })
        .collect()
}

/// One node's estimate from its photons `members` and its box `lo`..`hi`.
pub fn node_estimate(members: &[Vpl], lo: Vec3, hi: Vec3, min_radius: f32) -> CutNode {
    if members.is_empty() {
        return CutNode { radius: min_radius, ..Default::default() };
    }
    let centre = lo + (hi - lo) * centre_fraction();
    let side = (hi - lo).max_element();
    let (mut best, mut best_d2) = (0, f32::INFINITY);
    for (j, m) in members.iter().enumerate() {
        let d = Vec3::from(m.position) - centre;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if d2 < best_d2 {
            (best, best_d2) = (j, d2);
        }
    }
    let rep = &members[best];
    let n = Vec3::from(rep.normal);
    let radius = side.max(min_radius);
    let mut e = Vec3::ZERO;
    for m in members {
        e += Vec3::from(m.incoming).dot(n).max(0.0) * Vec3::from(m.flux);
    }
    CutNode {
        position: rep.position,
        radius,
        normal: rep.normal,
        irradiance: (e / (radius * radius)).to_array(),
        ..Default::default()
    }
}

/// Where in a node's box its representative is sought, per axis (`CUT_CENTRE_SKEW`).
pub fn centre_fraction() -> Vec3 {
    Vec3::splat(0.5) + Vec3::new(1.0, 2.0, 3.0) * CUT_CENTRE_SKEW
}

/// The density estimate of irradiance at `p` with normal `n`: Σ Φ / (π r²) over the photons
/// strictly inside the k-th nearest's distance r (or `max_radius`; at least `min_radius`, since
/// the representative the estimate is made at is itself a photon, and k of them may lie on one
/// point), and whether the search stopped at the visit budget.
///
/// A photon at `p` itself is left out. The cut asks at its nodes' representatives, which are
/// photons, and the other photons about a photon are distributed as about any point (Palm), so
/// counting it would make the estimate (k − 1) / (k − 2) times too bright; left out, the k − 2
/// others inside the k − 1-th other's distance give the unbiased (m − 1) / (π r_m²). At a point
/// that is no photon (a gather hit) nothing is at distance 0 and the estimate is the usual one.
pub fn density(map: &PhotonMap, p: Vec3, n: Vec3, params: &CutParams) -> (Vec3, bool) {
    let max_r2 = params.max_radius * params.max_radius;
    let found = nearest(map, p, n, params.k, max_r2);
    let r2 = found.radius2(params.k, max_r2).max(params.min_radius * params.min_radius);
    let mut sum = Vec3::ZERO;
    for &(d2, j) in &found.heap {
        if d2 < r2 && d2 > 0.0 {
            sum += Vec3::from(map.photons[j as usize].flux);
        }
    }
    (sum / (PI * r2), found.truncated)
}

/// [`density`] at each of `points`.
pub fn densities(map: &PhotonMap, points: &[Endpoint], params: &CutParams) -> Densities {
    points
        .par_iter()
        .map(|e| {
            let (d, truncated) = density(map, e.p(), e.n(), params);
            (d.to_array(), truncated)
        })
        .collect()
}

/// The whole cut of `map` on the CPU: its node estimates, and the selection with the CPU's
/// density estimates.
pub fn cut_of(map: &PhotonMap, params: &CutParams) -> GatherCut {
    let estimates = node_estimates(map, params);
    let cut: Result<GatherCut, std::convert::Infallible> =
        vplgi_shared::illumination_cut::select(&estimates, params, |points| Ok(densities(map, points, params)));
    cut.unwrap_or_else(|never| match never {})
}

impl vplgi_frame::stages::IlluminationCut for CpuScene<'_> {
    fn node_estimates(&self, map: &PhotonMap, params: &CutParams) -> Result<Vec<CutNode>, FrameError> {
        Ok(node_estimates(map, params))
    }

    fn densities(&self, map: &PhotonMap, points: &[Endpoint], params: &CutParams) -> Result<Densities, FrameError> {
        Ok(densities(map, points, params))
    }

    fn upload_cut(&self, cut: GatherCut) -> Result<GatherCut, FrameError> {
        Ok(cut)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photon(p: [f32; 3], flux: [f32; 3], incoming: [f32; 3]) -> Vpl {
        Vpl { position: p, normal: [0.0, 0.0, 1.0], flux, incoming, ..Default::default() }
    }

    /// Eq. 3 by hand. Three photons on the plane z = 0: at x = 0 (flux 1, straight down), x = 1.5
    /// (flux 3, arriving at 60°) and x = 4 (flux 2, from below the surface). The representative
    /// is sought at x = 4 · 33 / 64 = 2.06: nearest is the photon at x = 1.5. The box's largest side is 4, so
    /// Ẽ = (1 · 1 + 0.5 · 3 + 0 · 2) / 16 = 0.15625 per channel.
    #[test]
    fn eq3_by_hand() {
        let half = 3f32.sqrt() / 2.0;
        let members = [
            photon([0.0, 0.0, 0.0], [1.0; 3], [0.0, 0.0, 1.0]),
            photon([1.5, 0.0, 0.0], [3.0; 3], [half, 0.0, 0.5]),
            photon([4.0, 0.0, 0.0], [2.0; 3], [0.0, 0.0, -1.0]),
        ];
        let e = node_estimate(&members, Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0), 1e-3);
        assert_eq!(e.position, [1.5, 0.0, 0.0]);
        assert_eq!(e.radius, 4.0);
        for c in e.irradiance {
            assert!((c - 2.5 / 16.0).abs() < 1e-6, "{:?}", e.irradiance);
        }
        // A node of one photon has a box of size 0: its radius is the floor.
        assert_eq!(node_estimate(&members[..1], Vec3::ZERO, Vec3::ZERO, 0.5).radius, 0.5);
        assert_eq!(node_estimate(&[], Vec3::ZERO, Vec3::ZERO, 0.5), CutNode { radius: 0.5, ..Default::default() });
    }

    /// Photons on a unit grid of the plane z = 0, each of flux 1: irradiance 1 per unit area.
    /// The estimate at a grid point with k = 13 reaches the ring at distance 2 (the 13 points
    /// within √4: the centre, 4 at 1, 4 at √2, 4 at 2), sums the 8 strictly inside but for the
    /// centre, the photon the estimate stands on, and divides by 4π: 8 / (4π) = 0.637 (a lattice
    /// reads low: see `caustics`). Photons facing away (normals beyond 60°) are not counted.
    #[test]
    fn density_on_a_lattice() {
        let mut photons = Vec::new();
        for x in -6..=6 {
            for y in -6..=6 {
                photons.push(photon([x as f32, y as f32, 0.0], [1.0; 3], [0.0, 0.0, 1.0]));
            }
        }
        let map = crate::caustics::photon_map(&photons, 4);
        let params = CutParams { size: 4, refinements: 0, k: 13, max_radius: 10.0, min_radius: 1e-3 };
        let (e, truncated) = density(&map, Vec3::ZERO, Vec3::Z, &params);
        assert!(!truncated);
        assert!((e.x - 8.0 / (4.0 * PI)).abs() < 1e-5, "{e}");
        let (away, _) = density(&map, Vec3::ZERO, -Vec3::Z, &params);
        assert_eq!(away, Vec3::ZERO);
    }
}
