//! The whole frame, each backend chaining its own stages: judged where the chain cannot move the
//! result (the unclustered frame, on pixels whose primary hits agree), measured and explained
//! where it can (a clustering from inputs that differ by rounding may take another trajectory:
//! measured on the generated rooms, relMSE 2e-4 to 2e-3 in `--cluster vpl`).

use crate::map::{DisagreementMap, ItemKind};
use crate::shade::{rel_mse, worst_pixel};
use crate::shading_points::{hit_differences, HitDifferences};
use crate::tolerance::{Disagreement, SHADE_REL_MSE, SHADING_POINTS_SAME_SURFACE};
use crate::{count, result, ImagePair, Mode, Plan, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_types::{ClusterMode, FrameConfig, ShadingPoint, VplSource};

/// What the modes of one frame share: both backends' primary hits, and how far the VPLs differ
/// by rounding (measured only if some mode clusters them).
struct Shared {
    c_sp: Vec<ShadingPoint>,
    g_sp: Vec<ShadingPoint>,
    hits: HitDifferences,
    vpl_rounding: Option<f64>,
}

impl Shared {
    fn new(twins: &Twins, cfg: &FrameConfig, modes: &[Mode]) -> Result<Shared, VerifyError> {
        let (c_sp, g_sp) =
            crate::shading_points::both(twins, &cfg.camera_params(twins.scene.camera))?;
        let hits = hit_differences(
            &c_sp,
            &g_sp,
            twins.cpu.extent,
            twins.scene.camera.position,
            (cfg.width, cfg.spp),
            None,
        );
        let vpl_rounding = if modes.iter().any(|m| m.cluster.clusters_vpls()) {
            let checks = match cfg.vpl_source {
                VplSource::Paths => crate::trace_vpls::compare(twins, &cfg.trace_params())?,
                VplSource::Rsm => crate::rsm_vpls::compare(twins, &cfg.rsm_params())?,
            };
            Some(
                checks
                    .into_iter()
                    .find(|c| c.what.starts_with("largest relative difference"))
                    .map_or(f64::NAN, |c| c.measured),
            )
        } else {
            None
        };
        Ok(Shared { c_sp, g_sp, hits, vpl_rounding })
    }
}

/// One mode's frame on both backends.
fn compare(
    twins: &Twins,
    cfg: &FrameConfig,
    shared: &Shared,
) -> Result<(Vec<Disagreement>, Vec<String>, ImagePair, DisagreementMap), VerifyError> {
    let cpu = vplgi_frame::render(twins.cpu, cfg, &vplgi_frame::NoProgress)?;
    let gpu = vplgi_frame::render(twins.gpu, cfg, &vplgi_frame::NoProgress)?;
    let Shared { c_sp, g_sp, hits, vpl_rounding } = shared;
    let mode = Mode::of(cfg);
    let case = mode.name();
    let spp = cfg.spp as usize;
    // Pixels all of whose samples hit the same triangle on both backends.
    let agree: Vec<bool> = (0..cpu.pixels.len())
        .map(|p| (p * spp..(p + 1) * spp).all(|s| c_sp[s].triangle == g_sp[s].triangle))
        .collect();
    let pick = |img: &[[f32; 3]]| -> Vec<[f32; 3]> {
        img.iter().zip(&agree).filter(|(_, a)| **a).map(|(p, _)| *p).collect()
    };
    let (c_agree, g_agree) = (pick(&cpu.pixels), pick(&gpu.pixels));
    let whole = rel_mse(&cpu.pixels, &gpu.pixels);
    let same_surface = hits.same_surface_share();
    let mut checks = vec![Disagreement::at_least(
        "frame",
        "share of primary hits on the same surface point (of those seeing no mirror or glass)",
        same_surface,
        SHADING_POINTS_SAME_SURFACE,
    )
    .with_case(&case)
    .with_worst(hits.first_other.clone())];
    let mut notes = Vec::new();
    let (_, worst) = worst_pixel(&cpu.pixels, &gpu.pixels, cfg.width, |i| agree[i]);
    let agreeing = rel_mse(&c_agree, &g_agree);
    let what = "relMSE(GPU, CPU) on pixels whose primary hits agree";
    checks.push(if mode.cluster == ClusterMode::None {
        Disagreement::at_most("frame", what, agreeing, SHADE_REL_MSE)
            .with_case(&case)
            .with_worst(worst)
    } else {
        Disagreement::info("frame", what, agreeing).with_case(&case).with_worst(worst)
    });
    checks
        .push(Disagreement::info("frame", "relMSE(GPU, CPU), whole image", whole).with_case(&case));
    if hits.ties > 0 {
        notes.push(format!(
            "{case}: {} of {} primary hits land on another triangle at the same point (a ray through a shared edge), and those pixels shade another surface",
            count(hits.ties),
            count(hits.samples)
        ));
    }
    // A clustering is k-means from each backend's own points, and its trajectory can part on the
    // smallest difference of its input, so clustered frames are explained here, and judged by
    // the shade stage on identical inputs.
    let mut inputs = Vec::new();
    if let (true, Some(rounding)) = (mode.cluster.clusters_vpls(), vpl_rounding) {
        inputs.push(format!("the VPLs differ by rounding (largest {rounding:.1e}, relative)"));
    }
    if mode.cluster.clusters_sps() {
        inputs.push(format!(
            "the shading points differ by rounding (largest {:.1e} of the extent) and {} of them sit on another triangle (other normals)",
            hits.max_position,
            count(hits.ties)
        ));
    }
    if !inputs.is_empty() {
        notes.push(format!(
            "{case}: {}: k-means may follow another trajectory from such inputs, and the images then differ by as much as two clusterings do. \
             Measured, not judged; the shade stage judges this mode on identical inputs.",
            inputs.join("; ")
        ));
    }
    checks.push(
        Disagreement::info("frame", "clusters, |CPU - GPU| (VPL + shading point)", {
            let d = |a: u32, b: u32| (a as f64 - b as f64).abs();
            d(cpu.stats.vpl_clusters, gpu.stats.vpl_clusters)
                + d(cpu.stats.sp_clusters, gpu.stats.sp_clusters)
        })
        .with_case(&case),
    );
    // Where the image is judged (the unclustered mode), pixels beyond its bound on their own;
    // the primary hits, which every mode shares, have their own map (`verify`).
    let name = format!("frame-{}", case.replace('/', "-"));
    let mut map = DisagreementMap::new(name.clone(), cfg.width, cfg.height);
    if mode.cluster == ClusterMode::None {
        for i in (0..cpu.pixels.len().min(gpu.pixels.len())).filter(|&i| agree[i]) {
            if crate::shade::pixel_beyond(&cpu.pixels, &gpu.pixels, i) {
                map.mark(i, ItemKind::Beyond);
            }
        }
    }
    let pair = ImagePair {
        case: name,
        width: cfg.width,
        height: cfg.height,
        cpu: cpu.pixels,
        gpu: gpu.pixels,
    };
    Ok((checks, notes, pair, map))
}

/// The frame of every mode in `modes`.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let (cfg, modes) = (&plan.config, &plan.modes[..]);
    let mut r = result(VerifyStage::Frame);
    let shared = Shared::new(twins, cfg, modes)?;
    let mut hits = DisagreementMap::new("frame-primary-hits", cfg.width, cfg.height);
    let camera = cfg.camera_params(twins.scene.camera);
    hits.mark_points(
        &shared.c_sp,
        &shared.g_sp,
        &crate::shading_points::judge(twins, Some(&camera)),
    );
    r.maps.push(hits);
    for mode in modes {
        let (checks, notes, pair, map) = compare(twins, &mode.apply(cfg), &shared)?;
        r.checks.extend(checks);
        r.notes.extend(notes);
        r.images.push(pair);
        r.maps.push(map);
    }
    Ok(r)
}
