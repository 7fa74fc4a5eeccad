//! `vplgi scene`: procedural scenes at the paper's scale, written as `.glb`.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use vplgi_scene::generate::{generate, GENERATORS};

#[derive(Args)]
pub struct SceneArgs {
    #[command(subcommand)]
    command: SceneCommand,
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Generate a scene (deterministic) and write it as binary glTF: cornell-fine (the Cornell
    /// box tessellated, ~1.9 M triangles), conference (tables and chairs on thin legs, ~300 k),
    /// living-room (large smooth walls, sofas, a window-like light, ~300 k).
    Generate(GenerateArgs),
}

#[derive(Args)]
struct GenerateArgs {
    /// Which scene.
    #[arg(value_parser = ["cornell-fine", "conference", "living-room"])]
    name: String,
    /// About how many triangles [default: the paper's size: 1,900,000 for cornell-fine, 300,000
    /// for the rooms]. Large surfaces are split to meet it; furniture detail is fixed.
    #[arg(long)]
    triangles: Option<usize>,
    /// Output file [default: out/scenes/NAME.glb].
    #[arg(long, value_name = "FILE.glb")]
    out: Option<PathBuf>,
}

pub fn run(args: SceneArgs) -> Result<()> {
    let SceneCommand::Generate(g) = args.command;
    let default = GENERATORS.iter().find(|x| x.0 == g.name).map_or(300_000, |x| x.1);
    let scene = generate(&g.name, g.triangles.unwrap_or(default)).map_err(|e| anyhow::anyhow!("{e}"))?;
    let out = g.out.unwrap_or_else(|| PathBuf::from(format!("out/scenes/{}.glb", g.name)));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let bytes = vplgi_scene::gltf_write::glb(&scene).map_err(|e| anyhow::anyhow!("{e}"))?;
    vplgi_image::write_atomically(&out, |w| {
        use std::io::Write;
        w.write_all(&bytes)
    })
    .with_context(|| format!("writing {}", out.display()))?;
    let emissive = scene.material_ids.iter().filter(|&&m| scene.materials[m as usize].emission.max_element() > 0.0).count();
    println!("{}: {} triangles ({} emissive), {:.1} MB", scene.name, scene.triangle_count(), emissive, bytes.len() as f64 / 1e6);
    println!("wrote {}\nrender it: vplgi render {}", out.display(), out.display());
    Ok(())
}
