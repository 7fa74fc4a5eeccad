//! The tracked ratios of `make perf-report` over time: one entry per run in
//! `docs/perf/history.json` (with its commit and date) and a chart of them, `history.svg`: each
//! stage's GPU/CPU time ratio per frame, k-means' speed-up over faiss and the visibility stage's
//! share of raw Embree throughput, each beside its target.

use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

/// The targets drawn as dashed lines (issue "GPU kernels worth their name").
pub const STAGE_RATIO_TARGET: f64 = 3.0;
pub const FRAME_RATIO_TARGET: f64 = 2.5;
pub const KMEANS_SPEEDUP_TARGET: f64 = 5.0;
pub const VISIBILITY_PERCENT_TARGET: f64 = 95.0;

/// The history entry of a perf report (the `perf.json` value): the ratios only.
pub fn entry(report: &Value) -> Value {
    let m = &report["machine"];
    let frames: Vec<Value> = report["frames"]
        .as_array()
        .map(|fs| {
            fs.iter()
                .map(|f| {
                    let stages: serde_json::Map<String, Value> = f["stages"]
                        .as_array()
                        .map(|ss| {
                            ss.iter()
                                .filter_map(|s| {
                                    Some((s["stage"].as_str()?.to_string(), s["ratio"].clone()))
                                })
                                .collect()
                        })
                        .unwrap_or_default();
                    json!({"name": f["name"], "ratios": stages})
                })
                .collect()
        })
        .unwrap_or_default();
    let rows = report["kmeans"]["rows"].as_array().cloned().unwrap_or_default();
    let seconds = |prefix: &str| {
        rows.iter()
            .find(|r| r["name"].as_str().is_some_and(|n| n.starts_with(prefix)))
            .and_then(|r| r["seconds"].as_f64())
    };
    let speedup = match (seconds("faiss"), seconds("vplgi `cluster`, CPU, gamma = 1")) {
        (Some(f), Some(v)) if v > 0.0 => json!(f / v),
        _ => Value::Null,
    };
    json!({
        "commit": m["commit"],
        "date": m["date"],
        "quick": report["quick"],
        "adapter": report["adapter"],
        "frames": frames,
        "kmeans_speedup_over_faiss": speedup,
        "visibility_percent_of_embree": report["visibility"]["percent_of_raw"],
        // Against the fastest of Embree's one-ray and packet loops (reports from 2026-12-04 on).
        "visibility_percent_of_fastest_embree": report["visibility"]["percent_of_fastest"],
        "floor_ratio": report["floor"]["ratio"],
    })
}

/// Reads the history file at `path` (a JSON array of entries).
pub fn read(path: &Path) -> Result<Vec<Value>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    match serde_json::from_str::<Value>(&text) {
        Ok(Value::Array(a)) => Ok(a),
        Ok(_) => bail!("{}: the perf history must be a JSON array of entries", path.display()),
        Err(e) => bail!(
            "{}: not valid JSON ({e}); fix or remove it to start a new history",
            path.display()
        ),
    }
}

/// Appends `entry` to the history file at `path` (a JSON array; created if missing) and returns
/// every entry.
pub fn append(path: &Path, entry: Value) -> Result<Vec<Value>> {
    let mut entries = if path.exists() { read(path)? } else { Vec::new() };
    entries.push(entry);
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, serde_json::to_string_pretty(&entries)? + "\n")
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(entries)
}

/// One line of a panel: a name, a colour and a value per entry (None: not measured then).
#[derive(Clone)]
struct Series {
    name: String,
    colour: &'static str,
    values: Vec<Option<f64>>,
}

const COLOURS: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];
const WIDTH: f64 = 820.0;
const PANEL: f64 = 230.0;
const LEFT: f64 = 60.0;
const RIGHT: f64 = 200.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 40.0;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// One panel at vertical offset `y0`: the series against the run index, a dashed target line,
/// the commits under the axis. `log`: a log2 value axis (ratios).
fn panel(
    svg: &mut String,
    y0: f64,
    title: &str,
    series: &[Series],
    target: f64,
    commits: &[String],
    log: bool,
) {
    let values = series
        .iter()
        .flat_map(|s| s.values.iter().flatten().copied())
        .chain([target])
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = values.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if log {
        (lo.log2().floor(), hi.log2().ceil().max(lo.log2().floor() + 1.0))
    } else {
        (0.0, (hi * 1.1).max(1.0))
    };
    let f = |v: f64| if log { v.log2() } else { v };
    let (x0, x1, top, bottom) = (LEFT, WIDTH - RIGHT, y0 + TOP, y0 + PANEL - BOTTOM);
    let n = commits.len().max(1);
    let x = |i: usize| {
        if n == 1 {
            (x0 + x1) / 2.0
        } else {
            x0 + (x1 - x0) * i as f64 / (n - 1) as f64
        }
    };
    let y = |v: f64| bottom - (bottom - top) * (f(v) - lo) / (hi - lo);
    let _ = writeln!(
        svg,
        r#"<text x="{x0}" y="{}" font-size="14" font-weight="bold">{}</text>"#,
        y0 + 20.0,
        escape(title)
    );
    let ticks: Vec<f64> = if log {
        (lo as i32..=hi as i32).map(|e| 2f64.powi(e)).collect()
    } else {
        (0..=4).map(|k| hi * k as f64 / 4.0).collect()
    };
    for t in ticks {
        let ty = y(t);
        let _ = writeln!(
            svg,
            r##"<line x1="{x0}" y1="{ty:.1}" x2="{x1}" y2="{ty:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" font-size="11" text-anchor="end">{}</text>"##,
            x0 - 6.0,
            ty + 4.0,
            if log { format!("{t}×") } else { format!("{t:.1}") }
        );
    }
    let ty = y(target);
    let _ = writeln!(
        svg,
        r##"<line x1="{x0}" y1="{ty:.1}" x2="{x1}" y2="{ty:.1}" stroke="#000" stroke-dasharray="5,4"/><text x="{}" y="{:.1}" font-size="11">target {target}</text>"##,
        x1 + 6.0,
        ty + 4.0
    );
    for (i, c) in commits.iter().enumerate() {
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{}" font-size="10" text-anchor="middle">{}</text>"#,
            x(i),
            bottom + 14.0,
            escape(c)
        );
    }
    for (k, s) in series.iter().enumerate() {
        let points: Vec<String> = s
            .values
            .iter()
            .enumerate()
            .filter_map(|(i, v)| {
                v.filter(|v| v.is_finite() && *v > 0.0).map(|v| format!("{:.1},{:.1}", x(i), y(v)))
            })
            .collect();
        if points.len() > 1 {
            let _ = writeln!(
                svg,
                r#"<polyline fill="none" stroke="{}" stroke-width="2" points="{}"/>"#,
                s.colour,
                points.join(" ")
            );
        }
        for p in &points {
            let (px, py) = p.split_once(',').unwrap_or(("0", "0"));
            let _ = writeln!(svg, r#"<circle cx="{px}" cy="{py}" r="3" fill="{}"/>"#, s.colour);
        }
        let ly = top + 14.0 * k as f64;
        let _ = writeln!(
            svg,
            r#"<rect x="{}" y="{:.1}" width="10" height="10" fill="{}"/><text x="{}" y="{:.1}" font-size="11">{}</text>"#,
            x1 + 70.0,
            ly,
            s.colour,
            x1 + 84.0,
            ly + 9.0,
            escape(&s.name)
        );
    }
}

/// The chart of `entries`: the full-size runs, or the `--quick` ones (marked as such) when the
/// history holds no full-size run.
pub fn chart(entries: &[Value]) -> String {
    let full: Vec<&Value> = entries.iter().filter(|e| e["quick"] != Value::Bool(true)).collect();
    let (shown, note) = if full.is_empty() {
        (entries.iter().collect::<Vec<_>>(), " (--quick runs: not measurements)")
    } else {
        (full, "")
    };
    let commits: Vec<String> = shown
        .iter()
        .map(|e| {
            e["commit"].as_str().unwrap_or("?").split_whitespace().next().unwrap_or("?").to_string()
        })
        .collect();
    let mut colour = COLOURS.iter().cycle();
    let mut ratios = Vec::new();
    let frame_names: Vec<String> = {
        let mut names: Vec<String> = Vec::new();
        for e in &shown {
            for f in e["frames"].as_array().into_iter().flatten() {
                if let Some(n) = f["name"].as_str().filter(|n| !names.iter().any(|m| m == n)) {
                    names.push(n.to_string());
                }
            }
        }
        names
    };
    for (fi, frame) in frame_names.iter().enumerate() {
        let mut stages: Vec<String> = Vec::new();
        for e in &shown {
            for f in e["frames"]
                .as_array()
                .into_iter()
                .flatten()
                .filter(|f| f["name"].as_str() == Some(frame))
            {
                for k in f["ratios"].as_object().into_iter().flatten().map(|(k, _)| k) {
                    if !stages.contains(k) {
                        stages.push(k.clone());
                    }
                }
            }
        }
        // Every stage of the first frame; only the whole frame of the others (one chart stays legible).
        for stage in stages.iter().filter(|s| fi == 0 || s.as_str() == "total") {
            let values = shown
                .iter()
                .map(|e| {
                    e["frames"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .find(|f| f["name"].as_str() == Some(frame))
                        .and_then(|f| f["ratios"][stage.as_str()].as_f64())
                })
                .collect();
            let scene = frame.split_whitespace().next().unwrap_or(frame);
            let name = if fi == 0 { stage.clone() } else { format!("{scene}: {stage}") };
            ratios.push(Series { name, colour: colour.next().unwrap_or(&"#000"), values });
        }
    }
    let one = |key: &str, name: &str, c: &'static str| {
        vec![Series {
            name: name.into(),
            colour: c,
            values: shown.iter().map(|e| e[key].as_f64()).collect(),
        }]
    };
    let height = 3.0 * PANEL;
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" font-family="sans-serif" viewBox="0 0 {WIDTH} {height}">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let first = frame_names.first().map_or("no frame".to_string(), |f| f.clone());
    panel(
        &mut svg,
        0.0,
        &format!("GPU / CPU time per stage, {first} (lower is better){note}"),
        &ratios,
        STAGE_RATIO_TARGET,
        &commits,
        true,
    );
    panel(
        &mut svg,
        PANEL,
        &format!("k-means: faiss-cpu time / vplgi CPU time, gamma = 1 (higher is better){note}"),
        &one("kmeans_speedup_over_faiss", "speed-up", "#2ca02c"),
        KMEANS_SPEEDUP_TARGET,
        &commits,
        false,
    );
    panel(
        &mut svg,
        2.0 * PANEL,
        &format!("visibility: % of raw Embree throughput (higher is better){note}"),
        &[
            one("visibility_percent_of_embree", "% of the one-ray loop", "#1f77b4"),
            one("visibility_percent_of_fastest_embree", "% of the fastest loop", "#d62728"),
        ]
        .concat(),
        VISIBILITY_PERCENT_TARGET,
        &commits,
        false,
    );
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(commit: &str, quick: bool, shade: f64) -> Value {
        json!({
            "machine": {"commit": commit, "date": "2026-12-02 17:00 UTC"},
            "quick": quick,
            "adapter": "llvmpipe",
            "frames": [{"name": "cornell-box 512x512", "stages": [{"stage": "shade", "ratio": shade}, {"stage": "total", "ratio": 2.0}]}],
            "kmeans": {"rows": [{"name": "faiss-cpu 1.15.1", "seconds": 6.0}, {"name": "vplgi `cluster`, CPU, gamma = 1: every point", "seconds": 2.0}]},
            "visibility": {"percent_of_raw": 90.0, "percent_of_fastest": 85.0},
            "floor": {"ratio": 1.1},
        })
    }

    #[test]
    fn an_entry_keeps_the_tracked_ratios() {
        let e = entry(&report("abc1234", false, 1.5));
        assert_eq!(e["frames"][0]["ratios"]["shade"], 1.5);
        assert_eq!(e["kmeans_speedup_over_faiss"], 3.0);
        assert_eq!(e["visibility_percent_of_embree"], 90.0);
        assert_eq!(e["visibility_percent_of_fastest_embree"], 85.0);
        assert_eq!(e["commit"], "abc1234");
    }

    #[test]
    fn runs_accumulate_and_are_charted_in_order() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("history.json");
        append(&path, entry(&report("aaaaaaa", false, 4.0))).expect("first");
        let all = append(&path, entry(&report("bbbbbbb", false, 2.0))).expect("second");
        assert_eq!(all.len(), 2);
        let svg = chart(&all);
        assert!(
            svg.find("aaaaaaa").expect("first commit")
                < svg.find("bbbbbbb").expect("second commit")
        );
        assert!(svg.contains("<polyline"), "two runs draw lines");
        assert!(!svg.contains("--quick"), "full-size runs are not marked as quick");
        // Quick runs are left out once a full-size run exists.
        let all = append(&path, entry(&report("ccccccc", true, 9.0))).expect("third");
        assert!(!chart(&all).contains("ccccccc"));
    }

    #[test]
    fn a_broken_history_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("history.json");
        std::fs::write(&path, "{ not json").expect("write");
        let e = append(&path, json!({})).expect_err("broken file");
        assert!(format!("{e:#}").contains("history.json"), "{e:#}");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "{ not json",
            "the broken file is left as it was"
        );
    }
}
