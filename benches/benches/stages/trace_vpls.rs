//! Stage 1, `trace_vpls`: light particles traced into VPLs, CPU (Embree) and GPU.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, sizes, Gpu};
use vplgi_cpu::NoProgress;
use vplgi_gpu::trace_vpls::TraceVplsKernel;

fn trace_vpls(c: &mut Criterion) {
    let mut group = c.benchmark_group("trace_vpls");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("trace_vpls");
    let kernel = gpu.as_ref().map(|g| TraceVplsKernel::new(&g.ctx.device).expect("trace_vpls pipelines"));
    for size in sizes() {
        let cfg = &size.cfg;
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::trace_vpls::trace_vpls(&cs, &cfg.trace_params(), &NoProgress))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let run = || {
                k.run(&g.ctx.device, &g.ctx.queue, &g.scene, &cfg.trace_params()).expect("trace_vpls");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, trace_vpls);
