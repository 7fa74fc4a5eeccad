//! The GPU device lost in the middle of a frame: the frame ends with an error that says so, it
//! does not panic, hang or return a picture. `Device::destroy` is wgpu's own way to lose a
//! device; the frame driver's progress callback pulls the trigger when a chosen stage starts, so
//! the loss lands between the stages' dispatches, where a driver reset would.
//!
//! Outputs: the CLI writes its files only from a finished frame and through atomic renames
//! (`crates/vplgi-cli/tests/faults.rs` kills it mid-write), so an error here leaves nothing behind.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use vplgi_frame::Progress;
use vplgi_gpu::{GpuBackend, GpuKernels};
use vplgi_scene::cornell::cornell_box;
use vplgi_types::{ClusterMode, FrameConfig};

/// Destroys `device` when the frame driver starts `stage`.
struct LoseDeviceAt {
    device: wgpu::Device,
    stage: &'static str,
    pulled: AtomicBool,
}

impl Progress for LoseDeviceAt {
    fn start(&self, stage: &str, _total: u64) {
        if stage == self.stage && !self.pulled.swap(true, Ordering::SeqCst) {
            self.device.destroy();
        }
    }
}

#[test]
fn a_device_lost_mid_frame_is_a_clear_error() {
    let scene = cornell_box();
    let cfg = FrameConfig {
        width: 48,
        height: 40,
        vpls: 600,
        k_sp: 120,
        k_vpl: 60,
        cluster: ClusterMode::Both,
        ..FrameConfig::default()
    };
    // The driver announces these stages; the device is lost as each one starts, in turn.
    for stage in ["shading_points", "cluster", "shade"] {
        let Some(ctx) = vplgi_tests::gpu("a_device_lost_mid_frame_is_a_clear_error") else {
            return;
        };
        let kernels = GpuKernels::new(&ctx.device).unwrap();
        let backend = GpuBackend::new(&ctx.device, &ctx.queue, &kernels, &scene).unwrap();
        let trigger =
            LoseDeviceAt { device: ctx.device.clone(), stage, pulled: AtomicBool::new(false) };
        let start = Instant::now();
        let result = vplgi_frame::render(&backend, &cfg, &trigger);
        let took = start.elapsed();
        assert!(trigger.pulled.load(Ordering::SeqCst), "the frame never started {stage}");
        let message = match result {
            Ok(_) => panic!("device lost at {stage}: the frame came back as if nothing happened"),
            Err(e) => e.to_string(),
        };
        println!("device lost at the start of {stage}: error after {took:.2?}: {message}");
        assert!(
            message.contains("device lost"),
            "device lost at {stage}: the error does not say so: {message}"
        );
        assert!(took < Duration::from_secs(60), "device lost at {stage}: the error took {took:?}");
    }
}
