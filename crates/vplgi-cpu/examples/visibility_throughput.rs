//! Shadow-ray throughput of the `visibility` stage against a bare loop of Embree occlusion
//! queries (`rtcOccluded1`) over the very same rays, on the built-in Cornell box.
//!
//! Rows are shading points of a 512x512 frame (every 32nd), columns the first 1,000 VPLs of a
//! 10,000-VPL set: 8,192 x 1,000 pairs like `--cluster both` at the paper's settings. Each
//! measurement is the median of 7 runs, taken in the same process.
//!
//! Run: `cargo run --release -p vplgi-cpu --example visibility_throughput`

use rayon::prelude::*;
use std::time::Instant;
use vplgi_cpu::visibility::{facing, visibility, Endpoint};
use vplgi_cpu::{CpuScene, NoProgress};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = vplgi_scene::cornell::cornell_box();
    let device = vplgi_embree::Device::new(None)?;
    let cs = CpuScene::new(&scene, &device)?;
    let sps = vplgi_cpu::shading_points::shading_points(&cs, 512, 512, 1, 1);
    let rows: Vec<Endpoint> = sps.iter().step_by(32).filter(|s| !s.is_miss()).map(Endpoint::of).collect();
    let vpls = vplgi_cpu::trace_vpls::trace_vpls(&cs, 1, 10_000, 3, &NoProgress).vpls;
    let cols: Vec<Endpoint> = vpls.iter().take(1000).map(|v| Endpoint { position: v.position.into(), normal: v.normal.into() }).collect();

    // The same rays the stage traces: facing pairs, both ends pushed off their surfaces.
    let rays: Vec<(glam::Vec3, glam::Vec3)> = rows
        .iter()
        .flat_map(|a| cols.iter().filter(move |b| facing(a, b)).map(move |b| (*a, *b)))
        .map(|(a, b)| {
            let p = cs.offset_toward(a.position, a.normal, b.position);
            let q = cs.offset_toward(b.position, b.normal, a.position);
            (p, q - p)
        })
        .collect();

    let mut stage = Vec::new();
    let mut raw = Vec::new();
    let mut traced = 0;
    let mut stage_visible = 0;
    let mut raw_visible = 0;
    for _ in 0..7 {
        let t = Instant::now();
        let (m, n) = visibility(&cs, &rows, &cols, &NoProgress);
        stage.push(t.elapsed().as_secs_f64());
        traced = n;
        stage_visible = m.count_ones();
        let t = Instant::now();
        raw_visible = rays.par_iter().filter(|(o, d)| !cs.rt.occluded(*o, *d, vplgi_cpu::SEGMENT_TNEAR, 1.0)).count() as u64;
        raw.push(t.elapsed().as_secs_f64());
    }
    assert_eq!(traced as usize, rays.len());
    assert_eq!(stage_visible, raw_visible, "the stage and the raw loop must see the same rays");
    let (s, r) = (median(stage), median(raw));
    println!("{} x {} pairs, {} rays traced ({} threads)", rows.len(), cols.len(), rays.len(), rayon::current_num_threads());
    println!("visibility stage: {:.1} ms, {:.2} Mrays/s", s * 1e3, rays.len() as f64 / s / 1e6);
    println!("raw rtcOccluded1: {:.1} ms, {:.2} Mrays/s", r * 1e3, rays.len() as f64 / r / 1e6);
    println!("stage / raw throughput: {:.1} %", 100.0 * r / s);
    Ok(())
}
