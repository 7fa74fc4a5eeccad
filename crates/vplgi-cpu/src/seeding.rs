//! Stage 3's first step with `--seeding adaptive`, `seeding`: K initial centroids among the
//! hits by Wang et al.'s screen-space quadtree (section 3.2), distributed by each node's
//! geometric variation under Eq. 2. The rules both backends follow are in
//! [`vplgi_shared::seeding`]; this is the CPU twin of `shaders/seeding.wgsl`.

use crate::cluster::{bounds, cosine, dist2};
use glam::Vec3;
use rayon::prelude::*;
use vplgi_types::clustering::{ward_error, FixedPoint};
use vplgi_shared::seeding::{capped_shares, quantize_error, ranks, Quadtree, SeedParams, CHILDREN};
use vplgi_types::MISS;
use crate::backend::CpuHits;
use crate::CpuScene;
use vplgi_frame::FrameError;
use vplgi_types::CameraParams;

/// The hits of an image, located: hit `i` is a surface point (`positions[i]`, `normals[i]`),
/// and pixel `p`'s hits are `pixel_first[p] .. pixel_first[p + 1]` (hits are numbered in sample
/// order, so a pixel's hits are consecutive).
pub struct ImageHits<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    pub pixel_first: &'a [u32],
    pub width: u32,
    pub height: u32,
}

/// Per-node statistics of the quadtree, every level in one array ([`Quadtree::node`]).
struct Nodes {
    counts: Vec<u32>,
    /// Eq. 2 variation, in quantized steps.
    variation: Vec<u64>,
}

impl ImageHits<'_> {
    /// The hits of pixel (`x`, `y`): none in the padding.
    fn pixel_hits(&self, q: &Quadtree, x: u32, y: u32) -> std::ops::Range<u32> {
        match q.pixel(x, y) {
            Some(p) => self.pixel_first[p as usize]..self.pixel_first[p as usize + 1],
            None => 0..0,
        }
    }

    /// The hits under node (`l`, `x`, `y`), pixel row by pixel row (the order does not matter
    /// to integer sums).
    fn node_hits(&self, q: &Quadtree, l: u32, x: u32, y: u32) -> impl Iterator<Item = u32> + '_ {
        let size = 1u32 << l;
        let q = *q;
        (y * size..(y + 1) * size).flat_map(move |py| (x * size..(x + 1) * size).flat_map(move |px| self.pixel_hits(&q, px, py)))
    }
}

/// Counts, fixed-point sums, means and Eq. 2 variations of every node.
fn node_statistics(hits: &ImageHits, q: &Quadtree, fix: &FixedPoint, alpha: f32) -> Nodes {
    let total = q.nodes() as usize;
    let mut counts = vec![0u32; total];
    let mut sums = vec![[0u64; 6]; total];
    // Level 1 from the pixels, the levels above from their four children (integer sums: exact).
    for l in 1..=q.levels {
        let side = q.side(l);
        let level: Vec<(u32, [u64; 6])> = (0..side * side)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % side, i / side);
                let mut s = [0u64; 6];
                let mut n = 0u32;
                if l == 1 {
                    for h in hits.node_hits(q, 1, x, y) {
                        let v = fix.quantize(hits.positions[h as usize], hits.normals[h as usize]);
                        for a in 0..6 {
                            s[a] += v[a] as u64;
                        }
                        n += 1;
                    }
                } else {
                    for (cx, cy) in CHILDREN {
                        let c = q.node(l - 1, 2 * x + cx, 2 * y + cy) as usize;
                        n += counts[c];
                        for a in 0..6 {
                            s[a] += sums[c][a];
                        }
                    }
                }
                (n, s)
            })
            .collect();
        let first = q.level_offset(l) as usize;
        for (i, (n, s)) in level.into_iter().enumerate() {
            (counts[first + i], sums[first + i]) = (n, s);
        }
    }
    // The variation of each node: its hits' Eq. 2 errors against its mean.
    let variation: Vec<u64> = (0..total as u32)
        .into_par_iter()
        .map(|node| {
            let n = counts[node as usize];
            if n == 0 {
                return 0;
            }
            let (p, nrm) = fix.mean(&sums[node as usize], n);
            let nrm = nrm.unwrap_or(Vec3::ZERO);
            let (l, x, y) = locate(q, node);
            hits.node_hits(q, l, x, y)
                .map(|h| quantize_error(ward_error(alpha, dist2(hits.positions[h as usize], p), cosine(hits.normals[h as usize], nrm))) as u64)
                .sum()
        })
        .collect();
    Nodes { counts, variation }
}

/// Level and coordinates of node `node` of the array of every level.
fn locate(q: &Quadtree, node: u32) -> (u32, u32, u32) {
    let l = (1..=q.levels).rev().find(|&l| q.level_offset(l) <= node).unwrap_or(1);
    let i = node - q.level_offset(l);
    (l, i % q.side(l), i / q.side(l))
}

/// The hit of rank `rank` under node (`l`, `x`, `y`): children in [`CHILDREN`] order, then a
/// pixel's hits in order.
fn hit_at(hits: &ImageHits, q: &Quadtree, nodes: &Nodes, (mut l, mut x, mut y): (u32, u32, u32), mut rank: u32) -> u32 {
    while l > 1 {
        let (cx, cy) = CHILDREN
            .iter()
            .map(|&(cx, cy)| (2 * x + cx, 2 * y + cy))
            .find(|&(cx, cy)| {
                let n = nodes.counts[q.node(l - 1, cx, cy) as usize];
                if rank < n {
                    true
                } else {
                    rank -= n;
                    false
                }
            })
            .unwrap_or((2 * x, 2 * y));
        (l, x, y) = (l - 1, cx, cy);
    }
    for (px, py) in CHILDREN {
        let r = hits.pixel_hits(q, 2 * x + px, 2 * y + py);
        if rank < r.len() as u32 {
            return r.start + rank;
        }
        rank -= r.len() as u32;
    }
    MISS
}

/// The adaptive seeds: at most `params.k` hit indices, in quadtree order.
pub fn seeding(hits: &ImageHits, params: &SeedParams) -> Vec<u32> {
    let m = hits.positions.len() as u32;
    if m == 0 || params.k == 0 {
        return Vec::new();
    }
    let q = Quadtree::new(hits.width, hits.height);
    let (lo, hi) = bounds(hits.positions);
    let nodes = node_statistics(hits, &q, &FixedPoint::new(lo, hi), params.alpha);
    let total = params.k.min(m);
    let mut slots = vec![MISS; total as usize];
    // (seeds, first slot) of each node of the level being distributed, top down.
    let mut given = vec![(0u32, 0u32); q.nodes() as usize];
    given[q.node(q.levels, 0, 0) as usize] = (total, 0);
    for l in (1..=q.levels).rev() {
        let side = q.side(l);
        for i in 0..side * side {
            let (x, y) = (i % side, i / side);
            let node = q.node(l, x, y);
            let (s, first) = given[node as usize];
            let n = nodes.counts[node as usize];
            if s == 0 || n == 0 {
                continue;
            }
            let child = |j: usize| q.node(l - 1, 2 * x + CHILDREN[j].0, 2 * y + CHILDREN[j].1) as usize;
            if s >= n && l == 1 {
                for r in 0..n {
                    slots[(first + r) as usize] = hit_at(hits, &q, &nodes, (l, x, y), r);
                }
            } else if s >= n {
                // Every hit is a seed: each child as many as it has hits (the GPU's way, which
                // keeps every invocation's loops short).
                let mut at = first;
                for j in 0..4 {
                    given[child(j)] = (nodes.counts[child(j)], at);
                    at += nodes.counts[child(j)];
                }
            } else if s == 1 || l == 1 {
                for (j, r) in ranks(params.seed, node, s, n).enumerate() {
                    slots[first as usize + j] = hit_at(hits, &q, &nodes, (l, x, y), r);
                }
            } else {
                let w = [0, 1, 2, 3].map(|j| nodes.variation[child(j)]);
                let cap = [0, 1, 2, 3].map(|j| nodes.counts[child(j)]);
                let mut at = first;
                for (j, share) in capped_shares(s, w, cap).into_iter().enumerate() {
                    given[child(j)] = (share, at);
                    at += share;
                }
            }
        }
    }
    slots.into_iter().filter(|&h| h != MISS).collect()
}

impl vplgi_frame::stages::Seeding for CpuScene<'_> {
    fn seeding(&self, hits: &CpuHits, camera: &CameraParams, params: &SeedParams) -> Result<Vec<u32>, FrameError> {
        let (pos, nor) = crate::cluster::positions_and_normals(&hits.points);
        // Hits are in sample order: pixel p's are those of samples p spp .. (p + 1) spp.
        let pixels = camera.width as usize * camera.height as usize;
        let pixel_first: Vec<u32> = (0..=pixels).map(|p| hits.samples.partition_point(|&s| (s as usize) < p * camera.spp as usize) as u32).collect();
        let image = ImageHits { positions: &pos, normals: &nor, pixel_first: &pixel_first, width: camera.width, height: camera.height };
        Ok(seeding(&image, params))
    }
}

#[cfg(test)]
mod tests;
