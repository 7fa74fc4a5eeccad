//! `make perf-report`: vplgi measured side by side with its peers, in one run, written to
//! `docs/PERFORMANCE.md` (every number also in `docs/perf/perf.json`, pictures in `docs/perf/`):
//!
//! 1. k-means: our clustering of 1,000,000 points (positions in the unit cube, unit normals) into
//!    8,192 clusters with 10 iterations, Eq. 7's normal test disabled so that it is plain
//!    Euclidean k-means on positions, against faiss-cpu's `Kmeans` on the same points, K and
//!    iterations; and our GPU clustering on the same data.
//! 2. visibility: the stage's shadow-ray throughput against bare loops of Embree's one-ray and
//!    packet queries (`rtcOccluded1`, 4, 8, 16) over the very same rays.
//! 3. floor: the GPU/CPU ratio of the simplest SIMT-friendly kernel (nearest of 64 centroids),
//!    what the adapter costs by itself.
//! 4. frames: GPU / CPU time and throughput per stage of the paper-size Cornell box and of the
//!    generated conference room (300 k triangles) at 256x180.
//! 5. approximation: the clustered frame against the unclustered reference: time, MSE, FLIP.
//! 6. history: the tracked ratios appended to `perf/history.json`, charted in `perf/history.svg`.
//!
//! Every figure is a median of runs taken in this process, and ratios compare runs taken side by
//! side. Without a GPU the adapter is Mesa lavapipe on the same CPU cores.

use anyhow::{bail, Context, Result};
use clap::Parser;
use glam::Vec3;
use rayon::prelude::*;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use vplgi_cpu::cluster::cluster;
use vplgi_cpu::visibility::{facing, visibility, Endpoint};
use vplgi_cpu::{CpuScene, NoProgress};
use vplgi_frame::{Frame, FrameStats};
use vplgi_frame::{Stage, StageTimings};
use vplgi_reports::{history, median};
use vplgi_scene::Scene;
use vplgi_types::clustering::ClusterParams;
use vplgi_types::{CameraParams, FrameConfig, TraceParams};

#[derive(Parser)]
#[command(
    about = "Measures vplgi against faiss-cpu, raw Embree, its own GPU backend and its unclustered reference; writes a Markdown report"
)]
struct Opts {
    /// The report. Numbers go to perf/perf.json and pictures to perf/ beside it.
    #[arg(long, default_value = "docs/PERFORMANCE.md")]
    out: PathBuf,
    /// Small sizes throughout: a check that the report runs, in seconds, not a measurement.
    #[arg(long)]
    quick: bool,
    /// Python interpreter that can `import faiss` (make perf-report installs faiss-cpu for it).
    #[arg(long, default_value = "python3")]
    python: String,
    /// Measure nothing: redraw perf/history.svg from perf/history.json (after editing it).
    #[arg(long)]
    chart_only: bool,
    /// The faiss side of the k-means comparison.
    #[arg(long, default_value = "benches/faiss_kmeans.py")]
    faiss_script: PathBuf,
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

fn shell(cmd: &str, args: &[&str]) -> String {
    Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into())
}

fn machine() -> Value {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map_or("unknown".into(), |s| s.trim().to_string());
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let mem_kib: f64 = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    let dirty = !shell("git", &["status", "--porcelain", "--untracked-files=no"]).is_empty();
    json!({
        "cpu": model,
        "threads": rayon::current_num_threads(),
        "memory_gib": (mem_kib / 1048576.0 * 10.0).round() / 10.0,
        "date": shell("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
        "commit": format!("{}{}", shell("git", &["rev-parse", "--short", "HEAD"]), if dirty { " with uncommitted changes" } else { "" }),
    })
}

/// Mean squared distance of each point to the centroid of its label.
fn kmeans_mse(ps: &[Vec3], labels: &[u32], centroids: &[Vec3]) -> f64 {
    ps.iter()
        .zip(labels)
        .map(|(p, &l)| (*p - centroids[l as usize]).length_squared() as f64)
        .sum::<f64>()
        / ps.len() as f64
}

struct Kmeans {
    n: usize,
    k: u32,
    iterations: u32,
    runs: usize,
}

fn kmeans(
    opts: &Opts,
    km: &Kmeans,
    gpu: Option<&vplgi_gpu::GpuContext>,
    dir: &Path,
) -> Result<Value> {
    let (ps, ns, plain) = vplgi_benches::kmeans_problem(km.n, km.k, km.iterations);
    let params = |gamma| ClusterParams { gamma, ..plain };
    let mut rows = Vec::new();

    let points_file = dir.join("kmeans-points.f32");
    let bytes: Vec<u8> = ps.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
    std::fs::write(&points_file, bytes)
        .with_context(|| format!("cannot write {}", points_file.display()))?;
    eprintln!(
        "k-means: faiss-cpu ({} points, K = {}, {} iterations, {} runs)",
        km.n, km.k, km.iterations, km.runs
    );
    let out = Command::new(&opts.python)
        .arg(&opts.faiss_script)
        .arg(&points_file)
        .args([km.k.to_string(), km.iterations.to_string(), km.runs.to_string()])
        .output()
        .with_context(|| format!("cannot run {} {}", opts.python, opts.faiss_script.display()))?;
    let _ = std::fs::remove_file(&points_file);
    let faiss: Option<Value> = if out.status.success() {
        Some(serde_json::from_slice(&out.stdout).context("faiss_kmeans.py printed no JSON")?)
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        if !opts.quick {
            bail!("the faiss side failed (make perf-report installs faiss-cpu):\n{err}");
        }
        eprintln!(
            "faiss not available ({}): skipped in --quick mode",
            err.lines().last().unwrap_or("")
        );
        None
    };
    if let Some(f) = &faiss {
        rows.push(json!({"name": format!("faiss-cpu {} Kmeans ({} threads)", f["version"].as_str().unwrap_or("?"), f["threads"]), "seconds": f["seconds"], "mse": f["mse"]}));
    }

    for gamma in [1, 4] {
        eprintln!("k-means: vplgi CPU, gamma = {gamma}");
        let mut times = Vec::new();
        let mut mse = 0.0;
        for _ in 0..km.runs {
            let t0 = Instant::now();
            let c = cluster(&ps, &ns, &params(gamma));
            times.push(secs(t0));
            let labels: Vec<u32> = (0..km.n).map(|i| c.hard_label(i)).collect();
            mse = kmeans_mse(&ps, &labels, &c.positions);
        }
        let what = if gamma == 1 {
            "every point in every iteration, as faiss"
        } else {
            "iterations on every 4th point, the pipeline's default"
        };
        rows.push(json!({"name": format!("vplgi `cluster`, CPU, gamma = {gamma}: {what}"), "seconds": median(times), "mse": mse}));
    }

    if let Some(ctx) = gpu {
        eprintln!("k-means: vplgi GPU, gamma = 1");
        let kernel = vplgi_gpu::cluster::ClusterKernel::new(&ctx.device)?;
        let e: Vec<vplgi_gpu::visibility::Endpoint> =
            ps.iter().zip(&ns).map(|(&p, &n)| vplgi_gpu::visibility::Endpoint::new(p, n)).collect();
        let buf = vplgi_gpu::buffers::storage(&ctx.device, "points", &e);
        let mut times = Vec::new();
        let mut mse = 0.0;
        for _ in 0..km.runs {
            let t0 = Instant::now();
            let c = kernel.cluster(&ctx.device, &ctx.queue, &buf, km.n as u32, &params(1))?;
            vplgi_gpu::buffers::sync(&ctx.device)?;
            times.push(secs(t0));
            let labels: Vec<u32> =
                vplgi_gpu::buffers::read_back(&ctx.device, &ctx.queue, &c.labels, km.n)?;
            let cents: Vec<vplgi_gpu::visibility::Endpoint> =
                vplgi_gpu::buffers::read_back(&ctx.device, &ctx.queue, &c.centroids, c.k as usize)?;
            let cents: Vec<Vec3> = cents
                .iter()
                .map(|e| Vec3::new(e.position[0], e.position[1], e.position[2]))
                .collect();
            mse = kmeans_mse(&ps, &labels, &cents);
        }
        rows.push(json!({"name": format!("vplgi `cluster`, GPU ({}), gamma = 1", ctx.describe()), "seconds": median(times), "mse": mse}));
    }
    Ok(
        json!({"points": km.n, "k": km.k, "iterations": km.iterations, "runs": km.runs, "rows": rows}),
    )
}

/// A bare loop of one of Embree's queries: its name, its packet width, and the loop.
type RawQuery<'a> = (&'static str, usize, Box<dyn Fn(&[(Vec3, Vec3)]) -> u64 + Sync + 'a>);

/// Bare parallel loops of Embree's queries over `rays` in their order: `rtcOccluded1` one ray at
/// a time, and `rtcOccludedN` over packets of N consecutive rays (one shading point toward N
/// VPLs: Embree's coherent case). Each returns the number of visible rays.
fn raw_queries<'a>(cs: &'a CpuScene) -> [RawQuery<'a>; 4] {
    fn packets<const N: usize>(
        rays: &[(Vec3, Vec3)],
        query: impl Fn(&[Vec3; N], &[Vec3; N], usize) -> u16 + Sync,
    ) -> u64 {
        rays.par_chunks(N)
            .map(|c| {
                let origins: [Vec3; N] =
                    std::array::from_fn(|k| c.get(k).map_or(Vec3::ZERO, |r| r.0));
                let dirs: [Vec3; N] = std::array::from_fn(|k| c.get(k).map_or(Vec3::X, |r| r.1));
                (c.len() as u32 - query(&origins, &dirs, c.len()).count_ones()) as u64
            })
            .sum()
    }
    let (near, far) = (vplgi_cpu::SEGMENT_TNEAR, vplgi_cpu::SEGMENT_TFAR);
    [
        (
            "rtcOccluded1",
            1,
            Box::new(move |rays| {
                rays.par_iter().filter(|(o, d)| !cs.rt.occluded(*o, *d, near, far)).count() as u64
            }),
        ),
        (
            "rtcOccluded4",
            4,
            Box::new(move |rays| packets::<4>(rays, |o, d, n| cs.rt.occluded4(o, d, n, near, far))),
        ),
        (
            "rtcOccluded8",
            8,
            Box::new(move |rays| packets::<8>(rays, |o, d, n| cs.rt.occluded8(o, d, n, near, far))),
        ),
        (
            "rtcOccluded16",
            16,
            Box::new(move |rays| {
                packets::<16>(rays, |o, d, n| cs.rt.occluded16(o, d, n, near, far))
            }),
        ),
    ]
}

/// The stage against bare loops of Embree's one-ray and packet queries over the very same rays
/// (facing pairs, both ends pushed off their surfaces), runs interleaved, medians of `runs`.
fn visibility_vs_embree(
    cs: &CpuScene,
    width: u32,
    stride: usize,
    n_cols: usize,
    runs: usize,
) -> Value {
    let sps = vplgi_cpu::shading_points::shading_points(
        cs,
        &CameraParams::new(cs.scene.camera, width, width, 1, 1),
    );
    let rows: Vec<Endpoint> =
        sps.iter().step_by(stride).filter(|s| !s.is_miss()).map(Endpoint::of).collect();
    let vpls = vplgi_cpu::trace_vpls::trace_vpls(
        cs,
        &TraceParams::new(1, n_cols as u32 * 10, 3),
        &NoProgress,
    )
    .vpls;
    let cols: Vec<Endpoint> = vpls.iter().take(n_cols).map(Endpoint::of_vpl).collect();
    let rays: Vec<(Vec3, Vec3)> = rows
        .iter()
        .flat_map(|a| cols.iter().filter(move |b| facing(a, b)).map(move |b| (*a, *b)))
        .map(|(a, b)| cs.shadow_segment(a.p(), a.n(), b.p(), b.n()))
        .collect();
    let queries = raw_queries(cs);
    let mut raw_times = vec![Vec::new(); queries.len()];
    let mut stage = Vec::new();
    let (mut stage_visible, mut traced) = (0, 0);
    let mut raw_visible = vec![0; queries.len()];
    for _ in 0..runs {
        for (k, (_, _, query)) in queries.iter().enumerate() {
            let t = Instant::now();
            raw_visible[k] = query(&rays);
            raw_times[k].push(secs(t));
        }
        let t = Instant::now();
        let (m, n) = visibility(cs, &rows, &cols, &NoProgress);
        stage.push(secs(t));
        (traced, stage_visible) = (n, m.count_ones());
    }
    assert_eq!(traced as usize, rays.len(), "the stage traced other rays");
    for (k, (name, _, _)) in queries.iter().enumerate() {
        assert_eq!(raw_visible[k], stage_visible, "{name} and the stage must see the same rays");
    }
    let s = median(stage);
    let raw: Vec<Value> = queries
        .iter()
        .zip(raw_times)
        .map(|((name, width, _), t)| {
            let t = median(t);
            json!({"query": name, "width": width, "seconds": t, "mrays": rays.len() as f64 / t / 1e6, "percent": 100.0 * t / s})
        })
        .collect();
    let fastest = raw
        .iter()
        .min_by(|a, b| {
            a["seconds"]
                .as_f64()
                .partial_cmp(&b["seconds"].as_f64())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .cloned();
    let one_ray = raw[0]["seconds"].as_f64().unwrap_or(f64::NAN);
    json!({"rows": rows.len(), "cols": cols.len(), "rays": rays.len(), "stage_s": s, "stage_mrays": rays.len() as f64 / s / 1e6,
           "stage_width": vplgi_cpu::visibility::PACKET, "raw": raw, "fastest": fastest,
           "percent_of_raw": 100.0 * one_ray / s,
           "percent_of_fastest": fastest.as_ref().map_or(f64::NAN, |f| 100.0 * f["seconds"].as_f64().unwrap_or(f64::NAN) / s)})
}

/// Work per stage in the unit that matters for it, from a frame's counts: (unit, amount).
fn work(stage: &str, s: &FrameStats) -> Option<(&'static str, f64)> {
    match stage {
        "trace_vpls" => Some(("M light particles/s", s.light_particles as f64)),
        "shading_points" => Some(("M primary rays/s", s.shading_points as f64)),
        // Points clustered (both clusterings), each through all its k-means iterations: the
        // kernels do not count point-centroid tests (the CPU's search prunes most of them).
        "cluster" => Some(("M points clustered/s", (s.shading_point_hits + s.vpls) as f64)),
        "visibility" => s.visibility_rays.map(|r| ("M shadow rays/s", r as f64)),
        // Every hit shading point against every light (VPL clusters, or VPLs unclustered).
        "shade" => Some((
            "M light evaluations/s",
            s.shading_point_hits as f64 * s.vpl_clusters.max(1) as f64,
        )),
        _ => None,
    }
}

/// One frame on both backends, alternating, `runs` times: median stage times, their ratio and
/// each stage's throughput. Returns the JSON and the last CPU frame.
fn frame_pair(
    name: &str,
    scene: &Scene,
    cs: &CpuScene,
    cfg: &FrameConfig,
    runs: usize,
    gpu: Option<(&vplgi_gpu::GpuContext, &vplgi_gpu::GpuKernels)>,
) -> Result<(Value, Frame)> {
    let (mut cpu_runs, mut gpu_runs) = (Vec::new(), Vec::new());
    let mut last = None;
    let mut gpu_stats = None;
    for r in 0..runs {
        eprintln!(
            "frames: {name} {}x{}, CPU and GPU, run {} of {runs}",
            cfg.width,
            cfg.height,
            r + 1
        );
        let f = vplgi_cpu::render(cs, cfg, &NoProgress)?;
        cpu_runs.push(f.timings.clone());
        last = Some(f);
        if let Some((g, k)) = gpu {
            let f = vplgi_gpu::render(&g.device, &g.queue, k, scene, cfg)?;
            gpu_runs.push(f.timings);
            gpu_stats = Some(f.stats);
        }
    }
    let cpu_frame = last.context("no run")?;
    let cpu_t = StageTimings::median(&cpu_runs);
    let gpu_t = (!gpu_runs.is_empty()).then(|| StageTimings::median(&gpu_runs));
    let stages: Vec<Value> = stage_list(&cpu_t)
        .iter()
        .filter(|(_, c)| *c > 0.0)
        .map(|(stage, c)| {
            let g = gpu_t
                .as_ref()
                .and_then(|g| stage_list(g).into_iter().find(|(n, _)| n == stage).map(|x| x.1));
            // The GPU frame does not count its shadow rays: those of the CPU frame, whose rows and
            // columns it traces too (up to clustering ties), stand in.
            let rate = |stats: &FrameStats, ms: f64| {
                work(stage, stats)
                    .or_else(|| work(stage, &cpu_frame.stats))
                    .map(|(_, n)| n / (ms / 1e3) / 1e6)
            };
            json!({
                "stage": stage, "cpu_ms": c, "gpu_ms": g, "ratio": g.map(|g| g / c),
                "unit": work(stage, &cpu_frame.stats).map(|(u, _)| u),
                "cpu_rate": rate(&cpu_frame.stats, *c),
                "gpu_rate": g.zip(gpu_stats.as_ref()).and_then(|(g, st)| rate(st, g)),
            })
        })
        .collect();
    let value = json!({
        "name": format!("{name} {}x{}", cfg.width, cfg.height),
        "config": {"scene": name, "triangles": scene.triangle_count(), "width": cfg.width, "height": cfg.height, "vpls": cfg.vpls, "k_vpl": cfg.k_vpl, "k_sp": cfg.k_sp, "f": cfg.f},
        "runs": runs,
        "stages": stages,
    });
    Ok((value, cpu_frame))
}

/// The floor: brute-force nearest of 64 centroids for `n` points, the GPU kernel against its
/// rayon twin (vplgi_reports::floor).
fn floor(ctx: &vplgi_gpu::GpuContext, n: usize, runs: usize) -> Result<Value> {
    eprintln!(
        "floor: nearest of {} centroids for {n} points, CPU and GPU",
        vplgi_reports::floor::CENTROIDS
    );
    let mut rng = vplgi_types::Rng::new(2026, vplgi_types::Stream::Oracle, 1);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let points: Vec<Vec3> = (0..n).map(|_| v()).collect();
    let centroids: Vec<Vec3> = (0..vplgi_reports::floor::CENTROIDS).map(|_| v()).collect();
    let cpu = vplgi_reports::floor::cpu(&points, &centroids, runs);
    let gpu = vplgi_reports::floor::gpu(ctx, &points, &centroids, runs)?;
    let agree = cpu.labels.iter().zip(&gpu.labels).filter(|(a, b)| a == b).count();
    Ok(
        json!({"points": n, "centroids": centroids.len(), "cpu_s": cpu.seconds, "gpu_s": gpu.seconds, "ratio": gpu.seconds / cpu.seconds, "labels_agree": agree}),
    )
}

/// The stages and the total, by name.
fn stage_list(t: &StageTimings) -> Vec<(&'static str, f64)> {
    t.iter().map(|(s, ms)| (s.name(), ms)).chain([("total", t.total())]).collect()
}

fn image(w: u32, h: u32, pixels: Vec<[f32; 3]>) -> vplgi_image::Image {
    vplgi_image::Image { width: w, height: h, pixels }
}

fn main() -> Result<()> {
    let opts = Opts::parse();
    let dir = opts.out.parent().map_or_else(|| PathBuf::from("perf"), |p| p.join("perf"));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    if opts.chart_only {
        let history = history::read(&dir.join("history.json"))?;
        let chart = dir.join("history.svg");
        std::fs::write(&chart, history::chart(&history))
            .with_context(|| format!("cannot write {}", chart.display()))?;
        println!("wrote {} from {} runs", chart.display(), history.len());
        return Ok(());
    }
    let started = Instant::now();
    let gpu = match vplgi_gpu::GpuContext::new() {
        Ok(c) => Some(c),
        Err(e) => {
            eprintln!("no GPU adapter ({e}): GPU rows are left out");
            None
        }
    };
    let adapter = gpu.as_ref().map_or("none".to_string(), |g| g.describe());
    let lavapipe = adapter.contains("llvmpipe");
    let mut report = json!({"machine": machine(), "adapter": adapter, "quick": opts.quick});

    // 1. k-means.
    let km = if opts.quick {
        Kmeans { n: 20_000, k: 256, iterations: 3, runs: 1 }
    } else {
        Kmeans { n: 1_000_000, k: 8192, iterations: 10, runs: 3 }
    };
    report["kmeans"] = kmeans(&opts, &km, gpu.as_ref(), &dir)?;

    // 2. visibility against raw Embree.
    let scene = vplgi_scene::cornell::cornell_box();
    let device = vplgi_embree::Device::new(None)?;
    let cs = CpuScene::new(&scene, &device)?;
    eprintln!("visibility against raw Embree");
    report["visibility"] = if opts.quick {
        visibility_vs_embree(&cs, 64, 4, 200, 3)
    } else {
        visibility_vs_embree(&cs, 512, 32, 1000, 7)
    };

    // 3. The floor of the GPU/CPU ratio: a kernel that maps perfectly to SIMT hardware.
    if let Some(g) = &gpu {
        report["floor"] =
            floor(g, if opts.quick { 100_000 } else { 4_000_000 }, if opts.quick { 1 } else { 5 })?;
    }

    // 4 and 5. Frames, CPU and GPU alternating: the paper-size Cornell box and the generated
    // conference room; then the Cornell box's unclustered reference.
    let clustered = if opts.quick {
        FrameConfig {
            width: 64,
            height: 64,
            vpls: 500,
            k_vpl: 50,
            k_sp: 200,
            ..FrameConfig::default()
        }
    } else {
        FrameConfig::default()
    };
    let reference = FrameConfig { cluster: vplgi_types::ClusterMode::None, ..clustered.clone() };
    let runs = if opts.quick { 1 } else { 3 };
    let kernels = gpu.as_ref().map(|g| vplgi_gpu::GpuKernels::new(&g.device)).transpose()?;
    let gpu_pair = gpu.as_ref().zip(kernels.as_ref());
    let (cornell, cpu_frame) = frame_pair("cornell-box", &scene, &cs, &clustered, runs, gpu_pair)?;
    let conference_scene =
        vplgi_scene::generate::generate("conference", if opts.quick { 20_000 } else { 300_000 })
            .map_err(anyhow::Error::msg)?;
    let conference_cs = CpuScene::new(&conference_scene, &device)?;
    let (w, h) = if opts.quick { (64, 45) } else { (256, 180) };
    let conference_cfg = FrameConfig { width: w, height: h, ..clustered.clone() };
    let (conference, _) = frame_pair(
        "conference",
        &conference_scene,
        &conference_cs,
        &conference_cfg,
        runs,
        gpu_pair,
    )?;
    report["frames"] = json!([cornell, conference]);
    let cpu_pixels = cpu_frame.pixels;
    eprintln!("frames: the unclustered reference (CPU)");
    let t0 = Instant::now();
    let rf = vplgi_cpu::render(&cs, &reference, &NoProgress)?;
    let cornell_cpu_ms = report["frames"][0]["stages"]
        .as_array()
        .and_then(|ss| ss.iter().find(|s| s["stage"] == "total"))
        .map_or(f64::NAN, |s| f(&s["cpu_ms"]));
    let ref_s = secs(t0);
    let (w, h) = (clustered.width, clustered.height);
    let (ref_img, test_img) = (image(w, h, rf.pixels), image(w, h, cpu_pixels));
    let cmp = vplgi_image::compare(&ref_img, &test_img)?;
    vplgi_image::write_png(&dir.join("reference.png"), &ref_img, 1.0)?;
    vplgi_image::write_png(&dir.join("clustered.png"), &test_img, 1.0)?;
    vplgi_image::write_error_map(&dir.join("error_map.png"), &cmp)?;
    report["approximation"] = json!({
        "reference_s": ref_s, "reference_visibility_s": rf.timings.get(Stage::Visibility) / 1e3, "clustered_s": cornell_cpu_ms / 1e3,
        "speedup": ref_s / (cornell_cpu_ms / 1e3), "mse": cmp.metrics.mse, "rel_mse": cmp.metrics.rel_mse, "flip": cmp.metrics.flip,
    });
    report["wall_s"] = json!(secs(started));

    let json_path = dir.join("perf.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&report)? + "\n")
        .with_context(|| format!("cannot write {}", json_path.display()))?;
    let history = vplgi_reports::history::append(
        &dir.join("history.json"),
        vplgi_reports::history::entry(&report),
    )?;
    let chart = dir.join("history.svg");
    std::fs::write(&chart, vplgi_reports::history::chart(&history))
        .with_context(|| format!("cannot write {}", chart.display()))?;
    report["history"] = json!(history);
    let md = markdown(&report, lavapipe, &opts, &dir)?;
    std::fs::write(&opts.out, md)
        .with_context(|| format!("cannot write {}", opts.out.display()))?;
    println!("wrote {} and {} in {:.0} s", opts.out.display(), json_path.display(), secs(started));
    Ok(())
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// The report; a hand-written `optimisations.md` in `dir` (what was made faster, before and
/// after) is appended.
fn markdown(r: &Value, lavapipe: bool, opts: &Opts, dir: &Path) -> Result<String> {
    let m = &r["machine"];
    let mut s = String::new();
    writeln!(s, "# Performance\n")?;
    writeln!(
        s,
        "Generated by `make perf-report` ({}) on {}, commit {}.",
        if opts.quick { "**--quick: small sizes, not a measurement**" } else { "full sizes" },
        m["date"].as_str().unwrap_or("?"),
        m["commit"].as_str().unwrap_or("?")
    )?;
    writeln!(
        s,
        "Machine: {}, {} threads, {} GiB. GPU adapter: {}.",
        m["cpu"].as_str().unwrap_or("?"),
        m["threads"],
        m["memory_gib"],
        r["adapter"].as_str().unwrap_or("none")
    )?;
    if lavapipe {
        writeln!(s, "The adapter is **Mesa lavapipe**, software Vulkan on the same CPU cores: GPU figures here say how GPU-friendly a kernel is, not how fast a GPU runs it.")?;
    }
    writeln!(
        s,
        "Every time is a median of runs taken in this one process; ratios compare runs taken side by side. Raw numbers: [perf/perf.json](perf/perf.json).\n"
    )?;

    let k = &r["kmeans"];
    writeln!(s, "## k-means against faiss-cpu\n")?;
    writeln!(s, "{} points (positions uniform in the unit cube, unit normals), K = {}, {} iterations, the normal test of Eq. 7 disabled: plain Euclidean k-means on positions. MSE is the mean squared distance of a point to its final centroid; median of {} runs.\n", k["points"], k["k"], k["iterations"], k["runs"])?;
    writeln!(s, "| implementation | time (s) | MSE | time / faiss time |\n|---|---:|---:|---:|")?;
    let rows = k["rows"].as_array().cloned().unwrap_or_default();
    let faiss_s = rows
        .iter()
        .find(|x| x["name"].as_str().unwrap_or("").starts_with("faiss"))
        .map(|x| f(&x["seconds"]));
    for row in &rows {
        let ratio =
            faiss_s.map_or("–".to_string(), |fs| format!("{:.2}×", f(&row["seconds"]) / fs));
        writeln!(
            s,
            "| {} | {:.2} | {:.3e} | {ratio} |",
            row["name"].as_str().unwrap_or("?"),
            f(&row["seconds"]),
            f(&row["mse"])
        )?;
    }

    let v = &r["visibility"];
    writeln!(s, "\n## visibility against raw Embree\n")?;
    writeln!(
        s,
        "Cornell box: {} shading points x {} VPLs, {} shadow rays (facing pairs) traced by the `visibility` stage and by bare parallel loops of Embree's queries over the very same rays: `rtcOccluded1` one ray at a time, and `rtcOccludedN` over packets of N consecutive rays (one shading point toward N VPLs, Embree's coherent case); all find the same visible pairs. Runs interleaved, median of each.\n",
        v["rows"], v["cols"], v["rays"]
    )?;
    writeln!(
        s,
        "| | time (ms) | Mrays/s | stage throughput, % of this loop's |\n|---|---:|---:|---:|"
    )?;
    writeln!(
        s,
        "| `visibility` stage (packets of {}) | {:.1} | {:.2} | – |",
        v["stage_width"],
        f(&v["stage_s"]) * 1e3,
        f(&v["stage_mrays"])
    )?;
    for q in v["raw"].as_array().into_iter().flatten() {
        writeln!(
            s,
            "| raw `{}` loop | {:.1} | {:.2} | {:.1} % |",
            q["query"].as_str().unwrap_or("?"),
            f(&q["seconds"]) * 1e3,
            f(&q["mrays"]),
            f(&q["percent"])
        )?;
    }
    writeln!(
        s,
        "\nThe fastest raw loop is `{}`; the stage runs at **{:.1} %** of its throughput (target: at least 95 % of raw Embree) and at {:.1} % of the one-ray loop's.",
        v["fastest"]["query"].as_str().unwrap_or("?"),
        f(&v["percent_of_fastest"]),
        f(&v["percent_of_raw"]),
    )?;

    writeln!(s, "\n## GPU against CPU, per stage\n")?;
    writeln!(s, "Wall time of each stage inside a frame (`--cluster both`), median of runs alternating CPU and GPU, and each stage's throughput in its own unit (the counts of each backend's frame over its time; the GPU does not count shadow rays, so its rays/s use the CPU frame's count). Targets: every stage at most {}× the CPU's time, the whole frame at most {}×.", history::STAGE_RATIO_TARGET, history::FRAME_RATIO_TARGET)?;
    let fl = &r["floor"];
    if fl.is_object() {
        writeln!(
            s,
            "\n**The floor.** The simplest kernel that maps perfectly to SIMT hardware (every point tests the same {} centroids in the same order: no divergence, no gathers, no private arrays; `reports/src/floor.rs`) takes **{:.2}×** its rayon twin's time for {} points ({:.1} ms against {:.1} ms; {} of {} labels agree). On lavapipe that ratio is what the adapter costs by itself; a stage's ratio above it is the kernel's.",
            fl["centroids"], f(&fl["ratio"]), fl["points"], f(&fl["gpu_s"]) * 1e3, f(&fl["cpu_s"]) * 1e3, fl["labels_agree"], fl["points"]
        )?;
    }
    for fr in r["frames"].as_array().cloned().unwrap_or_default() {
        let c = &fr["config"];
        writeln!(
            s,
            "\n### {} ({} triangles)\n\n{}x{}, {} VPLs, {} / {} VPL / SP clusters, F = {}, median of {} runs.\n",
            c["scene"].as_str().unwrap_or("?"),
            c["triangles"],
            c["width"],
            c["height"],
            c["vpls"],
            c["k_vpl"],
            c["k_sp"],
            c["f"],
            fr["runs"]
        )?;
        writeln!(s, "| stage | CPU (ms) | GPU (ms) | GPU / CPU | CPU throughput | GPU throughput |\n|---|---:|---:|---:|---:|---:|")?;
        for st in fr["stages"].as_array().cloned().unwrap_or_default() {
            let g = st["gpu_ms"].as_f64().map_or("–".into(), |g| format!("{g:.1}"));
            let ratio = st["ratio"].as_f64().map_or("–".into(), |x| format!("{x:.2}×"));
            let unit = st["unit"].as_str().unwrap_or("");
            let rate = |v: &Value| v.as_f64().map_or("–".into(), |x| format!("{x:.1} {unit}"));
            writeln!(
                s,
                "| {} | {:.1} | {g} | {ratio} | {} | {} |",
                st["stage"].as_str().unwrap_or("?"),
                f(&st["cpu_ms"]),
                rate(&st["cpu_rate"]),
                rate(&st["gpu_rate"])
            )?;
        }
    }

    let a = &r["approximation"];
    writeln!(s, "\n## Clustered against the reference\n")?;
    writeln!(s, "The same frame unclustered (`--cluster none`, every shading point against every VPL) and clustered, on the CPU.\n")?;
    writeln!(s, "| | time (s) | speed-up | MSE | relMSE | FLIP |\n|---|---:|---:|---:|---:|---:|")?;
    writeln!(s, "| reference (`none`) | {:.1} | 1× | – | – | – |", f(&a["reference_s"]))?;
    writeln!(
        s,
        "| clustered (`both`) | {:.2} | **{:.1}×** | {:.2e} | {:.2e} | {:.4} |",
        f(&a["clustered_s"]),
        f(&a["speedup"]),
        f(&a["mse"]),
        f(&a["rel_mse"]),
        f(&a["flip"])
    )?;
    writeln!(s, "\nThe paper reports 14.5× on its Cornell box and 16× at MSE 1.8e-3 on its conference room, measured with CUDA and OptiX on a GPU.\n")?;
    writeln!(s, "| reference | clustered | FLIP error map |\n|---|---|---|\n| ![reference](perf/reference.png) | ![clustered](perf/clustered.png) | ![error](perf/error_map.png) |")?;

    writeln!(s, "\n## Over time\n")?;
    writeln!(s, "Every `make perf-report` adds its ratios to [perf/history.json](perf/history.json) (with its commit), charted here; dashed lines are the targets.\n\n![ratios over time](perf/history.svg)\n")?;
    writeln!(s, "| commit | date | frame GPU / CPU | k-means speed-up over faiss | visibility, % of Embree's one-ray loop | visibility, % of its fastest loop |\n|---|---|---|---:|---:|---:|")?;
    let hist = r["history"].as_array().cloned().unwrap_or_default();
    for e in hist.iter().rev().take(10) {
        let frames: Vec<String> = e["frames"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|fr| {
                Some(format!("{}: {:.2}×", fr["name"].as_str()?, fr["ratios"]["total"].as_f64()?))
            })
            .collect();
        let quick = if e["quick"] == Value::Bool(true) { " (--quick)" } else { "" };
        let num = |v: &Value, suffix: &str| {
            v.as_f64().map_or("–".into(), |x| format!("{x:.2}{suffix}"))
        };
        writeln!(
            s,
            "| {}{quick} | {} | {} | {} | {} | {} |",
            e["commit"].as_str().unwrap_or("?"),
            e["date"].as_str().unwrap_or("?"),
            frames.join("; "),
            num(&e["kmeans_speedup_over_faiss"], "×"),
            num(&e["visibility_percent_of_embree"], " %"),
            num(&e["visibility_percent_of_fastest_embree"], " %")
        )?;
    }

    if let Ok(text) = std::fs::read_to_string(dir.join("optimisations.md")) {
        writeln!(s, "\n{}", text.trim_end())?;
    }
    Ok(s)
}
