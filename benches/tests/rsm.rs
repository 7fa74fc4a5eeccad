//! `rsm --quick` runs end to end at small sizes and writes every scene's table (each light shape
//! at each count, with pictures) and the Table 1 timings on both backends.

use std::process::Command;

#[test]
fn quick_rsm_report_covers_every_scene_shape_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("RSM.md");
    let vplgi = std::path::Path::new(env!("CARGO_BIN_EXE_rsm")).with_file_name("vplgi");
    assert!(vplgi.exists(), "{} is missing: run the tests with --workspace", vplgi.display());
    let o = Command::new(env!("CARGO_BIN_EXE_rsm"))
        .args(["--quick", "--out", out.to_str().unwrap(), "--vplgi", vplgi.to_str().unwrap(), "--work", dir.path().join("work").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "rsm failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join("rsm/rsm.json")).unwrap()).unwrap();
    for sc in json["scenes"].as_array().unwrap() {
        let name = sc["scene"].as_str().unwrap();
        assert!(md.contains(&format!("## {name}")), "{name} missing");
        let frames = sc["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 1 + 3 * 2, "unclustered, then three shapes at two counts");
        for f in frames {
            assert!(f["rel_mse"].as_f64().unwrap() > 0.0 && f["flip"].as_f64().unwrap() > 0.0, "{f}");
            let kept: Vec<f64> = f["mean_ratio"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            // Positive and not absurd; at the quick sizes' few clusters the sun-lit room keeps as
            // little as 3 % (its clusters go to the roof the sun sees, not the room).
            assert!(kept.iter().all(|k| *k > 0.0 && *k < 3.0), "{name}: light kept {kept:?}");
        }
        assert!(sc["reference_mean_error"].as_array().unwrap().iter().all(|e| e.as_f64().unwrap() > 0.0));
        for picture in ["reference", "unclustered", "disk-exact-64", "point-64-error"] {
            assert!(dir.path().join("rsm").join(format!("{name}-{picture}.png")).is_file(), "{name}-{picture}.png");
        }
    }
    let table = json["table_1"].as_array().unwrap();
    assert_eq!(table.len(), 3);
    assert!(table.iter().all(|t| t["cpu_ms"].as_f64().unwrap() > 0.0 && t["gpu_ms"].as_f64().unwrap() > 0.0), "{table:?}");
    assert!(md.contains("Table 1") && md.contains("lavapipe"), "{md}");
}
