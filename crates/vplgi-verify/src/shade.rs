//! `shade`, and the final image on identical inputs: the GPU's shade kernel fed the CPU's shading
//! points, lights, shading-point clusters and visibility matrix, in every mode (SPEC: relMSE(GPU,
//! CPU) <= 1e-4).

use crate::inputs::{CpuClusters, CpuFrame};
use crate::tolerance::{Disagreement, CLUSTER_LIGHTS_REL, SHADE_REL_MSE};
use crate::{result, ImagePair, Mode, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_cpu::interpolate::IrradianceSamples;
use vplgi_cpu::shade::{sample_irradiance, VisibilitySource};
use vplgi_frame::{Backend, LightSet};
use vplgi_gpu::buffers::{read_back, storage, Window};
use vplgi_gpu::cluster::GpuClustering;
use vplgi_gpu::interpolate::{InterpolateInputs, SampleLighting};
use vplgi_gpu::shade::{ShadeInputs, Visibility};
use vplgi_gpu::trace_vpls::GpuVpls;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::{FrameConfig, LightOutline, ShadeMode, VplLight};

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
    // Interpolating, the sample points' 1 / R_j are the CPU's for both (gather_radius is judged
    // on its own); each backend sums the irradiance samples itself.
    let samples = match &clusters.sp_clusters {
        Some(_) if cfg.shade == ShadeMode::Interpolate => {
            let inv_radius = vplgi_cpu::gather_radius::gather_radius(cs, &clusters.rows, &cfg.gather_params());
            let irradiance = sample_irradiance(&clusters.rows, &clusters.lights, &matrix, params.g_max);
            Some(IrradianceSamples { points: clusters.rows.clone(), inv_radius, irradiance })
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
            let at = InterpolateInputs { sps: &sps, sp_first: 0, row_of: &row_of, labels: &labels, f: sc.f as u32, window: all_hits };
            let running = kernels.interpolate.run(device, queue, &gpu_samples, &at, 0..frame.sps.len() as u32)?;
            kernels.shade.finish(device, queue, twins.gpu.scene(), &sps, 0, &running, 0..n_pixels as u32, &params)?
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
                visibility,
            };
            kernels.shade.run(device, queue, twins.gpu.scene(), &inputs, 0..n_pixels as u32, &params)?
        }
    };
    let gpu: Vec<[f32; 4]> = read_back(device, queue, &out, n_pixels)?;
    Ok((cpu, gpu.into_iter().map(|p| [p[0], p[1], p[2]]).collect()))
}

/// The GPU's lights of the CPU's VPL clustering (the frame's `cluster_lights` kernel: flux sums
/// and, for disks, R²) against the CPU's: the largest relative difference of any component.
pub fn compare_lights(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame, clusters: &CpuClusters) -> Result<Option<Disagreement>, VerifyError> {
    let Some(vc) = &clusters.vpl_clusters else { return Ok(None) };
    let (device, queue) = (twins.device(), twins.queue());
    let n = frame.vpls.len() as u32;
    let k = vc.k() as u32;
    let hard: Vec<u32> = (0..frame.vpls.len()).map(|i| vc.hard_label(i)).collect();
    let gc = GpuClustering::of_labels(device, &hard, &vc.representatives);
    let vpls = GpuVpls { buffer: storage(device, "vpls", &frame.vpls), count: n, particles: 0 };
    let buffer = twins.gpu.vpl_lights(&vpls, n, LightSet::Clusters { clusters: &gc, k, shape: cfg.light_shape })?;
    let gpu: Vec<VplLight> = read_back(device, queue, &buffer.buffer, k as usize)?;
    let mut worst = (0.0f64, None);
    for (c, (a, b)) in clusters.lights.lights.iter().zip(&gpu).enumerate() {
        let (fa, fb) = (bytemuck::cast::<VplLight, [f32; 12]>(*a), bytemuck::cast::<VplLight, [f32; 12]>(*b));
        let d = fa.iter().zip(&fb).map(|(x, y)| ((x - y).abs() / x.abs().max(1e-20)) as f64).fold(0.0, f64::max);
        if d > worst.0 || d.is_nan() {
            worst = (d, Some(format!("cluster {c}: CPU flux {} R² {}, GPU flux {} R² {}", crate::v3(a.flux), a.radius2, crate::v3(b.flux), b.radius2)));
        }
    }
    // A polygon's outline: each vertex's distance to the nearest vertex of the other's, over the
    // polygon's size (√area), and the areas' relative difference. Not vertex by vertex: where a
    // diagonal side of the outline just grazes a corner, rounding may cut the corner on one
    // backend (two vertices a rounding error apart) and not on the other, the same polygon.
    if let Some(outlines) = &buffer.outlines {
        let gpu: Vec<LightOutline> = read_back(device, queue, outlines, k as usize)?;
        for (c, (a, b)) in clusters.lights.outlines.iter().zip(&gpu).enumerate() {
            let size = (a.area() as f64).sqrt().max(1e-20);
            let d = outline_distance(a, b).max(outline_distance(b, a)) / size;
            let d = d.max(((a.area() - b.area()) / a.area().max(1e-20)).abs() as f64);
            if d > worst.0 || d.is_nan() {
                worst =
                    (d, Some(format!("cluster {c}: CPU outline of {} vertices, area {}; GPU {} vertices, area {}", a.count(), a.area(), b.count(), b.area())));
            }
        }
    }
    let shape = serde_json::to_value(cfg.light_shape).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
    Ok(Some(
        Disagreement::at_most("shade / cluster lights", "largest relative difference of a light's flux, R² or outline", worst.0, CLUSTER_LIGHTS_REL)
            .with_case(format!("{} {shape}", Mode::of(cfg).name_in(cfg)))
            .with_worst(worst.1),
    ))
}

/// The farthest any vertex of `a` is from the nearest vertex of `b` (0 with no vertices in `a`,
/// infinite with none in `b` only).
fn outline_distance(a: &LightOutline, b: &LightOutline) -> f64 {
    let v = |o: &LightOutline| o.vertices[..o.count()].iter().map(|x| glam::DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64)).collect::<Vec<_>>();
    let (a, b) = (v(a), v(b));
    a.iter().map(|x| b.iter().map(|y| x.distance(*y)).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max)
}

/// Compares the two images of one mode.
pub fn compare(twins: &Twins, cfg: &FrameConfig) -> Result<(Vec<Disagreement>, ImagePair), VerifyError> {
    compare_on(twins, cfg, &CpuFrame::new(twins.cpu, cfg))
}

/// [`compare`] on the CPU's stages 1 and 2 already made (they do not depend on the mode).
pub fn compare_on(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame) -> Result<(Vec<Disagreement>, ImagePair), VerifyError> {
    let clusters = CpuClusters::new(twins.cpu, frame, cfg);
    let (cpu, gpu) = shade_both(twins, cfg, frame, &clusters)?;
    let (max_rel, worst) = worst_pixel(&cpu, &gpu, cfg.width, |_| true);
    let case = Mode::of(cfg).name_in(cfg);
    let mut checks = vec![
        Disagreement::at_most("shade / final image", "relMSE(GPU, CPU) on the same inputs", rel_mse(&cpu, &gpu), SHADE_REL_MSE)
            .with_case(&case)
            .with_worst(worst),
        Disagreement::info("shade / final image", "largest relative pixel difference", max_rel as f64).with_case(&case),
    ];
    checks.extend(compare_lights(twins, cfg, frame, &clusters)?);
    let pair = ImagePair { case: format!("shade-{}", case.replace('/', "-")), width: cfg.width, height: cfg.height, cpu, gpu };
    Ok((checks, pair))
}

/// The final image of every mode in `modes`, each on its own CPU inputs.
pub fn verify(twins: &Twins, cfg: &FrameConfig, modes: &[Mode]) -> Result<StageResult, VerifyError> {
    let mut r = result(VerifyStage::Shade);
    let frame = CpuFrame::new(twins.cpu, cfg);
    for mode in modes {
        let (checks, pair) = compare_on(twins, &mode.apply(cfg), &frame)?;
        r.checks.extend(checks);
        r.images.push(pair);
    }
    r.notes.push(
        "the GPU's shade kernel reads the CPU's shading points, lights (VPLs or VPL clusters), shading-point clusters and visibility matrix: \
         the final image of each mode on identical inputs"
            .into(),
    );
    Ok(r)
}
