//! `make bench`'s verdict: every benchmark criterion ran in this run, against the saved baseline,
//! as slower, faster or within the noise. The noise is measured, not assumed: each side's median
//! comes with criterion's 95 % bootstrap interval, and a change counts only when it exceeds both
//! intervals' half-widths combined (root sum of squares). Criterion's own verdict uses a fixed
//! 1 % threshold, which this machine's run-to-run spread (up to ±10 %) exceeds.

use anyhow::{Context, Result};
use clap::Parser;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

#[derive(Parser)]
#[command(
    about = "Compares the benchmarks of this criterion run with a saved baseline, beyond the measured noise"
)]
struct Opts {
    /// Criterion's output folder.
    #[arg(long, default_value = "target/criterion")]
    criterion: PathBuf,
    /// The saved baseline's name (`cargo bench -- --save-baseline NAME`).
    #[arg(long, default_value = "main")]
    baseline: String,
    /// Only benchmarks measured after this Unix time (seconds): this run's.
    #[arg(long, default_value_t = 0)]
    since: u64,
}

/// Median and the half-width of its 95 % interval, in nanoseconds.
fn median(path: &Path) -> Result<(f64, f64)> {
    let v: Value = serde_json::from_slice(
        &std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?,
    )
    .with_context(|| format!("{} is not criterion's JSON", path.display()))?;
    let m = &v["median"];
    let (p, lo, hi) = (
        m["point_estimate"].as_f64(),
        m["confidence_interval"]["lower_bound"].as_f64(),
        m["confidence_interval"]["upper_bound"].as_f64(),
    );
    match (p, lo, hi) {
        (Some(p), Some(lo), Some(hi)) => Ok((p, (hi - lo) / 2.0)),
        _ => anyhow::bail!("{}: no median with an interval", path.display()),
    }
}

/// Every benchmark folder under `dir` (one holding `new/benchmark.json`).
fn benchmarks(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.join("new/benchmark.json").is_file() {
            out.push(p.clone());
        }
        if p.is_dir() {
            benchmarks(&p, out);
        }
    }
}

fn modified_after(path: &Path, since: u64) -> bool {
    let t = std::fs::metadata(path).and_then(|m| m.modified()).ok();
    t.and_then(|t| t.duration_since(SystemTime::UNIX_EPOCH).ok())
        .is_some_and(|d| d.as_secs() >= since)
}

fn main() -> Result<()> {
    let opts = Opts::parse();
    let mut dirs = Vec::new();
    benchmarks(&opts.criterion, &mut dirs);
    dirs.sort();
    let (mut slower, mut faster, mut same, mut new) = (Vec::new(), 0, 0, 0);
    println!("against baseline '{}' (a change counts when it exceeds the two medians' 95 % intervals combined):", opts.baseline);
    for d in dirs.iter().filter(|d| modified_after(&d.join("new/benchmark.json"), opts.since)) {
        let id = d.strip_prefix(&opts.criterion).unwrap_or(d).display().to_string();
        let base = d.join(&opts.baseline).join("estimates.json");
        if !base.is_file() {
            println!("  {id:<40} no baseline yet");
            new += 1;
            continue;
        }
        let (b, bn) = median(&base)?;
        let (n, nn) = median(&d.join("new/estimates.json"))?;
        let change = (n - b) / b;
        let noise = ((bn / b).powi(2) + (nn / n).powi(2)).sqrt();
        let verdict = if change > noise {
            slower.push(id.clone());
            "SLOWER"
        } else if -change > noise {
            faster += 1;
            "faster"
        } else {
            same += 1;
            "within noise"
        };
        println!(
            "  {id:<40} {:>10.3} ms -> {:>10.3} ms  {:>+7.1} % (noise ±{:.1} %)  {verdict}",
            b / 1e6,
            n / 1e6,
            change * 100.0,
            noise * 100.0
        );
    }
    println!(
        "{} slower, {faster} faster, {same} within noise, {new} without a baseline",
        slower.len()
    );
    if !slower.is_empty() {
        println!("regressions beyond the noise: {}", slower.join(", "));
    }
    Ok(())
}
