//! The shader registry, from the files themselves: every `shaders/*.wgsl` is a stage module whose
//! first line names the shared files of `shaders/common/` it is composed with
//! (`// include: common/types.wgsl common/rng.wgsl`), and every `shaders/common/*.wgsl` is such a
//! shared file. A new shader, stage or shared, is registered by existing.

use std::fmt::Write as _;
use std::path::Path;

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    let common = dir.join("common");
    println!("cargo::rerun-if-changed={}", dir.display());
    println!("cargo::rerun-if-changed={}", common.display());
    let mut out =
        String::from("/// Shared WGSL files by name (`common/rng.wgsl`), from `build.rs`.\n");
    out.push_str("pub const COMMON: &[(&str, &str)] = &[\n");
    for path in wgsl_files(&common) {
        let name = path.file_name().and_then(|n| n.to_str()).expect("a UTF-8 file name");
        let path = path.canonicalize().expect("the shader's path");
        writeln!(out, "    (\"common/{name}\", include_str!({:?})),", path.display().to_string())
            .expect("a string");
    }
    out.push_str("];\n");
    let files = wgsl_files(&dir);
    out.push_str("/// Stage files: (name, source, the common files it includes, in order), from `build.rs`.\n");
    out.push_str("pub const STAGES: &[(&str, &str, &[&str])] = &[\n");
    for path in files {
        let name = path.file_name().and_then(|n| n.to_str()).expect("a UTF-8 file name");
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let Some(includes) = text.lines().next().and_then(|l| l.strip_prefix("// include:")) else {
            panic!(
                "{}: the first line must be `// include:` and the common files the shader uses",
                path.display()
            );
        };
        let includes: Vec<String> = includes.split_whitespace().map(|i| format!("{i:?}")).collect();
        let path = path.canonicalize().expect("the shader's path");
        writeln!(
            out,
            "    ({name:?}, include_str!({:?}), &[{}]),",
            path.display().to_string(),
            includes.join(", ")
        )
        .expect("a string");
    }
    out.push_str("];\n");
    let target = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("shaders.rs");
    std::fs::write(&target, out).unwrap_or_else(|e| panic!("{}: {e}", target.display()));
}

/// The `.wgsl` files directly in `dir`, sorted.
fn wgsl_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a shaders/ entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
        .collect();
    files.sort();
    files
}
