//! Helpers every subcommand shares: loading the scene named on the command line, writing JSON
//! atomically, cleaning up after Ctrl-C, and the process's peak memory.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Peak resident memory of this process so far (Linux `VmHWM`), in MiB.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib: f64 = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kib / 1024.0)
}

/// Loads the scene named on the command line, or the built-in Cornell box.
pub fn load_scene(path: Option<&Path>) -> Result<(vplgi_scene::Scene, String)> {
    match path {
        None => Ok((vplgi_scene::cornell::cornell_box(), "builtin:cornell-box".into())),
        Some(p) if p.as_os_str() == "cornell-box" && !p.exists() => {
            Ok((vplgi_scene::cornell::cornell_box(), "builtin:cornell-box".into()))
        }
        Some(p) => Ok((vplgi_scene::Scene::load(p)?, p.display().to_string())),
    }
}

/// Warns, once per material, where `scene` has mirrors or glass and the frame leaves out the
/// caustic map: camera rays and light particles go on from such a surface, but the light that
/// reaches a diffuse surface through it is in the image only with `--caustics photons`.
pub fn warn_without_caustics(
    scene: &vplgi_scene::Scene,
    source: &str,
    cfg: &vplgi_types::FrameConfig,
) {
    if cfg.has_caustics() {
        return;
    }
    for m in scene.materials.iter().filter(|m| m.surface.is_specular()) {
        eprintln!(
            "warning: {source}: material '{}' is {}: camera rays and light particles go on from it, reflected or refracted, but light that \
             reaches a diffuse surface through it (caustics, and direct light through glass) is in the image only with --caustics photons",
            m.name,
            m.surface.describe()
        );
    }
}

/// Writes pretty JSON atomically.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value).context("serialising JSON")?;
    vplgi_image::write_atomically(path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())?;
        w.write_all(b"\n")
    })?;
    Ok(())
}

/// On Ctrl-C, remove this process's unfinished temporary files in `dir` before exiting, so an
/// interrupted run leaves the previous outputs (or nothing), never a partial file.
pub fn install_interrupt_cleanup(dir: PathBuf) {
    let marker = format!(".tmp-{}-", std::process::id());
    let _ = ctrlc::set_handler(move || {
        if let Ok(entries) = std::fs::read_dir(&dir) {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().contains(&marker) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        eprintln!("\ninterrupted: no output written");
        std::process::exit(130);
    });
}

/// `--shaders DIR` of `render` and `verify`: the WGSL files found in `dir` replace the
/// compiled-in copies for every kernel built afterwards (validated first), each one named on
/// stderr, so a kernel author times or verifies an edited shader without rebuilding vplgi.
pub fn use_shaders_from(dir: Option<&Path>) -> Result<Vec<vplgi_gpu::shader::ReplacedSource>> {
    let Some(dir) = dir else {
        return Ok(Vec::new());
    };
    let replaced = vplgi_gpu::shader::use_sources_from(dir)
        .with_context(|| format!("--shaders {}", dir.display()))?;
    for r in &replaced {
        eprintln!(
            "shader {} from {}{}",
            r.name,
            r.path.display(),
            if r.differs { " (differs from the built-in copy)" } else { "" }
        );
    }
    Ok(replaced)
}
