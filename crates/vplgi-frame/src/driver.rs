//! The frame, written once over [`Backend`]: which stages run in which variant, how work is cut
//! into chunks that fit the backend, and what is timed and counted.

use crate::backend::{Counted, LightSet, RsmStart, SampleChunk, ShadeInput, ShadeVisibility};
use crate::frame::{Frame, FrameError, FrameStats, Progress, StageTimings};
use crate::stages::{Backend, Stage};
use std::ops::Range;
use std::time::Instant;
use vplgi_shared::illumination_cut;
use vplgi_shared::rsm::RsmCentre;
use vplgi_shared::rsm_importance;
use vplgi_types::clustering::Centre;
use vplgi_types::clustering::ClusterStart;
use vplgi_types::{
    Camera, CausticParams, ClusterMode, FrameConfig, Gi, RsmSeeding, Seeding, ShadeMode,
    ShadeParams, Temporal, VplClustering, VplSource,
};

/// Bits of visibility matrix shaded at once when shading points are not clustered (each hit is
/// its own row): bounds the matrix to 64 MiB whatever the image size.
pub const ROW_CHUNK_BITS: u64 = 64 << 23;

/// Renders one frame from the scene's camera.
pub fn render<B: Backend>(
    b: &B,
    cfg: &FrameConfig,
    progress: &dyn Progress,
) -> Result<Frame, B::Error> {
    render_from(b, cfg, &View { camera: b.camera(), previous: None, previous_rsm: None }, progress)
}

/// Where a frame of a sequence is seen from, and what it carries over from the frame before.
#[derive(Clone, Copy, Debug)]
pub struct View<'a> {
    pub camera: Camera,
    /// With `--temporal on`: the previous frame's [`Frame::centres`].
    pub previous: Option<&'a [Centre]>,
    /// With `--temporal on`: the previous frame's [`Frame::rsm_centres`].
    pub previous_rsm: Option<&'a [RsmCentre]>,
}

/// Renders one frame of a sequence.
pub fn render_from<B: Backend>(
    b: &B,
    cfg: &FrameConfig,
    view: &View<'_>,
    progress: &dyn Progress,
) -> Result<Frame, B::Error> {
    render_view(b, cfg, view, 0..cfg.height, progress)
}

/// Times `work` as part of `stage`, waiting for the backend to finish it.
fn timed<B: Backend, T>(
    b: &B,
    t: &mut StageTimings,
    stage: Stage,
    work: impl FnOnce() -> Result<T, B::Error>,
) -> Result<T, B::Error> {
    let clock = Instant::now();
    let out = work()?;
    b.sync()?;
    t.add(stage, clock.elapsed().as_secs_f64() * 1e3);
    Ok(out)
}

/// Renders image rows `rows` of an unclustered frame (`--cluster none`): each pixel bit-identical
/// to the whole frame's, since without clustering a pixel depends only on the VPLs (traced in
/// full) and its own samples. The frame holds the rows only. This is how a reference is cut into
/// tiles; clustered frames cannot be (their clusters depend on the whole image).
pub fn render_rows<B: Backend>(
    b: &B,
    cfg: &FrameConfig,
    rows: Range<u32>,
    progress: &dyn Progress,
) -> Result<Frame, B::Error> {
    render_view(
        b,
        cfg,
        &View { camera: b.camera(), previous: None, previous_rsm: None },
        rows,
        progress,
    )
}

fn render_view<B: Backend>(
    b: &B,
    cfg: &FrameConfig,
    view: &View<'_>,
    rows: Range<u32>,
    progress: &dyn Progress,
) -> Result<Frame, B::Error> {
    cfg.validate().map_err(FrameError::InvalidConfig)?;
    if rows.start >= rows.end || rows.end > cfg.height {
        return Err(FrameError::InvalidConfig(format!(
            "rows {}..{} of a {}-row image",
            rows.start, rows.end, cfg.height
        ))
        .into());
    }
    if (rows.start > 0 || rows.end < cfg.height) && cfg.cluster != ClusterMode::None {
        return Err(FrameError::InvalidConfig(
            "only unclustered frames (--cluster none) can be rendered in tiles".into(),
        )
        .into());
    }
    // `--gi photon`'s samples carry spherical harmonics for glossy receivers (the glossy last
    // bounce); the VPL lights' samples hold irradiance alone.
    if cfg.shade == ShadeMode::Interpolate
        && cfg.cluster != ClusterMode::None
        && cfg.gi == Gi::Vpl
        && b.has_glossy()
    {
        return Err(FrameError::InvalidConfig(
            "--shade interpolate with --gi vpl interpolates irradiance, and rough metal does not reflect light as a \
             multiple of its irradiance: render scenes with glossy surfaces with --shade fuzzy, or with --gi photon, \
             whose samples carry spherical harmonics"
                .into(),
        )
        .into());
    }
    b.check_frame(cfg)?;
    let mut t = StageTimings::default();
    let extent = b.scene_extent();
    let spp = cfg.spp;
    let n_samples = cfg.width * cfg.height * spp;
    let mut stats = FrameStats {
        scene_extent: extent,
        shading_points: n_samples,
        g_clamp_d_min: cfg.g_clamp_rel * extent,
        ..Default::default()
    };

    // With `--gi photon` there are no VPLs: the global photon map's cut lights the gather.
    let cut = if cfg.has_photons() {
        Some(illumination_cut(b, cfg, extent, &mut t, &mut stats, progress)?)
    } else {
        None
    };
    let (vpls, particles) = match cfg.vpl_source {
        _ if cut.is_some() => {
            b.trace_vpls(&vplgi_types::TraceParams { count: 0, ..cfg.trace_params() }, progress)?
        }
        VplSource::Paths => {
            timed(b, &mut t, Stage::TraceVpls, || b.trace_vpls(&cfg.trace_params(), progress))?
        }
        VplSource::Rsm => {
            timed(b, &mut t, Stage::RsmVpls, || b.rsm_vpls(&cfg.rsm_params(), progress))?
        }
    };
    (stats.vpls, stats.light_particles) = (vpls.count(), particles);
    // The caustic photon map: the same particles' paths, photons where they leave a mirror or
    // glass. Timed as trace_vpls (the tracing) and caustics (the tree).
    let photon_map = if cfg.has_caustics() && b.has_specular() {
        let (photons, used) = timed(b, &mut t, Stage::TraceVpls, || {
            b.trace_vpls(&cfg.caustic_trace_params(), progress)
        })?;
        (stats.caustic_photons, stats.caustic_particles) = (photons.count(), used);
        Some(timed(b, &mut t, Stage::Caustics, || b.photon_map(&photons, cfg.photon_leaf))?)
    } else {
        None
    };

    // Shading points of the rows, in chunks of whole pixels the backend can hold. Indices stay
    // global: the RNG streams use them, so a tile's pixels equal the whole frame's.
    progress.start(Stage::ShadingPoints.name(), 1);
    let camera = cfg.camera_params(view.camera);
    let per_chunk = (b.max_samples_per_chunk() / spp).max(1) * spp;
    let (first_sample, end_sample) = (rows.start * cfg.width * spp, rows.end * cfg.width * spp);
    let mut chunks = timed(b, &mut t, Stage::ShadingPoints, || {
        let mut chunks = Vec::new();
        let mut first = first_sample;
        while first < end_sample {
            let count = (end_sample - first).min(per_chunk);
            chunks.push(SampleChunk {
                first,
                count,
                samples: b.shading_points(&camera, first..first + count)?,
            });
            first += count;
        }
        Ok(chunks)
    })?;
    progress.finish();

    // Only surface hits take part in clustering, visibility and shading. Lights are one per VPL
    // cluster or one per VPL; shading points are clustered or each their own visibility row.
    progress.start(Stage::Cluster.name(), 1);
    let (mut centres, mut rsm_centres) = (Vec::new(), Vec::new());
    let (hits, lights, cols, sp_clusters) = timed(b, &mut t, Stage::Cluster, || {
        let hits = b.compact_hits(&chunks, n_samples)?;
        stats.shading_point_hits = hits.count();
        let lights = if cfg.cluster.clusters_vpls() && vpls.count() > 0 {
            let (c, k) = match cfg.vpl_cluster {
                VplClustering::Eq7 => b.cluster(
                    &b.vpl_points(&vpls)?,
                    &cfg.vpl_cluster_params(),
                    ClusterStart::Stride,
                )?,
                VplClustering::Rsm => {
                    let importance = match cfg.rsm_seeding {
                        RsmSeeding::Halton => None,
                        RsmSeeding::Importance => {
                            let samples = rsm_importance::pixel_samples(cfg.width, cfg.height, spp);
                            Some(b.rsm_importance(
                                &vpls,
                                cfg.rsm_size,
                                &hits,
                                &samples,
                                rsm_importance::D_MIN_REL * extent,
                            )?)
                        }
                    };
                    let temporal = cfg.temporal == Temporal::On;
                    let start = RsmStart {
                        importance: importance.as_ref(),
                        previous: view.previous_rsm.filter(|_| temporal),
                        carry: temporal,
                    };
                    let (c, k, carried) =
                        b.rsm_cluster(&vpls, cfg.rsm_size, &cfg.rsm_cluster_params(extent), start)?;
                    (stats.vpl_kept, stats.vpl_fresh, rsm_centres) = (k.kept, k.fresh, carried);
                    (c, k)
                }
            };
            (stats.vpl_clusters, stats.vpl_widened) = (c.count(), k.widened);
            b.vpl_lights(&vpls, LightSet::Clusters { clusters: &c, shape: cfg.light_shape })?
        } else {
            b.vpl_lights(&vpls, LightSet::EachVpl { max_bounce: cfg.bounces })?
        };
        let cols = b.light_points(&lights)?;
        let sp_clusters = if cfg.cluster.clusters_sps() && hits.count() > 0 {
            let points = b.hit_points(&hits);
            let seeds = match cfg.seeding {
                Seeding::Stride => None,
                Seeding::Adaptive => Some(b.seeding(&hits, &camera, &cfg.seed_params(extent))?),
            };
            let params = cfg.sp_cluster_params(extent);
            let start = match (cfg.temporal, view.previous, seeds.as_deref()) {
                (Temporal::On, Some(previous), seeds) => ClusterStart::Warm { previous, seeds },
                (_, _, Some(s)) => ClusterStart::Seeds(s),
                (_, _, None) => ClusterStart::Stride,
            };
            let (c, k) = b.cluster(points, &params, start)?;
            (stats.sp_clusters, stats.sp_widened, stats.sp_kept, stats.sp_fresh) =
                (c.count(), k.widened, k.kept, k.fresh);
            if cfg.temporal == Temporal::On {
                centres = b.cluster_centres(&c, points, params.metric)?;
            }
            let reps = b.representatives(&c, points)?;
            Some((c, reps))
        } else {
            None
        };
        Ok((hits, lights, cols, sp_clusters))
    })?;
    progress.finish();

    let shade = cfg.shade_params(extent);
    let mut rays: Option<u64> = None;
    let mut count_rays = |r: Option<u64>| {
        if let Some(r) = r {
            *rays.get_or_insert(0) += r;
        }
    };
    // With clustered shading points the matrix has a row per cluster and is made once. With
    // `--shade interpolate` the rows' points (the representatives) become the sample points:
    // their gather rays, then the irradiance of the lights at each with its own row.
    let clustered = match sp_clusters {
        Some((c, reps)) => {
            let (matrix, r) = timed(b, &mut t, Stage::Visibility, || {
                b.visibility(&reps, 0..reps.count(), &cols, progress)
            })?;
            count_rays(r);
            let samples = match cfg.shade {
                ShadeMode::Fuzzy => None,
                ShadeMode::Interpolate => {
                    progress.start(Stage::Interpolate.name(), 1);
                    let samples = match &cut {
                        // The gather rays give both 1 / R_j and the irradiance.
                        Some(cut) => {
                            let (samples, counts) = timed(b, &mut t, Stage::FinalGather, || {
                                b.final_gather(reps, cut, &cfg.gather_params())
                            })?;
                            (stats.gather_fallback, stats.gather_truncated) =
                                (counts.fallback, counts.truncated);
                            samples
                        }
                        None => {
                            let inv_radius = timed(b, &mut t, Stage::GatherRadius, || {
                                b.gather_radius(&reps, &cfg.gather_params())
                            })?;
                            timed(b, &mut t, Stage::Interpolate, || {
                                b.sample_irradiance(reps, inv_radius, &lights, &matrix, shade.g_max)
                            })?
                        }
                    };
                    progress.finish();
                    Some(samples)
                }
            };
            Some((c, matrix, samples))
        }
        None => None,
    };
    let mut pixels = Vec::with_capacity((rows.end - rows.start) as usize * cfg.width as usize);
    for chunk in &chunks {
        let (px0, px1) = (chunk.first / spp, (chunk.first + chunk.count) / spp);
        match &clustered {
            Some((c, matrix, samples)) => {
                let h = b.hits_before(&hits, chunk.first)?
                    ..b.hits_before(&hits, chunk.first + chunk.count)?;
                progress.start(Stage::Shade.name(), 1);
                let visibility = match samples {
                    None => ShadeVisibility::Fuzzy { clustering: c, hits: h },
                    Some(samples) => {
                        ShadeVisibility::Interpolated { clustering: c, hits: h, samples }
                    }
                };
                let input = ShadeInput { chunk, hits: &hits, lights: &lights, matrix, visibility };
                pixels
                    .extend(timed(b, &mut t, Stage::Shade, || b.shade(&input, px0..px1, &shade))?);
                progress.finish();
            }
            None => {
                let own = OwnRows { chunk, hits: &hits, lights: &lights, cols: &cols };
                pixels.extend(shade_own_rows(b, &mut t, &own, &shade, progress, &mut count_rays)?);
            }
        }
    }

    if let Some(map) = &photon_map {
        let params = cfg.caustic_params(extent, 0);
        for chunk in &chunks {
            stats.caustic_truncated +=
                add_caustics(b, &mut t, map, chunk, &params, &mut pixels, first_sample)?;
        }
    }

    // Bias compensation, level by level (Kollig and Keller): level j's points are surfaces seen
    // from level j - 1's where the clamp bit, shaded like camera hits (each its own visibility
    // row) by the VPLs of at most bounces - j surfaces, so no path is longer than the frame's.
    // Their radiance, already weighted by their parents' albedos and clamped shares, adds to the
    // pixels. Without a clamp or without VPLs nothing was clamped.
    if cfg.bias_compensation && shade.g_max.is_finite() && vpls.count() > 0 {
        for level in 1..=cfg.bounces {
            let max_bounce = cfg.bounces - level;
            let set =
                if max_bounce == 0 { LightSet::Nothing } else { LightSet::EachVpl { max_bounce } };
            let lights = timed(b, &mut t, Stage::BiasPoints, || b.vpl_lights(&vpls, set))?;
            let cols = b.light_points(&lights)?;
            let bias = cfg.bias_params(extent, level);
            // A bias point's emission and direct light reach the camera after a bounce: they
            // are indirect light, kept whatever `--lighting` says.
            let level_shade = ShadeParams { seed: bias.seed, direct: true, ..shade };
            let mut any = false;
            for chunk in chunks.iter_mut() {
                let range = chunk.first..chunk.first + chunk.count;
                let samples = timed(b, &mut t, Stage::BiasPoints, || {
                    b.bias_points(&chunk.samples, range, &bias)
                })?;
                chunk.samples = samples;
                let hits = timed(b, &mut t, Stage::BiasPoints, || {
                    b.compact_hits(std::slice::from_ref(chunk), n_samples)
                })?;
                if hits.count() == 0 {
                    continue;
                }
                any = true;
                stats.bias_points += hits.count() as u64;
                let own = OwnRows { chunk, hits: &hits, lights: &lights, cols: &cols };
                let added =
                    shade_own_rows(b, &mut t, &own, &level_shade, progress, &mut count_rays)?;
                let px0 = ((chunk.first - first_sample) / spp) as usize;
                add_pixels(&mut pixels, px0, &added);
                // The caustic light at the level's points, through photons of paths that are no
                // longer than the frame's with the level's surfaces.
                if let Some(map) = &photon_map {
                    let params = cfg.caustic_params(extent, level);
                    stats.caustic_truncated +=
                        add_caustics(b, &mut t, map, chunk, &params, &mut pixels, first_sample)?;
                }
            }
            if !any {
                break;
            }
        }
    }
    let vis_ms = t.get(Stage::Visibility);
    stats.visibility_rays = rays;
    stats.visibility_mrays_per_s =
        rays.map(|r| if vis_ms > 0.0 { r as f64 / (vis_ms * 1e3) } else { 0.0 });
    Ok(Frame {
        width: cfg.width,
        height: rows.end - rows.start,
        pixels,
        timings: t,
        stats,
        centres,
        rsm_centres,
    })
}

/// `--gi photon`: the global photon map, its tree and its illumination cut, ready for gathering.
/// Tracing is timed as `trace_vpls`, the tree and the cut as `illumination_cut`.
fn illumination_cut<B: Backend>(
    b: &B,
    cfg: &vplgi_types::FrameConfig,
    extent: f32,
    t: &mut StageTimings,
    stats: &mut FrameStats,
    progress: &dyn Progress,
) -> Result<B::Cut, B::Error> {
    let (photons, used) =
        timed(b, t, Stage::TraceVpls, || b.trace_vpls(&cfg.global_trace_params(), progress))?;
    (stats.global_photons, stats.global_particles) = (photons.count(), used);
    let params = cfg.cut_params(extent);
    timed(b, t, Stage::IlluminationCut, || {
        let map = b.photon_map(&photons, cfg.photon_leaf)?;
        let estimates = b.node_estimates(&map, &params)?;
        let cut = illumination_cut::select(&estimates, &params, |points| {
            b.densities(&map, points, &params)
        })?;
        let s = cut.stats;
        (stats.cut_coarse, stats.cut_size, stats.cut_estimates, stats.cut_truncated) =
            (s.coarse, s.size, s.estimates, s.truncated);
        b.upload_cut(cut)
    })
}

/// Adds `added` to the pixels from `first` on.
fn add_pixels(pixels: &mut [[f32; 3]], first: usize, added: &[[f32; 3]]) {
    for (p, a) in pixels[first..first + added.len()].iter_mut().zip(added) {
        for c in 0..3 {
            p[c] += a[c];
        }
    }
}

/// Adds the caustic light of `chunk`'s points to their pixels (`pixels` starts at camera sample
/// `first_sample`); how many estimates stopped at the visit budget.
fn add_caustics<B: Backend>(
    b: &B,
    t: &mut StageTimings,
    map: &B::PhotonMap,
    chunk: &SampleChunk<B::Samples>,
    params: &CausticParams,
    pixels: &mut [[f32; 3]],
    first_sample: u32,
) -> Result<u64, B::Error> {
    let (added, cut) = timed(b, t, Stage::Caustics, || {
        b.caustics(map, &chunk.samples, chunk.first..chunk.first + chunk.count, params)
    })?;
    add_pixels(pixels, ((chunk.first - first_sample) / params.spp) as usize, &added);
    Ok(cut as u64)
}

/// A chunk's hits shaded with each hit its own visibility row (unclustered shading points).
struct OwnRows<'a, B: Backend> {
    chunk: &'a SampleChunk<B::Samples>,
    hits: &'a B::Hits,
    lights: &'a B::Lights,
    cols: &'a B::Points,
}

/// The radiance of a chunk's pixels when each hit is its own visibility row: visibility and
/// shading proceed in pixel blocks whose rows fit the memory bound and the backend.
fn shade_own_rows<B: Backend>(
    b: &B,
    t: &mut StageTimings,
    own: &OwnRows<'_, B>,
    shade: &ShadeParams,
    progress: &dyn Progress,
    count_rays: &mut impl FnMut(Option<u64>),
) -> Result<Vec<[f32; 3]>, B::Error> {
    let OwnRows { chunk, hits, lights, cols } = *own;
    let spp = shade.spp;
    let row_bits = 64 * (cols.count() as u64).div_ceil(64).max(1);
    let row_budget = (ROW_CHUNK_BITS / row_bits).min(b.max_visibility_rows(cols.count()));
    let px_block = ((row_budget / spp as u64).min(u32::MAX as u64) as u32).max(1);
    let (px0, px1) = (chunk.first / spp, (chunk.first + chunk.count) / spp);
    let mut pixels = Vec::with_capacity((px1 - px0) as usize);
    // Hits are numbered in sample order: a block's hits are consecutive rows, starting where the
    // previous block's ended (on the GPU each count is a read-back).
    let mut px = px0;
    let mut first_row = b.hits_before(hits, px * spp)?;
    while px < px1 {
        let end = px.saturating_add(px_block).min(px1);
        let last_row = b.hits_before(hits, end * spp)?;
        let (matrix, r) = timed(b, t, Stage::Visibility, || {
            b.visibility(b.hit_points(hits), first_row..last_row, cols, progress)
        })?;
        count_rays(r);
        let input = ShadeInput {
            chunk,
            hits,
            lights,
            matrix: &matrix,
            visibility: ShadeVisibility::Own { first_row },
        };
        pixels.extend(timed(b, t, Stage::Shade, || b.shade(&input, px..end, shade))?);
        (px, first_row) = (end, last_row);
    }
    Ok(pixels)
}
