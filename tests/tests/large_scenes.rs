//! Public scenes too large to ship, rendered when present: ignored by default, run with
//! `cargo test --release -p vplgi-tests --test large_scenes -- --ignored`.

/// Crytek Sponza (glTF, 262,267 triangles, 69 textures) at the path in `VPLGI_SPONZA` (the
/// .gltf file): loads, and renders lit on the CPU (and on the GPU when an adapter exists).
#[test]
#[ignore]
fn sponza_renders_when_present() {
    let Some(path) = std::env::var_os("VPLGI_SPONZA") else {
        println!("SKIPPED: set VPLGI_SPONZA to Sponza's .gltf to render it");
        return;
    };
    let scene = vplgi_scene::Scene::load(std::path::Path::new(&path)).unwrap();
    println!(
        "{}: {} triangles, {} textures",
        scene.name,
        scene.triangle_count(),
        scene.textures.len()
    );
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).unwrap();
    let cfg = vplgi_types::FrameConfig {
        width: 96,
        height: 64,
        vpls: 2000,
        k_sp: 600,
        k_vpl: 200,
        ..Default::default()
    };
    let f = vplgi_cpu::render(&cs, &cfg, &vplgi_cpu::NoProgress).unwrap();
    assert!(f.pixels.iter().any(|p| p[0] > 0.0), "Sponza renders black");
    if let Ok(ctx) = vplgi_gpu::GpuContext::new() {
        let k = vplgi_gpu::GpuKernels::new(&ctx.device).unwrap();
        let g = vplgi_gpu::render(&ctx.device, &ctx.queue, &k, &scene, &cfg).unwrap();
        let img = |p: Vec<[f32; 3]>| vplgi_image::Image { width: 96, height: 64, pixels: p };
        let cmp = vplgi_image::compare(&img(f.pixels.clone()), &img(g.pixels)).unwrap();
        println!("GPU against CPU on {}: FLIP {:.4}", ctx.describe(), cmp.metrics.flip);
    }
}
