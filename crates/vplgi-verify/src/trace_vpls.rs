//! `trace_vpls`: the GPU's VPLs against the CPU's (SPEC: same count; positions, normals and
//! fluxes within 1e-4 relative; at most 0.1 % of paths diverge, counted).

use crate::tolerance::{chain_rows, Disagreement, Diverged, TRACE_VPLS_DIVERGED_PATHS, TRACE_VPLS_REL};
use crate::map::{DisagreementMap, ItemKind, Placed};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::Vec3;
use std::collections::{BTreeMap, BTreeSet};
use vplgi_gpu::buffers::read_back;
use vplgi_types::{TraceParams, Vpl};

/// The VPLs of each light path, in order.
fn by_path(v: &[Vpl]) -> BTreeMap<u32, Vec<Vpl>> {
    let mut m: BTreeMap<u32, Vec<Vpl>> = BTreeMap::new();
    for x in v {
        m.entry(x.path).or_default().push(*x);
    }
    m
}

/// The largest relative difference between two VPLs: position over the scene extent, normal,
/// flux per particle (each side's flux times its own particle count) over its largest channel;
/// infinite if they are at different bounces.
pub(crate) fn difference(a: &Vpl, b: &Vpl, extent: f32, (pa, pb): (f32, f32)) -> f32 {
    if a.bounce != b.bounce {
        return f32::INFINITY;
    }
    let pos = (Vec3::from(a.position) - Vec3::from(b.position)).length() / extent;
    let nor = (Vec3::from(a.normal) - Vec3::from(b.normal)).length();
    let (fa, fb) = (Vec3::from(a.flux) * pa, Vec3::from(b.flux) * pb);
    let flux = (fa - fb).abs().max_element() / fa.abs().max_element().max(1e-12);
    pos.max(nor).max(flux)
}

/// Whether `p` lies within `eps` of an edge of one of `scene`'s triangles: where a ray through a
/// shared edge may go to either triangle.
pub(crate) fn on_an_edge(scene: &vplgi_scene::Scene, p: Vec3, eps: f32) -> bool {
    let near_segment = |a: Vec3, b: Vec3| {
        let ab = b - a;
        let t = ((p - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        (a + ab * t - p).length() <= eps
    };
    scene.indices.iter().any(|t| {
        let [a, b, c] = t.map(|i| scene.positions[i as usize]);
        near_segment(a, b) || near_segment(b, c) || near_segment(c, a)
    })
}

/// Whether `p` lies within `eps` of two of `scene`'s triangles: on an edge they share, or on the
/// line where one passes through the other. A ray to such a point may reach either first, and
/// rounding decides which.
pub(crate) fn on_two_triangles(scene: &vplgi_scene::Scene, p: Vec3, eps: f32) -> bool {
    let p = p.as_dvec3();
    let near = |t: &[u32; 3]| crate::segment::point_triangle_distance(p, &t.map(|i| scene.positions[i as usize].as_dvec3())) <= eps as f64;
    scene.indices.iter().filter(|t| near(t)).nth(1).is_some()
}

/// Traces `params` on both backends and compares path by path. A path agrees when it has the
/// same VPLs, each within [`TRACE_VPLS_REL`]; the last path may be cut at a different length
/// (the VPL budget runs out inside it) if an earlier one diverged. Fluxes are compared per
/// particle: a path that diverges (a particle that hits on one side and escapes on the other)
/// changes how many particles it takes to make the VPLs, so dividing by each side's own count
/// would make every path differ by that ratio.
pub fn compare(twins: &Twins, params: &TraceParams) -> Result<Vec<Disagreement>, VerifyError> {
    Ok(compare_paths(twins, params)?.0)
}

/// [`compare`], and where the paths that part first do so: the first differing VPL (the CPU's,
/// or the GPU's where the CPU has none), as a tie or another path.
fn compare_paths(twins: &Twins, params: &TraceParams) -> Result<(Vec<Disagreement>, Placed), VerifyError> {
    let mut parted = Vec::new();
    let cs = twins.cpu;
    let cpu = vplgi_cpu::trace_vpls::trace_vpls(cs, params, &vplgi_cpu::NoProgress);
    let g = twins.gpu.kernels().trace_vpls.run(twins.device(), twins.queue(), twins.gpu.scene(), params)?;
    let gpu: Vec<Vpl> = read_back(twins.device(), twins.queue(), &g.buffer, g.count as usize)?;
    let (cp, gp) = (by_path(&cpu.vpls), by_path(&gpu));
    let scramble = vplgi_cpu::trace_vpls::emission_scramble(params.seed);
    let paths: BTreeSet<u32> = cp.keys().chain(gp.keys()).copied().collect();
    let last = paths.iter().next_back().copied();
    // By the most mirrors and glass a path's VPLs passed on either side: none, one, more.
    let mut classes: [Diverged; 3] = Default::default();
    let mut ties = 0usize;
    // VPLs that the paths which parted have on one side and not the other.
    let mut parted_vpls = 0usize;
    let mut max_agreeing = 0.0f32;
    for p in &paths {
        let (a, b) = (cp.get(p).map_or(&[][..], Vec::as_slice), gp.get(p).map_or(&[][..], Vec::as_slice));
        let cut = Some(*p) == last;
        let n = if cut { a.len().min(b.len()) } else { a.len().max(b.len()) };
        let mut path_diff = 0.0f32;
        let (mut at, mut first_off) = (None, None);
        for i in 0..n {
            let d = match (a.get(i), b.get(i)) {
                (Some(x), Some(y)) => difference(x, y, cs.extent, (cpu.particles as f32, g.particles as f32)),
                _ => f32::INFINITY,
            };
            if d > path_diff {
                (path_diff, at) = (d, Some(i));
            }
            if d > TRACE_VPLS_REL as f32 && first_off.is_none() {
                first_off = Some(i);
            }
        }
        // Where the paths first part, the same point at the same bounce where two triangles
        // meet (an edge they share, or the line where one passes through the other, as in a
        // soup) means a ray each backend gave to another of them (another albedo and normal
        // from there on): the shading-points row's edge tie, counted apart. So does a VPL on
        // one side only that lies on an edge: the other backend gave the hit to a triangle the
        // particle meets from behind or edge-on, which keeps no VPL there. And so do VPLs at two
        // points, one of them on an edge: the ray touched a ridge (two triangles folded away
        // from it) at a single point, a hit one backend counts and the other passes.
        let eps = TRACE_VPLS_REL as f32 * cs.extent;
        // The same point on one triangle alone with another flux is a difference.
        let tie = first_off.is_some_and(|i| match (a.get(i), b.get(i)) {
            (Some(x), Some(y)) if (Vec3::from(x.position) - Vec3::from(y.position)).length() <= eps => {
                x.bounce == y.bounce && on_two_triangles(twins.scene, Vec3::from(x.position), eps)
            }
            (Some(x), Some(y)) => [x, y].iter().any(|v| on_an_edge(twins.scene, Vec3::from(v.position), eps)),
            (Some(x), None) | (None, Some(x)) => on_an_edge(twins.scene, Vec3::from(x.position), eps),
            (None, None) => false,
        });
        if tie || path_diff > TRACE_VPLS_REL as f32 {
            parted_vpls += a.len().abs_diff(b.len());
        }
        let chain = a.iter().chain(b).map(|v| v.specular).max().unwrap_or(0).min(2) as usize;
        let class = &mut classes[chain];
        class.items += 1;
        // Any path that parts beyond a tie is tried: a ray that grazes a silhouette (hitting on
        // one side, escaping on the other: no VPL to test for an edge) or meets a mirror on one
        // side only parts by rounding the tie test cannot see.
        let nudged = !tie
            && path_diff > TRACE_VPLS_REL as f32
            && nudge_reaches(cs, params, (scramble, *p), b, (cut, g.particles));
        if let Some(v) = first_off.and_then(|i| a.get(i).or(b.get(i))) {
            if tie || path_diff > TRACE_VPLS_REL as f32 {
                parted.push((Vec3::from(v.position), if tie || nudged { ItemKind::Tie } else { ItemKind::Other }));
            }
        }
        if tie {
            ties += 1;
        } else if nudged {
            class.nudged += 1;
        } else if path_diff > TRACE_VPLS_REL as f32 {
            class.diverge(path_diff, || {
                let i = at.unwrap_or(0);
                let show = |v: Option<&Vpl>| v.map_or("none".to_string(), |v| format!("bounce {} at {} flux {}", v.bounce, v3(v.position), v3(v.flux)));
                format!("path {p}, VPL {i}: CPU {}, GPU {}", show(a.get(i)), show(b.get(i)))
            });
        } else {
            max_agreeing = max_agreeing.max(path_diff);
        }
    }
    let count_diff = cpu.vpls.len().abs_diff(gpu.len());
    let case = format!("{} VPLs, {} bounces, seed {}", count(params.count as usize), params.bounces, params.seed);
    let [direct, one, longer] = classes;
    let mut rows = vec![
        // Both backends make exactly the VPLs asked for, unless the particle budget runs out first
        // (a scene whose light mostly escapes): then each has the VPLs its particles made, and
        // the counts may differ by what the paths that parted hold, and by nothing else.
        Disagreement::at_most("trace_vpls", "VPL count, |CPU - GPU|, beyond the paths that parted", count_diff.saturating_sub(parted_vpls) as f64, 0.0)
            .with_case(&case)
            .with_worst(
                (count_diff > 0)
                    .then(|| format!("CPU {} VPLs, GPU {} from {} particles; {parted_vpls} on paths that parted", cpu.vpls.len(), gpu.len(), g.particles)),
            ),
        crate::tolerance::share_of_diverged(
            "trace_vpls",
            "light paths that diverge (of those passing no mirror or glass)",
            (direct.diverged, direct.items),
            TRACE_VPLS_DIVERGED_PATHS,
        )
        .with_case(&case)
        .with_worst(direct.worst),
        Disagreement::info(
            "trace_vpls",
            "paths that part at a tie (the same point where two triangles meet; or a first differing VPL on an edge, on one side or beside another point)",
            ties as f64,
        )
        .with_case(&case),
        Disagreement::info(
            "trace_vpls",
            "of those passing no mirror or glass: paths that part beyond a tie where the CPU, its emission direction nudged, makes the GPU's VPLs (set aside as ties)",
            direct.nudged as f64,
        )
        .with_case(&case),
        Disagreement::info("trace_vpls", "largest relative difference on agreeing paths", max_agreeing as f64).with_case(&case),
        Disagreement::info("trace_vpls", "light particles traced, |CPU - GPU| (moves with diverging paths)", (cpu.particles as f64 - g.particles as f64).abs())
            .with_case(&case),
    ];
    rows.extend(chain_rows(
        "trace_vpls",
        &case,
        [one, longer],
        |label| format!("light paths through {label} that diverge"),
        |label| format!("light paths through {label} that part where the CPU, its emission direction nudged, makes the GPU's VPLs (set aside as ties)"),
    ));
    Ok((rows, parted))
}

/// Whether the CPU, following light particle `index` (of the frame's emission set shifted by
/// `scramble`) with its emission direction nudged as a camera chain's is
/// ([`crate::shading_points::Nudge`]), makes the GPU's VPLs `gpu` of that path, each within
/// [`TRACE_VPLS_REL`] (as many as the shorter side has where the path was `cut`). The GPU's
/// fluxes are divided by its `particles`; the CPU's, fresh from the particle, not yet.
fn nudge_reaches(cs: &vplgi_cpu::CpuScene, params: &TraceParams, (scramble, index): ([u32; 5], u32), gpu: &[Vpl], (cut, particles): (bool, u32)) -> bool {
    let Some(emission) = vplgi_cpu::trace_vpls::particle_emission(cs, scramble, index) else {
        return false;
    };
    crate::shading_points::nudged(emission.dir).any(|dir| {
        let cpu = vplgi_cpu::trace_vpls::follow_particle(cs, params, index, &vplgi_scene::lights::Emission { dir, ..emission });
        let n = if cut { cpu.len().min(gpu.len()) } else { cpu.len().max(gpu.len()) };
        (0..n).all(|i| match (cpu.get(i), gpu.get(i)) {
            (Some(x), Some(y)) => difference(x, y, cs.extent, (1.0, particles as f32)) <= TRACE_VPLS_REL as f32,
            _ => false,
        })
    })
}

/// The frame's VPLs.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::TraceVpls);
    let (checks, parted) = compare_paths(twins, &cfg.trace_params())?;
    r.checks = checks;
    // Where the paths that part do so, seen from the camera.
    r.maps.push(DisagreementMap::projected("trace_vpls", &twins.scene.camera, (cfg.width, cfg.height), &parted));
    r.notes.push(
        "VPLs are matched by light path; a path agrees when every VPL is within 1e-4 (position relative to the scene extent, normal, flux per particle relative \
         to its largest channel) at the same bounce. A path whose first differing VPL is at the same point where two triangles meet (an edge they share or a line where one passes \
         through the other: another triangle, so another albedo) is counted apart, as the shading-points row counts edge ties, and so is one whose first differing VPL lies on a triangle's edge, on one side only \
         (the other backend gave the hit to a triangle that keeps no VPL there) or beside the other's elsewhere (a ray touching a ridge at one point). A path that parts beyond \
         these is set aside too where the CPU, its particle's emission direction turned by 1e-5 rad or less, makes the GPU's VPLs (rounding the tests cannot see)"
            .into(),
    );
    // The caustic photons are the same paths' other deposit: judged by the same rows.
    if twins.scene.has_specular() {
        let params = TraceParams { count: cfg.caustic_photons.min(crate::caustics::VERIFY_PHOTONS), ..cfg.caustic_trace_params() };
        let (checks, _) = compare_paths(twins, &params)?;
        r.checks.extend(checks.into_iter().map(|c| {
            let case = format!("caustic photons; {}", c.case);
            c.with_case(case)
        }));
        r.notes.push("the caustic photons (the same particles, a photon where a path leaves a mirror or glass) are matched by light path the same way".into());
    }
    // And so are the global map's photons (`--gi photon`).
    if cfg.has_photons() {
        let params = TraceParams { count: cfg.global_photons.min(crate::illumination_cut::VERIFY_PHOTONS), ..cfg.global_trace_params() };
        let (checks, _) = compare_paths(twins, &params)?;
        r.checks.extend(checks.into_iter().map(|c| {
            let case = format!("global photons; {}", c.case);
            c.with_case(case)
        }));
        r.notes.push("the global map's photons (the same particles, a photon at every non-specular surface) are matched by light path the same way".into());
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit triangles crossing at right angles (one in z = 0, one in x = 0.25 through it)
    /// and a third sharing an edge with the first.
    fn crossing() -> vplgi_scene::Scene {
        let mut s = vplgi_scene::cornell::cornell_box();
        s.positions =
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.25, -0.5, -0.5), Vec3::new(0.25, 1.0, -0.5), Vec3::new(0.25, 0.25, 1.0), Vec3::new(1.0, 1.0, 0.0)];
        s.normals = vec![Vec3::Z; 7];
        s.uvs = vec![glam::Vec2::ZERO; 7];
        s.indices = vec![[0, 1, 2], [3, 4, 5], [1, 6, 2]];
        s.material_ids = vec![0, 0, 0];
        s
    }

    #[test]
    fn two_triangles_meet_on_shared_edges_and_crossing_lines() {
        let s = crossing();
        let eps = 1e-5;
        // On the line where the second passes through the first (x = 0.25, z = 0).
        assert!(on_two_triangles(&s, Vec3::new(0.25, 0.3, 0.0), eps));
        assert!(!on_an_edge(&s, Vec3::new(0.25, 0.3, 0.0), eps));
        // On the edge the first and third share, and 2e-5 off it inside the first.
        assert!(on_two_triangles(&s, Vec3::new(0.5, 0.5, 0.0), eps));
        assert!(!on_two_triangles(&s, Vec3::new(0.5 - 1.5e-5, 0.5 - 1.5e-5, 0.0), eps));
        // Inside the first only; on the first's outer edge only.
        assert!(!on_two_triangles(&s, Vec3::new(0.1, 0.1, 0.0), eps));
        assert!(!on_two_triangles(&s, Vec3::new(0.6, 0.0, 0.0), eps));
    }
}
