//! `gather_radius` (`--shade interpolate`): 1 / R_j of the frame's sample points (the
//! shading-point clusters' representatives) from the frame's gather rays, CPU and GPU, from the
//! same points.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_gpu::gather_radius::GatherRadiusKernel;

fn gather_radius_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("gather_radius");
    configure(&mut group);
    let gpu = Gpu::new("gather_radius");
    let kernel = gpu.as_ref().map(|g| GatherRadiusKernel::new(&g.ctx.device).expect("gather_radius pipeline"));
    for size in sizes() {
        let inputs = Inputs::new(&size.cfg);
        let params = inputs.cfg.gather_params();
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::gather_radius::gather_radius(&inputs.cs, &inputs.rows, &params).len())
        });
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let points = g.visibility_endpoints(&inputs.rows);
            let n = inputs.rows.len() as u32;
            let run = || {
                k.run(&g.ctx.device, &g.ctx.queue, &g.scene, &points, n, &params).expect("gather_radius");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, gather_radius_stage);
