//! The measurement behind `vplgi_gpu::bvh::BUILD`: how many BVH nodes a shadow segment visits
//! with obvhs' medium preset and with ours, on the scenes given as arguments.
//!
//! Segments join two surface points drawn by area (pushed 1e-3 off their surfaces); traversal is
//! any-hit, depth first, nearer-child order ignored, as in `shaders/common/bvh.wgsl`. Both trees
//! must find the same occluded segments.
//!
//! Run: `cargo run --release -p vplgi-gpu --example bvh_visits -- SCENE.glb...`
//! (`vplgi scene generate conference --out conference.glb` makes one.)

use glam::Vec3A;
use vplgi_types::{Rng, Stream};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        return Err("usage: bvh_visits SCENE.glb...".into());
    }
    for path in paths {
        let scene = vplgi_scene::gltf_load::load(std::path::Path::new(&path))?;
        let tris = vplgi_gpu::bvh::triangles(&scene);
        let area: Vec<f32> =
            tris.iter().map(|t| (t.v1 - t.v0).cross(t.v2 - t.v0).length()).collect();
        let total: f32 = area.iter().sum();
        let cdf: Vec<f32> = area
            .iter()
            .scan(0.0, |acc, a| {
                *acc += a / total;
                Some(*acc)
            })
            .collect();
        let point = |rng: &mut Rng| {
            let t = cdf.partition_point(|&c| c < rng.next_f32()).min(tris.len() - 1);
            let (mut s, mut u) = (rng.next_f32(), rng.next_f32());
            if s + u > 1.0 {
                (s, u) = (1.0 - s, 1.0 - u);
            }
            let tri = &tris[t];
            tri.v0
                + (tri.v1 - tri.v0) * s
                + (tri.v2 - tri.v0) * u
                + Vec3A::from(scene.geometric_normal(t)) * 1e-3
        };
        println!("{path}: {} triangles", tris.len());
        for (name, params) in [
            ("obvhs medium", obvhs::BvhBuildParams::medium_build()),
            ("vplgi (bvh::BUILD)", vplgi_gpu::bvh::BUILD),
        ] {
            let mut build_time = std::time::Duration::ZERO;
            let start = std::time::Instant::now();
            let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut build_time);
            let built = start.elapsed();
            let mut rng = Rng::new(1, Stream::Oracle, 0);
            let (n, mut visits, mut tests, mut blocked) = (20_000, 0usize, 0usize, 0usize);
            for _ in 0..n {
                let (p, q) = (point(&mut rng), point(&mut rng));
                let ray = obvhs::ray::Ray::new(p, q - p, 1e-5, 1.0);
                let mut stack = vec![0usize];
                'ray: while let Some(i) = stack.pop() {
                    let node = &bvh.nodes[i];
                    visits += 1;
                    let (t1, t2) = (
                        (node.aabb.min - ray.origin) * ray.inv_direction,
                        (node.aabb.max - ray.origin) * ray.inv_direction,
                    );
                    if t1.min(t2).max_element().max(ray.tmin)
                        > t1.max(t2).min_element().min(ray.tmax)
                    {
                        continue;
                    }
                    if node.prim_count == 0 {
                        stack.extend([node.first_index as usize + 1, node.first_index as usize]);
                        continue;
                    }
                    for slot in node.first_index..node.first_index + node.prim_count {
                        tests += 1;
                        if tris[bvh.primitive_indices[slot as usize] as usize].intersect(&ray)
                            < ray.tmax
                        {
                            blocked += 1;
                            break 'ray;
                        }
                    }
                }
            }
            let per = |x: usize| x as f64 / n as f64;
            println!(
                "  {name:20} build {:6.0} ms, {:8} nodes; per segment {:7.1} nodes, {:5.1} triangle tests; {blocked} of {n} blocked",
                built.as_secs_f64() * 1e3,
                bvh.nodes.len(),
                per(visits),
                per(tests)
            );
        }
    }
    Ok(())
}
