//! Stage 5, `shade`: every pixel's direct light and its F clusters' VPL-cluster lights, weighted
//! by the clusters' visibility rows, CPU and GPU on identical inputs.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_cpu::shade::VisibilitySource;
use vplgi_gpu::buffers::{storage, Window};
use vplgi_gpu::shade::{ShadeInputs, ShadeKernel, Visibility};
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::LightShape;

fn shade(c: &mut Criterion) {
    let mut group = c.benchmark_group("shade");
    configure(&mut group);
    let gpu = Gpu::new("shade");
    let kernel = gpu.as_ref().map(|g| ShadeKernel::new(&g.ctx.device).expect("shade pipeline"));
    for size in sizes() {
        let i = Inputs::new(&size.cfg);
        let cfg = &i.cfg;
        let sc = &i.sp_clusters;
        let src = VisibilitySource::Fuzzy { matrix: &i.matrix, row_of: &i.row_of, labels: &sc.labels, weights: &sc.weights, f: sc.f };
        // The same clusters as disk lights, by Eq. 2 (--light-shape disk: "cpu-disk", "gpu-disk")
        // and by the exact form factor (disk-exact: "cpu-disk-exact", "gpu-disk-exact"), and as
        // polygons (polygon: "cpu-polygon", "gpu-polygon").
        let disks = vplgi_cpu::shade::vpl_lights(&i.vpls, Some(&i.vpl_clusters), LightShape::Disk);
        let exact = vplgi_cpu::shade::vpl_lights(&i.vpls, Some(&i.vpl_clusters), LightShape::DiskExact);
        let polygons = vplgi_cpu::shade::vpl_lights(&i.vpls, Some(&i.vpl_clusters), LightShape::Polygon);
        for (suffix, lights) in [("", &i.lights), ("-disk", &disks), ("-disk-exact", &exact), ("-polygon", &polygons)] {
            group.bench_function(BenchmarkId::new(format!("cpu{suffix}"), size.name), |b| {
                b.iter(|| vplgi_cpu::shade::shade(&i.cs, &i.sps, 0, 0..i.pixels(), lights, &src, &cfg.shade_params(i.cs.extent)))
            });
            if let (Some(g), Some(k)) = (&gpu, &kernel) {
                let d = &g.ctx.device;
                let (sps, row_of) = (storage(d, "sps", &i.sps), storage(d, "row of", &i.row_of));
                let words = storage(d, "words", bytemuck::cast_slice::<u64, u32>(i.matrix.words()));
                let (labels, weights) = (storage(d, "labels", &sc.labels), storage(d, "weights", &sc.weights));
                let (light_buf, outlines) = g.lights(lights);
                let window = Window { first: 0, count: i.sp_points.0.len() as u64 };
                let inputs = ShadeInputs {
                    sps: &sps,
                    sp_first: 0,
                    row_of: &row_of,
                    words: &words,
                    words_per_row: words_per_row(i.cols.len()) as u32,
                    vpl_lights: &light_buf,
                    outlines: outlines.as_ref(),
                    light_count: lights.lights.len() as u32,
                    exact_shapes: lights.lights.iter().any(|l| l.exact != 0),
                    lobes: None,
                    visibility: Visibility::Fuzzy { labels: &labels, weights: &weights, f: sc.f as u32, window },
                };
                let run = || {
                    k.run(d, &g.ctx.queue, &g.scene, &inputs, 0..i.pixels() as u32, &cfg.shade_params(i.cs.extent)).expect("shade");
                };
                run();
                group.bench_function(BenchmarkId::new(format!("gpu{suffix}"), size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
            }
        }
    }
    group.finish();
}

criterion_group!(benches, shade);
