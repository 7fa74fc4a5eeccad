//! `vplgi reference` and `vplgi merge`: unclustered reference images as the mean and per-pixel
//! variance of several independent renders (seeds), with a JSON sidecar, optionally cut into
//! row tiles that `merge` joins bit-identically to the single run. With `--cluster`, the same
//! statistics of a clustered configuration: the baseline that regression tests hold clustered
//! frames to (not cut into tiles: a clustering depends on the whole image).

use crate::frame_args::{FrameArgs, REFERENCE};
use crate::shared::{load_scene, write_json};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{json, Value};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vplgi_image::{Image, REL_MSE_EPSILON};
use vplgi_types::FrameConfig;

#[derive(Args)]
pub struct ReferenceArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Independent renders, with seeds --seed, --seed + 1, ...; the mean and the per-pixel
    /// variance are taken over them (at least 2).
    #[arg(long, default_value_t = 8, conflicts_with = "target_error")]
    seeds: u32,
    /// Render seeds until the mean image's relative standard error is at most this, e.g. `0.5%`
    /// or `0.005`, instead of a fixed --seeds. The error is aggregated over the image as the
    /// square root of the relMSE the mean is expected to have against the converged image, from
    /// the per-pixel variances: sqrt(mean over pixels and channels of (variance / seeds) /
    /// (mean^2 + 0.01)), the relMSE of `vplgi compare`. At least 4 seeds; the achieved error (and
    /// the error of each third of the image's mean) is recorded in reference.json.
    #[arg(long, value_name = "ERROR", conflicts_with = "tile")]
    target_error: Option<String>,
    /// With --target-error: stop after this many seeds even if the target is not reached (the
    /// reference is written, and vplgi exits with an error that says how far it got).
    #[arg(long, default_value_t = 256, requires = "target_error")]
    max_seeds: u32,
    #[command(flatten)]
    frame: FrameArgs,
    /// Render only tile I of N: rows (I-1)*H/N .. I*H/N. Join the tiles' folders with
    /// `vplgi merge`; the result is bit-identical to rendering all rows at once.
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    /// Why this reference was made (recorded in reference.json; `make references` requires it).
    #[arg(long)]
    why: Option<String>,
    /// Output directory: mean.exr, variance.exr, mean.png, reference.json.
    #[arg(long, value_name = "DIR", default_value = "out/reference")]
    out: PathBuf,
}

#[derive(Args)]
pub struct MergeArgs {
    /// The tiles' output folders (every tile of one reference, in any order).
    #[arg(required = true, num_args = 1..)]
    tiles: Vec<PathBuf>,
    /// Output directory for the joined reference.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Parses `I/N` (1 <= I <= N).
fn parse_tile(s: &str) -> Result<(u32, u32)> {
    let bad = || anyhow::anyhow!("--tile {s:?}: expected I/N with 1 <= I <= N, e.g. 2/4");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (u32, u32) =
        (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    if i == 0 || i > n {
        return Err(bad());
    }
    Ok((i, n))
}

/// Parses a relative error: `0.5%` or `0.005`, strictly between 0 and 1.
fn parse_error(s: &str) -> Result<f64> {
    let bad =
        || anyhow::anyhow!("--target-error {s:?}: expected a relative error such as 0.5% or 0.005");
    let t = s.trim();
    let e = match t.strip_suffix('%') {
        Some(p) => p.trim().parse::<f64>().map_err(|_| bad())? / 100.0,
        None => t.parse::<f64>().map_err(|_| bad())?,
    };
    if !(e > 0.0 && e < 1.0) {
        return Err(bad());
    }
    Ok(e)
}

/// A target error needs a variance estimate it can trust before it stops: with fewer seeds the
/// sample variance itself is too noisy (its relative spread is about sqrt(2 / (n - 1))).
const MIN_SEEDS: u32 = 4;

/// Rows of tile `i` of `n` (1-based).
fn tile_rows(i: u32, n: u32, height: u32) -> std::ops::Range<u32> {
    ((i - 1) as u64 * height as u64 / n as u64) as u32..(i as u64 * height as u64 / n as u64) as u32
}

pub fn run(args: ReferenceArgs) -> Result<()> {
    if args.seeds < 2 {
        bail!("--seeds {}: the per-pixel variance needs at least 2 seeds", args.seeds);
    }
    let target = args.target_error.as_deref().map(parse_error).transpose()?;
    let (min_seeds, max_seeds) = match target {
        Some(_) if args.max_seeds < MIN_SEEDS => {
            bail!("--max-seeds {}: a target error needs at least {MIN_SEEDS} seeds", args.max_seeds)
        }
        Some(_) => (MIN_SEEDS, args.max_seeds),
        None => (args.seeds, args.seeds),
    };
    let (index, count) = match &args.tile {
        Some(t) => parse_tile(t)?,
        None => (1, 1),
    };
    let mut base = args.frame.config(&REFERENCE)?;
    if base.cluster != vplgi_types::ClusterMode::None && args.frame.bias_compensation.is_none() {
        // The mean of a clustered configuration is a baseline for `render` of that
        // configuration, which keeps the clamp unless told otherwise.
        base.bias_compensation = false;
    }
    if count > 1 && base.cluster != vplgi_types::ClusterMode::None {
        bail!("--tile {index}/{count}: only unclustered references (--cluster none) can be cut into tiles; a clustering depends on the whole image");
    }
    if count > base.height {
        bail!("--tile {index}/{count}: more tiles than the {} rows", base.height);
    }
    let (scene, source) = load_scene(args.scene.as_deref())?;
    crate::shared::warn_without_caustics(&scene, &source, &base);
    let rows = tile_rows(index, count, base.height);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let device = vplgi_embree::Device::new(None)?;
    let cs = vplgi_cpu::CpuScene::new(&scene, &device)
        .with_context(|| format!("building the Embree scene for {source}"))?;

    let started = Instant::now();
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(min_seeds as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) =
        ProgressStyle::with_template("reference [{bar:40}] {pos}/{len} seeds {msg} ({eta} left)")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    let mut stats = Moments::new(base.width, rows.end - rows.start);
    let mut seeds: Vec<u32> = Vec::new();
    let mut error = f64::INFINITY;
    loop {
        let n = seeds.len() as u32;
        let converged = target.is_some_and(|t| n >= min_seeds && error <= t);
        if n >= max_seeds || converged {
            break;
        }
        let seed = base.seed.wrapping_add(n);
        let f = vplgi_cpu::render_rows(
            &cs,
            &FrameConfig { seed, ..base.clone() },
            rows.clone(),
            &vplgi_cpu::NoProgress,
        )?;
        stats.add(&f.pixels);
        seeds.push(seed);
        bar.inc(1);
        if seeds.len() >= 2 {
            error = stats.relative_standard_error();
            bar.set_message(match target {
                Some(t) => format!("error {:.3}% (target {:.3}%)", 100.0 * error, 100.0 * t),
                None => format!("error {:.3}%", 100.0 * error),
            });
        }
        if let Some(t) = target {
            // The error falls as 1/sqrt(seeds): the seeds it will take at this rate, which is
            // what the bar's length and time estimate show.
            let n = seeds.len() as f64;
            let needed =
                if error.is_finite() { (n * (error / t).powi(2)).ceil() as u32 } else { min_seeds };
            bar.set_length(needed.clamp(min_seeds.max(seeds.len() as u32), max_seeds) as u64);
        }
    }
    bar.finish_and_clear();
    let h = rows.end - rows.start;
    let mean = Image { width: base.width, height: h, pixels: stats.mean() };
    let variance = Image { width: base.width, height: h, pixels: stats.variance() };
    let wall = started.elapsed().as_secs_f64();
    vplgi_image::write_exr(&args.out.join("mean.exr"), &mean)?;
    vplgi_image::write_exr(&args.out.join("variance.exr"), &variance)?;
    vplgi_image::write_png(&args.out.join("mean.png"), &mean, 1.0)?;
    let sidecar = json!({
        "vplgi_version": env!("CARGO_PKG_VERSION"),
        "commit": env!("VPLGI_GIT_COMMIT"),
        "scene": { "source": source, "name": scene.name, "triangles": scene.triangle_count(), "hash": format!("{:016x}", scene.content_hash()) },
        "params": base,
        "seeds": seeds,
        "width": base.width,
        "height": base.height,
        "tile": if count > 1 { json!({ "index": index, "count": count, "rows": [rows.start, rows.end] }) } else { Value::Null },
        "wall_time_s": wall,
        "why": args.why,
        "threads": rayon::current_num_threads(),
        "files": { "mean": "mean.exr", "variance": "variance.exr" },
        "variance": "per-pixel sample variance (divided by seeds - 1) of the per-seed renders; the mean's variance is this divided by the number of seeds",
        "error": {
            "relative_standard_error": error,
            "aggregate": ERROR_AGGREGATE,
            "target": target,
            "reached": target.map(|t| error <= t),
            "thirds": if count > 1 { Value::Null } else { json!(stats.thirds_relative_standard_error()) },
            "thirds_per_seed": if count > 1 { Value::Null } else { json!(stats.thirds) },
            "thirds_aggregate": "per third of the image's rows (top, middle, bottom) and channel: the standard error of the third's mean over the seeds, from the spread of the per-seed means (all pixels of a seed share its VPLs, so per-pixel variances cannot give it), relative to the mean",
            "thirds_per_seed_layout": "per seed, in seed order: the mean of each third (rows t*H/3 .. (t+1)*H/3) per channel",
        },
    });
    write_json(&args.out.join("reference.json"), &sidecar)?;
    let what = if count > 1 {
        format!("tile {index}/{count} (rows {}..{}) of ", rows.start, rows.end)
    } else {
        String::new()
    };
    println!(
        "{what}{} reference: {} seeds x {} VPLs, {}x{}, {wall:.1} s, relative standard error {:.3}%",
        scene.name,
        seeds.len(),
        base.vpls,
        base.width,
        base.height,
        100.0 * error
    );
    println!(
        "wrote {}\n      {}\n      {}\n      {}",
        args.out.join("mean.exr").display(),
        args.out.join("variance.exr").display(),
        args.out.join("mean.png").display(),
        args.out.join("reference.json").display()
    );
    if count > 1 {
        println!("join the tiles with: vplgi merge DIR... --out DIR");
    }
    if let Some(t) = target.filter(|&t| error > t) {
        bail!(
            "--target-error {:.3}% not reached: {:.3}% after --max-seeds {} seeds (about {} would do; the reference above holds what was rendered)",
            100.0 * t,
            100.0 * error,
            seeds.len(),
            (seeds.len() as f64 * (error / t).powi(2)).ceil()
        );
    }
    Ok(())
}

/// How reference.json's `error.relative_standard_error` is aggregated.
const ERROR_AGGREGATE: &str = "sqrt of the mean over pixels and channels of (variance / seeds) / (mean^2 + 0.01): \
     the square root of the relMSE (as vplgi compare defines it) that mean.exr is expected to have against the converged image";

/// The aggregate relative standard error of a mean image of `n` seeds from its per-pixel sample
/// variances: the square root of the relMSE expected against the converged image, with the
/// relMSE of `vplgi compare` (per pixel and channel, the squared error over the squared reference
/// plus [`REL_MSE_EPSILON`], averaged).
fn relative_standard_error(
    mean: impl Iterator<Item = [f64; 3]>,
    variance: impl Iterator<Item = [f64; 3]>,
    n: f64,
) -> f64 {
    let (mut sum, mut samples) = (0.0, 0.0);
    for (m, v) in mean.zip(variance) {
        for c in 0..3 {
            sum += v[c] / n / (m[c] * m[c] + REL_MSE_EPSILON);
            samples += 1.0;
        }
    }
    (sum / samples).sqrt()
}

/// Per-pixel running statistics over seeds, in f64 (Welford's update, so the variance keeps its
/// precision however many seeds), and each seed's mean over each third of the rows.
struct Moments {
    width: u32,
    height: u32,
    n: u32,
    mean: Vec<[f64; 3]>,
    m2: Vec<[f64; 3]>,
    thirds: Vec<[[f64; 3]; 3]>,
}

impl Moments {
    fn new(width: u32, height: u32) -> Self {
        let pixels = (width * height) as usize;
        Moments {
            width,
            height,
            n: 0,
            mean: vec![[0.0; 3]; pixels],
            m2: vec![[0.0; 3]; pixels],
            thirds: Vec::new(),
        }
    }

    fn add(&mut self, render: &[[f32; 3]]) {
        self.n += 1;
        let n = self.n as f64;
        for ((x, m), m2) in render.iter().zip(&mut self.mean).zip(&mut self.m2) {
            for c in 0..3 {
                let x = x[c] as f64;
                let d = x - m[c];
                m[c] += d / n;
                m2[c] += d * (x - m[c]);
            }
        }
        let mut thirds = [[0.0; 3]; 3];
        for (t, third) in thirds.iter_mut().enumerate() {
            let (r0, r1) = (t as u32 * self.height / 3, (t as u32 + 1) * self.height / 3);
            let px = &render[(r0 * self.width) as usize..(r1 * self.width) as usize];
            for c in 0..3 {
                third[c] = px.iter().map(|p| p[c] as f64).sum::<f64>() / px.len().max(1) as f64;
            }
        }
        self.thirds.push(thirds);
    }

    fn mean(&self) -> Vec<[f32; 3]> {
        self.mean.iter().map(|m| m.map(|x| x as f32)).collect()
    }

    /// Sample variance (divided by n - 1); zero for a single seed.
    fn variance(&self) -> Vec<[f32; 3]> {
        let d = (self.n.max(2) - 1) as f64;
        self.m2.iter().map(|m| m.map(|x| (x / d) as f32)).collect()
    }

    fn relative_standard_error(&self) -> f64 {
        let d = (self.n.max(2) - 1) as f64;
        relative_standard_error(
            self.mean.iter().copied(),
            self.m2.iter().map(|m| m.map(|x| x / d)),
            self.n as f64,
        )
    }

    /// Per third and channel: the standard error of the third's mean over the seeds, relative to
    /// that mean (infinite below 2 seeds or for a black third).
    fn thirds_relative_standard_error(&self) -> [[f64; 3]; 3] {
        let n = self.thirds.len() as f64;
        std::array::from_fn(|t| {
            std::array::from_fn(|c| {
                let xs = self.thirds.iter().map(|s| s[t][c]);
                let m = xs.clone().sum::<f64>() / n;
                let v = xs.map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
                if n >= 2.0 && m > 0.0 {
                    (v / n).sqrt() / m
                } else {
                    f64::INFINITY
                }
            })
        })
    }
}

fn read_sidecar(dir: &Path) -> Result<Value> {
    let path = dir.join("reference.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!("{}: not a reference folder (no reference.json)", dir.display())
    })?;
    serde_json::from_str(&text).with_context(|| format!("{}: malformed JSON", path.display()))
}

pub fn merge(args: MergeArgs) -> Result<()> {
    let mut tiles = Vec::new();
    for dir in &args.tiles {
        let s = read_sidecar(dir)?;
        let t = &s["tile"];
        let (Some(i), Some(n), Some(r0), Some(r1)) = (
            t["index"].as_u64(),
            t["count"].as_u64(),
            t["rows"][0].as_u64(),
            t["rows"][1].as_u64(),
        ) else {
            bail!(
                "{}: not a tile (reference.json has no tile; render with --tile I/N)",
                dir.display()
            );
        };
        tiles.push((i, n, r0 as u32, r1 as u32, dir.clone(), s));
    }
    tiles.sort_by_key(|t| t.0);
    let first = &tiles[0].5;
    // Everything but the tile and the timing must agree.
    let key = |s: &Value| {
        json!([
            s["scene"]["hash"],
            s["params"],
            s["seeds"],
            s["width"],
            s["height"],
            s["tile"]["count"],
            s["commit"]
        ])
    };
    for t in &tiles[1..] {
        if key(&t.5) != key(first) {
            bail!(
                "{} and {} are tiles of different references (scene, parameters, seeds, size, tile count or commit differ)",
                tiles[0].4.display(),
                t.4.display()
            );
        }
    }
    let n = tiles[0].1;
    let indices: Vec<u64> = tiles.iter().map(|t| t.0).collect();
    if indices != (1..=n).collect::<Vec<_>>() {
        bail!("need each of the {n} tiles exactly once, got tiles {indices:?}");
    }
    let (width, height) =
        (first["width"].as_u64().unwrap_or(0) as u32, first["height"].as_u64().unwrap_or(0) as u32);
    let mut mean = Vec::new();
    let mut variance = Vec::new();
    let mut next_row = 0;
    for (i, _, r0, r1, dir, _) in &tiles {
        if *r0 != next_row {
            bail!("{}: tile {i} starts at row {r0}, expected {next_row}", dir.display());
        }
        for (name, into) in [("mean.exr", &mut mean), ("variance.exr", &mut variance)] {
            let img = vplgi_image::read_exr(&dir.join(name))?;
            if (img.width, img.height) != (width, r1 - r0) {
                bail!(
                    "{}: {}x{}, expected {}x{} for rows {r0}..{r1}",
                    dir.join(name).display(),
                    img.width,
                    img.height,
                    width,
                    r1 - r0
                );
            }
            into.extend(img.pixels);
        }
        next_row = *r1;
    }
    if next_row != height {
        bail!("the tiles cover rows 0..{next_row} of {height}");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let mean = Image { width, height, pixels: mean };
    vplgi_image::write_exr(&args.out.join("mean.exr"), &mean)?;
    vplgi_image::write_exr(
        &args.out.join("variance.exr"),
        &Image { width, height, pixels: variance.clone() },
    )?;
    vplgi_image::write_png(&args.out.join("mean.png"), &mean, 1.0)?;
    let mut sidecar = first.clone();
    let n = first["seeds"].as_array().map_or(0, Vec::len) as f64;
    let widen = |p: &[f32; 3]| p.map(f64::from);
    sidecar["error"]["relative_standard_error"] = json!(relative_standard_error(
        mean.pixels.iter().map(widen),
        variance.iter().map(widen),
        n
    ));
    sidecar["error"]["thirds"] = Value::Null;
    sidecar["error"]["thirds_per_seed"] = Value::Null;
    sidecar["tile"] = Value::Null;
    sidecar["wall_time_s"] =
        json!(tiles.iter().map(|t| t.5["wall_time_s"].as_f64().unwrap_or(0.0)).sum::<f64>());
    sidecar["merged_from"] =
        json!(tiles.iter().map(|t| t.4.display().to_string()).collect::<Vec<_>>());
    write_json(&args.out.join("reference.json"), &sidecar)?;
    println!("joined {n} tiles into {}x{}: {}", width, height, args.out.join("mean.exr").display());
    Ok(())
}
