//! The GPU's acceleration structure: an obvhs BVH2 built on the CPU and uploaded once.
//!
//! BVH2 rather than obvhs' CWBVH for now: its WGSL traversal is a plain stack loop that is easy
//! to keep identical to the CPU's opinion, which is what the differential tests need first.
//! Measured (`cargo run --release -p vplgi-gpu --example bvh_choice`, 20k random triangles,
//! 262k shadow segments, 2026-11-25): obvhs on one CPU thread traces 0.47 Mrays/s with BVH2 and
//! 0.77 Mrays/s with CWBVH (1.6x); our WGSL BVH2 on lavapipe (both cores) traces 0.13 Mrays/s.
//! So the 8-wide layout is worth porting, but lavapipe's execution of a divergent loop, not the
//! node layout, dominates there; the CWBVH port belongs to the performance work.

use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use glam::Vec3A;
use obvhs::bvh2::node::Bvh2Node;
use vplgi_scene::Scene;

/// Depth of the traversal stack in `shaders/common/bvh.wgsl` (`BVH_STACK`).
pub const STACK_DEPTH: usize = 64;

/// A triangle as the WGSL traversal reads it (`BvhTri`): v0 with the scene triangle index in w,
/// then the two edges.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BvhTri {
    pub v0: [f32; 4],
    pub e1: [f32; 4],
    pub e2: [f32; 4],
}

/// The flat arrays uploaded to the device.
pub struct BvhArrays {
    pub nodes: Vec<Bvh2Node>,
    pub tris: Vec<BvhTri>,
    pub depth: usize,
}

/// Builds the BVH2 of `scene` and lays its triangles out in leaf order.
pub fn build(scene: &Scene) -> Result<BvhArrays, GpuError> {
    if scene.triangle_count() == 0 {
        // One leaf with an empty (inverted) box: every ray misses it at the root.
        let empty = obvhs::aabb::Aabb { min: Vec3A::splat(f32::INFINITY), max: Vec3A::splat(f32::NEG_INFINITY) };
        return Ok(BvhArrays { nodes: vec![Bvh2Node::new(empty, 1, 0)], tris: vec![BvhTri::zeroed()], depth: 1 });
    }
    let tris = triangles(scene);
    let mut build_time = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut build_time);
    let depth = depth(&bvh.nodes);
    if depth > STACK_DEPTH {
        return Err(GpuError::TooLarge { what: "the BVH's depth (the WGSL traversal stack)".into(), needed: depth as u64, limit: STACK_DEPTH as u64 });
    }
    let laid_out = bvh
        .primitive_indices
        .iter()
        .map(|&p| {
            let [a, b, c] = scene.triangle(p as usize);
            let (e1, e2) = (b - a, c - a);
            BvhTri { v0: [a.x, a.y, a.z, f32::from_bits(p)], e1: [e1.x, e1.y, e1.z, 0.0], e2: [e2.x, e2.y, e2.z, 0.0] }
        })
        .collect();
    Ok(BvhArrays { nodes: bvh.nodes, tris: laid_out, depth })
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

/// Largest number of nodes the traversal can have pending: the tree depth.
fn depth(nodes: &[Bvh2Node]) -> usize {
    let mut max = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        max = max.max(d);
        let n = &nodes[i];
        if n.prim_count == 0 {
            stack.push((n.first_index as usize, d + 1));
            stack.push((n.first_index as usize + 1, d + 1));
        }
    }
    max
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_and_triangle_layouts_match_the_wgsl_structs() {
        assert_eq!(std::mem::size_of::<Bvh2Node>(), 48, "BvhNode in bvh.wgsl is 48 bytes");
        assert_eq!(std::mem::size_of::<BvhTri>(), 48);
        let scene = vplgi_scene::cornell::cornell_box();
        let arrays = build(&scene).unwrap();
        // Every scene triangle appears in the leaves.
        let mut seen: Vec<u32> = arrays.tris.iter().map(|t| t.v0[3].to_bits()).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen, (0..scene.triangle_count() as u32).collect::<Vec<_>>());
        assert!(arrays.depth <= STACK_DEPTH);
    }
}
