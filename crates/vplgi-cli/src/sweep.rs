//! `vplgi sweep`: the paper's Figures 7, 9 and 11 for a scene. Figure 7 varies the number of
//! shading-point clusters (VPLs unclustered), Figure 9 the number of VPL clusters (shading points
//! unclustered), Figure 11 both. Each is drawn as PNG and SVG charts (stage times and image error,
//! against MSE and against FLIP); every configuration's image and FLIP error map go into one
//! contact sheet, and every number into sweep.json. `--figure variants` sets the core paper's
//! choices for clustering shading points beside Wang et al.'s (metric, representative, seeding) at each
//! shading-point cluster count, charted at equal time and at equal count. `--figure flicker` renders
//! each variant along the scene's camera animation with `--temporal` off and on, and charts the
//! clustering's own flicker: the change between frames that the unclustered sequence lacks.

use crate::engine::{with_engine, BackendArg, Engine};
use crate::frame_args::{FrameArgs, SWEEP};
use crate::plot::{contact_sheet, heatmap, stacked_bars, variant_lines, Bar, Series, Tile};
use crate::shared::{load_scene, write_json};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::io::IsTerminal;
use std::path::PathBuf;
use vplgi_frame::{NoProgress, StageTimings};
use vplgi_image::{compare, error_map_rgb8, tonemap_srgb8, Image};
use vplgi_scene::Camera;
use vplgi_types::{
    ClusterMode, FrameConfig, Seeding, ShadeMode, SpMetric, SpRepresentative, Temporal,
};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Debug)]
enum Figure {
    /// Time and error against the number of shading-point clusters (`--cluster sp`).
    #[value(name = "7")]
    Seven,
    /// Time and error against the number of VPL clusters (`--cluster vpl`).
    #[value(name = "9")]
    Nine,
    /// Time and error over both counts (`--cluster both`).
    #[value(name = "11")]
    Eleven,
    /// Error against time and against the shading-point cluster count for each of --variants
    /// (`--cluster sp`): the two papers' choices side by side.
    #[value(name = "variants")]
    Variants,
    /// The clustering's own flicker along the scene's camera animation (--frames frames) for
    /// each of --variants with --temporal off and on, against frame time and the shading-point
    /// cluster count (`--cluster sp`): the change between frames that the unclustered sequence
    /// of the same path does not have.
    #[value(name = "flicker")]
    Flicker,
}

/// One set of shading-point choices of `--figure variants`, over the sweep's frame options.
#[derive(Clone, Debug)]
struct Variant {
    name: String,
    metric: Option<SpMetric>,
    representative: Option<SpRepresentative>,
    seeding: Option<Seeding>,
    shade: Option<ShadeMode>,
}

impl Variant {
    fn apply(&self, cfg: FrameConfig) -> FrameConfig {
        FrameConfig {
            metric: self.metric.unwrap_or(cfg.metric),
            representative: self.representative.unwrap_or(cfg.representative),
            seeding: self.seeding.unwrap_or(cfg.seeding),
            shade: self.shade.unwrap_or(cfg.shade),
            ..cfg
        }
    }
}

/// `ward+min-error+adaptive`: option values joined by `+`, at most one per option.
fn parse_variant(s: &str) -> Result<Variant, String> {
    let mut v = Variant {
        name: s.to_string(),
        metric: None,
        representative: None,
        seeding: None,
        shade: None,
    };
    for token in s.split('+') {
        let twice = |what: &str| format!("`{s}` names the {what} twice");
        if let Ok(m) = SpMetric::from_str(token, true) {
            if v.metric.replace(m).is_some() {
                return Err(twice("metric"));
            }
        } else if let Ok(r) = SpRepresentative::from_str(token, true) {
            if v.representative.replace(r).is_some() {
                return Err(twice("representative"));
            }
        } else if let Ok(x) = Seeding::from_str(token, true) {
            if v.seeding.replace(x).is_some() {
                return Err(twice("seeding"));
            }
        } else if let Ok(x) = ShadeMode::from_str(token, true) {
            if v.shade.replace(x).is_some() {
                return Err(twice("shade"));
            }
        } else {
            return Err(format!(
                "`{token}` in `{s}` is not a --metric (eq7, ward), --representative (nearest, min-error), --seeding (stride, adaptive) or --shade (fuzzy, interpolate)"
            ));
        }
    }
    Ok(v)
}

#[derive(Args)]
pub struct SweepArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Figures to make.
    #[arg(long = "figure", value_enum, num_args = 1.., default_values = ["7", "9", "11"])]
    figures: Vec<Figure>,
    /// Shading-point cluster counts (Figures 7 and 11), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [2000u32, 4000, 8000, 16000, 30000])]
    sp_clusters: Vec<u32>,
    /// VPL cluster counts (Figures 9 and 11), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [500u32, 1000, 1500, 2000, 2500])]
    vpl_clusters: Vec<u32>,
    /// With --figure variants: the shading-point choices compared, comma-separated; each joins
    /// values of --metric, --representative, --seeding and --shade with `+` (what is left out
    /// comes from the frame options). The default sets the core paper's choices, Wang et al.'s
    /// with and without their interpolation, and each half of Wang et al.'s clustering alone.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = parse_variant,
        default_value = "eq7+nearest+stride+fuzzy,ward+min-error+adaptive+interpolate,ward+min-error+adaptive+fuzzy,eq7+nearest+adaptive+fuzzy,ward+min-error+stride+fuzzy"
    )]
    variants: Vec<Variant>,
    /// With --figure flicker: frames along the scene's camera animation (glTF, or `vplgi scene
    /// generate NAME --camera-walk K`), at least 2.
    #[arg(long, default_value_t = 9)]
    frames: u32,
    /// Where the clustered frames run. The reference is always rendered by the CPU reference.
    #[arg(long, value_enum, default_value = "cpu")]
    backend: BackendArg,
    /// Renders per configuration; stage times are the median over them.
    #[arg(long, default_value_t = 1)]
    runs: usize,
    /// The unclustered reference (an EXR of the same size) instead of rendering one.
    #[arg(long, value_name = "EXR")]
    reference: Option<PathBuf>,
    #[command(flatten)]
    frame: FrameArgs,
    /// Output directory: sweep.json, fig*.png/svg, variants-*.png/svg, flicker.png/svg,
    /// contact_sheet.png, configs/*/.
    #[arg(long, value_name = "DIR", default_value = "out/sweep")]
    out: PathBuf,
}

/// One configuration of a figure.
struct Config {
    figure: Figure,
    label: String,
    cfg: FrameConfig,
    /// The variant's name (`--figure variants`).
    variant: Option<String>,
}

/// One sequence of `--figure flicker`: a variant at one count, with --temporal off or on.
struct SequenceConfig {
    label: String,
    /// The chart's line: the variant's name, with ` +temporal` when on.
    series: String,
    cfg: FrameConfig,
}

/// What a sequence measured.
struct SequenceMeasured {
    /// Mean relative change between consecutive frames.
    flicker: f64,
    /// Mean change the unclustered sequence does not have (`vplgi_image::excess_change`).
    own_flicker: f64,
    ms_per_frame: f64,
    tile: Tile,
}

/// What a configuration measured.
struct Measured {
    timings: StageTimings,
    mse: f64,
    rel_mse: f64,
    flip: f64,
    tile: Tile,
}

fn configs(args: &SweepArgs, base: &FrameConfig) -> Vec<Config> {
    let mut out = Vec::new();
    for &figure in &args.figures {
        match figure {
            Figure::Seven => out.extend(args.sp_clusters.iter().map(|&k| Config {
                figure,
                label: format!("fig7-sp{k}"),
                cfg: FrameConfig { cluster: ClusterMode::Sp, k_sp: k, ..base.clone() },
                variant: None,
            })),
            Figure::Nine => out.extend(args.vpl_clusters.iter().map(|&k| Config {
                figure,
                label: format!("fig9-vpl{k}"),
                cfg: FrameConfig { cluster: ClusterMode::Vpl, k_vpl: k, ..base.clone() },
                variant: None,
            })),
            Figure::Eleven => {
                for &s in &args.sp_clusters {
                    for &v in &args.vpl_clusters {
                        out.push(Config {
                            figure,
                            label: format!("fig11-sp{s}-vpl{v}"),
                            cfg: FrameConfig {
                                cluster: ClusterMode::Both,
                                k_sp: s,
                                k_vpl: v,
                                ..base.clone()
                            },
                            variant: None,
                        });
                    }
                }
            }
            Figure::Variants => {
                for v in &args.variants {
                    out.extend(args.sp_clusters.iter().map(|&k| Config {
                        figure,
                        label: format!("variants-sp{k}-{}", v.name),
                        cfg: v.apply(FrameConfig {
                            cluster: ClusterMode::Sp,
                            k_sp: k,
                            ..base.clone()
                        }),
                        variant: Some(v.name.clone()),
                    }));
                }
            }
            Figure::Flicker => {}
        }
    }
    out
}

fn sequences(args: &SweepArgs, base: &FrameConfig) -> Vec<SequenceConfig> {
    if !args.figures.contains(&Figure::Flicker) {
        return Vec::new();
    }
    let mut out = Vec::new();
    for v in &args.variants {
        for temporal in [Temporal::Off, Temporal::On] {
            let series = if temporal == Temporal::On {
                format!("{} +temporal", v.name)
            } else {
                v.name.clone()
            };
            out.extend(args.sp_clusters.iter().map(|&k| SequenceConfig {
                label: format!("flicker-sp{k}-{}", series.replace(" +", "+")),
                series: series.clone(),
                cfg: v.apply(FrameConfig {
                    cluster: ClusterMode::Sp,
                    k_sp: k,
                    temporal,
                    ..base.clone()
                }),
            }));
        }
    }
    out
}

pub fn run(args: SweepArgs) -> Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    for (name, list) in
        [("--sp-clusters", &args.sp_clusters), ("--vpl-clusters", &args.vpl_clusters)]
    {
        if list.is_empty() || list.contains(&0) {
            bail!("{name} needs one or more counts above 0");
        }
    }
    let base = args.frame.config(&SWEEP)?;
    let configs = configs(&args, &base);
    let sequences = sequences(&args, &base);
    for (label, cfg) in configs
        .iter()
        .map(|c| (&c.label, &c.cfg))
        .chain(sequences.iter().map(|c| (&c.label, &c.cfg)))
    {
        cfg.validate().map_err(|e| anyhow::anyhow!("configuration {label}: {e}"))?;
    }
    if !sequences.is_empty() && args.frames < 2 {
        bail!("--frames {}: --figure flicker measures the change between frames, so it needs at least 2", args.frames);
    }
    crate::plot::ensure_font()?;
    let (scene, source) = load_scene(args.scene.as_deref())?;
    let cameras = match (&scene.camera_path, sequences.is_empty()) {
        (_, true) => Vec::new(),
        (Some(path), false) => path.frames(args.frames).map_err(|e| anyhow::anyhow!("{source}: camera path: {e}"))?,
        (None, false) => bail!(
            "{source} has no camera animation, which --figure flicker follows: animate the camera node (translation / rotation channels), or generate a scene with one: vplgi scene generate conference --camera-walk 5"
        ),
    };
    let given = match &args.reference {
        Some(path) => {
            let img = vplgi_image::read_exr(path)?;
            if (img.width, img.height) != (base.width, base.height) {
                bail!(
                    "{}: the reference is {}x{}, the sweep renders {}x{} (set --width/--height)",
                    path.display(),
                    img.width,
                    img.height,
                    base.width,
                    base.height
                );
            }
            Some(img)
        }
        None => None,
    };
    std::fs::create_dir_all(args.out.join("configs"))
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    // The reference: given, or rendered by the CPU reference (and kept beside the sweep).
    let (reference, reference_ms) = match given {
        Some(img) => (img, None),
        // Sequences only: the single-frame reference is not needed.
        None if configs.is_empty() => (Image { width: 0, height: 0, pixels: Vec::new() }, None),
        None => {
            eprintln!(
                "rendering the unclustered reference ({}x{}, {} VPLs) on the CPU",
                base.width, base.height, base.vpls
            );
            let reference = FrameConfig { cluster: ClusterMode::None, ..base.clone() };
            let f = with_engine(BackendArg::Cpu, &scene, &source, |engine| {
                engine.render(&reference, &crate::progress::Bars::new())
            })?;
            let img = Image { width: base.width, height: base.height, pixels: f.pixels };
            std::fs::create_dir_all(args.out.join("reference"))?;
            vplgi_image::write_exr(&args.out.join("reference/image.exr"), &img)?;
            vplgi_image::write_png(&args.out.join("reference/image.png"), &img, 1.0)?;
            (img, Some(f.timings.total()))
        }
    };
    // The reference time belongs on the charts only when it was measured on the sweep's backend.
    let reference_line = if args.backend == BackendArg::Cpu { reference_ms } else { None };
    // --figure flicker: the unclustered sequence of the same path, on the CPU like the reference.
    let converged: Vec<Image> = if sequences.is_empty() {
        Vec::new()
    } else {
        eprintln!(
            "rendering the unclustered sequence ({} frames along the camera animation) on the CPU",
            cameras.len()
        );
        let unclustered = FrameConfig { cluster: ClusterMode::None, ..base.clone() };
        let mut images = Vec::with_capacity(cameras.len());
        with_engine(BackendArg::Cpu, &scene, &source, |engine| {
            engine.walk(&unclustered, &cameras, None, &crate::progress::Bars::new(), |_, f| {
                images.push(Image { width: base.width, height: base.height, pixels: f.pixels });
                Ok(())
            })
        })?;
        images
    };
    let converged_flicker = mean(
        &converged
            .windows(2)
            .map(|w| vplgi_image::relative_change(&w[0], &w[1]))
            .collect::<Result<Vec<_>, _>>()?,
    );

    let (measured, sequence_measured, backend_name) =
        with_engine(args.backend, &scene, &source, |engine| {
            let total = configs.len() + sequences.len();
            let bar = if std::io::stderr().is_terminal() {
                ProgressBar::new(total as u64)
            } else {
                ProgressBar::hidden()
            };
            if let Ok(style) =
                ProgressStyle::with_template("{msg:>26} [{bar:40}] {pos}/{len} ({eta} left)")
            {
                bar.set_style(style.progress_chars("=> "));
            }
            let mut measured = Vec::new();
            for c in &configs {
                bar.set_message(c.label.clone());
                if bar.is_hidden() {
                    eprintln!("sweep: {} ({} of {total})", c.label, measured.len() + 1);
                }
                let mut runs = Vec::new();
                let mut pixels = Vec::new();
                for _ in 0..args.runs {
                    let f = engine.render(&c.cfg, &NoProgress)?;
                    runs.push(f.timings);
                    pixels = f.pixels;
                }
                let img = Image { width: base.width, height: base.height, pixels };
                let cmp = compare(&reference, &img)?;
                let dir = args.out.join("configs").join(&c.label);
                std::fs::create_dir_all(&dir)?;
                vplgi_image::write_exr(&dir.join("image.exr"), &img)?;
                vplgi_image::write_png(&dir.join("image.png"), &img, 1.0)?;
                vplgi_image::write_error_map(&dir.join("error_map.png"), &cmp)?;
                let timings = StageTimings::median(&runs);
                let tile = Tile {
                    label: format!(
                        "{}  {:.0} ms  MSE {:.1e}  FLIP {:.3}",
                        c.label,
                        timings.total(),
                        cmp.metrics.mse,
                        cmp.metrics.flip
                    ),
                    width: img.width,
                    height: img.height,
                    image: tonemap_srgb8(&img, 1.0),
                    error_map: error_map_rgb8(&c.label, &cmp)?,
                };
                measured.push(Measured {
                    timings,
                    mse: cmp.metrics.mse,
                    rel_mse: cmp.metrics.rel_mse,
                    flip: cmp.metrics.flip,
                    tile,
                });
                bar.inc(1);
            }
            let mut sequence_measured = Vec::new();
            for c in &sequences {
                bar.set_message(c.label.clone());
                if bar.is_hidden() {
                    eprintln!(
                        "sweep: {} ({} of {total}, {} frames)",
                        c.label,
                        measured.len() + sequence_measured.len() + 1,
                        cameras.len()
                    );
                }
                sequence_measured
                    .push(measure_sequence(engine, c, &cameras, &converged, &args.out)?);
                bar.inc(1);
            }
            bar.finish_and_clear();
            Ok((measured, sequence_measured, engine.name))
        })?;

    let backend = if backend_name == "gpu" { " (GPU)" } else { "" };
    let of = |f: Figure| -> Vec<(&Config, &Measured)> {
        configs.iter().zip(&measured).filter(|(c, _)| c.figure == f).collect()
    };
    let mut charts = Vec::new();
    for (metric, name) in [("mse", "MSE"), ("flip", "FLIP")] {
        let err = |m: &Measured| if metric == "mse" { m.mse } else { m.flip };
        for (fig, what, x_desc) in [
            (Figure::Seven, "shading-point clusters (VPLs unclustered)", "shading-point clusters"),
            (Figure::Nine, "VPL clusters (shading points unclustered)", "VPL clusters"),
        ] {
            let rows = of(fig);
            if rows.is_empty() {
                continue;
            }
            let bars: Vec<Bar> = rows
                .iter()
                .map(|(c, m)| Bar {
                    label: if fig == Figure::Seven { c.cfg.k_sp } else { c.cfg.k_vpl }.to_string(),
                    stages: m.timings.iter().map(|(s, ms)| (s.name(), ms)).collect(),
                    error: err(m),
                })
                .collect();
            let n = if fig == Figure::Seven { 7 } else { 9 };
            let stem = args.out.join(format!("fig{n}-{metric}"));
            stacked_bars(
                &stem,
                &format!("{}: time and {name} against {what}{backend}", scene.name),
                x_desc,
                &bars,
                name,
                reference_line,
            )?;
            charts.push(stem.with_extension("png"));
        }
        let rows = of(Figure::Variants);
        if !rows.is_empty() {
            // Configurations are made variant by variant, each over every count.
            let series: Vec<Series> = rows
                .chunks(args.sp_clusters.len())
                .map(|chunk| Series {
                    name: chunk[0].0.variant.clone().unwrap_or_default(),
                    error: chunk.iter().map(|(_, m)| err(m)).collect(),
                    time_ms: chunk.iter().map(|(_, m)| m.timings.total()).collect(),
                })
                .collect();
            let stem = args.out.join(format!("variants-{metric}"));
            let title = format!(
                "{}: {name} of shading-point clustering variants, --cluster sp{backend}",
                scene.name
            );
            variant_lines(
                &stem,
                &title,
                &args.sp_clusters,
                "shading-point clusters",
                &series,
                name,
            )?;
            charts.push(stem.with_extension("png"));
        }
        if metric == "flip" && !sequences.is_empty() {
            // Sequences are made series by series (variant, then --temporal off and on), each over every count.
            let series: Vec<Series> = sequences
                .chunks(args.sp_clusters.len())
                .zip(sequence_measured.chunks(args.sp_clusters.len()))
                .map(|(c, m)| Series {
                    name: c[0].series.clone(),
                    error: m.iter().map(|m| m.own_flicker).collect(),
                    time_ms: m.iter().map(|m| m.ms_per_frame).collect(),
                })
                .collect();
            let stem = args.out.join("flicker");
            let title = format!(
                "{}: the clustering's own flicker along {} frames, --cluster sp{backend}",
                scene.name,
                cameras.len()
            );
            variant_lines(
                &stem,
                &title,
                &args.sp_clusters,
                "shading-point clusters",
                &series,
                "change the unclustered sequence lacks",
            )?;
            charts.push(stem.with_extension("png"));
        }
        let rows = of(Figure::Eleven);
        if !rows.is_empty() {
            let (ns, nv) = (args.sp_clusters.len(), args.vpl_clusters.len());
            let grid = |f: &dyn Fn(&Measured) -> f64| -> Vec<Vec<f64>> {
                (0..ns).map(|j| (0..nv).map(|i| f(rows[j * nv + i].1)).collect()).collect()
            };
            let stem = args.out.join(format!("fig11-{metric}"));
            heatmap(
                &stem,
                &format!("{}: frame time and {name} over both cluster counts{backend}", scene.name),
                &args.vpl_clusters,
                &args.sp_clusters,
                &grid(&|m| m.timings.total()),
                &grid(&|m| err(m)),
                name,
            )?;
            charts.push(stem.with_extension("png"));
        }
    }
    let tiles: Vec<Tile> = measured
        .iter()
        .map(|m| &m.tile)
        .chain(sequence_measured.iter().map(|m| &m.tile))
        .map(|t| Tile {
            label: t.label.clone(),
            width: t.width,
            height: t.height,
            image: t.image.clone(),
            error_map: t.error_map.clone(),
        })
        .collect();
    let sheet = args.out.join("contact_sheet.png");
    contact_sheet(&sheet, &tiles, 3, 240)?;

    let report = json!({
        "vplgi_version": env!("CARGO_PKG_VERSION"),
        "scene": { "source": source, "name": scene.name, "triangles": scene.triangle_count() },
        "backend": backend_name,
        "runs": args.runs,
        "base": base,
        "reference": { "exr": args.reference.clone().unwrap_or_else(|| args.out.join("reference/image.exr")), "total_ms": reference_ms, "backend": "cpu" },
        "configs": configs.iter().zip(&measured).map(|(c, m)| json!({
            "label": c.label, "figure": format!("{:?}", c.figure).to_lowercase(), "cluster": c.cfg.cluster, "k_sp": c.cfg.k_sp, "k_vpl": c.cfg.k_vpl,
            "variant": c.variant, "metric": c.cfg.metric, "representative": c.cfg.representative, "seeding": c.cfg.seeding, "shade": c.cfg.shade, "alpha": c.cfg.alpha,
            "timings_ms": m.timings, "mse": m.mse, "rel_mse": m.rel_mse, "flip": m.flip,
            "image": args.out.join("configs").join(&c.label).join("image.png"), "error_map": args.out.join("configs").join(&c.label).join("error_map.png"),
        })).collect::<Vec<_>>(),
        "sequences": sequences.iter().zip(&sequence_measured).map(|(c, m)| json!({
            "label": c.label, "series": c.series, "k_sp": c.cfg.k_sp, "temporal": c.cfg.temporal, "metric": c.cfg.metric,
            "representative": c.cfg.representative, "seeding": c.cfg.seeding, "shade": c.cfg.shade, "alpha": c.cfg.alpha,
            "frames": cameras.len(), "ms_per_frame": m.ms_per_frame, "flicker": m.flicker, "own_flicker": m.own_flicker,
            "last_frame": args.out.join("configs").join(&c.label).join("image.png"),
        })).collect::<Vec<_>>(),
        "converged_flicker": converged_flicker,
    });
    write_json(&args.out.join("sweep.json"), &report)?;
    println!(
        "{} configurations of {} ({}x{}, {} VPLs)",
        configs.len() + sequences.len(),
        scene.name,
        base.width,
        base.height,
        base.vpls
    );
    if let Some(c) = converged_flicker {
        println!("flicker along {} frames: unclustered {:.2} %; the clustering's own, per sequence, in sweep.json and flicker.png", cameras.len(), 100.0 * c);
    }
    println!("charts (PNG, and SVG beside each):");
    for c in &charts {
        println!("  {}", c.display());
    }
    println!(
        "contact sheet: {}\nnumbers: {}",
        sheet.display(),
        args.out.join("sweep.json").display()
    );
    Ok(())
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Renders one sequence of `--figure flicker` along `cameras`, keeping only the frame before,
/// and measures its flicker and the part of it `converged` (the unclustered sequence) lacks.
/// Its last frame and that frame's error map go to `out/configs/LABEL/`.
fn measure_sequence(
    engine: &Engine,
    c: &SequenceConfig,
    cameras: &[Camera],
    converged: &[Image],
    out: &std::path::Path,
) -> Result<SequenceMeasured> {
    let (mut changes, mut excess, mut ms) = (Vec::new(), Vec::new(), Vec::new());
    let mut previous: Option<Image> = None;
    engine.walk(&c.cfg, cameras, None, &NoProgress, |i, f| {
        let img = Image { width: c.cfg.width, height: c.cfg.height, pixels: f.pixels };
        ms.push(f.timings.total());
        if let Some(p) = &previous {
            changes.push(vplgi_image::relative_change(p, &img)?);
            excess.push(vplgi_image::excess_change(p, &img, (&converged[i - 1], &converged[i]))?);
        }
        previous = Some(img);
        Ok(())
    })?;
    let last = previous.context("a sequence of no frames")?;
    let cmp = compare(&converged[converged.len() - 1], &last)?;
    let dir = out.join("configs").join(&c.label);
    std::fs::create_dir_all(&dir)?;
    vplgi_image::write_png(&dir.join("image.png"), &last, 1.0)?;
    vplgi_image::write_error_map(&dir.join("error_map.png"), &cmp)?;
    let (flicker, own_flicker, ms_per_frame) =
        (mean(&changes).unwrap_or(0.0), mean(&excess).unwrap_or(0.0), mean(&ms).unwrap_or(0.0));
    Ok(SequenceMeasured {
        flicker,
        own_flicker,
        ms_per_frame,
        tile: Tile {
            label: format!(
                "{}  {ms_per_frame:.0} ms/frame  own flicker {:.2} %",
                c.label,
                100.0 * own_flicker
            ),
            width: last.width,
            height: last.height,
            image: tonemap_srgb8(&last, 1.0),
            error_map: error_map_rgb8(&c.label, &cmp)?,
        },
    })
}
