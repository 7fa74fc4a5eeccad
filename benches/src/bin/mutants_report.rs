//! `make mutants`' bookkeeping. A full run is many hours on 2 cores, longer than a working session,
//! so outcomes accumulate in a committed ledger (`ci/mutants-ledger.tsv`) and each run tests only
//! the mutants the ledger has no outcome for.
//!
//! A ledger row holds the outcome, the git blob of the mutated file as tested, the commit the run
//! started on, and the mutant as cargo-mutants names it ("crates/x/src/f.rs:12:5: replace a with b
//! in g"). A row counts only while its file's content is still that blob: editing a file sends all
//! its mutants back to be tested. (Tests added since do not: a caught mutant stays caught as tests
//! grow, and `MUTANTS_RETEST=1` tests the survivors again after new tests.)
//!
//! Usage:
//!   mutants_report prepare LEDGER REPORT_DIR [--retest-survivors]
//!       Records the selected files' blobs and writes the ledger's still-valid mutants into
//!       REPORT_DIR/mutants.out/previously_caught.txt, which `cargo mutants --iterate` skips.
//!   mutants_report record LEDGER REPORT_DIR
//!       Adds the outcomes of the run in REPORT_DIR/mutants.out to the ledger.
//!   mutants_report report LEDGER REPORT_DIR HARMLESS_TSV OUT_MD
//!       Writes docs/MUTANTS.md: per file, how many mutants and what became of them, then every
//!       survivor with why it is harmless (from the table) or marked unexplained.
//!
//! REPORT_DIR/all-mutants.txt is `cargo mutants --list` of the selection.

use anyhow::{bail, Context, Result};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// The outcomes a ledger row can hold, with the words the report uses.
const OUTCOMES: [(&str, &str); 4] = [("caught", "caught"), ("missed", "survived"), ("timeout", "timed out"), ("unviable", "did not build")];

/// The file a mutant lives in: the text before its first colon.
fn file_of(mutant: &str) -> &str {
    mutant.split(':').next().unwrap_or("?")
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

/// The selection, in cargo-mutants' order.
fn selected(dir: &Path) -> Result<Vec<String>> {
    let path = dir.join("all-mutants.txt");
    Ok(lines(&read(&path)?).map(str::to_string).collect())
}

struct Row {
    outcome: String,
    blob: String,
    commit: String,
}

/// mutant -> row.
fn ledger(path: &Path) -> Result<BTreeMap<String, Row>> {
    let mut rows = BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(path) else { return Ok(rows) };
    for (i, l) in text.lines().enumerate() {
        if l.trim().is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.splitn(4, '\t').collect();
        let [outcome, blob, commit, mutant] = f[..] else { bail!("{}:{}: expected outcome<TAB>blob<TAB>commit<TAB>mutant", path.display(), i + 1) };
        if !OUTCOMES.iter().any(|(o, _)| *o == outcome) {
            bail!("{}:{}: unknown outcome {outcome:?}", path.display(), i + 1);
        }
        rows.insert(mutant.to_string(), Row { outcome: outcome.into(), blob: blob.into(), commit: commit.into() });
    }
    Ok(rows)
}

/// The blobs of the selected files as prepare recorded them (file -> blob), and the commit.
fn blobs(dir: &Path) -> Result<(HashMap<String, String>, String)> {
    let text = read(&dir.join("blobs.tsv"))?;
    let mut commit = String::new();
    let mut map = HashMap::new();
    for l in lines(&text) {
        let (k, v) = l.split_once('\t').context("blobs.tsv: expected file<TAB>blob")?;
        if k == "commit" {
            commit = v.to_string();
        } else {
            map.insert(k.to_string(), v.to_string());
        }
    }
    Ok((map, commit))
}

/// The ledger's rows still valid for the current content of their files.
fn valid<'a>(rows: &'a BTreeMap<String, Row>, selection: &[String], blob: &HashMap<String, String>) -> Vec<(&'a String, &'a Row)> {
    selection.iter().filter_map(|m| rows.get_key_value(m)).filter(|(m, r)| blob.get(file_of(m)) == Some(&r.blob)).collect()
}

/// The ledger's rows whose files are outside the selection (`blob` holds the selected files).
fn unselected<'a>(rows: &'a BTreeMap<String, Row>, blob: &HashMap<String, String>) -> Vec<(&'a String, &'a Row)> {
    rows.iter().filter(|(m, _)| !blob.contains_key(file_of(m))).collect()
}

fn prepare(ledger_path: &Path, dir: &Path, retest_survivors: bool) -> Result<()> {
    let selection = selected(dir)?;
    let mut files: Vec<&str> = selection.iter().map(|m| file_of(m)).collect();
    files.dedup();
    let mut tsv = format!("commit\t{}\n", git(&["rev-parse", "HEAD"])?);
    let mut blob = HashMap::new();
    for f in files {
        let b = git(&["hash-object", f])?;
        writeln!(tsv, "{f}\t{b}")?;
        blob.insert(f.to_string(), b);
    }
    write(&dir.join("blobs.tsv"), &tsv)?;
    let rows = ledger(ledger_path)?;
    let keep = valid(&rows, &selection, &blob);
    let skip: Vec<&str> =
        keep.iter().filter(|(_, r)| !(retest_survivors && matches!(r.outcome.as_str(), "missed" | "timeout"))).map(|(m, _)| m.as_str()).collect();
    let out = dir.join("mutants.out");
    for d in [out.clone(), dir.join("mutants.out.old")] {
        if d.exists() {
            std::fs::remove_dir_all(&d).with_context(|| format!("{}: cannot remove", d.display()))?;
        }
    }
    std::fs::create_dir_all(&out).with_context(|| format!("{}: cannot create", out.display()))?;
    let mut list = skip.join("\n");
    list.push('\n');
    write(&out.join("previously_caught.txt"), &list)?;
    println!(
        "make mutants: {} of {} selected mutants have an outcome in {} for their files' current content; {} to run",
        keep.len(),
        selection.len(),
        ledger_path.display(),
        selection.len() - skip.len()
    );
    Ok(())
}

/// Fails if cargo refused the arguments of any mutant's test run: the mutant would count as caught
/// without a test having run (a doubled `--workspace` once did exactly that).
fn check_logs(run: &Path) -> Result<()> {
    const REFUSALS: [&str; 3] = ["error: the argument", "error: unexpected argument", "error: no test target named"];
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
    let selection = selected(dir)?;
    let (blob, commit) = blobs(dir)?;
    let mut rows = ledger(ledger_path)?;
    let mut added = BTreeMap::<&str, usize>::new();
    for (outcome, _) in OUTCOMES {
        let Ok(text) = std::fs::read_to_string(run.join(format!("{outcome}.txt"))) else { continue };
        for m in lines(&text) {
            let b = blob.get(file_of(m)).with_context(|| format!("{m}: not in the selection prepare saw"))?;
            rows.insert(m.to_string(), Row { outcome: outcome.into(), blob: b.clone(), commit: commit.clone() });
            *added.entry(outcome).or_default() += 1;
        }
    }
    // Rewrite with the selection's rows still valid, in cargo-mutants' order, so the diff of a run
    // shows what it learned, then the rows of files this run did not select, untouched: a run
    // narrowed with MUTANTS_FILES must not erase what other runs learned.
    let mut text = String::from(
        "# make mutants' ledger (see benches/src/bin/mutants_report.rs): outcome, git blob of the mutated file as tested,\n\
         # commit the run started on, mutant. Written by `make mutants`; do not edit.\n",
    );
    for (m, r) in valid(&rows, &selection, &blob).into_iter().chain(unselected(&rows, &blob)) {
        writeln!(text, "{}\t{}\t{}\t{m}", r.outcome, r.blob, r.commit)?;
    }
    write(ledger_path, &text)?;
    println!("make mutants: this run added {added:?} to {}", ledger_path.display());
    Ok(())
}

/// The harmless-mutant table: tab-separated lines "text the mutant's line contains<TAB>why it
/// is harmless"; `#` starts a comment.
fn harmless(path: &Path) -> Result<Vec<(String, String)>> {
    let mut rows = Vec::new();
    for (i, l) in read(path)?.lines().enumerate() {
        if l.trim().is_empty() || l.starts_with('#') {
            continue;
        }
        let Some((pattern, why)) = l.split_once('\t') else { bail!("{}:{}: expected `pattern<TAB>reason`", path.display(), i + 1) };
        rows.push((pattern.trim().to_string(), why.trim().to_string()));
    }
    Ok(rows)
}

fn report(ledger_path: &Path, dir: &Path, table: &Path, out: &Path) -> Result<()> {
    let selection = selected(dir)?;
    let (blob, _) = blobs(dir)?;
    let rows = ledger(ledger_path)?;
    let reasons = harmless(table)?;
    let done = valid(&rows, &selection, &blob);
    // file -> outcome -> mutants, with every selected file present.
    let mut by_file: BTreeMap<&str, BTreeMap<&str, Vec<&str>>> = BTreeMap::new();
    let mut selected_in: BTreeMap<&str, usize> = BTreeMap::new();
    for m in &selection {
        *selected_in.entry(file_of(m)).or_default() += 1;
        by_file.entry(file_of(m)).or_default();
    }
    let mut commits: Vec<&str> = Vec::new();
    for (m, r) in &done {
        by_file.entry(file_of(m)).or_default().entry(r.outcome.as_str()).or_default().push(m.as_str());
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
         runs (here from commit(s) {}); each outcome counts only while its file is unchanged since it was tested.\n",
        git(&["log", "-1", "--format=%cd", "--date=format:%Y-%m-%d"])?,
        short(&git(&["rev-parse", "HEAD"])?),
        if commits.is_empty() { "none yet".to_string() } else { commits.iter().map(|c| format!("`{}`", short(c))).collect::<Vec<_>>().join(", ") }
    )?;
    writeln!(
        md,
        "**{} of the {} selected mutants have an outcome{}.**\n",
        done.len(),
        selection.len(),
        if done.len() < selection.len() { " so far (`make mutants` again tests the rest)" } else { "" }
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
    for (outcome, what) in OUTCOMES.into_iter().filter(|(o, _)| matches!(*o, "missed" | "timeout")) {
        for (file, o) in &by_file {
            for m in o.get(outcome).into_iter().flatten() {
                let why = reasons.iter().find(|(p, _)| m.contains(p.as_str())).map(|(_, w)| w.as_str());
                unexplained += usize::from(why.is_none());
                writeln!(md, "- `{m}` ({what}, {file}): {}", why.unwrap_or("**unexplained**"))?;
            }
        }
    }
    if count("missed") + count("timeout") == 0 {
        writeln!(md, "None.")?;
    }
    writeln!(md, "\n{unexplained} survivor(s) unexplained.")?;
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
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    match a[..] {
        ["prepare", ledger, dir] => prepare(Path::new(ledger), Path::new(dir), false),
        ["prepare", ledger, dir, "--retest-survivors"] => prepare(Path::new(ledger), Path::new(dir), true),
        ["record", ledger, dir] => record(Path::new(ledger), Path::new(dir)),
        ["report", ledger, dir, table, out] => report(Path::new(ledger), Path::new(dir), Path::new(table), Path::new(out)),
        _ => bail!(
            "usage: mutants_report prepare LEDGER REPORT_DIR [--retest-survivors] | record LEDGER REPORT_DIR | \
             report LEDGER REPORT_DIR HARMLESS_TSV OUT_MD"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_narrowed_run_keeps_the_rows_of_files_it_did_not_select() {
        let row = |blob: &str| Row { outcome: "caught".into(), blob: blob.into(), commit: "c".into() };
        let rows: BTreeMap<String, Row> =
            [("a.rs:1:1: replace x".to_string(), row("A")), ("a.rs:2:1: replace y".to_string(), row("old")), ("b.rs:1:1: replace z".to_string(), row("B"))]
                .into();
        let blob: HashMap<String, String> = [("a.rs".to_string(), "A".to_string())].into();
        let selection = vec!["a.rs:1:1: replace x".to_string(), "a.rs:2:1: replace y".to_string()];
        let kept: Vec<&String> = valid(&rows, &selection, &blob).into_iter().chain(unselected(&rows, &blob)).map(|(m, _)| m).collect();
        // a.rs's lapsed row goes, b.rs (not selected) stays.
        assert_eq!(kept, ["a.rs:1:1: replace x", "b.rs:1:1: replace z"]);
    }
}
