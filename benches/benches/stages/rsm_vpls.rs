//! Stage 1 with `--vpl-source rsm`, `rsm_vpls`: the reflective shadow maps of the Cornell box's
//! lights into VPLs, CPU (Embree) and GPU, at the paper's map sizes (Table 1: 128² and 256²;
//! 16² and 32² for the smoke run).

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, smoke, Gpu};
use vplgi_cpu::NoProgress;
use vplgi_gpu::rsm_vpls::RsmVplsKernel;
use vplgi_types::RsmParams;

fn rsm_vpls(c: &mut Criterion) {
    let mut group = c.benchmark_group("rsm_vpls");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("rsm_vpls");
    let kernel = gpu.as_ref().map(|g| RsmVplsKernel::new(&g.ctx.device).expect("rsm_vpls pipelines"));
    let sizes: [(&str, u32); 2] = if smoke() { [("small", 16), ("paper", 32)] } else { [("small", 128), ("paper", 256)] };
    for (name, size) in sizes {
        let params = RsmParams::new(size, 1);
        group.bench_function(BenchmarkId::new("cpu", name), |b| b.iter(|| vplgi_cpu::rsm_vpls::rsm_vpls(&cs, &params, &NoProgress)));
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let maps = g.scene.sampler.rsm_maps(size);
            let run = || {
                k.run(&g.ctx.device, &g.ctx.queue, &g.scene, &maps, &params).expect("rsm_vpls");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, rsm_vpls);
