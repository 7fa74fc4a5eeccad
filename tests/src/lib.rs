//! Shared helpers for the cross-crate tests: the SPEC's tolerances and the measured
//! [`tolerance::Disagreement`] every differential test prints, shared inputs and proptest
//! strategies ([`inputs`]), image statistics, and the GPU context for differential tests.

pub mod inputs;
pub use vplgi_verify::tolerance;

use vplgi_gpu::GpuContext;

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
