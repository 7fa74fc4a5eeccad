//! Shared helpers for the cross-crate tests: the SPEC's tolerances and the measured
//! [`tolerance::Disagreement`] every differential test prints (from `vplgi-verify`, which holds
//! each stage's comparison), shared inputs and proptest strategies ([`inputs`]), image
//! statistics, and the GPU for differential tests.

pub mod inputs;

pub use vplgi_verify::tolerance;

use proptest::test_runner::{Config, FileFailurePersistence};
use std::sync::OnceLock;
use vplgi_gpu::{GpuBackend, GpuContext, GpuKernels};
use vplgi_verify::Twins;

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
        Err(e) => no_gpu(test, &e.to_string()),
    }
}

fn no_gpu<T>(test: &str, e: &str) -> Option<T> {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{test}: no GPU adapter under CI: {e}");
    }
    eprintln!("\n*** SKIPPED {test}: {e} ***\n");
    None
}

/// A device with every kernel compiled, shared by all cases of a property test (compiling the
/// pipelines takes seconds; uploading a small scene, milliseconds).
pub struct SharedGpu {
    pub ctx: GpuContext,
    pub kernels: GpuKernels,
}

/// The process's [`SharedGpu`], made on first use (see [`gpu`] for what happens without one).
pub fn shared_gpu(test: &str) -> Option<&'static SharedGpu> {
    static GPU: OnceLock<Result<SharedGpu, String>> = OnceLock::new();
    let made = GPU.get_or_init(|| {
        let ctx = GpuContext::new().map_err(|e| e.to_string())?;
        let kernels = GpuKernels::new(&ctx.device).map_err(|e| e.to_string())?;
        Ok(SharedGpu { ctx, kernels })
    });
    match made {
        Ok(g) => {
            println!("[{}] {test}", g.ctx.describe());
            Some(g)
        }
        Err(e) => no_gpu(test, e),
    }
}

/// Runs `f` with `scene` ready on both backends.
pub fn with_twins<T>(
    gpu: &SharedGpu,
    scene: &vplgi_scene::Scene,
    f: impl FnOnce(&Twins) -> T,
) -> T {
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = vplgi_cpu::CpuScene::new(scene, &device).expect("Embree scene");
    let gb = GpuBackend::new(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels, scene)
        .expect("scene on the GPU");
    f(&Twins { scene, cpu: &cs, gpu: &gb })
}

/// Cases per property test: `VPLGI_PROPTEST_CASES`, or `default` (small, for `make test`;
/// `make verify-long` sets 10,000).
pub fn cases(default: u32) -> u32 {
    std::env::var("VPLGI_PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// The configuration of every property test: [`cases`] cases, and shrunk failures kept in
/// `tests/tests/<file>.proptest-regressions` (committed: each is replayed first on every run).
pub fn proptest_config(default_cases: u32) -> Config {
    Config {
        cases: cases(default_cases),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..Config::default()
    }
}

/// Prints the checks, each after `label`, and panics at the first that does not hold (with its
/// measurement): [`hold`] for tests that are not property tests.
pub fn check_all(label: &str, checks: &[tolerance::Disagreement]) {
    for c in checks {
        print!("{label}");
        c.check();
    }
}

/// Fails the property-test case (with the measurement) unless every judged check holds; prints
/// them all.
pub fn hold(
    checks: &[tolerance::Disagreement],
) -> Result<(), proptest::test_runner::TestCaseError> {
    for c in checks {
        println!("{c}");
    }
    match checks.iter().find(|c| !c.holds()) {
        Some(c) => Err(proptest::test_runner::TestCaseError::fail(c.to_string())),
        None => Ok(()),
    }
}
