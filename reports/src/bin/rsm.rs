//! `make rsm`: Prutkin et al. 2012's reflective-shadow-map clusters as lights, measured; written to
//! `docs/RSM.md` (numbers in `docs/rsm/rsm.json`, pictures in `docs/rsm/`).
//!
//! **Quality at equal cluster counts.** On the built-in Cornell box and the generated sun-lit
//! living room, one bounce, `--lighting indirect` (the light clustering changes): the VPLs of one
//! shadow map per light, clustered in shadow-map space (`--vpl-cluster rsm`) into K clusters lit
//! as clamped points, as disks through Eq. 2, and as disks through the exact form factor, beside
//! the unclustered shadow-map VPLs; each against a converged, unbiased reference of the same
//! scene (`vplgi reference`, path VPLs with bias compensation): relMSE, FLIP, and the light kept
//! (mean ratio per channel; below 1 is energy lost). The shading points are not clustered
//! (`--cluster vpl`), so only the VPL clustering differs.
//!
//! **Clustering time at the paper's Table 1 sizes** (128² map with 256 clusters, 128² with
//! 1,024, 256² with 1,024) on the Cornell box, CPU and GPU (Mesa lavapipe on the same cores),
//! the median `rsm_cluster` stage time of three frames, beside the paper's GTX 560 Ti.

use anyhow::{Context, Result};
use clap::Parser;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use vplgi_reports::{median, run};

#[derive(Parser)]
#[command(
    about = "Measures reflective-shadow-map clusters as points and disks against converged references; writes docs/RSM.md"
)]
struct Opts {
    /// The report; numbers and pictures go to rsm/ beside it.
    #[arg(long, default_value = "docs/RSM.md")]
    out: PathBuf,
    /// The vplgi binary.
    #[arg(long, default_value = "target/release/vplgi")]
    vplgi: PathBuf,
    /// Small images, few seeds and small maps: a check that it runs, not the measurement.
    #[arg(long)]
    quick: bool,
    /// Where scenes, references and frames go [default: target/rsm, or target/rsm-quick].
    #[arg(long)]
    work: Option<PathBuf>,
}

/// The light shapes compared, in table order.
const SHAPES: [&str; 4] = ["point", "disk", "disk-exact", "polygon"];

/// Every shadow-map VPL as a point with no clamp: the light the VPLs themselves carry, which no
/// clustering can add to.
const UNCLAMPED: &str = "unclustered, no clamp";

/// The exact disks from plain Halton seeds (the other rows warp them by the importance map).
const HALTON: &str = "disk-exact, Halton seeds";

/// The moving-light sequence: frames, and how far the sun turns over them (degrees).
const SEQUENCE_FRAMES: u32 = 12;
const SEQUENCE_DEGREES: f32 = 30.0;

/// The paper's Table 1: (map side, clusters, ms on a GTX 560 Ti, clustering with importance).
const TABLE_1: [(u32, u32, f64); 3] = [(128, 256, 0.92), (128, 1024, 3.2), (256, 1024, 9.5)];

struct SceneCase {
    name: &'static str,
    /// A generated scene's name, or None for the built-in Cornell box.
    generated: Option<&'static str>,
    width: u32,
    height: u32,
    rsm_size: u32,
    /// VPLs per seed of the reference.
    vpls: u32,
    seeds: u32,
}

fn main() -> Result<()> {
    let o = Opts::parse();
    let q = o.quick;
    let cases = if q {
        [
            SceneCase {
                name: "cornell-box",
                generated: None,
                width: 32,
                height: 32,
                rsm_size: 32,
                vpls: 1000,
                seeds: 2,
            },
            SceneCase {
                name: "sunlit-living-room",
                generated: Some("sunlit-living-room"),
                width: 32,
                height: 24,
                rsm_size: 48,
                vpls: 2000,
                seeds: 2,
            },
        ]
    } else {
        [
            SceneCase {
                name: "cornell-box",
                generated: None,
                width: 128,
                height: 128,
                rsm_size: 128,
                vpls: 10_000,
                seeds: 16,
            },
            SceneCase {
                name: "sunlit-living-room",
                generated: Some("sunlit-living-room"),
                width: 192,
                height: 135,
                rsm_size: 256,
                vpls: 20_000,
                seeds: 8,
            },
        ]
    };
    let counts: &[u32] = if q { &[16, 64] } else { &[64, 256, 1024] };
    let work = o
        .work
        .clone()
        .unwrap_or_else(|| PathBuf::from(if q { "target/rsm-quick" } else { "target/rsm" }));
    let docs = o.out.parent().map_or_else(|| PathBuf::from("rsm"), |p| p.join("rsm"));
    std::fs::create_dir_all(&docs)?;
    let vplgi = |args: &[&str]| -> Result<()> { run(Command::new(&o.vplgi).args(args)) };
    let mut scenes = Vec::new();
    for c in &cases {
        let dir = work.join(c.name);
        let scene = match c.generated {
            Some(g) => {
                let glb = work.join("scenes").join(format!("{g}.glb"));
                if !glb.exists() {
                    eprintln!("generating {g}");
                    vplgi(&[
                        "scene",
                        "generate",
                        g,
                        "--triangles",
                        if q { "4000" } else { "60000" },
                        "--out",
                        s(&glb),
                    ])?;
                }
                s(&glb).to_string()
            }
            None => "cornell-box".to_string(),
        };
        let (w, h, size) = (c.width.to_string(), c.height.to_string(), c.rsm_size.to_string());
        let frame = ["--bounces", "1", "--lighting", "indirect", "--width", &w, "--height", &h];
        let reference = dir.join("reference");
        if !reference.join("mean.exr").exists() {
            eprintln!("{}: the reference ({} seeds)", c.name, c.seeds);
            let (seeds, vpls) = (c.seeds.to_string(), c.vpls.to_string());
            let mut args = vec![
                "reference",
                &scene,
                "--seeds",
                &seeds,
                "--vpls",
                &vpls,
                "--out",
                s(&reference),
            ];
            args.extend(frame);
            vplgi(&args)?;
        }
        // One `render` of the scene's shadow-map VPLs (`--rsm-size` `size`, `k` clusters, plus
        // `extra`) compared with the reference: (compare.json, report.json).
        let render_and_compare =
            |out: &Path, size: &str, k: u32, extra: &[&str]| -> Result<(Value, Value)> {
                let k_vpl = k.max(1).to_string();
                let mut args = vec![
                    "render",
                    &scene,
                    "--vpl-source",
                    "rsm",
                    "--rsm-size",
                    size,
                    "--k-vpl",
                    &k_vpl,
                    "--out",
                    s(out),
                ];
                args.extend(frame);
                args.extend(extra);
                vplgi(&args)?;
                vplgi(&[
                    "compare",
                    s(&reference.join("mean.exr")),
                    s(&out.join("image.exr")),
                    "--out",
                    s(out),
                ])?;
                Ok((read_json(&out.join("compare.json"))?, read_json(&out.join("report.json"))?))
            };
        let mut frames = Vec::new();
        let mut runs: Vec<(String, u32, Vec<&str>)> = vec![
            ("unclustered".into(), 0, vec!["--cluster", "none"]),
            (UNCLAMPED.into(), 0, vec!["--cluster", "none", "--g-clamp", "0"]),
        ];
        for &k in counts {
            for shape in SHAPES {
                runs.push((
                    shape.into(),
                    k,
                    vec!["--cluster", "vpl", "--vpl-cluster", "rsm", "--light-shape", shape],
                ));
            }
            runs.push((
                HALTON.into(),
                k,
                vec![
                    "--cluster",
                    "vpl",
                    "--vpl-cluster",
                    "rsm",
                    "--light-shape",
                    "disk-exact",
                    "--rsm-seeding",
                    "halton",
                ],
            ));
        }
        for (light, k, extra) in runs {
            let label = if k == 0 {
                light.replace(", ", "-").replace(' ', "-")
            } else {
                format!("{}-{k}", light.replace(", Halton seeds", "-halton"))
            };
            eprintln!("{}: {label}", c.name);
            let out = dir.join(&label);
            let (cmp, report) = render_and_compare(&out, &size, k, &extra)?;
            let ms = |key: &str| report["timings_ms"][key].as_f64().unwrap_or(f64::NAN);
            frames.push(json!({
                "light": light, "k": k, "rel_mse": cmp["rel_mse"], "flip": cmp["flip"], "mean_ratio": cmp["mean_ratio"],
                "vpls": report["stats"]["vpls"], "clusters": report["stats"]["vpl_clusters"], "shade_ms": ms("shade"), "total_ms": ms("total"),
            }));
            // Pictures: the reference, and every light shape at the middle count with its error map.
            if (k == counts[counts.len() / 2] && light != HALTON) || light == "unclustered" {
                std::fs::copy(out.join("image.png"), docs.join(format!("{}-{label}.png", c.name)))?;
                std::fs::copy(
                    out.join("error_map.png"),
                    docs.join(format!("{}-{label}-error.png", c.name)),
                )?;
            }
        }
        // The Cornell box's energy again from a map of twice the side: the shadow map's own
        // quadrature error moves with its size (its unclamped VPLs keep more or less than the
        // reference), so this separates what the light shapes lose from what the map does.
        let mut finer = Vec::new();
        let finer_size = (2 * c.rsm_size).to_string();
        if c.generated.is_none() {
            let mut runs: Vec<(&str, u32, Vec<&str>)> =
                vec![(UNCLAMPED, 0, vec!["--cluster", "none", "--g-clamp", "0"])];
            for &k in counts {
                for shape in SHAPES {
                    runs.push((
                        shape,
                        k,
                        vec!["--cluster", "vpl", "--vpl-cluster", "rsm", "--light-shape", shape],
                    ));
                }
            }
            for (light, k, extra) in runs {
                eprintln!("{}: {light} at {k} clusters, --rsm-size {finer_size}", c.name);
                let out =
                    dir.join(format!("finer-{}-{k}", light.replace(", ", "-").replace(' ', "-")));
                let (cmp, _) = render_and_compare(&out, &finer_size, k, &extra)?;
                finer.push(json!({"light": light, "k": k, "rel_mse": cmp["rel_mse"], "mean_ratio": cmp["mean_ratio"]}));
            }
        }
        std::fs::copy(reference.join("mean.png"), docs.join(format!("{}-reference.png", c.name)))?;
        let reference_sidecar = read_json(&reference.join("reference.json"))?;
        scenes.push(json!({
            "scene": c.name, "width": c.width, "height": c.height, "rsm_size": c.rsm_size, "seeds": c.seeds, "reference_vpls": c.vpls,
            "reference_error": reference_sidecar["error"]["relative_standard_error"],
            "reference_mean_error": mean_standard_error(&reference_sidecar["error"]["thirds_per_seed"]),
            "frames": frames, "middle_k": counts[counts.len() / 2],
            "finer": if finer.is_empty() { Value::Null } else { json!({"rsm_size": 2 * c.rsm_size, "frames": finer}) },
        }));
    }
    eprintln!("timing the clustering at Table 1's sizes");
    let mut timings = Vec::new();
    for (size, k, paper_ms) in TABLE_1 {
        let (size, k) = if q { (size / 4, k / 8) } else { (size, k) };
        let mut row = json!({"rsm_size": size, "k": k, "paper_ms": paper_ms});
        for (backend, seeding) in
            [("cpu", "halton"), ("cpu", "importance"), ("gpu", "halton"), ("gpu", "importance")]
        {
            let mut ms = Vec::new();
            for r in 0..3 {
                let out = work.join("timing").join(format!("{backend}-{seeding}-{size}-{k}-{r}"));
                let (size_s, k_s) = (size.to_string(), k.to_string());
                vplgi(&[
                    "render",
                    "--backend",
                    backend,
                    "--vpl-source",
                    "rsm",
                    "--bounces",
                    "1",
                    "--rsm-size",
                    &size_s,
                    "--vpl-cluster",
                    "rsm",
                    "--cluster",
                    "vpl",
                    "--k-vpl",
                    &k_s,
                    "--rsm-seeding",
                    seeding,
                    "--width",
                    "128",
                    "--height",
                    "128",
                    "--out",
                    s(&out),
                ])?;
                let report = read_json(&out.join("report.json"))?;
                ms.push(
                    report["timings_ms"]["cluster"]
                        .as_f64()
                        .context("no cluster timing in the report")?,
                );
                row["vpls"] = report["stats"]["vpls"].clone();
            }
            row[format!("{backend}_{seeding}_ms")] = json!(median(ms));
        }
        timings.push(row);
    }
    let sequence = moving_sun(&o, &work, q)?;
    let (date, commit) = vplgi_reports::date_and_commit()?;
    let result = json!({"date": date, "commit": commit, "quick": q, "scenes": scenes, "table_1": timings, "sequence": sequence});
    std::fs::write(docs.join("rsm.json"), serde_json::to_string_pretty(&result)?)?;
    std::fs::write(&o.out, markdown(&result)?)?;
    eprintln!("wrote {}", o.out.display());
    Ok(())
}

/// Temporal stability along a moving light: the sun-lit room's sun turned by
/// [`SEQUENCE_DEGREES`] over [`SEQUENCE_FRAMES`] frames (`render --frames --light-orbit`), its
/// RSM clusters as exact disks re-clustered from scratch each frame and warm-started from the
/// previous frame's (`--temporal on`, with the default iterations and with one, the paper's),
/// each sequence judged against the unclustered shadow-map VPLs' sequence: the change between
/// frames that sequence does not have (`temporal_error`), the approximation's own flicker.
fn moving_sun(o: &Opts, work: &Path, q: bool) -> Result<Value> {
    let vplgi = |args: &[&str]| -> Result<()> { run(Command::new(&o.vplgi).args(args)) };
    let glb = work.join("scenes").join("sunlit-living-room.glb");
    let dir = work.join("sequence");
    let (w, h, size, k, frames) =
        if q { ("32", "24", "48", "32", 3) } else { ("192", "135", "256", "256", SEQUENCE_FRAMES) };
    let (frames_s, degrees) = (frames.to_string(), SEQUENCE_DEGREES.to_string());
    let common = [
        "render",
        s(&glb),
        "--frames",
        &frames_s,
        "--light-orbit",
        &degrees,
        "--vpl-source",
        "rsm",
        "--bounces",
        "1",
        "--lighting",
        "indirect",
        "--rsm-size",
        size,
        "--width",
        w,
        "--height",
        h,
    ];
    let reference = dir.join("unclustered");
    eprintln!("moving sun: the unclustered sequence");
    let mut args = common.to_vec();
    args.extend(["--cluster", "none", "--out", s(&reference)]);
    vplgi(&args)?;
    let mut rows = Vec::new();
    for (label, temporal, iterations) in [
        ("from scratch", "off", None),
        ("warm start", "on", None),
        ("warm start, 1 iteration per frame", "on", Some("1")),
    ] {
        eprintln!("moving sun: {label}");
        let out = dir.join(label.replace([' ', ','], "-"));
        let mut args = common.to_vec();
        args.extend([
            "--cluster",
            "vpl",
            "--vpl-cluster",
            "rsm",
            "--light-shape",
            "disk-exact",
            "--k-vpl",
            k,
            "--temporal",
            temporal,
        ]);
        args.extend(["--flicker-reference", s(&reference), "--out", s(&out)]);
        if let Some(i) = iterations {
            args.extend(["--iterations", i]);
        }
        vplgi(&args)?;
        let seq = read_json(&out.join("sequence.json"))?;
        let f = seq["frames"].as_array().cloned().unwrap_or_default();
        let mean = |key: &str| {
            f.iter().skip(1).filter_map(|x| x[key].as_f64()).sum::<f64>()
                / (f.len().max(2) - 1) as f64
        };
        rows.push(json!({
            "label": label, "flicker": seq["flicker"], "temporal_error": seq["temporal_error"], "converged_flicker": seq["converged_flicker"],
            "clusters": mean("vpl_clusters"), "kept": mean("vpl_kept"), "fresh": mean("vpl_fresh"), "frame_ms": mean("total_ms"),
        }));
    }
    Ok(
        json!({"frames": frames, "degrees": SEQUENCE_DEGREES, "width": w, "height": h, "rsm_size": size, "k": k, "rows": rows}),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

fn read_json(p: &Path) -> Result<Value> {
    serde_json::from_slice(&std::fs::read(p).with_context(|| format!("reading {}", p.display()))?)
        .with_context(|| format!("parsing {}", p.display()))
}

/// The relative standard error of the reference image's mean, per channel, from its sidecar's
/// per-seed means of each third of the rows (all pixels of a seed share its VPLs, so it is the
/// spread of the seeds' whole-image means that counts): the noise floor of "light kept".
fn mean_standard_error(thirds_per_seed: &Value) -> Value {
    let seeds: Vec<[f64; 3]> = thirds_per_seed
        .as_array()
        .map(|a| {
            a.iter()
                .map(|thirds| {
                    let t: Vec<Vec<f64>> = thirds
                        .as_array()
                        .map(|t| {
                            t.iter()
                                .map(|c| {
                                    c.as_array()
                                        .map(|c| c.iter().filter_map(Value::as_f64).collect())
                                        .unwrap_or_default()
                                })
                                .collect()
                        })
                        .unwrap_or_default();
                    [0, 1, 2].map(|c| {
                        t.iter().filter_map(|third| third.get(c)).sum::<f64>()
                            / t.len().max(1) as f64
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    let n = seeds.len() as f64;
    if n < 2.0 {
        return json!(null);
    }
    json!([0, 1, 2].map(|c| {
        let mean = seeds.iter().map(|s| s[c]).sum::<f64>() / n;
        let var = seeds.iter().map(|s| (s[c] - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (var / n).sqrt() / mean
    }))
}

/// The light kept, as "0.988 (0.987–0.990)": the mean of the channels' ratios and their range.
fn kept(ratio: &Value) -> String {
    let r: Vec<f64> =
        ratio.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect()).unwrap_or_default();
    if r.is_empty() {
        return "?".into();
    }
    let (lo, hi) =
        r.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    format!("{:.3} ({lo:.3}–{hi:.3})", r.iter().sum::<f64>() / r.len() as f64)
}

/// The mean of a frame's per-channel light kept (NaN if missing).
fn kept_mean(ratio: &Value) -> f64 {
    let r: Vec<f64> =
        ratio.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect()).unwrap_or_default();
    if r.is_empty() {
        f64::NAN
    } else {
        r.iter().sum::<f64>() / r.len() as f64
    }
}

/// Per cluster count, each light shape's error in light kept (kept − 1, in %), and which of the
/// shapes without a clamp miss the reference's energy by less than the clamped points do.
fn energy_table(frames: &[Value]) -> String {
    let of = |light: &str, k: u64| {
        frames
            .iter()
            .find(|x| x["light"] == light && x["k"].as_u64() == Some(k))
            .map(|x| kept_mean(&x["mean_ratio"]) - 1.0)
    };
    let mut counts: Vec<u64> =
        frames.iter().filter_map(|x| x["k"].as_u64()).filter(|&k| k > 0).collect();
    counts.dedup();
    let baseline = of(UNCLAMPED, 0).map_or("?".into(), |e| format!("{:+.2} %", 100.0 * e));
    let mut s = format!(
        "\nEnergy: light kept − 1 at each cluster count (the unclamped shadow-map VPLs themselves: {baseline}); an area shape *loses less* than the clamped points where its |kept − 1| is smaller.\n\n| `--k-vpl` | point | disk | disk-exact | polygon | area shapes closer to the reference than points |\n|---:|---:|---:|---:|---:|---|\n"
    );
    for k in counts {
        let cell =
            |light: &str| of(light, k).map_or("?".into(), |e| format!("{:+.2} %", 100.0 * e));
        let point = of("point", k).map_or(f64::NAN, f64::abs);
        let closer: Vec<&str> = ["disk", "disk-exact", "polygon"]
            .into_iter()
            .filter(|l| of(l, k).is_some_and(|e| e.abs() < point))
            .collect();
        let closer = if closer.is_empty() { "none".to_string() } else { closer.join(", ") };
        s.push_str(&format!(
            "| {k} | {} | {} | {} | {} | {closer} |\n",
            cell("point"),
            cell("disk"),
            cell("disk-exact"),
            cell("polygon")
        ));
    }
    s
}

fn markdown(r: &Value) -> Result<String> {
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mut s = String::new();
    writeln!(s, "# Reflective-shadow-map clusters as lights (Prutkin et al. 2012)\n")?;
    writeln!(
        s,
        "{} Numbers: [rsm/rsm.json](rsm/rsm.json). CPU times on this machine's 2 cores; GPU times on Mesa's lavapipe (software Vulkan) on the same cores, not a GPU.\n",
        vplgi_reports::generated_by("rsm", r, "measurement")
    )?;
    writeln!(
        s,
        "Each scene's VPLs come from one reflective shadow map per light (`--vpl-source rsm`, one bounce) and are clustered in shadow-map space with the paper's Eq. 1 (`--vpl-cluster rsm`, weights 1, 10, 0), from seeds warped by the bidirectional importance map (`--rsm-seeding importance`, the default; the row *disk-exact, Halton seeds* starts from the plain Halton points instead). A cluster then lights the scene as a point with the geometry-term clamp (`point`, the core paper's light), as a disk through the paper's Eq. 2 (`disk`), as the same disk through its exact form factor (`disk-exact`), or as the convex polygon around its members (their extent in 8 directions of the representative's plane) through its exact form factor (`polygon`, the paper's other shape); disks and polygons have no clamp. `unclustered` is every shadow-map VPL as a clamped point, and *unclustered, no clamp* the same VPLs unclamped: the light they carry, which clustering cannot add to. Shading points are not clustered (`--cluster vpl`). Every image holds the indirect light only (`--lighting indirect`) and is compared with a converged, unbiased reference of the same scene (`vplgi reference`: path VPLs with bias compensation, its own relative standard error given below). *Light kept* is the image's mean over the reference's per channel (the mean of the three, and their range): below 1 is energy lost.\n"
    )?;
    for sc in r["scenes"].as_array().cloned().unwrap_or_default() {
        let name = sc["scene"].as_str().unwrap_or("?");
        writeln!(
            s,
            "## {name} ({}x{}, --rsm-size {})\n\nReference: {} seeds of {} VPLs, per-pixel relative standard error {:.2} %; standard error of its mean (what *light kept* is measured against) {} % per channel.\n",
            sc["width"],
            sc["height"],
            sc["rsm_size"],
            sc["seeds"],
            sc["reference_vpls"],
            100.0 * f(&sc["reference_error"]),
            sc["reference_mean_error"].as_array().map_or("?".into(), |a| a.iter().map(|x| format!("{:.2}", 100.0 * f(x))).collect::<Vec<_>>().join(" / "))
        )?;
        writeln!(s, "| lights | clusters | relMSE | FLIP | light kept | shade (s) | frame (s) |\n|---|---:|---:|---:|---|---:|---:|")?;
        let frames = sc["frames"].as_array().cloned().unwrap_or_default();
        for x in &frames {
            let clusters = if x["k"].as_u64() == Some(0) {
                format!("– ({} VPLs)", x["vpls"])
            } else {
                x["clusters"].to_string()
            };
            writeln!(
                s,
                "| `{}` | {clusters} | {:.2e} | {:.4} | {} | {:.2} | {:.2} |",
                x["light"].as_str().unwrap_or("?"),
                f(&x["rel_mse"]),
                f(&x["flip"]),
                kept(&x["mean_ratio"]),
                f(&x["shade_ms"]) / 1e3,
                f(&x["total_ms"]) / 1e3
            )?;
        }
        s.push_str(&energy_table(&frames));
        if let Some(finer) = sc["finer"]["frames"].as_array() {
            writeln!(
                s,
                "\nThe same at `--rsm-size {}` (energy only): the map's own quadrature error changes with its size, and with it which shape lands nearest the reference.",
                sc["finer"]["rsm_size"]
            )?;
            s.push_str(&energy_table(finer));
        }
        let k = sc["middle_k"].as_u64().unwrap_or(0);
        writeln!(s, "\nAt `--k-vpl {k}` (images, then FLIP error maps against the reference):\n")?;
        writeln!(s, "| reference | unclustered | point | disk | disk-exact | polygon |\n|---|---|---|---|---|---|")?;
        writeln!(
            s,
            "| ![](rsm/{name}-reference.png) | ![](rsm/{name}-unclustered.png) | ![](rsm/{name}-point-{k}.png) | ![](rsm/{name}-disk-{k}.png) | ![](rsm/{name}-disk-exact-{k}.png) | ![](rsm/{name}-polygon-{k}.png) |"
        )?;
        writeln!(
            s,
            "| | ![](rsm/{name}-unclustered-error.png) | ![](rsm/{name}-point-{k}-error.png) | ![](rsm/{name}-disk-{k}-error.png) | ![](rsm/{name}-disk-exact-{k}-error.png) | ![](rsm/{name}-polygon-{k}-error.png) |\n"
        )?;
    }
    let sq = &r["sequence"];
    writeln!(s, "## A moving sun: flicker of cold and warm-started clusters\n")?;
    writeln!(
        s,
        "The sun-lit living room ({}x{}, `--rsm-size {}`, `--k-vpl {}`, exact disks) over {} frames while its sun turns {}° about the vertical (`render --frames {} --light-orbit {}`), on the CPU. *Flicker* is the mean relative change between consecutive frames; the sun's patch of light moves, so the unclustered shadow-map VPLs change too ({}). *Temporal error* is the change a sequence has that the unclustered one does not (`--flicker-reference`): the clustering's own flicker. Warm start: each frame starts from the previous frame's live clusters and seeds only the slots of those that emptied (*kept* and *seeded*, per frame after the first).\n",
        sq["width"].as_str().unwrap_or("?"),
        sq["height"].as_str().unwrap_or("?"),
        sq["rsm_size"].as_str().unwrap_or("?"),
        sq["k"].as_str().unwrap_or("?"),
        sq["frames"],
        sq["degrees"],
        sq["frames"],
        sq["degrees"],
        sq["rows"][0]["converged_flicker"].as_f64().map_or("?".into(), |x| format!("{:.2} %", 100.0 * x)),
    )?;
    writeln!(s, "| clustering | flicker | temporal error | clusters | kept | seeded | frame (ms) |\n|---|---:|---:|---:|---:|---:|---:|")?;
    for x in sq["rows"].as_array().cloned().unwrap_or_default() {
        writeln!(
            s,
            "| {} | {:.2} % | {:.3} % | {:.0} | {:.0} | {:.0} | {:.0} |",
            x["label"].as_str().unwrap_or("?"),
            100.0 * f(&x["flicker"]),
            100.0 * f(&x["temporal_error"]),
            f(&x["clusters"]),
            f(&x["kept"]),
            f(&x["fresh"]),
            f(&x["frame_ms"])
        )?;
    }
    writeln!(s, "\n## Clustering time at the paper's Table 1 sizes\n")?;
    writeln!(
        s,
        "The Cornell box's shadow map clustered (`rsm_cluster`: k-means with Eq. 1 over the 5 x 5 neighbouring cells, the sort by cluster and the update, 10 iterations), the median `cluster` stage time of three 128 x 128 frames: from plain Halton seeds, and with the paper's bidirectional importance map (256 G-buffer pixels) built and the seeds warped by it, as the paper's Table 1 times it.\n"
    )?;
    writeln!(
        s,
        "| map | clusters | VPLs | CPU, Halton (ms) | CPU, importance (ms) | GPU, lavapipe, Halton (ms) | GPU, lavapipe, importance (ms) | paper, GTX 560 Ti (ms) |\n|---|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for t in r["table_1"].as_array().cloned().unwrap_or_default() {
        writeln!(
            s,
            "| {0}² | {1} | {2} | {3:.1} | {4:.1} | {5:.1} | {6:.1} | {7} |",
            t["rsm_size"],
            t["k"],
            t["vpls"],
            f(&t["cpu_halton_ms"]),
            f(&t["cpu_importance_ms"]),
            f(&t["gpu_halton_ms"]),
            f(&t["gpu_importance_ms"]),
            f(&t["paper_ms"])
        )?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_references_mean_error_is_the_spread_of_its_seeds() {
        // Two seeds whose thirds average to 1.0 and 1.2 (red), 2 and 2 (green), 0.5 and 0.7
        // (blue): standard deviations 0.1414, 0, 0.1414 over means 1.1, 2, 0.6, over √2.
        let seed = |r: f64, g: f64, b: f64| json!([[r, g, b], [r, g, b], [r, g, b]]);
        let e = mean_standard_error(&json!([seed(1.0, 2.0, 0.5), seed(1.2, 2.0, 0.7)]));
        let e: Vec<f64> = e.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        assert!(
            (e[0] - 0.1 / 1.1).abs() < 1e-12 && e[1] == 0.0 && (e[2] - 0.1 / 0.6).abs() < 1e-12,
            "{e:?}"
        );
        assert_eq!(mean_standard_error(&json!([seed(1.0, 1.0, 1.0)])), json!(null));
    }

    #[test]
    fn the_energy_table_names_the_shapes_closer_than_points() {
        let frame = |light: &str, k: u64, kept: f64| json!({"light": light, "k": k, "mean_ratio": [kept, kept, kept]});
        let frames = [
            frame(UNCLAMPED, 0, 0.996),
            frame("point", 64, 1.009),
            frame("disk", 64, 0.865),
            frame("disk-exact", 64, 0.984),
            frame("polygon", 64, 0.993),
            frame("point", 256, 1.000),
            frame("disk", 256, 0.9),
            frame("disk-exact", 256, 0.99),
            frame("polygon", 256, 0.997),
        ];
        let t = energy_table(&frames);
        assert!(t.contains("themselves: -0.40 %"), "{t}");
        assert!(t.contains("| 64 | +0.90 % | -13.50 % | -1.60 % | -0.70 % | polygon |"), "{t}");
        assert!(t.contains("| 256 | +0.00 % | -10.00 % | -1.00 % | -0.30 % | none |"), "{t}");
    }

    #[test]
    fn light_kept_shows_the_mean_and_the_range() {
        assert_eq!(kept(&json!([0.98, 1.0, 0.99])), "0.990 (0.980–1.000)");
        assert_eq!(kept(&json!(null)), "?");
    }
}
