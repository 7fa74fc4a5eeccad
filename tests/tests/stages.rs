//! The stage table is complete: every stage of `vplgi_frame::stage_table!` has its CPU and GPU
//! implementation in the module named after it, its shader, its verify comparison judged against
//! a SPEC tolerance, its property test and its bench; every part (a variant timed as its stage)
//! has its modules and shader. And what the Makefile reads from the table (the property tests it
//! runs, the files it mutates) is the table. No GPU needed.

use std::path::{Path, PathBuf};
use std::process::Command;
use vplgi_frame::Stage;

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the repository")
        .to_path_buf()
}

fn read(path: &str) -> Option<String> {
    std::fs::read_to_string(repository().join(path)).ok()
}

/// `shading_points` -> `ShadingPoints`: the trait a module implements.
fn trait_of(module: &str) -> String {
    module.split('_').map(|w| w[..1].to_uppercase() + &w[1..]).collect()
}

/// What a stage or part lacks, one line each.
fn missing(stage: Stage) -> Vec<String> {
    let mut missing = Vec::new();
    let name = stage.name();
    let mut lacks = |what: String| missing.push(format!("{name}: {what}"));
    for module in std::iter::once(name).chain(stage.parts().iter().copied()) {
        let implementation = format!("impl vplgi_frame::stages::{} for", trait_of(module));
        for backend in ["vplgi-cpu", "vplgi-gpu"] {
            let path = format!("crates/{backend}/src/{module}.rs");
            match read(&path) {
                Some(text) if text.contains(&implementation) => {}
                Some(_) => lacks(format!("{path} does not implement {}", trait_of(module))),
                None => lacks(format!("no {path}")),
            }
        }
        let (file, passes) = (format!("{module}.wgsl"), format!("{module}_"));
        if !vplgi_gpu::shader::STAGES.iter().any(|(f, _, _)| *f == file || f.starts_with(&passes)) {
            lacks(format!("no shaders/{file} (or {passes}*.wgsl)"));
        }
    }
    if vplgi_verify::VerifyStage::from_name(name).is_none() {
        lacks("no row in vplgi verify".into());
    }
    match read(&format!("crates/vplgi-verify/src/{name}.rs")) {
        Some(text)
            if text.contains("use crate::tolerance::")
                && (text.contains("Disagreement::at_most")
                    || text.contains("Disagreement::at_least")
                    || text.contains("tolerance::share_of_diverged(")) => {}
        Some(_) => lacks("its verify comparison judges nothing against the tolerance table".into()),
        None => lacks(format!("no crates/vplgi-verify/src/{name}.rs")),
    }
    match read(&format!("tests/tests/{name}.rs")) {
        Some(text) if text.contains("proptest!") => {}
        Some(_) => lacks(format!("tests/tests/{name}.rs has no property test")),
        None => lacks(format!("no property test tests/tests/{name}.rs")),
    }
    match read(&format!("benches/benches/stages/{name}.rs")) {
        Some(text) if text.contains("criterion_group!(benches") => {}
        Some(_) => {
            lacks(format!("benches/benches/stages/{name}.rs has no criterion group `benches`"))
        }
        None => lacks(format!("no bench benches/benches/stages/{name}.rs")),
    }
    missing
}

#[test]
fn every_stage_has_all_of_its_files() {
    let missing: Vec<String> = Stage::ALL.into_iter().flat_map(missing).collect();
    assert!(missing.is_empty(), "the stage table is incomplete:\n  {}", missing.join("\n  "));
}

/// A stage trait is implemented in its own module and nowhere else, so each backend's stage has
/// one home.
#[test]
fn stage_traits_are_implemented_in_their_own_modules() {
    for backend in ["vplgi-cpu", "vplgi-gpu"] {
        let dir = repository().join(format!("crates/{backend}/src"));
        let mut files = Vec::new();
        let mut stack = vec![dir.clone()];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).expect("readable").flatten() {
                let p = e.path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    files.push(p);
                }
            }
        }
        for file in files {
            let text = std::fs::read_to_string(&file).expect("readable");
            let home = file
                .strip_prefix(&dir)
                .expect("below src")
                .with_extension("")
                .to_string_lossy()
                .into_owned();
            for line in text.lines().filter(|l| l.starts_with("impl vplgi_frame::stages::")) {
                let t = line
                    .trim_start_matches("impl vplgi_frame::stages::")
                    .split_whitespace()
                    .next()
                    .unwrap_or_default();
                assert_eq!(trait_of(&home), t, "{}: {line}", file.display());
            }
        }
    }
}

/// `make stages` prints the stages, then every stage and part module, as the Makefile's
/// property-test and mutant lists read them from the table.
#[test]
fn the_makefile_reads_the_table() {
    let out = Command::new("make")
        .args(["-s", "--no-print-directory", "stages"])
        .current_dir(repository())
        .output()
        .expect("make runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let lines: Vec<&str> = text.lines().collect();
    let stages: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
    let modules: Vec<&str> = Stage::ALL
        .iter()
        .flat_map(|s| std::iter::once(s.name()).chain(s.parts().iter().copied()))
        .collect();
    assert_eq!(lines, [stages.join(" "), modules.join(" ")]);
}
