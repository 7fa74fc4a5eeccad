//! Stage `caustics` (`--caustics photons`): the light that reaches a shading point straight from
//! a mirror or glass, which no VPL carries (none sits on a mirror) and no shadow ray sees (it
//! stops at glass). `trace_vpls` leaves a caustic photon wherever a particle meets a
//! non-specular surface after a specular vertex; this stage estimates their density at every
//! shading point from its k nearest (Jensen's estimator, which Wang et al. 2009 use for their
//! caustic map):
//!
//! ```text
//! L_c(x, ω_o) = Σ_{i : d_i < r} f(x, ω_i, ω_o) Φ_i / (π r²)
//! ```
//!
//! r is the distance to the k-th nearest photon, or `max_radius` where fewer than k lie within
//! it, and the sum takes the photons strictly inside r: k − 1 of them, which makes the estimate
//! unbiased where photons fall as a uniform Poisson process (π r_k² λ is then Gamma(k)-
//! distributed, so E[1 / r_k²] = π λ / (k − 1)). Photons from the stratified emission fall more
//! evenly than that, and on a lattice the same estimate would read 1 / k low; the mirror oracle
//! in `tests/tests/caustics.rs` measures where between the two they lie. Only photons whose surface normal is within 60° of the point's count
//! (`CAUSTIC_NORMAL_COS`): a photon around a corner, or on the other side of a thin wall, lies
//! near in space but on another surface. f is ρ / π, times the receiver's lobe for rough metal.
//!
//! The search is the balanced kd-tree of `vplgi_shared::photon_tree`, built once on the host
//! and shared with the GPU: a depth-first walk, nearer child first, pruned by the box distance,
//! keeping the k nearest by (distance², map index) in a max-heap. Both backends walk the same
//! nodes in the same order and stop after the same number of visits (`CAUSTIC_VISITS`), so they
//! keep the same photons but for rounding.

use crate::shade::receiver;
use crate::CpuScene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::Range;
use vplgi_frame::{Counted, FrameError};
use vplgi_scene::Material;
use vplgi_shared::photon_tree::{self, box_distance2, STACK};
use vplgi_types::params::{CAUSTIC_NORMAL_COS, CAUSTIC_VISITS};
use vplgi_types::{CausticParams, PhotonNode, ShadingPoint, Vpl};

/// A photon map: its photons in the order of its kd-tree, and the tree.
#[derive(Clone, Debug, Default)]
pub struct PhotonMap {
    pub photons: Vec<Vpl>,
    pub nodes: Vec<PhotonNode>,
}

impl Counted for PhotonMap {
    fn count(&self) -> u32 {
        self.photons.len() as u32
    }
}

/// The map of `photons`, leaves of at most `leaf` photons.
pub fn photon_map(photons: &[Vpl], leaf: u32) -> PhotonMap {
    let (photons, nodes) = photon_tree::ordered(photons, leaf);
    PhotonMap { photons, nodes }
}

/// The k nearest photons of a query: a max-heap on (distance², map index), its top the k-th.
#[derive(Clone, Debug, Default)]
pub struct Nearest {
    /// (distance², map index), at most k.
    pub heap: Vec<(f32, u32)>,
    /// The walk stopped at the visit budget.
    pub truncated: bool,
}

impl Nearest {
    /// The estimate's radius²: the k-th nearest's distance², or `max_r2` where fewer than k were
    /// found.
    pub fn radius2(&self, k: u32, max_r2: f32) -> f32 {
        match self.heap.first() {
            Some(&(kth, _)) if self.heap.len() == k as usize => kth,
            _ => max_r2,
        }
    }
}

/// The k nearest photons of `map` to `p` with normals within 60° of `n` and distance² below
/// `max_r2`.
pub fn nearest(map: &PhotonMap, p: Vec3, n: Vec3, k: u32, max_r2: f32) -> Nearest {
    let k = k as usize;
    let mut out = Nearest { heap: Vec::with_capacity(k), truncated: false };
    if map.photons.is_empty() || k == 0 {
        return out;
    }
    let len = map.nodes.len();
    let mut stack = [0u32; STACK];
    let mut top = 1;
    let mut visits = 0;
    while top > 0 {
        if visits >= CAUSTIC_VISITS {
            out.truncated = true;
            break;
        }
        top -= 1;
        let i = stack[top] as usize;
        visits += 1;
        let node = &map.nodes[i];
        let bound = if out.heap.len() == k { out.heap[0].0 } else { max_r2 };
        if box_distance2(node, p) > bound {
            continue;
        }
        if photon_tree::is_leaf(i, len) {
            for j in node.first..node.first + node.count {
                visits += 1;
                let photon = &map.photons[j as usize];
                if Vec3::from(photon.normal).dot(n) <= CAUSTIC_NORMAL_COS {
                    continue;
                }
                let d = Vec3::from(photon.position) - p;
                let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
                if d2 < max_r2 {
                    offer(&mut out.heap, k, (d2, j));
                }
            }
            continue;
        }
        // Push the farther child first, so the nearer is walked first (ties: left first).
        let (l, r) = (2 * i + 1, 2 * i + 2);
        let (dl, dr) = (box_distance2(&map.nodes[l], p), box_distance2(&map.nodes[r], p));
        let (near, far) = if dr < dl { (r, l) } else { (l, r) };
        stack[top] = far as u32;
        stack[top + 1] = near as u32;
        top += 2;
    }
    out
}

/// Offers `item` to the max-heap `heap` of at most `k` smallest items.
fn offer(heap: &mut Vec<(f32, u32)>, k: usize, item: (f32, u32)) {
    let less = |a: (f32, u32), b: (f32, u32)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
    let mut i;
    if heap.len() < k {
        // Sift up from the end.
        heap.push(item);
        i = heap.len() - 1;
        while i > 0 {
            let parent = (i - 1) / 2;
            if !less(heap[parent], heap[i]) {
                break;
            }
            heap.swap(parent, i);
            i = parent;
        }
        return;
    }
    if !less(item, heap[0]) {
        return;
    }
    // Replace the top and sift down.
    heap[0] = item;
    i = 0;
    loop {
        let (l, r) = (2 * i + 1, 2 * i + 2);
        let mut largest = i;
        if l < k && less(heap[largest], heap[l]) {
            largest = l;
        }
        if r < k && less(heap[largest], heap[r]) {
            largest = r;
        }
        if largest == i {
            break;
        }
        heap.swap(i, largest);
        i = largest;
    }
}

/// The caustic radiance at shading point `sp` toward where it is seen from, and whether its
/// search stopped at the visit budget. Zero for a miss.
pub fn estimate(map: &PhotonMap, materials: &[Material], sp: &ShadingPoint, params: &CausticParams) -> (Vec3, bool) {
    if sp.is_miss() {
        return (Vec3::ZERO, false);
    }
    let (p, n) = (Vec3::from(sp.position), Vec3::from(sp.normal));
    let max_r2 = params.max_radius * params.max_radius;
    let found = nearest(map, p, n, params.k, max_r2);
    let r2 = found.radius2(params.k, max_r2);
    let at = receiver(materials, sp);
    let mut sum = Vec3::ZERO;
    for &(d2, j) in &found.heap {
        let photon = &map.photons[j as usize];
        if d2 >= r2 || photon.bounce > params.max_bounce {
            continue;
        }
        let a = at.map_or(1.0, |(surface, view)| surface.lobe(n, view, Vec3::from(photon.incoming)));
        sum += Vec3::from(photon.flux) * a;
    }
    (sum * Vec3::from(sp.albedo) / (PI * PI * r2), found.truncated)
}

/// The caustic radiance of the pixels of `points` (camera samples `samples`, whole pixels), each
/// the mean of its samples', and how many estimates were truncated.
pub fn caustics(cs: &CpuScene, map: &PhotonMap, points: &[ShadingPoint], samples: Range<u32>, params: &CausticParams) -> (Vec<[f32; 3]>, u32) {
    let spp = params.spp.max(1) as usize;
    let count = (samples.end - samples.start) as usize;
    let materials = &cs.scene.materials;
    let per_pixel: Vec<([f32; 3], u32)> = points[..count]
        .par_chunks(spp)
        .map(|pixel| {
            let mut sum = Vec3::ZERO;
            let mut cut = 0;
            for sp in pixel {
                let (l, truncated) = estimate(map, materials, sp, params);
                sum += l;
                cut += truncated as u32;
            }
            ((sum / spp as f32).to_array(), cut)
        })
        .collect();
    let truncated = per_pixel.iter().map(|p| p.1).sum();
    (per_pixel.into_iter().map(|p| p.0).collect(), truncated)
}

impl vplgi_frame::stages::Caustics for CpuScene<'_> {
    fn photon_map(&self, photons: &Vec<Vpl>, leaf: u32) -> Result<PhotonMap, FrameError> {
        Ok(photon_map(photons, leaf))
    }

    fn caustics(
        &self,
        map: &PhotonMap,
        points: &Vec<ShadingPoint>,
        samples: Range<u32>,
        params: &CausticParams,
    ) -> Result<(Vec<[f32; 3]>, u32), FrameError> {
        Ok(caustics(self, map, points, samples, params))
    }
}
