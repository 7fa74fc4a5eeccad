//! `interpolate` (`--shade interpolate`): the GPU's irradiance samples at the CPU's sample points
//! (from the CPU's radii, lights and visibility rows) against the CPU's, and the interpolated
//! final image of each mode that clusters shading points (SPEC: the shade row, relMSE ≤ 1e-4).

use crate::inputs::{CpuClusters, CpuFrame};
use crate::shade::{compare_on, rel_mse, worst_item, Pixels};
use crate::tolerance::{Disagreement, SHADE_REL_MSE};
use crate::{count, interpolating, result, v3, Mode, Plan, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::interpolate::SampleLighting;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::FrameConfig;

/// The irradiance samples of `clusters`' sample points on both backends.
pub fn both(twins: &Twins, cfg: &FrameConfig, clusters: &CpuClusters) -> Result<(Pixels, Pixels), VerifyError> {
    let cs = twins.cpu;
    let (device, queue) = (twins.device(), twins.queue());
    let g_max = cfg.g_max(cs.extent);
    let (matrix, _) = vplgi_cpu::visibility::visibility(cs, &clusters.rows, &clusters.cols, &vplgi_cpu::NoProgress);
    let cpu = vplgi_cpu::shade::sample_irradiance(&cs.scene.materials, &clusters.rows, &clusters.lights, &matrix, g_max);
    let words = storage(device, "words", bytemuck::cast_slice::<u64, u32>(matrix.words()));
    let lights = storage(device, "lights", &clusters.lights.lights);
    let outlines = (!clusters.lights.outlines.is_empty()).then(|| storage(device, "light outlines", &clusters.lights.outlines));
    let n_lights = clusters.lights.lights.len() as u32;
    let exact_shapes = clusters.lights.lights.iter().any(|l| l.exact != 0);
    let lighting = SampleLighting {
        words: &words,
        words_per_row: words_per_row(clusters.lights.lights.len()) as u32,
        vpl_lights: &lights,
        outlines: outlines.as_ref(),
        light_count: n_lights,
        exact_shapes,
        lobes: twins.gpu.scene().glossy_lobes(),
        g_max,
    };
    let n = clusters.rows.len();
    let k = twins.gpu.kernels();
    let points = (storage(device, "sample points", &clusters.rows), n as u32);
    // The radii travel with the samples but take no part in summing them.
    let samples = k.interpolate.sample_irradiance(device, queue, &k.shade, points, storage(device, "inverse radii", &vec![0.0f32; n]), &lighting)?;
    let gpu: Vec<[f32; 4]> = read_back(device, queue, &samples.irradiance, n)?;
    Ok((cpu, gpu.into_iter().map(|e| [e[0], e[1], e[2]]).collect()))
}

/// Compares the irradiance samples of `cfg`'s sample points.
pub fn compare_samples(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame) -> Result<Vec<Disagreement>, VerifyError> {
    let clusters = CpuClusters::new(twins.cpu, frame, cfg);
    let (cpu, gpu) = both(twins, cfg, &clusters)?;
    let (worst, at) = worst_item(&cpu, &gpu, |_| true, |j| format!("sample point {j}"));
    let at = at.or_else(|| cpu.first().zip(gpu.first()).map(|(c, g)| format!("sample point 0: CPU {}, GPU {}", v3(*c), v3(*g))));
    let case = format!("{} {} sample points", Mode::of(cfg).name_in(cfg), count(cpu.len()));
    Ok(vec![
        Disagreement::at_most("interpolate / samples", "relMSE(GPU, CPU) of the irradiance samples on the same inputs", rel_mse(&cpu, &gpu), SHADE_REL_MSE)
            .with_case(&case)
            .with_worst(at),
        Disagreement::info("interpolate / samples", "largest relative difference of a sample", worst as f64).with_case(case),
    ])
}

/// The samples of the plan's frame, interpolating, and the interpolated image of each mode of
/// `modes` that clusters shading points (of none does, `both/weighted`).
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let (cfg, modes) = (&plan.config, &plan.modes[..]);
    let mut r = result(VerifyStage::Interpolate);
    let cfg = interpolating(cfg);
    let frame = CpuFrame::new(twins.cpu, &cfg);
    r.checks.extend(compare_samples(twins, &cfg, &frame)?);
    let mut clustered: Vec<Mode> = modes.iter().copied().filter(|m| m.cluster.clusters_sps()).collect();
    if clustered.is_empty() {
        clustered.push(Mode::of(&cfg));
    }
    for mode in clustered {
        let (checks, pair, map) = compare_on(twins, &mode.apply(&cfg), &frame)?;
        r.checks.extend(checks);
        r.images.push(pair);
        r.maps.push(map);
    }
    r.notes.push(
        "the GPU sums the lights at the CPU's sample points (each its own visibility row) and interpolates them with the CPU's 1/R and clusters: \
         the irradiance samples, then the final image of each mode"
            .into(),
    );
    Ok(r)
}
