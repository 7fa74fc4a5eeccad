//! `vplgi compare`: image metrics and an error map.

use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct CompareArgs {
    /// The reference image (linear OpenEXR), e.g. a `--cluster none` render.
    reference: PathBuf,
    /// The image to evaluate (linear OpenEXR, same size).
    test: PathBuf,
    /// Where to write compare.json and error_map.png [default: the test image's directory]
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

pub fn run(args: CompareArgs) -> Result<()> {
    let reference = vplgi_image::read_exr(&args.reference)?;
    let test = vplgi_image::read_exr(&args.test)?;
    let cmp = vplgi_image::compare(&reference, &test).with_context(|| {
        format!("comparing {} with {}", args.test.display(), args.reference.display())
    })?;
    let out = match args.out {
        Some(d) => d,
        None => args
            .test
            .parent()
            .map(|p| if p.as_os_str().is_empty() { PathBuf::from(".") } else { p.to_path_buf() })
            .unwrap_or_else(|| PathBuf::from(".")),
    };
    std::fs::create_dir_all(&out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let m = cmp.metrics;
    let report = serde_json::json!({
        "reference": args.reference,
        "test": args.test,
        "width": cmp.width,
        "height": cmp.height,
        "mse": m.mse,
        "rel_mse": m.rel_mse,
        "flip": m.flip,
        "mean_ratio": m.mean_ratio,
        "flip_kind": "LDR-FLIP of both images tonemapped with exposure 1 (clamp, sRGB)",
        "rel_mse_epsilon": vplgi_image::REL_MSE_EPSILON,
    });
    let json_path = out.join("compare.json");
    crate::shared::write_json(&json_path, &report)?;
    let map_path = out.join("error_map.png");
    vplgi_image::write_error_map(&map_path, &cmp)?;
    println!("mse      {:.6e}\nrel_mse  {:.6e}\nflip     {:.6}", m.mse, m.rel_mse, m.flip);
    println!(
        "mean ratio (test / reference): R {:.5}, G {:.5}, B {:.5}",
        m.mean_ratio[0], m.mean_ratio[1], m.mean_ratio[2]
    );
    println!("wrote {} and {}", json_path.display(), map_path.display());
    Ok(())
}
