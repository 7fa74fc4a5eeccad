//! The GPU's acceleration structure: an obvhs BVH2 built on the CPU, threaded for stackless
//! traversal and uploaded once.
//!
//! The WGSL traversal (`shaders/common/bvh.wgsl`) keeps no stack: nodes are laid out in depth-
//! first preorder, an inner node's first child is the next node, and every node carries a skip
//! link to the node after its subtree, where traversal goes when the ray misses the node's box or
//! has tested the leaf. A ray's whole traversal state is then one node index, which lets
//! `visibility.wgsl` start an invocation's next shadow ray the moment the current one ends
//! instead of waiting for the slowest SIMD lane, and removes the per-invocation stack array that
//! lavapipe spills to memory. The price is a fixed child order, so closest-hit rays cannot visit
//! the nearer child first. Measured by `cargo run --release -p vplgi-gpu --example bvh_choice`
//! and on the conference scene; the numbers are in `docs/perf/optimisations.md`.

use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use glam::Vec3A;
use obvhs::bvh2::node::Bvh2Node;
use vplgi_scene::Scene;
pub use vplgi_types::device::{BvhTri, END, LEAF_COUNT_BITS};

/// A node as the traversal reads it (`BvhNode`, a `vec4<u32>` in bvh.wgsl), 16 bytes: the box's
/// corners quantized to 16 bits per axis in the scene's [`BvhFrame`] (words 0-2: min x, y, z,
/// max x, y, z, low half first), then the link (word 3). One load per node visited instead of
/// two: on lavapipe a storage-buffer load is a loop over the SIMD lanes per component, and the
/// node fetch was the hot spot of `visibility` (`ci/jit-profile.sh`). The quantized box always
/// contains the exact one (rounded outwards, with a step of margin), so traversal only visits
/// more, never misses: hits are the same.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct BvhNode {
    pub words: [u32; 4],
}

/// Link word of a leaf: this bit, [`LINK_LAST`] on the last node of the preorder (the traversal
/// ends after it; any other leaf's next node is the one after it), and the first slot of its
/// triangles shifted left by [`LEAF_COUNT_BITS`], or'ed with their count.
pub const LINK_LEAF: u32 = 1 << 31;
pub const LINK_LAST: u32 = 1 << 30;
/// Link word of an inner node whose subtree ends the preorder; any other inner node's link is
/// its skip link, the node after its subtree (its first child is the next node).
pub const LINK_END: u32 = LINK_LEAF - 1;

/// Where the quantized corners are: `origin + q * step` per axis, q in 0 ..= 65535
/// (`bvh_frame` in scene.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BvhFrame {
    pub origin: [f32; 4],
    pub step: [f32; 4],
}

impl BvhFrame {
    /// The corner of quantized coordinates `q` on `axis`, as the GPU may compute it: multiply
    /// then add, or fused. Returns (the smaller, the larger).
    fn corner(&self, axis: usize, q: u32) -> (f32, f32) {
        let (o, s) = (self.origin[axis], self.step[axis]);
        let (a, b) = (o + q as f32 * s, (q as f32).mul_add(s, o));
        (a.min(b), a.max(b))
    }

    /// The box of a node at its narrowest of the two ways the GPU may compute it.
    pub fn dequantize(&self, node: &BvhNode) -> ([f32; 3], [f32; 3]) {
        let w = node.words;
        let q = [w[0] & 0xffff, w[0] >> 16, w[1] & 0xffff, w[1] >> 16, w[2] & 0xffff, w[2] >> 16];
        (
            std::array::from_fn(|a| self.corner(a, q[a]).1),
            std::array::from_fn(|a| self.corner(a, q[3 + a]).0),
        )
    }
}

/// obvhs' medium preset without its coarse search near the root (`search_depth_threshold` 3
/// there): on scenes whose walls are fine grids (the generated ones) the preset builds trees
/// whose shadow segments visit about a hundred times more nodes, for the same occluders and the
/// same build time. `examples/bvh_visits.rs` measures both builds on a scene; the numbers are in
/// commit b2f6076. And smaller leaves (a leaf collapses when a node costs as much as a triangle
/// test, not three times as much): a 16-byte node is a third of a triangle's loads, and the
/// triangle fetch became the hot spot of `visibility` once nodes were quantized.
pub const BUILD: obvhs::BvhBuildParams = obvhs::BvhBuildParams {
    search_depth_threshold: 0,
    collapse_traversal_cost: 1.0,
    ..obvhs::BvhBuildParams::medium_build()
};

/// The flat arrays uploaded to the device.
pub struct BvhArrays {
    pub nodes: Vec<BvhNode>,
    pub tris: Vec<BvhTri>,
    pub frame: BvhFrame,
}

/// A node of the threaded BVH before its box is quantized.
struct Threaded {
    min: [f32; 3],
    max: [f32; 3],
    /// The node after this node's subtree in preorder, or [`END`].
    skip: u32,
    /// For a leaf, its first triangle slot and count; `None` for an inner node.
    leaf: Option<(u32, u32)>,
}

/// Builds the BVH2 of `scene`, threads it and lays its triangles out in leaf order.
pub fn build(scene: &Scene) -> Result<BvhArrays, GpuError> {
    if scene.triangle_count() == 0 {
        // One leaf without triangles: every ray misses.
        let empty = BvhNode { words: [0, 0, 0, LINK_LEAF | LINK_LAST] };
        return Ok(BvhArrays {
            nodes: vec![empty],
            tris: vec![BvhTri::zeroed()],
            frame: BvhFrame::zeroed(),
        });
    }
    let tris = triangles(scene);
    let mut build_time = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, BUILD, &mut build_time);
    let (nodes, frame) = quantize(&thread(&bvh.nodes)?)?;
    let laid_out = bvh
        .primitive_indices
        .iter()
        .map(|&p| {
            let [a, b, c] = scene.triangle(p as usize);
            BvhTri {
                v0: [a.x, a.y, a.z, f32::from_bits(p)],
                v1: [b.x, b.y, b.z, 0.0],
                v2: [c.x, c.y, c.z, 0.0],
            }
        })
        .collect();
    Ok(BvhArrays { nodes, tris: laid_out, frame })
}

/// Lays `nodes` (root at 0, an inner node's children at `first_index` and `first_index + 1`) out
/// in preorder with skip links.
fn thread(nodes: &[Bvh2Node]) -> Result<Vec<Threaded>, GpuError> {
    // Preorder through an explicit stack (the tree may be deeper than the thread's stack allows).
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        let n = &nodes[i];
        if n.prim_count == 0 {
            stack.push(n.first_index as usize + 1);
            stack.push(n.first_index as usize);
        }
    }
    // Subtree sizes, children before parents: a first child sits right after its parent and the
    // second child right after the first child's subtree.
    let mut size = vec![1usize; order.len()];
    for p in (0..order.len()).rev() {
        if nodes[order[p]].prim_count == 0 {
            let first = size[p + 1];
            size[p] = 1 + first + size[p + 1 + first];
        }
    }
    let max_count = (1 << LEAF_COUNT_BITS) - 1;
    let max_slot = 1u32 << (30 - LEAF_COUNT_BITS);
    if order.len() as u64 >= LINK_END as u64 {
        return Err(GpuError::TooLarge {
            what: "BVH nodes".into(),
            needed: order.len() as u64,
            limit: LINK_END as u64 - 1,
        });
    }
    order
        .iter()
        .enumerate()
        .map(|(p, &i)| {
            let n = &nodes[i];
            let leaf = if n.prim_count == 0 {
                None
            } else if n.prim_count > max_count || n.first_index >= max_slot {
                return Err(GpuError::TooLarge {
                    what: "a BVH leaf (triangles per leaf, or the first triangle slot)".into(),
                    needed: n.first_index.max(n.prim_count) as u64,
                    limit: max_count.max(max_slot) as u64,
                });
            } else {
                Some((n.first_index, n.prim_count))
            };
            let next = p + size[p];
            let skip = if next == order.len() { END } else { next as u32 };
            Ok(Threaded { min: n.aabb.min.into(), max: n.aabb.max.into(), skip, leaf })
        })
        .collect()
}

/// The widest crack between triangles that the WGSL triangle test closes, in float spacings of
/// the largest coordinate it computes with (`crack_width` in bvh.wgsl): separately transformed
/// meshes meet at vertices a few ulps apart.
pub const CRACK_ULPS: f32 = 8.0;

/// The nodes' boxes quantized to 16 bits per axis in a frame spanning the root's box, rounded
/// outwards so that every quantized box holds its node's box however the GPU evaluates
/// `origin + q * step` (multiply then add, or fused), and the links encoded. Every box keeps at
/// least one step of room around its node's exact box, the root's included (the frame starts a
/// step before it), and a step is at least twice the crack the triangle test closes: a ray
/// through a crack at the scene's outer walls still enters the boxes of both sides.
fn quantize(nodes: &[Threaded]) -> Result<(Vec<BvhNode>, BvhFrame), GpuError> {
    let root = &nodes[0];
    let mut frame = BvhFrame::zeroed();
    for a in 0..3 {
        let (lo, hi) = (root.min[a], root.max[a]);
        // The crack's float spacings at the box's far coordinate, twice over: a step reaches
        // past the crack however close to the next power of two that coordinate is. 65,532
        // steps span the box, one more lies on each side, and one spare absorbs the rounding.
        let far = lo.abs().max(hi.abs());
        let spacing = f32::from_bits(far.to_bits() + 1) - far;
        let step =
            if hi > lo { ((hi - lo) / 65532.0).max(2.0 * CRACK_ULPS * spacing) } else { 0.0 };
        frame.origin[a] = lo - step;
        frame.step[a] = step;
    }
    let quantized = |node: &Threaded| -> Result<[u32; 6], GpuError> {
        let mut q = [0u32; 6];
        for a in 0..3 {
            let step = frame.step[a];
            if step == 0.0 {
                continue; // a flat frame: every corner is the origin, exactly
            }
            let at = |v: f32| (v - frame.origin[a]) / step;
            // One step of margin past the rounding, then widened until provably outside.
            let mut lo = (at(node.min[a]).floor() - 1.0).clamp(0.0, 65535.0) as u32;
            while lo > 0 && frame.corner(a, lo).1 > node.min[a] {
                lo -= 1;
            }
            let mut hi = (at(node.max[a]).ceil() + 1.0).clamp(0.0, 65535.0) as u32;
            while hi < 65535 && frame.corner(a, hi).0 < node.max[a] {
                hi += 1;
            }
            if frame.corner(a, lo).1 > node.min[a] || frame.corner(a, hi).0 < node.max[a] {
                return Err(GpuError::TooLarge {
                    what: "BVH box quantization steps (a box outside the root's)".into(),
                    needed: 65536,
                    limit: 65535,
                });
            }
            (q[a], q[3 + a]) = (lo, hi);
        }
        Ok(q)
    };
    let last = nodes.len() - 1;
    let packed = nodes
        .iter()
        .enumerate()
        .map(|(p, node)| {
            let q = quantized(node)?;
            let link = match node.leaf {
                Some((first, count)) => {
                    LINK_LEAF
                        | if p == last { LINK_LAST } else { 0 }
                        | first << LEAF_COUNT_BITS
                        | count
                }
                None if node.skip == END => LINK_END,
                None => node.skip,
            };
            Ok(BvhNode { words: [q[0] | q[1] << 16, q[2] | q[3] << 16, q[4] | q[5] << 16, link] })
        })
        .collect::<Result<Vec<_>, GpuError>>()?;
    Ok((packed, frame))
}

/// The scene's triangles as obvhs builds and intersects them (also the input of the obvhs CPU
/// traversal that serves as a third opinion in tests).
pub fn triangles(scene: &Scene) -> Vec<obvhs::triangle::Triangle> {
    (0..scene.triangle_count())
        .map(|t| {
            let [a, b, c] = scene.triangle(t);
            obvhs::triangle::Triangle { v0: Vec3A::from(a), v1: Vec3A::from(b), v2: Vec3A::from(c) }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::ray::Ray;

    /// A node as bvh.wgsl decodes it: its box, the node after it when the ray misses the box
    /// (or has tested the leaf), and a leaf's triangle slots.
    fn decode(
        arrays: &BvhArrays,
        i: u32,
    ) -> (obvhs::aabb::Aabb, u32, Option<std::ops::Range<u32>>) {
        let node = &arrays.nodes[i as usize];
        let (min, max) = arrays.frame.dequantize(node);
        let aabb = obvhs::aabb::Aabb { min: Vec3A::from(min), max: Vec3A::from(max) };
        let link = node.words[3];
        if link & LINK_LEAF != 0 {
            let payload = link & (LINK_LAST - 1);
            let first = payload >> LEAF_COUNT_BITS;
            let next = if link & LINK_LAST != 0 { END } else { i + 1 };
            (aabb, next, Some(first..first + (payload & ((1 << LEAF_COUNT_BITS) - 1))))
        } else {
            (aabb, if link == LINK_END { END } else { link }, None)
        }
    }

    /// The traversal of bvh.wgsl, on the CPU: closest hit distance and the nodes visited.
    fn traverse(arrays: &BvhArrays, tris: &[obvhs::triangle::Triangle], ray: &Ray) -> (f32, usize) {
        let (mut t, mut visited, mut i) = (ray.tmax, 0, 0u32);
        while i != END {
            let (aabb, mut next, leaf) = decode(arrays, i);
            visited += 1;
            if aabb.intersect_ray(&Ray { tmax: t, ..*ray }) < f32::INFINITY {
                match leaf {
                    None => next = i + 1,
                    Some(slots) => {
                        for slot in slots {
                            let tri = arrays.tris[slot as usize].v0[3].to_bits() as usize;
                            t = t.min(tris[tri].intersect(&Ray { tmax: t, ..*ray }));
                        }
                    }
                }
            }
            i = next;
        }
        (t, visited)
    }

    #[test]
    fn node_and_triangle_layouts_match_the_wgsl_structs() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 16, "BvhNode in bvh.wgsl is a vec4<u32>");
        assert_eq!(std::mem::size_of::<BvhTri>(), 48);
        let scene = vplgi_scene::cornell::cornell_box();
        let arrays = build(&scene).unwrap();
        // Every scene triangle appears in the leaves, once.
        let mut seen: Vec<u32> = arrays.tris.iter().map(|t| t.v0[3].to_bits()).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..scene.triangle_count() as u32).collect::<Vec<_>>());
    }

    /// Skip links: descending everywhere visits every node once, in order; missing the root ends
    /// the traversal; and on random rays through random clutter the threaded traversal finds the
    /// same closest hit as testing every triangle, while visiting far fewer nodes.
    #[test]
    fn threaded_traversal_finds_the_brute_force_closest_hit() {
        let mut rng = vplgi_types::Rng::new(3, vplgi_types::Stream::Oracle, 0);
        let mut r = || rng.next_f32();
        let mut scene =
            Scene { materials: vec![vplgi_scene::Material::default()], ..Scene::default() };
        for i in 0..3000u32 {
            let c = glam::Vec3::new(r(), r(), r()) * 2.0 - 1.0;
            for _ in 0..3 {
                scene.positions.push(c + (glam::Vec3::new(r(), r(), r()) - 0.5) * 0.1);
                scene.normals.push(glam::Vec3::Z);
                scene.uvs.push(glam::Vec2::ZERO);
            }
            scene.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
            scene.material_ids.push(0);
        }
        let arrays = build(&scene).unwrap();
        let tris = triangles(&scene);
        let n = arrays.nodes.len();
        assert_eq!(arrays.nodes[0].words[3], LINK_END, "the root's subtree is everything");
        let mut order = Vec::new();
        let mut i = 0u32;
        while i != END {
            order.push(i);
            let (_, next, leaf) = decode(&arrays, i);
            i = if leaf.is_none() { i + 1 } else { next };
        }
        assert_eq!(order, (0..n as u32).collect::<Vec<_>>());
        let (mut hits, mut visited) = (0, 0);
        for _ in 0..2000 {
            let o = Vec3A::new(r(), r(), r()) * 3.0 - 1.5;
            let d = Vec3A::new(r(), r(), r()) * 2.0 - 1.0 - o; // toward the clutter
            let ray = Ray::new(o, d, 0.0, f32::INFINITY);
            let brute = tris.iter().map(|t| t.intersect(&ray)).fold(f32::INFINITY, f32::min);
            let (t, v) = traverse(&arrays, &tris, &ray);
            assert_eq!(t.to_bits(), brute.to_bits(), "closest hit from {o} along {d}");
            hits += (t < f32::INFINITY) as usize;
            visited += v;
        }
        assert!(hits > 200 && hits < 1800, "{hits} of 2000 rays hit: the test needs both");
        assert!(
            visited < 2000 * n / 10,
            "{} nodes visited per ray of {n}: the boxes prune nothing",
            visited / 2000
        );
    }

    /// Every quantized box holds its node's exact box with the triangle test's crack to spare
    /// on every side (the root's too), both ways the GPU may evaluate a corner, on the clutter
    /// scene and on a tiny scene far from the origin (where the float spacing is large against
    /// the box).
    #[test]
    fn quantized_boxes_hold_the_exact_boxes() {
        let mut rng = vplgi_types::Rng::new(4, vplgi_types::Stream::Oracle, 0);
        for (offset, size) in [(0.0f32, 2.0f32), (1.0e5, 1.0e-2), (-3.0e3, 1.0e3)] {
            let mut scene =
                Scene { materials: vec![vplgi_scene::Material::default()], ..Scene::default() };
            for i in 0..500u32 {
                let c = glam::Vec3::splat(offset)
                    + glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * size;
                for _ in 0..3 {
                    scene.positions.push(
                        c + (glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5)
                            * size
                            * 0.05,
                    );
                    scene.normals.push(glam::Vec3::Z);
                    scene.uvs.push(glam::Vec2::ZERO);
                }
                scene.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
                scene.material_ids.push(0);
            }
            let tris = triangles(&scene);
            let mut build_time = std::time::Duration::ZERO;
            let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, BUILD, &mut build_time);
            let threaded = thread(&bvh.nodes).unwrap();
            let (packed, frame) = quantize(&threaded).unwrap();
            // The crack bvh.wgsl's triangle test closes at this scene's coordinates.
            let far = (0..3)
                .map(|a| threaded[0].min[a].abs().max(threaded[0].max[a].abs()))
                .fold(0.0f32, f32::max);
            let crack = CRACK_ULPS * f32::EPSILON * far;
            for (exact, node) in threaded.iter().zip(&packed) {
                let (min, max) = frame.dequantize(node);
                for a in 0..3 {
                    assert!(
                        min[a] <= exact.min[a] - crack && max[a] >= exact.max[a] + crack,
                        "offset {offset}: axis {a}: {min:?}..{max:?} against {:?}..{:?}",
                        exact.min,
                        exact.max
                    );
                }
            }
        }
    }
}
