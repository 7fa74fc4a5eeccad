//! `vplgi scene`: procedural scenes at the paper's scale, written as `.glb`, and any scene
//! exported for Mitsuba 3.

use crate::shared::load_scene;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};
use vplgi_scene::generate::{generate, GENERATORS};
use vplgi_scene::mitsuba::{export, RenderDefaults};
use vplgi_scene::Surface;
use vplgi_types::FrameConfig;

#[derive(Args)]
pub struct SceneArgs {
    #[command(subcommand)]
    command: SceneCommand,
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Generate a scene (deterministic) and write it as binary glTF: cornell-fine (the Cornell
    /// box tessellated, ~1.9 M triangles), conference (tables and chairs on thin legs, ~300 k),
    /// living-room (large smooth walls, sofas, a glass-topped table, a wall mirror, a
    /// window-like light, ~300 k), sunlit-living-room (the same room with a wooden table and no
    /// mirror, an open window and the sun, a directional light, shining in), seams
    /// and seams-rotated (a Cornell box whose walls and block faces are separately transformed
    /// meshes meeting at cracks a few ulps wide, as exported scenes do, seen by a centred camera
    /// whose pixel rays run along them: GPU traversal against Embree on real-world geometry),
    /// cornell-mirror, cornell-glass and cornell-glossy (the Cornell box with a mirror wall and
    /// sphere, a closed glass cube and sphere, rough metals of roughness 0.6, 0.3 and 0.1: mirrors
    /// and glass are seen through and pass light on, rough metals reflect glossily),
    /// cornell-water (the Cornell box a third full of wavy water, index 1.33, lit by the ceiling
    /// and by a point light whose caustics the waves throw on the floor: render it with
    /// --caustics photons, ~17 k), cornell-mirrors (the Cornell box with a mirror back and right
    /// wall, a finely tessellated white sphere and a point light, ~84 k).
    Generate(GenerateArgs),
    /// Write a scene for another renderer, to cross-check vplgi's references against it:
    /// `--format mitsuba` writes DIR/scene.xml (Mitsuba 3, `path` integrator) with one PLY mesh per
    /// material in DIR/meshes/. Render it with `mitsuba -D spp=1024 DIR/scene.xml` or from Python
    /// (`mi.load_file`); width, height, spp and max_depth are overridable defaults.
    Export(ExportArgs),
}

#[derive(Args)]
struct ExportArgs {
    /// Scene file (.gltf / .glb) [default: the built-in Cornell box; `cornell-box` names it too].
    #[arg(value_name = "SCENE")]
    scene: Option<PathBuf>,
    /// Target renderer (only Mitsuba 3 for now).
    #[arg(long, value_parser = ["mitsuba"], default_value = "mitsuba")]
    format: String,
    /// Output folder (created; files already in it are replaced one by one).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Image width written as the default (vplgi render's default).
    #[arg(long, default_value_t = FrameConfig::default().width)]
    width: u32,
    /// Image height written as the default.
    #[arg(long, default_value_t = FrameConfig::default().height)]
    height: u32,
    /// Samples per pixel written as the default.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// vplgi's light bounces; Mitsuba's max_depth is written as this + 2, the same paths.
    #[arg(long, default_value_t = FrameConfig::default().bounces)]
    bounces: u32,
}

#[derive(Args)]
struct GenerateArgs {
    /// Which scene.
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(GENERATORS.map(|g| g.0)))]
    name: String,
    /// About how many triangles [default: the paper's size: 1,900,000 for cornell-fine, 300,000
    /// for the rooms, 36 for the seams rooms]. Large surfaces are split to meet it; furniture
    /// detail is fixed.
    #[arg(long)]
    triangles: Option<usize>,
    /// Output file [default: out/scenes/NAME.glb, NAME-matte.glb with --matte].
    #[arg(long, value_name = "FILE.glb")]
    out: Option<PathBuf>,
    /// Also animate the camera node: a walk of N keyframes one second apart (forward by 12 % of
    /// the scene's diagonal, swaying and turning a little), which `vplgi render --frames` renders
    /// as a sequence.
    #[arg(long, value_name = "N")]
    camera_walk: Option<u32>,
    /// Make every surface diffuse, its base colour kept (mirrors, glass and metals turn matte):
    /// the same scene without specular or glossy light, which tells what only they cause (`make
    /// validate` renders cornell-mirror and cornell-glass both ways).
    #[arg(long)]
    matte: bool,
}

pub fn run(args: SceneArgs) -> Result<()> {
    match args.command {
        SceneCommand::Generate(g) => run_generate(g),
        SceneCommand::Export(e) => run_export(e),
    }
}

fn run_export(args: ExportArgs) -> Result<()> {
    if args.width == 0 || args.height == 0 || args.spp == 0 {
        bail!("--width, --height and --spp must be at least 1");
    }
    let (scene, source) = load_scene(args.scene.as_deref())?;
    let defaults = RenderDefaults {
        width: args.width,
        height: args.height,
        spp: args.spp,
        max_depth: args.bounces + 2,
    };
    let exported = export(&scene, defaults);
    // scene.xml is written last, so an interrupted export has no scene file to render.
    let mut files = exported.files;
    files.rotate_left(1);
    for (name, bytes) in &files {
        let path = args.out.join(name);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
        }
        write_file(&path, bytes)?;
    }
    for w in &exported.warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "{source}: {} triangles, {} materials, {} punctual lights -> {} ({} files)",
        scene.triangle_count(),
        scene.materials.len(),
        scene.lights.len(),
        args.out.join("scene.xml").display(),
        files.len()
    );
    println!("render it: mitsuba -D spp=1024 {}", args.out.join("scene.xml").display());
    Ok(())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    vplgi_image::write_atomically(path, |w| {
        use std::io::Write;
        w.write_all(bytes)
    })
    .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn run_generate(g: GenerateArgs) -> Result<()> {
    let default = GENERATORS.iter().find(|x| x.0 == g.name).map_or(300_000, |x| x.1);
    let mut scene =
        generate(&g.name, g.triangles.unwrap_or(default)).map_err(|e| anyhow::anyhow!("{e}"))?;
    if g.matte {
        scene.name = format!("{} (matte)", scene.name);
        scene.materials.iter_mut().for_each(|m| m.surface = Surface::Diffuse);
    }
    if let Some(keys) = g.camera_walk {
        scene.camera_path = Some(
            vplgi_scene::generate::camera_walk(&scene, keys)
                .map_err(|e| anyhow::anyhow!("--camera-walk: {e}"))?,
        );
    }
    let stem = if g.matte { format!("{}-matte", g.name) } else { g.name.clone() };
    let out = g.out.unwrap_or_else(|| PathBuf::from(format!("out/scenes/{stem}.glb")));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let bytes = vplgi_scene::gltf_write::glb(&scene).map_err(|e| anyhow::anyhow!("{e}"))?;
    write_file(&out, &bytes)?;
    let emissive = scene
        .material_ids
        .iter()
        .filter(|&&m| scene.materials[m as usize].emission.max_element() > 0.0)
        .count();
    println!(
        "{}: {} triangles ({} emissive), {:.1} MB",
        scene.name,
        scene.triangle_count(),
        emissive,
        bytes.len() as f64 / 1e6
    );
    match g.camera_walk {
        Some(keys) => {
            println!("wrote {} (camera walk of {keys} keyframes)\nrender it: vplgi render {} --frames {}", out.display(), out.display(), 4 * (keys - 1) + 1)
        }
        None => println!("wrote {}\nrender it: vplgi render {}", out.display(), out.display()),
    }
    Ok(())
}
