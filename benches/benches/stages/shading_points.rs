//! Stage 2, `shading_points`: camera rays to the first hit, CPU (Embree) and GPU.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, sizes, Gpu};
use vplgi_gpu::shading_points::ShadingPointsKernel;

fn shading_points(c: &mut Criterion) {
    let mut group = c.benchmark_group("shading_points");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("shading_points");
    let kernel = gpu.as_ref().map(|g| ShadingPointsKernel::new(&g.ctx.device).expect("shading_points pipeline"));
    for size in sizes() {
        let cfg = &size.cfg;
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera)))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let n = cfg.width as u64 * cfg.height as u64 * cfg.spp as u64;
            // The points stay on the device, as in the chained pipeline.
            let run = || {
                k.dispatch_range(&g.ctx.device, &g.ctx.queue, &g.scene, &cfg.camera_params(g.scene.camera), 0..n as u32).expect("shading_points");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, shading_points);
