//! The balanced kd-tree over a photon map, built once on the host and read by both backends'
//! `caustics`, `illumination_cut` and `final_gather` (as the BVH is built once and shared): the
//! twins then differ only in their per-query arithmetic, never in the structure they search.
//!
//! Each node splits its photons at the median along the longest side of their box, ties broken
//! by the photon's index, so the tree is a pure function of the positions. Every level halves
//! the counts (the left child takes the larger half), so every leaf lies at the same depth, the
//! tree is complete and a node needs no child links: node i's children are 2i + 1 and 2i + 2,
//! and the nodes whose children would lie past the array are the leaves. The photons end up
//! permuted so that each node's are consecutive.

use glam::Vec3;
use vplgi_types::{PhotonNode, Vpl};

/// Entries of a walk's stack: a depth-first walk holds one pending sibling per level, and a
/// balanced tree over at most 2³² photons has at most 32 levels.
pub const STACK: usize = 64;

/// A photon map's tree: `order[j]` is the photon that takes place j, and `nodes` the complete
/// binary tree over those places.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonTree {
    pub order: Vec<u32>,
    pub nodes: Vec<PhotonNode>,
}

/// Levels below the root for `n` photons and leaves of at most `leaf`: the fewest that bring the
/// larger half down to `leaf`.
pub fn depth(n: usize, leaf: u32) -> u32 {
    let leaf = leaf.max(1) as usize;
    let mut d = 0;
    while n.div_ceil(1 << d) > leaf {
        d += 1;
    }
    d
}

/// Whether node `i` of a tree of `nodes` nodes is a leaf.
pub fn is_leaf(i: usize, nodes: usize) -> bool {
    2 * i + 1 >= nodes
}

/// The tree over photons at `positions`, leaves of at most `leaf` (at least 1) photons.
pub fn build(positions: &[Vec3], leaf: u32) -> PhotonTree {
    let n = positions.len();
    let levels = depth(n, leaf);
    let len = (2usize << levels) - 1;
    let mut nodes = vec![PhotonNode::default(); len];
    let mut order: Vec<u32> = (0..n as u32).collect();
    nodes[0].count = n as u32;
    // Top-down: split each node's range at its median, then its children's.
    for i in 0..len {
        let (first, count) = (nodes[i].first as usize, nodes[i].count as usize);
        let (lo, hi) = bounds(positions, &order[first..first + count]);
        (nodes[i].lo, nodes[i].hi) = (lo.to_array(), hi.to_array());
        if is_leaf(i, len) {
            continue;
        }
        let left = count.div_ceil(2);
        if count > 1 {
            let axis = (hi - lo).max_position();
            let key = |j: &u32| (positions[*j as usize][axis], *j);
            order[first..first + count].select_nth_unstable_by(left - 1, |a, b| {
                key(a).partial_cmp(&key(b)).expect("photon positions are finite")
            });
        }
        nodes[2 * i + 1] =
            PhotonNode { first: first as u32, count: left as u32, ..Default::default() };
        nodes[2 * i + 2] = PhotonNode {
            first: (first + left) as u32,
            count: (count - left) as u32,
            ..Default::default()
        };
    }
    PhotonTree { order, nodes }
}

/// A photon map: `photons` permuted into the order of their tree (leaves of at most `leaf`), and
/// the tree's nodes, as both backends search it.
pub fn ordered(photons: &[Vpl], leaf: u32) -> (Vec<Vpl>, Vec<PhotonNode>) {
    let positions: Vec<Vec3> = photons.iter().map(|p| Vec3::from(p.position)).collect();
    let tree = build(&positions, leaf);
    (tree.order.iter().map(|&j| photons[j as usize]).collect(), tree.nodes)
}

/// The box of the photons `members`; an empty box (lo > hi) for none.
fn bounds(positions: &[Vec3], members: &[u32]) -> (Vec3, Vec3) {
    members.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &j| {
        let p = positions[j as usize];
        (lo.min(p), hi.max(p))
    })
}

/// Squared distance from `p` to the box of `node` (0 inside; infinite for an empty node).
pub fn box_distance2(node: &PhotonNode, p: Vec3) -> f32 {
    let (lo, hi) = (Vec3::from(node.lo), Vec3::from(node.hi));
    if node.count == 0 {
        return f32::INFINITY;
    }
    let d = (lo - p).max(p - hi).max(Vec3::ZERO);
    d.x * d.x + d.y * d.y + d.z * d.z
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_types::{Rng, Stream};

    fn cloud(n: usize, seed: u32) -> Vec<Vec3> {
        let mut rng = Rng::new(seed, Stream::LightPath, 0);
        (0..n)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32() * 0.3, rng.next_f32() * 2.0))
            .collect()
    }

    /// Every photon sits in exactly one leaf; every leaf holds at most `leaf`; every node's box
    /// holds its photons and its children's ranges split its own; each split separates the two
    /// halves along some axis (the median property, checked against a sort).
    #[test]
    fn the_tree_is_complete_balanced_and_split_at_medians() {
        for (n, leaf) in [(0, 8), (1, 8), (8, 8), (9, 8), (17, 8), (1000, 8), (1000, 1), (4097, 5)]
        {
            let pos = cloud(n, n as u32 + leaf);
            let t = build(&pos, leaf);
            let mut seen = t.order.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..n as u32).collect::<Vec<_>>(), "n {n}: a permutation");
            let len = t.nodes.len();
            let mut in_leaves = 0;
            for (i, node) in t.nodes.iter().enumerate() {
                let members = &t.order[node.first as usize..(node.first + node.count) as usize];
                for &j in members {
                    let p = pos[j as usize];
                    assert!(
                        p.cmpge(Vec3::from(node.lo)).all() && p.cmple(Vec3::from(node.hi)).all()
                    );
                }
                if is_leaf(i, len) {
                    assert!(node.count <= leaf.max(1), "n {n}: leaf {i} holds {}", node.count);
                    in_leaves += node.count;
                    continue;
                }
                let (l, r) = (&t.nodes[2 * i + 1], &t.nodes[2 * i + 2]);
                assert_eq!(
                    (l.first, l.first + l.count, r.first + r.count),
                    (node.first, r.first, node.first + node.count)
                );
                assert!(l.count == r.count || l.count == r.count + 1);
                if node.count > 1 {
                    let axis = (Vec3::from(node.hi) - Vec3::from(node.lo)).max_position();
                    let key = |j: u32| (pos[j as usize][axis], j);
                    let mut sorted: Vec<u32> = members.to_vec();
                    sorted.sort_by(|a, b| key(*a).partial_cmp(&key(*b)).unwrap());
                    let mut left: Vec<u32> = members[..l.count as usize].to_vec();
                    left.sort_unstable();
                    let mut expect = sorted[..l.count as usize].to_vec();
                    expect.sort_unstable();
                    assert_eq!(left, expect, "n {n}: node {i} splits at its median");
                }
            }
            assert_eq!(in_leaves as usize, n);
        }
    }

    /// A box's distance is 0 inside, the distance to the nearest face or corner outside.
    #[test]
    fn box_distance_is_the_distance_to_the_box() {
        let node = PhotonNode { lo: [0.0; 3], hi: [1.0; 3], count: 1, first: 0 };
        assert_eq!(box_distance2(&node, Vec3::splat(0.5)), 0.0);
        assert_eq!(box_distance2(&node, Vec3::new(3.0, 0.5, 0.5)), 4.0);
        assert_eq!(box_distance2(&node, Vec3::new(-1.0, 2.0, 3.0)), 1.0 + 1.0 + 4.0);
        assert_eq!(box_distance2(&PhotonNode::default(), Vec3::ZERO), f32::INFINITY);
    }
}
