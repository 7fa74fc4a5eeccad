//! `results --quick` runs end to end at small sizes and writes the table with every scene and
//! setting on both backends, numbers and thumbnails.

use std::process::Command;

#[test]
fn quick_results_write_every_scene_and_setting() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("RESULTS.md");
    let vplgi = std::path::Path::new(env!("CARGO_BIN_EXE_results")).with_file_name("vplgi");
    if !vplgi.exists() {
        // The workspace's vplgi binary is built by `cargo test --workspace` before this runs.
        panic!("{} is missing: run the tests with --workspace", vplgi.display());
    }
    let o = Command::new(env!("CARGO_BIN_EXE_results"))
        .args([
            "--quick",
            "--out",
            out.to_str().unwrap(),
            "--vplgi",
            vplgi.to_str().unwrap(),
            "--work",
            dir.path().join("work").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "results failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    for scene in [
        "cornell-fine",
        "conference",
        "living-room",
        "cornell-mirror",
        "cornell-glass",
        "cornell-glossy",
    ] {
        assert!(md.contains(&format!("## {scene}")), "{scene} missing");
        assert!(dir
            .path()
            .join("results")
            .join(format!("{scene}-intermediate-error.png"))
            .is_file());
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("results/results.json")).unwrap())
            .unwrap();
    for sc in json["scenes"].as_array().unwrap() {
        let frames = sc["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 7, "reference + 3 settings on the CPU and on the GPU");
        assert_eq!(frames.iter().filter(|f| f["backend"] == "gpu").count(), 3);
        for f in &frames[1..] {
            assert!(f["mse"].as_f64().unwrap() > 0.0 && f["flip"].as_f64().unwrap() > 0.0);
            assert!(f["rss_mib"].as_f64().unwrap() > 1.0);
        }
    }
}
