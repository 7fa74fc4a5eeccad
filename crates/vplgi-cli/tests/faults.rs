//! Faults a user meets: a run killed outright, and an output directory that cannot take the
//! files. Neither may leave a partial output file behind; both must say what happened.

use std::path::Path;
use std::process::{Command, Output};
use std::time::Instant;

fn vplgi() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vplgi"))
}

fn run(args: &[&str]) -> Output {
    vplgi().args(args).output().expect("run vplgi")
}

/// Every file in `dir` is complete: it has its final name and parses as what its extension
/// says. The outputs go to a fresh folder, where each file is written without a name and linked
/// under its final one only once complete, so no temporary name (`.image.exr.tmp-<pid>-<n>`)
/// may be left either.
fn assert_complete(dir: &Path, what: &str) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut n = 0;
    for e in entries {
        let path = e.expect("entry").path();
        let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
        assert!(!name.contains(".tmp-"), "{what}: a temporary file {name} was left");
        let ok = if name.ends_with(".exr") {
            vplgi_image::read_exr(&path).is_ok()
        } else if name.ends_with(".json") {
            serde_json::from_slice::<serde_json::Value>(&std::fs::read(&path).expect("read"))
                .is_ok()
        } else if name.ends_with(".png") {
            image::open(&path).is_ok()
        } else {
            panic!("{what}: unexpected file {name}");
        };
        assert!(ok, "{what}: {name} is a partial file");
        n += 1;
    }
    n
}

/// Runs `args` (whose last two are `--out DIR`) to completion once to time it, then kills it
/// with SIGKILL at points spread over that time (more of them near the end, where the files are
/// written), and checks the output folder each time.
fn kill_at_every_stage(what: &str, args: &[&str], out: &Path) {
    let clock = Instant::now();
    let o = run(args);
    assert!(o.status.success(), "{what}: {}", String::from_utf8_lossy(&o.stderr));
    let full = clock.elapsed();
    let files = assert_complete(out, what);
    for at in [0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.98, 0.99, 0.995] {
        let _ = std::fs::remove_dir_all(out);
        let mut child = vplgi()
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        std::thread::sleep(full.mul_f64(at));
        let _ = child.kill(); // SIGKILL: no handler runs
        let _ = child.wait();
        let left = assert_complete(out, what);
        println!(
            "{what}: killed at {:.1} % of {:.2} s: {left} of {files} files, all complete",
            100.0 * at,
            full.as_secs_f64()
        );
    }
}

/// SIGKILL at any moment of `render`, `reference` or `merge` leaves only complete files.
#[test]
fn killed_runs_leave_no_partial_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let (render, reference, merged) = (d("render"), d("reference"), d("merged"));
    kill_at_every_stage(
        "render",
        &[
            "render", "--width", "384", "--height", "384", "--vpls", "3000", "--k-sp", "2000",
            "--k-vpl", "300", "--out", &render,
        ],
        Path::new(&render),
    );
    kill_at_every_stage(
        "reference",
        &[
            "reference",
            "--width",
            "160",
            "--height",
            "160",
            "--vpls",
            "800",
            "--seeds",
            "3",
            "--out",
            &reference,
        ],
        Path::new(&reference),
    );
    let tiles: Vec<String> = (1..=2).map(|i| d(&format!("tile{i}"))).collect();
    for (i, t) in tiles.iter().enumerate() {
        let tile = format!("{}/2", i + 1);
        let o = run(&[
            "reference",
            "--width",
            "256",
            "--height",
            "256",
            "--vpls",
            "200",
            "--seeds",
            "2",
            "--tile",
            &tile,
            "--out",
            t,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    kill_at_every_stage(
        "merge",
        &["merge", &tiles[0], &tiles[1], "--out", &merged],
        Path::new(&merged),
    );
}

/// An output folder that cannot be made, and one whose disk fills up (a file-size limit, which
/// fails writes the way a full disk does): a one-line error naming the path and the cause, a
/// non-zero exit, and no file written.
#[test]
fn unwritable_and_full_outputs_are_clear_errors() {
    let dir = tempfile::tempdir().expect("tempdir");
    let blocker = dir.path().join("a-file");
    std::fs::write(&blocker, b"not a folder").expect("write");
    let out = blocker.join("out");
    let o =
        run(&["render", "--width", "8", "--height", "8", "--out", out.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("cannot create output directory")
            && err.contains("a-file/out"),
        "{err}"
    );

    let out = dir.path().join("full");
    std::fs::create_dir(&out).expect("mkdir");
    // 16 KiB per file: the 64x64 EXR (about 50 KB) cannot be written. SIGXFSZ is ignored, so the
    // write fails with EFBIG as on a full disk instead of killing the process.
    let script = format!(
        "trap '' XFSZ; ulimit -f 16; exec '{}' render --width 64 --height 64 --vpls 200 --k-sp 100 --k-vpl 50 --out '{}'",
        env!("CARGO_BIN_EXE_vplgi"),
        out.display()
    );
    let o = Command::new("bash").args(["-c", &script]).output().expect("bash");
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{err}");
    assert!(!o.status.success(), "a render into a full disk succeeded");
    assert!(
        err.contains("cannot write") && err.contains("image.exr") && err.contains("File too large"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    let left: Vec<String> = std::fs::read_dir(&out)
        .expect("read")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(left.iter().all(|n| !n.ends_with(".exr")), "a partial image was left: {left:?}");
    assert_complete(&out, "full disk");
}
