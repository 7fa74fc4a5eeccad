//! `make results`: the paper's table reproduced on the three generated scenes, and on the Cornell
//! boxes with a mirror wall and sphere and with glass (not in the paper), written to
//! `docs/RESULTS.md` (numbers also in `docs/results/results.json`, thumbnails in
//! `docs/results/`, full-size images under `target/results/`).
//!
//! For each scene at the paper's resolution and VPL count: the unclustered reference (CPU), then
//! the paper's light, intermediate and high-quality cluster settings (0.75k/1k, 2k/8k, 4k/30k VPL
//! / SP clusters) on the CPU and on the GPU (lavapipe where there is no GPU). Every frame is one
//! `vplgi render` process, so its peak resident memory is its own. Scenes are generated once
//! and cached under `target/results/scenes/`. About 30 minutes of CPU frames and references and
//! 25 of GPU frames on lavapipe; `--cpu-only` skips the GPU.

use anyhow::{Context, Result};
use clap::Parser;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use vplgi_frame::Report;
use vplgi_reports::run;

#[derive(Parser)]
#[command(about = "Reproduces the paper's table on the generated scenes; writes docs/RESULTS.md")]
struct Opts {
    /// The report; thumbnails and numbers go to results/ beside it.
    #[arg(long, default_value = "docs/RESULTS.md")]
    out: PathBuf,
    /// The vplgi binary.
    #[arg(long, default_value = "target/release/vplgi")]
    vplgi: PathBuf,
    /// Small scenes and images: a check that it runs, not the table.
    #[arg(long)]
    quick: bool,
    /// Render no GPU frames (they take about 25 minutes on lavapipe).
    #[arg(long)]
    cpu_only: bool,
    /// Reuse frames already rendered in the work folder (a report.json is there) instead of
    /// rendering them again: for finishing an interrupted run with the same code.
    #[arg(long)]
    reuse: bool,
    /// Where the scenes and full-size frames go [default: target/results, or
    /// target/results-quick with --quick].
    #[arg(long)]
    work: Option<PathBuf>,
    /// Only these scenes (comma-separated); the report keeps the other scenes' rows of the last
    /// one, each dated with its own commit [default: all].
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
}

struct SceneSpec {
    name: &'static str,
    width: u32,
    height: u32,
    vpls: u32,
    triangles: usize,
    paper: &'static str,
}

const CONFIGS: [(&str, u32, u32); 3] =
    [("light", 750, 1000), ("intermediate", 2000, 8000), ("high", 4000, 30000)];

/// A JSON file read as `T` (the typed `Report` of a `vplgi render`, or a plain `Value`).
fn json_of<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    serde_json::from_slice(
        &std::fs::read(path).with_context(|| format!("reading {}", path.display()))?,
    )
    .with_context(|| format!("parsing {}", path.display()))
}

/// A 256-pixel-wide PNG thumbnail of a PNG.
fn thumbnail(from: &Path, to: &Path) -> Result<()> {
    let img = image::open(from).with_context(|| format!("reading {}", from.display()))?.into_rgb8();
    let (w, h) = img.dimensions();
    let tw = 256.min(w);
    let th = (h as u64 * tw as u64 / w as u64).max(1) as u32;
    let rgb = vplgi_image::resize_rgb8(img.as_raw(), (w, h), (tw, th));
    vplgi_image::write_rgb8_png(to, tw, th, &rgb)?;
    Ok(())
}

fn main() -> Result<()> {
    let o = Opts::parse();
    let q = o.quick;
    let scenes = [
        SceneSpec {
            name: "cornell-fine",
            width: if q { 64 } else { 1024 },
            height: if q { 64 } else { 1024 },
            vpls: if q { 500 } else { 5000 },
            triangles: if q { 20_000 } else { 1_900_000 },
            paper: "Cornell box, 1.9 M triangles, 1024x1024, 5,000 VPLs",
        },
        SceneSpec {
            name: "conference",
            width: if q { 64 } else { 1024 },
            height: if q { 45 } else { 720 },
            vpls: if q { 500 } else { 8000 },
            triangles: if q { 20_000 } else { 300_000 },
            paper: "conference room, 331 k triangles, 1024x720, 8,000 VPLs",
        },
        SceneSpec {
            name: "living-room",
            width: if q { 64 } else { 1024 },
            height: if q { 45 } else { 720 },
            vpls: if q { 500 } else { 10_000 },
            triangles: if q { 20_000 } else { 300_000 },
            paper: "living room, 313 k triangles, 1024x720, 10,000 VPLs",
        },
        SceneSpec {
            name: "cornell-mirror",
            width: if q { 64 } else { 512 },
            height: if q { 64 } else { 512 },
            vpls: if q { 500 } else { 5000 },
            triangles: if q { 2_000 } else { 20_000 },
            paper: "none: the Cornell box with a mirror back wall and a mirror sphere, seen and lit through the mirrors (`--specular-depth` 6)",
        },
        SceneSpec {
            name: "cornell-glass",
            width: if q { 64 } else { 512 },
            height: if q { 64 } else { 512 },
            vpls: if q { 500 } else { 5000 },
            triangles: if q { 2_000 } else { 20_000 },
            paper: "none: the Cornell box with a closed glass cube and sphere, seen and lit through the glass",
        },
        SceneSpec {
            name: "cornell-glossy",
            width: if q { 64 } else { 512 },
            height: if q { 64 } else { 512 },
            vpls: if q { 500 } else { 5000 },
            triangles: if q { 2_000 } else { 20_000 },
            paper: "none: the Cornell box with rough metal objects of roughness 0.6, 0.3 and 0.1 (GGX α 0.36, 0.09 and 0.01), lit and seen through their lobes",
        },
    ];
    if let Some(bad) = o.scenes.iter().find(|n| !scenes.iter().any(|sc| sc.name == n.as_str())) {
        anyhow::bail!(
            "--scenes: unknown scene {bad:?} (known: {})",
            scenes.iter().map(|sc| sc.name).collect::<Vec<_>>().join(", ")
        );
    }
    let configs: Vec<(&str, u32, u32)> = if q {
        CONFIGS.iter().map(|&(n, v, s)| (n, v / 25, s / 25)).collect()
    } else {
        CONFIGS.to_vec()
    };
    let work = o.work.clone().unwrap_or_else(|| {
        PathBuf::from(if q { "target/results-quick" } else { "target/results" })
    });
    let docs = o.out.parent().map_or_else(|| PathBuf::from("results"), |p| p.join("results"));
    std::fs::create_dir_all(&docs)?;
    let vplgi = |args: &[&str]| -> Result<()> { run(Command::new(&o.vplgi).args(args)) };
    let mut rows = Vec::new();
    let (date, commit) = vplgi_reports::date_and_commit()?;
    for sc in
        scenes.iter().filter(|sc| o.scenes.is_empty() || o.scenes.iter().any(|n| n == sc.name))
    {
        let glb = work.join("scenes").join(format!("{}-{}.glb", sc.name, sc.triangles));
        if vplgi_reports::scene_is_stale(&glb, &o.vplgi) {
            eprintln!("generating {} ({} triangles)", sc.name, sc.triangles);
            vplgi(&[
                "scene",
                "generate",
                sc.name,
                "--triangles",
                &sc.triangles.to_string(),
                "--out",
                glb.to_str().unwrap_or_default(),
            ])?;
        }
        let dir = work.join(sc.name);
        let (w, h, v) = (sc.width.to_string(), sc.height.to_string(), sc.vpls.to_string());
        let render = |out: &Path, extra: &[&str]| -> Result<Report> {
            let mut args = vec![
                "render",
                glb.to_str().unwrap_or_default(),
                "--width",
                &w,
                "--height",
                &h,
                "--vpls",
                &v,
                "--out",
                out.to_str().unwrap_or_default(),
            ];
            args.extend_from_slice(extra);
            if !(o.reuse && out.join("report.json").exists()) {
                vplgi(&args)?;
            }
            json_of::<Report>(&out.join("report.json"))
        };
        eprintln!("{}: the unclustered reference", sc.name);
        let ref_dir = dir.join("reference");
        let reference = render(&ref_dir, &["--cluster", "none"])?;
        thumbnail(&ref_dir.join("image.png"), &docs.join(format!("{}-reference.png", sc.name)))?;
        let mut frames = vec![
            json!({"config": "reference", "backend": "cpu", "ms": reference.timings_ms.total(), "rss_mib": reference.peak_rss_mib, "triangles": reference.triangles}),
        ];
        for &(config, k_vpl, k_sp) in &configs {
            for backend in ["cpu", "gpu"] {
                if backend == "gpu" && o.cpu_only {
                    continue;
                }
                eprintln!("{}: {config} on the {backend}", sc.name);
                let out = dir.join(format!("{config}-{backend}"));
                let r = render(
                    &out,
                    &[
                        "--cluster",
                        "both",
                        "--k-vpl",
                        &k_vpl.to_string(),
                        "--k-sp",
                        &k_sp.to_string(),
                        "--backend",
                        backend,
                    ],
                )?;
                vplgi(&[
                    "compare",
                    ref_dir.join("image.exr").to_str().unwrap_or_default(),
                    out.join("image.exr").to_str().unwrap_or_default(),
                    "--out",
                    out.to_str().unwrap_or_default(),
                ])?;
                let c: Value = json_of(&out.join("compare.json"))?;
                if backend == "cpu" {
                    thumbnail(
                        &out.join("image.png"),
                        &docs.join(format!("{}-{config}.png", sc.name)),
                    )?;
                    thumbnail(
                        &out.join("error_map.png"),
                        &docs.join(format!("{}-{config}-error.png", sc.name)),
                    )?;
                }
                frames.push(json!({"config": config, "backend": backend, "k_vpl": k_vpl, "k_sp": k_sp, "ms": r.timings_ms.total(), "rss_mib": r.peak_rss_mib, "mse": c["mse"], "flip": c["flip"], "adapter": r.adapter.as_ref().map(|a| a.name.clone())}));
            }
        }
        rows.push(json!({"scene": sc.name, "paper": sc.paper, "width": sc.width, "height": sc.height, "vpls": sc.vpls, "frames": frames, "date": date, "commit": commit}));
    }
    let order: Vec<&str> = scenes.iter().map(|sc| sc.name).collect();
    let rows = vplgi_reports::with_earlier_rows(
        rows,
        &order,
        &docs.join("results.json"),
        &["date", "commit"],
    )?;
    let report = json!({"quick": q, "date": date, "commit": commit, "scenes": rows});
    std::fs::write(docs.join("results.json"), serde_json::to_string_pretty(&report)? + "\n")?;
    std::fs::write(&o.out, markdown(&report)?)?;
    println!("wrote {} and {}", o.out.display(), docs.join("results.json").display());
    Ok(())
}

/// The adapter the GPU frames ran on, or a note that there were none.
fn gpu_adapter(r: &Value) -> String {
    let scenes = r["scenes"].as_array().cloned().unwrap_or_default();
    let adapter = scenes
        .iter()
        .flat_map(|sc| sc["frames"].as_array().cloned().unwrap_or_default())
        .find(|x| x["backend"] == "gpu")
        .and_then(|x| x["adapter"].as_str().map(str::to_string));
    adapter.unwrap_or_else(|| "no adapter: this run had --cpu-only".into())
}

fn markdown(r: &Value) -> Result<String> {
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mut s = String::new();
    writeln!(s, "# Results: the paper's table on the generated scenes\n")?;
    writeln!(
        s,
        "{} Each scene's section names the commit it was rendered at (`--scenes` reruns some and keeps the rest). The scenes come from `vplgi scene generate` (see the README). Numbers: [results/results.json](results/results.json); full-size images under `target/results/` after a run.\n",
        vplgi_reports::generated_by("results", r, "table")
    )?;
    writeln!(s, "Every frame is one `vplgi render` process on this machine's 2 cores: time is the frame's total (`timings_ms.total`), memory the process's peak resident set (scene, acceleration structure, buffers; on the GPU also lavapipe's). GPU frames (backend `gpu`) ran on **{}**: where that is Mesa lavapipe, software Vulkan on the same two cores, their times say nothing about a real GPU. Speed-up is over the reference, which is rendered on the CPU only; MSE and FLIP are against it. Peak memory is given for every frame of both backends (cornell-fine is at its paper resolution, 1024x1024, not 1024x720). [PERFORMANCE.md](PERFORMANCE.md) compares the backends stage by stage on the Cornell box.\n", gpu_adapter(r))?;
    for sc in r["scenes"].as_array().cloned().unwrap_or_default() {
        writeln!(
            s,
            "## {} ({}x{}, {} VPLs)\n\nThe paper's scene: {}. Rendered on {} at commit {}.\n",
            sc["scene"].as_str().unwrap_or("?"),
            sc["width"],
            sc["height"],
            sc["vpls"],
            sc["paper"].as_str().unwrap_or("?"),
            sc["date"].as_str().unwrap_or("?"),
            sc["commit"].as_str().unwrap_or("?")
        )?;
        writeln!(s, "| setting (VPL / SP clusters) | backend | time (s) | speed-up | peak memory (MiB) | MSE | FLIP |\n|---|---|---:|---:|---:|---:|---:|")?;
        let frames = sc["frames"].as_array().cloned().unwrap_or_default();
        let ref_ms = frames.first().map_or(f64::NAN, |x| f(&x["ms"]));
        for x in &frames {
            let name = if x["config"] == "reference" {
                "reference (none)".to_string()
            } else {
                format!("{} ({} / {})", x["config"].as_str().unwrap_or("?"), x["k_vpl"], x["k_sp"])
            };
            let metric = |k: &str, fmt: fn(f64) -> String| {
                x.get(k).and_then(|v| v.as_f64()).map_or("–".to_string(), fmt)
            };
            let speed = if x["config"] == "reference" {
                "–".to_string()
            } else {
                format!("{:.1}×", ref_ms / f(&x["ms"]))
            };
            writeln!(
                s,
                "| {name} | {} | {:.2} | {speed} | {:.0} | {} | {} |",
                x["backend"].as_str().unwrap_or("?"),
                f(&x["ms"]) / 1e3,
                f(&x["rss_mib"]),
                metric("mse", |v| format!("{v:.2e}")),
                metric("flip", |v| format!("{v:.4}"))
            )?;
        }
        let n = sc["scene"].as_str().unwrap_or("?");
        writeln!(s, "\n| reference | light | intermediate | high |\n|---|---|---|---|")?;
        writeln!(s, "| ![](results/{n}-reference.png) | ![](results/{n}-light.png) | ![](results/{n}-intermediate.png) | ![](results/{n}-high.png) |")?;
        writeln!(s, "| FLIP error maps: | ![](results/{n}-light-error.png) | ![](results/{n}-intermediate-error.png) | ![](results/{n}-high-error.png) |\n")?;
    }
    Ok(s)
}
