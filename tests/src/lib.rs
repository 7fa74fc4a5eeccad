//! Shared helpers for the cross-crate tests: the CPU pipeline at test sizes, and the GPU
//! context for differential tests.

use vplgi_cpu::{CpuScene, Frame, NoProgress};
use vplgi_gpu::GpuContext;
use vplgi_scene::Scene;
use vplgi_types::FrameConfig;

/// A small configuration for tests: the built-in defaults at `size` x `size`.
pub fn small_config(size: u32, vpls: u32) -> FrameConfig {
    FrameConfig { width: size, height: size, vpls, k_sp: 400, k_vpl: 200, ..FrameConfig::default() }
}

/// Renders `scene` with the CPU reference.
pub fn render(scene: &Scene, cfg: &FrameConfig) -> Frame {
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = CpuScene::new(scene, &device).expect("Embree scene");
    vplgi_cpu::render(&cs, cfg, &NoProgress).expect("valid test configuration")
}

/// Mean of each channel over all pixels.
pub fn mean_rgb(pixels: &[[f32; 3]]) -> [f64; 3] {
    let mut m = [0.0f64; 3];
    for p in pixels {
        for c in 0..3 {
            m[c] += p[c] as f64;
        }
    }
    m.map(|v| v / pixels.len().max(1) as f64)
}

/// The GPU for a differential test, announced with the adapter's name. Without an adapter the
/// test fails under CI (`CI=true`) and is skipped loudly elsewhere.
pub fn gpu(test: &str) -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(ctx) => {
            println!("[{}] {test}", ctx.describe());
            Some(ctx)
        }
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("{test}: no GPU adapter under CI: {e}");
            }
            eprintln!("\n*** SKIPPED {test}: {e} ***\n");
            None
        }
    }
}
