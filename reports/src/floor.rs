//! The floor of the GPU/CPU ratio on this machine (`make perf-report`): the simplest kernel that
//! maps perfectly to SIMT hardware, timed against its rayon twin. Brute-force nearest centroid:
//! every point tests the same 64 centroids in the same order, no divergence, no gathers, no
//! private arrays, one store per point. Whatever a stage's kernel costs beyond this ratio is the
//! kernel's; below it lies only what the adapter (on lavapipe, the CPU itself running 8-wide
//! SIMD through llvmpipe) cannot do better than the compiled Rust loop.

use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use vplgi_gpu::buffers::{read_back, storage, storage_zeroed, sync};

/// Centroids every point tests.
pub const CENTROIDS: usize = 64;

const SHADER: &str = r#"
@group(0) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> centroids: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> labels: array<u32>;

@compute @workgroup_size(64)
fn nearest(@builtin(global_invocation_id) g: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = g.x + g.y * groups.x * 64u;
    if (i >= arrayLength(&labels)) {
        return;
    }
    let p = points[i].xyz;
    var best = 0u;
    var best_d = 3.4028235e38;
    for (var k = 0u; k < arrayLength(&centroids); k = k + 1u) {
        let d = centroids[k].xyz - p;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if (d2 < best_d) {
            best_d = d2;
            best = k;
        }
    }
    labels[i] = best;
}
"#;

/// One side of the floor measurement.
pub struct FloorRun {
    pub seconds: f64,
    pub labels: Vec<u32>,
}

fn nearest(p: Vec3, centroids: &[Vec3]) -> u32 {
    let mut best = (0, f32::MAX);
    for (k, c) in centroids.iter().enumerate() {
        let d = *c - p;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if d2 < best.1 {
            best = (k as u32, d2);
        }
    }
    best.0
}

/// The rayon twin: median of `runs`.
pub fn cpu(points: &[Vec3], centroids: &[Vec3], runs: usize) -> FloorRun {
    let mut times = Vec::new();
    let mut labels = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        labels = points.par_iter().map(|&p| nearest(p, centroids)).collect();
        times.push(t.elapsed().as_secs_f64());
    }
    FloorRun { seconds: crate::median(times), labels }
}

/// The kernel on `ctx`'s adapter, wall time from submission to completion: median of `runs`
/// after one run that compiles.
pub fn gpu(
    ctx: &vplgi_gpu::GpuContext,
    points: &[Vec3],
    centroids: &[Vec3],
    runs: usize,
) -> Result<FloorRun, vplgi_gpu::GpuError> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let p4: Vec<[f32; 4]> = points.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect();
    let c4: Vec<[f32; 4]> = centroids.iter().map(|c| [c.x, c.y, c.z, 0.0]).collect();
    let (pb, cb) = (storage(device, "points", &p4), storage(device, "centroids", &c4));
    let lb = storage_zeroed::<u32>(device, "labels", points.len());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("floor"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("floor"),
        layout: None,
        module: &module,
        entry_point: Some("nearest"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bindings = [
        (0, pb.as_entire_buffer_binding()),
        (1, cb.as_entire_buffer_binding()),
        (2, lb.as_entire_buffer_binding()),
    ];
    let groups = (points.len() as u32).div_ceil(64);
    let mut times = Vec::new();
    for _ in 0..=runs {
        let t = Instant::now();
        vplgi_gpu::buffers::dispatch_windows(device, queue, &pipeline, &bindings, groups);
        sync(device)?;
        times.push(t.elapsed().as_secs_f64());
    }
    times.remove(0);
    Ok(FloorRun {
        seconds: crate::median(times),
        labels: read_back(device, queue, &lb, points.len())?,
    })
}
