//! `bias_points`: the GPU's compensation points of the CPU's shading points against the CPU's
//! (SPEC: the shading-point bound on surfaces, ties on shared edges counted as agreement;
//! weights within `BIAS_POINTS_WEIGHT_ABS` of what the CPU's arithmetic gives at the GPU's point).

use crate::map::DisagreementMap;
use crate::shading_points::hit_differences;
use crate::tolerance::{Disagreement, BIAS_POINTS_WEIGHT_ABS, SHADING_POINTS_SAME_SURFACE};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::Vec3;
use vplgi_frame::prelude::*;
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_types::{BiasParams, ShadingPoint};

/// One compensation level on both backends, from the same parents (camera samples `0 ..`).
pub fn both(twins: &Twins, parents: &[ShadingPoint], params: &BiasParams) -> Result<(Vec<ShadingPoint>, Vec<ShadingPoint>), VerifyError> {
    let cpu = vplgi_cpu::bias_points::bias_points(twins.cpu, parents, 0, params);
    let n = parents.len() as u32;
    let on_device = storage(twins.device(), "parents", parents);
    let out = twins.gpu.bias_points(&on_device, 0..n, params)?;
    let gpu = read_back::<ShadingPoint>(twins.device(), twins.queue(), &out, n as usize)?;
    Ok((cpu, gpu))
}

/// Compares one level's compensation points of `parents` (of an image `width` wide with `spp`
/// samples per pixel, for naming items).
pub fn compare(twins: &Twins, parents: &[ShadingPoint], (width, spp): (u32, u32), params: &BiasParams) -> Result<Vec<Disagreement>, VerifyError> {
    compare_mapped(twins, parents, (width, spp), params, None)
}

/// [`compare`], marking each compensation point's pixel in `map` by how it compares.
fn compare_mapped(
    twins: &Twins,
    parents: &[ShadingPoint],
    (width, spp): (u32, u32),
    params: &BiasParams,
    map: Option<&mut DisagreementMap>,
) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu) = both(twins, parents, params)?;
    if let Some(map) = map {
        map.mark_points(&cpu, &gpu, &crate::shading_points::judge(twins, None));
    }
    let d = hit_differences(&cpu, &gpu, twins.cpu.extent, twins.scene.camera.position, (width, spp), None);
    let kept = cpu.iter().filter(|p| !p.is_miss()).count();
    let (mut weight, mut worst, mut raw, mut raw_at, mut other) = (0.0f64, None, 0.0f32, None, 0usize);
    for (i, ((c, g), parent)) in cpu.iter().zip(&gpu).zip(parents).enumerate() {
        if c.pixel != g.pixel || g.emitted != [0.0; 3] {
            other += 1;
        }
        if c.triangle == g.triangle && !c.is_miss() {
            let diff = (Vec3::from(c.albedo) - Vec3::from(g.albedo)).abs().max_element();
            if diff > raw {
                raw = diff;
                raw_at = Some(format!("sample {i}: CPU weight {}, GPU {}", v3(c.albedo), v3(g.albedo)));
            }
            // The weight the CPU's arithmetic gives at the GPU's point: the share moves with
            // the pair's distance, so the hit's rounding (judged by the position row) would
            // otherwise count twice, and most where surfaces nearly touch.
            let surface = twins.cpu.scene.materials[parent.material as usize].surface;
            let (p, n) = (Vec3::from(parent.position), Vec3::from(parent.normal));
            // A glossy parent's lobe at each backend's own sampled direction (the point's view
            // back to p): a peak of GGX α turns a direction's rounding δ into about δ / α of the
            // lobe, more than the hit's rounding moves the share.
            let share = |y: &ShadingPoint| {
                let y_pos = Vec3::from(y.position);
                let lobe = surface.lobe(n, Vec3::from(parent.view), -Vec3::from(y.view));
                vplgi_cpu::bias_points::clamped_share(p, n, y_pos, Vec3::from(y.normal), params.g_max, lobe) as f64
            };
            let (at_cpu, at_gpu) = (share(c), share(g));
            if at_cpu > 0.0 {
                let diff = (0..3).map(|k| (c.albedo[k] as f64 * at_gpu / at_cpu - g.albedo[k] as f64).abs()).fold(0.0, f64::max);
                if diff > weight {
                    weight = diff;
                    worst = Some(format!(
                        "sample {i}: CPU arithmetic at the GPU's point {}, GPU {}",
                        v3(c.albedo.map(|a| (a as f64 * at_gpu / at_cpu) as f32)),
                        v3(g.albedo)
                    ));
                }
            }
        }
    }
    let case = format!("{} parents, {} kept on the CPU, seed {}", count(parents.len()), count(kept), params.seed);
    Ok(vec![
        Disagreement::at_least(
            "bias_points",
            "share of compensation points on the same surface point",
            d.same_surface_share(),
            SHADING_POINTS_SAME_SURFACE,
        )
        .with_case(&case)
        .with_worst(d.first_other.clone()),
        Disagreement::at_most(
            "bias_points",
            "largest weight difference at the GPU's point (albedo x parent albedo x clamped share)",
            weight,
            BIAS_POINTS_WEIGHT_ABS,
        )
        .with_case(&case)
        .with_worst(worst),
        Disagreement::info("bias_points", "largest weight difference, raw (moves with the hit's rounding, most where surfaces nearly touch)", raw as f64)
            .with_case(&case)
            .with_worst(raw_at),
        Disagreement::at_most("bias_points", "points with another pixel or with emission", other as f64, 0.0).with_case(&case),
        Disagreement::info("bias_points", "compensation points on another triangle at the same point (edge ties)", d.ties as f64).with_case(&case),
    ])
}

/// The frame's camera samples (the CPU's) and their first two compensation levels, with the
/// frame's clamp.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::BiasPoints);
    let camera = cfg.camera_params(twins.scene.camera);
    let mut parents = vplgi_cpu::shading_points::shading_points(twins.cpu, &camera);
    for level in 1..=cfg.bounces.min(2) {
        let params = cfg.bias_params(twins.cpu.extent, level);
        let mut map = DisagreementMap::new(format!("bias_points-level{level}"), camera.width, camera.height);
        r.checks.extend(compare_mapped(twins, &parents, (camera.width, camera.spp), &params, Some(&mut map))?);
        r.maps.push(map);
        parents = vplgi_cpu::bias_points::bias_points(twins.cpu, &parents, 0, &params);
    }
    r.notes.push(format!(
        "levels 1 and 2 of the geometry-term clamp's bias compensation from the frame's {} camera samples (the GPU fed the CPU's points of the level \
         before), with the frame's clamp (d_min = {} of the scene's diagonal); a point is kept where the clamp bites. Weights are compared absolutely: \
         where G barely exceeds g_max the clamped share is near 0 and its relative rounding large",
        count(parents.len()),
        cfg.g_clamp_rel
    ));
    Ok(r)
}
