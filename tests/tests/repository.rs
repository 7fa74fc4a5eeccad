//! The repository's own references: every path to a file of the repository that a comment, a
//! doc or the Makefile names exists. A renamed or deleted file otherwise leaves its readers
//! pointed at nothing (`frame.wgsl` named two `pipeline.rs` files long gone).

use std::path::{Path, PathBuf};

/// Where paths are named: source, shaders, docs, scripts and the Makefile.
const NAMING: [&str; 7] = ["rs", "wgsl", "md", "sh", "toml", "py", "yaml"];

/// Folders of the repository a path may start with; a crate's folder may be named without
/// `crates/` (`vplgi-gpu/src/bvh.rs`).
const ROOTS: [&str; 10] = [
    "crates/",
    "shaders/",
    "tests/",
    "benches/",
    "reports/",
    "docs/",
    "ci/",
    "fixtures/",
    "fuzz/",
    "vplgi-",
];

/// Paths that name what runs make, not what the repository holds.
const MADE: [&str; 5] = ["fuzz/target", "fuzz/corpus", "fuzz/artifacts", "target/", "out/"];

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the repository")
        .to_path_buf()
}

/// The files that may name paths, below `dir`, skipping build output and hidden folders.
fn naming_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable folder").flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if !name.starts_with('.') && name != "target" && name != "out" && name != "node_modules"
            {
                naming_files(&path, out);
            }
        } else if name == "Makefile"
            || path.extension().is_some_and(|e| NAMING.contains(&e.to_string_lossy().as_ref()))
        {
            out.push(path);
        }
    }
}

/// The repository paths named in `text`: a root at a word's start, then path characters; not a
/// pattern (`<stage>`, `{file}`, `$$t`) and not outside the repository (`../shared/`).
fn named_paths(text: &str) -> Vec<String> {
    let is_path_char = |c: char| c.is_ascii_alphanumeric() || "_./-*<>{}$".contains(c);
    let mut found = Vec::new();
    let bytes = text.as_bytes();
    for (i, _) in text.char_indices() {
        if i > 0 && (is_path_char(bytes[i - 1] as char) || bytes[i - 1] == b'/') {
            continue;
        }
        let Some(root) = ROOTS.iter().find(|r| text[i..].starts_with(*r)) else { continue };
        let end = text[i..].find(|c: char| !is_path_char(c)).map_or(text.len(), |e| i + e);
        let path = text[i..end].trim_end_matches(['.', '-', '/']);
        if !path.contains('/')
            || path.contains(['<', '{', '$'])
            || MADE.iter().any(|m| path.starts_with(m))
        {
            continue;
        }
        if *root == "vplgi-" {
            found.push(format!("crates/{path}"));
        } else {
            found.push(path.to_string());
        }
    }
    found
}

/// Whether `path` (relative to the repository, at most one `*` in its last part) names something.
fn exists(repo: &Path, path: &str) -> bool {
    let Some((dir, last)) = path.rsplit_once('/').filter(|_| path.contains('*')) else {
        return repo.join(path).exists();
    };
    let (head, tail) = last.split_once('*').unwrap_or((last, ""));
    std::fs::read_dir(repo.join(dir)).is_ok_and(|d| {
        d.flatten().any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with(head) && n.ends_with(tail) && n.len() >= head.len() + tail.len()
        })
    })
}

#[test]
fn every_path_named_in_comments_and_docs_exists() {
    let repo = repository();
    let mut files = Vec::new();
    naming_files(&repo, &mut files);
    let (mut checked, mut missing) = (0usize, Vec::new());
    for file in &files {
        let Ok(text) = std::fs::read_to_string(file) else { continue };
        for path in named_paths(&text) {
            checked += 1;
            if !exists(&repo, &path) {
                missing.push(format!(
                    "{}: {path}",
                    file.strip_prefix(&repo).unwrap_or(file).display()
                ));
            }
        }
    }
    missing.sort();
    missing.dedup();
    println!("{checked} paths named in {} files", files.len());
    assert!(checked > 300, "only {checked} paths found: the scan is broken");
    assert!(missing.is_empty(), "{} paths name nothing:\n{}", missing.len(), missing.join("\n"));
}

/// The scanner itself: roots at a word's start, crate folders without `crates/`, globs,
/// sentence ends; patterns, outside paths and made files skipped.
#[test]
fn named_paths_are_read_as_written() {
    let text = "see crates/vplgi-cpu/src/shade.rs. Also vplgi-gpu/src/bvh.rs, shaders/cluster_*.wgsl and \
                tests/tests/<stage>.rs, ../shared/SPEC.md, fuzz/target/x.log, crates/c/src/{file}, my-crates/x.rs";
    assert_eq!(
        named_paths(text),
        ["crates/vplgi-cpu/src/shade.rs", "crates/vplgi-gpu/src/bvh.rs", "shaders/cluster_*.wgsl"]
    );
    let repo = repository();
    // Absent files, spelled so that the scan of this file does not read them as named.
    let absent = |name: &str| ["shaders", name].join("/");
    assert!(
        exists(&repo, "shaders/cluster_*.wgsl")
            && !exists(&repo, &absent("nothing_*.wgsl"))
            && !exists(&repo, &absent("none.wgsl"))
    );
}
