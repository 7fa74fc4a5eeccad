//! `final_gather` (`--gi photon`): the gather at the frame's sample points (the shading-point
//! clusters' representatives) with `--preset photon`'s 256 rays, lit by the CPU's cut of the
//! frame's global photon map (traced and cut once, not timed), CPU and GPU, from the same points
//! and cut.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, smoke, Gpu, Inputs};
use vplgi_gpu::final_gather::FinalGatherKernel;
use vplgi_gpu::illumination_cut::IlluminationCutKernel;
use vplgi_types::interpolation::GatherParams;

fn final_gather_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("final_gather");
    configure(&mut group);
    let gpu = Gpu::new("final_gather");
    let kernels = gpu.as_ref().map(|g| {
        (
            IlluminationCutKernel::new(&g.ctx.device).expect("illumination_cut pipelines"),
            FinalGatherKernel::new(&g.ctx.device).expect("final_gather pipeline"),
        )
    });
    for size in sizes() {
        let (inputs, map) = Inputs::with_global_map(&size);
        let cfg = &inputs.cfg;
        let cut = vplgi_cpu::illumination_cut::cut_of(&map, &cfg.cut_params(inputs.cs.extent));
        let params = GatherParams { seed: cfg.seed, rays: if smoke() { 4 } else { vplgi_types::FrameConfig::photon().gather_rays } };
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::final_gather::final_gather(&inputs.cs, inputs.rows.clone(), &cut, &params).1)
        });
        if let (Some(g), Some((ic, k))) = (&gpu, &kernels) {
            let (device, queue) = (&g.ctx.device, &g.ctx.queue);
            let on_device = ic.upload(device, &cut);
            let run = || {
                let points = vplgi_gpu::GpuPoints::upload(device, "sample points", &inputs.rows);
                k.run(device, queue, &g.scene, points, &on_device, &params).expect("final gather");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, final_gather_stage);
