//! `make variants`: the two papers' choices for shading points compared on the three generated
//! scenes, written to `docs/VARIANTS.md` (numbers in `docs/variants/variants.json`, charts in
//! `docs/variants/`).
//!
//! For each scene, one `vplgi sweep --figure variants` on the CPU (`--cluster sp`, every VPL its
//! own light): each variant at each shading-point cluster count, against the unclustered
//! reference. The question is which variant is best **at equal time**: for each time budget (the
//! core paper's frame time at each count), the lowest error each variant reached in a frame no
//! slower than the budget. Then, along a camera walk of each scene, one `vplgi sweep --figure
//! flicker`: the two papers' pipelines with and without `--temporal on`, each sequence's change
//! between frames that the unclustered sequence of the same walk does not have. About ten
//! minutes on 2 cores.

use anyhow::{Context, Result};
use clap::Parser;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::Command;
use vplgi_reports::run;

#[derive(Parser)]
#[command(
    about = "Compares the shading-point variants at equal time on the generated scenes; writes docs/VARIANTS.md"
)]
struct Opts {
    /// The report; charts and numbers go to variants/ beside it.
    #[arg(long, default_value = "docs/VARIANTS.md")]
    out: PathBuf,
    /// The vplgi binary.
    #[arg(long, default_value = "target/release/vplgi")]
    vplgi: PathBuf,
    /// Small scenes and images: a check that it runs, not the comparison.
    #[arg(long)]
    quick: bool,
    /// Where the scenes and sweeps go [default: target/variants, or target/variants-quick].
    #[arg(long)]
    work: Option<PathBuf>,
}

/// The core paper's choices first: its times are the budgets.
const VARIANTS: &str =
    "eq7+nearest+stride+fuzzy,ward+min-error+adaptive+interpolate,ward+min-error+adaptive+fuzzy,eq7+nearest+adaptive+fuzzy,ward+min-error+stride+fuzzy";

/// The pipelines whose flicker is measured along each scene's walk, each with --temporal off
/// and on: the core paper's and Wang et al.'s.
const PIPELINES: &str = "eq7+nearest+stride+fuzzy,ward+min-error+adaptive+interpolate";

/// A frame may be this much slower than a budget and still count as within it: repeated runs of
/// one configuration vary by about as much on this machine.
const TIME_SLACK: f64 = 1.05;

fn main() -> Result<()> {
    let o = Opts::parse();
    let q = o.quick;
    // (scene, width, height, VPLs): 256 pixels wide, the paper's aspect ratios.
    let scenes = [("cornell-fine", 256, 256), ("conference", 256, 180), ("living-room", 256, 180)];
    let (scale, vpls, triangles, counts, runs) = if q {
        (4, "300", "20000", "100,400", "1")
    } else {
        (1, "2000", "300000", "1000,2000,4000,8000", "2")
    };
    let work = o.work.clone().unwrap_or_else(|| {
        PathBuf::from(if q { "target/variants-quick" } else { "target/variants" })
    });
    let docs = o.out.parent().map_or_else(|| PathBuf::from("variants"), |p| p.join("variants"));
    std::fs::create_dir_all(&docs)?;
    let vplgi = |args: &[&str]| -> Result<()> { run(Command::new(&o.vplgi).args(args)) };
    let mut rows = Vec::new();
    for (name, w, h) in scenes {
        let glb = work.join("scenes").join(format!("{name}-{triangles}.glb"));
        if vplgi_reports::scene_is_stale(&glb, &o.vplgi) {
            eprintln!("generating {name}");
            vplgi(&[
                "scene",
                "generate",
                name,
                "--triangles",
                triangles,
                "--out",
                glb.to_str().unwrap_or_default(),
            ])?;
        }
        eprintln!("{name}: sweeping the variants");
        let dir = work.join(name);
        let (w, h) = ((w / scale).to_string(), (h / scale).to_string());
        vplgi(&[
            "sweep",
            glb.to_str().unwrap_or_default(),
            "--figure",
            "variants",
            "--variants",
            VARIANTS,
            "--width",
            &w,
            "--height",
            &h,
            "--vpls",
            vpls,
            "--sp-clusters",
            counts,
            "--runs",
            runs,
            "--out",
            dir.to_str().unwrap_or_default(),
        ])?;
        for metric in ["flip", "mse"] {
            let chart = format!("variants-{metric}.svg");
            std::fs::copy(dir.join(&chart), docs.join(format!("{name}-{chart}")))
                .with_context(|| format!("copying {chart}"))?;
        }
        let sweep: Value = serde_json::from_slice(
            &std::fs::read(dir.join("sweep.json")).context("reading sweep.json")?,
        )?;
        let frames: Vec<Value> = sweep["configs"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .map(|c| json!({"variant": c["variant"], "k_sp": c["k_sp"], "ms": c["timings_ms"]["total"], "flip": c["flip"], "rel_mse": c["rel_mse"]}))
            .collect();
        let walk = flicker(&o, &work, &docs, name, (&w, &h), vpls, q)?;
        rows.push(json!({"scene": name, "width": w, "height": h, "vpls": vpls, "frames": frames, "walk": walk}));
    }
    let (date, commit) = vplgi_reports::date_and_commit()?;
    let report = json!({"quick": q, "date": date, "commit": commit, "scenes": rows});
    std::fs::write(docs.join("variants.json"), serde_json::to_string_pretty(&report)? + "\n")?;
    std::fs::write(&o.out, markdown(&report)?)?;
    println!("wrote {} and {}", o.out.display(), docs.join("variants.json").display());
    Ok(())
}

/// One `vplgi sweep --figure flicker` along a 5-key `--camera-walk` of `name` at `--lighting
/// indirect`: each of [`PIPELINES`] with --temporal off and on at each count, judged against the
/// unclustered sequence of the same walk. Its chart goes to `docs`.
fn flicker(
    o: &Opts,
    work: &std::path::Path,
    docs: &std::path::Path,
    name: &str,
    (w, h): (&str, &str),
    vpls: &str,
    q: bool,
) -> Result<Value> {
    let (triangles, frames, counts) =
        if q { ("20000", "3", "100") } else { ("300000", "17", "1000,4000") };
    let glb = work.join("scenes").join(format!("{name}-{triangles}-walk.glb"));
    let vplgi = |args: &[&str]| -> Result<()> { run(Command::new(&o.vplgi).args(args)) };
    if vplgi_reports::scene_is_stale(&glb, &o.vplgi) {
        vplgi(&[
            "scene",
            "generate",
            name,
            "--triangles",
            triangles,
            "--camera-walk",
            "5",
            "--out",
            glb.to_str().unwrap_or_default(),
        ])?;
    }
    eprintln!("{name}: flicker along the walk");
    let dir = work.join(name).join("flicker");
    vplgi(&[
        "sweep",
        glb.to_str().unwrap_or_default(),
        "--figure",
        "flicker",
        "--variants",
        PIPELINES,
        "--frames",
        frames,
        "--sp-clusters",
        counts,
        "--width",
        w,
        "--height",
        h,
        "--vpls",
        vpls,
        "--lighting",
        "indirect",
        "--out",
        dir.to_str().unwrap_or_default(),
    ])?;
    std::fs::copy(dir.join("flicker.svg"), docs.join(format!("{name}-flicker.svg")))
        .context("copying flicker.svg")?;
    let sweep: Value = serde_json::from_slice(
        &std::fs::read(dir.join("sweep.json")).context("reading the flicker sweep.json")?,
    )?;
    Ok(
        json!({"frames": frames, "converged_flicker": sweep["converged_flicker"], "sequences": sweep["sequences"]}),
    )
}

/// The lowest FLIP among `frames` of `variant` no slower than `budget` ms (with the slack), and
/// that frame's cluster count.
fn best_within(frames: &[Value], variant: &str, budget: f64) -> Option<(f64, u64)> {
    frames
        .iter()
        .filter(|x| {
            x["variant"] == variant && x["ms"].as_f64().is_some_and(|t| t <= budget * TIME_SLACK)
        })
        .filter_map(|x| Some((x["flip"].as_f64()?, x["k_sp"].as_u64()?)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

fn markdown(r: &Value) -> Result<String> {
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let variants: Vec<&str> = VARIANTS.split(',').collect();
    let mut s = String::new();
    writeln!(s, "# Shading-point variants at equal time\n")?;
    writeln!(
        s,
        "{} Numbers: [variants/variants.json](variants/variants.json).\n",
        vplgi_reports::generated_by("variants", r, "comparison")
    )?;
    writeln!(
        s,
        "The core paper clusters shading points with Eq. 7, evenly spread seeds and the member nearest the centroid, and shades every pixel from every light through its F clusters' visibility (`eq7+nearest+stride+fuzzy`). Wang et al. 2009 seed by a screen-space quadtree (`adaptive`), cluster by their Eq. 2 (`ward`), take the member of smallest error (`min-error`), and interpolate irradiance computed at those members only (`interpolate`). Each scene is one `vplgi sweep --figure variants` on the CPU (this machine's 2 cores) with `--cluster sp`: every VPL is its own light, so the variants differ in shading points only. Error is FLIP against the unclustered reference of the same VPLs; time is the frame's total, the median of the runs.\n"
    )?;
    writeln!(s, "**At equal time**: each budget is the core paper's frame time at one cluster count; a variant's entry is the lowest FLIP it reached in a frame no slower than the budget (+{:.0} % for timing noise), with that frame's cluster count; – where none of its frames fit. The best entry of each budget is in bold.\n", (TIME_SLACK - 1.0) * 100.0)?;
    for sc in r["scenes"].as_array().cloned().unwrap_or_default() {
        let name = sc["scene"].as_str().unwrap_or("?");
        writeln!(
            s,
            "## {name} ({}x{}, {} VPLs)\n",
            sc["width"].as_str().unwrap_or("?"),
            sc["height"].as_str().unwrap_or("?"),
            sc["vpls"].as_str().unwrap_or("?")
        )?;
        let frames = sc["frames"].as_array().cloned().unwrap_or_default();
        let budgets: Vec<(f64, u64)> = frames
            .iter()
            .filter(|x| x["variant"] == variants[0])
            .map(|x| (f(&x["ms"]), x["k_sp"].as_u64().unwrap_or(0)))
            .collect();
        write!(s, "| variant |")?;
        for (t, k) in &budgets {
            write!(s, " ≤ {:.2} s (core paper at K = {k}) |", t / 1e3)?;
        }
        writeln!(s, "\n|---|{}", "---:|".repeat(budgets.len()))?;
        let best: Vec<Option<f64>> = budgets
            .iter()
            .map(|(t, _)| {
                variants
                    .iter()
                    .filter_map(|v| best_within(&frames, v, *t).map(|b| b.0))
                    .min_by(f64::total_cmp)
            })
            .collect();
        for v in &variants {
            write!(s, "| `{v}` |")?;
            for ((t, _), top) in budgets.iter().zip(&best) {
                match best_within(&frames, v, *t) {
                    Some((e, k)) if Some(e) == *top => write!(s, " **{e:.4}** (K {k}) |")?,
                    Some((e, k)) => write!(s, " {e:.4} (K {k}) |")?,
                    None => write!(s, " – |")?,
                }
            }
            writeln!(s)?;
        }
        writeln!(s, "\nEvery frame (time in seconds, FLIP, relMSE):\n\n| variant | K | time (s) | FLIP | relMSE |\n|---|---:|---:|---:|---:|")?;
        for x in &frames {
            writeln!(
                s,
                "| `{}` | {} | {:.2} | {:.4} | {:.2e} |",
                x["variant"].as_str().unwrap_or("?"),
                x["k_sp"],
                f(&x["ms"]) / 1e3,
                f(&x["flip"]),
                f(&x["rel_mse"])
            )?;
        }
        writeln!(s, "\n![FLIP against time and count](variants/{name}-variants-flip.svg)\n")?;
        let walk = &sc["walk"];
        let sequences = walk["sequences"].as_array().cloned().unwrap_or_default();
        if !sequences.is_empty() {
            writeln!(
                s,
                "**Flicker along a camera walk** (`vplgi sweep --figure flicker`: {} frames of `scene generate {name} --camera-walk 5`, `--lighting indirect`, `--cluster sp`): the mean relative change between consecutive frames, the same for the unclustered sequence ({:.2} %), and the change the unclustered sequence does not have (camera motion cancelled: the clustering's own flicker).\n",
                walk["frames"].as_str().unwrap_or("?"),
                100.0 * f(&walk["converged_flicker"])
            )?;
            writeln!(s, "| pipeline | K | change between frames | change the unclustered sequence does not have | s per frame |\n|---|---:|---:|---:|---:|")?;
            for x in &sequences {
                writeln!(
                    s,
                    "| `{}` | {} | {:.2} % | {:.2} % | {:.2} |",
                    x["series"].as_str().unwrap_or("?"),
                    x["k_sp"],
                    100.0 * f(&x["flicker"]),
                    100.0 * f(&x["own_flicker"]),
                    f(&x["ms_per_frame"]) / 1e3
                )?;
            }
            writeln!(s, "\n![the clustering's own flicker against time and count](variants/{name}-flicker.svg)\n")?;
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_best_frame_within_a_budget() {
        let frames = vec![
            json!({"variant": "a", "k_sp": 10, "ms": 100.0, "flip": 0.3}),
            json!({"variant": "a", "k_sp": 20, "ms": 200.0, "flip": 0.2}),
            json!({"variant": "b", "k_sp": 10, "ms": 50.0, "flip": 0.25}),
        ];
        assert_eq!(best_within(&frames, "a", 150.0), Some((0.3, 10)));
        assert_eq!(best_within(&frames, "a", 195.0), Some((0.2, 20)), "within the slack");
        assert_eq!(best_within(&frames, "a", 50.0), None);
        assert_eq!(best_within(&frames, "b", 1000.0), Some((0.25, 10)));
    }
}
