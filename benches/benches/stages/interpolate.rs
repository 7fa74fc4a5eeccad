//! `interpolate` (`--shade interpolate`): the irradiance samples at the frame's sample points
//! (every light, each point its own visibility row) and their interpolation to every shading
//! point, CPU and GPU, from the same clusters, lights, matrix and radii. Direct light, which
//! `shade` adds in either mode, is not part of it: compare with `shade`'s light sums.

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, sizes, Gpu, Inputs};
use vplgi_cpu::interpolate::IrradianceSamples;
use vplgi_cpu::shade::{irradiance, sample_irradiance, LightArrays, VisibilitySource};
use vplgi_gpu::buffers::{storage, Window};
use vplgi_gpu::interpolate::{InterpolateInputs, InterpolateKernel, SampleLighting};
use vplgi_gpu::shade::ShadeKernel;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::MISS;

fn interpolate_stage(c: &mut Criterion) {
    use rayon::prelude::*;
    let mut group = c.benchmark_group("interpolate");
    configure(&mut group);
    let gpu = Gpu::new("interpolate");
    let kernels = gpu
        .as_ref()
        .map(|g| (InterpolateKernel::new(&g.ctx.device).expect("interpolate pipelines"), ShadeKernel::new(&g.ctx.device).expect("shade pipelines")));
    for size in sizes() {
        let inputs = Inputs::new(&size.cfg);
        let g_max = inputs.cfg.g_max(inputs.cs.extent);
        let inv_radius = vplgi_cpu::gather_radius::gather_radius(&inputs.cs, &inputs.rows, &inputs.cfg.gather_params());
        let sc = &inputs.sp_clusters;
        let none = LightArrays::new(&Default::default(), &[]);
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| {
                let irr = sample_irradiance(&inputs.cs.scene.materials, &inputs.rows, &inputs.lights, &inputs.matrix, g_max);
                let samples = IrradianceSamples { points: inputs.rows.clone(), inv_radius: inv_radius.clone(), irradiance: irr, sh: Vec::new() };
                let vis = VisibilitySource::Interpolated { row_of: &inputs.row_of, labels: &sc.labels, f: sc.f, samples: &samples };
                let sps = &inputs.sps;
                (0..sps.len())
                    .into_par_iter()
                    .filter(|&i| inputs.row_of[i] != MISS)
                    .map(|i| irradiance(sps[i].position.into(), sps[i].normal.into(), None, i, &none, &vis, g_max).x)
                    .sum::<f32>()
            })
        });
        if let (Some(g), Some((k, shade))) = (&gpu, &kernels) {
            let (device, queue) = (&g.ctx.device, &g.ctx.queue);
            let words = storage(device, "words", bytemuck::cast_slice::<u64, u32>(inputs.matrix.words()));
            let lights = storage(device, "lights", &inputs.lights.lights);
            let lighting = SampleLighting {
                words: &words,
                words_per_row: words_per_row(inputs.lights.lights.len()) as u32,
                vpl_lights: &lights,
                outlines: None,
                light_count: inputs.lights.lights.len() as u32,
                exact_shapes: false,
                lobes: None,
                g_max,
            };
            let (sps, row_of, labels) = (storage(device, "sps", &inputs.sps), storage(device, "row_of", &inputs.row_of), storage(device, "labels", &sc.labels));
            let n_hits = inputs.sp_points.0.len() as u64;
            // A diffuse scene: one white diffuse record stands for every material.
            let lobes = vplgi_gpu::buffers::storage_zeroed::<vplgi_types::BsdfRecord>(device, "lobes", 1);
            let at = InterpolateInputs { sps: &sps, sp_first: 0, row_of: &row_of, labels: &labels, f: sc.f as u32, window: Window { first: 0, count: n_hits }, lobes: &lobes };
            let run = || {
                let points = (g.visibility_endpoints(&inputs.rows), inputs.rows.len() as u32);
                let samples = k.sample_irradiance(device, queue, shade, points, storage(device, "inverse radii", &inv_radius), &lighting).expect("samples");
                k.run(device, queue, &samples, &at, 0..inputs.sps.len() as u32).expect("interpolate");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    group.finish();
}

criterion_group!(benches, interpolate_stage);
