//! `rsm --quick` runs end to end at small sizes and writes every scene's table (each light shape
//! and the Halton-seeded exact disks at each count, with pictures, and the energy of each shape
//! at each count), the moving-sun sequences
//! (from scratch and warm) and the Table 1 timings on both backends with both seedings.

use std::process::Command;

#[test]
fn quick_rsm_report_covers_every_scene_shape_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("RSM.md");
    let vplgi = std::path::Path::new(env!("CARGO_BIN_EXE_rsm")).with_file_name("vplgi");
    assert!(vplgi.exists(), "{} is missing: run the tests with --workspace", vplgi.display());
    let o = Command::new(env!("CARGO_BIN_EXE_rsm"))
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
    assert!(o.status.success(), "rsm failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("rsm/rsm.json")).unwrap()).unwrap();
    for sc in json["scenes"].as_array().unwrap() {
        let name = sc["scene"].as_str().unwrap();
        assert!(md.contains(&format!("## {name}")), "{name} missing");
        let frames = sc["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 2 + 5 * 2, "unclustered with and without the clamp, then four shapes and the Halton-seeded disks at two counts");
        for f in frames {
            assert!(
                f["rel_mse"].as_f64().unwrap() > 0.0 && f["flip"].as_f64().unwrap() > 0.0,
                "{f}"
            );
            let kept: Vec<f64> =
                f["mean_ratio"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            // Positive and not absurd; at the quick sizes' few clusters the sun-lit room keeps as
            // little as 3 % (its clusters go to the roof the sun sees, not the room).
            assert!(kept.iter().all(|k| *k > 0.0 && *k < 3.0), "{name}: light kept {kept:?}");
        }
        assert!(sc["reference_mean_error"]
            .as_array()
            .unwrap()
            .iter()
            .all(|e| e.as_f64().unwrap() > 0.0));
        for picture in [
            "reference",
            "unclustered",
            "disk-exact-64",
            "polygon-64",
            "point-64-error",
            "polygon-64-error",
        ] {
            assert!(
                dir.path().join("rsm").join(format!("{name}-{picture}.png")).is_file(),
                "{name}-{picture}.png"
            );
        }
    }
    let table = json["table_1"].as_array().unwrap();
    assert_eq!(table.len(), 3);
    for key in ["cpu_halton_ms", "cpu_importance_ms", "gpu_halton_ms", "gpu_importance_ms"] {
        assert!(table.iter().all(|t| t[key].as_f64().unwrap() > 0.0), "{key}: {table:?}");
    }
    // The sequences: a warm start keeps clusters after the first frame, a cold one none, and
    // both are judged against the unclustered sequence.
    let rows = json["sequence"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0]["kept"].as_f64(), Some(0.0), "from scratch keeps nothing");
    assert!(
        rows[1]["kept"].as_f64().unwrap() > 0.0 && rows[2]["kept"].as_f64().unwrap() > 0.0,
        "{rows:?}"
    );
    assert!(
        rows.iter()
            .all(|r| r["temporal_error"].as_f64().unwrap() > 0.0
                && r["flicker"].as_f64().unwrap() > 0.0),
        "{rows:?}"
    );
    assert!(md.contains("moving sun") || md.contains("A moving sun"), "{md}");
    assert!(md.contains("Table 1") && md.contains("lavapipe"), "{md}");
    assert_eq!(
        md.matches("| `--k-vpl` | point | disk | disk-exact | polygon |").count(),
        3,
        "an energy table per scene, and the Cornell box's at a finer map: {md}"
    );
    let finer =
        json["scenes"][0]["finer"]["frames"].as_array().expect("the Cornell box's finer map");
    assert_eq!(finer.len(), 1 + 4 * 2, "the unclamped VPLs, then four shapes at two counts");
}
