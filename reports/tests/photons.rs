//! `photons --quick` runs end to end at small sizes and writes the ablation of both scenes (every
//! variant's error and time at every cut size, and the pictures the document shows) and the
//! per-stage times of Table 1's stand-ins, with the glossy last bounce on cornell-glossy.

use std::process::Command;

#[test]
fn quick_photons_ablate_both_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("PHOTONS.md");
    let o = Command::new(env!("CARGO_BIN_EXE_photons"))
        .args(["--quick", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "photons failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("photons/photons.json")).unwrap())
            .unwrap();
    for sc in json["scenes"].as_array().unwrap() {
        let name = sc["scene"].as_str().unwrap();
        assert!(md.contains(&format!("## {name}")), "{name} missing");
        for picture in ["reference", "a", "c", "a-c"] {
            assert!(
                dir.path().join(format!("photons/{name}-{picture}.png")).is_file(),
                "{name}-{picture}.png"
            );
        }
        let cuts = sc["cuts"].as_array().unwrap();
        assert_eq!(cuts.len(), 2, "two cut sizes");
        let errors = [&sc["a"]["rel_mse"]]
            .into_iter()
            .chain(cuts.iter().flat_map(|c| [&c["c"]["rel_mse"], &c["a_c"]["rel_mse"]]));
        for e in errors {
            let e = e.as_f64().unwrap();
            assert!(e > 0.0 && e < 1.0, "{name}: relMSE {e}");
        }
        assert!(cuts
            .iter()
            .all(|c| c["nodes"].as_u64().unwrap() >= c["target"].as_u64().unwrap() / 2));
    }
    // The glossy last bounce: each of cornell-glossy's three rough metals judged three ways
    // against the reference, and the five pictures.
    let glossy = json["glossy"]["materials"].as_array().unwrap();
    assert_eq!(glossy.len(), 3, "three rough metals");
    for m in glossy {
        for way in ["photon", "full_map", "per_pixel", "as_diffuse"] {
            let (ratio, e) =
                (m[way]["ratio"].as_f64().unwrap(), m[way]["rel_mse"].as_f64().unwrap());
            assert!(ratio > 0.0 && e > 0.0 && e.is_finite(), "{m}");
        }
    }
    assert!(md.contains("## The glossy last bounce"));
    for picture in ["reference", "photon", "full-map", "per-pixel", "as-diffuse"] {
        assert!(
            dir.path().join(format!("photons/glossy-{picture}.png")).is_file(),
            "glossy-{picture}.png"
        );
    }
    // Table 1's stand-ins, each timed per stage on the CPU (and the GPU where there is one).
    let rows = json["table1"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for row in rows {
        let total = row["cpu"]["total"].as_f64().unwrap();
        assert!(total > 0.0 && row["cpu"]["final_gather"].as_f64().unwrap() > 0.0, "{row}");
        assert!(md.contains(&format!("| {} |", row["scene"].as_str().unwrap())));
    }
    // --markdown-only writes the same document from the numbers alone.
    std::fs::remove_file(&out).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_photons"))
        .args(["--markdown-only", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "photons --markdown-only failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), md);
}
