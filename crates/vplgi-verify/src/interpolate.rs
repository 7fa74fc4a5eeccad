//! `interpolate` (`--shade interpolate`): the GPU's irradiance samples at the CPU's sample points
//! (from the CPU's radii, lights and visibility rows) against the CPU's, and the interpolated
//! final image of each mode that clusters shading points (SPEC: the shade row, relMSE ≤ 1e-4);
//! with `--gi photon` on a glossy scene, the glossy last bounce from the same samples.

use crate::inputs::{CpuClusters, CpuFrame};
use crate::shade::{compare_on, rel_mse, worst_item, Pixels};
use crate::tolerance::{Disagreement, SHADE_REL_MSE};
use crate::{count, interpolating, result, v3, Mode, Plan, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_cpu::shade::{irradiance, receiver, LightArrays, VisibilitySource};
use vplgi_gpu::buffers::{read_back, storage, Window};
use vplgi_gpu::interpolate::{GpuIrradianceSamples, InterpolateInputs, SampleLighting};
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::{FrameConfig, Gi, MISS};

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

/// `--gi photon` on a scene with glossy surfaces: the CPU's final-gather samples (spherical
/// harmonics included, lit by the cut the CPU chose) interpolated at every shading point by both
/// backends, glossy receivers integrating the harmonics against their lobes (the glossy last
/// bounce). Judged as the shade row, relMSE ≤ `SHADE_REL_MSE`, over the glossy shading points.
pub fn compare_glossy(twins: &Twins, cfg: &FrameConfig, frame: &CpuFrame) -> Result<Vec<Disagreement>, VerifyError> {
    let cs = twins.cpu;
    let clusters = CpuClusters::new(cs, frame, cfg);
    // `interpolating` clusters shading points in every mode it returns.
    let Some(sc) = clusters.sp_clusters.as_ref() else { return Ok(Vec::new()) };
    let photons = crate::illumination_cut::global_photons(twins, cfg);
    let cut = vplgi_cpu::illumination_cut::cut_of(&vplgi_cpu::caustics::photon_map(&photons, cfg.photon_leaf), &cfg.cut_params(cs.extent));
    let (samples, _) = vplgi_cpu::final_gather::final_gather(cs, clusters.rows.clone(), &cut, &cfg.gather_params());
    let vis = VisibilitySource::Interpolated { row_of: &frame.row_of, labels: &sc.labels, f: sc.f, samples: &samples };
    let none = LightArrays::new(&Default::default(), &[]);
    let materials = &cs.scene.materials;
    let glossy: Vec<usize> = (0..frame.sps.len()).filter(|&i| frame.row_of[i] != MISS && receiver(materials, &frame.sps[i]).is_some()).collect();
    let cpu: Vec<[f32; 3]> = glossy
        .iter()
        .map(|&i| {
            let sp = &frame.sps[i];
            irradiance(sp.position.into(), sp.normal.into(), receiver(materials, sp), i, &none, &vis, f32::INFINITY).to_array()
        })
        .collect();
    let (device, queue) = (twins.device(), twins.queue());
    let e: Vec<[f32; 4]> = samples.irradiance.iter().map(|e| [e[0], e[1], e[2], 0.0]).collect();
    let gpu_samples = GpuIrradianceSamples {
        points: storage(device, "sample points", &samples.points),
        inv_radius: storage(device, "inverse radii", &samples.inv_radius),
        irradiance: storage(device, "irradiance", &e),
        sh: Some(storage(device, "harmonics", &samples.sh)),
        count: samples.points.len() as u32,
    };
    let (sps, row_of, labels) = (storage(device, "sps", &frame.sps), storage(device, "row_of", &frame.row_of), storage(device, "labels", &sc.labels));
    let inputs = InterpolateInputs {
        sps: &sps,
        sp_first: 0,
        row_of: &row_of,
        labels: &labels,
        f: sc.f as u32,
        window: Window { first: 0, count: frame.hits.len() as u64 },
        lobes: &twins.gpu.scene().lobes,
    };
    let k = twins.gpu.kernels();
    let running = k.interpolate.run(device, queue, &gpu_samples, &inputs, 0..frame.sps.len() as u32)?;
    let all: Vec<[f32; 4]> = read_back(device, queue, &running, frame.sps.len())?;
    let gpu: Vec<[f32; 3]> = glossy.iter().map(|&i| [all[i][0], all[i][1], all[i][2]]).collect();
    let (worst, at) = worst_item(&cpu, &gpu, |_| true, |j| format!("shading point {}", glossy[j]));
    let case = format!("{} glossy shading points of {}, {} sample points", count(glossy.len()), count(frame.sps.len()), count(samples.points.len()));
    Ok(vec![
        Disagreement::at_most("interpolate / glossy", "relMSE(GPU, CPU) of the glossy last bounce on the same samples", rel_mse(&cpu, &gpu), SHADE_REL_MSE)
            .with_case(&case)
            .with_worst(at),
        Disagreement::info("interpolate / glossy", "largest relative difference at a glossy shading point", worst as f64).with_case(case),
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
    if cfg.gi == Gi::Photon && twins.cpu.scene.materials.iter().any(|m| m.surface.is_glossy()) {
        r.checks.extend(compare_glossy(twins, &cfg, &frame)?);
    }
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
