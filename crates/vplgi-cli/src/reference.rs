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
use vplgi_image::Image;
use vplgi_types::FrameConfig;

#[derive(Args)]
pub struct ReferenceArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Independent renders, with seeds --seed, --seed + 1, ...; the mean and the per-pixel
    /// variance are taken over them (at least 2).
    #[arg(long, default_value_t = 8)]
    seeds: u32,
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
    let (i, n): (u32, u32) = (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    if i == 0 || i > n {
        return Err(bad());
    }
    Ok((i, n))
}

/// Rows of tile `i` of `n` (1-based).
fn tile_rows(i: u32, n: u32, height: u32) -> std::ops::Range<u32> {
    ((i - 1) as u64 * height as u64 / n as u64) as u32..(i as u64 * height as u64 / n as u64) as u32
}

pub fn run(args: ReferenceArgs) -> Result<()> {
    if args.seeds < 2 {
        bail!("--seeds {}: the per-pixel variance needs at least 2 seeds", args.seeds);
    }
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
    let rows = tile_rows(index, count, base.height);
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let device = vplgi_embree::Device::new(None)?;
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).with_context(|| format!("building the Embree scene for {source}"))?;

    let started = Instant::now();
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(args.seeds as u64) } else { ProgressBar::hidden() };
    if let Ok(style) = ProgressStyle::with_template("reference seeds [{bar:40}] {pos}/{len} ({eta} left)") {
        bar.set_style(style.progress_chars("=> "));
    }
    let seeds: Vec<u32> = (0..args.seeds).map(|k| base.seed.wrapping_add(k)).collect();
    let mut renders = Vec::new();
    for &seed in &seeds {
        let f = vplgi_cpu::render_rows(&cs, &FrameConfig { seed, ..base.clone() }, rows.clone(), &vplgi_cpu::NoProgress)?;
        renders.push(f.pixels);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let (mean, variance) = mean_and_variance(&renders);
    let h = rows.end - rows.start;
    let mean = Image { width: base.width, height: h, pixels: mean };
    let variance = Image { width: base.width, height: h, pixels: variance };
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
    });
    write_json(&args.out.join("reference.json"), &sidecar)?;
    let what = if count > 1 { format!("tile {index}/{count} (rows {}..{}) of ", rows.start, rows.end) } else { String::new() };
    println!("{what}{} reference: {} seeds x {} VPLs, {}x{}, {wall:.1} s", scene.name, args.seeds, base.vpls, base.width, base.height);
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
    Ok(())
}

/// Per pixel and channel, in seed order: the mean, and the sample variance (n - 1), in f64.
fn mean_and_variance(renders: &[Vec<[f32; 3]>]) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let n = renders.len() as f64;
    let pixels = renders.first().map_or(0, |r| r.len());
    let mut mean = Vec::with_capacity(pixels);
    let mut var = Vec::with_capacity(pixels);
    for i in 0..pixels {
        let m: [f64; 3] = std::array::from_fn(|c| renders.iter().map(|r| r[i][c] as f64).sum::<f64>() / n);
        let v: [f64; 3] = std::array::from_fn(|c| renders.iter().map(|r| (r[i][c] as f64 - m[c]).powi(2)).sum::<f64>() / (n - 1.0));
        mean.push(m.map(|x| x as f32));
        var.push(v.map(|x| x as f32));
    }
    (mean, var)
}

fn read_sidecar(dir: &Path) -> Result<Value> {
    let path = dir.join("reference.json");
    let text = std::fs::read_to_string(&path).with_context(|| format!("{}: not a reference folder (no reference.json)", dir.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: malformed JSON", path.display()))
}

pub fn merge(args: MergeArgs) -> Result<()> {
    let mut tiles = Vec::new();
    for dir in &args.tiles {
        let s = read_sidecar(dir)?;
        let t = &s["tile"];
        let (Some(i), Some(n), Some(r0), Some(r1)) = (t["index"].as_u64(), t["count"].as_u64(), t["rows"][0].as_u64(), t["rows"][1].as_u64()) else {
            bail!("{}: not a tile (reference.json has no tile; render with --tile I/N)", dir.display());
        };
        tiles.push((i, n, r0 as u32, r1 as u32, dir.clone(), s));
    }
    tiles.sort_by_key(|t| t.0);
    let first = &tiles[0].5;
    // Everything but the tile and the timing must agree.
    let key = |s: &Value| json!([s["scene"]["hash"], s["params"], s["seeds"], s["width"], s["height"], s["tile"]["count"], s["commit"]]);
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
    let (width, height) = (first["width"].as_u64().unwrap_or(0) as u32, first["height"].as_u64().unwrap_or(0) as u32);
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
                bail!("{}: {}x{}, expected {}x{} for rows {r0}..{r1}", dir.join(name).display(), img.width, img.height, width, r1 - r0);
            }
            into.extend(img.pixels);
        }
        next_row = *r1;
    }
    if next_row != height {
        bail!("the tiles cover rows 0..{next_row} of {height}");
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let mean = Image { width, height, pixels: mean };
    vplgi_image::write_exr(&args.out.join("mean.exr"), &mean)?;
    vplgi_image::write_exr(&args.out.join("variance.exr"), &Image { width, height, pixels: variance })?;
    vplgi_image::write_png(&args.out.join("mean.png"), &mean, 1.0)?;
    let mut sidecar = first.clone();
    sidecar["tile"] = Value::Null;
    sidecar["wall_time_s"] = json!(tiles.iter().map(|t| t.5["wall_time_s"].as_f64().unwrap_or(0.0)).sum::<f64>());
    sidecar["merged_from"] = json!(tiles.iter().map(|t| t.4.display().to_string()).collect::<Vec<_>>());
    write_json(&args.out.join("reference.json"), &sidecar)?;
    println!("joined {n} tiles into {}x{}: {}", width, height, args.out.join("mean.exr").display());
    Ok(())
}
