//! `shade`, and the final image on identical inputs: the GPU's shade kernel fed the CPU's shading
//! points, lights, shading-point clusters and visibility matrix, in every mode (SPEC: relMSE(GPU,
//! CPU) <= 1e-4).

use crate::inputs::{CpuClusters, CpuFrame};
use crate::segment::{TieOracle, Verdict};
use crate::tolerance::{polygon_outline_bounds, Disagreement, CLUSTER_LIGHTS_REL, SHADE_REL_MSE};
use crate::map::{DisagreementMap, ItemKind};
use crate::{result, ImagePair, Mode, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::{DVec3, Vec3};
use vplgi_cpu::interpolate::IrradianceSamples;
use vplgi_cpu::shade::{sample_irradiance, VisibilitySource};
use vplgi_cpu::CpuScene;
use vplgi_frame::prelude::*;
use vplgi_frame::LightSet;
use vplgi_gpu::buffers::{read_back, storage, Window};
use vplgi_gpu::cluster::GpuClustering;
use vplgi_gpu::interpolate::{InterpolateInputs, SampleLighting};
use vplgi_gpu::shade::{FinishInput, ShadeInputs, Visibility};
use vplgi_gpu::trace_vpls::GpuVpls;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::{FrameConfig, LightOutline, ShadeMode, ShadeParams, ShadingPoint, VplLight};

/// An image's pixels, row-major.
pub type Pixels = Vec<[f32; 3]>;

/// relMSE of `test` against `reference` (`vplgi_image`'s definition); NaN if either has a NaN.
pub fn rel_mse(reference: &[[f32; 3]], test: &[[f32; 3]]) -> f64 {
    let mut sum = 0.0f64;
    for (a, b) in reference.iter().zip(test) {
        for c in 0..3 {
            let (x, y) = (a[c] as f64, b[c] as f64);
            sum += (x - y).powi(2) / (x * x + vplgi_image::REL_MSE_EPSILON);
        }
    }
    if reference.len() != test.len() {
        return f64::NAN;
    }
    sum / (3 * reference.len().max(1)) as f64
}

/// The pixel whose channels differ most relative to the CPU's value, with both values, among
/// the pixels `include` accepts.
pub fn worst_pixel(cpu: &[[f32; 3]], gpu: &[[f32; 3]], width: u32, include: impl Fn(usize) -> bool) -> (f32, Option<String>) {
    worst_item(cpu, gpu, include, |i| format!("pixel ({}, {})", i as u32 % width, i as u32 / width))
}

/// The RGB item whose channels differ most relative to the CPU's value, among the items
/// `include` accepts, described as `name(i)` with both values.
pub fn worst_item(cpu: &[[f32; 3]], gpu: &[[f32; 3]], include: impl Fn(usize) -> bool, name: impl Fn(usize) -> String) -> (f32, Option<String>) {
    let mut worst = (0.0f32, None);
    for (i, (a, b)) in cpu.iter().zip(gpu).enumerate().filter(|(i, _)| include(*i)) {
        let d = (0..3).map(|c| (a[c] - b[c]).abs() / a[c].abs().max(1e-3)).fold(0.0f32, |m, x| if x.is_nan() || m.is_nan() { f32::NAN } else { m.max(x) });
        if d > worst.0 || (d.is_nan() && !worst.0.is_nan()) {
            worst = (d, Some(format!("{}: CPU {}, GPU {}", name(i), crate::v3(*a), crate::v3(*b))));
        }
    }
    worst
}

/// Shades every pixel of `cfg` on both backends from the CPU's inputs `frame` and `clusters`.
pub fn shade_both(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame, clusters: &CpuClusters) -> Result<(Pixels, Pixels), VerifyError> {
    let cs = twins.cpu;
    let (device, queue) = (twins.device(), twins.queue());
    let n_pixels = (cfg.width * cfg.height) as usize;
    let limit = device.limits().max_storage_buffer_binding_size;
    let wpr = words_per_row(clusters.cols.len());
    let needed = [
        ("shading points", std::mem::size_of_val(&frame.sps[..]) as u64),
        ("visibility words", (clusters.rows.len() * wpr * 4) as u64),
        ("lights", std::mem::size_of_val(&clusters.lights.lights[..]) as u64),
    ];
    if let Some((what, bytes)) = needed.iter().find(|(_, b)| *b > limit) {
        return Err(VerifyError::TooLarge(format!(
            "verify shades the whole frame in one dispatch: its {what} need {bytes} B, this adapter binds at most {limit} B (use a smaller --width/--height/--spp or --vpls)"
        )));
    }
    let (matrix, _) = vplgi_cpu::visibility::visibility(cs, &clusters.rows, &clusters.cols, &vplgi_cpu::NoProgress);
    let params = cfg.shade_params(cs.extent);
    // Interpolating, the sample points' 1 / R_j are the CPU's for both (their stage is judged on
    // its own); each backend sums the irradiance samples itself.
    let samples = match &clusters.sp_clusters {
        Some(_) if cfg.shade == ShadeMode::Interpolate => {
            let inv_radius = clusters.inv_radius(cs, cfg);
            let irradiance = sample_irradiance(&cs.scene.materials, &clusters.rows, &clusters.lights, &matrix, params.g_max);
            Some(IrradianceSamples { points: clusters.rows.clone(), inv_radius, irradiance, sh: Vec::new() })
        }
        _ => None,
    };
    let src = match (&clusters.sp_clusters, &samples) {
        (Some(sc), Some(samples)) => VisibilitySource::Interpolated { row_of: &frame.row_of, labels: &sc.labels, f: sc.f, samples },
        (Some(sc), None) => VisibilitySource::Fuzzy { matrix: &matrix, row_of: &frame.row_of, labels: &sc.labels, weights: &sc.weights, f: sc.f },
        (None, _) => VisibilitySource::Own { matrix: &matrix, row_of: &frame.row_of, first_row: 0 },
    };
    let cpu = vplgi_cpu::shade::shade(cs, &frame.sps, 0, 0..n_pixels, &clusters.lights, &src, &params);

    let sps = storage(device, "sps", &frame.sps);
    let row_of = storage(device, "row_of", &frame.row_of);
    let words = storage(device, "words", bytemuck::cast_slice::<u64, u32>(matrix.words()));
    let lights = storage(device, "lights", &clusters.lights.lights);
    let outlines = (!clusters.lights.outlines.is_empty()).then(|| storage(device, "light outlines", &clusters.lights.outlines));
    let exact_shapes = clusters.lights.lights.iter().any(|l| l.exact != 0);
    let (labels, weights) = match &clusters.sp_clusters {
        Some(sc) => (storage(device, "labels", &sc.labels), storage(device, "weights", &sc.weights)),
        None => (storage::<u32>(device, "labels", &[]), storage::<f32>(device, "weights", &[])),
    };
    let all_hits = Window { first: 0, count: frame.hits.len() as u64 };
    let kernels = twins.gpu.kernels();
    let out = match (&clusters.sp_clusters, &samples) {
        (Some(sc), Some(samples)) => {
            let lighting = SampleLighting {
                words: &words,
                words_per_row: wpr as u32,
                vpl_lights: &lights,
                outlines: outlines.as_ref(),
                light_count: clusters.lights.lights.len() as u32,
                exact_shapes,
                lobes: twins.gpu.scene().glossy_lobes(),
                g_max: params.g_max,
            };
            let points = (storage(device, "sample points", &samples.points), samples.points.len() as u32);
            let gpu_samples = kernels.interpolate.sample_irradiance(
                device,
                queue,
                &kernels.shade,
                points,
                storage(device, "inverse radii", &samples.inv_radius),
                &lighting,
            )?;
            let at = InterpolateInputs { sps: &sps, sp_first: 0, row_of: &row_of, labels: &labels, f: sc.f as u32, window: all_hits, lobes: &twins.gpu.scene().lobes };
            let running = kernels.interpolate.run(device, queue, &gpu_samples, &at, 0..frame.sps.len() as u32)?;
            kernels.shade.finish(device, queue, twins.gpu.scene(), &FinishInput { sps: &sps, sp_first: 0, running: &running, pixels: 0..n_pixels as u32 }, &params)?
        }
        _ => {
            let visibility = match &clusters.sp_clusters {
                Some(sc) => Visibility::Fuzzy { labels: &labels, weights: &weights, f: sc.f as u32, window: all_hits },
                None => Visibility::Own { first_row: 0 },
            };
            let inputs = ShadeInputs {
                sps: &sps,
                sp_first: 0,
                row_of: &row_of,
                words: &words,
                words_per_row: wpr as u32,
                vpl_lights: &lights,
                outlines: outlines.as_ref(),
                light_count: clusters.lights.lights.len() as u32,
                exact_shapes,
                lobes: twins.gpu.scene().glossy_lobes(),
                visibility,
            };
            kernels.shade.run(device, queue, twins.gpu.scene(), &inputs, 0..n_pixels as u32, &params)?
        }
    };
    let gpu: Vec<[f32; 4]> = read_back(device, queue, &out, n_pixels)?;
    Ok((cpu, gpu.into_iter().map(|p| [p[0], p[1], p[2]]).collect()))
}

/// The GPU's lights of the CPU's VPL clustering (the frame's `cluster_lights` kernel: flux sums
/// and, for disks, R²) against the CPU's: the largest relative difference of any component; and
/// for polygons the outlines (and with them R², area / π), each within its own
/// [`polygon_outline_bounds`].
pub fn compare_lights(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame, clusters: &CpuClusters) -> Result<Vec<Disagreement>, VerifyError> {
    let Some(vc) = &clusters.vpl_clusters else { return Ok(Vec::new()) };
    let (device, queue) = (twins.device(), twins.queue());
    let n = frame.vpls.len() as u32;
    let k = vc.k() as u32;
    let hard: Vec<u32> = (0..frame.vpls.len()).map(|i| vc.hard_label(i)).collect();
    let gc = GpuClustering::of_labels(device, &hard, &vc.representatives);
    let vpls = GpuVpls { buffer: storage(device, "vpls", &frame.vpls), count: n, particles: 0 };
    let buffer = twins.gpu.vpl_lights(&vpls, LightSet::Clusters { clusters: &gc, shape: cfg.light_shape })?;
    let gpu: Vec<VplLight> = read_back(device, queue, &buffer.buffer, k as usize)?;
    let polygons = buffer.outlines.is_some();
    let mut worst = (0.0f64, None);
    for (c, (a, b)) in clusters.lights.lights.iter().zip(&gpu).enumerate() {
        let (fa, fb) = (bytemuck::cast::<VplLight, [f32; 16]>(*a), bytemuck::cast::<VplLight, [f32; 16]>(*b));
        // A polygon's R² is its outline's area / π, judged with the outline below.
        let judged = fa.iter().zip(&fb).enumerate().filter(|(i, _)| !(polygons && *i == 3));
        let d = judged.map(|(_, (x, y))| ((x - y).abs() / x.abs().max(1e-20)) as f64).fold(0.0, f64::max);
        if d > worst.0 || d.is_nan() {
            worst = (d, Some(format!("cluster {c}: CPU flux {} R² {}, GPU flux {} R² {}", crate::v3(a.flux), a.radius2, crate::v3(b.flux), b.radius2)));
        }
    }
    let shape = serde_json::to_value(cfg.light_shape).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
    let case = format!("{} {shape}", Mode::of(cfg).name_in(cfg));
    let what = if polygons { "largest relative difference of a light's flux" } else { "largest relative difference of a light's flux or R²" };
    let mut checks = vec![Disagreement::at_most("shade / cluster lights", what, worst.0, CLUSTER_LIGHTS_REL).with_case(&case).with_worst(worst.1)];
    if let Some(outlines) = &buffer.outlines {
        // Each cluster's reach: the farthest light-carrying member from its representative.
        let mut reach = vec![0.0f64; k as usize];
        for (v, &c) in frame.vpls.iter().zip(&hard) {
            if vplgi_shared::disk::member_weight(Vec3::from(v.flux)) > 0.0 {
                let centre = dvec(clusters.lights.lights[c as usize].position);
                reach[c as usize] = reach[c as usize].max(dvec(v.position).distance(centre));
            }
        }
        let gpu: Vec<LightOutline> = read_back(device, queue, outlines, k as usize)?;
        let mut worst = (0.0f64, None);
        for (c, (a, b)) in clusters.lights.outlines.iter().zip(&gpu).enumerate() {
            let d = outline_share(a, b, reach[c], dvec(clusters.lights.lights[c].position).length());
            if d.share > worst.0 || d.share.is_nan() {
                worst = (d.share, Some(format!("cluster {c}: {d}")));
            }
        }
        checks.push(
            Disagreement::at_most(
                "shade / cluster lights",
                "largest difference of a polygon's area or vertices over its rounding bound (tolerance::polygon_outline_bounds)",
                worst.0,
                1.0,
            )
            .with_case(case)
            .with_worst(worst.1),
        );
    }
    Ok(checks)
}

fn dvec(v: [f32; 3]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

/// Two backends' outline of one polygon light, measured against [`polygon_outline_bounds`].
struct OutlineDifference {
    /// The larger of the area's and the vertices' difference over its bound (≤ 1 agrees).
    share: f64,
    areas: (f32, f32),
    counts: (usize, usize),
    vertex_distance: f64,
    bounds: (f64, f64),
}

impl std::fmt::Display for OutlineDifference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "CPU outline of {} vertices, area {:e}; GPU {} vertices, area {:e} (bound {:.2e}); vertices {:.2e} apart (bound {:.2e})",
            self.counts.0, self.areas.0, self.counts.1, self.areas.1, self.bounds.0, self.vertex_distance, self.bounds.1
        )
    }
}

/// `cpu` and `gpu`, the outline of a cluster whose members reach `reach` from its representative
/// (`centre_distance` from the origin). Vertices are compared each to the nearest vertex of the
/// other outline, not one by one: where a diagonal side just grazes a corner, rounding may cut
/// the corner on one backend (two vertices a rounding error apart) and not on the other, the
/// same polygon.
fn outline_share(cpu: &LightOutline, gpu: &LightOutline, reach: f64, centre_distance: f64) -> OutlineDifference {
    let v = |o: &LightOutline| o.vertices[..o.count()].iter().map(|x| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64)).collect::<Vec<_>>();
    let (a, b) = (v(cpu), v(gpu));
    let perimeter: f64 = (0..a.len()).map(|i| a[i].distance(a[(i + 1) % a.len()])).sum();
    let bounds = polygon_outline_bounds(cpu.area() as f64, perimeter, reach, centre_distance);
    let vertex_distance = outline_distance(&a, &b).max(outline_distance(&b, &a));
    let area_difference = (cpu.area() as f64 - gpu.area() as f64).abs();
    let share = (area_difference / bounds.0.max(f64::MIN_POSITIVE)).max(vertex_distance / bounds.1.max(f64::MIN_POSITIVE));
    OutlineDifference { share, areas: (cpu.area(), gpu.area()), counts: (a.len(), b.len()), vertex_distance, bounds }
}

/// The farthest any vertex of `a` is from the nearest vertex of `b` (0 with no vertices in `a`,
/// infinite with none in `b` only).
fn outline_distance(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().map(|x| b.iter().map(|y| x.distance(*y)).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max)
}

/// Compares the two images of one mode.
pub fn compare(twins: &Twins, cfg: &FrameConfig) -> Result<(Vec<Disagreement>, ImagePair), VerifyError> {
    let (checks, pair, _) = compare_on(twins, cfg, &CpuFrame::new(twins.cpu, cfg))?;
    Ok((checks, pair))
}

/// Whether pixel `i`'s own relMSE exceeds the image's bound: a pixel the map shows as beyond.
pub(crate) fn pixel_beyond(cpu: &[[f32; 3]], gpu: &[[f32; 3]], i: usize) -> bool {
    rel_mse(&cpu[i..=i], &gpu[i..=i]) > SHADE_REL_MSE
}

/// [`compare`] on the CPU's stages 1 and 2 already made (they do not depend on the mode).
///
/// Each backend traces the direct light's shadow rays itself (Embree, the WGSL BVH), so "the
/// same inputs" cannot cover them: a pixel whose direct light rests on a ray that rounding alone
/// decides (a [`Verdict::Tie`], as the visibility rows set aside) may rightly differ by the whole
/// light. The SPEC's bound is judged on the other pixels; every pixel's relMSE, the pixels set
/// aside and the failing pixels left unexamined (beyond [`MAX_TIE_PIXELS`], judged with the
/// image) are reported beside it. The map shows the pixels set aside as ties and those beyond
/// the image's bound on their own.
pub fn compare_on(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame) -> Result<(Vec<Disagreement>, ImagePair, DisagreementMap), VerifyError> {
    let clusters = CpuClusters::new(twins.cpu, frame, cfg);
    let (cpu, gpu) = shade_both(twins, cfg, frame, &clusters)?;
    let oracle = TieOracle::new(twins.scene);
    let DirectTies { pixels: ties, unexamined } = direct_ties(twins.cpu, &oracle, &frame.sps, &cfg.shade_params(twins.cpu.extent), &cpu, &gpu, MAX_TIE_PIXELS);
    let kept = |i: usize| ties.binary_search(&i).is_err();
    let (max_rel, mut worst) = worst_pixel(&cpu, &gpu, cfg.width, kept);
    if unexamined > 0 {
        // Said where a failure is read: some of what fails may be ties nobody looked at.
        let note = format!("{unexamined} failing pixels beyond the {MAX_TIE_PIXELS} worst were not examined for ties and are judged");
        worst = Some(worst.map_or(note.clone(), |w| format!("{w}; {note}")));
    }
    let (cpu_kept, gpu_kept): (Pixels, Pixels) = cpu.iter().zip(&gpu).enumerate().filter(|(i, _)| kept(*i)).map(|(_, (a, b))| (*a, *b)).unzip();
    let case = Mode::of(cfg).name_in(cfg);
    let mut checks = vec![
        Disagreement::at_most(
            "shade / final image",
            "relMSE(GPU, CPU) on the same inputs, apart from pixels whose direct light is a rounding tie",
            rel_mse(&cpu_kept, &gpu_kept),
            SHADE_REL_MSE,
        )
        .with_case(&case)
        .with_worst(worst),
        Disagreement::info("shade / final image", "relMSE(GPU, CPU) on the same inputs, every pixel", rel_mse(&cpu, &gpu)).with_case(&case),
        Disagreement::info(
            "shade / final image",
            format!("pixels set aside: a direct-light shadow ray is a rounding tie (f64, within {:.1e})", oracle.tolerance()),
            ties.len() as f64,
        )
        .with_case(&case),
        Disagreement::info(
            "shade / final image",
            format!("failing pixels not examined for ties (only the {MAX_TIE_PIXELS} worst are; the rest stay judged)"),
            unexamined as f64,
        )
        .with_case(&case),
        Disagreement::info("shade / final image", "largest relative pixel difference, apart from those", max_rel as f64).with_case(&case),
    ];
    checks.extend(compare_lights(twins, cfg, frame, &clusters)?);
    let name = format!("shade-{}", case.replace('/', "-"));
    let mut map = DisagreementMap::new(name.clone(), cfg.width, cfg.height);
    for i in 0..cpu.len().min(gpu.len()) {
        map.mark(i, if !kept(i) { ItemKind::Tie } else if pixel_beyond(&cpu, &gpu, i) { ItemKind::Beyond } else { ItemKind::Agree });
    }
    let pair = ImagePair { case: name, width: cfg.width, height: cfg.height, cpu, gpu };
    Ok((checks, pair, map))
}

/// At most this many pixels are judged for direct-light ties (each judges its shadow rays against
/// every triangle in f64, a cost of pixels × rays × triangles per mode, and a broken kernel can
/// make every pixel fail). Failing pixels beyond them are counted, reported, and stay judged: the
/// cap can make the judged relMSE higher, never lower.
pub const MAX_TIE_PIXELS: usize = 2_000;

/// What [`direct_ties`] found.
#[derive(Debug, PartialEq)]
struct DirectTies {
    /// The pixels (sorted) set aside.
    pixels: Vec<usize>,
    /// Failing pixels not examined (beyond the `max` worst): never set aside, so judged.
    unexamined: usize,
}

/// The pixels whose direct light rests on a rounding tie: some shadow ray of one of their
/// samples, exactly as `vplgi_cpu::shade::direct` traces it, that the f64 oracle cannot decide.
/// Only pixels whose own relMSE breaks the bound are judged, the `max` worst of them: a pixel
/// within it is never set aside, so the judged image can only lose pixels that fail on their own,
/// and failing pixels beyond the `max` are counted, not set aside.
fn direct_ties(cs: &CpuScene, oracle: &TieOracle, sps: &[ShadingPoint], params: &ShadeParams, cpu: &[[f32; 3]], gpu: &[[f32; 3]], max: usize) -> DirectTies {
    if !params.direct {
        return DirectTies { pixels: Vec::new(), unexamined: 0 };
    }
    let mut suspects: Vec<(f64, usize)> =
        (0..cpu.len()).map(|i| (rel_mse(&cpu[i..=i], &gpu[i..=i]), i)).filter(|&(e, _)| e > SHADE_REL_MSE || e.is_nan()).collect();
    suspects.sort_by(|a, b| b.0.total_cmp(&a.0));
    let unexamined = suspects.len().saturating_sub(max);
    let spp = params.spp as usize;
    let mut ties: Vec<usize> = suspects
        .iter()
        .take(max)
        .map(|&(_, px)| px)
        .filter(|&px| {
            (px * spp..(px + 1) * spp).any(|s| {
                let sp = &sps[s];
                let mut tie = false;
                if !sp.is_miss() {
                    vplgi_cpu::shade::direct_with(cs, sp, s as u32, params.seed, params.direct_samples, |r| {
                        let d = r.dir.as_dvec3();
                        tie |= oracle.span_verdict(r.origin.as_dvec3(), d, r.tmin as f64, r.tmax as f64) == Verdict::Tie;
                        true
                    });
                }
                tie
            })
        })
        .collect();
    ties.sort_unstable();
    DirectTies { pixels: ties, unexamined }
}

/// The final image of every mode in `modes`, each on its own CPU inputs.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let (cfg, modes) = (&plan.config, &plan.modes[..]);
    let mut r = result(VerifyStage::Shade);
    let frame = CpuFrame::new(twins.cpu, cfg);
    for mode in modes {
        let (checks, pair, map) = compare_on(twins, &mode.apply(cfg), &frame)?;
        r.checks.extend(checks);
        r.images.push(pair);
        r.maps.push(map);
    }
    r.notes.push(
        "the GPU's shade kernel reads the CPU's shading points, lights (VPLs or VPL clusters), shading-point clusters and visibility matrix: \
         the final image of each mode on identical inputs"
            .into(),
    );
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_shared::polygon::{support, Outline, SIDES};

    /// A sliver: members along a crease 0.23 long and 0.0014 wide, the representative at one
    /// end, far from the origin (the case a random soup found beyond the flat 1e-5).
    fn sliver() -> (Vec<(Vec3, Vec3)>, Vec3, Vec3) {
        let normal = Vec3::new(0.3, 0.8, 0.5).normalize();
        let (t, b) = vplgi_shared::polygon::frame(normal);
        let centre = Vec3::new(1.3, -0.7, 0.9);
        let members = (0..20).map(|i| (centre + t * (0.23 * i as f32 / 19.0) + b * (0.0014 * (i % 2) as f32), Vec3::splat(0.1))).collect();
        (members, centre, normal)
    }

    fn outline(s: &[f32; SIDES], centre: Vec3, normal: Vec3) -> LightOutline {
        Outline::new(s).light_outline(centre, normal)
    }

    /// A point light 1 above the unit square's shared diagonal; shading points 1 below it,
    /// facing up, whose shadow rays run through the diagonal (a tie), through one triangle's
    /// interior (blocked) and past the square (visible). Only the first is set aside, and only
    /// while its pixel breaks the bound on its own.
    #[test]
    fn only_failing_pixels_whose_direct_shadow_ray_is_a_tie_are_set_aside() {
        let mut scene = crate::segment::tests::square();
        scene.materials.iter_mut().for_each(|m| m.emission = Vec3::ZERO);
        scene.lights = vec![vplgi_scene::PunctualLight::Point { position: Vec3::new(0.5, 0.5, 1.0), intensity: Vec3::ONE }];
        let device = vplgi_embree::Device::new(None).expect("Embree");
        let cs = CpuScene::new(&scene, &device).expect("scene");
        let oracle = TieOracle::new(&scene);
        let below = |x: f32, y: f32| ShadingPoint { position: [x, y, -1.0], normal: [0.0, 0.0, 1.0], triangle: 0, albedo: [0.5; 3], ..Default::default() };
        let sps = [below(0.5, 0.5), below(0.3, 0.7), below(3.0, 0.5), below(0.5, 0.5)];
        let params = ShadeParams { spp: 1, seed: 3, direct_samples: 1, g_max: f32::INFINITY, direct: true };
        let cpu = vec![[1.0f32; 3]; 4];
        let mut gpu = vec![[2.0f32; 3]; 4];
        gpu[3] = cpu[3];
        assert_eq!(direct_ties(&cs, &oracle, &sps, &params, &cpu, &gpu, MAX_TIE_PIXELS), DirectTies { pixels: vec![0], unexamined: 0 });
        // Without direct light no shadow ray is traced.
        assert_eq!(direct_ties(&cs, &oracle, &sps, &ShadeParams { direct: false, ..params }, &cpu, &gpu, MAX_TIE_PIXELS).pixels, Vec::<usize>::new());
        // Examining only the worst failing pixel: the tie (made the worst) is still set aside, and
        // the other two failing pixels are counted as unexamined, not set aside.
        gpu[0] = [3.0; 3];
        assert_eq!(direct_ties(&cs, &oracle, &sps, &params, &cpu, &gpu, 1), DirectTies { pixels: vec![0], unexamined: 2 });
        // The tie no longer the worst (pixels 1 and 2 are; their rays are no ties): examining one
        // pixel sets nothing aside and leaves two unexamined, the tie among them.
        gpu[0] = [1.5; 3];
        assert_eq!(direct_ties(&cs, &oracle, &sps, &params, &cpu, &gpu, 1), DirectTies { pixels: vec![], unexamined: 2 });
    }

    #[test]
    fn a_sliver_rounded_differently_agrees_and_a_wrong_support_does_not() {
        let (members, centre, normal) = sliver();
        let s = support(members.iter().copied(), centre, normal);
        let reach = members.iter().map(|(x, _)| x.distance(centre) as f64).fold(0.0, f64::max);
        let cpu = outline(&s, centre, normal);
        let share = |gpu: &LightOutline| outline_share(&cpu, gpu, reach, centre.length() as f64);
        // Every side a few ulps of the reach away, as a fused multiply-add would put it: beyond
        // the flat relative bound on the area, within the rounding bound.
        let nudge = 4.0 * f32::EPSILON * reach as f32;
        let rounded: [f32; SIDES] = std::array::from_fn(|a| s[a] + if a % 2 == 0 { nudge } else { -nudge });
        let gpu = outline(&rounded, centre, normal);
        let relative = ((cpu.area() - gpu.area()) / cpu.area()).abs() as f64;
        assert!(relative > CLUSTER_LIGHTS_REL, "the sliver should be beyond the flat bound: {relative:e}");
        let d = share(&gpu);
        println!("rounded: {d}, share {}", d.share);
        assert!(d.share <= 1.0, "{d}");
        // A support 1 % too narrow across the sliver, and a support without the far member.
        let mut narrow = s;
        narrow[2] *= 0.99;
        let far = support(members[..19].iter().copied(), centre, normal);
        for wrong in [narrow, far] {
            let d = share(&outline(&wrong, centre, normal));
            println!("wrong: {d}, share {}", d.share);
            assert!(d.share > 1.0, "{d}");
        }
        // A cluster that stays a point on one backend only.
        assert!(share(&LightOutline::default()).share > 1.0);
    }

    #[test]
    fn round_outlines_keep_the_flat_bound() {
        // Members on a circle around the representative: a near-regular octagon.
        let normal = Vec3::Z;
        let (t, b) = vplgi_shared::polygon::frame(normal);
        let centre = Vec3::new(0.2, 0.1, 0.4);
        let members: Vec<_> = (0..32).map(|i| (centre + (t * (i as f32 * 0.196).cos() + b * (i as f32 * 0.196).sin()) * 0.1, Vec3::ONE)).collect();
        let s = support(members.iter().copied(), centre, normal);
        let cpu = outline(&s, centre, normal);
        let v: Vec<DVec3> = cpu.vertices[..cpu.count()].iter().map(|x| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64)).collect();
        let perimeter: f64 = (0..v.len()).map(|i| v[i].distance(v[(i + 1) % v.len()])).sum();
        let (area, vertex) = polygon_outline_bounds(cpu.area() as f64, perimeter, 0.1, centre.length() as f64);
        assert_eq!(area, CLUSTER_LIGHTS_REL * cpu.area() as f64);
        assert_eq!(vertex, CLUSTER_LIGHTS_REL * (cpu.area() as f64).sqrt());
    }
}
