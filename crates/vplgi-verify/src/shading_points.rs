//! `shading_points`: the GPU's camera samples against the CPU's (SPEC: >= 99.9 % hit the same
//! triangle; positions within 1e-4 of the scene extent).

use crate::tolerance::{shading_points_same_emission_share, Disagreement, SHADING_POINTS_POSITION_REL, SHADING_POINTS_SAME_SURFACE};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage};
use glam::Vec3;
use vplgi_types::{CameraParams, FrameConfig, ShadingPoint};

/// How two backends' shading points of the same samples differ.
#[derive(Clone, Debug, Default)]
pub struct HitDifferences {
    pub samples: usize,
    /// Same triangle (or both missed).
    pub same: usize,
    /// Another triangle at the same point (within 1e-5 of the extent): a ray through an edge two
    /// triangles share may legitimately return either.
    pub ties: usize,
    /// Everything else: another surface, or a hit against a miss.
    pub other: usize,
    /// The first sample that differs beyond a tie, described.
    pub first_other: Option<String>,
    /// Largest position difference over the extent among samples on the same triangle, and where.
    pub max_position: f32,
    pub max_position_at: Option<String>,
    /// The same, each difference times the cosine between the camera ray and the surface normal,
    /// and where. A ray that grazes a surface at angle theta to it slides along it by about
    /// 1 / sin theta times any rounding of its direction (CPU and GPU round the camera ray
    /// differently in the last bit): this is the disagreement with that slide divided out, the
    /// same as the raw one wherever rays meet surfaces at a sensible angle.
    pub max_position_conditioned: f32,
    pub max_position_conditioned_at: Option<String>,
    /// Of the `same` samples, those whose emitted radiance agrees (within 1e-6, relative above 1).
    /// Misses count too: at spp > 1 a sample's emission is its pixel's, from 4 x 4 extra rays, so
    /// a sample that misses may carry some, and one of those rays through a shared edge may see
    /// the emitter on one backend only (a step of 1/16).
    pub same_emission: usize,
    /// Largest emitted-radiance difference among the `same` samples that disagree, and where.
    pub max_emitted: f32,
    pub max_emitted_at: Option<String>,
}

fn describe(i: usize, width: u32, spp: u32, c: &ShadingPoint, g: &ShadingPoint) -> String {
    let px = i as u32 / spp;
    let show = |s: &ShadingPoint| if s.is_miss() { "a miss".to_string() } else { format!("triangle {} at {}", s.triangle, v3(s.position)) };
    format!("sample {i} (pixel {}, {}): CPU {}, GPU {}", px % width, px / width, show(c), show(g))
}

/// Classifies every sample's pair of shading points; `eye` is the camera's position.
pub fn hit_differences(cpu: &[ShadingPoint], gpu: &[ShadingPoint], extent: f32, eye: Vec3, (width, spp): (u32, u32)) -> HitDifferences {
    let mut d = HitDifferences { samples: cpu.len(), ..Default::default() };
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        let apart = (Vec3::from(c.position) - Vec3::from(g.position)).length() / extent;
        if c.triangle == g.triangle {
            d.same += 1;
            let emitted = (Vec3::from(c.emitted) - Vec3::from(g.emitted)).abs().max_element();
            if emitted <= 1e-6 * Vec3::from(c.emitted).max_element().max(1.0) {
                d.same_emission += 1;
            } else if emitted > d.max_emitted {
                d.max_emitted = emitted;
                d.max_emitted_at = Some(format!("{}: emitted CPU {}, GPU {}", describe(i, width, spp, c, g), v3(c.emitted), v3(g.emitted)));
            }
            if c.is_miss() {
                continue;
            }
            if apart > d.max_position {
                d.max_position = apart;
                d.max_position_at = Some(describe(i, width, spp, c, g));
            }
            let cos = Vec3::from(c.normal).dot((Vec3::from(c.position) - eye).normalize_or_zero()).abs();
            if apart * cos > d.max_position_conditioned {
                d.max_position_conditioned = apart * cos;
                d.max_position_conditioned_at = Some(format!("{} (cosine of incidence {cos:.2e})", describe(i, width, spp, c, g)));
            }
        } else if !c.is_miss() && !g.is_miss() && apart <= 1e-5 {
            d.ties += 1;
        } else {
            d.other += 1;
            d.first_other.get_or_insert_with(|| describe(i, width, spp, c, g));
        }
    }
    d.other += cpu.len().abs_diff(gpu.len());
    d
}

/// The shading points of `camera` on both backends.
pub fn both(twins: &Twins, camera: &CameraParams) -> Result<(Vec<ShadingPoint>, Vec<ShadingPoint>), VerifyError> {
    let cpu = vplgi_cpu::shading_points::shading_points(twins.cpu, camera.width, camera.height, camera.spp, camera.seed);
    let gpu = twins.gpu.kernels().shading_points.run(twins.device(), twins.queue(), twins.gpu.scene(), camera, None)?;
    Ok((cpu, gpu))
}

/// Shades nothing: traces `camera`'s samples on both backends and compares them.
pub fn compare(twins: &Twins, camera: &CameraParams) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu) = both(twins, camera)?;
    let d = hit_differences(&cpu, &gpu, twins.cpu.extent, twins.scene.camera.position, (camera.width, camera.spp));
    let n = d.samples.max(1) as f64;
    let case = format!("{}x{}, {} spp", camera.width, camera.height, camera.spp);
    let mut albedo = 0.0f32;
    for (c, g) in cpu.iter().zip(&gpu).filter(|(c, g)| c.triangle == g.triangle && !c.is_miss()) {
        albedo = albedo.max((Vec3::from(c.albedo) - Vec3::from(g.albedo)).abs().max_element());
    }
    Ok(vec![
        Disagreement::at_least("shading_points", "share of samples on the same surface point", (d.same + d.ties) as f64 / n, SHADING_POINTS_SAME_SURFACE)
            .with_case(&case)
            .with_worst(d.first_other.clone()),
        Disagreement::at_most(
            "shading_points",
            "position difference / scene extent, times the cosine of incidence",
            d.max_position_conditioned as f64,
            SHADING_POINTS_POSITION_REL,
        )
        .with_case(&case)
        .with_worst(d.max_position_conditioned_at.clone()),
        Disagreement::info("shading_points", "position difference / scene extent, raw (large only at grazing incidence)", d.max_position as f64)
            .with_case(&case)
            .with_worst(d.max_position_at.clone()),
        Disagreement::info("shading_points", "samples on another triangle at the same point (edge ties)", d.ties as f64).with_case(&case),
        Disagreement::info("shading_points", "largest albedo difference", albedo as f64).with_case(&case),
        // Emission otherwise reaches only the frame rows, where a 1 % error on an emitter's pixels
        // passed (relMSE far below the bound).
        Disagreement::at_least(
            "shading_points",
            "share of samples on the same triangle (or both missing) with the same emitted radiance",
            d.same_emission as f64 / d.same.max(1) as f64,
            shading_points_same_emission_share(camera.spp),
        )
        .with_case(&case)
        .with_worst(d.max_emitted_at.clone()),
        Disagreement::info("shading_points", "largest emitted-radiance difference among them", d.max_emitted as f64).with_case(&case),
    ])
}

/// The frame's camera samples.
pub fn verify(twins: &Twins, cfg: &FrameConfig) -> Result<StageResult, VerifyError> {
    let mut r = result(VerifyStage::ShadingPoints);
    r.checks = compare(twins, &cfg.camera_params(twins.scene.camera))?;
    r.notes.push(format!(
        "{} samples; a ray through an edge shared by two triangles may return either (same point, another triangle): counted as agreement, and reported. \
         Positions are judged with each difference times the cosine between the camera ray and the surface: a ray grazing a surface slides along it by \
         1 / cosine times the last-bit rounding of its direction, which the backends do differently (make verify-long met a hit at cosine 1.9e-4, 1.06e-4 \
         of the extent apart); the raw difference is reported",
        count((cfg.width * cfg.height * cfg.spp) as usize)
    ));
    Ok(r)
}
