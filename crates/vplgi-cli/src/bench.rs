//! `vplgi bench`: the paper's timing method (section 4.1) — every configuration rendered `runs`
//! times, each stage reported as the mean of its `best` smallest times — for a scene and a list
//! of configurations, written as JSON and as a Markdown table.

use crate::engine::{with_engine, BackendArg};
use crate::frame_args::{FrameArgs, BENCH};
use crate::shared::{load_scene, write_json};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use vplgi_frame::{NoProgress, Stage, StageTimings};
use vplgi_types::{ClusterMode, Preset};

#[derive(Args)]
pub struct BenchArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Configurations to time, in order.
    #[arg(long = "config", value_enum, num_args = 1.., default_values = ["reference", "light", "intermediate", "high"])]
    configs: Vec<Preset>,
    /// Where the frames run.
    #[arg(long, value_enum, default_value = "cpu")]
    backend: BackendArg,
    /// Renders per configuration.
    #[arg(long, default_value_t = 10)]
    runs: usize,
    /// Each stage's time is the mean of its `best` smallest times over the runs.
    #[arg(long, default_value_t = 3)]
    best: usize,
    /// Options laid over every preset of --config.
    #[command(flatten)]
    frame: FrameArgs,
    /// Output directory for bench.json and bench.md.
    #[arg(long, value_name = "DIR", default_value = "out/bench")]
    out: PathBuf,
}

/// Mean of the `best` smallest values.
fn best_mean(values: &mut [f64], best: usize) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = best.min(values.len()).max(1);
    values[..n].iter().sum::<f64>() / n as f64
}

/// Every stage the mean of its `best` smallest times; the total is their sum.
fn summarize(runs: &[StageTimings], best: usize) -> StageTimings {
    StageTimings::combine(runs, |v| best_mean(v, best))
}

pub fn run(args: BenchArgs) -> Result<()> {
    if args.runs == 0 || args.best == 0 || args.best > args.runs {
        bail!("need 1 <= --best <= --runs (got --best {} --runs {})", args.best, args.runs);
    }
    let (scene, source) = load_scene(args.scene.as_deref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let configs = args
        .configs
        .iter()
        .map(|&p| {
            Ok((
                p,
                args.frame.config_of(&BENCH, p).with_context(|| format!("configuration {p:?}"))?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    let (summaries, rows, backend, adapter) = with_engine(
        args.backend,
        &scene,
        &source,
        |engine| {
            let mut rows = Vec::new();
            let mut summaries = Vec::new();
            for (preset, cfg) in &configs {
                // One untimed frame first: the GPU compiles its pipelines on first dispatch.
                engine.render(cfg, &NoProgress)?;
                let mut runs = Vec::with_capacity(args.runs);
                for i in 0..args.runs {
                    eprint!("\r{preset:?}: run {}/{}", i + 1, args.runs);
                    runs.push(engine.render(cfg, &NoProgress)?.timings);
                }
                eprintln!();
                let summary = summarize(&runs, args.best);
                rows.push(serde_json::json!({ "config": format!("{preset:?}").to_lowercase(), "params": cfg, "timings_ms": summary, "runs_ms": runs }));
                summaries.push(summary);
            }
            Ok((summaries, rows, engine.name, engine.adapter.as_ref().map(|a| a.name.clone())))
        },
    )?;

    let report = serde_json::json!({
        "scene": { "source": source, "name": scene.name, "triangles": scene.triangle_count() },
        "backend": backend,
        "adapter": adapter,
        "threads": rayon::current_num_threads(),
        "method": format!("each configuration rendered {} times after one untimed frame; every stage (and the total) is the mean of its {} smallest times", args.runs, args.best),
        "configs": rows,
    });
    let json_path = args.out.join("bench.json");
    write_json(&json_path, &report)?;

    let stage_names: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
    let mut md = format!(
        "# vplgi bench: {} ({} triangles), backend {}{}\n\n{}.\n\n| config | clusters VPL / SP | {} | total (ms) |\n|---|---|{}---:|\n",
        scene.name,
        scene.triangle_count(),
        backend,
        adapter.as_deref().map(|a| format!(" ({a}; GPU times on lavapipe run on the CPU cores)")).unwrap_or_default(),
        report["method"].as_str().unwrap_or_default(),
        stage_names.join(" | "),
        "---:|".repeat(Stage::ALL.len())
    );
    for ((preset, cfg), t) in configs.iter().zip(&summaries) {
        let clusters = if cfg.cluster == ClusterMode::None {
            "–".to_string()
        } else {
            format!("{} / {}", cfg.k_vpl, cfg.k_sp)
        };
        let stages: String = t.iter().map(|(_, ms)| format!(" {ms:.1} |")).collect();
        md.push_str(&format!("| {preset:?} | {clusters} |{stages} {:.1} |\n", t.total()));
    }
    let md_path = args.out.join("bench.md");
    vplgi_image::write_atomically(&md_path, |w| {
        use std::io::Write;
        w.write_all(md.as_bytes())
    })?;
    print!("{md}");
    println!("\nwrote {} and {}", json_path.display(), md_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn best_mean_takes_the_smallest() {
        assert_eq!(best_mean(&mut [5.0, 1.0, 3.0, 2.0], 3), 2.0);
        assert_eq!(best_mean(&mut [4.0], 3), 4.0);
    }
}
