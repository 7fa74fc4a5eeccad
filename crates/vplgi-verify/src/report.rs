//! The report of a verification: `verify.json` (every measurement), `verify.md` (tables) and a
//! static `verify.html` (tables; for image stages the CPU image, the GPU image and their FLIP
//! error map side by side; for stages whose items disagree, a map of where), with the images in
//! `images/`. A failing stage's maps are shown again under the summary, on the first screen.

use crate::map::ItemKind;
use crate::{ImagePair, StageResult};
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use vplgi_image::{write_atomically, Image, ImageError};

/// Everything a verification run measured, and on what.
#[derive(Serialize)]
pub struct VerifyReport {
    pub scene: String,
    /// The GPU adapter (on machines without a GPU: lavapipe, a CPU Vulkan).
    pub adapter: String,
    pub config: vplgi_types::FrameConfig,
    pub modes: Vec<String>,
    /// Shader files read from `--shaders DIR` instead of the compiled-in copies.
    pub shaders: Vec<vplgi_gpu::shader::ReplacedSource>,
    pub stages: Vec<StageResult>,
    pub images: Vec<ImageFiles>,
    /// The disagreement maps drawn (those with some item beyond a tie).
    pub maps: Vec<MapFiles>,
    pub passed: bool,
    pub seconds: f64,
}

/// The files of one image pair, relative to the report's directory.
#[derive(Clone, Debug, Serialize)]
pub struct ImageFiles {
    pub stage: String,
    pub case: String,
    pub cpu: String,
    pub gpu: String,
    /// The FLIP error map, absent when an image holds a non-finite pixel.
    pub error_map: Option<String>,
    pub flip: Option<f64>,
}

/// One disagreement map's file, relative to the report's directory, and its legend.
#[derive(Clone, Debug, Serialize)]
pub struct MapFiles {
    pub stage: String,
    pub case: String,
    pub file: String,
    /// Pixels of each kind but agreement, with what the kind means and its colour.
    pub legend: Vec<MapKey>,
}

/// One kind of a map's legend.
#[derive(Clone, Debug, Serialize)]
pub struct MapKey {
    pub kind: ItemKind,
    pub meaning: &'static str,
    /// `#rrggbb`.
    pub colour: String,
    pub pixels: usize,
}

/// Writes each stage's disagreement maps that show a disagreement beyond a tie into
/// `dir/images` and returns their files.
pub fn write_maps(dir: &Path, stages: &[StageResult]) -> Result<Vec<MapFiles>, ImageError> {
    images_dir(dir)?;
    let mut files = Vec::new();
    for s in stages {
        for map in s.maps.iter().filter(|m| m.shows_disagreement()) {
            let file = format!("images/{}-map.png", map.case);
            vplgi_image::write_rgb8_png(&dir.join(&file), map.width, map.height, &map.rgb8())?;
            let counts = map.counts();
            let legend = ItemKind::ALL[1..]
                .iter()
                .map(|&kind| {
                    let [r, g, b] = kind.colour();
                    MapKey {
                        kind,
                        meaning: kind.meaning(),
                        colour: format!("#{r:02x}{g:02x}{b:02x}"),
                        pixels: counts[kind as usize],
                    }
                })
                .collect();
            files.push(MapFiles {
                stage: s.stage.name().into(),
                case: map.case.clone(),
                file,
                legend,
            });
        }
    }
    Ok(files)
}

impl VerifyReport {
    /// Judged checks that fail, over all stages.
    pub fn failures(&self) -> impl Iterator<Item = &crate::tolerance::Disagreement> {
        self.stages.iter().flat_map(StageResult::failures)
    }
}

fn image(pair: &ImagePair, pixels: &[[f32; 3]]) -> Image {
    Image { width: pair.width, height: pair.height, pixels: pixels.to_vec() }
}

/// Makes `dir/images`, where the report's pictures go.
fn images_dir(dir: &Path) -> Result<(), ImageError> {
    let images = dir.join("images");
    std::fs::create_dir_all(&images).map_err(|e| ImageError::Write { path: images, source: e })
}

/// Writes each stage's image pairs into `dir/images` and returns their files.
pub fn write_images(dir: &Path, stages: &[StageResult]) -> Result<Vec<ImageFiles>, ImageError> {
    images_dir(dir)?;
    let mut files = Vec::new();
    for s in stages {
        for pair in &s.images {
            let (cpu, gpu) = (image(pair, &pair.cpu), image(pair, &pair.gpu));
            let name = |what: &str| format!("images/{}-{what}.png", pair.case);
            vplgi_image::write_png(&dir.join(name("cpu")), &cpu, 1.0)?;
            vplgi_image::write_png(&dir.join(name("gpu")), &gpu, 1.0)?;
            let (error_map, flip) = match vplgi_image::compare(&cpu, &gpu) {
                Ok(cmp) => {
                    vplgi_image::write_error_map(&dir.join(name("error")), &cmp)?;
                    (Some(name("error")), Some(cmp.metrics.flip))
                }
                Err(_) => (None, None),
            };
            files.push(ImageFiles {
                stage: s.stage.name().into(),
                case: pair.case.clone(),
                cpu: name("cpu"),
                gpu: name("gpu"),
                error_map,
                flip,
            });
        }
    }
    Ok(files)
}

/// Writes `verify.json`, `verify.md` and `verify.html` into `dir`, each atomically.
pub fn write(dir: &Path, report: &VerifyReport) -> Result<(), ImageError> {
    let json =
        serde_json::to_string_pretty(report).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
    write_atomically(&dir.join("verify.json"), |w| w.write_all(json.as_bytes()))?;
    let md = markdown(report);
    write_atomically(&dir.join("verify.md"), |w| w.write_all(md.as_bytes()))?;
    let html = html(report);
    write_atomically(&dir.join("verify.html"), |w| w.write_all(html.as_bytes()))
}

fn verdict(passed: bool) -> &'static str {
    if passed {
        "PASS"
    } else {
        "FAIL"
    }
}

fn config_line(r: &VerifyReport) -> String {
    let c = &r.config;
    format!(
        "{}x{} at {} spp, {} VPLs ({} bounces), K_vpl {}, K_sp {}, F {}, seed {}",
        c.width, c.height, c.spp, c.vpls, c.bounces, c.k_vpl, c.k_sp, c.f, c.seed
    )
}

/// The stages, failing first, each in pipeline order: the summary's rows.
pub fn summary(r: &VerifyReport) -> Vec<&StageResult> {
    let mut rows: Vec<&StageResult> = r.stages.iter().collect();
    rows.sort_by_key(|st| st.passed());
    rows
}

/// A summary row's share of the bound, as printed: `0.37`, `12`, `-`.
fn used_text(st: &StageResult) -> String {
    match st.worst_used() {
        None => "-".into(),
        Some(u) if u.is_infinite() => "inf".into(),
        Some(u) if u >= 10.0 => format!("{u:.0}"),
        Some(u) => format!("{u:.2}"),
    }
}

/// The summary as plain text, one line per stage (what `vplgi verify` prints last).
pub fn summary_text(r: &VerifyReport) -> String {
    let mut s =
        format!("{:<16} {:<7} {:>11} {:>8}\n", "stage", "verdict", "worst/bound", "seconds");
    for st in summary(r) {
        s += &format!(
            "{:<16} {:<7} {:>11} {:>8.1}\n",
            st.stage.name(),
            verdict(st.passed()),
            used_text(st),
            st.seconds
        );
    }
    s
}

/// The report as Markdown.
pub fn markdown(r: &VerifyReport) -> String {
    let mut s = format!("# vplgi verify: {}\n\n", verdict(r.passed));
    s += &format!(
        "- scene: {}\n- GPU: {} (on lavapipe the GPU runs on the CPU)\n- frame: {}\n",
        r.scene,
        r.adapter,
        config_line(r)
    );
    s += &format!("- modes: {}\n- {:.1} s\n", r.modes.join(", "), r.seconds);
    for sh in &r.shaders {
        s += &format!(
            "- shader `{}` read from {}{}\n",
            sh.name,
            sh.path.display(),
            if sh.differs { " (differs from the built-in copy)" } else { "" }
        );
    }
    s += "\n| stage | verdict | worst measured / bound | time |\n|---|---|---|---|\n";
    for st in summary(r) {
        let name = st.stage.name();
        s += &format!(
            "| [{name}](#{name}) | {} | {} | {:.1} s |\n",
            verdict(st.passed()),
            used_text(st),
            st.seconds
        );
    }
    for st in &r.stages {
        s += &format!(
            "\n## {} — {} ({:.1} s)\n\n",
            st.stage.name(),
            verdict(st.passed()),
            st.seconds
        );
        s +=
            "| SPEC row | case | measured | value | bound | verdict |\n|---|---|---|---|---|---|\n";
        for c in &st.checks {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} |\n",
                c.stage,
                c.case,
                c.what,
                c.measured_text(),
                c.bound_text(),
                c.verdict()
            );
        }
        let worst: Vec<_> =
            st.checks.iter().filter(|c| c.worst.is_some() && (!c.holds() || c.judged())).collect();
        if !worst.is_empty() {
            s += "\nWorst items:\n\n";
            for c in worst {
                s += &format!(
                    "- {} ({}), {}: {}\n",
                    c.stage,
                    c.case,
                    c.what,
                    c.worst.as_deref().unwrap_or_default()
                );
            }
        }
        for n in &st.notes {
            s += &format!("\n{n}\n");
        }
        for im in r.images.iter().filter(|i| i.stage == st.stage.name()) {
            let err = im
                .error_map
                .as_deref()
                .map_or(String::from("(no error map: a pixel is not finite)"), |e| {
                    format!("![error]({e})")
                });
            s += &format!("\n{}: ![CPU]({}) ![GPU]({}) {err}\n", im.case, im.cpu, im.gpu);
        }
        for m in r.maps.iter().filter(|m| m.stage == st.stage.name()) {
            s += &format!("\nWhere {} disagrees: ![map]({}) {}\n", m.case, m.file, legend_text(m));
        }
    }
    s
}

/// Escapes text for HTML.
fn esc(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A map's legend in words: `12 pixels: a miss on one backend only; ...`.
fn legend_text(m: &MapFiles) -> String {
    let kinds: Vec<String> = m
        .legend
        .iter()
        .filter(|k| k.pixels > 0)
        .map(|k| format!("{} pixels: {}", k.pixels, k.meaning))
        .collect();
    kinds.join("; ")
}

/// An image that opens full size when clicked.
fn linked_figure(src: &str, alt: &str, caption: &str, class: &str) -> String {
    format!(
        "<figure><a href=\"{0}\"><img class=\"{class}\" src=\"{0}\" alt=\"{1}\"></a><figcaption>{2}</figcaption></figure>",
        esc(src),
        esc(alt),
        caption
    )
}

/// A disagreement map with its legend, the counts beside the colours.
fn map_figure(m: &MapFiles) -> String {
    let mut legend = String::new();
    for k in m.legend.iter().filter(|k| k.pixels > 0) {
        legend += &format!(
            "<br><span class=\"swatch\" style=\"background:{}\"></span> {} px: {}",
            k.colour,
            k.pixels,
            esc(k.meaning)
        );
    }
    format!(
        "<figure class=\"map\"><figcaption>where <b>{0}</b> disagrees</figcaption><a href=\"{1}\"><img class=\"map\" src=\"{1}\" alt=\"where {0} disagrees\"></a><figcaption>{2}</figcaption></figure>",
        esc(&m.case),
        esc(&m.file),
        legend.trim_start_matches("<br>")
    )
}

/// The report as one static HTML page (no scripts).
pub fn html(r: &VerifyReport) -> String {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>vplgi verify</title>\n<style>\
         body{font-family:sans-serif;margin:2em;max-width:90em}table{border-collapse:collapse;margin:1em 0}\
         td,th{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}td.n{font-family:monospace;text-align:right}\
         .ok{color:#070}.FAILS{color:#b00;font-weight:bold}.info{color:#666}.PASS{color:#070}.FAIL{color:#b00}\
         figure{display:inline-block;margin:.5em;vertical-align:top}figure img{image-rendering:pixelated;width:256px;border:1px solid #ccc}\
         .worst{font-family:monospace;font-size:.85em}tr.failing{background:#fdd}\
         .swatch{display:inline-block;width:.8em;height:.8em;border:1px solid #999}figcaption{max-width:256px;font-size:.85em}</style></head><body>\n",
    );
    s += &format!("<h1>vplgi verify: <span class=\"{0}\">{0}</span></h1>\n<ul>", verdict(r.passed));
    s += &format!(
        "<li>scene: {}</li><li>GPU: {} (on lavapipe the GPU runs on the CPU)</li><li>frame: {}</li><li>modes: {}</li><li>{:.1} s</li>",
        esc(&r.scene),
        esc(&r.adapter),
        esc(&config_line(r)),
        esc(&r.modes.join(", ")),
        r.seconds
    );
    for sh in &r.shaders {
        s += &format!(
            "<li>shader <code>{}</code> read from {}{}</li>",
            esc(sh.name),
            esc(&sh.path.display().to_string()),
            if sh.differs { " (differs from the built-in copy)" } else { "" }
        );
    }
    s += "</ul>\n<h2>Summary</h2>\n<p>Failing stages first. The worst share of a bound is the judged check closest to its bound: measured / bound for an upper bound, the disagreeing share over the allowed one for a lower bound; above 1 fails.</p>\n<table id=\"summary\"><tr><th>stage</th><th>verdict</th><th>worst measured / bound</th><th>time</th></tr>\n";
    for st in summary(r) {
        let (name, v) = (st.stage.name(), verdict(st.passed()));
        s += &format!(
            "<tr class=\"{}\"><td><a href=\"#{name}\">{name}</a></td><td class=\"{v}\">{v}</td><td class=\"n\">{}</td><td class=\"n\">{:.1} s</td></tr>\n",
            if st.passed() { "" } else { "failing" },
            used_text(st),
            st.seconds
        );
    }
    s += "</table>\n";
    // Where the failing stages fail, before anything else: each one's first map (its section
    // has them all).
    let failing: Vec<&MapFiles> = summary(r)
        .into_iter()
        .filter(|st| !st.passed())
        .filter_map(|st| r.maps.iter().find(|m| m.stage == st.stage.name()))
        .collect();
    if !failing.is_empty() {
        s += "<div id=\"failing-maps\">";
        for m in failing {
            s += &map_figure(m);
        }
        s += "</div>\n";
    }
    for st in &r.stages {
        let v = verdict(st.passed());
        s += &format!(
            "<section id=\"{0}\"><h2>{0}: <span class=\"{v}\">{v}</span> ({1:.1} s)</h2>\n",
            st.stage.name(),
            st.seconds
        );
        s += "<table><tr><th>SPEC row</th><th>case</th><th>measured</th><th>value</th><th>bound</th><th>verdict</th><th>worst item</th></tr>\n";
        for c in &st.checks {
            s += &format!(
                "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"{}\">{}</td><td class=\"worst\">{}</td></tr>\n",
                if c.holds() { "" } else { "failing" },
                esc(&c.stage),
                esc(&c.case),
                esc(&c.what),
                c.measured_text(),
                esc(&c.bound_text()),
                c.verdict(),
                c.verdict(),
                esc(c.worst.as_deref().unwrap_or(""))
            );
        }
        s += "</table>\n";
        for m in r.maps.iter().filter(|m| m.stage == st.stage.name()) {
            s += &map_figure(m);
        }
        for n in &st.notes {
            s += &format!("<p>{}</p>\n", esc(n));
        }
        for im in r.images.iter().filter(|i| i.stage == st.stage.name()) {
            s += &format!("<div class=\"pair\"><h3>{}</h3>", esc(&im.case));
            s += &linked_figure(&im.cpu, "CPU image", "CPU", "image");
            s += &linked_figure(&im.gpu, "GPU image", "GPU", "image");
            match (&im.error_map, im.flip) {
                (Some(e), Some(f)) => {
                    s += &linked_figure(
                        e,
                        "FLIP error map",
                        &format!("FLIP error map (mean {f:.2e})"),
                        "image",
                    )
                }
                _ => s +=
                    "<figure><figcaption>no error map: a pixel is not finite</figcaption></figure>",
            }
            s += "</div>\n";
        }
        s += "</section>\n";
    }
    s += "</body></html>\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::DisagreementMap;
    use crate::tolerance::Disagreement;
    use crate::VerifyStage;

    fn stage(stage: VerifyStage, measured: f64, map: DisagreementMap) -> StageResult {
        let mut r = crate::result(stage);
        r.checks.push(Disagreement::at_most(stage.name(), "a row", measured, 1.0));
        r.maps.push(map);
        r
    }

    /// A map is drawn where something disagrees beyond a tie, with its legend; a failing stage's
    /// map is shown under the summary, before the stages, and every image is a link.
    #[test]
    fn a_failing_stage_leads_with_its_map() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let mut seam = DisagreementMap::new("seam", 4, 4);
        for i in 0..4 {
            seam.mark(i * 5, ItemKind::Miss);
        }
        let mut ties = DisagreementMap::new("ties", 4, 4);
        ties.mark(3, ItemKind::Tie);
        let stages =
            vec![stage(VerifyStage::Rng, 0.0, ties), stage(VerifyStage::ShadingPoints, 2.0, seam)];
        let maps = write_maps(dir.path(), &stages).expect("maps written");
        assert_eq!(maps.len(), 1, "a map of ties alone is not drawn");
        assert_eq!(
            (maps[0].stage.as_str(), maps[0].file.as_str()),
            ("shading_points", "images/seam-map.png")
        );
        assert!(dir.path().join("images/seam-map.png").exists());
        let miss = maps[0].legend.iter().find(|k| k.kind == ItemKind::Miss).expect("misses");
        assert_eq!((miss.pixels, miss.colour.as_str()), (4, "#ff1e1e"));
        let report = VerifyReport {
            scene: "test".into(),
            adapter: "none".into(),
            config: vplgi_types::FrameConfig::default(),
            modes: Vec::new(),
            shaders: Vec::new(),
            stages,
            images: Vec::new(),
            maps,
            passed: false,
            seconds: 0.0,
        };
        let page = html(&report);
        let (shown, first) = (
            page.find("id=\"failing-maps\"").expect("maps under the summary"),
            page.find("<section").expect("sections"),
        );
        assert!(page.find("id=\"summary\"").expect("summary") < shown && shown < first);
        assert!(page[shown..first].contains("<a href=\"images/seam-map.png\"><img class=\"map\""));
        assert!(page.contains("4 px: a miss on one backend only"));
        assert!(markdown(&report).contains("![map](images/seam-map.png)"));
    }
}
