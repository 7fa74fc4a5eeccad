//! `rsm_vpls`: the GPU's reflective-shadow-map VPLs against the CPU's, texel by texel (the
//! trace_vpls row of the SPEC: positions, normals and fluxes within 1e-4 relative; at most 0.1 %
//! of texels may differ at grazing hits, counted; a texel whose ray meets a shared edge, or the
//! line where two triangles cross, may land on either triangle, counted apart as a tie). Texels
//! whose rays passed mirrors or glass are judged apart, as `trace_vpls`'s paths are.

use crate::tolerance::{chain_rows, Disagreement, Diverged, TRACE_VPLS_DIVERGED_PATHS, TRACE_VPLS_REL};
use crate::trace_vpls::{difference, on_an_edge, on_two_triangles};
use crate::map::{DisagreementMap, ItemKind, Placed};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::Vec3;
use std::collections::BTreeMap;
use vplgi_gpu::buffers::read_back;
use vplgi_types::{RsmParams, Vpl};

/// Both backends' VPLs of the maps of `params` (texel order).
pub fn both(twins: &Twins, params: &RsmParams) -> Result<(Vec<Vpl>, Vec<Vpl>, u32), VerifyError> {
    let cpu = vplgi_cpu::rsm_vpls::rsm_vpls(twins.cpu, params, &vplgi_cpu::NoProgress);
    let maps = twins.gpu.scene().sampler.rsm_maps(params.size);
    let g = twins.gpu.kernels().rsm_vpls.run(twins.device(), twins.queue(), twins.gpu.scene(), &maps, params)?;
    let gpu: Vec<Vpl> = read_back(twins.device(), twins.queue(), &g.buffer, g.count as usize)?;
    Ok((cpu.vpls, gpu, cpu.particles))
}

/// Compares the texels of the maps of `params`.
pub fn compare(twins: &Twins, params: &RsmParams) -> Result<Vec<Disagreement>, VerifyError> {
    compare_mapped(twins, params, &mut Vec::new())
}


/// [`compare`], adding to `parted` where each texel's VPLs that differ lie (the CPU's, or the
/// GPU's where the CPU has none), as a tie or not.
fn compare_mapped(twins: &Twins, params: &RsmParams, parted: &mut Placed) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu, texels) = both(twins, params)?;
    let extent = twins.cpu.extent;
    let (c, g): (BTreeMap<u32, Vpl>, BTreeMap<u32, Vpl>) = (cpu.iter().map(|v| (v.path, *v)).collect(), gpu.iter().map(|v| (v.path, *v)).collect());
    let (mut differ, mut ties, mut max_agreeing, mut worst_diff, mut worst) = (0usize, 0usize, 0.0f32, 0.0f32, None);
    let eps = TRACE_VPLS_REL as f32 * extent;
    let maps = twins.cpu.lights.rsm_maps(params.size);
    // Whether the CPU, texel t's ray nudged as a camera chain's is
    // (`crate::shading_points::Nudge`), makes the GPU's VPL `gpu` (or none where it has none).
    let nudge_reaches = |t: u32, gpu: Option<&Vpl>| {
        let Some(ray) = vplgi_shared::rsm::texel_ray(&maps[vplgi_shared::rsm::map_of(&maps, t)], t) else {
            return false;
        };
        crate::shading_points::nudged(ray.dir).any(|dir| {
            let cpu = vplgi_cpu::rsm_vpls::follow_texel(twins.cpu, &vplgi_shared::rsm::TexelRay { dir, ..ray }, t, params);
            match (cpu, gpu) {
                (Some(x), Some(y)) => difference(&x, y, extent, (1.0, 1.0)) <= TRACE_VPLS_REL as f32,
                (None, None) => true,
                _ => false,
            }
        })
    };
    // By the most mirrors and glass either backend's ray passed: one, more.
    let mut chains: [Diverged; 2] = Default::default();
    for t in c.keys().chain(g.keys().filter(|t| !c.contains_key(t))) {
        let (a, b) = (c.get(t), g.get(t));
        let d = match (a, b) {
            (Some(x), Some(y)) => difference(x, y, extent, (1.0, 1.0)),
            _ => f32::INFINITY,
        };
        let chain = match a.iter().chain(&b).map(|v| v.specular).max().unwrap_or(0) {
            0 => None,
            1 => Some(&mut chains[0]),
            _ => Some(&mut chains[1]),
        };
        if let Some(chain) = chain {
            // The tie tests below look at the VPLs alone, and a chained ray may part at an
            // edge of the mirror before them: chained texels are judged by their own bound.
            chain.items += 1;
            if d > TRACE_VPLS_REL as f32 && nudge_reaches(*t, b) {
                chain.nudged += 1;
                if let Some(v) = a.or(b) {
                    parted.push((Vec3::from(v.position), ItemKind::Tie));
                }
            } else if d > TRACE_VPLS_REL as f32 {
                if let Some(v) = a.or(b) {
                    parted.push((Vec3::from(v.position), ItemKind::Other));
                }
                chain.diverge(d, || format!("texel {t}: CPU {}, GPU {}", show(a), show(b)));
            } else {
                max_agreeing = max_agreeing.max(d);
            }
            continue;
        }
        if d <= TRACE_VPLS_REL as f32 {
            max_agreeing = max_agreeing.max(d);
            continue;
        }
        // The same point where two triangles meet (a shared edge, or where one passes through
        // the other: the other triangle gave another normal or albedo), or a VPL on an edge on
        // one side only: the shading-points row's tie. On one triangle alone the same point with
        // another flux is a difference, not a tie.
        let tie = match (a, b) {
            (Some(x), Some(y)) if (Vec3::from(x.position) - Vec3::from(y.position)).length() <= eps => on_two_triangles(twins.scene, Vec3::from(x.position), eps),
            // Two points, one on an edge: the ray touched a ridge at one point, a hit one
            // backend counts and the other passes.
            (Some(x), Some(y)) => [x, y].iter().any(|v| on_an_edge(twins.scene, Vec3::from(v.position), eps)),
            (Some(x), None) | (None, Some(x)) => on_an_edge(twins.scene, Vec3::from(x.position), eps),
            (None, None) => false,
        };
        // A ray that grazes a silhouette or meets a mirror on one side only parts by rounding
        // the tests above cannot see: a texel that parts is nudged too.
        let tie = tie || nudge_reaches(*t, b);
        if let Some(v) = a.or(b) {
            parted.push((Vec3::from(v.position), if tie { ItemKind::Tie } else { ItemKind::Other }));
        }
        if tie {
            ties += 1;
            continue;
        }
        differ += 1;
        if d > worst_diff || worst.is_none() {
            worst_diff = d;
            worst = Some(format!("texel {t}: CPU {}, GPU {}", show(a), show(b)));
        }
    }
    let case = format!("--rsm-size {}: {} texels, {} VPLs on the CPU", params.size, count(texels as usize), count(cpu.len()));
    let direct = (texels as usize).saturating_sub(chains[0].items + chains[1].items);
    let mut rows = vec![
        crate::tolerance::share_of_diverged(
            "rsm_vpls",
            "texels whose VPLs differ (of those whose rays pass no mirror or glass)",
            (differ, direct),
            TRACE_VPLS_DIVERGED_PATHS,
        )
        .with_case(&case)
        .with_worst(worst),
        Disagreement::info(
            "rsm_vpls",
            "texels that part at a tie (the same point where two triangles meet; a VPL on an edge, on one side or beside another point; or the CPU's ray nudged makes the GPU's VPL)",
            ties as f64,
        )
        .with_case(&case),
        Disagreement::info("rsm_vpls", "largest relative difference on agreeing texels", max_agreeing as f64).with_case(&case),
        Disagreement::info("rsm_vpls", "VPL count, |CPU - GPU|", cpu.len().abs_diff(gpu.len()) as f64).with_case(&case),
    ];
    rows.extend(chain_rows(
        "rsm_vpls",
        &case,
        chains,
        |label| format!("texels whose rays pass {label} and whose VPLs differ"),
        |label| format!("texels whose rays pass {label} and part where the CPU, the ray nudged, makes the GPU's VPL (set aside as ties)"),
    ));
    Ok(rows)
}

/// A texel's VPL on one backend, described.
fn show(v: Option<&Vpl>) -> String {
    v.map_or("none".to_string(), |v| match v.specular {
        0 => format!("at {} flux {}", v3(v.position), v3(v.flux)),
        n => format!("at {} flux {} through {n} specular", v3(v.position), v3(v.flux)),
    })
}

/// The reflective shadow maps of the frame's `--rsm-size` (whatever its VPL source).
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::RsmVpls);
    let mut parted = Vec::new();
    r.checks = compare_mapped(twins, &cfg.rsm_params(), &mut parted)?;
    // The texels whose VPLs differ, seen from the camera.
    r.maps.push(DisagreementMap::projected("rsm_vpls", &twins.scene.camera, (cfg.width, cfg.height), &parted));
    r.notes.push(
        "VPLs are matched by texel; a texel agrees when both backends have a VPL within 1e-4 (position relative to the scene extent, normal, flux relative \
         to its largest channel) or neither has one. A texel whose VPLs lie at the same point where two triangles meet (a shared edge or a crossing: another triangle there), \
         or that has a VPL on an edge (on one side only, or beside the other's elsewhere), is a tie, counted apart; so is one where the CPU, the texel's ray turned by 1e-5 rad \
         or less, makes the GPU's VPL"
            .into(),
    );
    Ok(r)
}
