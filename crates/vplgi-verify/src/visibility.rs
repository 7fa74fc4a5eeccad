//! `visibility`: Embree (the CPU stage), obvhs' CPU traversal and the GPU compared three ways on
//! the same shadow rays (SPEC: >= 99.9 % identical bits between every pair).

use crate::inputs::{CpuClusters, CpuFrame};
use crate::segment::{TieOracle, Verdict};
use crate::tolerance::{Disagreement, VISIBILITY_SAME_BITS};
use crate::map::{DisagreementMap, ItemKind, Placed};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::{Vec3, Vec3A};
use vplgi_cpu::CpuScene;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::Endpoint;

/// Most row x column pairs compared: obvhs' traversal runs on one core.
pub const MAX_PAIRS: usize = 4 << 20;

/// obvhs' BVH of a scene: the third opinion.
pub struct ObvhsScene {
    bvh: obvhs::cwbvh::CwBvh,
    tris: Vec<obvhs::triangle::Triangle>,
}

impl ObvhsScene {
    pub fn new(scene: &vplgi_scene::Scene) -> ObvhsScene {
        let tris = vplgi_gpu::bvh::triangles(scene);
        let mut build_time = std::time::Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut build_time);
        ObvhsScene { bvh, tris }
    }

    /// Whether the segment between two surface points is unblocked, with the CPU's offsets and
    /// facing test.
    pub fn visible(&self, cs: &CpuScene, a: &Endpoint, b: &Endpoint) -> bool {
        if !vplgi_cpu::visibility::facing(a, b) {
            return false;
        }
        let p = cs.offset_toward(a.p(), a.n(), b.p());
        let q = cs.offset_toward(b.p(), b.n(), a.p());
        // obvhs 0.4's node test clamps a box's entry to t >= 1e-4 whatever the ray's tmin, so a
        // blocker within 1e-4 of the start (a box face 1e-5 below an offset endpoint, found at
        // 10,000 cases) is never reached from p. The same segment traced back from q reaches it
        // (TFAR = 1 - TNEAR, so both rays test one span); a blocker is one either ray finds. Both
        // rays start at an endpoint, unrounded, so a segment that grazes a plane through its
        // start still touches it at t = 0 (a ray started before p, at a rounded origin, put that
        // touch at t = 4e-5 on a segment 0.001 from parallel).
        let hit = |from: Vec3, along: Vec3| {
            let ray = obvhs::ray::Ray::new(Vec3A::from(from), Vec3A::from(along), vplgi_cpu::SEGMENT_TNEAR, vplgi_cpu::SEGMENT_TFAR);
            !self.bvh.ray_traverse_miss(ray, |r, id| self.tris[self.bvh.primitive_indices[id] as usize].intersect(r))
        };
        !hit(p, q - p) && !hit(q, p - q)
    }
}

/// Evenly spaced rows, at most `max` of them.
pub fn sample_rows(rows: &[Endpoint], max: usize) -> Vec<Endpoint> {
    if rows.len() <= max {
        return rows.to_vec();
    }
    (0..max).map(|i| rows[i * rows.len() / max]).collect()
}

/// Disagreeing pairs judged by the f64 oracle at most: each costs a pass over the triangles.
/// Pairs beyond them count as differing in every row, and how many is reported.
pub const MAX_TIE_CHECKS: usize = 20_000;

/// The visibility matrix of `rows` x `cols` three ways. Each pair of backends gets the SPEC's
/// row (identical bits) and the same share with rounding ties set aside (`segment::TieOracle`):
/// a pair where no triangle blocks with room to spare yet one comes within rounding of the span.
/// The second can only be higher; it tells a kernel author whether the misses are ties or
/// errors, and is what inputs built to graze (endpoints on edges) are judged by.
pub fn compare(twins: &Twins, obvhs: &ObvhsScene, rows: &[Endpoint], cols: &[Endpoint]) -> Result<Vec<Disagreement>, VerifyError> {
    compare_mapped(twins, obvhs, rows, cols, &mut Vec::new())
}

/// [`compare`], adding to `parted` the row point of each pair whose Embree and GPU bits differ,
/// as a rounding tie or not.
fn compare_mapped(
    twins: &Twins,
    obvhs: &ObvhsScene,
    rows: &[Endpoint],
    cols: &[Endpoint],
    parted: &mut Placed,
) -> Result<Vec<Disagreement>, VerifyError> {
    let cs = twins.cpu;
    let (embree, _) = vplgi_cpu::visibility::visibility(cs, rows, cols, &vplgi_cpu::NoProgress);
    let words = twins.gpu.kernels().visibility.run(twins.device(), twins.queue(), twins.gpu.scene(), rows, cols, None)?;
    let wpr = words_per_row(cols.len());
    let oracle = TieOracle::new(twins.scene);
    let (mut checked, mut unexamined) = (0usize, 0u64);
    let (mut differ, mut robust, mut ties, mut visible) = ([0u64; 3], [0u64; 3], 0u64, 0u64);
    let mut first: [Option<String>; 3] = [None, None, None];
    let mut first_robust: [Option<String>; 3] = [None, None, None];
    let show = |v: bool| if v { "visible" } else { "blocked" };
    for (r, a) in rows.iter().enumerate() {
        for (c, b) in cols.iter().enumerate() {
            let e = embree.get(r, c);
            let o = obvhs.visible(cs, a, b);
            let g = (words[r * wpr + c / 32] >> (c % 32)) & 1 == 1;
            visible += e as u64;
            if e == o && o == g {
                continue;
            }
            let pair = || format!("row {r} at {} to column {c} at {}", v3(a.p().into()), v3(b.p().into()));
            let verdict = (checked < MAX_TIE_CHECKS).then(|| {
                checked += 1;
                tie_verdict(cs, &oracle, a, b)
            });
            ties += (verdict == Some(Verdict::Tie)) as u64;
            unexamined += verdict.is_none() as u64;
            if e != g {
                parted.push((a.p(), if verdict == Some(Verdict::Tie) { ItemKind::Tie } else { ItemKind::Other }));
            }
            for (k, (x, y)) in [(e, o), (e, g), (o, g)].into_iter().enumerate() {
                if x != y {
                    differ[k] += 1;
                    first[k].get_or_insert_with(|| format!("{}: {} / {}", pair(), show(x), show(y)));
                    if verdict != Some(Verdict::Tie) {
                        robust[k] += 1;
                        let exact = verdict.map_or("not judged in f64".into(), |v| format!("f64: {v:?}"));
                        first_robust[k].get_or_insert_with(|| format!("{}: {} / {} ({exact})", pair(), show(x), show(y)));
                    }
                }
            }
        }
    }
    let total = (rows.len() * cols.len()).max(1) as u64;
    let share = |d: u64| (total - d) as f64 / total as f64;
    let names = ["Embree / obvhs", "Embree / GPU", "obvhs / GPU"];
    let mut out = Vec::new();
    // Embree / GPU first: the CPU stage against the kernel.
    for k in [1, 0, 2] {
        out.push(
            Disagreement::at_least("visibility", format!("share of identical bits, {}", names[k]), share(differ[k]), VISIBILITY_SAME_BITS)
                .with_worst(first[k].take()),
        );
    }
    for k in [1, 0, 2] {
        out.push(
            Disagreement::at_least(
                "visibility",
                format!("share of identical bits apart from rounding ties, {}", names[k]),
                share(robust[k]),
                VISIBILITY_SAME_BITS,
            )
            .with_worst(first_robust[k].take()),
        );
    }
    out.push(Disagreement::info("visibility", format!("disagreeing pairs that are rounding ties (f64, within {:.1e})", oracle.tolerance()), ties as f64));
    out.push(Disagreement::info(
        "visibility",
        format!("disagreeing pairs not judged in f64 (beyond the first {MAX_TIE_CHECKS}; counted as differing)"),
        unexamined as f64,
    ));
    out.push(Disagreement::info("visibility", "share of visible pairs (Embree)", visible as f64 / total as f64));
    Ok(out)
}

/// The f64 oracle's verdict on the CPU's segment between `a` and `b`; a pair whose facing test
/// is within rounding of its bound is a tie too.
fn tie_verdict(cs: &CpuScene, oracle: &TieOracle, a: &Endpoint, b: &Endpoint) -> Verdict {
    let d = (b.p() - a.p()).as_dvec3();
    let bound = vplgi_types::params::FACING_COS as f64 * d.length();
    let margin = (a.n().as_dvec3().dot(d) - bound).min(-b.n().as_dvec3().dot(d) - bound);
    if margin.abs() <= oracle.tolerance() {
        return Verdict::Tie;
    }
    if margin < 0.0 {
        return Verdict::Blocked;
    }
    let p = cs.offset_toward(a.p(), a.n(), b.p());
    let q = cs.offset_toward(b.p(), b.n(), a.p());
    oracle.verdict(p.as_dvec3(), q.as_dvec3())
}

/// The frame's shadow rays in its mode: rows are its hits (or its shading-point clusters'
/// representatives), columns its lights (VPLs or VPL clusters), from the CPU's stages.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::Visibility);
    let frame = CpuFrame::new(twins.cpu, cfg);
    let clusters = CpuClusters::new(twins.cpu, &frame, cfg);
    let max_rows = (MAX_PAIRS / clusters.cols.len().max(1)).max(1);
    let rows = sample_rows(&clusters.rows, max_rows);
    let case = format!("{} rows x {} columns", count(rows.len()), count(clusters.cols.len()));
    let obvhs = ObvhsScene::new(twins.scene);
    let mut parted = Vec::new();
    for d in compare_mapped(twins, &obvhs, &rows, &clusters.cols, &mut parted)? {
        r.checks.push(d.with_case(&case));
    }
    // The rows whose bits differ, seen from the camera.
    r.maps.push(DisagreementMap::projected("visibility", &twins.scene.camera, (cfg.width, cfg.height), &parted));
    let what = if cfg.cluster.clusters_sps() { "shading-point cluster representatives" } else { "hits" };
    let cols = if cfg.cluster.clusters_vpls() { "VPL cluster lights" } else { "VPLs" };
    if rows.len() < clusters.rows.len() {
        r.notes.push(format!(
            "rows: {} of the frame's {} {what}, evenly spaced (obvhs traces on one core); columns: its {cols}",
            count(rows.len()),
            count(clusters.rows.len())
        ));
    } else {
        r.notes.push(format!("rows: the frame's {what}; columns: its {cols}"));
    }
    Ok(r)
}
