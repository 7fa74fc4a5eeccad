//! Stage 3, `cluster`: the frame's two clusterings (VPLs into K_VPL hard clusters, hit shading
//! points into K_SP F-fuzzy clusters), CPU and GPU, from the same points, with the shading points
//! by Eq. 7 (`cpu`, `gpu`) and by Eq. 2 of Wang et al. (`cpu-ward`, `gpu-ward`); the shading
//! points' clustering started warm from a previous frame's (`cpu-warm`, `gpu-warm`, `--temporal
//! on`), with the centres read back for the next frame; and `kmeans`, the
//! k-means problem `make perf-report` compares with faiss (1M uniform points, K = 8,192).

mod seeding;

use criterion::{criterion_group, BenchmarkId, Criterion};
use vplgi_benches::{configure, kmeans_problem, kmeans_size, sizes, Gpu, Inputs};
use vplgi_cpu::cluster::temporal::centres;
use vplgi_cpu::cluster::{cluster, cluster_from, ClusterStart};
use vplgi_frame::RsmStart;
use vplgi_gpu::cluster::ClusterKernel;
use vplgi_types::clustering::Centre;
use vplgi_types::{FrameConfig, SpMetric, SpRepresentative};

fn cluster_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("cluster");
    configure(&mut group);
    let gpu = Gpu::new("cluster");
    let kernel = gpu.as_ref().map(|g| ClusterKernel::new(&g.ctx.device).expect("cluster pipelines"));
    for size in sizes() {
        let inputs = Inputs::new(&size.cfg);
        // `cpu`/`gpu`: the frame's two clusterings as configured (Eq. 7); `-ward`: the same with
        // the shading points clustered after Wang et al. (Eq. 2, min-error representatives).
        let wang = FrameConfig { metric: SpMetric::Ward, representative: SpRepresentative::MinError, ..inputs.cfg.clone() };
        let vpl = inputs.cfg.vpl_cluster_params();
        for (suffix, sp) in [("", inputs.cfg.sp_cluster_params(inputs.cs.extent)), ("-ward", wang.sp_cluster_params(inputs.cs.extent))] {
            group.bench_function(BenchmarkId::new(format!("cpu{suffix}"), size.name), |b| {
                b.iter(|| {
                    let v = cluster(&inputs.vpl_points.0, &inputs.vpl_points.1, &vpl);
                    let s = cluster(&inputs.sp_points.0, &inputs.sp_points.1, &sp);
                    (v.k(), s.k())
                })
            });
            if let (Some(g), Some(k)) = (&gpu, &kernel) {
                let (vpl_buf, sp_buf) = (g.endpoints(&inputs.vpl_points), g.endpoints(&inputs.sp_points));
                let (n_vpl, n_sp) = (inputs.vpl_points.0.len() as u32, inputs.sp_points.0.len() as u32);
                let run = || {
                    k.cluster(&g.ctx.device, &g.ctx.queue, &vpl_buf, n_vpl, &vpl).expect("cluster VPLs");
                    k.cluster(&g.ctx.device, &g.ctx.queue, &sp_buf, n_sp, &sp).expect("cluster shading points");
                };
                run();
                group.bench_function(BenchmarkId::new(format!("gpu{suffix}"), size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
            }
        }
        // `-warm`: the previous frame is this one's cold clustering with its thresholds halved,
        // so that some points fit nowhere and seed new clusters, as after a camera move.
        let sp = inputs.cfg.sp_cluster_params(inputs.cs.extent);
        let (ps, ns) = (&inputs.sp_points.0, &inputs.sp_points.1);
        let previous: Vec<Centre> =
            centres(&cluster(ps, ns, &sp), ps, ns, sp.metric).into_iter().map(|c| Centre { threshold: 0.5 * c.threshold, ..c }).collect();
        let warm = ClusterStart::Warm { previous: &previous, seeds: None };
        group.bench_function(BenchmarkId::new("cpu-warm", size.name), |b| b.iter(|| centres(&cluster_from(ps, ns, &sp, warm), ps, ns, sp.metric).len()));
        if let (Some(g), Some(k)) = (&gpu, &kernel) {
            let (buf, n) = (g.endpoints(&inputs.sp_points), ps.len() as u32);
            let run = || {
                let c = k.cluster_from(&g.ctx.device, &g.ctx.queue, (&buf, n), &sp, warm).expect("warm clustering");
                k.centres(&g.ctx.device, &g.ctx.queue, &c, (&buf, n), sp.metric).expect("centres");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu-warm", size.name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    // --vpl-cluster rsm at the paper's Table 1 sizes (RSM 128² with 256 and 1,024 clusters, 256²
    // with 1,024), the Cornell box's shadow-map VPLs, 10 iterations, the paper's Cornell weights:
    // `rsm` from Halton seeds, `rsm-importance` with the importance map of 256 G-buffer points
    // built and warped, as the paper's Table 1 times it.
    let cs = vplgi_benches::cpu_scene();
    let view = vplgi_types::FrameConfig::default();
    let sps = vplgi_cpu::shading_points::shading_points(&cs, &view.camera_params(cs.scene.camera));
    let gbuffer: Vec<vplgi_types::Endpoint> = vplgi_shared::rsm_importance::pixel_samples(view.width, view.height, view.spp)
        .into_iter()
        .map(|s| &sps[s as usize])
        .filter(|sp| !sp.is_miss())
        .map(vplgi_types::Endpoint::of)
        .collect();
    let d_min = vplgi_shared::rsm_importance::D_MIN_REL * cs.extent;
    let table1: [(&str, u32, u32); 3] = if vplgi_benches::smoke() {
        [("16-16", 16, 16), ("16-64", 16, 64), ("32-64", 32, 64)]
    } else {
        [("128-256", 128, 256), ("128-1024", 128, 1024), ("256-1024", 256, 1024)]
    };
    for (name, size, k) in table1 {
        let vpls = vplgi_cpu::rsm_vpls::rsm_vpls(&cs, &vplgi_types::RsmParams::new(size, 1), &vplgi_cpu::NoProgress).vpls;
        let maps = cs.lights.rsm_maps(size);
        let params = vplgi_shared::rsm::RsmClusterParams { k, iterations: 10, weights: Default::default(), extent: cs.extent };
        group.bench_function(BenchmarkId::new("cpu-rsm", name), |b| b.iter(|| vplgi_cpu::rsm_cluster::rsm_cluster(&vpls, &maps, &params, None).k()));
        group.bench_function(BenchmarkId::new("cpu-rsm-importance", name), |b| {
            b.iter(|| {
                let importance = vplgi_cpu::rsm_importance::rsm_importance(&vpls, &maps, &gbuffer, d_min);
                vplgi_cpu::rsm_cluster::rsm_cluster(&vpls, &maps, &params, Some(&importance)).k()
            })
        });
        // `-warm` (--temporal on): from the previous frame's clusters, here this frame's own.
        let previous = vplgi_cpu::rsm_cluster::rsm_cluster_from(&vpls, &maps, &params, None, None).centres;
        group.bench_function(BenchmarkId::new("cpu-rsm-warm", name), |b| {
            b.iter(|| vplgi_cpu::rsm_cluster::rsm_cluster_from(&vpls, &maps, &params, None, Some(&previous)).centres.len())
        });
        if let Some(g) = &gpu {
            let (device, queue) = (&g.ctx.device, &g.ctx.queue);
            let kernel = vplgi_gpu::rsm_cluster::RsmClusterKernel::new(device).expect("rsm_cluster pipelines");
            let importance_kernel = vplgi_gpu::rsm_importance::RsmImportanceKernel::new(device).expect("rsm_importance pipelines");
            let n = vpls.len() as u32;
            let buf = vplgi_gpu::trace_vpls::GpuVpls { buffer: vplgi_gpu::buffers::storage(device, "vpls", &vpls), count: n, particles: 0 };
            let points = vplgi_gpu::buffers::storage(device, "importance points", &gbuffer);
            let run = || {
                kernel.run(device, queue, &buf, &maps, &params, RsmStart { importance: None, previous: None, carry: false }).expect("rsm_cluster");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu-rsm", name), |b| b.iter_custom(|iters| g.time(iters, run)));
            let run = || {
                let importance = importance_kernel.run(device, queue, &buf, &maps, (&points, gbuffer.len() as u32), d_min).expect("rsm_importance");
                kernel
                    .run(device, queue, &buf, &maps, &params, RsmStart { importance: Some(&importance), previous: None, carry: false })
                    .expect("rsm_cluster");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu-rsm-importance", name), |b| b.iter_custom(|iters| g.time(iters, run)));
            let run = || {
                let start = RsmStart { importance: None, previous: Some(&previous), carry: true };
                kernel.run(device, queue, &buf, &maps, &params, start).expect("rsm_cluster");
            };
            run();
            group.bench_function(BenchmarkId::new("gpu-rsm-warm", name), |b| b.iter_custom(|iters| g.time(iters, run)));
        }
    }
    let (n, k, iterations) = kmeans_size();
    let (ps, ns, params) = kmeans_problem(n, k, iterations);
    group.bench_function(BenchmarkId::new("cpu", "kmeans"), |b| b.iter(|| cluster(&ps, &ns, &params).k()));
    group.finish();
}

criterion_group!(benches, cluster_stage, seeding::seeding_stage);
