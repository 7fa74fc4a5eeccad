//! `illumination_cut` (`--gi photon`): the cut of the global photon map of the small and the
//! paper's frame of the Cornell box (the frame's photon count, traced once by the CPU, not
//! timed): Eq. 3 at every node and the refinements' density estimates, CPU and GPU, with the
//! host's choices between them.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_gpu::caustics::CausticsKernel;
use vplgi_gpu::illumination_cut::IlluminationCutKernel;
use vplgi_shared::illumination_cut::select;

fn illumination_cut_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("illumination_cut");
    configure(&mut group);
    let gpu = Gpu::new("illumination_cut");
    let kernels = gpu.as_ref().map(|g| {
        (
            CausticsKernel::new(&g.ctx.device).expect("caustics pipeline"),
            IlluminationCutKernel::new(&g.ctx.device).expect("illumination_cut pipelines"),
        )
    });
    for size in sizes() {
        let (inputs, map) = Inputs::with_global_map(&size);
        let cfg = &inputs.cfg;
        let params = cfg.cut_params(inputs.cs.extent);
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| {
                let estimates = vplgi_cpu::illumination_cut::node_estimates(&map, &params);
                let cut: Result<_, std::convert::Infallible> =
                    select(&estimates, &params, |p| Ok(vplgi_cpu::illumination_cut::densities(&map, p, &params)));
                cut.map(|c| c.nodes.len())
            })
        });
        if let (Some(g), Some((caustics, k))) = (&gpu, &kernels) {
            let (device, queue) = (&g.ctx.device, &g.ctx.queue);
            let on_device = caustics.upload(device, &map.photons, &map.nodes);
            let nodes = map.nodes.len() as u32;
            let run = || {
                let estimates = k.node_estimates(device, queue, &on_device, nodes, &params).expect("node estimates");
                select(&estimates, &params, |p| k.densities(device, queue, &on_device, p, &params)).expect("densities");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, illumination_cut_stage);
