//! `vplgi render`: one frame on either backend, written as EXR, PNG and report.json; or, with
//! `--frames N`, a sequence along the scene's camera path, each frame written as it is done.

use crate::engine::{with_engine, BackendArg};
use crate::frame_args::{FrameArgs, RENDER};
use crate::progress::Bars;
use crate::shared::{
    install_interrupt_cleanup, load_scene, peak_rss_mib, use_shaders_from, write_json,
};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use vplgi_frame::{Clusters, GClamp, KernelTime, Outputs, Report, SceneInfo, Setup, Stage};

#[derive(Args)]
pub struct RenderArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Where the frame runs.
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: BackendArg,
    #[command(flatten)]
    frame: FrameArgs,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// With `--backend gpu`: time every GPU kernel with timestamp queries, print them by cost and
    /// add them to report.json as `gpu_profile`.
    #[arg(long)]
    profile: bool,
    /// With `--backend gpu`: WGSL read from DIR, laid out like `shaders/` (a file present there
    /// replaces the built-in copy), so an edited kernel is rendered and timed (with --profile)
    /// without rebuilding vplgi. `--shaders shaders` in a checkout.
    #[arg(long, value_name = "DIR")]
    shaders: Option<PathBuf>,
    /// Exposure applied before tonemapping the PNG.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Render a sequence of N frames along the scene's camera animation (glTF translation and
    /// rotation channels of the camera node; `vplgi scene generate NAME --camera-walk K` makes
    /// one), at evenly spaced times from its first key to its last. Frames are written as they
    /// are done (frame-0000.exr and .png, ...), with sequence.json: per-frame times and the
    /// sequence's flicker, the mean relative change between consecutive frames (compare it with
    /// the same sequence rendered --cluster none, and measure on --lighting indirect).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// With --frames: the --out of a converged sequence along the same path (the same --frames,
    /// size and --lighting, rendered --cluster none or as a reference). Each frame's change that
    /// the converged sequence does not have (camera motion cancels) is added to sequence.json
    /// as `excess_change`, and its mean as `temporal_error`: the approximation's own flicker.
    #[arg(long, value_name = "DIR", requires = "frames")]
    flicker_reference: Option<PathBuf>,
    /// With --frames: move the lights along the sequence. The scene's punctual lights (point,
    /// spot, directional: the sun) turn about the vertical axis through the centre of the scene's
    /// bounds, evenly from 0 degrees at the first frame to DEGREES at the last; the scene is
    /// built anew for each frame (emissive surfaces stay). A scene without a camera animation is
    /// then seen from its camera throughout. `vplgi scene generate sunlit-living-room` has a sun
    /// to move; with --temporal on and --vpl-cluster rsm, each frame's clusters start from the
    /// previous frame's (the sun's patch of light moves, the clusters follow).
    #[arg(long, value_name = "DEGREES", requires = "frames", allow_negative_numbers = true)]
    light_orbit: Option<f32>,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "out/render")]
    out: PathBuf,
}

pub fn run(args: RenderArgs) -> Result<()> {
    // Checked before any work (the frame driver checks again), so a typo fails fast.
    let cfg = args.frame.config(&RENDER)?;
    if args.profile && args.backend == BackendArg::Cpu {
        bail!("--profile times GPU kernels: use it with --backend gpu (CPU stage times are in every report.json)");
    }
    if args.shaders.is_some() && args.backend == BackendArg::Cpu {
        bail!("--shaders replaces GPU kernels: use it with --backend gpu");
    }
    use_shaders_from(args.shaders.as_deref())?;
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("configuring the thread pool")?;
    }
    let t_load = Instant::now();
    let (scene, source) = load_scene(args.scene.as_deref())?;
    let load_ms = t_load.elapsed().as_secs_f64() * 1e3;

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    install_interrupt_cleanup(args.out.clone());

    crate::shared::warn_without_caustics(&scene, &source, &cfg);
    let light_sampler = vplgi_scene::lights::LightSampler::new(&scene);
    if !light_sampler.has_lights() {
        eprintln!("warning: {source} has no light (no emissive triangle, no punctual light): the image will be black");
    }
    if let Some(n) = args.frames {
        if args.profile {
            bail!("--profile times one frame: leave out --frames");
        }
        return render_sequence(&args, &cfg, &scene, &source, n);
    }
    let mut profile = None;
    let (frame, backend, adapter, setup_ms) =
        with_engine(args.backend, &scene, &source, |engine| {
            let bars = Bars::new();
            let frame = match engine.gpu {
                Some(ctx) if args.profile => {
                    let (frame, by_kernel) =
                        vplgi_gpu::timing::device_time_by_kernel(&ctx.device, &ctx.queue, || {
                            engine.render(&cfg, &bars)
                        })?;
                    match by_kernel {
                        Some(k) => profile = Some(k),
                        None => eprintln!(
                            "note: {} has no timestamp queries: no kernel profile",
                            ctx.describe()
                        ),
                    }
                    frame?
                }
                _ => engine.render(&cfg, &bars)?,
            };
            Ok((frame, engine.name, engine.adapter.clone(), engine.setup_ms))
        })?;

    let image = vplgi_image::Image { width: cfg.width, height: cfg.height, pixels: frame.pixels };
    let exr = args.out.join("image.exr");
    let png = args.out.join("image.png");
    let json = args.out.join("report.json");
    vplgi_image::write_exr(&exr, &image)?;
    vplgi_image::write_png(&png, &image, args.exposure)?;
    let stats = frame.stats;
    let report = Report {
        vplgi_version: env!("CARGO_PKG_VERSION").into(),
        backend: backend.into(),
        adapter,
        threads: rayon::current_num_threads(),
        scene: SceneInfo {
            source: source.clone(),
            name: scene.name.clone(),
            emissive_triangles: light_sampler.emitters.len() as u64,
            punctual_lights: scene.lights.len() as u64,
            extent: scene.extent(),
        },
        triangles: scene.triangle_count() as u64,
        params: cfg.clone(),
        vpls: stats.vpls,
        clusters: Clusters { vpl: stats.vpl_clusters, sp: stats.sp_clusters },
        g_clamp: GClamp {
            relative: cfg.g_clamp_rel,
            d_min: stats.g_clamp_d_min,
            compensated: cfg.bias_compensation && cfg.g_clamp_rel > 0.0,
        },
        stats,
        timings_ms: frame.timings,
        setup_ms: Setup { load: load_ms, scene_build: setup_ms },
        peak_rss_mib: peak_rss_mib(),
        gpu_profile: profile.as_ref().map(|p| {
            p.iter()
                .map(|k| KernelTime {
                    kernel: k.kernel.clone(),
                    passes: k.passes,
                    device_ms: k.time.as_secs_f64() * 1e3,
                })
                .collect()
        }),
        outputs: Outputs { exr: exr.clone(), png: png.clone() },
    };
    write_json(&json, &serde_json::to_value(&report).context("serialising the report")?)?;

    println!(
        "{} ({} triangles), {}x{}, {} VPLs, clusters: {} VPL / {} SP, backend {backend}",
        scene.name,
        scene.triangle_count(),
        cfg.width,
        cfg.height,
        report.vpls,
        report.clusters.vpl,
        report.clusters.sp
    );
    if cfg.has_caustics() {
        let s = &report.stats;
        if s.caustic_photons == 0 {
            println!("caustics: no caustic photons (the scene has no mirror or glass, or no particle met one)");
        } else {
            println!(
                "caustics: {} photons from {} light particles{}",
                s.caustic_photons,
                s.caustic_particles,
                if s.caustic_truncated > 0 {
                    format!(", {} estimates stopped at the visit budget", s.caustic_truncated)
                } else {
                    String::new()
                }
            );
        }
    }
    let t = &report.timings_ms;
    let stages: Vec<String> = Stage::ALL.iter().map(|&s| format!("{s} {:.1}", t.get(s))).collect();
    println!("timings (ms): {}, total {:.1}", stages.join(", "), t.total());
    if let Some(p) = &profile {
        let total: f64 = p.iter().map(|k| k.time.as_secs_f64()).sum();
        println!("GPU kernels by device time (timestamp queries; {:.1} ms in all):", total * 1e3);
        println!("  {:>10} {:>6} {:>7}  kernel", "ms", "%", "passes");
        for k in p {
            let ms = k.time.as_secs_f64() * 1e3;
            println!(
                "  {ms:>10.1} {:>5.1}% {:>7}  {}",
                100.0 * ms / (total * 1e3).max(1e-9),
                k.passes,
                k.kernel
            );
        }
    }
    println!("wrote {}\n      {}\n      {}", exr.display(), png.display(), json.display());
    Ok(())
}

/// One frame of a sequence, as sequence.json lists it.
#[derive(serde::Serialize)]
struct SequenceFrame {
    frame: u32,
    exr: PathBuf,
    png: PathBuf,
    camera_position: [f32; 3],
    camera_forward: [f32; 3],
    total_ms: f64,
    vpl_clusters: u32,
    sp_clusters: u32,
    /// With --temporal on: of those, the previous frame's clusters kept and the new ones.
    sp_kept: u32,
    sp_fresh: u32,
    /// With --temporal on and --vpl-cluster rsm: the previous frame's VPL clusters kept, and the
    /// slots seeded anew.
    vpl_kept: u32,
    vpl_fresh: u32,
    /// With --light-orbit: how far the lights have turned, degrees.
    light_degrees: Option<f32>,
    /// Relative change from the frame before (`vplgi_image::relative_change`); none for the first.
    change: Option<f64>,
    /// With --flicker-reference: the change the converged sequence does not have
    /// (`vplgi_image::excess_change`).
    excess_change: Option<f64>,
}

/// `--frames N`: the camera path sampled at N times, each frame rendered, written and dropped
/// (only the previous image is kept, for the change between frames), then sequence.json.
fn render_sequence(
    args: &RenderArgs,
    cfg: &vplgi_frame::FrameConfig,
    scene: &vplgi_scene::Scene,
    source: &str,
    n: u32,
) -> Result<()> {
    let orbit = args.light_orbit;
    if let Some(d) = orbit {
        if !d.is_finite() {
            bail!("--light-orbit must be a finite number of degrees (got {d})");
        }
        if scene.lights.is_empty() {
            bail!("{source} has no punctual light for --light-orbit to move (its emissive surfaces stay where they are): try vplgi scene generate sunlit-living-room");
        }
    }
    let cameras = match (&scene.camera_path, orbit) {
        (Some(path), _) => path.frames(n).map_err(|e| anyhow::anyhow!("{source}: camera path: {e}"))?,
        (None, Some(_)) => vec![scene.camera; n as usize],
        (None, None) => bail!(
            "{source} has no camera animation, which --frames follows: animate the camera node (translation / rotation channels), or generate a scene with one: vplgi scene generate conference --camera-walk 5; or move the lights with --light-orbit DEGREES"
        ),
    };
    let degrees = |i: usize| orbit.map(|d| if n > 1 { d * i as f32 / (n - 1) as f32 } else { 0.0 });
    let lit_scene = |i: usize| scene.with_lights_turned(degrees(i).unwrap_or(0.0));
    let lit: Option<&dyn Fn(usize) -> vplgi_scene::Scene> =
        orbit.map(|_| &lit_scene as &dyn Fn(usize) -> vplgi_scene::Scene);
    // The converged frames are read (and checked) before any work.
    let converged: Option<Vec<vplgi_image::Image>> = args
        .flicker_reference
        .as_ref()
        .map(|dir| {
            (0..n)
                .map(|i| {
                    let path = dir.join(format!("frame-{i:04}.exr"));
                    let img = vplgi_image::read_exr(&path)
                        .with_context(|| format!("--flicker-reference: {}", path.display()))?;
                    if (img.width, img.height) != (cfg.width, cfg.height) {
                        bail!(
                            "--flicker-reference: {} is {}x{}, the sequence {}x{}",
                            path.display(),
                            img.width,
                            img.height,
                            cfg.width,
                            cfg.height
                        );
                    }
                    Ok(img)
                })
                .collect::<Result<Vec<_>>>()
        })
        .transpose()?;
    let span = scene.camera_path.as_ref().map(|p| p.span());
    let mut frames = Vec::with_capacity(n as usize);
    let mut previous: Option<vplgi_image::Image> = None;
    let clock = Instant::now();
    let (backend, adapter) = with_engine(args.backend, scene, source, |engine| {
        engine.walk(cfg, &cameras, lit, &Bars::new(), |i, frame| {
            let camera = &cameras[i];
            let image =
                vplgi_image::Image { width: cfg.width, height: cfg.height, pixels: frame.pixels };
            let exr = args.out.join(format!("frame-{i:04}.exr"));
            let png = args.out.join(format!("frame-{i:04}.png"));
            vplgi_image::write_exr(&exr, &image)?;
            vplgi_image::write_png(&png, &image, args.exposure)?;
            let change =
                previous.as_ref().map(|p| vplgi_image::relative_change(p, &image)).transpose()?;
            let excess_change = match (&previous, &converged) {
                (Some(p), Some(c)) => {
                    Some(vplgi_image::excess_change(p, &image, (&c[i - 1], &c[i]))?)
                }
                _ => None,
            };
            let total_ms = frame.timings.total();
            eprintln!(
                "frame {}/{n}: {total_ms:.0} ms{}",
                i + 1,
                change.map_or(String::new(), |c| format!(
                    ", {:.2} % changed from the frame before",
                    100.0 * c
                ))
            );
            frames.push(SequenceFrame {
                frame: i as u32,
                exr,
                png,
                camera_position: camera.position.to_array(),
                camera_forward: camera.forward.to_array(),
                total_ms,
                vpl_clusters: frame.stats.vpl_clusters,
                sp_clusters: frame.stats.sp_clusters,
                sp_kept: frame.stats.sp_kept,
                sp_fresh: frame.stats.sp_fresh,
                vpl_kept: frame.stats.vpl_kept,
                vpl_fresh: frame.stats.vpl_fresh,
                light_degrees: degrees(i),
                change,
                excess_change,
            });
            previous = Some(image);
            Ok(())
        })?;
        Ok((engine.name, engine.adapter.clone()))
    })?;
    let changes: Vec<f64> = frames.iter().filter_map(|f| f.change).collect();
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let flicker = mean(&changes);
    let excess: Vec<f64> = frames.iter().filter_map(|f| f.excess_change).collect();
    let temporal_error = mean(&excess);
    let converged_flicker = converged.as_ref().and_then(|c| {
        let changes: Vec<f64> =
            c.windows(2).filter_map(|w| vplgi_image::relative_change(&w[0], &w[1]).ok()).collect();
        mean(&changes)
    });
    let json = args.out.join("sequence.json");
    let report = serde_json::json!({
        "vplgi_version": env!("CARGO_PKG_VERSION"),
        "backend": backend,
        "adapter": adapter,
        "scene": source,
        "params": cfg,
        "path_seconds": span.map(|(a, b)| [a, b]),
        "light_orbit_degrees": orbit,
        "frames": frames,
        "flicker": flicker,
        "flicker_reference": args.flicker_reference,
        "converged_flicker": converged_flicker,
        "temporal_error": temporal_error,
        "seconds": clock.elapsed().as_secs_f64(),
    });
    write_json(&json, &report)?;
    match flicker {
        Some(f) => {
            println!(
                "{n} frames of {} ({}x{}), flicker (mean relative change between frames) {:.2} %",
                scene.name,
                cfg.width,
                cfg.height,
                100.0 * f
            );
            if let (Some(c), Some(t)) = (converged_flicker, temporal_error) {
                println!("  converged sequence {:.2} %; change it does not have (temporal error) {:.2} %", 100.0 * c, 100.0 * t);
            }
        }
        None => println!("1 frame of {} ({}x{})", scene.name, cfg.width, cfg.height),
    }
    println!(
        "wrote {} .. {}\n      {}",
        frames[0].png.display(),
        frames[frames.len() - 1].png.display(),
        json.display()
    );
    Ok(())
}
