//! `variants --quick` runs end to end at small sizes and writes the comparison with every scene,
//! variant and budget, numbers and charts, and the flicker of each pipeline along a walk.

use std::process::Command;

#[test]
fn quick_variants_compare_every_scene_and_variant() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("VARIANTS.md");
    let vplgi = std::path::Path::new(env!("CARGO_BIN_EXE_variants")).with_file_name("vplgi");
    assert!(vplgi.exists(), "{} is missing: run the tests with --workspace", vplgi.display());
    let o = Command::new(env!("CARGO_BIN_EXE_variants"))
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
    assert!(o.status.success(), "variants failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    for scene in ["cornell-fine", "conference", "living-room"] {
        assert!(md.contains(&format!("## {scene}")), "{scene} missing");
        assert!(dir.path().join("variants").join(format!("{scene}-variants-flip.svg")).is_file());
    }
    assert!(md.contains("`ward+min-error+adaptive+interpolate`") && md.contains("**"), "{md}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("variants/variants.json")).unwrap())
            .unwrap();
    for sc in json["scenes"].as_array().unwrap() {
        let frames = sc["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 10, "5 variants at 2 counts");
        assert!(frames
            .iter()
            .all(|f| f["flip"].as_f64().unwrap() > 0.0 && f["ms"].as_f64().unwrap() > 0.0));
        let sequences = sc["walk"]["sequences"].as_array().unwrap();
        assert_eq!(sequences.len(), 4, "two pipelines with and without --temporal");
        assert!(sequences.iter().all(|s| s["own_flicker"].as_f64().unwrap() > 0.0));
        assert!(sc["walk"]["converged_flicker"].as_f64().unwrap() > 0.0);
        let scene = sc["scene"].as_str().unwrap();
        assert!(dir.path().join("variants").join(format!("{scene}-flicker.svg")).is_file());
    }
    assert!(
        md.contains("Flicker along a camera walk")
            && md.contains("`ward+min-error+adaptive+interpolate +temporal`"),
        "{md}"
    );
}
