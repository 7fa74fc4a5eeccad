//! The whole frame, each backend chaining its own stages: judged where the chain cannot move the
//! result (modes that do not cluster shading points, on pixels whose primary hits agree), measured
//! and explained elsewhere.

use crate::shade::{rel_mse, worst_pixel};
use crate::shading_points::hit_differences;
use crate::tolerance::{Disagreement, SHADE_REL_MSE, SHADING_POINTS_SAME_SURFACE};
use crate::{count, result, ImagePair, Mode, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_types::FrameConfig;

/// One mode's frame on both backends.
pub fn compare(twins: &Twins, cfg: &FrameConfig) -> Result<(Vec<Disagreement>, Vec<String>, ImagePair), VerifyError> {
    let cpu = vplgi_frame::render(twins.cpu, cfg, &vplgi_frame::NoProgress)?;
    let gpu = vplgi_frame::render(twins.gpu, cfg, &vplgi_frame::NoProgress)?;
    let (c_sp, g_sp) = crate::shading_points::both(twins, &cfg.camera_params())?;
    let hits = hit_differences(&c_sp, &g_sp, twins.cpu.extent, cfg.width, cfg.spp);
    let mode = Mode::of(cfg);
    let case = mode.name();
    let spp = cfg.spp as usize;
    // Pixels all of whose samples hit the same triangle on both backends.
    let agree: Vec<bool> = (0..cpu.pixels.len()).map(|p| (p * spp..(p + 1) * spp).all(|s| c_sp[s].triangle == g_sp[s].triangle)).collect();
    let pick = |img: &[[f32; 3]]| -> Vec<[f32; 3]> { img.iter().zip(&agree).filter(|(_, a)| **a).map(|(p, _)| *p).collect() };
    let (c_agree, g_agree) = (pick(&cpu.pixels), pick(&gpu.pixels));
    let whole = rel_mse(&cpu.pixels, &gpu.pixels);
    let same_surface = (hits.same + hits.ties) as f64 / hits.samples.max(1) as f64;
    let mut checks = vec![Disagreement::at_least("frame", "share of primary hits on the same surface point", same_surface, SHADING_POINTS_SAME_SURFACE)
        .with_case(&case)
        .with_worst(hits.first_other.clone())];
    let mut notes = Vec::new();
    if mode.cluster.clusters_sps() {
        let (_, worst) = worst_pixel(&cpu.pixels, &gpu.pixels, cfg.width, |_| true);
        checks.push(Disagreement::info("frame", "relMSE(GPU, CPU), whole image", whole).with_case(&case).with_worst(worst));
        notes.push(format!(
            "{case}: the shading points are clustered from each backend's own hits. {} of {} primary hits land on another triangle at the same point \
             (a ray through a shared edge), so their normals differ, and positions differ by rounding (largest {:.1e} of the extent): k-means \
             may follow another trajectory, and the images differ by as much as two clusterings do. Not judged here; the shade stage judges this mode on identical inputs.",
            count(hits.ties),
            count(hits.samples),
            hits.max_position
        ));
    } else {
        let (_, worst) = worst_pixel(&cpu.pixels, &gpu.pixels, cfg.width, |i| agree[i]);
        checks.push(
            Disagreement::at_most("frame", "relMSE(GPU, CPU) on pixels whose primary hits agree", rel_mse(&c_agree, &g_agree), SHADE_REL_MSE)
                .with_case(&case)
                .with_worst(worst),
        );
        checks.push(Disagreement::info("frame", "relMSE(GPU, CPU), whole image", whole).with_case(&case));
        if hits.ties > 0 {
            notes.push(format!(
                "{case}: {} of {} primary hits land on another triangle at the same point (a ray through a shared edge), and those pixels shade another surface; they are left out of the judged relMSE",
                count(hits.ties),
                count(hits.samples)
            ));
        }
    }
    checks.push(
        Disagreement::info("frame", "clusters, |CPU - GPU| (VPL + shading point)", {
            let d = |a: u32, b: u32| (a as f64 - b as f64).abs();
            d(cpu.stats.vpl_clusters, gpu.stats.vpl_clusters) + d(cpu.stats.sp_clusters, gpu.stats.sp_clusters)
        })
        .with_case(&case),
    );
    let pair = ImagePair { case: format!("frame-{}", case.replace('/', "-")), width: cfg.width, height: cfg.height, cpu: cpu.pixels, gpu: gpu.pixels };
    Ok((checks, notes, pair))
}

/// The frame of every mode in `modes`.
pub fn verify(twins: &Twins, cfg: &FrameConfig, modes: &[Mode]) -> Result<StageResult, VerifyError> {
    let mut r = result(VerifyStage::Frame);
    for mode in modes {
        let (checks, notes, pair) = compare(twins, &mode.apply(cfg))?;
        r.checks.extend(checks);
        r.notes.extend(notes);
        r.images.push(pair);
    }
    Ok(r)
}
