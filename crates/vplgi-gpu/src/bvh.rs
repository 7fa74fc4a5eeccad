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
use bytemuck::Zeroable;
use glam::Vec3A;
use obvhs::bvh2::node::Bvh2Node;
use vplgi_scene::Scene;
pub use vplgi_types::device::{BvhNode, BvhTri, END, LEAF_COUNT_BITS};

/// obvhs' medium preset without its coarse search near the root (`search_depth_threshold` 3
/// there): on scenes whose walls are fine grids (the generated ones) the preset builds trees
/// whose shadow segments visit about a hundred times more nodes, for the same occluders and the
/// same build time. `examples/bvh_visits.rs` measures both builds on a scene; the numbers are in
/// commit b2f6076.
pub const BUILD: obvhs::BvhBuildParams = obvhs::BvhBuildParams { search_depth_threshold: 0, ..obvhs::BvhBuildParams::medium_build() };

/// The flat arrays uploaded to the device.
pub struct BvhArrays {
    pub nodes: Vec<BvhNode>,
    pub tris: Vec<BvhTri>,
}

/// Builds the BVH2 of `scene`, threads it and lays its triangles out in leaf order.
pub fn build(scene: &Scene) -> Result<BvhArrays, GpuError> {
    if scene.triangle_count() == 0 {
        // One leaf with an inverted box and a degenerate triangle: every ray misses.
        let empty = BvhNode { min: [f32::INFINITY; 3], skip: END, max: [f32::NEG_INFINITY; 3], leaf: 1 };
        return Ok(BvhArrays { nodes: vec![empty], tris: vec![BvhTri::zeroed()] });
    }
    let tris = triangles(scene);
    let mut build_time = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, BUILD, &mut build_time);
    let nodes = thread(&bvh.nodes)?;
    let laid_out = bvh
        .primitive_indices
        .iter()
        .map(|&p| {
            let [a, b, c] = scene.triangle(p as usize);
            BvhTri { v0: [a.x, a.y, a.z, f32::from_bits(p)], v1: [b.x, b.y, b.z, 0.0], v2: [c.x, c.y, c.z, 0.0] }
        })
        .collect();
    Ok(BvhArrays { nodes, tris: laid_out })
}

/// Lays `nodes` (root at 0, an inner node's children at `first_index` and `first_index + 1`) out
/// in preorder with skip links.
fn thread(nodes: &[Bvh2Node]) -> Result<Vec<BvhNode>, GpuError> {
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
    order
        .iter()
        .enumerate()
        .map(|(p, &i)| {
            let n = &nodes[i];
            let leaf = if n.prim_count == 0 {
                0
            } else if n.prim_count > max_count || n.first_index >= 1 << (32 - LEAF_COUNT_BITS) {
                return Err(GpuError::TooLarge {
                    what: "a BVH leaf (triangles per leaf, or the first triangle slot)".into(),
                    needed: n.first_index.max(n.prim_count) as u64,
                    limit: max_count.max(1 << (32 - LEAF_COUNT_BITS)) as u64,
                });
            } else {
                n.first_index << LEAF_COUNT_BITS | n.prim_count
            };
            let next = p + size[p];
            let skip = if next == order.len() { END } else { next as u32 };
            Ok(BvhNode { min: n.aabb.min.into(), skip, max: n.aabb.max.into(), leaf })
        })
        .collect()
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

    /// The traversal of bvh.wgsl, on the CPU: closest hit distance and the nodes visited.
    fn traverse(arrays: &BvhArrays, tris: &[obvhs::triangle::Triangle], ray: &Ray) -> (f32, usize) {
        let (mut t, mut visited, mut i) = (ray.tmax, 0, 0u32);
        while i != END {
            let n = &arrays.nodes[i as usize];
            visited += 1;
            let aabb = obvhs::aabb::Aabb { min: Vec3A::from(n.min), max: Vec3A::from(n.max) };
            let mut next = n.skip;
            if aabb.intersect_ray(&Ray { tmax: t, ..*ray }) < f32::INFINITY {
                if n.leaf == 0 {
                    next = i + 1;
                } else {
                    let first = n.leaf >> LEAF_COUNT_BITS;
                    for slot in first..first + (n.leaf & ((1 << LEAF_COUNT_BITS) - 1)) {
                        let tri = arrays.tris[slot as usize].v0[3].to_bits() as usize;
                        t = t.min(tris[tri].intersect(&Ray { tmax: t, ..*ray }));
                    }
                }
            }
            i = next;
        }
        (t, visited)
    }

    #[test]
    fn node_and_triangle_layouts_match_the_wgsl_structs() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 32, "BvhNode in bvh.wgsl is 32 bytes");
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
        let mut scene = Scene { materials: vec![vplgi_scene::Material::default()], ..Scene::default() };
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
        assert_eq!(arrays.nodes[0].skip, END, "the root's subtree is everything");
        let mut order = Vec::new();
        let mut i = 0u32;
        while i != END {
            order.push(i);
            let node = &arrays.nodes[i as usize];
            i = if node.leaf == 0 { i + 1 } else { node.skip };
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
        assert!(visited < 2000 * n / 10, "{} nodes visited per ray of {n}: the boxes prune nothing", visited / 2000);
    }
}
