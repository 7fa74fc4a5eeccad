//! `perf_report --quick` runs end to end (small sizes) and writes every section, with numbers.

use std::process::Command;

#[test]
fn quick_perf_report_writes_every_section() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("PERFORMANCE.md");
    // faiss is not installed for the tests: --quick reports without it.
    let o = Command::new(env!("CARGO_BIN_EXE_perf_report"))
        .args(["--quick", "--out", out.to_str().unwrap()])
        .output()
        .expect("run perf_report");
    assert!(o.status.success(), "perf_report failed: {}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(&out).unwrap();
    for section in [
        "## k-means against faiss-cpu",
        "## visibility against raw Embree",
        "## GPU against CPU, per stage",
        "## Clustered against the reference",
        "## Over time",
        "### conference",
        "**The floor.**",
        "--quick",
    ] {
        assert!(md.contains(section), "missing {section:?} in:\n{md}");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("perf/perf.json")).unwrap()).unwrap();
    let rows = json["kmeans"]["rows"].as_array().unwrap();
    let cpu: Vec<&serde_json::Value> =
        rows.iter().filter(|r| r["name"].as_str().unwrap().contains("CPU")).collect();
    assert_eq!(cpu.len(), 2, "{rows:?}");
    // Uniform points in K cube-like cells of side K^(-1/3): MSE = 3 axes x side^2 / 12.
    let ideal = 256f64.powf(-2.0 / 3.0) / 4.0;
    for r in rows {
        let mse = r["mse"].as_f64().unwrap();
        assert!(
            mse > 0.8 * ideal && mse < 1.3 * ideal,
            "{}: MSE {mse}, ideal cells give {ideal}",
            r["name"]
        );
    }
    assert!(json["visibility"]["percent_of_raw"].as_f64().unwrap() > 0.0);
    // A measured speed-up, not a target: at --quick sizes on a loaded machine the clustered frame
    // is not always faster (speed belongs in the report, not in a timed test).
    let speedup = json["approximation"]["speedup"].as_f64().unwrap();
    assert!(speedup.is_finite() && speedup > 0.0, "speed-up {speedup}");
    // Both frames have every stage's ratio and throughput on both backends (the GPU is lavapipe).
    let frames = json["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    for fr in frames {
        for st in fr["stages"].as_array().unwrap() {
            assert!(st["ratio"].as_f64().is_some_and(|r| r > 0.0), "{st}");
            if st["stage"] != "total" {
                assert!(
                    st["cpu_rate"].as_f64().is_some_and(|r| r > 0.0)
                        && st["gpu_rate"].as_f64().is_some_and(|r| r > 0.0),
                    "{st}"
                );
            }
        }
    }
    assert_eq!(
        json["floor"]["labels_agree"], json["floor"]["points"],
        "the floor kernel and its twin must agree"
    );
    // The run was added to the history and charted.
    let history: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("perf/history.json")).unwrap())
            .unwrap();
    assert_eq!(history.as_array().unwrap().len(), 1);
    assert!(std::fs::read_to_string(dir.path().join("perf/history.svg"))
        .unwrap()
        .starts_with("<svg"));
    for png in ["reference.png", "clustered.png", "error_map.png"] {
        assert!(dir.path().join("perf").join(png).is_file(), "{png} missing");
    }
}
