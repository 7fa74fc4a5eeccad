//! `vplgi bench`: the paper's timing method (section 4.1) — every configuration rendered `runs`
//! times, each stage reported as the mean of its `best` smallest times — for a scene and a list
//! of configurations, written as JSON and as a Markdown table.

use crate::render::{load_scene, write_json};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use vplgi_types::{ClusterMode, FrameConfig, StageTimings};

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum Backend {
    Cpu,
    Gpu,
}

#[derive(Clone, Copy, PartialEq, ValueEnum, Debug)]
enum Preset {
    /// `--cluster none`: every shading point against every VPL.
    Reference,
    /// The paper's light setting: 750 VPL / 1,000 SP clusters.
    Light,
    /// The paper's intermediate setting: 2,000 VPL / 8,000 SP clusters.
    Intermediate,
    /// The paper's high-quality setting: 4,000 VPL / 30,000 SP clusters.
    High,
    /// vplgi's default: 1,000 VPL / 8,000 SP clusters.
    Default,
}

impl Preset {
    fn config(self) -> FrameConfig {
        match self {
            Preset::Reference => FrameConfig::reference(),
            Preset::Light => FrameConfig::paper_light(),
            Preset::Intermediate => FrameConfig::paper_intermediate(),
            Preset::High => FrameConfig::paper_high(),
            Preset::Default => FrameConfig::default(),
        }
    }
}

#[derive(Args)]
pub struct BenchArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Configurations to time, in order.
    #[arg(long = "config", value_enum, num_args = 1.., default_values = ["reference", "light", "intermediate", "high"])]
    configs: Vec<Preset>,
    /// Where the frames run.
    #[arg(long, value_enum, default_value = "cpu")]
    backend: Backend,
    /// Renders per configuration.
    #[arg(long, default_value_t = 10)]
    runs: usize,
    /// Each stage's time is the mean of its `best` smallest times over the runs.
    #[arg(long, default_value_t = 3)]
    best: usize,
    /// Image width (overrides the presets' 512).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (overrides the presets' 512).
    #[arg(long)]
    height: Option<u32>,
    /// Number of VPLs (overrides the presets' 10,000).
    #[arg(long)]
    vpls: Option<u32>,
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

fn summarize(runs: &[StageTimings], best: usize) -> StageTimings {
    let pick = |f: fn(&StageTimings) -> f64| best_mean(&mut runs.iter().map(f).collect::<Vec<_>>(), best);
    StageTimings {
        trace_vpls: pick(|t| t.trace_vpls),
        shading_points: pick(|t| t.shading_points),
        cluster: pick(|t| t.cluster),
        visibility: pick(|t| t.visibility),
        shade: pick(|t| t.shade),
        total: pick(|t| t.total),
    }
}

pub fn run(args: BenchArgs) -> Result<()> {
    if args.runs == 0 || args.best == 0 || args.best > args.runs {
        bail!("need 1 <= --best <= --runs (got --best {} --runs {})", args.best, args.runs);
    }
    let (scene, source) = load_scene(args.scene.as_deref())?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let configs: Vec<(Preset, FrameConfig)> = args
        .configs
        .iter()
        .map(|&p| {
            let mut c = p.config();
            c.width = args.width.unwrap_or(c.width);
            c.height = args.height.unwrap_or(c.height);
            c.vpls = args.vpls.unwrap_or(c.vpls);
            (p, c)
        })
        .collect();
    for (p, c) in &configs {
        c.validate().map_err(|e| anyhow::anyhow!("configuration {p:?}: {e}"))?;
    }

    let device = vplgi_embree::Device::new(None)?;
    let cs = vplgi_cpu::CpuScene::new(&scene, &device)?;
    let gpu = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => {
            let ctx = vplgi_gpu::GpuContext::new()?;
            let kernels = vplgi_gpu::pipeline::GpuKernels::new(&ctx.device)?;
            Some((ctx, kernels))
        }
    };
    let adapter = gpu.as_ref().map(|(c, _)| c.describe());
    let render = |cfg: &FrameConfig| -> Result<StageTimings> {
        Ok(match &gpu {
            None => vplgi_cpu::render(&cs, cfg, &vplgi_cpu::NoProgress)?.timings,
            Some((ctx, k)) => vplgi_gpu::pipeline::render(&ctx.device, &ctx.queue, k, &scene, cfg)?.timings,
        })
    };

    let mut rows = Vec::new();
    let mut summaries = Vec::new();
    for (preset, cfg) in &configs {
        // One untimed frame first: the GPU compiles its pipelines on first dispatch.
        render(cfg)?;
        let mut runs = Vec::with_capacity(args.runs);
        for i in 0..args.runs {
            eprint!("\r{preset:?}: run {}/{}", i + 1, args.runs);
            runs.push(render(cfg)?);
        }
        eprintln!();
        let summary = summarize(&runs, args.best);
        rows.push(serde_json::json!({ "config": format!("{preset:?}").to_lowercase(), "params": cfg, "timings_ms": summary, "runs_ms": runs }));
        summaries.push(summary);
    }

    let report = serde_json::json!({
        "scene": { "source": source, "name": scene.name, "triangles": scene.triangle_count() },
        "backend": if gpu.is_some() { "gpu" } else { "cpu" },
        "adapter": adapter,
        "threads": rayon::current_num_threads(),
        "method": format!("each configuration rendered {} times after one untimed frame; every stage (and the total) is the mean of its {} smallest times", args.runs, args.best),
        "configs": rows,
    });
    let json_path = args.out.join("bench.json");
    write_json(&json_path, &report)?;

    let mut md = format!(
        "# vplgi bench: {} ({} triangles), backend {}{}\n\n{}.\n\n| config | clusters VPL / SP | trace_vpls | shading_points | cluster | visibility | shade | total (ms) |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
        scene.name,
        scene.triangle_count(),
        if gpu.is_some() { "gpu" } else { "cpu" },
        adapter.as_deref().map(|a| format!(" ({a}; GPU times on lavapipe run on the CPU cores)")).unwrap_or_default(),
        report["method"].as_str().unwrap_or_default()
    );
    for ((preset, cfg), t) in configs.iter().zip(&summaries) {
        let clusters = if cfg.cluster == ClusterMode::None { "–".to_string() } else { format!("{} / {}", cfg.k_vpl, cfg.k_sp) };
        md.push_str(&format!(
            "| {:?} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |\n",
            preset, clusters, t.trace_vpls, t.shading_points, t.cluster, t.visibility, t.shade, t.total
        ));
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
