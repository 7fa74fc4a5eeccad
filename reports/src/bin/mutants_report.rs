//! `make mutants`' bookkeeping. A full run is many hours on 2 cores, longer than a working session,
//! so outcomes accumulate in a committed ledger (`ci/mutants-ledger.tsv`) and each run tests only
//! the mutants the ledger has no outcome for.
//!
//! A ledger row holds the outcome, the commit the run started on, and the mutant's key: its file,
//! a hash of the text of the function it mutates, its place relative to that function's first line,
//! and what cargo-mutants says it does ("crates/vplgi-cpu/src/shade.rs 1f0c…a2 +3:5: replace a
//! with b in g"). A row counts only while that function's text is unchanged: editing a function
//! sends its mutants back to be tested, while an edit elsewhere in the file (a test module,
//! another function, lines added above) leaves them counted. (Tests added since do not lapse rows either: a caught mutant
//! stays caught as tests grow, and `MUTANTS_RETEST=1` tests the survivors the harmless table does
//! not explain, not the timeouts, again after new tests.)
//!
//! Usage:
//!   mutants_report prepare LEDGER REPORT_DIR [--retest-survivors HARMLESS_TSV]
//!       Keys the selection (REPORT_DIR/all-mutants.json, `cargo mutants --list --json`) by the
//!       current sources into REPORT_DIR/keys.tsv, and writes the mutants the ledger already has an
//!       outcome for into REPORT_DIR/mutants.out/previously_caught.txt, which `cargo mutants
//!       --iterate` skips; with --retest-survivors, all but the survivors the table does not
//!       explain.
//!   mutants_report record LEDGER REPORT_DIR
//!       Adds the outcomes of the run in REPORT_DIR/mutants.out to the ledger.
//!   mutants_report report LEDGER REPORT_DIR HARMLESS_TSV OUT_MD
//!       Writes docs/MUTANTS.md: per file, how many mutants and what became of them, then every
//!       survivor with why it is harmless (from the table) or marked unexplained.

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// The outcomes a ledger row can hold, with the words the report uses.
const OUTCOMES: [(&str, &str); 4] = [
    ("caught", "caught"),
    ("missed", "survived"),
    ("timeout", "timed out"),
    ("unviable", "did not build"),
];

/// The file a mutant lives in: the text before its first colon (of a name) or space (of a key).
fn file_of(mutant: &str) -> &str {
    mutant.split([':', ' ']).next().unwrap_or("?")
}

fn read(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))
}

/// Writes through a temporary file so an interrupted write leaves the old file whole.
fn write(path: &Path, text: &str) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))
}

fn lines(text: &str) -> impl Iterator<Item = &str> {
    text.lines().map(str::trim_end).filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
}

fn git(args: &[&str]) -> Result<String> {
    let out = Command::new("git").args(args).output().context("cannot run git")?;
    if !out.status.success() {
        bail!("git {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// A mutant as `cargo mutants --list --json` describes it (the fields used here).
#[derive(Deserialize)]
struct Listed {
    name: String,
    file: String,
    function: Option<Function>,
    span: Span,
}

#[derive(Deserialize)]
struct Function {
    span: Span,
}

#[derive(Deserialize)]
struct Span {
    start: Position,
    end: Position,
}

#[derive(Deserialize)]
struct Position {
    line: usize,
    column: usize,
}

/// FNV-1a, 64 bits: stable across Rust versions and platforms, unlike `DefaultHasher`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// The ledger key of mutant `m` of the file whose text is `source`: the file, the hash of the lines
/// of the mutated function (of the whole file for a mutant outside any function), the mutant's line
/// relative to the function's first and its column, and what it does.
fn key(m: &Listed, source: &str) -> Result<String> {
    let what = m
        .name
        .splitn(4, ':')
        .nth(3)
        .map(str::trim_start)
        .with_context(|| format!("{}: expected file:line:column: description", m.name))?;
    let text: Vec<&str> = source.lines().collect();
    let (first, last) =
        m.function.as_ref().map_or((1, text.len()), |f| (f.span.start.line, f.span.end.line));
    let body = text.get(first.saturating_sub(1)..last.min(text.len())).with_context(|| {
        format!("{}: its function's lines {first}-{last} are not in {}", m.name, m.file)
    })?;
    let line = m
        .span
        .start
        .line
        .checked_sub(first)
        .with_context(|| format!("{}: starts before its function", m.name))?;
    Ok(format!(
        "{} {:016x} +{line}:{}: {what}",
        m.file,
        fnv1a(body.join("\n").as_bytes()),
        m.span.start.column
    ))
}

/// The selection (REPORT_DIR/all-mutants.json) in cargo-mutants' order, as (name, key) pairs keyed by
/// the sources under the current directory.
fn key_selection(dir: &Path) -> Result<Vec<(String, String)>> {
    let path = dir.join("all-mutants.json");
    let listed: Vec<Listed> = serde_json::from_str(&read(&path)?).with_context(|| {
        format!("{}: not a `cargo mutants --list --json` listing", path.display())
    })?;
    let mut sources = HashMap::new();
    let mut out = Vec::with_capacity(listed.len());
    for m in &listed {
        if !sources.contains_key(&m.file) {
            sources.insert(m.file.clone(), read(Path::new(&m.file))?);
        }
        out.push((m.name.clone(), key(m, &sources[&m.file])?));
    }
    Ok(out)
}

/// The keyed selection prepare saved (REPORT_DIR/keys.tsv: commit, then name<TAB>key per mutant).
fn selection(dir: &Path) -> Result<(Vec<(String, String)>, String)> {
    let path = dir.join("keys.tsv");
    let text = read(&path)?;
    let mut commit = String::new();
    let mut keyed = Vec::new();
    for l in lines(&text) {
        let (a, b) = l
            .split_once('\t')
            .with_context(|| format!("{}: expected name<TAB>key", path.display()))?;
        if a == "commit" {
            commit = b.to_string();
        } else {
            keyed.push((a.to_string(), b.to_string()));
        }
    }
    Ok((keyed, commit))
}

struct Row {
    outcome: String,
    commit: String,
}

/// key -> row.
fn ledger(path: &Path) -> Result<BTreeMap<String, Row>> {
    let mut rows = BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(path) else { return Ok(rows) };
    for (i, l) in text.lines().enumerate() {
        if l.trim().is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.splitn(3, '\t').collect();
        let [outcome, commit, key] = f[..] else {
            bail!("{}:{}: expected outcome<TAB>commit<TAB>key", path.display(), i + 1)
        };
        if !OUTCOMES.iter().any(|(o, _)| *o == outcome) {
            bail!("{}:{}: unknown outcome {outcome:?}", path.display(), i + 1);
        }
        rows.insert(key.to_string(), Row { outcome: outcome.into(), commit: commit.into() });
    }
    Ok(rows)
}

/// The selected mutants the ledger has a row for, as (current name, row).
fn valid<'a>(
    rows: &'a BTreeMap<String, Row>,
    keyed: &'a [(String, String)],
) -> Vec<(&'a String, &'a Row)> {
    keyed.iter().filter_map(|(name, key)| rows.get(key).map(|r| (name, r))).collect()
}

/// The ledger's rows whose files are outside the selection.
fn unselected<'a>(
    rows: &'a BTreeMap<String, Row>,
    keyed: &[(String, String)],
) -> Vec<(&'a String, &'a Row)> {
    let files: std::collections::HashSet<&str> = keyed.iter().map(|(_, k)| file_of(k)).collect();
    rows.iter().filter(|(k, _)| !files.contains(file_of(k))).collect()
}

/// `retest`: the harmless table, whose survivors stay skipped while the others are tested again.
fn prepare(ledger_path: &Path, dir: &Path, retest: Option<&Path>) -> Result<()> {
    let keyed = key_selection(dir)?;
    let mut tsv = format!("commit\t{}\n", git(&["rev-parse", "HEAD"])?);
    for (name, key) in &keyed {
        writeln!(tsv, "{name}\t{key}")?;
    }
    write(&dir.join("keys.tsv"), &tsv)?;
    let rows = ledger(ledger_path)?;
    let keep = valid(&rows, &keyed);
    // A timeout is not re-tested: it is a mutant that never finishes (an infinite recursion or loop),
    // and new tests cannot make it finish, only cost another 5-minute timeout. Nor is a survivor
    // the table explains: no test is meant to notice it, and each costs a full run of the tests.
    let reasons = retest.map(harmless).transpose()?;
    let key_of: HashMap<&str, &str> = keyed.iter().map(|(n, k)| (n.as_str(), k.as_str())).collect();
    let retested = |name: &str, r: &Row| {
        let explained = |table: &Vec<(String, String)>| {
            table.iter().any(|(p, _)| key_of.get(name).is_some_and(|k| describes(p, k)))
        };
        r.outcome == "missed" && reasons.as_ref().is_some_and(|t| !explained(t))
    };
    let skip: Vec<&str> =
        keep.iter().filter(|(m, r)| !retested(m, r)).map(|(m, _)| m.as_str()).collect();
    let out = dir.join("mutants.out");
    for d in [out.clone(), dir.join("mutants.out.old")] {
        if d.exists() {
            std::fs::remove_dir_all(&d)
                .with_context(|| format!("{}: cannot remove", d.display()))?;
        }
    }
    std::fs::create_dir_all(&out).with_context(|| format!("{}: cannot create", out.display()))?;
    let mut list = skip.join("\n");
    list.push('\n');
    write(&out.join("previously_caught.txt"), &list)?;
    println!(
        "make mutants: {} of {} selected mutants have an outcome in {} for their functions' current text; {} to run",
        keep.len(),
        keyed.len(),
        ledger_path.display(),
        keyed.len() - skip.len()
    );
    Ok(())
}

/// Fails if cargo refused the arguments of any mutant's test run: the mutant would count as caught
/// without a test having run (a doubled `--workspace` once did exactly that).
fn check_logs(run: &Path) -> Result<()> {
    const REFUSALS: [&str; 3] =
        ["error: the argument", "error: unexpected argument", "error: no test target named"];
    let Ok(entries) = std::fs::read_dir(run.join("log")) else { return Ok(()) };
    for e in entries {
        let path = e?.path();
        let text = read(&path)?;
        if let Some(r) = REFUSALS.iter().find(|r| text.contains(*r)) {
            bail!("{}: cargo refused the test arguments (\"{r}...\"), so no test ran for that mutant: fix the Makefile's MUTANTS_TARGETS", path.display());
        }
    }
    Ok(())
}

fn record(ledger_path: &Path, dir: &Path) -> Result<()> {
    let run = dir.join("mutants.out");
    check_logs(&run)?;
    let (keyed, commit) = selection(dir)?;
    let key_of: HashMap<&str, &str> = keyed.iter().map(|(n, k)| (n.as_str(), k.as_str())).collect();
    let mut rows = ledger(ledger_path)?;
    let mut added = BTreeMap::<&str, usize>::new();
    for (outcome, _) in OUTCOMES {
        let Ok(text) = std::fs::read_to_string(run.join(format!("{outcome}.txt"))) else {
            continue;
        };
        for m in lines(&text) {
            let key =
                key_of.get(m).with_context(|| format!("{m}: not in the selection prepare saw"))?;
            rows.insert(key.to_string(), Row { outcome: outcome.into(), commit: commit.clone() });
            *added.entry(outcome).or_default() += 1;
        }
    }
    // Rewrite with the selection's rows still valid, in cargo-mutants' order, so the diff of a run
    // shows what it learned, then the rows of files this run did not select, untouched: a run
    // narrowed with MUTANTS_FILES must not erase what other runs learned.
    let mut text = String::from(
        "# make mutants' ledger (see reports/src/bin/mutants_report.rs): outcome, commit the run started on, and the\n\
         # mutant's key (file, hash of its function's text, line in that function:column: what it does). Do not edit.\n",
    );
    for (k, r) in
        keyed.iter().filter_map(|(_, k)| rows.get_key_value(k)).chain(unselected(&rows, &keyed))
    {
        writeln!(text, "{}\t{}\t{k}", r.outcome, r.commit)?;
    }
    write(ledger_path, &text)?;
    println!("make mutants: this run added {added:?} to {}", ledger_path.display());
    Ok(())
}

/// The harmless-mutant table: tab-separated lines "pattern<TAB>why it is harmless"; `#` starts a
/// comment. A pattern names mutants the way their ledger keys do, without the function's hash and
/// with `*` for any text: "cluster.rs +3:61: replace < with <= in Grid::fill" (the line counted from
/// the function's first), or "cluster.rs +75:* in Grid::search_from" for a whole line. A reason so
/// stays attached when lines are added above its function, and is reported stale when the mutants
/// it describes no longer exist or are caught.
fn harmless(path: &Path) -> Result<Vec<(String, String)>> {
    let mut rows = Vec::new();
    for (i, l) in read(path)?.lines().enumerate() {
        if l.trim().is_empty() || l.starts_with('#') {
            continue;
        }
        let Some((pattern, why)) = l.split_once('\t') else {
            bail!("{}:{}: expected `pattern<TAB>reason`", path.display(), i + 1)
        };
        rows.push((pattern.trim().to_string(), why.trim().to_string()));
    }
    Ok(rows)
}

/// What a harmless-table pattern is matched against: the key without its hash, after a `/` so that
/// a pattern starting at a file name ("cluster.rs +1:") matches at a path component
/// ("crates/vplgi-cpu/src/cluster.rs") and not inside a longer name ("rsm_cluster.rs").
fn unhashed(key: &str) -> String {
    let mut parts = key.splitn(3, ' ');
    let (file, _hash, rest) =
        (parts.next().unwrap_or(""), parts.next(), parts.next().unwrap_or(""));
    format!("/{file} {rest}")
}

/// The harmless-table pattern that names exactly the mutant with ledger key `key`: the key without
/// its hash and with the file's name only.
fn pattern_of(key: &str) -> String {
    let text = unhashed(key);
    let (file, rest) = text.split_once(' ').unwrap_or((&text, ""));
    format!("{} {rest}", file.rsplit('/').next().unwrap_or(file))
}

/// Whether harmless-table `pattern` describes the mutant with ledger key `key`: its parts between
/// `*`s appear in the key in order ("cluster.rs +75:* in Grid::search_from" is every mutant of
/// that line of that function).
fn describes(pattern: &str, key: &str) -> bool {
    let text = unhashed(key);
    let mut rest = text.as_str();
    format!("/{pattern}").split('*').all(|part| match rest.find(part) {
        Some(i) => {
            rest = &rest[i + part.len()..];
            true
        }
        None => false,
    })
}

fn report(ledger_path: &Path, dir: &Path, table: &Path, out: &Path) -> Result<()> {
    let (keyed, _) = selection(dir)?;
    let selection: Vec<&String> = keyed.iter().map(|(n, _)| n).collect();
    let rows = ledger(ledger_path)?;
    let reasons = harmless(table)?;
    let done = valid(&rows, &keyed);
    let key_of: HashMap<&str, &str> = keyed.iter().map(|(n, k)| (n.as_str(), k.as_str())).collect();
    // file -> outcome -> mutants, with every selected file present.
    let mut by_file: BTreeMap<&str, BTreeMap<&str, Vec<&str>>> = BTreeMap::new();
    let mut selected_in: BTreeMap<&str, usize> = BTreeMap::new();
    for m in &selection {
        *selected_in.entry(file_of(m)).or_default() += 1;
        by_file.entry(file_of(m)).or_default();
    }
    let mut commits: Vec<&str> = Vec::new();
    for (m, r) in &done {
        by_file
            .entry(file_of(m))
            .or_default()
            .entry(r.outcome.as_str())
            .or_default()
            .push(m.as_str());
        if !commits.contains(&r.commit.as_str()) {
            commits.push(&r.commit);
        }
    }
    let count = |o: &str| done.iter().filter(|(_, r)| r.outcome == o).count();
    let short = |c: &str| c.chars().take(7).collect::<String>();
    let mut md = String::new();
    writeln!(md, "# Mutation testing\n")?;
    writeln!(
        md,
        "Generated by `make mutants` on {} at commit {}. cargo-mutants changes one operator, return value or condition \
         at a time in `vplgi-types` and the CPU stage modules, builds, and runs the tests that cover that code (see the \
         Makefile). A mutant that no test notices has *survived*: either a test is missing or the change cannot be \
         observed. Every survivor below is explained or marked **unexplained**.\n\n\
         A full run takes longer than a working session, so outcomes accumulate in `ci/mutants-ledger.tsv` across \
         runs (here from commit(s) {}); each outcome counts only while the function it mutates is unchanged since it was tested.\n",
        git(&["log", "-1", "--format=%cd", "--date=format:%Y-%m-%d"])?,
        short(&git(&["rev-parse", "HEAD"])?),
        if commits.is_empty() { "none yet".to_string() } else { commits.iter().map(|c| format!("`{}`", short(c))).collect::<Vec<_>>().join(", ") }
    )?;
    writeln!(
        md,
        "**{} of the {} selected mutants have an outcome{}.**\n",
        done.len(),
        selection.len(),
        if done.len() < selection.len() {
            " so far (`make mutants` again tests the rest)"
        } else {
            ""
        }
    )?;
    writeln!(md, "| file | selected | tested | caught | survived | timed out | did not build |\n|---|---:|---:|---:|---:|---:|---:|")?;
    for (file, o) in &by_file {
        let n = |l: &str| o.get(l).map_or(0, Vec::len);
        writeln!(
            md,
            "| `{file}` | {} | {} | {} | {} | {} | {} |",
            selected_in.get(file).copied().unwrap_or(0),
            o.values().map(Vec::len).sum::<usize>(),
            n("caught"),
            n("missed"),
            n("timeout"),
            n("unviable")
        )?;
    }
    writeln!(
        md,
        "| **all** | **{}** | **{}** | **{}** | **{}** | **{}** | **{}** |\n",
        selection.len(),
        done.len(),
        count("caught"),
        count("missed"),
        count("timeout"),
        count("unviable")
    )?;
    let mut unexplained = 0;
    writeln!(md, "## Survivors\n")?;
    for (outcome, what) in OUTCOMES.into_iter().filter(|(o, _)| matches!(*o, "missed" | "timeout"))
    {
        for (file, o) in &by_file {
            for m in o.get(outcome).into_iter().flatten() {
                let key = key_of[m];
                match reasons.iter().find(|(p, _)| describes(p, key)) {
                    Some((_, why)) => writeln!(md, "- `{m}` ({what}, {file}): {why}")?,
                    None => {
                        unexplained += 1;
                        let pattern = pattern_of(key);
                        writeln!(md, "- `{m}` ({what}, {file}): **unexplained** (table pattern: `{pattern}`)")?
                    }
                }
            }
        }
    }
    if count("missed") + count("timeout") == 0 {
        writeln!(md, "None.")?;
    }
    writeln!(md, "\n{unexplained} survivor(s) unexplained.")?;
    let stale = stale(&reasons, &keyed, &rows);
    if !stale.is_empty() {
        writeln!(md, "\n## Stale reasons\n\nThese lines of `ci/mutants-harmless.tsv` describe no selected mutant that survives or is untested (the code changed, or a test now catches it); delete or re-key them:\n")?;
        for p in &stale {
            writeln!(md, "- `{p}`")?;
        }
    }
    write(out, &md)?;
    println!(
        "wrote {}: {} of {} mutants tested: {} caught, {} survived, {} timed out, {} did not build; {unexplained} unexplained",
        out.display(),
        done.len(),
        selection.len(),
        count("caught"),
        count("missed"),
        count("timeout"),
        count("unviable")
    );
    if !stale.is_empty() {
        println!(
            "make mutants: {} stale line(s) in {}, listed in {}",
            stale.len(),
            table.display(),
            out.display()
        );
    }
    Ok(())
}

/// The harmless-table patterns of selected files that describe no selected mutant still in need of
/// a reason (survived, timed out, or not yet tested). Patterns of files outside the selection are
/// left alone: a run narrowed with MUTANTS_FILES cannot judge them.
fn stale<'a>(
    reasons: &'a [(String, String)],
    keyed: &[(String, String)],
    rows: &BTreeMap<String, Row>,
) -> Vec<&'a str> {
    let needs_reason =
        |k: &String| rows.get(k).is_none_or(|r| matches!(r.outcome.as_str(), "missed" | "timeout"));
    reasons
        .iter()
        .map(|(p, _)| p.as_str())
        .filter(|p| {
            // The pattern's file name and the space after it: a pattern of its own for the file.
            let file = p.split_inclusive(' ').next().unwrap_or(p);
            keyed.iter().any(|(_, k)| describes(file, k))
                && !keyed.iter().any(|(_, k)| needs_reason(k) && describes(p, k))
        })
        .collect()
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    match a[..] {
        ["prepare", ledger, dir] => prepare(Path::new(ledger), Path::new(dir), None),
        ["prepare", ledger, dir, "--retest-survivors", table] => prepare(Path::new(ledger), Path::new(dir), Some(Path::new(table))),
        ["record", ledger, dir] => record(Path::new(ledger), Path::new(dir)),
        ["report", ledger, dir, table, out] => report(Path::new(ledger), Path::new(dir), Path::new(table), Path::new(out)),
        _ => bail!(
            "usage: mutants_report prepare LEDGER REPORT_DIR [--retest-survivors HARMLESS_TSV] | record LEDGER REPORT_DIR | \
             report LEDGER REPORT_DIR HARMLESS_TSV OUT_MD"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listed(name: &str, fn_lines: (usize, usize), line: usize) -> Listed {
        let pos = |line| Position { line, column: 5 };
        Listed {
            name: name.into(),
            file: "a.rs".into(),
            function: Some(Function {
                span: Span { start: pos(fn_lines.0), end: pos(fn_lines.1) },
            }),
            span: Span { start: pos(line), end: pos(line) },
        }
    }

    /// The point of keying by function: lines added above a function leave its mutants' keys as
    /// they were, an edit inside it changes them.
    #[test]
    fn keys_follow_the_function_not_the_line() -> Result<()> {
        let before = "fn f() {\n    a + b\n}\nfn g() {\n    c\n}\n";
        let shifted = format!("// a new line\n{before}");
        let edited = before.replace("a + b", "a - b");
        let g = |src: &str, first: usize| {
            key(
                &listed(
                    &format!("a.rs:{}:5: replace c in g", first + 1),
                    (first, first + 2),
                    first + 1,
                ),
                src,
            )
        };
        let f = |src: &str, first: usize| {
            key(
                &listed(
                    &format!("a.rs:{}:5: replace + with - in f", first + 1),
                    (first, first + 2),
                    first + 1,
                ),
                src,
            )
        };
        assert_eq!(g(before, 4)?, g(&shifted, 5)?);
        assert_eq!(f(before, 1)?, f(&shifted, 2)?);
        assert_eq!(g(before, 4)?, g(&edited, 4)?);
        assert_ne!(f(before, 1)?, f(&edited, 1)?);
        assert!(
            f(before, 1)?.starts_with("a.rs ")
                && f(before, 1)?.ends_with(" +1:5: replace + with - in f"),
            "{}",
            f(before, 1)?
        );
        Ok(())
    }

    #[test]
    fn a_narrowed_run_keeps_the_rows_of_files_it_did_not_select() {
        let row = || Row { outcome: "caught".into(), commit: "c".into() };
        let rows: BTreeMap<String, Row> = [
            ("a.rs 01 +1:1: replace x".to_string(), row()),
            ("a.rs 02 +1:1: replace y".to_string(), row()),
            ("b.rs 03 +1:1: replace z".to_string(), row()),
        ]
        .into();
        // a.rs's second function has changed (hash 04 now): its row lapses; b.rs (not selected) stays.
        let keyed = vec![
            ("a.rs:1:1: replace x".to_string(), "a.rs 01 +1:1: replace x".to_string()),
            ("a.rs:9:1: replace y".to_string(), "a.rs 04 +1:1: replace y".to_string()),
        ];
        let kept: Vec<&String> = valid(&rows, &keyed).into_iter().map(|(m, _)| m).collect();
        assert_eq!(kept, ["a.rs:1:1: replace x"]);
        let other: Vec<&String> = unselected(&rows, &keyed).into_iter().map(|(k, _)| k).collect();
        assert_eq!(other, ["b.rs 03 +1:1: replace z"]);
    }

    /// A reason names its mutant by file, line in the function and description, so it survives lines
    /// added above the function; a file name does not match inside a longer one; and a reason whose
    /// mutant is gone, or now caught, is reported stale while one for an untested mutant is not.
    #[test]
    fn reasons_follow_the_function_and_go_stale_with_it() {
        let key =
            |file: &str, hash: &str, what: &str| format!("crates/c/src/{file} {hash} +2:9: {what}");
        assert!(describes(
            "cluster.rs +2:9: replace < with <= in f",
            &key("cluster.rs", "01", "replace < with <= in f")
        ));
        assert!(!describes(
            "cluster.rs +2:9: replace < with <= in f",
            &key("rsm_cluster.rs", "01", "replace < with <= in f")
        ));
        assert!(!describes(
            "cluster.rs +2:9: replace < with <= in f",
            &key("cluster.rs", "01", "replace < with > in f")
        ));
        assert!(describes(
            "cluster.rs +2:* in f",
            &key("cluster.rs", "01", "replace < with > in f")
        ));
        assert_eq!(
            pattern_of(&key("cluster.rs", "01", "replace / with * in f")),
            "cluster.rs +2:9: replace / with * in f"
        );
        assert!(!describes(
            "cluster.rs +2:* in f",
            &key("cluster.rs", "01", "replace < with > in g")
        ));
        let reasons: Vec<(String, String)> = [
            "cluster.rs +2:9: survives",
            "cluster.rs +2:9: caught now",
            "cluster.rs +2:9: untested",
            "cluster.rs +2:9: gone",
            "other.rs +1:1: x",
        ]
        .iter()
        .map(|p| (p.to_string(), "why".to_string()))
        .collect();
        let keyed: Vec<(String, String)> = ["survives", "caught now", "untested"]
            .iter()
            .map(|w| (format!("cluster.rs:9:9: {w}"), key("cluster.rs", "07", w)))
            .collect();
        let row = |o: &str| Row { outcome: o.into(), commit: "c".into() };
        let rows: BTreeMap<String, Row> =
            [(keyed[0].1.clone(), row("missed")), (keyed[1].1.clone(), row("caught"))].into();
        assert_eq!(
            stale(&reasons, &keyed, &rows),
            ["cluster.rs +2:9: caught now", "cluster.rs +2:9: gone"]
        );
    }
}
