//! Instance, adapter and device, built once.

use std::sync::{Arc, Mutex};

/// Errors of the GPU backend. None of them panics.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on Debian install a Vulkan driver, e.g. `apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe, a CPU Vulkan)")]
    NoAdapter(String),
    #[error("the adapter {adapter} refused a device: {message}")]
    Device { adapter: String, message: String },
    #[error("wgpu validation error in {what}: {message}")]
    Validation { what: String, message: String },
    #[error("GPU device lost or timed out in {what}: {message}")]
    Lost { what: String, message: String },
    #[error(
        "the GPU ran out of memory in {what} (use a smaller frame, or --backend cpu): {message}"
    )]
    OutOfMemory { what: String, message: String },
    /// `what` names the quantity and its unit.
    #[error("{what}: {needed} needed, this adapter allows {limit} (use --backend cpu, or a smaller input)")]
    TooLarge { what: String, needed: u64, limit: u64 },
}

/// Refuses `needed` of `what` past `limit`, the bound that keeps one invocation's loops inside
/// lavapipe's loop limiter; `why` says which loop grows with it.
pub fn within_loop_limit(what: &str, needed: u32, limit: u32, why: &str) -> Result<(), GpuError> {
    if needed > limit {
        return Err(GpuError::TooLarge {
            what: format!(
                "{what} ({why}, and lavapipe ends an invocation's loops after 65,535 iterations)"
            ),
            needed: needed as u64,
            limit: limit as u64,
        });
    }
    Ok(())
}

/// A device ready for the vplgi kernels.
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// What the adapter offers beyond the WebGPU baseline. The kernels need none of it; timestamp
    /// queries and 64-bit atomics are what the performance work can use where present.
    pub features: wgpu::Features,
    /// Errors wgpu reported outside an error scope (kept instead of panicking).
    uncaptured: Arc<Mutex<Vec<String>>>,
}

impl GpuContext {
    /// Picks an adapter (Vulkan first; `WGPU_BACKEND` overrides) and opens a device with the
    /// adapter's own limits.
    pub fn new() -> Result<GpuContext, GpuError> {
        pollster::block_on(Self::new_async(None, None))
    }

    /// A device whose storage-binding size and workgroups per dimension are forced below the
    /// adapter's, so tests exercise the chunking paths on small inputs: every stage reads its
    /// limits from the device.
    pub fn with_limits(
        max_binding_bytes: Option<u64>,
        max_workgroups: Option<u32>,
    ) -> Result<GpuContext, GpuError> {
        pollster::block_on(Self::new_async(max_binding_bytes, max_workgroups))
    }

    async fn new_async(
        max_binding_bytes: Option<u64>,
        max_workgroups: Option<u32>,
    ) -> Result<GpuContext, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            })
            .await
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let mut limits = adapter.limits();
        if let Some(b) = max_binding_bytes {
            limits.max_storage_buffer_binding_size = limits.max_storage_buffer_binding_size.min(b);
        }
        if let Some(g) = max_workgroups {
            limits.max_compute_workgroups_per_dimension =
                limits.max_compute_workgroups_per_dimension.min(g);
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("vplgi"),
                // Timestamp queries time the benches' GPU passes (`timing`); nothing else needs
                // more than the WebGPU baseline.
                required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
                required_limits: limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GpuError::Device { adapter: describe(&info), message: e.to_string() })?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let features = adapter.features();
        Ok(GpuContext { adapter, device, queue, info, features, uncaptured })
    }

    /// "Vulkan/llvmpipe (LLVM 15.0.6, 256 bits)": backend and adapter name.
    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    /// The optional features that matter to vplgi, by name, for reports.
    pub fn notable_features(&self) -> Vec<&'static str> {
        [
            (wgpu::Features::TIMESTAMP_QUERY, "timestamp-query"),
            (wgpu::Features::SHADER_INT64, "shader-int64"),
            (wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS, "shader-int64-atomics"),
            (wgpu::Features::SUBGROUP, "subgroups"),
            (wgpu::Features::EXPERIMENTAL_RAY_QUERY, "ray-query"),
        ]
        .into_iter()
        .filter(|(f, _)| self.features.contains(*f))
        .map(|(_, name)| name)
        .collect()
    }

    /// Errors wgpu reported outside any error scope since the last call.
    pub fn take_uncaptured_errors(&self) -> Vec<String> {
        self.uncaptured.lock().map(|mut v| std::mem::take(&mut *v)).unwrap_or_default()
    }
}

pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{:?}/{}", info.backend, info.name)
}

/// Runs `f` inside validation and out-of-memory error scopes and turns a captured error into
/// [`GpuError`]. Running out of memory is reported first: the invalid buffer it leaves behind
/// also fails validation, and "out of memory" is the cause a user can act on.
pub fn validated<T>(
    device: &wgpu::Device,
    what: &str,
    f: impl FnOnce() -> T,
) -> Result<T, GpuError> {
    let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let value = crate::timing::in_kernel(what, f);
    let invalid = pollster::block_on(validation.pop());
    let exhausted = pollster::block_on(memory.pop());
    match (exhausted, invalid) {
        (Some(e), _) => {
            Err(GpuError::OutOfMemory { what: what.to_string(), message: e.to_string() })
        }
        (None, Some(e)) => {
            Err(GpuError::Validation { what: what.to_string(), message: e.to_string() })
        }
        (None, None) => Ok(value),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The GPU for a test of this crate, announced with the adapter's name (vplgi_tests::gpu's
    /// rule, which this crate cannot depend on): without an adapter the test fails under CI
    /// (`CI=true`) and is skipped loudly elsewhere.
    pub(crate) fn test_gpu(test: &str) -> Option<GpuContext> {
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

    /// Without a usable adapter the error says so and tells how to get one. Forced here by asking
    /// for a backend that does not exist on Linux, in a child process so the environment variable
    /// stays local to it.
    #[test]
    fn missing_adapter_is_a_clear_error_with_a_hint() {
        if std::env::var("VPLGI_CHILD_NO_ADAPTER").is_ok() {
            match GpuContext::new() {
                Ok(ctx) => panic!("expected no adapter, got {}", ctx.describe()),
                Err(e) => {
                    let msg = e.to_string();
                    assert!(
                        msg.contains("no GPU adapter") && msg.contains("mesa-vulkan-drivers"),
                        "{msg}"
                    );
                    return;
                }
            }
        }
        let exe = std::env::current_exe().expect("test binary");
        let status = std::process::Command::new(exe)
            .args([
                "--exact",
                "context::tests::missing_adapter_is_a_clear_error_with_a_hint",
                "--nocapture",
            ])
            .env("VPLGI_CHILD_NO_ADAPTER", "1")
            .env("WGPU_BACKEND", "dx12")
            .status()
            .expect("run the child test");
        assert!(status.success(), "the child process did not see the expected error");
    }

    /// Running out of device memory inside `validated` is `GpuError::OutOfMemory`, naming the
    /// step: no panic, no abort. Forced in a child process (the address-space cap stays local to
    /// it): once the device is open, the cap is set just above what the process has mapped, so
    /// lavapipe cannot back a 1 GiB buffer. A cap set before the device opens only makes the
    /// device or the driver fail (measured), which `GpuError::Device` already covers.
    #[test]
    fn out_of_memory_is_a_clear_error() {
        if std::env::var("VPLGI_CHILD_OUT_OF_MEMORY").is_ok() {
            let ctx = GpuContext::new().expect("a GPU adapter (the parent found one)");
            let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
            let mapped_kib: u64 = status
                .lines()
                .find_map(|l| l.strip_prefix("VmSize:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
                .expect("VmSize");
            let cap = (mapped_kib + 256 * 1024) * 1024;
            // SAFETY: setrlimit reads the struct it is given and nothing else.
            let set = unsafe {
                libc::setrlimit(libc::RLIMIT_AS, &libc::rlimit { rlim_cur: cap, rlim_max: cap })
            };
            assert_eq!(set, 0, "setrlimit failed");
            let r = validated(&ctx.device, "a 1 GiB buffer", || {
                crate::buffers::storage_zeroed::<u32>(&ctx.device, "huge", 1 << 28)
            });
            match r {
                Err(e @ GpuError::OutOfMemory { .. }) => println!("captured: {e}"),
                Err(e) => panic!("expected out of memory, got {e}"),
                Ok(_) => panic!("a 1 GiB buffer fit under a cap of {} MiB more than mapped", 256),
            }
            return;
        }
        if GpuContext::new().is_err() {
            eprintln!("\n*** SKIPPED out_of_memory_is_a_clear_error: no GPU adapter ***\n");
            assert!(!std::env::var("CI").is_ok_and(|v| v == "true"), "no GPU adapter under CI");
            return;
        }
        let exe = std::env::current_exe().expect("test binary");
        let out = std::process::Command::new(exe)
            .args(["--exact", "context::tests::out_of_memory_is_a_clear_error", "--nocapture"])
            .env("VPLGI_CHILD_OUT_OF_MEMORY", "1")
            .output()
            .expect("run the child test");
        let stdout = String::from_utf8_lossy(&out.stdout);
        println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "the child process did not see the expected error");
        assert!(
            stdout.contains("ran out of memory in a 1 GiB buffer"),
            "the message names neither the cause nor the step"
        );
    }

    /// A wgpu validation error inside `validated` comes back as `GpuError::Validation`, not a
    /// panic (here: binding a 4-byte buffer where the shader needs 48-byte records).
    #[test]
    fn validation_errors_become_errors() {
        let Some(ctx) = test_gpu("validation_errors_become_errors") else { return };
        let kernel = crate::visibility::VisibilityKernel::new(&ctx.device).unwrap();
        let scene = vplgi_scene::cornell::cornell_box();
        let gs = crate::scene::GpuScene::new(&ctx.device, &scene).unwrap();
        let tiny = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("too small"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let r = kernel.run_on_device(&ctx.device, &ctx.queue, &gs, (&tiny, 1), (&tiny, 1), 0..1);
        match r {
            Err(GpuError::Validation { message, .. }) => {
                println!("captured: {}", message.lines().next().unwrap_or(""))
            }
            Err(e) => panic!("unexpected error {e}"),
            Ok(_) => panic!("an invalid binding was accepted"),
        }
        assert!(
            ctx.take_uncaptured_errors().is_empty(),
            "the error must be captured by the scope, not left uncaptured"
        );
    }
}
