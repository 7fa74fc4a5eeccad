//! `bias_points`: one level of the clamp's bias compensation (a cosine-sampled segment from
//! every shading point to the surface it sees, kept where the clamp bites), CPU (Embree) and
//! GPU, on the camera's shading points with the default clamp.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, sizes, Gpu};
use vplgi_gpu::bias_points::BiasPointsKernel;
use vplgi_gpu::buffers::storage;

fn bias_points(c: &mut Criterion) {
    let mut group = c.benchmark_group("bias_points");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("bias_points");
    let kernel = gpu.as_ref().map(|g| BiasPointsKernel::new(&g.ctx.device).expect("bias_points pipeline"));
    for size in sizes() {
        let cfg = &size.cfg;
        let parents = vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera));
        let params = cfg.bias_params(cs.extent, 1);
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| b.iter(|| vplgi_cpu::bias_points::bias_points(&cs, &parents, 0, &params)));
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let n = parents.len() as u32;
            let on_device = storage(&g.ctx.device, "parents", &parents);
            // The points stay on the device, as in the chained pipeline.
            let run = || {
                k.run(&g.ctx.device, &g.ctx.queue, &g.scene, &on_device, 0..n, &params).expect("bias_points");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, bias_points);
