//! `vplgi verify`: every stage of the GPU twin against the CPU reference on a scene, each judged
//! on the CPU's inputs against the SPEC's tolerances, written as verify.json, verify.md and
//! verify.html.

use crate::frame_args::{FrameArgs, VERIFY};
use crate::shared::{load_scene, use_shaders_from};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use vplgi_verify::report::{write, write_images, write_maps, VerifyReport};
use vplgi_verify::{Listener, Mode, Plan, StageResult, Twins, VerifyStage};

#[derive(Args)]
pub struct VerifyArgs {
    /// Scene file (.gltf or .glb). Omitted or `cornell-box`: the built-in Cornell box.
    scene: Option<PathBuf>,
    #[command(flatten)]
    frame: FrameArgs,
    /// Stages to verify, comma-separated [default: all]. rsm_vpls verifies the reflective shadow
    /// maps of --rsm-size whatever --vpl-source is; bias_points is the clamp's bias compensation;
    /// shade and frame run in every mode (--cluster x --fuzzy) unless --cluster or --fuzzy picks
    /// one.
    #[arg(long, value_delimiter = ',', value_parser = StageParser, value_name = "LIST")]
    stages: Vec<VerifyStage>,
    /// Read the WGSL from DIR instead of the compiled-in copies: every file DIR holds under the
    /// names of shaders/ (shade.wgsl, common/rng.wgsl, ...) replaces the built-in one, so an
    /// edited kernel is verified without rebuilding vplgi. `--shaders shaders` in a checkout.
    #[arg(long, value_name = "DIR")]
    shaders: Option<PathBuf>,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "out/verify")]
    out: PathBuf,
}

/// Reads a stage by name; its possible values, which `--help` lists, are the stages of
/// `VerifyStage::ALL`.
#[derive(Clone)]
struct StageParser;

impl clap::builder::TypedValueParser for StageParser {
    type Value = VerifyStage;

    fn parse_ref(
        &self,
        _cmd: &clap::Command,
        _arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<VerifyStage, clap::Error> {
        let s = value.to_string_lossy();
        VerifyStage::from_name(s.trim()).ok_or_else(|| {
            let names: Vec<&str> = VerifyStage::ALL.iter().map(|s| s.name()).collect();
            clap::Error::raw(
                clap::error::ErrorKind::InvalidValue,
                format!("unknown stage '{s}' (stages: {})\n", names.join(", ")),
            )
        })
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(VerifyStage::ALL.iter().map(|s| clap::builder::PossibleValue::new(s.name()))))
    }
}

/// Prints each stage's measurements as it finishes.
struct Printer;

impl Listener for Printer {
    fn started(&self, stage: VerifyStage) {
        eprintln!("verifying {} ...", stage.name());
    }
    fn finished(&self, r: &StageResult) {
        for c in &r.checks {
            println!("{c}");
        }
        println!(
            "{}: {} in {:.2} s",
            r.stage.name(),
            if r.passed() { "ok" } else { "FAILS" },
            r.seconds
        );
    }
}

pub fn run(args: VerifyArgs) -> Result<()> {
    let config = args.frame.config(&VERIFY)?;
    let modes = if args.frame.cluster.is_some() || args.frame.fuzzy.is_some() {
        vec![Mode::of(&config)]
    } else {
        Mode::ALL.to_vec()
    };
    let stages =
        if args.stages.is_empty() { VerifyStage::ALL.to_vec() } else { args.stages.clone() };
    let shaders = use_shaders_from(args.shaders.as_deref())?;
    let (scene, source) = load_scene(args.scene.as_deref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;

    let clock = Instant::now();
    let ctx = vplgi_gpu::GpuContext::new()
        .context("vplgi verify compares the GPU twin with the CPU: it needs a GPU adapter")?;
    eprintln!("verifying on {} (lavapipe runs the GPU kernels on the CPU)", ctx.describe());
    let device = vplgi_embree::Device::new(None)?;
    let cs = vplgi_cpu::CpuScene::new(&scene, &device)
        .with_context(|| format!("building the Embree scene for {source}"))?;
    let kernels = vplgi_gpu::GpuKernels::new(&ctx.device)?;
    let gb = vplgi_gpu::GpuBackend::new(&ctx.device, &ctx.queue, &kernels, &scene)
        .with_context(|| format!("uploading {source} to the GPU"))?;
    let twins = Twins { scene: &scene, cpu: &cs, gpu: &gb };
    let plan = Plan { config: config.clone(), modes: modes.clone(), stages };
    let results = vplgi_verify::run(&twins, &plan, &Printer)?;
    let errors = ctx.take_uncaptured_errors();
    if !errors.is_empty() {
        bail!("the GPU reported errors outside any check: {}", errors.join("; "));
    }

    let images = write_images(&args.out, &results)?;
    let maps = write_maps(&args.out, &results)?;
    let report = VerifyReport {
        scene: source,
        adapter: ctx.describe(),
        config,
        modes: modes.iter().map(|m| m.name()).collect(),
        shaders,
        passed: results.iter().all(StageResult::passed),
        stages: results,
        images,
        maps,
        seconds: clock.elapsed().as_secs_f64(),
    };
    write(&args.out, &report)?;
    let page = args.out.join("verify.html");
    let failures: Vec<_> = report.failures().collect();
    // The summary last, so a terminal shows it without scrolling.
    let summary = vplgi_verify::report::summary_text(&report);
    if failures.is_empty() {
        let judged = report.stages.iter().flat_map(|s| &s.checks).filter(|c| c.judged()).count();
        println!(
            "\nverify: PASS, {judged} checks within the SPEC's tolerances in {:.0} s. Report: {} (and verify.md, verify.json)",
            report.seconds,
            page.display()
        );
        println!("\n{}", summary.trim_end());
        return Ok(());
    }
    eprintln!("\nverify: FAIL. Report: {} (and verify.md, verify.json)", page.display());
    for f in &failures {
        eprintln!("  {f}");
    }
    let failing: Vec<&str> =
        report.stages.iter().filter(|s| !s.passed()).map(|s| s.stage.name()).collect();
    for m in report.maps.iter().filter(|m| failing.contains(&m.stage.as_str())) {
        eprintln!("  where {} disagrees: {}", m.case, args.out.join(&m.file).display());
    }
    println!("\n{}", summary.trim_end());
    let first = failures[0];
    bail!(
        "{} check(s) outside the SPEC's tolerances; first: stage {}{}: {} = {} (bound {})",
        failures.len(),
        first.stage,
        if first.case.is_empty() { String::new() } else { format!(" ({})", first.case) },
        first.what,
        first.measured_text(),
        first.bound_text()
    )
}
