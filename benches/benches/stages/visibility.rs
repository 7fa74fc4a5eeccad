//! Stage 4, `visibility`: the bit matrix between the shading-point clusters' representatives and
//! the VPL clusters' lights (K_SP x K_VPL shadow rays), CPU (Embree) and GPU.

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_cpu::NoProgress;
use vplgi_gpu::visibility::VisibilityKernel;

fn visibility(c: &mut Criterion) {
    let mut group = c.benchmark_group("visibility");
    configure(&mut group);
    let gpu = Gpu::new("visibility");
    let kernel = gpu.as_ref().map(|g| VisibilityKernel::new(&g.ctx.device).expect("visibility pipeline"));
    for size in sizes() {
        let inputs = Inputs::new(&size.cfg);
        // Criterion reports pairs (rays, less the pairs facing away) per second.
        group.throughput(Throughput::Elements((inputs.rows.len() * inputs.cols.len()) as u64));
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::visibility::visibility(&inputs.cs, &inputs.rows, &inputs.cols, &NoProgress))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let (rows, cols) = (g.visibility_endpoints(&inputs.rows), g.visibility_endpoints(&inputs.cols));
            let (n_rows, n_cols) = (inputs.rows.len() as u32, inputs.cols.len() as u32);
            let run = || {
                k.run_on_device(&g.ctx.device, &g.ctx.queue, &g.scene, (&rows, n_rows), (&cols, n_cols), 0..n_rows).expect("visibility");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, visibility);
