//! `visibility`: Embree (the CPU stage), obvhs' CPU traversal and the GPU compared three ways on
//! the same shadow rays (SPEC: >= 99.9 % identical bits between every pair).

use crate::inputs::{CpuClusters, CpuFrame};
use crate::tolerance::{Disagreement, VISIBILITY_SAME_BITS};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage};
use glam::Vec3A;
use vplgi_cpu::CpuScene;
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::{Endpoint, FrameConfig};

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
        // blocker within 1e-4 of the segment's start (a box face 1e-5 below an offset endpoint,
        // found at 10,000 cases) was never reached. Starting the ray BACK_OFF segments earlier
        // puts the segment's whole span past that clamp; the triangle test still counts only
        // t in (TNEAR, TFAR) of the segment.
        const BACK_OFF: f32 = 1.0 / 64.0;
        let d = q - p;
        let ray = obvhs::ray::Ray::new(Vec3A::from(p - d * BACK_OFF), Vec3A::from(d), BACK_OFF + vplgi_cpu::SEGMENT_TNEAR, BACK_OFF + vplgi_cpu::SEGMENT_TFAR);
        self.bvh.ray_traverse_miss(ray, |r, id| self.tris[self.bvh.primitive_indices[id] as usize].intersect(r))
    }
}

/// Evenly spaced rows, at most `max` of them.
pub fn sample_rows(rows: &[Endpoint], max: usize) -> Vec<Endpoint> {
    if rows.len() <= max {
        return rows.to_vec();
    }
    (0..max).map(|i| rows[i * rows.len() / max]).collect()
}

/// The visibility matrix of `rows` x `cols` three ways.
pub fn compare(twins: &Twins, obvhs: &ObvhsScene, rows: &[Endpoint], cols: &[Endpoint]) -> Result<Vec<Disagreement>, VerifyError> {
    let cs = twins.cpu;
    let (embree, _) = vplgi_cpu::visibility::visibility(cs, rows, cols, &vplgi_cpu::NoProgress);
    let words = twins.gpu.kernels().visibility.run(twins.device(), twins.queue(), twins.gpu.scene(), rows, cols, None)?;
    let wpr = words_per_row(cols.len());
    let (mut e_o, mut e_g, mut o_g, mut visible) = (0u64, 0u64, 0u64, 0u64);
    let mut first: [Option<String>; 3] = [None, None, None];
    let show = |v: bool| if v { "visible" } else { "blocked" };
    for (r, a) in rows.iter().enumerate() {
        for (c, b) in cols.iter().enumerate() {
            let e = embree.get(r, c);
            let o = obvhs.visible(cs, a, b);
            let g = (words[r * wpr + c / 32] >> (c % 32)) & 1 == 1;
            visible += e as u64;
            let pair = || format!("row {r} at {} to column {c} at {}", v3(a.p().into()), v3(b.p().into()));
            for (k, (x, y, n)) in [(e, o, &mut e_o), (e, g, &mut e_g), (o, g, &mut o_g)].into_iter().enumerate() {
                if x != y {
                    *n += 1;
                    first[k].get_or_insert_with(|| format!("{}: {} / {}", pair(), show(x), show(y)));
                }
            }
        }
    }
    let total = (rows.len() * cols.len()).max(1) as u64;
    let share = |d: u64| (total - d) as f64 / total as f64;
    let [w_eo, w_eg, w_og] = first;
    Ok(vec![
        Disagreement::at_least("visibility", "share of identical bits, Embree / GPU", share(e_g), VISIBILITY_SAME_BITS).with_worst(w_eg),
        Disagreement::at_least("visibility", "share of identical bits, Embree / obvhs", share(e_o), VISIBILITY_SAME_BITS).with_worst(w_eo),
        Disagreement::at_least("visibility", "share of identical bits, obvhs / GPU", share(o_g), VISIBILITY_SAME_BITS).with_worst(w_og),
        Disagreement::info("visibility", "share of visible pairs (Embree)", visible as f64 / total as f64),
    ])
}

/// The frame's shadow rays in its mode: rows are its hits (or its shading-point clusters'
/// representatives), columns its lights (VPLs or VPL clusters), from the CPU's stages.
pub fn verify(twins: &Twins, cfg: &FrameConfig) -> Result<StageResult, VerifyError> {
    let mut r = result(VerifyStage::Visibility);
    let frame = CpuFrame::new(twins.cpu, cfg);
    let clusters = CpuClusters::new(twins.cpu, &frame, cfg);
    let max_rows = (MAX_PAIRS / clusters.cols.len().max(1)).max(1);
    let rows = sample_rows(&clusters.rows, max_rows);
    let case = format!("{} rows x {} columns", count(rows.len()), count(clusters.cols.len()));
    let obvhs = ObvhsScene::new(twins.scene);
    for d in compare(twins, &obvhs, &rows, &clusters.cols)? {
        r.checks.push(d.with_case(&case));
    }
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
