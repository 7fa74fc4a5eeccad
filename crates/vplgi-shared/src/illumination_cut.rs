//! The illumination cut of the global photon map (Wang et al. 2009, section 3.3): the host-side
//! choices both backends share, as they share the photon tree. Each backend computes the
//! per-node arithmetic (Eq. 3's estimates, the density estimates at the cut nodes); what is
//! chosen from those numbers is made here, once, so equal numbers give equal cuts.
//!
//! A cut is a set of tree nodes that covers every leaf exactly once. The coarse cut takes the
//! nodes whose Eq. 3 estimate Ẽ_p exceeds E_min, the mean estimate at the tree level of the
//! target size, keeping only the lowest of such nodes on any path; every leaf left uncovered is
//! covered by the root of the largest subtree that holds no such node. Bright, detailed regions
//! are so cut finely and dim, smooth ones coarsely. Where that lands further than a factor 2
//! from the target size, E_min is scaled by bisection (the paper gives only the level). Each
//! refinement pass then replaces a cut node by its children where the density estimate at it,
//! E_p, and Ẽ_p disagree by more than ΔE = 1.2 Ẽ_p: Ẽ_p spreads the node's photons over its
//! whole box, and a large gap says its light is not spread evenly.
//!
//! Final gathering reads the cut through the tree above it: [`for_gathering`] gives each node
//! at or above the cut the box around the kernels of the cut nodes below it (Eq. 4's spheres of
//! radius r_j about p_j), so a lookup walks down only where some kernel reaches; and the same
//! boxes around the fallback's kernels, `GATHER_FALLBACK_REACH` times as wide.

use crate::photon_tree::is_leaf;
use vplgi_types::params::{CUT_REFINE_RATIO, GATHER_FALLBACK_REACH};
use vplgi_types::pod::CUT_ABOVE;
use vplgi_types::{CutBound, CutNode, CutParams, Endpoint};

/// The brightness a cut compares: the mean of the three channels.
pub fn brightness(e: [f32; 3]) -> f32 {
    (e[0] + e[1] + e[2]) / 3.0
}

/// The tree level of a cut of `size` nodes in a tree of `nodes` nodes: the deepest level with
/// at most `size` nodes (level l holds 2^l).
pub fn level(size: u32, nodes: usize) -> u32 {
    let depth = (nodes + 1).ilog2().saturating_sub(1);
    size.max(1).ilog2().min(depth)
}

/// The coarse cut for threshold `e_min`: the tree nodes (ascending) whose estimate exceeds it
/// with no such node below them, and the roots of the largest subtrees holding no such node
/// that no other cut node covers.
pub fn coarse_at(estimates: &[CutNode], e_min: f32) -> Vec<u32> {
    let len = estimates.len();
    let marked: Vec<bool> = estimates.iter().map(|e| brightness(e.irradiance) > e_min).collect();
    // Whether the subtree of each node holds a marked node, bottom-up.
    let mut below = marked.clone();
    for i in (0..len).rev() {
        if !is_leaf(i, len) {
            below[i] |= below[2 * i + 1] || below[2 * i + 2];
        }
    }
    let lowest =
        |i: usize| marked[i] && (is_leaf(i, len) || !(below[2 * i + 1] || below[2 * i + 2]));
    (0..len)
        .filter(|&i| {
            lowest(i) || (!below[i] && (i == 0 || (below[(i - 1) / 2] && !lowest((i - 1) / 2))))
        })
        .map(|i| i as u32)
        .collect()
}

/// Bisection steps on E_min's scale where the coarse cut misses its target by more than 2x.
const SCALE_STEPS: u32 = 32;

/// The coarse cut for a target of `size` nodes: E_min the mean estimate at the target's level,
/// scaled until the cut is within a factor 2 of the target if it can be (the closest found
/// otherwise).
pub fn coarse(estimates: &[CutNode], size: u32) -> Vec<u32> {
    let len = estimates.len();
    if len == 0 {
        return Vec::new();
    }
    let l = level(size, len);
    let (first, last) = ((1usize << l) - 1, (2usize << l) - 1);
    let mean = estimates[first..last].iter().map(|e| brightness(e.irradiance) as f64).sum::<f64>()
        / (last - first) as f64;
    let target = size as f64;
    let off = |cut: &[u32]| (cut.len() as f64 / target).ln().abs();
    let mut best = coarse_at(estimates, mean as f32);
    // A higher E_min marks fewer nodes: scale in log space between 2^-64 and 2^64.
    let (mut lo, mut hi) = (-64.0f64, 64.0f64);
    for _ in 0..SCALE_STEPS {
        if off(&best) <= std::f64::consts::LN_2 {
            break;
        }
        let mid = (lo + hi) / 2.0;
        let cut = coarse_at(estimates, (mean * mid.exp2()) as f32);
        if cut.len() as f64 > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if off(&cut) < off(&best) {
            best = cut;
        }
    }
    best
}

/// One refinement pass: each cut node that is not a leaf and whose density estimate
/// `irradiance[node]` differs from its Eq. 3 estimate by more than `CUT_REFINE_RATIO` times the
/// latter is replaced by its children. The result is ascending.
pub fn refine(cut: &[u32], estimates: &[CutNode], irradiance: &[Option<[f32; 3]>]) -> Vec<u32> {
    let len = estimates.len();
    let mut next = Vec::with_capacity(cut.len() * 2);
    for &i in cut {
        let i = i as usize;
        let e_tilde = brightness(estimates[i].irradiance);
        let e = irradiance[i].map_or(e_tilde, brightness);
        if !is_leaf(i, len) && (e - e_tilde).abs() > CUT_REFINE_RATIO * e_tilde {
            next.extend([2 * i as u32 + 1, 2 * i as u32 + 2]);
        } else {
            next.push(i as u32);
        }
    }
    next.sort_unstable();
    next
}

/// What the cut's selection did, for the frame's statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CutStats {
    /// Nodes of the coarse cut.
    pub coarse: u32,
    /// Nodes after the refinements.
    pub size: u32,
    /// Density estimates made (one per node that was ever in the cut).
    pub estimates: u32,
    /// Density estimates that stopped at the visit budget.
    pub truncated: u32,
}

/// A cut ready for final gathering: its nodes with their density estimates, and the walk's
/// bounds over the whole tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GatherCut {
    /// The cut's tree nodes, ascending.
    pub tree_nodes: Vec<u32>,
    /// Per cut node: representative, radius, and E_p.
    pub nodes: Vec<CutNode>,
    /// Per tree node: [`CutBound`] around the kernels (nodes below the cut keep an empty box;
    /// the walk never reaches them).
    pub bounds: Vec<CutBound>,
    /// The same around the fallback's kernels, `GATHER_FALLBACK_REACH` times as wide, walked
    /// only for a hit the kernels miss.
    pub wide_bounds: Vec<CutBound>,
    pub stats: CutStats,
}

/// The density estimates a selection asks for: irradiance (rgb) at each point, and whether its
/// search stopped at the visit budget.
pub type Densities = Vec<([f32; 3], bool)>;

/// The cut of a tree whose node estimates are `estimates`: the coarse cut, `params.refinements`
/// passes, and the gathering bounds. `density` gives the density estimate at points (each
/// node's representative and normal); it is asked once per pass, for the cut nodes not asked
/// before.
pub fn select<E>(
    estimates: &[CutNode],
    params: &CutParams,
    mut density: impl FnMut(&[Endpoint]) -> Result<Densities, E>,
) -> Result<GatherCut, E> {
    let mut cut = coarse(estimates, params.size);
    let mut stats = CutStats { coarse: cut.len() as u32, ..Default::default() };
    let mut known: Vec<Option<[f32; 3]>> = vec![None; estimates.len()];
    for pass in 0..=params.refinements {
        let asked: Vec<u32> =
            cut.iter().copied().filter(|&i| known[i as usize].is_none()).collect();
        if !asked.is_empty() {
            let points: Vec<Endpoint> = asked
                .iter()
                .map(|&i| {
                    let e = &estimates[i as usize];
                    Endpoint::new(e.position.into(), e.normal.into())
                })
                .collect();
            for (&i, (e, truncated)) in asked.iter().zip(density(&points)?) {
                known[i as usize] = Some(e);
                stats.truncated += truncated as u32;
            }
            stats.estimates += asked.len() as u32;
        }
        if pass == params.refinements {
            break;
        }
        let next = refine(&cut, estimates, &known);
        if next == cut {
            break;
        }
        cut = next;
    }
    stats.size = cut.len() as u32;
    let mut out = for_gathering(estimates, &cut, &known);
    out.stats = stats;
    Ok(out)
}

/// The cut `cut` (ascending tree nodes, each with its density estimate in `irradiance`) as final
/// gathering reads it.
pub fn for_gathering(
    estimates: &[CutNode],
    cut: &[u32],
    irradiance: &[Option<[f32; 3]>],
) -> GatherCut {
    let nodes = cut
        .iter()
        .map(|&i| CutNode {
            irradiance: irradiance[i as usize].unwrap_or([0.0; 3]),
            ..estimates[i as usize]
        })
        .collect();
    GatherCut {
        tree_nodes: cut.to_vec(),
        nodes,
        bounds: bounds(estimates, cut, 1.0),
        wide_bounds: bounds(estimates, cut, GATHER_FALLBACK_REACH),
        stats: CutStats::default(),
    }
}

/// Per tree node, the box around the spheres of `reach` times the radius about the cut nodes
/// at or below it, with the cut slot or [`CUT_ABOVE`].
fn bounds(estimates: &[CutNode], cut: &[u32], reach: f32) -> Vec<CutBound> {
    let len = estimates.len();
    let empty = CutBound {
        lo: [f32::INFINITY; 3],
        slot: vplgi_types::MISS,
        hi: [f32::NEG_INFINITY; 3],
        _pad: 0,
    };
    let mut bounds = vec![empty; len];
    let mut in_cut = vec![false; len];
    for (slot, &i) in cut.iter().enumerate() {
        let i = i as usize;
        let e = estimates[i];
        let (p, r) = (glam::Vec3::from(e.position), e.radius * reach);
        bounds[i] =
            CutBound { lo: (p - r).to_array(), slot: slot as u32, hi: (p + r).to_array(), _pad: 0 };
        in_cut[i] = true;
    }
    // Bottom-up: a node above the cut bounds its children's boxes.
    let mut above = vec![false; len];
    for i in (0..len).rev() {
        if is_leaf(i, len) || in_cut[i] {
            continue;
        }
        let (l, r) = (2 * i + 1, 2 * i + 2);
        if in_cut[l] || above[l] || in_cut[r] || above[r] {
            above[i] = true;
            let (a, b) = (bounds[l], bounds[r]);
            bounds[i] = CutBound {
                lo: glam::Vec3::from(a.lo).min(b.lo.into()).to_array(),
                slot: CUT_ABOVE,
                hi: glam::Vec3::from(a.hi).max(b.hi.into()).to_array(),
                _pad: 0,
            };
        }
    }
    bounds
}

/// Eq. 5's kernel: 1 − u² within the node's radius (u ≤ 1), 0 beyond.
pub fn kernel(u2: f32) -> f32 {
    if u2 <= 1.0 {
        1.0 - u2
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Estimates for a tree of `len` nodes, brightness per node as given.
    fn estimates(bright: &[f32]) -> Vec<CutNode> {
        bright
            .iter()
            .map(|&b| CutNode { irradiance: [b; 3], radius: 1.0, ..Default::default() })
            .collect()
    }

    /// Every leaf of the tree is under exactly one cut node.
    fn covers_once(cut: &[u32], len: usize) {
        for leaf in (0..len).filter(|&i| is_leaf(i, len)) {
            let mut covering = 0;
            let mut i = leaf;
            loop {
                covering += cut.contains(&(i as u32)) as u32;
                if i == 0 {
                    break;
                }
                i = (i - 1) / 2;
            }
            assert_eq!(covering, 1, "leaf {leaf} is covered {covering} times by {cut:?}");
        }
    }

    /// A 15-node tree (depth 3) by hand. Node 5 (level 2) and leaf 8 are bright, and so is 1,
    /// which has the bright 8 below it: it is dropped for 8. Leaf 8's sibling 7 and the subtree
    /// of 4 are mark-free under the dropped 1 and 3; the subtree of 6 is mark-free under the root,
    /// which is not marked. The cut is 4, 5, 6, 7, 8: each leaf once.
    #[test]
    fn the_coarse_cut_keeps_the_lowest_marks_and_covers_the_rest_with_the_largest_subtrees() {
        let mut b = vec![0.0; 15];
        (b[1], b[5], b[8]) = (5.0, 5.0, 5.0);
        let e = estimates(&b);
        let cut = coarse_at(&e, 1.0);
        assert_eq!(cut, vec![4, 5, 6, 7, 8]);
        covers_once(&cut, 15);
        // Nothing marked: the root alone; everything marked: the leaves.
        assert_eq!(coarse_at(&e, 10.0), vec![0]);
        assert_eq!(coarse_at(&estimates(&[1.0; 15]), 0.0), (7..15).collect::<Vec<_>>());
    }

    /// On random estimates the coarse cut always covers each leaf once, and lands within a
    /// factor 2 of targets the tree can meet. Eq. 3's estimates are densities, of the same order
    /// at every level where light is even: here noise about a constant. (A single marked leaf
    /// already makes a cut of depth + 1 nodes, so small targets in deep trees are not met.)
    #[test]
    fn coarse_cuts_cover_every_leaf_once_and_meet_their_target() {
        let mut rng = vplgi_types::Rng::new(5, vplgi_types::Stream::LightPath, 0);
        for depth in [3u32, 6, 10] {
            let len = (2usize << depth) - 1;
            let b: Vec<f32> = (0..len).map(|_| 0.5 + rng.next_f32()).collect();
            let e = estimates(&b);
            for size in [1u32, 1 << (depth - 2), 1 << (depth - 1), 1 << depth] {
                let cut = coarse(&e, size);
                covers_once(&cut, len);
                let ratio = cut.len() as f64 / size as f64;
                assert!(
                    (0.5..=2.0).contains(&ratio),
                    "depth {depth}, target {size}: {} nodes",
                    cut.len()
                );
            }
        }
    }

    /// A refinement splits exactly the non-leaf nodes whose density estimate is more than 2.2x
    /// (or below -0.2x) their Eq. 3 estimate, and keeps the cover.
    #[test]
    fn refinement_splits_where_the_estimates_disagree() {
        let e = estimates(&[1.0; 15]);
        let mut irradiance = vec![None; 15];
        irradiance[1] = Some([2.3; 3]); // beyond 1 + 1.2: split
        irradiance[2] = Some([2.1; 3]); // within: kept
        let next = refine(&[1, 2], &e, &irradiance);
        assert_eq!(next, vec![2, 3, 4]);
        covers_once(&next, 15);
        // A leaf is never split.
        irradiance[9] = Some([100.0; 3]);
        assert_eq!(refine(&[9], &e, &irradiance), vec![9]);
    }

    /// The gathering bounds: a cut node's box holds its kernel (and in the wide bounds, twice its
    /// radius), a node above the cut holds its children's, and nodes below the cut are never
    /// marked above.
    #[test]
    fn gathering_bounds_hold_the_kernels_below() {
        let mut e = estimates(&[1.0; 7]);
        e[1].position = [0.0, 0.0, 0.0];
        e[5].position = [3.0, 0.0, 0.0];
        e[6].position = [0.0, 5.0, 0.0];
        e[6].radius = 2.0;
        let irradiance = vec![Some([1.0; 3]); 7];
        let g = for_gathering(&e, &[1, 5, 6], &irradiance);
        assert_eq!(g.nodes.len(), 3);
        assert_eq!(g.bounds[1].slot, 0);
        assert_eq!((g.bounds[5].slot, g.bounds[6].slot), (1, 2));
        assert_eq!((g.bounds[0].slot, g.bounds[2].slot), (CUT_ABOVE, CUT_ABOVE));
        assert_eq!(g.bounds[2].lo, [-2.0, -1.0, -2.0]);
        assert_eq!(g.bounds[2].hi, [4.0, 7.0, 2.0]);
        assert_eq!(g.bounds[0].lo, [-2.0, -1.0, -2.0]);
        assert_eq!(g.wide_bounds[2].lo, [-4.0, -2.0, -4.0]);
        assert_eq!(g.wide_bounds[2].hi, [5.0, 9.0, 4.0]);
        assert_eq!(g.wide_bounds[2].slot, CUT_ABOVE);
        assert_eq!(g.bounds[3].slot, vplgi_types::MISS);
    }
}
