//! The whole frame (`--cluster both`): the five stages chained, CPU reference and GPU pipeline.
//! The GPU frame includes uploading the scene and building its BVH, as `vplgi render` does.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, scene, sizes, Gpu};
use vplgi_cpu::NoProgress;
use vplgi_gpu::GpuKernels;

fn frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("frame");
    let kernels = gpu.as_ref().map(|g| GpuKernels::new(&g.ctx.device).expect("GPU pipelines"));
    for size in sizes() {
        let cfg = &size.cfg;
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::render(&cs, cfg, &NoProgress).expect("CPU frame"))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernels) {
            let run = || {
                vplgi_gpu::render(&g.ctx.device, &g.ctx.queue, k, scene(), cfg).expect("GPU frame");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| {
                b.iter_custom(|iters| g.time(iters, run))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
