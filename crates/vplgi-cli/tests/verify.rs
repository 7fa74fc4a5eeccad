//! `vplgi verify` as a kernel author runs it: a passing run and its report in a real browser, a
//! shader broken on purpose through `--shaders`, and bad arguments.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn vplgi(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vplgi")).args(args).output().expect("run vplgi")
}

/// A small frame: every stage and mode in seconds.
const SMALL: [&str; 10] =
    ["--width", "40", "--height", "32", "--vpls", "600", "--k-sp", "150", "--k-vpl", "60"];

/// Skips (outside CI) when there is no GPU adapter; otherwise the run's output.
fn verify(out: &Path, extra: &[&str]) -> Option<Output> {
    let mut args = vec!["verify", "--out", out.to_str().expect("utf-8 path")];
    args.extend_from_slice(extra);
    let o = vplgi(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    if err.contains("no GPU adapter") && std::env::var("CI").map_or(true, |v| v != "true") {
        eprintln!("\n*** SKIPPED: {err} ***\n");
        return None;
    }
    Some(o)
}

/// A `shaders/` folder in `dir` holding the built-in `file` with each `(from, to)` of `edits`
/// applied: what a kernel author gives `--shaders`. Each `from` must be in the file, so a changed
/// shader fails here rather than leaving the test's kernel unbroken.
fn edited_shaders(dir: &Path, file: &str, edits: &[(&str, &str)]) -> PathBuf {
    let shaders = dir.join("shaders");
    std::fs::create_dir(&shaders).expect("mkdir");
    let mut text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders").join(file),
    )
    .expect("a built-in shader");
    for (from, to) in edits {
        assert!(text.contains(from), "{file} changed: update this test's edit of {from}");
        text = text.replace(from, to);
    }
    std::fs::write(shaders.join(file), text).expect("write");
    shaders
}

/// Loads `page` in headless chromium with a script appended that reports, on the console, every
/// image that did not decode and the sections shown; returns the console lines and the DOM.
fn load_in_chromium(page: &Path) -> (Vec<String>, String) {
    let probe = page.with_file_name("probe.html");
    let html = std::fs::read_to_string(page).expect("read the page");
    let script = "<script>window.addEventListener('load', () => { for (const i of document.images) { if (!i.complete || i.naturalWidth === 0) \
                  console.error('image not loaded: ' + i.getAttribute('src')); } console.log('probe: ' + document.querySelectorAll('section').length + ' sections, ' \
                  + document.images.length + ' images'); for (const i of document.querySelectorAll('#failing-maps img')) { console.log('failing map ' \
                  + i.getAttribute('src') + ' top ' + Math.round(i.getBoundingClientRect().top) + ' of ' + window.innerHeight); } });</script>";
    std::fs::write(&probe, html.replace("</body>", &format!("{script}</body>")))
        .expect("write the probe page");
    let o = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=10000",
            "--dump-dom",
        ])
        .arg(format!("file://{}", probe.display()))
        .output()
        .expect("chromium (installed by ci/install-deps.sh) runs");
    assert!(o.status.success(), "chromium failed: {}", String::from_utf8_lossy(&o.stderr));
    let console = String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(String::from)
        .collect();
    (console, String::from_utf8_lossy(&o.stdout).into_owned())
}

/// Every stage passes on the Cornell box; the report's three files exist, and the HTML page,
/// loaded in a real browser, shows every stage and every image without a console error.
#[test]
fn verify_passes_and_its_page_loads_in_a_browser() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let Some(o) = verify(dir.path(), &SMALL) else { return };
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "verify failed:\n{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("verify: PASS"), "{stdout}");
    let report: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("verify.json")).expect("verify.json"),
    )
    .expect("JSON");
    assert_eq!(report["passed"], true);
    let stages: Vec<&str> = report["stages"]
        .as_array()
        .expect("stages")
        .iter()
        .filter_map(|s| s["stage"].as_str())
        .collect();
    let every: Vec<&str> = vplgi_verify::VerifyStage::ALL.iter().map(|s| s.name()).collect();
    assert_eq!(stages, every, "every stage of the table, in pipeline order");
    assert_eq!(report["modes"].as_array().map(Vec::len), Some(8), "every mode by default");
    // 8 modes x (shade, frame) and the 6 that cluster shading points interpolated, three
    // pictures each.
    assert_eq!(report["images"].as_array().map(Vec::len), Some(22));
    assert!(std::fs::read_to_string(dir.path().join("verify.md"))
        .expect("verify.md")
        .contains("## shade"));

    let (console, dom) = load_in_chromium(&dir.path().join("verify.html"));
    println!("console: {console:#?}");
    for s in stages {
        assert!(dom.contains(&format!("<section id=\"{s}\">")), "the page does not show stage {s}");
        assert!(
            dom.contains(&format!("<a href=\"#{s}\">{s}</a>")),
            "the summary does not list stage {s}"
        );
    }
    // The summary comes first on the page, and last in the text output.
    let summary = dom.find("id=\"summary\"").expect("a summary table");
    assert!(
        summary < dom.find("<section id=").expect("stage sections"),
        "the summary is not first"
    );
    let last = stdout.trim_end().lines().last().unwrap_or_default();
    assert!(last.starts_with("frame "), "the text output does not end with the summary: {last}");
    let errors: Vec<&String> = console.iter().filter(|l| !l.contains("probe: ")).collect();
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    assert!(
        console.iter().any(|l| l.contains(&format!("probe: {} sections, 66 images", every.len()))),
        "the probe did not run: {console:#?}"
    );
}

/// The probe itself sees a missing image: the browser check can fail.
#[test]
fn the_browser_probe_reports_a_missing_image() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let page = dir.path().join("page.html");
    std::fs::write(&page, "<!DOCTYPE html><html><body><section id=\"x\"></section><img src=\"missing.png\"></body></html>").expect("write");
    let (console, _) = load_in_chromium(&page);
    assert!(console.iter().any(|l| l.contains("image not loaded: missing.png")), "{console:#?}");
}

/// The shade kernel with its geometry-term clamp removed, given with --shaders: verify exits
/// non-zero, names the stage and its worst pixel, and still writes the report. At verify's default
/// size (the clamp bites near the contact edges of the boxes; at 40x32 with 600 VPLs it changes
/// the image by less than the tolerance).
#[test]
fn a_broken_shader_fails_naming_the_stage() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let clamp = "let capped = select(min(g, g_max), g, r2 > 0.0);";
    let shaders = edited_shaders(dir.path(), "shade.wgsl", &[(clamp, "let capped = g;")]);
    let out = dir.path().join("out");
    let Some(o) = verify(
        &out,
        &["--shaders", shaders.to_str().expect("utf-8"), "--stages", "shade", "--cluster", "both"],
    ) else {
        return;
    };
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("{stderr}");
    assert!(!o.status.success(), "a shader without the clamp passed verify");
    assert!(stderr.contains("differs from the built-in copy"), "{stderr}");
    assert!(
        stderr.contains("stage shade / final image (both/weighted)")
            && stderr.contains("worst: pixel ("),
        "{stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("verify.json")).expect("verify.json"))
            .expect("JSON");
    assert_eq!(report["passed"], false);
}

/// The shading-points kernel with 1 % more emitted radiance (its own hit's at 1 spp, the pixel's
/// 16-ray mean at 3), given with --shaders: verify fails at 1 and at 3 samples per pixel, on the
/// row that judges each sample's emission against what the scene's emitters can give. (At 3 spp
/// the share of samples whose emission agrees with the CPU's passes this kernel: its bound lets
/// 1.6 % differ, and the light is about 1 % of the Cornell box's samples.)
#[test]
fn one_percent_more_emission_fails_at_one_and_three_spp() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let shaders = edited_shaders(
        dir.path(),
        "shading_points.wgsl",
        &[
            ("sp.emitted = path.emitted;", "sp.emitted = 1.01 * path.emitted;"),
            (
                "return sum / f32(EMISSION_STRATA * EMISSION_STRATA);",
                "return 1.01 * sum / f32(EMISSION_STRATA * EMISSION_STRATA);",
            ),
        ],
    );
    for spp in ["1", "3"] {
        let out = dir.path().join(format!("out-{spp}"));
        let mut args = SMALL.to_vec();
        args.extend([
            "--spp",
            spp,
            "--stages",
            "shading_points",
            "--shaders",
            shaders.to_str().expect("utf-8"),
        ]);
        let Some(o) = verify(&out, &args) else { return };
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("{spp} spp:\n{}\n{stderr}", String::from_utf8_lossy(&o.stdout));
        assert!(!o.status.success(), "1 % more emission passed verify at {spp} spp");
        let row = stderr
            .lines()
            .find(|l| l.contains("samples whose emitted radiance is no"))
            .unwrap_or_else(|| panic!("no failing emission row at {spp} spp:\n{stderr}"));
        assert!(
            row.contains(&format!("[shading_points (40x32, {spp} spp)]"))
                && row.contains("FAILS")
                && row.contains("worst: sample "),
            "{row}"
        );
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("verify.json")).expect("verify.json"))
                .expect("JSON");
        assert_eq!(report["passed"], false);
    }
}

/// A shader that does not compile is refused before any GPU work, naming the file; an unknown
/// stage is refused with the list of stages.
#[test]
fn bad_shaders_and_stages_are_refused_by_name() {
    let dir = tempfile::tempdir().expect("temporary directory");
    std::fs::write(dir.path().join("visibility.wgsl"), "fn main( {").expect("write");
    let o = vplgi(&[
        "verify",
        "--shaders",
        dir.path().to_str().expect("utf-8"),
        "--out",
        dir.path().join("out").to_str().expect("utf-8"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("visibility.wgsl does not compile"), "{err}");
    assert!(!dir.path().join("out/verify.json").exists(), "a refused run wrote a report");
    let o = vplgi(&["verify", "--stages", "shade,bogus"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("unknown stage 'bogus'") && err.contains("trace_vpls"),
        "{err}"
    );
}

/// The shading-points kernel made to miss the rays of the pixels on the image's diagonal (a
/// seam), given with --shaders: verify fails on shading_points, says where its map is, and
/// verify.html, loaded in a real browser, shows that map under the summary, within the first
/// screen, with the missed pixels counted in its legend.
#[test]
fn a_failing_stage_shows_where_on_the_first_screen() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let hit = "if (path.triangle != NO_HIT) {";
    let seam = "if (path.triangle != NO_HIT && pixel % (params.width + 1u) != 0u) {";
    let shaders = edited_shaders(dir.path(), "shading_points.wgsl", &[(hit, seam)]);
    let out = dir.path().join("out");
    let mut args = SMALL.to_vec();
    args.extend(["--stages", "shading_points", "--shaders", shaders.to_str().expect("utf-8")]);
    let Some(o) = verify(&out, &args) else { return };
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("{stderr}");
    assert!(!o.status.success(), "a kernel missing a seam passed verify");
    let map = "images/shading_points-40x32-1spp-map.png";
    assert!(
        stderr.contains(&format!(
            "where shading_points-40x32-1spp disagrees: {}",
            out.join(map).display()
        )),
        "{stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("verify.json")).expect("verify.json"))
            .expect("JSON");
    let maps = report["maps"].as_array().expect("maps");
    let legend = maps.iter().find(|m| m["file"] == map).expect("the stage's map")["legend"]
        .as_array()
        .expect("legend")
        .clone();
    let missed = legend.iter().find(|k| k["kind"] == "Miss").expect("misses")["pixels"]
        .as_u64()
        .expect("a count");
    // Of the diagonal's 32 pixels, those that see the room on the CPU (the corners see out of
    // its open front); nothing else disagrees beyond a tie.
    assert!((20..=32).contains(&missed), "{legend:?}");
    for kind in ["Beyond", "Other"] {
        assert_eq!(legend.iter().find(|k| k["kind"] == kind).expect("a kind")["pixels"], 0);
    }
    // And the red pixels are on the diagonal, every one.
    let png = image::open(out.join(map)).expect("the map decodes").to_rgb8();
    let red: Vec<(u32, u32)> = png
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 == [255, 30, 30])
        .map(|(x, y, _)| (x, y))
        .collect();
    assert_eq!(red.len() as u64, missed);
    assert!(red.iter().all(|(x, y)| x == y), "red off the diagonal: {red:?}");

    let (console, dom) = load_in_chromium(&out.join("verify.html"));
    println!("console: {console:#?}");
    let errors: Vec<&String> = console.iter().filter(|l| l.contains("not loaded")).collect();
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let first_section = dom.find("<section id=").expect("stage sections");
    let shown = dom.find("id=\"failing-maps\"").expect("maps under the summary");
    let named = dom
        .find("<tr class=\"failing\"><td><a href=\"#shading_points\">shading_points</a>")
        .expect("the summary names the failing stage");
    assert!(named < shown, "the failing stage is not named above its map");
    assert!(shown < first_section, "the failing stage's map is not above the stages");
    assert!(dom[..first_section].contains(&format!("<a href=\"{map}\">")), "the map is not a link");
    let top = console
        .iter()
        .find_map(|l| {
            let rest = l.split(&format!("failing map {map} top ")).nth(1)?;
            let mut words = rest.split_whitespace();
            let top: i64 = words.next()?.parse().ok()?;
            let height: i64 = words.nth(1)?.trim_end_matches(['"', ',']).parse().ok()?;
            Some((top, height))
        })
        .expect("the probe saw the failing map");
    assert!(top.0 < top.1, "the map is below the first screen: top {} of {}", top.0, top.1);
}
