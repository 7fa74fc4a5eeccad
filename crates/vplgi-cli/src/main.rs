//! `vplgi`: render scenes with the clustered-VPL pipeline and compare images.

mod bench;
mod compare;
mod engine;
mod frame_args;
mod plot;
mod progress;
mod reference;
mod render;
mod scene;
mod shared;
mod sweep;
mod verify;

use clap::{CommandFactory, FromArgMatches, Subcommand};
use std::process::ExitCode;

/// Clustered virtual-point-light global illumination: a CPU reference (rayon + Embree 4) of the
/// pipeline of "fuzzy clustering of VPLs and shading points", with reference-image tools.
#[derive(clap::Parser)]
#[command(name = "vplgi", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (default: the built-in Cornell box) to DIR/image.exr, DIR/image.png and
    /// DIR/report.json.
    Render(render::RenderArgs),
    /// Compare a test image with a reference: prints MSE, relMSE and FLIP, writes
    /// DIR/compare.json and a false-colour FLIP error map DIR/error_map.png.
    Compare(compare::CompareArgs),
    /// Time configurations the paper's way (each rendered --runs times; every stage the mean of
    /// its --best smallest times); writes DIR/bench.json and DIR/bench.md.
    Bench(bench::BenchArgs),
    /// The paper's Figures 7, 9 and 11 for a scene: frame time split by stage and image error
    /// (MSE, FLIP) as the cluster counts vary, as PNG and SVG charts, plus a contact sheet of
    /// every configuration's image and error map; writes into DIR.
    Sweep(sweep::SweepArgs),
    /// Scenes: `vplgi scene generate NAME` writes a procedural scene at the paper's scale as .glb;
    /// `vplgi scene export --format mitsuba SCENE --out DIR` writes any scene for Mitsuba 3.
    Scene(scene::SceneArgs),
    /// Render an unclustered reference as the mean and per-pixel variance of several seeds:
    /// DIR/mean.exr, DIR/variance.exr, DIR/mean.png and the sidecar DIR/reference.json.
    /// The geometry-term clamp's bias is compensated (--bias-compensation). --tile I/N renders a
    /// band of rows, for several machines or a job array. With --cluster, the mean and variance
    /// of a clustered configuration instead (a regression baseline: clamped, as `render` draws
    /// it, unless --bias-compensation is given).
    Reference(reference::ReferenceArgs),
    /// Join the folders of a reference's tiles (vplgi reference --tile I/N) into one reference,
    /// bit-identical to rendering it in one run.
    Merge(reference::MergeArgs),
    /// Differential test of the GPU twin: every stage on both backends, each GPU stage fed the
    /// CPU's outputs of the stages before it, measured against the SPEC's tolerance table; then
    /// the whole frame. Writes DIR/verify.html (a summary, failing stages first with a map of
    /// where each fails; then tables, CPU and GPU images and error maps, and for every stage
    /// whose items disagree beyond a tie a map of where, coloured by kind), DIR/verify.md and
    /// DIR/verify.json; exits non-zero, naming the stage, the worst item and its values, when a
    /// tolerance is broken. --shaders DIR verifies edited WGSL without rebuilding.
    Verify(verify::VerifyArgs),
}

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing into a closed pipe (`vplgi compare A B | head -1`) would
    // panic; the default action ends the process quietly, as for other command-line tools.
    // Outputs are written atomically, so an interrupted run leaves no partial file.
    // SAFETY: setting a signal's disposition to its default before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // The frame options' help shows each subcommand's defaults, read from FrameConfig.
    let matches = frame_args::document(Cli::command()).get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Render(args) => render::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::Scene(args) => scene::run(args),
        Command::Reference(args) => reference::run(args),
        Command::Merge(args) => reference::merge(args),
        Command::Verify(args) => verify::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, `: `-separated, leaving out a cause whose text the
/// message before it already ends with (our errors name their cause in their own message).
fn describe(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !line.ends_with(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
    }
    line
}

/// `docs/CLI.md`, the option reference, is clap's help of every command, so it cannot drift from
/// the definitions: `make cli-doc` writes it and this test fails when it is out of date.
#[cfg(test)]
mod cli_doc {
    use super::*;
    use std::path::PathBuf;

    /// Help is wrapped at this width, whatever terminal runs the test.
    const WIDTH: usize = 100;

    fn section(cmd: &mut clap::Command, path: &str, out: &mut String) {
        out.push_str(&format!(
            "\n## `{path}`\n\n```text\n{}\n```\n",
            cmd.render_long_help().to_string().trim_end()
        ));
        for sub in cmd.get_subcommands_mut() {
            if sub.get_name() != "help" {
                let name = format!("{path} {}", sub.get_name());
                section(sub, &name, out);
            }
        }
    }

    fn markdown() -> String {
        let mut cmd = frame_args::document(Cli::command()).term_width(WIDTH).max_term_width(WIDTH);
        cmd.build();
        let mut out = String::from(
            "# vplgi command-line reference\n\nGenerated by `make cli-doc` from clap's definitions \
             (the help every command prints with `--help`); a test fails when it is out of date.\n",
        );
        section(&mut cmd, "vplgi", &mut out);
        out
    }

    #[test]
    fn cli_md_is_up_to_date() {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/CLI.md");
        let want = markdown();
        if std::env::var_os("VPLGI_WRITE_CLI_DOC").is_some() {
            std::fs::write(&path, &want).expect("docs/CLI.md written");
            return;
        }
        let have = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            have == want,
            "docs/CLI.md is out of date with the command-line definitions: run `make cli-doc`"
        );
    }
}
