//! Stage 3's first step with `--seeding adaptive`, `seeding`: Wang et al.'s screen-space quadtree
//! over the frame's hits (K_SP seeds, the frame's alpha), CPU and GPU, from the same hits.

use criterion::{BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_cpu::seeding::{seeding, ImageHits};
use vplgi_gpu::cluster::ClusterKernel;
use vplgi_gpu::seeding::{GpuImageHits, SeedingKernel};
use vplgi_types::MISS;

pub(super) fn seeding_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("seeding");
    configure(&mut group);
    let gpu = Gpu::new("seeding");
    let kernels =
        gpu.as_ref().map(|g| (SeedingKernel::new(&g.ctx.device).expect("seeding pipelines"), ClusterKernel::new(&g.ctx.device).expect("cluster pipelines")));
    for size in sizes() {
        let inputs = Inputs::new(&size.cfg);
        let cfg = &inputs.cfg;
        let params = cfg.seed_params(inputs.cs.extent);
        // Hits before each sample; a pixel's hits start at its first sample's entry.
        let offsets: Vec<u32> = std::iter::once(0)
            .chain(inputs.row_of.iter().scan(0u32, |before, &row| {
                *before += (row != MISS) as u32;
                Some(*before)
            }))
            .collect();
        let pixel_first: Vec<u32> = offsets.iter().step_by(cfg.spp as usize).copied().collect();
        let (ps, ns) = &inputs.sp_points;
        let image = ImageHits { positions: ps, normals: ns, pixel_first: &pixel_first, width: cfg.width, height: cfg.height };
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| b.iter(|| seeding(&image, &params).len()));
        if let (Some(g), Some((seeder, cluster))) = (&gpu, &kernels) {
            let points = g.endpoints(&inputs.sp_points);
            let offsets = vplgi_gpu::buffers::storage(&g.ctx.device, "hit offsets", &offsets);
            let hits = GpuImageHits { points: &points, count: ps.len() as u32, offsets: &offsets, width: cfg.width, height: cfg.height, spp: cfg.spp };
            let run = || {
                seeder.run(&g.ctx.device, &g.ctx.queue, cluster, &hits, &params).expect("seeding");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

