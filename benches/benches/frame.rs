//! The whole frame (`--cluster both`): the five stages chained, CPU reference and GPU pipeline.
//! The GPU frame includes uploading the scene and building its BVH, as `vplgi render` does.
//! `frame_specular` times the small frame on the Cornell boxes with mirrors and glass and with
//! rough metal: camera and light paths through specular chains, and glossy lobes in `shade`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use vplgi_benches::{configure, cpu_scene, scene, sizes, Gpu};
use vplgi_cpu::NoProgress;
use vplgi_gpu::GpuKernels;

fn frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame");
    configure(&mut group);
    let cs = cpu_scene();
    let gpu = Gpu::new("frame");
    let kernels = gpu.as_ref().map(|g| GpuKernels::new(&g.ctx.device).expect("GPU pipelines"));
    for size in sizes() {
        let cfg = &size.cfg;
        group.bench_function(BenchmarkId::new("cpu", size.name), |b| {
            b.iter(|| vplgi_cpu::render(&cs, cfg, &NoProgress).expect("CPU frame"))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernels) {
            let run = || {
                vplgi_gpu::render(&g.ctx.device, &g.ctx.queue, k, scene(), cfg).expect("GPU frame");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", size.name), |b| {
                b.iter_custom(|iters| g.time(iters, run))
            });
        }
    }
    group.finish();
}

fn frame_specular(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame_specular");
    configure(&mut group);
    let gpu = Gpu::new("frame_specular");
    let kernels = gpu.as_ref().map(|g| GpuKernels::new(&g.ctx.device).expect("GPU pipelines"));
    let cfg = &sizes()[0].cfg;
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    for (name, scene) in [
        ("cornell-mirror", vplgi_scene::cornell::cornell_mirror(0)),
        ("cornell-glass", vplgi_scene::cornell::cornell_glass(0)),
        ("cornell-glossy", vplgi_scene::cornell::cornell_glossy(0)),
    ] {
        let cs = vplgi_cpu::CpuScene::new(&scene, &device).expect("Embree scene");
        group.bench_function(BenchmarkId::new("cpu", name), |b| {
            b.iter(|| vplgi_cpu::render(&cs, cfg, &NoProgress).expect("CPU frame"))
        });
        if let (Some(g), Some(k)) = (&gpu, &kernels) {
            let run = || {
                vplgi_gpu::render(&g.ctx.device, &g.ctx.queue, k, &scene, cfg).expect("GPU frame");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu", name), |b| {
                b.iter_custom(|iters| g.time(iters, run))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, frame, frame_specular);
criterion_main!(benches);
