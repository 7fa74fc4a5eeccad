//! The measurement behind the GPU's BVH layout: shadow-ray throughput of obvhs' BVH2 and CWBVH
//! traversals on the CPU, and of our WGSL BVH2 traversal on the GPU adapter, over the same rays.
//!
//! Scene: 20,000 random small triangles between two planes (z in (-0.9, 0.9)); rays: every pair
//! of 256 points on z = -1 (normals +z) and 1,024 points on z = +1 (normals -z), 262,144 segments,
//! so every pair faces and every ray crosses the clutter. Medians of 5 runs.
//!
//! Run: `cargo run --release -p vplgi-gpu --example bvh_choice`

use glam::{Vec3, Vec3A};
use std::time::Instant;
use vplgi_gpu::scene::GpuScene;
use vplgi_gpu::visibility::{Endpoint, VisibilityKernel};
use vplgi_scene::{Material, Scene};
use vplgi_types::{Rng, Stream};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut rng = Rng::new(1, Stream::Oracle, 0);
    let mut r = || rng.next_f32();
    let mut scene =
        Scene { name: "clutter".into(), materials: vec![Material::default()], ..Scene::default() };
    for i in 0..20_000u32 {
        let c = Vec3::new(r() * 2.0 - 1.0, r() * 2.0 - 1.0, r() * 1.8 - 0.9);
        for _ in 0..3 {
            scene.positions.push(c + (Vec3::new(r(), r(), r()) - 0.5) * 0.06);
            scene.normals.push(Vec3::Z);
            scene.uvs.push(glam::Vec2::ZERO);
        }
        scene.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
        scene.material_ids.push(0);
    }
    let rows: Vec<Endpoint> = (0..256)
        .map(|_| Endpoint::new(Vec3::new(r() * 2.0 - 1.0, r() * 2.0 - 1.0, -1.0), Vec3::Z))
        .collect();
    let cols: Vec<Endpoint> = (0..1024)
        .map(|_| Endpoint::new(Vec3::new(r() * 2.0 - 1.0, r() * 2.0 - 1.0, 1.0), -Vec3::Z))
        .collect();
    let rays: Vec<(Vec3A, Vec3A)> = rows
        .iter()
        .flat_map(|a| {
            cols.iter().map(move |b| {
                (Vec3A::from_slice(&a.position[..3]), Vec3A::from_slice(&b.position[..3]))
            })
        })
        .map(|(a, b)| (a, b - a))
        .collect();
    let n = rays.len() as f64;

    let tris = vplgi_gpu::bvh::triangles(&scene);
    let mut bt = std::time::Duration::ZERO;
    let bvh2 = obvhs::bvh2::builder::build_bvh2_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut bt,
    );
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut bt,
    );
    let (mut t2, mut tc) = (Vec::new(), Vec::new());
    let (mut v2, mut vc) = (0, 0);
    for _ in 0..5 {
        let t = Instant::now();
        v2 = rays
            .iter()
            .filter(|(o, d)| {
                bvh2.ray_traverse_miss(obvhs::ray::Ray::new(*o, *d, 1e-5, 1.0), |ray, id| {
                    tris[bvh2.primitive_indices[id] as usize].intersect(ray)
                })
            })
            .count();
        t2.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        vc = rays
            .iter()
            .filter(|(o, d)| {
                cw.ray_traverse_miss(obvhs::ray::Ray::new(*o, *d, 1e-5, 1.0), |ray, id| {
                    tris[cw.primitive_indices[id] as usize].intersect(ray)
                })
            })
            .count();
        tc.push(t.elapsed().as_secs_f64());
    }
    println!(
        "{} rays, {} triangles; visible: BVH2 {v2}, CWBVH {vc}",
        rays.len(),
        scene.triangle_count()
    );
    println!("CPU, one thread, obvhs BVH2:  {:.2} Mrays/s", n / median(t2) / 1e6);
    println!("CPU, one thread, obvhs CWBVH: {:.2} Mrays/s", n / median(tc) / 1e6);

    match vplgi_gpu::GpuContext::new() {
        Ok(ctx) => {
            let gs = GpuScene::new(&ctx.device, &scene)?;
            let k = VisibilityKernel::new(&ctx.device)?;
            k.run(&ctx.device, &ctx.queue, &gs, &rows, &cols, None)?; // warm-up: compilation
            let mut tg = Vec::new();
            let mut vg = 0;
            for _ in 0..5 {
                let t = Instant::now();
                let words = k.run(&ctx.device, &ctx.queue, &gs, &rows, &cols, None)?;
                tg.push(t.elapsed().as_secs_f64());
                vg = words.iter().map(|w| w.count_ones()).sum::<u32>();
            }
            println!(
                "GPU {}, WGSL BVH2: {:.2} Mrays/s (visible {vg})",
                ctx.describe(),
                n / median(tg) / 1e6
            );
        }
        Err(e) => println!("GPU: {e}"),
    }
    Ok(())
}
