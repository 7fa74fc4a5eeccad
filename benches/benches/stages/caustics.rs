//! `caustics` (`--caustics photons`): the caustic estimate at every shading point of the small
//! and the paper's frame of the Cornell box with a glass cube and sphere, CPU and GPU, from one
//! caustic photon map (the frame's default count, traced once by the CPU, not timed); and the
//! map's kd-tree, built on the host for both.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, smoke, sizes, Gpu};
use vplgi_cpu::caustics::{caustics, photon_map};
use vplgi_cpu::NoProgress;
use vplgi_gpu::caustics::CausticsKernel;

fn caustics_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("caustics");
    configure(&mut group);
    let scene = vplgi_scene::cornell::cornell_glass(0);
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).expect("Embree scene");
    let gpu = Gpu::new("caustics");
    let kernel = gpu.as_ref().map(|g| CausticsKernel::new(&g.ctx.device).expect("caustics pipeline"));
    let lobes = gpu.as_ref().map(|g| vplgi_gpu::scene::GpuScene::new(&g.ctx.device, &scene).expect("GPU scene"));
    for size in sizes() {
        let cfg = vplgi_types::FrameConfig {
            caustic_photons: if smoke() { 2_000 } else { size.cfg.caustic_photons },
            ..size.cfg.clone()
        };
        let photons = vplgi_cpu::trace_vpls::trace_vpls(&cs, &cfg.caustic_trace_params(), &NoProgress).vpls;
        group.bench_function(BenchmarkId::new("tree", size.name), |b| {
            b.iter(|| photon_map(&photons, cfg.photon_leaf).nodes.len())
        });
        let map = photon_map(&photons, cfg.photon_leaf);
        let sps = vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(scene.camera));
        let params = cfg.caustic_params(cs.extent, 0);
        let n = sps.len() as u32;
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| caustics(&cs, &map, &sps, 0..n, &params).1)
        });
        if let (Some(g), Some(k), Some(gs)) = (&gpu, &kernel, &lobes) {
            let on_device = k.upload(&g.ctx.device, &map.photons, &map.nodes);
            let points = vplgi_gpu::buffers::storage(&g.ctx.device, "shading points", &sps);
            let samples = vplgi_gpu::caustics::Samples { buffer: &points, count: n };
            let run = || {
                k.run(&g.ctx.device, &g.ctx.queue, &on_device, &samples, &gs.lobes, &params)
                    .expect("caustics");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, caustics_stage);
