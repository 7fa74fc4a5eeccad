//! `bias_points`, the bias compensation of the geometry-term clamp: an oracle on both backends
//! (compensated frames equal unclamped ones, which never run the compensation code, while
//! clamped frames lose a measured share of their light), and the GPU's compensation points
//! against the CPU's. Each test prints the measured disagreement.

use glam::Vec3;
use vplgi_cpu::CpuScene;
use vplgi_frame::{render, Backend};
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::GpuBackend;
use vplgi_scene::cornell::cornell_box;
use vplgi_tests::tolerance::{Disagreement, BIAS_POINTS_WEIGHT_ABS, SHADING_POINTS_SAME_SURFACE};
use vplgi_types::{BiasParams, ClusterMode, FrameConfig, ShadingPoint};
use vplgi_verify::shading_points::hit_differences;

/// A large clamp (d_min = half the diagonal) so that it removes a good share of the light.
const G_CLAMP: f32 = 0.5;

fn config(seed: u32) -> FrameConfig {
    FrameConfig { width: 32, height: 32, spp: 1, vpls: 3000, bounces: 2, cluster: ClusterMode::None, seed, g_clamp_rel: G_CLAMP, ..FrameConfig::reference() }
}

fn luminance(pixels: &[[f32; 3]]) -> f64 {
    let m = vplgi_tests::mean_rgb(pixels);
    0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2]
}

/// Per seed (the same VPLs in all three): the unclamped, clamped and compensated image means.
fn three_ways<B: Backend>(b: &B, seeds: std::ops::Range<u32>) -> Vec<(f64, f64, f64)>
where
    B::Error: std::fmt::Debug,
{
    let frame = |cfg: FrameConfig| luminance(&render(b, &cfg, &vplgi_frame::NoProgress).expect("frame").pixels);
    seeds
        .map(|seed| {
            let c = config(seed);
            let unclamped = frame(FrameConfig { g_clamp_rel: 0.0, bias_compensation: false, ..c.clone() });
            let clamped = frame(FrameConfig { bias_compensation: false, ..c.clone() });
            let compensated = frame(FrameConfig { bias_compensation: true, ..c });
            (unclamped, clamped, compensated)
        })
        .collect()
}

/// The compensated frame estimates the unclamped one: their paired difference over seeds is
/// within 4 standard errors of 0 and below a fifth of what the clamp removes (which must be
/// more than 3 % of the image, or the test would prove nothing).
fn check_compensation(backend: &str, runs: &[(f64, f64, f64)]) {
    let k = runs.len() as f64;
    let diffs: Vec<f64> = runs.iter().map(|r| r.2 - r.0).collect();
    let mean = diffs.iter().sum::<f64>() / k;
    let se = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
    let unclamped = runs.iter().map(|r| r.0).sum::<f64>() / k;
    let loss = runs.iter().map(|r| r.0 - r.1).sum::<f64>() / k;
    println!(
        "{backend}: unclamped mean {unclamped:.5}; the clamp removes {loss:.5} ({:.2} %); compensated - unclamped = {mean:+.5} +- {se:.5} \
         ({:+.2} % of the removed light)",
        100.0 * loss / unclamped,
        100.0 * mean / loss
    );
    assert!(loss > 0.03 * unclamped, "{backend}: the clamp removes only {loss} of {unclamped}: the test would prove nothing");
    assert!(mean.abs() <= 4.0 * se + 1e-6, "{backend}: compensated - unclamped = {mean} with standard error {se}");
    assert!(mean.abs() <= 0.2 * loss, "{backend}: compensated - unclamped = {mean}, against {loss} removed by the clamp");
}

#[test]
fn compensation_puts_back_what_the_clamp_removes_on_the_cpu() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    check_compensation("cpu", &three_ways(&cs, 1..7));
}

#[test]
fn compensation_puts_back_what_the_clamp_removes_on_the_gpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("compensation_puts_back_what_the_clamp_removes_on_the_gpu") else {
        return;
    };
    let scene = cornell_box();
    let gb = GpuBackend::new(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels, &scene).unwrap();
    check_compensation("gpu", &three_ways(&gb, 1..7));
}

/// The GPU's compensation points of the CPU's shading points: the same surfaces (ties on shared
/// edges counted as agreement; SPEC's shading-point bound) and the same weights (absolute: where
/// G is barely above g_max the share 1 - g_max / G is small and its relative rounding large).
#[test]
fn bias_points_match_the_cpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("bias_points_match_the_cpu") else {
        return;
    };
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let gb = GpuBackend::new(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels, &scene).unwrap();
    let (w, h, spp) = (64, 64, 2);
    let parents = vplgi_cpu::shading_points::shading_points(&cs, w, h, spp, 5);
    let n = parents.len() as u32;
    let mut checks = Vec::new();
    for level in 1..=2 {
        let params = BiasParams { seed: vplgi_types::params::level_seed(5, level), g_max: config(5).g_max(cs.extent) };
        let cpu = vplgi_cpu::bias_points::bias_points(&cs, &parents, 0, &params);
        let buf = storage(&gpu.ctx.device, "parents", &parents);
        let out = gb.bias_points(&buf, 0..n, &params).unwrap();
        let gpu_points: Vec<ShadingPoint> = read_back(&gpu.ctx.device, &gpu.ctx.queue, &out, n as usize).unwrap();
        let kept = cpu.iter().filter(|p| !p.is_miss()).count();
        assert!(kept > 200, "level {level}: only {kept} compensation points: the test would prove little");
        let d = hit_differences(&cpu, &gpu_points, cs.extent, scene.camera.position, (w, spp));
        let mut weight = 0.0f32;
        for (c, g) in cpu.iter().zip(&gpu_points) {
            assert_eq!(c.pixel, g.pixel);
            assert_eq!(g.emitted, [0.0; 3], "a compensation point emits nothing");
            if c.triangle == g.triangle && !c.is_miss() {
                let (a, b) = (Vec3::from(c.albedo), Vec3::from(g.albedo));
                weight = weight.max((a - b).abs().max_element());
            }
        }
        println!("level {level}: {kept} of {n} parents kept; {} agree, {} ties, {} differ; largest weight difference {weight:.2e}", d.same, d.ties, d.other);
        checks.push(Disagreement::at_least("bias_points", "share of identical surfaces", (d.same + d.ties) as f64 / n as f64, SHADING_POINTS_SAME_SURFACE));
        checks.push(Disagreement::at_most("bias_points", "largest weight difference", weight as f64, BIAS_POINTS_WEIGHT_ABS));
        // Each level's directions are its own.
        let level1 = BiasParams { seed: vplgi_types::params::level_seed(5, 1), ..params };
        if level == 2 {
            let again = vplgi_cpu::bias_points::bias_points(&cs, &parents, 0, &level1);
            assert_ne!(cpu, again, "levels 1 and 2 drew the same directions");
        }
    }
    for c in &checks {
        c.check();
    }
}
