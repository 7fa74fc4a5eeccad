//! One frame of the CPU reference: the five stages chained, timed, with progress reporting.

use crate::cluster::{cluster, Clustering};
use crate::shade::{shade, VisibilitySource, VplLight};
use crate::shading_points::{shading_points, shading_points_of};
use crate::trace_vpls::trace_vpls;
use crate::visibility::{visibility, Endpoint};
use crate::CpuScene;
use glam::Vec3;
use serde::Serialize;
use std::time::Instant;
pub use vplgi_types::StageTimings;
use vplgi_types::{FrameConfig, MISS};

/// Progress of long stages. Implementations must be cheap and thread-safe: `inc` is called from
/// rayon workers.
pub trait Progress: Sync {
    fn start(&self, _stage: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn set(&self, _done: u64) {}
    fn finish(&self) {}
}

/// Reports nothing.
pub struct NoProgress;
impl Progress for NoProgress {}

/// Counts that describe what a frame did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub vpls: usize,
    pub light_particles: u32,
    pub vpl_clusters: usize,
    pub shading_points: usize,
    pub shading_point_hits: usize,
    pub sp_clusters: usize,
    /// Shading points whose 27-cell neighbourhood had no compatible centroid.
    pub sp_widened: usize,
    pub vpl_widened: usize,
    pub visibility_rays: u64,
    /// Shadow rays per second inside `visibility` (millions).
    pub visibility_mrays_per_s: f64,
    /// The geometry-term clamp: G <= 1 / d_min², d_min = g_clamp_rel * scene extent.
    pub g_clamp_d_min: f32,
    pub scene_extent: f32,
}

/// A rendered frame: linear RGB, row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
    pub timings: StageTimings,
    pub stats: FrameStats,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Lights for indirect shading: one per VPL cluster (at its representative, with the summed
/// flux of its members), or one per VPL.
pub fn vpl_lights(vpls: &[vplgi_types::Vpl], clusters: Option<&Clustering>) -> Vec<VplLight> {
    match clusters {
        None => vpls.iter().map(|v| VplLight { position: v.position.into(), normal: v.normal.into(), flux: v.flux.into() }).collect(),
        Some(c) => {
            // Sequential sum in VPL order: deterministic.
            let mut flux = vec![Vec3::ZERO; c.k()];
            for (i, v) in vpls.iter().enumerate() {
                flux[c.hard_label(i) as usize] += Vec3::from(v.flux);
            }
            c.representatives
                .iter()
                .zip(flux)
                .map(|(&r, flux)| {
                    let v = &vpls[r as usize];
                    VplLight { position: v.position.into(), normal: v.normal.into(), flux }
                })
                .collect()
        }
    }
}

/// Rows of the visibility matrix shaded at once when shading points are not clustered: bounds
/// the matrix to 64 MiB whatever the image size.
const ROW_CHUNK_BITS: usize = 64 << 23;

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("invalid parameters: {0}")]
    InvalidConfig(String),
}

/// Renders one frame with the CPU reference.
pub fn render(cs: &CpuScene, cfg: &FrameConfig, progress: &dyn Progress) -> Result<Frame, RenderError> {
    render_rows(cs, cfg, 0..cfg.height, progress)
}

/// Renders image rows `rows` of an unclustered frame (`--cluster none`): each pixel bit-identical
/// to the whole frame's, since without clustering a pixel depends only on the VPLs (traced in
/// full) and its own samples. The frame holds the rows only. This is how a reference is cut into
/// tiles; clustered frames cannot be (their clusters depend on the whole image).
pub fn render_rows(cs: &CpuScene, cfg: &FrameConfig, rows: std::ops::Range<u32>, progress: &dyn Progress) -> Result<Frame, RenderError> {
    cfg.validate().map_err(RenderError::InvalidConfig)?;
    if rows.start >= rows.end || rows.end > cfg.height {
        return Err(RenderError::InvalidConfig(format!("rows {}..{} of a {}-row image", rows.start, rows.end, cfg.height)));
    }
    let tile = rows.start > 0 || rows.end < cfg.height;
    if tile && cfg.cluster != vplgi_types::ClusterMode::None {
        return Err(RenderError::InvalidConfig("only unclustered frames (--cluster none) can be rendered in tiles".into()));
    }
    let mut t = StageTimings::default();
    let mut stats = FrameStats { scene_extent: cs.extent, ..Default::default() };

    let t0 = Instant::now();
    let vset = trace_vpls(cs, cfg.seed, cfg.vpls, cfg.bounces, progress);
    t.trace_vpls = ms(t0);
    stats.vpls = vset.vpls.len();
    stats.light_particles = vset.particles;

    let t0 = Instant::now();
    progress.start("shading_points", 1);
    // Samples outside the rows stay misses: indices stay global (the RNG streams use them).
    let (px0, px1) = ((rows.start * cfg.width) as usize, (rows.end * cfg.width) as usize);
    let spp = cfg.spp as usize;
    let sps = if tile {
        let mut all = vec![vplgi_types::ShadingPoint { triangle: MISS, ..Default::default() }; (cfg.width * cfg.height) as usize * spp];
        let part = shading_points_of(cs, cfg.width, cfg.height, cfg.spp, cfg.seed, (px0 * spp) as u32..(px1 * spp) as u32);
        all[px0 * spp..px1 * spp].copy_from_slice(&part);
        all
    } else {
        shading_points(cs, cfg.width, cfg.height, cfg.spp, cfg.seed)
    };
    progress.finish();
    t.shading_points = ms(t0);
    stats.shading_points = sps.len();

    // Only surface hits take part in clustering, visibility and shading.
    let hits: Vec<u32> = (0..sps.len() as u32).filter(|&i| sps[i as usize].triangle != MISS).collect();
    let mut row_of = vec![MISS; sps.len()];
    for (r, &i) in hits.iter().enumerate() {
        row_of[i as usize] = r as u32;
    }
    stats.shading_point_hits = hits.len();

    let t0 = Instant::now();
    progress.start("cluster", 1);
    let vpl_clusters = cfg.cluster.clusters_vpls().then(|| {
        let pos: Vec<Vec3> = vset.vpls.iter().map(|v| v.position.into()).collect();
        let nor: Vec<Vec3> = vset.vpls.iter().map(|v| v.normal.into()).collect();
        cluster(&pos, &nor, &cfg.vpl_cluster_params())
    });
    let sp_clusters = cfg.cluster.clusters_sps().then(|| {
        let pos: Vec<Vec3> = hits.iter().map(|&i| sps[i as usize].position.into()).collect();
        let nor: Vec<Vec3> = hits.iter().map(|&i| sps[i as usize].normal.into()).collect();
        cluster(&pos, &nor, &cfg.sp_cluster_params())
    });
    let lights = vpl_lights(&vset.vpls, vpl_clusters.as_ref());
    progress.finish();
    t.cluster = ms(t0);
    stats.vpl_clusters = vpl_clusters.as_ref().map_or(0, |c| c.k());
    stats.vpl_widened = vpl_clusters.as_ref().map_or(0, |c| c.widened);
    stats.sp_clusters = sp_clusters.as_ref().map_or(0, |c| c.k());
    stats.sp_widened = sp_clusters.as_ref().map_or(0, |c| c.widened);

    let d_min = cfg.g_clamp_rel * cs.extent;
    stats.g_clamp_d_min = d_min;
    let g_max = if d_min > 0.0 { 1.0 / (d_min * d_min) } else { f32::INFINITY };
    let cols: Vec<Endpoint> = lights.iter().map(|l| l.endpoint()).collect();
    let n_pixels = (cfg.width * cfg.height) as usize;
    let mut pixels = Vec::with_capacity(px1 - px0);
    let mut vis_ms = 0.0;
    let mut shade_ms = 0.0;

    match &sp_clusters {
        Some(c) => {
            let rows: Vec<Endpoint> = c.representatives.iter().map(|&r| Endpoint::of(&sps[hits[r as usize] as usize])).collect();
            let t0 = Instant::now();
            let (matrix, rays) = visibility(cs, &rows, &cols, progress);
            vis_ms += ms(t0);
            stats.visibility_rays += rays;
            let t0 = Instant::now();
            let src = VisibilitySource::Fuzzy { matrix: &matrix, row_of: &row_of, labels: &c.labels, weights: &c.weights, f: c.f };
            progress.start("shade", 1);
            pixels = shade(cs, &sps, cfg.spp, 0..n_pixels, &lights, &src, g_max, cfg.seed, cfg.direct_samples);
            progress.finish();
            shade_ms += ms(t0);
        }
        None => {
            // Each shading point is its own row: visibility and shading proceed in pixel chunks
            // so the matrix stays small.
            let px_chunk = (ROW_CHUNK_BITS / cols.len().max(64) / spp).max(1);
            let mut px = px0;
            while px < px1 {
                let end = (px + px_chunk).min(px1);
                let chunk_hits: Vec<u32> = (px * spp..end * spp).filter(|&i| row_of[i] != MISS).map(|i| i as u32).collect();
                let first_row = chunk_hits.first().map_or(0, |&i| row_of[i as usize]);
                let rows: Vec<Endpoint> = chunk_hits.iter().map(|&i| Endpoint::of(&sps[i as usize])).collect();
                let t0 = Instant::now();
                let (matrix, rays) = visibility(cs, &rows, &cols, progress);
                vis_ms += ms(t0);
                stats.visibility_rays += rays;
                let t0 = Instant::now();
                let src = VisibilitySource::Own { matrix: &matrix, row_of: &row_of, first_row };
                pixels.extend(shade(cs, &sps, cfg.spp, px..end, &lights, &src, g_max, cfg.seed, cfg.direct_samples));
                shade_ms += ms(t0);
                px = end;
            }
        }
    }
    t.visibility = vis_ms;
    t.shade = shade_ms;
    stats.visibility_mrays_per_s = if vis_ms > 0.0 { stats.visibility_rays as f64 / (vis_ms * 1e3) } else { 0.0 };
    t.sum();
    Ok(Frame { width: cfg.width, height: rows.end - rows.start, pixels, timings: t, stats })
}
