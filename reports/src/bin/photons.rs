//! `make photons`: Wang et al.'s Figure 6 ablation and the speed of the illumination cut against
//! per-hit density estimation, on the generated `cornell-glass` and `conference` scenes, on the
//! CPU, written to `docs/PHOTONS.md` (numbers in `docs/photons/photons.json`, pictures beside).
//!
//! Every image is the indirect light alone, ρ / π E at each pixel's shading point: the parts
//! compared change nothing else. Each comes from the same global photon map:
//!
//! - the reference gathers at every pixel with 1,024 rays, each hit lit by the density
//!   estimate of the full map (the paper's (e));
//! - **(a)** gathers at the shading-point clusters' representatives, each hit lit by the full
//!   map, and interpolates;
//! - **(c)** gathers at every pixel, each hit lit by the cut;
//! - **(a + c)** gathers at the representatives from the cut and interpolates: `--gi photon`.
//!
//! (c) and (a + c) at cuts of 1k to 16k nodes. The gathers of (a) and (a + c) differ only in
//! how a hit is lit, which is the speed the cut is for. Then the glossy last bounce on
//! `cornell-glossy`'s rough metals, against a gather from each pixel's own BSDF; and one
//! `--preset photon` frame of each
//! of Table 1's stand-ins at the paper's sizes, per stage, on the CPU and the GPU. About ten
//! minutes on 2 cores.

use anyhow::{Context, Result};
use clap::Parser;
use glam::Vec3;
use rayon::prelude::*;
use serde_json::{json, Value};
use std::f32::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vplgi_cpu::caustics::photon_map;
use vplgi_cpu::final_gather::{cut_irradiance, gather_all, HitLight};
use vplgi_cpu::illumination_cut::{cut_of, density};
use vplgi_cpu::interpolate::{interpolate, IrradianceSamples};
use vplgi_image::Image;
use vplgi_shared::bsdf::Transport;
use vplgi_shared::sh::glossy_irradiance;
use vplgi_types::interpolation::GatherParams;
use vplgi_types::{Endpoint, FrameConfig};
use vplgi_verify::inputs::{CpuClusters, CpuFrame};

#[derive(Parser)]
#[command(
    about = "Wang et al.'s Figure 6 ablation and the cut's speed on the generated scenes; writes docs/PHOTONS.md"
)]
struct Opts {
    /// The report; pictures and numbers go to photons/ beside it.
    #[arg(long, default_value = "docs/PHOTONS.md")]
    out: PathBuf,
    /// Small scenes, maps and images: a check that it runs, not the measurement.
    #[arg(long)]
    quick: bool,
    /// Rewrite the document from the numbers of the last run (photons/photons.json beside it),
    /// measuring nothing.
    #[arg(long)]
    markdown_only: bool,
}

/// Rays of the reference's gather (the paper's Figure 6 (e)).
const REFERENCE_RAYS: u32 = 1024;

/// The sizes of the run: (image width, photons, shading-point clusters, gather rays, reference
/// rays, cut sizes).
struct Sizes {
    width: u32,
    photons: u32,
    clusters: u32,
    rays: u32,
    reference_rays: u32,
    cuts: Vec<u32>,
}

/// The sizes of a run, or of a `--quick` run.
fn sizes(quick: bool) -> Sizes {
    if quick {
        Sizes {
            width: 32,
            photons: 20_000,
            clusters: 100,
            rays: 16,
            reference_rays: 64,
            cuts: vec![256, 1024],
        }
    } else {
        Sizes {
            width: 128,
            photons: 300_000,
            clusters: 4_000,
            rays: 256,
            reference_rays: REFERENCE_RAYS,
            cuts: vec![1024, 2048, 4096, 8192, 16384],
        }
    }
}

fn main() -> Result<()> {
    let o = Opts::parse();
    let docs = o.out.parent().map_or_else(|| PathBuf::from("photons"), |p| p.join("photons"));
    if o.markdown_only {
        let json = docs.join("photons.json");
        let report: Value = serde_json::from_slice(
            &std::fs::read(&json).with_context(|| format!("reading {}", json.display()))?,
        )
        .with_context(|| format!("{}: not the numbers of a run", json.display()))?;
        std::fs::write(&o.out, markdown(&report, &sizes(report["quick"].as_bool() == Some(true))))?;
        eprintln!("wrote {}", o.out.display());
        return Ok(());
    }
    let s = sizes(o.quick);
    std::fs::create_dir_all(&docs)?;
    let (date, commit) = vplgi_reports::date_and_commit()?;
    let device = vplgi_embree::Device::new(None).context("Embree")?;
    let mut scenes = Vec::new();
    // (scene, aspect), each at its paper size (`vplgi scene generate`'s default); the conference
    // room smaller under --quick.
    for (name, aspect) in [("cornell-glass", 1.0f32), ("conference", 180.0 / 256.0)] {
        eprintln!("{name}: generating");
        let scene = if o.quick && name == "conference" {
            vplgi_scene::generate::generate(name, 20_000).map_err(anyhow::Error::msg)?
        } else {
            generated(name)?
        };
        let cs = vplgi_cpu::CpuScene::new(&scene, &device).context("Embree scene")?;
        let cfg = FrameConfig {
            width: s.width,
            height: (s.width as f32 * aspect).round() as u32,
            vpls: 16,
            global_photons: s.photons,
            k_sp: s.clusters,
            gather_rays: s.rays,
            ..FrameConfig::photon()
        };
        scenes.push(ablation(name, &cs, &cfg, &s, &docs)?);
    }
    let glossy = glossy(&device, &s, &docs)?;
    let table1 = table1(&device, o.quick)?;
    let report = json!({
        "date": date, "commit": commit, "quick": o.quick, "cpu": cpu_model(),
        "threads": rayon::current_num_threads(), "scenes": scenes, "glossy": glossy, "table1": table1,
    });
    std::fs::write(docs.join("photons.json"), serde_json::to_string_pretty(&report)?)?;
    std::fs::write(&o.out, markdown(&report, &s))?;
    eprintln!("wrote {}", o.out.display());
    Ok(())
}

/// The indirect light of the frame's hits as an image (misses black).
fn image(cfg: &FrameConfig, frame: &CpuFrame, irradiance: &[Vec3]) -> Image {
    let mut img = Image::new(cfg.width, cfg.height);
    for (h, &s) in frame.hits.iter().enumerate() {
        let sp = &frame.sps[s as usize];
        img.pixels[sp.pixel as usize] = (Vec3::from(sp.albedo) / PI * irradiance[h]).to_array();
    }
    img
}

/// The interpolation of sample irradiance at every hit.
fn interpolated(
    frame: &CpuFrame,
    clusters: &CpuClusters,
    samples: &IrradianceSamples,
) -> Vec<Vec3> {
    let c = clusters.sp_clusters.as_ref().expect("clustered shading points");
    frame
        .hit_endpoints()
        .iter()
        .enumerate()
        .map(|(h, e)| interpolate(e.p(), e.n(), None, &c.labels[h * c.f..(h + 1) * c.f], samples))
        .collect()
}

/// One gather at each of `points` (sample point j drawing stream (seed, Gather, j)), each hit
/// lit by `light`; the irradiance and 1 / R per point, and the seconds it took.
/// A gather's samples, its seconds, and the share of its rays whose hit no kernel reached (lit
/// by the fallback's wider kernels).
struct Gathered {
    samples: IrradianceSamples,
    seconds: f64,
    fallback: f64,
}

fn gather(
    cs: &vplgi_cpu::CpuScene,
    points: &[Endpoint],
    params: &GatherParams,
    light: &(dyn Fn(Vec3, Vec3) -> HitLight + Sync),
) -> Gathered {
    let clock = Instant::now();
    let (samples, counts) = gather_all(cs, points.to_vec(), params, light);
    let seconds = clock.elapsed().as_secs_f64();
    let fallback =
        counts.fallback as f64 / (points.len().max(1) as f64 * params.rays.max(1) as f64);
    Gathered { samples, seconds, fallback }
}

/// relMSE against the reference over all pixels and over the darkest tenth of the reference's
/// lit pixels, and the light kept (the mean of the three channels' sums against the
/// reference's).
fn errors(reference: &Image, test: &Image) -> Result<(f64, f64, f64)> {
    let m = vplgi_image::compare(reference, test)?.metrics;
    let (all, kept) = (m.rel_mse, m.mean_ratio.iter().sum::<f64>() / 3.0);
    let brightness = |p: &[f32; 3]| p[0] + p[1] + p[2];
    let mut lit: Vec<usize> =
        (0..reference.pixels.len()).filter(|&i| brightness(&reference.pixels[i]) > 0.0).collect();
    lit.sort_by(|&a, &b| {
        brightness(&reference.pixels[a]).total_cmp(&brightness(&reference.pixels[b]))
    });
    let dark = &lit[..(lit.len() / 10).max(1)];
    let pick = |img: &Image| Image {
        width: dark.len() as u32,
        height: 1,
        pixels: dark.iter().map(|&i| img.pixels[i]).collect(),
    };
    let dark = vplgi_image::compare(&pick(reference), &pick(test))?.metrics.rel_mse;
    Ok((all, dark, kept))
}

fn ablation(
    name: &str,
    cs: &vplgi_cpu::CpuScene,
    cfg: &FrameConfig,
    s: &Sizes,
    docs: &Path,
) -> Result<Value> {
    eprintln!("{name}: {} photons", s.photons);
    let clock = Instant::now();
    let photons =
        vplgi_cpu::trace_vpls::trace_vpls(cs, &cfg.global_trace_params(), &vplgi_cpu::NoProgress)
            .vpls;
    let map = photon_map(&photons, cfg.photon_leaf);
    let trace_s = clock.elapsed().as_secs_f64();
    let frame = CpuFrame::new(cs, cfg);
    let clusters = CpuClusters::new(cs, &frame, cfg);
    let hits = frame.hit_endpoints();
    let params = cfg.cut_params(cs.extent);
    let knn = |y: Vec3, n: Vec3| {
        let (irradiance, truncated) = density(&map, y, n, &params);
        HitLight { irradiance, fallback: false, truncated }
    };
    let rays = cfg.gather_params();
    // A seed of its own: the reference's rays are not the tested gathers' rays.
    let reference_rays = GatherParams { seed: rays.seed ^ 0x5eed, rays: s.reference_rays };
    eprintln!("{name}: the reference ({} rays at {} pixels)", s.reference_rays, hits.len());
    let g = gather(cs, &hits, &reference_rays, &knn);
    let reference_s = g.seconds;
    let reference = image(
        cfg,
        &frame,
        &g.samples.irradiance.iter().map(|&e| Vec3::from(e)).collect::<Vec<_>>(),
    );
    save(docs, name, "reference", &reference)?;
    eprintln!("{name}: (a) at {} representatives", clusters.rows.len());
    let a = gather(cs, &clusters.rows, &rays, &knn);
    let a_img = image(cfg, &frame, &interpolated(&frame, &clusters, &a.samples));
    save(docs, name, "a", &a_img)?;
    let judged = |img: &Image, g: &Gathered| -> Result<Value> {
        let (rel_mse, dark, kept) = errors(&reference, img)?;
        Ok(
            json!({"rel_mse": rel_mse, "dark_rel_mse": dark, "kept": kept, "fallback": g.fallback, "gather_s": g.seconds}),
        )
    };
    let a_row = judged(&a_img, &a)?;
    let mut cuts = Vec::new();
    for &size in &s.cuts {
        eprintln!("{name}: cut {size}");
        let clock = Instant::now();
        let cut = cut_of(&map, &vplgi_types::CutParams { size, ..params });
        let cut_s = clock.elapsed().as_secs_f64();
        let lookup = |y: Vec3, n: Vec3| cut_irradiance(&cut, y, n);
        let c = gather(cs, &hits, &rays, &lookup);
        let c_img = image(
            cfg,
            &frame,
            &c.samples.irradiance.iter().map(|&e| Vec3::from(e)).collect::<Vec<_>>(),
        );
        let ac = gather(cs, &clusters.rows, &rays, &lookup);
        let ac_img = image(cfg, &frame, &interpolated(&frame, &clusters, &ac.samples));
        if size == 4096 || s.cuts.len() < 5 && size == s.cuts[s.cuts.len() - 1] {
            save(docs, name, "c", &c_img)?;
            save(docs, name, "a-c", &ac_img)?;
        }
        cuts.push(json!({
            "target": size, "nodes": cut.nodes.len(), "coarse": cut.stats.coarse, "cut_s": cut_s,
            "c": judged(&c_img, &c)?, "a_c": judged(&ac_img, &ac)?,
        }));
    }
    Ok(json!({
        "scene": name, "triangles": cs.scene.triangle_count(), "width": cfg.width, "height": cfg.height,
        "photons": map.photons.len(), "trace_s": trace_s, "representatives": clusters.rows.len(), "rays": rays.rays,
        "reference_rays": s.reference_rays, "reference_s": reference_s,
        "a": a_row,
        "cuts": cuts,
    }))
}

/// The glossy last bounce on `cornell-glossy`: the indirect light of every shading point on
/// rough metal, against a reference that gathers at each with `reference_rays` rays drawn from
/// its own BSDF, each hit lit by the density estimate of the full map. Four ways to get it:
/// `--gi photon`'s (the cut's gather at the representatives, spherical harmonics interpolated
/// and integrated against the lobe); the same harmonics gathered at every glossy pixel from the
/// full map, which leaves only the order-4 truncation; `--gi photon`'s with the full map in
/// place of the cut, which separates the cut's error; and the interpolated irradiance as if
/// the metal were diffuse, what the frame would do without the harmonics. Per material, so each
/// roughness shows what order 4 holds.
fn glossy(device: &vplgi_embree::Device, s: &Sizes, docs: &Path) -> Result<Value> {
    let name = "cornell-glossy";
    eprintln!("{name}: the glossy last bounce");
    let scene = generated(name)?;
    let cs = vplgi_cpu::CpuScene::new(&scene, device).context("Embree scene")?;
    let cfg = FrameConfig {
        width: s.width,
        height: s.width,
        vpls: 16,
        global_photons: s.photons,
        k_sp: s.clusters,
        gather_rays: s.rays,
        ..FrameConfig::photon()
    };
    let photons =
        vplgi_cpu::trace_vpls::trace_vpls(&cs, &cfg.global_trace_params(), &vplgi_cpu::NoProgress)
            .vpls;
    let map = photon_map(&photons, cfg.photon_leaf);
    let params = cfg.cut_params(cs.extent);
    let cut = cut_of(&map, &params);
    let frame = CpuFrame::new(&cs, &cfg);
    let clusters = CpuClusters::new(&cs, &frame, &cfg);
    let c = clusters.sp_clusters.as_ref().context("clustered shading points")?;
    let materials = &cs.scene.materials;
    // The hits on rough metal: (hit, its shading point, its surface and view).
    let glossy: Vec<(usize, &vplgi_types::ShadingPoint)> = frame
        .hits
        .iter()
        .enumerate()
        .map(|(h, &i)| (h, &frame.sps[i as usize]))
        .filter(|(_, sp)| materials[sp.material as usize].surface.is_glossy())
        .collect();
    let knn = |y: Vec3, n: Vec3| {
        let (irradiance, truncated) = density(&map, y, n, &params);
        HitLight { irradiance, fallback: false, truncated }
    };
    eprintln!(
        "{name}: the reference ({} BSDF rays at {} glossy pixels)",
        s.reference_rays,
        glossy.len()
    );
    let clock = Instant::now();
    let reference: Vec<Vec3> = glossy
        .par_iter()
        .map(|&(h, sp)| {
            let (p, n, view) =
                (Vec3::from(sp.position), Vec3::from(sp.normal), Vec3::from(sp.view));
            let white = materials[sp.material as usize].surface.with_colour(Vec3::ONE);
            let mut rng =
                vplgi_types::Rng::new(cfg.seed ^ 0x9105, vplgi_types::Stream::Oracle, h as u32);
            let mut sum = Vec3::ZERO;
            for _ in 0..s.reference_rays {
                let (u1, u) = (rng.next_f32(), glam::Vec2::new(rng.next_f32(), rng.next_f32()));
                let Some(b) = white.sample_about(n, view, u1, u, Transport::Radiance) else {
                    continue;
                };
                let Some(hit) = cs.trace_beyond(p + n * cs.eps, b.wo, cs.eps) else { continue };
                if !hit.surface.is_specular() {
                    sum += b.weight * hit.albedo * knn(hit.position, hit.ns).irradiance;
                }
            }
            sum / s.reference_rays as f32
        })
        .collect();
    let reference_s = clock.elapsed().as_secs_f64();
    let lookup = |y: Vec3, n: Vec3| cut_irradiance(&cut, y, n);
    let rays = cfg.gather_params();
    let samples = gather(&cs, &clusters.rows, &rays, &lookup).samples;
    let full_map = gather(&cs, &clusters.rows, &rays, &knn).samples;
    let at = |h: usize| &c.labels[h * c.f..(h + 1) * c.f];
    let interpolated = |samples: &IrradianceSamples, with_sh: bool| -> Vec<Vec3> {
        glossy
            .iter()
            .map(|&(h, sp)| {
                let receiver = vplgi_cpu::shade::receiver(materials, sp).filter(|_| with_sh);
                interpolate(sp.position.into(), sp.normal.into(), receiver, at(h), samples)
            })
            .collect()
    };
    let (photon, as_diffuse) = (interpolated(&samples, true), interpolated(&samples, false));
    let photon_full_map = interpolated(&full_map, true);
    eprintln!("{name}: harmonics at every glossy pixel");
    let points: Vec<Endpoint> =
        glossy.iter().map(|(_, sp)| Endpoint::new(sp.position.into(), sp.normal.into())).collect();
    let each = gather(&cs, &points, &rays, &knn).samples;
    let per_pixel: Vec<Vec3> = glossy
        .iter()
        .enumerate()
        .map(|(j, (_, sp))| {
            let surface = materials[sp.material as usize].surface;
            glossy_irradiance(
                &each.sh[j],
                each.irradiance[j].into(),
                surface,
                sp.normal.into(),
                sp.view.into(),
            )
        })
        .collect();
    // Images of the glossy pixels (the rest black), and the numbers per material.
    let picture = |e: &[Vec3]| {
        let mut img = Image::new(cfg.width, cfg.height);
        for (&(_, sp), e) in glossy.iter().zip(e) {
            img.pixels[sp.pixel as usize] = (Vec3::from(sp.albedo) / PI * *e).to_array();
        }
        img
    };
    for (what, e) in [
        ("reference", &reference),
        ("photon", &photon),
        ("full-map", &photon_full_map),
        ("per-pixel", &per_pixel),
        ("as-diffuse", &as_diffuse),
    ] {
        save(docs, "glossy", what, &picture(e))?;
    }
    let mut rows = Vec::new();
    for (m, material) in materials.iter().enumerate().filter(|(_, m)| m.surface.is_glossy()) {
        let mine: Vec<usize> =
            (0..glossy.len()).filter(|&j| glossy[j].1.material as usize == m).collect();
        if mine.is_empty() {
            continue;
        }
        let pick = |e: &[Vec3]| Image {
            width: mine.len() as u32,
            height: 1,
            pixels: mine
                .iter()
                .map(|&j| (Vec3::from(glossy[j].1.albedo) / PI * e[j]).to_array())
                .collect(),
        };
        let r = pick(&reference);
        let judged = |e: &[Vec3]| -> Result<Value> {
            let m = vplgi_image::compare(&r, &pick(e))?.metrics;
            Ok(json!({"rel_mse": m.rel_mse, "ratio": m.mean_ratio.iter().sum::<f64>() / 3.0}))
        };
        rows.push(json!({
            "material": material.name, "surface": material.surface.describe(), "pixels": mine.len(),
            "photon": judged(&photon)?, "full_map": judged(&photon_full_map)?, "per_pixel": judged(&per_pixel)?,
            "as_diffuse": judged(&as_diffuse)?,
        }));
    }
    Ok(json!({
        "scene": name, "width": cfg.width, "height": cfg.height, "photons": map.photons.len(), "cut": cut.nodes.len(),
        "representatives": clusters.rows.len(), "rays": rays.rays, "reference_rays": s.reference_rays,
        "reference_s": reference_s, "glossy_pixels": glossy.len(), "materials": rows,
    }))
}

fn save(docs: &Path, scene: &str, what: &str, img: &Image) -> Result<()> {
    vplgi_image::write_png(&docs.join(format!("{scene}-{what}.png")), img, 4.0)
        .with_context(|| format!("writing {scene}-{what}.png"))
}

/// Generated scene `name` at its paper size, as `vplgi scene generate` makes it by default.
fn generated(name: &str) -> Result<vplgi_scene::Scene> {
    let size =
        vplgi_scene::generate::GENERATORS.iter().find(|g| g.0 == name).map_or(300_000, |g| g.1);
    vplgi_scene::generate::generate(name, size).map_err(anyhow::Error::msg)
}

/// Wang et al.'s Table 1 stand-ins: (scene, global photons, caustic photons, shading-point
/// clusters, cut, the paper's frames per second on a GTX 280). `cornell-glossy` stands for the
/// glossy elephant (its rough metals take the glossy last bounce; it has no mirror, so its
/// caustic map stays empty).
const TABLE1: [(&str, u32, u32, u32, u32, f64); 4] = [
    ("cornell-glass", 239_000, 100_000, 1_600, 4096, 4.2),
    ("cornell-water", 268_000, 277_000, 1_800, 8192, 2.7),
    ("cornell-glossy", 256_000, 24_000, 3_000, 4096, 3.1),
    ("cornell-mirrors", 290_000, 107_000, 4_000, 4096, 2.5),
];

/// One `--preset photon` frame of each Table 1 stand-in at the paper's sizes (512², its photon
/// counts, clusters and cut), on the CPU and on the GPU (lavapipe here) where an adapter is:
/// each stage's milliseconds.
fn table1(device: &vplgi_embree::Device, quick: bool) -> Result<Value> {
    let gpu = vplgi_gpu::GpuContext::new().ok();
    let kernels = match &gpu {
        Some(ctx) => Some(vplgi_gpu::GpuKernels::new(&ctx.device)?),
        None => None,
    };
    let mut rows = Vec::new();
    for (name, global, caustic, clusters, cut, fps) in TABLE1 {
        eprintln!("{name}: Table 1 frame");
        let scene = generated(name)?;
        let cfg = if quick {
            FrameConfig {
                width: 48,
                height: 48,
                global_photons: 5_000,
                caustic_photons: 2_000,
                k_sp: 100,
                cut_size: 256,
                gather_rays: 16,
                ..FrameConfig::photon()
            }
        } else {
            FrameConfig {
                width: 512,
                height: 512,
                global_photons: global,
                caustic_photons: caustic,
                k_sp: clusters,
                cut_size: cut,
                ..FrameConfig::photon()
            }
        };
        let stages = |t: &vplgi_frame::StageTimings| -> Value {
            let mut m = serde_json::Map::new();
            for (stage, ms) in t.iter().filter(|s| s.1 > 0.0) {
                m.insert(stage.name().into(), json!(ms));
            }
            m.insert("total".into(), json!(t.total()));
            Value::Object(m)
        };
        let cs = vplgi_cpu::CpuScene::new(&scene, device).context("Embree scene")?;
        let cpu = vplgi_frame::render(&cs, &cfg, &vplgi_frame::NoProgress)?;
        let on_gpu = match (&gpu, &kernels) {
            (Some(ctx), Some(k)) => {
                let gb = vplgi_gpu::GpuBackend::new(&ctx.device, &ctx.queue, k, &scene)?;
                Some(stages(&vplgi_frame::render(&gb, &cfg, &vplgi_frame::NoProgress)?.timings))
            }
            _ => None,
        };
        rows.push(json!({
            "scene": name, "triangles": scene.triangle_count(), "width": cfg.width, "height": cfg.height,
            "global_photons": cpu.stats.global_photons, "caustic_photons": cpu.stats.caustic_photons,
            "clusters": cpu.stats.sp_clusters, "cut": cpu.stats.cut_size, "paper_fps": fps,
            "cpu": stages(&cpu.timings), "gpu": on_gpu,
        }));
    }
    Ok(json!({"adapter": gpu.as_ref().map(|g| g.describe()), "rows": rows}))
}

/// The machine's CPU model, as /proc/cpuinfo names it.
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

fn markdown(r: &Value, s: &Sizes) -> String {
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# The photon pipeline: Wang et al.'s Figure 6 ablation and the cut's speed\n"
    );
    let _ = writeln!(
        md,
        "{} Every number is the CPU reference's (rayon and Embree) on {} with {} threads, but for the GPU rows of Table 1 (last section), which name their adapter.\n",
        vplgi_reports::generated_by("photons", r, "measurement"),
        r["cpu"].as_str().unwrap_or("?"),
        r["threads"]
    );
    let _ = writeln!(
        md,
        "Wang et al. (section 3) light the final gather's hits from an illumination cut of the global photon map instead of a \
         density estimate of the map at every hit, and gather only at the shading-point clusters' representatives, \
         interpolating between them. Their Figure 6 shows what each costs in error; this is that ablation on vplgi's generated \
         scenes. Every image is the **indirect light alone** (ρ / π E at each pixel's shading point, {w} pixels wide), from one \
         global map of {p} photons per scene:\n\n\
         - **reference**: a gather of {rr} rays at every pixel, each hit lit by the density estimate of the full map (the \
         `--photon-k` nearest photons), the paper's (e);\n\
         - **(a)**: {rays} rays at each of {k} clusters' representatives, each hit lit by the full map, interpolated;\n\
         - **(c)**: {rays} rays at every pixel, each hit lit by the cut;\n\
         - **(a + c)**: {rays} rays at the representatives, lit by the cut, interpolated: what `--gi photon` renders.\n\n\
         relMSE is against the reference (ε = 0.01, as everywhere in vplgi); *dark* is the relMSE of the darkest tenth of the \
         reference's lit pixels, where the paper saw its errors; *light kept* is the image's sum against the reference's. \
         Gather times are the gathers alone, on the same rays. A cut is asked for by its target size (E_min at that level of \
         the tree); its coarse cut and the cut after `--cut-refinements` passes are what the refinement made of it. A gather \
         hit beyond every Eq. 4 kernel is lit by kernels twice as wide (the share of such hits is given).\n",
        w = s.width,
        p = s.photons,
        rr = s.reference_rays,
        rays = s.rays,
        k = s.clusters
    );
    for sc in r["scenes"].as_array().cloned().unwrap_or_default() {
        let name = sc["scene"].as_str().unwrap_or("?");
        let _ = writeln!(
            md,
            "## {name}\n\n{} triangles, {}x{}, {} photons (traced in {:.1} s), {} representatives; the reference took {:.0} s.\n",
            sc["triangles"], sc["width"], sc["height"], sc["photons"], f(&sc["trace_s"]), sc["representatives"], f(&sc["reference_s"])
        );
        let cuts = sc["cuts"].as_array().cloned().unwrap_or_default();
        let row = |label: String, v: &Value| {
            format!(
                "| {label} | {:.3e} | {:.3e} | {:.4} | {:.2} % | {:.2} |",
                f(&v["rel_mse"]),
                f(&v["dark_rel_mse"]),
                f(&v["kept"]),
                100.0 * f(&v["fallback"]),
                f(&v["gather_s"])
            )
        };
        let head = "| relMSE | dark relMSE | light kept | hits beyond every kernel | gather s |\n|---|---:|---:|---:|---:|---:|";
        let _ = writeln!(
            md,
            "Gathering at every pixel from the cut, (c):\n\n| cut: target, coarse, refined {head}"
        );
        for c in &cuts {
            let _ = writeln!(
                md,
                "{}",
                row(format!("{}, {}, {}", c["target"], c["coarse"], c["nodes"]), &c["c"])
            );
        }
        let _ = writeln!(md, "\nGathering at the representatives and interpolating, (a) from the full map and (a + c) from the cut:\n\n| lit by {head}");
        let a = &sc["a"];
        let _ = writeln!(md, "{}", row("(a): the full map".into(), a));
        for c in &cuts {
            let _ =
                writeln!(md, "{}", row(format!("(a + c): the cut of {}", c["target"]), &c["a_c"]));
        }
        // Over the refined cuts in order of size: two targets may refine to cuts of either order.
        let falls = |key: &str| {
            let mut by_size: Vec<&Value> = cuts.iter().collect();
            by_size.sort_by_key(|c| c["nodes"].as_u64().unwrap_or(0));
            by_size.windows(2).all(|w| f(&w[1][key]["rel_mse"]) <= f(&w[0][key]["rel_mse"]))
        };
        let _ = writeln!(
            md,
            "\nAs the refined cut grows, (c)'s relMSE {} and (a + c)'s {}.",
            if falls("c") { "falls at every step" } else { "does **not** fall at every step" },
            if falls("a_c") { "falls at every step" } else { "does **not** fall at every step" }
        );
        // The comparison: the cut's gather against a density estimate at every hit, at
        // equal error (within 10 %): the smallest cut whose (a + c) error is that close to (a)'s.
        let equal = cuts.iter().find(|c| f(&c["a_c"]["rel_mse"]) <= 1.1 * f(&a["rel_mse"]));
        match equal {
            Some(at) => {
                let _ = writeln!(
                    md,
                    "The smallest cut within 10 % of (a)'s relMSE is the {}-node target ({} nodes, {:.3}x (a)'s relMSE): there, \
                     gathering from the cut is **{:.1}x** as fast as a density estimate at every hit (the issue's target: at least 5x).",
                    at["target"],
                    at["nodes"],
                    f(&at["a_c"]["rel_mse"]) / f(&a["rel_mse"]),
                    f(&a["gather_s"]) / f(&at["a_c"]["gather_s"])
                );
            }
            None => {
                let last = cuts.last().unwrap_or(&Value::Null);
                let _ = writeln!(
                    md,
                    "**No cut here comes within 10 % of (a)'s relMSE**: the largest ({} nodes) has {:.2}x it, and gathers {:.1}x as \
                     fast as a density estimate at every hit.",
                    last["nodes"],
                    f(&last["a_c"]["rel_mse"]) / f(&a["rel_mse"]),
                    f(&a["gather_s"]) / f(&last["a_c"]["gather_s"])
                );
            }
        }
        let _ = writeln!(
            md,
            "\n| reference | (a) | (c), 4k cut | (a + c), 4k cut |\n|---|---|---|---|\n| ![](photons/{name}-reference.png) | ![](photons/{name}-a.png) | ![](photons/{name}-c.png) | ![](photons/{name}-a-c.png) |\n"
        );
    }
    let g = &r["glossy"];
    let _ = writeln!(
        md,
        "## The glossy last bounce\n\n`cornell-glossy` ({}x{}, {} photons, a cut of {} nodes, {} representatives with {} rays each): the \
         indirect light of the {} pixels on rough metal (ρ / π times what `interpolate` gives a glossy receiver). The reference \
         gathers at each with {} rays drawn from the pixel's own BSDF, each hit lit by the density estimate of the full map ({:.0} s). \
         **photon** is `--gi photon`'s: order-4 spherical harmonics gathered at the representatives from the cut, interpolated and \
         integrated against the lobe; **full map** is the same with each gather hit lit by the full map's density estimate \
         instead of the cut, which leaves the interpolation and the truncation; **per pixel** gathers the harmonics at every \
         glossy pixel from the full map, so only the order-4 truncation is left; **as diffuse** interpolates the irradiance as for a Lambertian surface, what the frame would \
         do without the harmonics. *Ratio* is the mean over the reference's (the mean of the channels).\n",
        g["width"], g["height"], g["photons"], g["cut"], g["representatives"], g["rays"], g["glossy_pixels"], g["reference_rays"],
        f(&g["reference_s"])
    );
    let _ = writeln!(md, "| material | pixels | photon: ratio | relMSE | full map: ratio | relMSE | per pixel: ratio | relMSE | as diffuse: ratio | relMSE |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for m in g["materials"].as_array().cloned().unwrap_or_default() {
        let _ = write!(
            md,
            "| {} ({}) | {} |",
            m["material"].as_str().unwrap_or("?"),
            m["surface"].as_str().unwrap_or("?"),
            m["pixels"]
        );
        for k in ["photon", "full_map", "per_pixel", "as_diffuse"] {
            let _ = write!(md, " {:.3} | {:.3e} |", f(&m[k]["ratio"]), f(&m[k]["rel_mse"]));
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(
        md,
        "\n| reference | photon | full map | per pixel | as diffuse |\n|---|---|---|---|---|\n| ![](photons/glossy-reference.png) | ![](photons/glossy-photon.png) | ![](photons/glossy-full-map.png) | ![](photons/glossy-per-pixel.png) | ![](photons/glossy-as-diffuse.png) |\n"
    );
    let t = &r["table1"];
    let adapter = t["adapter"].as_str().unwrap_or("no GPU adapter");
    let software = if adapter.contains("llvmpipe") {
        " (lavapipe: Mesa's software Vulkan, on the same CPU cores)"
    } else {
        ""
    };
    let _ = writeln!(
        md,
        "## The paper's Table 1, per stage\n\nOne `--preset photon` frame of each stand-in at Table 1's sizes (512², one sample per pixel where the \
         paper supersamples 1024²; its photon counts, shading-point clusters and cut target), on the CPU and on the GPU: **{adapter}**{software}. \
         Milliseconds per stage (tracing counts both maps' photons; `illumination_cut` the tree and the cut); the paper's frame \
         rates (GTX 280) are context, not a target for a software rasteriser.\n"
    );
    let rows = t["rows"].as_array().cloned().unwrap_or_default();
    let stage_names: Vec<String> = vplgi_frame::Stage::ALL
        .iter()
        .map(|s| s.name().to_string())
        .filter(|n| rows.iter().any(|r| r["cpu"].get(n).is_some() || r["gpu"].get(n).is_some()))
        .collect();
    let _ =
        write!(md, "| scene | triangles | photons (global / caustic) | clusters | cut | backend |");
    for n in &stage_names {
        let _ = write!(md, " {n} |");
    }
    let _ = writeln!(md, " total | fps | paper's fps |");
    let _ = writeln!(
        md,
        "|---|---:|---:|---:|---:|---|{}---:|---:|---:|",
        "---:|".repeat(stage_names.len())
    );
    for row in &rows {
        for backend in ["cpu", "gpu"] {
            let times = &row[backend];
            if times.is_null() {
                continue;
            }
            let _ = write!(
                md,
                "| {} | {} | {} / {} | {} | {} | {backend} |",
                row["scene"].as_str().unwrap_or("?"),
                row["triangles"],
                row["global_photons"],
                row["caustic_photons"],
                row["clusters"],
                row["cut"]
            );
            for n in &stage_names {
                let _ = write!(md, " {:.0} |", times[n.as_str()].as_f64().unwrap_or(0.0));
            }
            let total = f(&times["total"]);
            let _ = writeln!(md, " {total:.0} | {:.2} | {} |", 1e3 / total, row["paper_fps"]);
        }
    }
    md
}
