//! One frame on the GPU: the five stages chained on device buffers, the twin of
//! `vplgi_cpu::pipeline::render`. Read back are the final image and a few counters the host
//! needs to size the next dispatches (VPL batch totals, the data box and occupancy counts of
//! each clustering, surviving cluster counts, hit counts at chunk boundaries).

use crate::buffers::{dispatch_windows, read_back, read_word, storage_zeroed, sync, uniform, Window, WINDOW_ALIGN};
use crate::cluster::ClusterKernel;
use crate::context::validated;
use crate::lights::GpuLights;
use crate::scan::ScanKernel;
use crate::scene::GpuScene;
use crate::shade::{ShadeInputs, ShadeKernel, Visibility, VplLight};
use crate::shader::pipelines;
use crate::shading_points::ShadingPointsKernel;
use crate::trace_vpls::TraceVplsKernel;
use crate::visibility::{words_per_row, Endpoint, VisibilityKernel};
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use serde::Serialize;
use std::time::Instant;
use vplgi_scene::lights::LightSampler;
use vplgi_scene::Scene;
use vplgi_types::{FrameConfig, StageTimings};

/// Every pipeline of the frame, compiled once.
pub struct GpuKernels {
    trace: TraceVplsKernel,
    shading_points: ShadingPointsKernel,
    cluster: ClusterKernel,
    visibility: VisibilityKernel,
    shade: ShadeKernel,
    scan: ScanKernel,
    frame: std::collections::HashMap<&'static str, wgpu::ComputePipeline>,
}

const FRAME_ENTRIES: [&str; 6] = ["sp_flags", "sp_compact", "vpl_endpoints", "vpl_lights", "cluster_lights", "light_endpoints"];

#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
struct FrameParams {
    n: u32,
    k: u32,
    first: u32,
    hit_first: u32,
    hit_count: u32,
    pad: [u32; 3],
}

impl GpuKernels {
    pub fn new(device: &wgpu::Device) -> Result<GpuKernels, GpuError> {
        Ok(GpuKernels {
            trace: TraceVplsKernel::new(device)?,
            shading_points: ShadingPointsKernel::new(device)?,
            cluster: ClusterKernel::new(device)?,
            visibility: VisibilityKernel::new(device)?,
            shade: ShadeKernel::new(device)?,
            scan: ScanKernel::new(device)?,
            frame: validated(device, "frame pipelines", || FRAME_ENTRIES.iter().copied().zip(pipelines(device, "frame.wgsl", &FRAME_ENTRIES)).collect())?,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn frame(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        entry: &str,
        n: u32,
        k: u32,
        bound: &[(u32, &wgpu::Buffer)],
        threads: u32,
    ) -> Result<(), GpuError> {
        let whole: Vec<(u32, wgpu::BufferBinding)> = bound.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
        self.frame_with(device, queue, entry, &FrameParams { n, k, ..Default::default() }, &whole, threads)
    }

    /// [`GpuKernels::frame`] with all parameters and any bindings (chunks, windows).
    fn frame_with(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        entry: &str,
        params: &FrameParams,
        bound: &[(u32, wgpu::BufferBinding)],
        threads: u32,
    ) -> Result<(), GpuError> {
        validated(device, entry, || {
            let p = uniform(device, "frame params", params);
            let mut all = vec![(0, p.as_entire_buffer_binding())];
            all.extend_from_slice(bound);
            dispatch_windows(device, queue, &self.frame[entry], &all, threads.div_ceil(64).max(1));
        })
    }
}

/// Counts that describe what a GPU frame did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GpuFrameStats {
    pub vpls: u32,
    pub light_particles: u32,
    pub vpl_clusters: u32,
    pub shading_points: u32,
    pub shading_point_hits: u32,
    pub sp_clusters: u32,
    /// Shading points / VPLs whose 27-cell neighbourhood had no compatible centroid.
    pub sp_widened: u32,
    pub vpl_widened: u32,
    pub g_clamp_d_min: f32,
    pub scene_extent: f32,
}

/// A rendered frame: linear RGB, row-major, row 0 at the top.
pub struct GpuFrame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
    pub timings: StageTimings,
    /// Uploading the scene and building its BVH.
    pub setup_ms: f64,
    pub stats: GpuFrameStats,
}

/// Rows of the visibility matrix shaded at once when shading points are not clustered, as on the
/// CPU: at most 64 Mi bits per chunk (and at most one storage binding).
const ROW_CHUNK_BITS: usize = 64 << 23;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Arrays of the frame that are bound whole: the per-sample hit flags, offsets and rows (4 B per
/// sample) must fit one storage binding, and every per-point array (hit points, labels and
/// weights: at most 64 B per point, bound in windows) one buffer. Checked before any work, so an
/// oversized frame is a clear error.
fn check_frame_size(device: &wgpu::Device, cfg: &FrameConfig) -> Result<(), GpuError> {
    let l = device.limits();
    let n_sp = cfg.width as u64 * cfg.height as u64 * cfg.spp as u64;
    let what = format!("a {}x{} frame at {} spp", cfg.width, cfg.height, cfg.spp);
    let per_sample = (n_sp + 1) * 4;
    if per_sample > l.max_storage_buffer_binding_size {
        return Err(GpuError::TooLarge {
            what: format!("bytes of per-sample hit offsets of {what} in one storage binding"),
            needed: per_sample,
            limit: l.max_storage_buffer_binding_size,
        });
    }
    let per_point = n_sp * (4 * cfg.effective_f() as u64).max(std::mem::size_of::<Endpoint>() as u64);
    if per_point > l.max_buffer_size {
        return Err(GpuError::TooLarge { what: format!("bytes of per-point labels of {what} in one buffer"), needed: per_point, limit: l.max_buffer_size });
    }
    Ok(())
}

/// Renders one frame on the GPU.
pub fn render(device: &wgpu::Device, queue: &wgpu::Queue, k: &GpuKernels, scene: &Scene, cfg: &FrameConfig) -> Result<GpuFrame, GpuError> {
    cfg.validate().map_err(|e| GpuError::Validation { what: "the frame configuration".into(), message: e })?;
    let t0 = Instant::now();
    let gs = GpuScene::new(device, scene)?;
    let sampler = LightSampler::new(scene);
    let gl = GpuLights::new(device, scene, &sampler);
    sync(device)?;
    let setup_ms = ms(t0);
    let mut t = StageTimings::default();
    let extent = scene.extent().max(1e-6);
    let mut stats = GpuFrameStats { scene_extent: extent, ..Default::default() };

    let t0 = Instant::now();
    let vset = k.trace.run(device, queue, &gs, &gl, cfg.seed, cfg.vpls, cfg.bounces)?;
    sync(device)?;
    t.trace_vpls = ms(t0);
    (stats.vpls, stats.light_particles) = (vset.count, vset.particles);

    let t0 = Instant::now();
    let n_sp = cfg.width * cfg.height * cfg.spp;
    let limit = device.limits().max_storage_buffer_binding_size;
    check_frame_size(device, cfg)?;
    // Shading points in chunks of whole pixels that each fit one storage binding, less one
    // window alignment: shade binds the chunk's hits' labels and weights (at most 64 B per hit,
    // like a shading point) from the aligned hit at or below the chunk's first.
    let sp_bytes = std::mem::size_of::<vplgi_types::ShadingPoint>() as u64;
    let per_chunk = (((limit / sp_bytes).saturating_sub(WINDOW_ALIGN) as u32) / cfg.spp).max(1) * cfg.spp;
    let mut sp_chunks: Vec<(u32, u32, wgpu::Buffer)> = Vec::new();
    let mut first = 0u32;
    while first < n_sp {
        let count = (n_sp - first).min(per_chunk);
        let buf = k.shading_points.dispatch_range(device, queue, &gs, cfg.width, cfg.height, cfg.spp, cfg.seed, first as u64, count as u64)?;
        sp_chunks.push((first, count, buf));
        first += count;
    }
    sync(device)?;
    t.shading_points = ms(t0);
    stats.shading_points = n_sp;

    let t0 = Instant::now();
    // Hits: numbered in sample order, with their rows and clustering points.
    let flags = storage_zeroed::<u32>(device, "hit flags", n_sp as usize);
    let hit_offsets = storage_zeroed::<u32>(device, "hit offsets", n_sp as usize + 1);
    for (first, count, buf) in &sp_chunks {
        let p = FrameParams { n: *count, first: *first, ..Default::default() };
        k.frame_with(device, queue, "sp_flags", &p, &[(1, buf.as_entire_buffer_binding()), (2, flags.as_entire_buffer_binding())], *count)?;
    }
    k.scan.run(device, queue, &flags, n_sp, &hit_offsets)?;
    let hits = read_word(device, queue, &hit_offsets, n_sp as u64)?;
    stats.shading_point_hits = hits;
    let row_of = storage_zeroed::<u32>(device, "row of", n_sp as usize);
    let hit_points = storage_zeroed::<Endpoint>(device, "hit points", hits as usize);
    let hit_windows = Window::split(hits as u64, std::mem::size_of::<Endpoint>() as u64, limit);
    for (first, count, buf) in &sp_chunks {
        for w in &hit_windows {
            let p = FrameParams { n: *count, first: *first, hit_first: w.first as u32, hit_count: w.count as u32, ..Default::default() };
            let b = [
                (1, buf.as_entire_buffer_binding()),
                (3, hit_offsets.as_entire_buffer_binding()),
                (4, row_of.as_entire_buffer_binding()),
                (5, w.of::<Endpoint>(&hit_points, 1)),
            ];
            k.frame_with(device, queue, "sp_compact", &p, &b, *count)?;
        }
    }

    // Lights for shading: VPL clusters at their representatives, or the VPLs.
    let n_vpl = vset.count;
    let (lights, n_lights) = if cfg.cluster.clusters_vpls() && n_vpl > 0 {
        let pts = storage_zeroed::<Endpoint>(device, "vpl points", n_vpl as usize);
        k.frame(device, queue, "vpl_endpoints", n_vpl, 0, &[(5, &pts), (6, &vset.buffer)], n_vpl)?;
        let c = k.cluster.cluster(device, queue, &pts, n_vpl, &cfg.vpl_cluster_params())?;
        let lights = storage_zeroed::<VplLight>(device, "cluster lights", c.k as usize);
        k.frame(device, queue, "cluster_lights", n_vpl, c.k, &[(6, &vset.buffer), (7, &c.labels), (8, &c.representatives), (9, &lights)], c.k)?;
        stats.vpl_clusters = c.k;
        let [_, widened, incompatible] = k.cluster.outcome_counts(device, queue, &c.outcome, n_vpl)?;
        stats.vpl_widened = widened + incompatible;
        (lights, c.k)
    } else {
        let lights = storage_zeroed::<VplLight>(device, "vpl lights", n_vpl as usize);
        k.frame(device, queue, "vpl_lights", n_vpl, 0, &[(6, &vset.buffer), (9, &lights)], n_vpl)?;
        (lights, n_vpl)
    };
    let cols = storage_zeroed::<Endpoint>(device, "light endpoints", n_lights as usize);
    k.frame(device, queue, "light_endpoints", n_lights, 0, &[(5, &cols), (9, &lights)], n_lights)?;

    let sp_clusters = if cfg.cluster.clusters_sps() && hits > 0 {
        let c = k.cluster.cluster(device, queue, &hit_points, hits, &cfg.sp_cluster_params())?;
        // Visibility rows of the clusters: their representatives' Endpoints.
        let rows = storage_zeroed::<Endpoint>(device, "cluster rows", c.k as usize);
        k.cluster.gather(device, queue, &rows, &c.representatives, c.k, &hit_points, hits)?;
        stats.sp_clusters = c.k;
        let [_, widened, incompatible] = k.cluster.outcome_counts(device, queue, &c.outcome, hits)?;
        stats.sp_widened = widened + incompatible;
        Some((c, rows))
    } else {
        None
    };
    sync(device)?;
    t.cluster = ms(t0);

    let d_min = cfg.g_clamp_rel * extent;
    stats.g_clamp_d_min = d_min;
    let g_max = if d_min > 0.0 { 1.0 / (d_min * d_min) } else { f32::INFINITY };
    let n_pixels = cfg.width * cfg.height;
    let wpr = words_per_row(n_lights as usize) as u32;
    let mut pixels: Vec<[f32; 3]> = Vec::with_capacity(n_pixels as usize);
    let to_rgb = |v: Vec<[f32; 4]>| v.into_iter().map(|p| [p[0], p[1], p[2]]);
    // Visibility rows shaded at once: as on the CPU, with their words within one storage
    // binding, and their Endpoints too (bound from the aligned row at or below the first).
    let row_budget =
        ((ROW_CHUNK_BITS as u64 / 32).min(limit / 4) / (wpr.max(1) as u64)).min((limit / std::mem::size_of::<Endpoint>() as u64).saturating_sub(WINDOW_ALIGN));
    let clustered_words = match &sp_clusters {
        Some((c, rows)) => {
            let t0 = Instant::now();
            let words = k.visibility.run_on_device(device, queue, &gs, rows, c.k, &cols, n_lights, 0, c.k)?;
            sync(device)?;
            t.visibility += ms(t0);
            Some(words)
        }
        None => None,
    };
    for (sp_first, sp_count, sp_buf) in &sp_chunks {
        let spp = cfg.spp;
        let (chunk_px0, chunk_px1) = (sp_first / spp, (sp_first + sp_count) / spp);
        match (&sp_clusters, &clustered_words) {
            (Some((c, _)), Some(words)) => {
                // The chunk's hits (numbered in sample order) and their labels and weights.
                let h0 = read_word(device, queue, &hit_offsets, *sp_first as u64)?;
                let h1 = read_word(device, queue, &hit_offsets, (sp_first + sp_count) as u64)?;
                let t0 = Instant::now();
                let window = Window::covering(h0 as u64, h1 as u64);
                let visibility = Visibility::Fuzzy { labels: &c.labels, weights: &c.weights, f: c.f, window };
                let inputs = ShadeInputs {
                    sps: sp_buf,
                    sp_first: *sp_first,
                    row_of: &row_of,
                    words,
                    words_per_row: wpr,
                    vpl_lights: &lights,
                    light_count: n_lights,
                    visibility,
                };
                let out = k.shade.run(device, queue, &gs, &gl, &inputs, chunk_px0..chunk_px1, spp, cfg.seed, cfg.direct_samples, g_max)?;
                pixels.extend(to_rgb(read_back::<[f32; 4]>(device, queue, &out, (chunk_px1 - chunk_px0) as usize)?));
                t.shade += ms(t0);
            }
            _ => {
                // Each hit is its own row: visibility and shading proceed in pixel chunks whose
                // rows fit the budget.
                let px_chunk = ((row_budget / spp as u64) as u32).max(1);
                let mut px = chunk_px0;
                while px < chunk_px1 {
                    let end = (px + px_chunk).min(chunk_px1);
                    // Hits of these pixels are rows first_row .. last_row (hits are numbered in order).
                    let first_row = read_word(device, queue, &hit_offsets, px as u64 * spp as u64)?;
                    let last_row = read_word(device, queue, &hit_offsets, end as u64 * spp as u64)?;
                    let t0 = Instant::now();
                    let words = k.visibility.run_on_device(device, queue, &gs, &hit_points, hits, &cols, n_lights, first_row, last_row - first_row)?;
                    sync(device)?;
                    t.visibility += ms(t0);
                    let t0 = Instant::now();
                    let inputs = ShadeInputs {
                        sps: sp_buf,
                        sp_first: *sp_first,
                        row_of: &row_of,
                        words: &words,
                        words_per_row: wpr,
                        vpl_lights: &lights,
                        light_count: n_lights,
                        visibility: Visibility::Own { first_row },
                    };
                    let out = k.shade.run(device, queue, &gs, &gl, &inputs, px..end, spp, cfg.seed, cfg.direct_samples, g_max)?;
                    pixels.extend(to_rgb(read_back::<[f32; 4]>(device, queue, &out, (end - px) as usize)?));
                    t.shade += ms(t0);
                    px = end;
                }
            }
        }
    }
    t.sum();
    Ok(GpuFrame { width: cfg.width, height: cfg.height, pixels, timings: t, setup_ms, stats })
}
