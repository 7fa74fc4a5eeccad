//! `cluster`: assignment, centroid update and fuzzy assignment on the same inputs, and the whole
//! clustering (Alg. 1 and 2) on the same points (SPEC: >= 99.99 % identical nearest labels;
//! update bit-identical; >= 99.9 % identical F-index sets, weights within 1e-5 summing to 1).

use crate::inputs::CpuFrame;
use crate::tolerance::{
    Disagreement, ASSIGN_SAME_LABELS, FUZZY_SAME_SETS, FUZZY_WEIGHTS_ABS, RSM_IMPORTANCE_REL, RSM_UPDATE_REL, SEEDING_DIFFERING_SEEDS,
    TEMPORAL_DIFFERING_THRESHOLDS, TEMPORAL_SAME_ADMISSION, UPDATE_DIFFERING_CENTROIDS,
};
use crate::map::{DisagreementMap, ItemKind, Placed};
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::Vec3;
use vplgi_cpu::cluster::{bounds, cluster, cluster_from, update, ClusterParams, Grid};
use vplgi_frame::RsmStart;
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::cluster::{AssignRule, ClusterKernel, GpuClustering};
use vplgi_gpu::seeding::GpuImageHits;
use vplgi_types::clustering::{fuzzy_weights, ClusterStart, FixedPoint, GridGeometry, Metric, Representative};
use vplgi_shared::rsm::{RsmCentre, RsmClusterParams, RsmLight};
use vplgi_shared::rsm_importance;
use vplgi_types::{Endpoint, FrameConfig, FuzzyMode, RsmSeeding, Seeding, Vpl, MISS};

fn endpoints(ps: &[Vec3], ns: &[Vec3]) -> Vec<Endpoint> {
    ps.iter().zip(ns).map(|(&p, &n)| Endpoint::new(p, n)).collect()
}

/// The CPU's F nearest compatible centroids of each point on `grid` (Eq. 7 or Eq. 2), `MISS`-padded, and
/// their weights (Eq. 8 or Eq. 9-10).
pub fn cpu_assign(grid: &Grid, (ps, ns): (&[Vec3], &[Vec3]), rule: AssignRule) -> (Vec<u32>, Vec<f32>) {
    let f = rule.f as usize;
    let (mut labels, mut weights) = (vec![MISS; ps.len() * f], vec![0.0f32; ps.len() * f]);
    for (i, (&p, &n)) in ps.iter().zip(ns).enumerate() {
        let mut best = vec![(f32::INFINITY, MISS); f];
        let (found, _) = grid.search(p, n, rule.metric, &mut best);
        fuzzy_weights(&best[..found], rule.fuzzy, rule.metric, grid.cell, &mut weights[i * f..i * f + found]);
        for (j, b) in best.iter().enumerate() {
            labels[i * f + j] = b.1;
        }
    }
    (labels, weights)
}

/// Assigns the points to their F nearest of `centroids` on both backends, on the CPU's grid, and
/// checks the SPEC's assignment row and (for F > 1) its fuzzy-assignment row.
pub fn compare_assign(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    centroids: (&[Vec3], &[Vec3]),
    rule: AssignRule,
) -> Result<Vec<Disagreement>, VerifyError> {
    compare_assign_mapped(device, queue, kernel, (ps, ns), centroids, rule, &mut Vec::new())
}

/// [`compare_assign`], adding to `parted` each point whose nearest label differs (another
/// cluster) or whose set of F labels does (beyond).
fn compare_assign_mapped(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    centroids: (&[Vec3], &[Vec3]),
    rule: AssignRule,
    parted: &mut Placed,
) -> Result<Vec<Disagreement>, VerifyError> {
    let (m, k, f) = (ps.len(), centroids.0.len(), rule.f as usize);
    let grid = Grid::for_data(bounds(ps), ps, k).fill(centroids.0, centroids.1);
    let (cl, cw) = cpu_assign(&grid, (ps, ns), rule);
    let pts = storage(device, "points", &endpoints(ps, ns));
    let cents = storage(device, "centroids", &endpoints(centroids.0, centroids.1));
    let geometry = GridGeometry { origin: grid.origin, cell: grid.cell, dims: grid.dims };
    let ggrid = kernel.fill_grid(device, queue, &geometry, &cents, k as u32)?;
    let a = kernel.assign(device, queue, &ggrid, (&pts, m as u32), (&cents, k as u32), rule)?;
    let gl: Vec<u32> = read_back(device, queue, &a.labels, m * f)?;
    let gw: Vec<f32> = read_back(device, queue, &a.weights, m * f)?;
    let (mut hard_same, mut set_same, mut max_w, mut max_sum) = (0usize, 0usize, 0.0f32, 0.0f32);
    let (mut worst_label, mut worst_set, mut worst_w) = (None, None, None);
    let d = |i: usize, c: u32| if c == MISS { f32::NAN } else { (ps[i] - centroids.0[c as usize]).length() };
    for i in 0..m {
        let (c, g) = (&cl[i * f..(i + 1) * f], &gl[i * f..(i + 1) * f]);
        if c[0] == g[0] {
            hard_same += 1;
        } else {
            parted.push((ps[i], ItemKind::Other));
            worst_label.get_or_insert_with(|| {
                format!(
                    "point {i} at {}: CPU cluster {} at distance {:.7e}, GPU cluster {} at distance {:.7e}",
                    v3(ps[i].into()),
                    c[0],
                    d(i, c[0]),
                    g[0],
                    d(i, g[0])
                )
            });
        }
        if c == g {
            set_same += 1;
            for j in 0..f {
                let e = (gw[i * f + j] - cw[i * f + j]).abs();
                if e > max_w {
                    max_w = e;
                    worst_w = Some(format!("point {i}, cluster {}: CPU weight {:.8}, GPU {:.8}", c[j], cw[i * f + j], gw[i * f + j]));
                }
            }
        } else {
            if c[0] == g[0] {
                parted.push((ps[i], ItemKind::Beyond));
            }
            worst_set.get_or_insert_with(|| format!("point {i}: CPU clusters {c:?}, GPU {g:?}"));
        }
        if g[0] != MISS {
            max_sum = max_sum.max((gw[i * f..(i + 1) * f].iter().sum::<f32>() - 1.0).abs());
        }
    }
    let n = m.max(1) as f64;
    let mut out = vec![
        Disagreement::at_least("cluster assignment", "share of identical nearest labels", hard_same as f64 / n, ASSIGN_SAME_LABELS).with_worst(worst_label)
    ];
    if f > 1 {
        out.push(Disagreement::at_least("fuzzy assignment", "share of identical F-index sets", set_same as f64 / n, FUZZY_SAME_SETS).with_worst(worst_set));
        out.push(Disagreement::at_most("fuzzy assignment", "largest weight difference", max_w as f64, FUZZY_WEIGHTS_ABS).with_worst(worst_w));
        out.push(Disagreement::at_most("fuzzy assignment", "largest |sum of a point's GPU weights - 1|", max_sum as f64, FUZZY_WEIGHTS_ABS));
    }
    Ok(out)
}

/// The centroid update (integer sums over the fixed-point box) given the same labels, on both
/// backends: the centroids and member counts must be bit-identical.
pub fn compare_update(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    centroids: (&[Vec3], &[Vec3]),
    labels: &[u32],
) -> Result<Disagreement, VerifyError> {
    let (m, k) = (ps.len(), centroids.0.len());
    let (lo, hi) = bounds(ps);
    let fix = FixedPoint::new(lo, hi);
    let (mut cp, mut cn) = (centroids.0.to_vec(), centroids.1.to_vec());
    let cpu_counts = update(&fix, ps, ns, labels, &mut cp, &mut cn);
    let pts = storage(device, "points", &endpoints(ps, ns));
    let cents = storage(device, "centroids", &endpoints(centroids.0, centroids.1));
    let lb = storage(device, "labels", labels);
    let gcounts = kernel.update(device, queue, &fix, (&pts, m as u32), (&lb, 1), (&cents, k as u32))?;
    let gc: Vec<Endpoint> = read_back(device, queue, &cents, k)?;
    let gcount: Vec<u32> = read_back(device, queue, &gcounts, k)?;
    let (mut differ, mut worst) = (0usize, None);
    for j in 0..k {
        let same = gc[j].position[..3] == cp[j].to_array() && gc[j].normal[..3] == cn[j].to_array() && gcount[j] == cpu_counts[j];
        if !same {
            differ += 1;
            worst.get_or_insert_with(|| {
                format!(
                    "centroid {j}: CPU {} ({} members), GPU {} ({} members)",
                    v3(cp[j].into()),
                    cpu_counts[j],
                    v3([gc[j].position[0], gc[j].position[1], gc[j].position[2]]),
                    gcount[j]
                )
            });
        }
    }
    Ok(Disagreement::at_most("centroid update", "centroids or member counts that differ", differ as f64, UPDATE_DIFFERING_CENTROIDS as f64).with_worst(worst))
}

/// The whole clustering (Alg. 1 iterations, empty-cluster removal, Alg. 2, representatives) on
/// both backends from the same points and seed (and the same given seeds, if any). Every step is one of the rows above on identical
/// inputs, so the trajectories stay together: the cluster counts must agree, and the label rows
/// meet the fuzzy-assignment row.
pub fn compare_clustering(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    params: &ClusterParams,
    start: ClusterStart<'_>,
) -> Result<Vec<Disagreement>, VerifyError> {
    let m = ps.len();
    let cpu = cluster_from(ps, ns, params, start);
    let pts = storage(device, "points", &endpoints(ps, ns));
    let g = kernel.cluster_from(device, queue, (&pts, m as u32), params, start)?;
    let f = g.f as usize;
    let gl: Vec<u32> = read_back(device, queue, &g.labels, m * f)?;
    let gr: Vec<u32> = read_back(device, queue, &g.representatives, g.k as usize)?;
    let rows_same = (0..m).filter(|&i| f == cpu.f && gl[i * f..(i + 1) * f] == cpu.labels[i * cpu.f..(i + 1) * cpu.f]).count();
    let reps_differ = if g.k as usize == cpu.k() { gr.iter().zip(&cpu.representatives).filter(|(a, b)| a != b).count() } else { cpu.k().max(g.k as usize) };
    let first_row = (0..m).find(|&i| f != cpu.f || gl[i * f..(i + 1) * f] != cpu.labels[i * cpu.f..(i + 1) * cpu.f]);
    let worst = first_row.map(|i| format!("point {i}: CPU clusters {:?}, GPU {:?}", &cpu.labels[i * cpu.f..(i + 1) * cpu.f], &gl[i * f..(i + 1) * f]));
    Ok(vec![
        Disagreement::at_most("whole clustering", "cluster count, |CPU - GPU|", (cpu.k() as f64 - g.k as f64).abs(), 0.0).with_worst(Some(format!(
            "CPU {} clusters, GPU {}",
            cpu.k(),
            g.k
        ))),
        Disagreement::at_least("whole clustering", "share of identical label rows", rows_same as f64 / m.max(1) as f64, FUZZY_SAME_SETS).with_worst(worst),
        Disagreement::info("whole clustering", "representatives that differ", reps_differ as f64),
    ])
}

/// `--temporal on` (the shading points' clustering started from the previous frame's clusters)
/// on both backends, from the CPU's clustering of the same points as the previous frame: its
/// thresholds computed by both from the CPU's labels; then, with the thresholds halved so that
/// some points fit nowhere and some centres admit nobody, the admission of every point on the
/// same grid, and the whole warm clustering (its label rows judged by the fuzzy row).
pub fn compare_temporal(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    params: &ClusterParams,
    seeds: Option<&[u32]>,
) -> Result<Vec<Disagreement>, VerifyError> {
    use vplgi_cpu::cluster::temporal::{admit, centres};
    let m = ps.len();
    let cold = cluster_from(ps, ns, params, seeds.map_or(ClusterStart::Stride, ClusterStart::Seeds));
    let cpu_centres = centres(&cold, ps, ns, params.metric);
    let pts = storage(device, "points", &endpoints(ps, ns));
    let on_device = GpuClustering {
        centroids: storage(device, "centroids", &endpoints(&cold.positions, &cold.normals)),
        k: cold.k() as u32,
        f: cold.f as u32,
        labels: storage(device, "labels", &cold.labels),
        weights: storage(device, "weights", &cold.weights),
        representatives: storage(device, "representatives", &cold.representatives),
        outcome: storage::<u32>(device, "outcome", &[]),
        kept: 0,
        fresh: 0,
    };
    let gpu_centres = kernel.centres(device, queue, &on_device, (&pts, m as u32), params.metric)?;
    let differ: Vec<usize> =
        (0..cpu_centres.len()).filter(|&j| gpu_centres.get(j).map(|c| c.threshold.to_bits()) != Some(cpu_centres[j].threshold.to_bits())).collect();
    let worst = differ.first().map(|&j| format!("cluster {j}: CPU threshold {}, GPU {:?}", cpu_centres[j].threshold, gpu_centres.get(j).map(|c| c.threshold)));
    let thresholds =
        Disagreement::at_most("temporal thresholds", "thresholds that differ", differ.len() as f64, TEMPORAL_DIFFERING_THRESHOLDS as f64).with_worst(worst);

    let previous: Vec<_> = cpu_centres.iter().map(|c| vplgi_types::clustering::Centre { threshold: 0.5 * c.threshold, ..*c }).collect();
    let grid = Grid::for_data(bounds(ps), ps, params.k as usize);
    let geometry = GridGeometry { origin: grid.origin, cell: grid.cell, dims: grid.dims };
    let cpu = admit(&grid, ps, ns, &previous, params.metric);
    let (gpu_kept, gpu_unfit) = kernel.admit(device, queue, &geometry, (&pts, m as u32), &previous, params.metric)?;
    let same = cpu.unfit.iter().zip(&gpu_unfit).filter(|(a, b)| a == b).count();
    let first = (0..m).find(|&i| cpu.unfit[i] != gpu_unfit[i]).map(|i| format!("point {i}: unfit on the CPU {}, on the GPU {}", cpu.unfit[i], gpu_unfit[i]));
    let unfit = cpu.unfit.iter().filter(|&&u| u).count();
    let admission =
        Disagreement::at_least("temporal admission", "share of points with the same verdict", same as f64 / m.max(1) as f64, TEMPORAL_SAME_ADMISSION)
            .with_worst(first);
    let kept_differ = cpu.kept.len().max(gpu_kept.len()) - cpu.kept.iter().zip(&gpu_kept).filter(|(a, b)| a == b).count();
    let mut checks = vec![
        thresholds,
        admission,
        Disagreement::info("temporal admission", "points that fit no centre (CPU)", unfit as f64),
        Disagreement::info("temporal admission", "centres kept (CPU)", cpu.kept.len() as f64),
        Disagreement::info("temporal admission", "kept centres that differ", kept_differ as f64),
    ];
    checks.extend(compare_clustering(device, queue, kernel, (ps, ns), params, ClusterStart::Warm { previous: &previous, seeds })?);
    Ok(checks)
}

/// The adaptive seeding (`--seeding adaptive`) of a frame's hits on both backends, from the
/// CPU's hits: the SPEC's seeding row (the same seeds in the same order: integer sums and the
/// same f32 operations on both). Returns the CPU's seeds with the check.
pub fn compare_seeding(twins: &Twins, frame: &CpuFrame, cfg: &FrameConfig) -> Result<(Vec<u32>, Disagreement), VerifyError> {
    let (device, queue) = (twins.device(), twins.queue());
    let cpu = frame.adaptive_seeds(cfg, twins.cpu.extent);
    let (ps, ns) = frame.hit_points();
    let points = storage(device, "hits", &endpoints(&ps, &ns));
    let offsets = storage(device, "hit offsets", &frame.sample_offsets());
    let image = GpuImageHits { points: &points, count: ps.len() as u32, offsets: &offsets, width: cfg.width, height: cfg.height, spp: cfg.spp };
    let kernels = twins.gpu.kernels();
    let gpu = kernels.seeding.run(device, queue, &kernels.cluster, &image, &cfg.seed_params(twins.cpu.extent))?;
    let differ = cpu.len().max(gpu.len()) - cpu.iter().zip(&gpu).filter(|(a, b)| a == b).count();
    let first =
        (0..cpu.len().max(gpu.len())).find(|&i| cpu.get(i) != gpu.get(i)).map(|i| format!("seed {i}: CPU hit {:?}, GPU hit {:?}", cpu.get(i), gpu.get(i)));
    let case =
        format!("{} hits, {}x{} pixels, K = {}: {} seeds on the CPU, {} on the GPU", count(ps.len()), cfg.width, cfg.height, cfg.k_sp, cpu.len(), gpu.len());
    let check =
        Disagreement::at_most("seeding (adaptive)", "seeds that differ", differ as f64, SEEDING_DIFFERING_SEEDS as f64).with_case(&case).with_worst(first);
    Ok((cpu, check))
}

/// The metric and representative rule of a clustering, for a check's case.
fn describe(params: &ClusterParams) -> String {
    let metric = match params.metric {
        Metric::Eq7 { normal_threshold } => format!("Eq. 7 (n_t {normal_threshold})"),
        Metric::Ward { alpha } => format!("Eq. 2 (alpha {alpha:.4} per unit)"),
    };
    match params.representative {
        Representative::Nearest => metric,
        Representative::MinError { .. } => format!("{metric}, min-error representatives"),
    }
}

/// All of the above on the frame's two point sets: its hits (the shading-point clustering's
/// parameters) and its VPLs (the VPL clustering's), with centroids and labels from the CPU.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::Cluster);
    let frame = CpuFrame::new(twins.cpu, cfg);
    let (device, queue, kernel) = (twins.device(), twins.queue(), &twins.gpu.kernels().cluster);
    let sets = [("hit points", frame.hit_points(), cfg.sp_cluster_params(twins.cpu.extent)), ("VPLs", frame.vpl_points(), cfg.vpl_cluster_params())];
    for (name, (ps, ns), params) in sets {
        if ps.is_empty() {
            r.notes.push(format!("no {name} to cluster"));
            continue;
        }
        let c = cluster(&ps, &ns, &ClusterParams { f: 1, fuzzy: FuzzyMode::Hard, ..params });
        let case = format!("{} {name}, {} centroids, {}", count(ps.len()), count(c.k()), describe(&params));
        let centroids = (&c.positions[..], &c.normals[..]);
        let rule = AssignRule { metric: params.metric, f: params.f, fuzzy: params.fuzzy };
        let fuzzy_case = if params.f > 1 { format!("{case}, F = {} {:?}", params.f, params.fuzzy) } else { case.clone() };
        let mut parted = Vec::new();
        for d in compare_assign_mapped(device, queue, kernel, (&ps, &ns), centroids, rule, &mut parted)? {
            r.checks.push(d.with_case(&fuzzy_case));
        }
        // The points whose labels differ, seen from the camera.
        let map_case = format!("cluster-{}", name.replace(' ', "-"));
        r.maps.push(DisagreementMap::projected(map_case, &twins.scene.camera, (cfg.width, cfg.height), &parted));
        let grid = Grid::for_data(bounds(&ps), &ps, c.k()).fill(&c.positions, &c.normals);
        let hard = vplgi_cpu::cluster::assign(&grid, &ps, &ns, params.metric, None);
        r.checks.push(compare_update(device, queue, kernel, (&ps, &ns), centroids, &hard)?.with_case(&case));
        // The seeding is checked on every frame's hits; the clustering runs from its seeds when
        // the frame asks for them.
        let seeds = if name == "hit points" {
            let (seeds, check) = compare_seeding(twins, &frame, cfg)?;
            r.checks.push(check);
            (cfg.seeding == Seeding::Adaptive).then_some(seeds)
        } else {
            None
        };
        let seeded = if seeds.is_some() { ", adaptive seeds" } else { "" };
        let whole = format!("{} {name}, K = {}, {} iterations, F = {}, {}{seeded}", count(ps.len()), params.k, params.iterations, params.f, describe(&params));
        let start = seeds.as_deref().map_or(ClusterStart::Stride, ClusterStart::Seeds);
        for d in compare_clustering(device, queue, kernel, (&ps, &ns), &params, start)? {
            r.checks.push(d.with_case(&whole));
        }
        if name == "hit points" {
            for d in compare_temporal(device, queue, kernel, (&ps, &ns), &params, seeds.as_deref())? {
                r.checks.push(d.with_case(format!("{whole}, warm from the CPU's clusters with halved thresholds")));
            }
        }
    }
    r.checks.extend(compare_rsm(twins, &frame, cfg)?);
    r.notes.push("centroids come from a CPU clustering of the same points; assignment is compared on the CPU's grid, the update on the CPU's labels".into());
    r.notes.push(
        "the RSM-space clustering (--vpl-cluster rsm) runs whole on both backends from the CPU's shadow-map VPLs of --rsm-size: labels judged by the \
         assignment row, centres by the update row relative to the scene's diagonal (float sums in the same order on both)"
            .into(),
    );
    Ok(r)
}

/// The RSM-space clustering of the CPU's shadow-map VPLs (`--rsm-size`) on both backends, whole:
/// with `--rsm-seeding importance`, first the importance map of those VPLs seen from the CPU's
/// G-buffer points of `frame` (each texel against its map's largest value, the importance row),
/// then the clustering seeded by the CPU's map on both: the share of VPLs with the same cluster
/// (the assignment row) and the largest distance between the two backends' centres over the
/// scene's diagonal (the update row, 1e-6 relative).
pub fn compare_rsm(twins: &Twins, frame: &CpuFrame, cfg: &FrameConfig) -> Result<Vec<Disagreement>, VerifyError> {
    let device = twins.device();
    let vpls = vplgi_cpu::rsm_vpls::rsm_vpls(twins.cpu, &cfg.rsm_params(), &vplgi_cpu::NoProgress).vpls;
    if vpls.is_empty() {
        return Ok(Vec::new());
    }
    let maps = twins.cpu.lights.rsm_maps(cfg.rsm_size);
    let params = cfg.rsm_cluster_params(twins.cpu.extent);
    let n = vpls.len() as u32;
    let gv = vplgi_gpu::trace_vpls::GpuVpls { buffer: storage(device, "vpls", &vpls), count: n, particles: 0 };
    let mut checks = Vec::new();
    let importance = match cfg.rsm_seeding {
        RsmSeeding::Halton => None,
        RsmSeeding::Importance => {
            let (importance, check) = compare_rsm_importance(twins, &gv, &vpls, &maps, &frame.gbuffer_points(cfg))?;
            checks.push(check);
            Some(importance)
        }
    };
    let gpu_importance = importance.as_ref().map(|i| storage(device, "rsm importance", i));
    let w = cfg.rsm_weights;
    let seeds = match cfg.rsm_seeding {
        RsmSeeding::Halton => "Halton seeds",
        RsmSeeding::Importance => "seeds warped by the CPU's importance map",
    };
    let setup = format!("--rsm-size {}: {} VPLs, K = {}, weights {},{},{}, {seeds}", cfg.rsm_size, count(vpls.len()), cfg.k_vpl, w.position, w.normal, w.flux);
    let rsm = RsmTwins {
        twins,
        vpls: &vpls,
        gpu_vpls: &gv,
        maps: &maps,
        params: &params,
        importance: importance.as_deref(),
        gpu_importance: gpu_importance.as_ref(),
    };
    let (cold, cold_checks) = rsm.compare("cluster (rsm)", None, &setup)?;
    checks.extend(cold_checks);
    // The warm start (--temporal on) from the CPU's clusters with every other one dropped, so
    // that kept slots and re-seeded slots both occur.
    let previous: Vec<RsmCentre> = cold.iter().step_by(2).copied().collect();
    let warm_setup = format!("{setup}, warm from {} of the CPU's {} clusters", previous.len(), cold.len());
    checks.extend(rsm.compare("cluster (rsm, warm)", Some(&previous), &warm_setup)?.1);
    Ok(checks)
}

/// One RSM clustering's inputs on both backends.
struct RsmTwins<'a> {
    twins: &'a Twins<'a>,
    vpls: &'a [Vpl],
    gpu_vpls: &'a vplgi_gpu::trace_vpls::GpuVpls,
    maps: &'a [RsmLight],
    params: &'a RsmClusterParams,
    importance: Option<&'a [f32]>,
    gpu_importance: Option<&'a wgpu::Buffer>,
}

impl RsmTwins<'_> {
    /// Both backends' clustering from `previous` (cold if `None`): the CPU's live clusters, and
    /// the checks under `stage`.
    fn compare(&self, stage: &str, previous: Option<&[RsmCentre]>, setup: &str) -> Result<(Vec<RsmCentre>, Vec<Disagreement>), VerifyError> {
        let (device, queue) = (self.twins.device(), self.twins.queue());
        let cpu = vplgi_cpu::rsm_cluster::rsm_cluster_from(self.vpls, self.maps, self.params, self.importance, previous);
        let start = RsmStart { importance: self.gpu_importance, previous, carry: true };
        let g = self.twins.gpu.kernels().rsm_cluster.run(device, queue, self.gpu_vpls, self.maps, self.params, start)?;
        let labels: Vec<u32> = read_back(device, queue, &g.clustering.labels, self.vpls.len())?;
        let c = &cpu.clustering;
        let same = (0..labels.len()).filter(|&i| labels[i] == c.hard_label(i)).count();
        let first_other =
            (0..labels.len()).find(|&i| labels[i] != c.hard_label(i)).map(|i| format!("VPL {i}: CPU cluster {}, GPU cluster {}", c.hard_label(i), labels[i]));
        // Centres: the kept clusters' and the states carried to a next frame.
        let centres: Vec<Endpoint> = read_back(device, queue, &g.clustering.centroids, g.k as usize)?;
        let extent = self.twins.cpu.extent;
        let mut worst = (0.0f64, None);
        let pairs = c.positions.iter().map(|p| p.to_array()).zip(centres.iter().map(|e| e.position));
        let carried = cpu.centres.iter().map(|s| s.centre).zip(g.centres.iter().map(|s| s.centre));
        for (j, (a, b)) in pairs.chain(carried).enumerate() {
            let d = (Vec3::from(a).distance(Vec3::from(b)) / extent) as f64;
            if d > worst.0 || d.is_nan() {
                worst = (d, Some(format!("centre {j}: CPU {}, GPU {}", v3(a), v3(b))));
            }
        }
        let case = format!("{setup} ({} kept on the CPU, {} on the GPU; slots warm {} / {}, seeded {} / {})", c.k(), g.k, cpu.kept, g.kept, cpu.fresh, g.fresh);
        let differing_counts = c.k().abs_diff(g.k as usize) + cpu.kept.abs_diff(g.kept) as usize + cpu.centres.len().abs_diff(g.centres.len());
        let checks = vec![
            Disagreement::at_least(stage, "share of VPLs in the same cluster", same as f64 / labels.len() as f64, ASSIGN_SAME_LABELS)
                .with_case(&case)
                .with_worst(first_other),
            Disagreement::at_most(stage, "clusters kept, slots warm and states carried, |CPU - GPU| summed", differing_counts as f64, 0.0).with_case(&case),
            Disagreement::at_most(stage, "largest centre distance over the scene diagonal", worst.0, RSM_UPDATE_REL).with_case(&case).with_worst(worst.1),
        ];
        Ok((cpu.centres, checks))
    }
}

/// `rsm_importance` of the same VPLs seen from the same G-buffer points on both backends: the
/// largest difference of a texel's importance over its map's largest (CPU) importance. Returns
/// the CPU's map with the check.
pub fn compare_rsm_importance(
    twins: &Twins,
    gpu_vpls: &vplgi_gpu::trace_vpls::GpuVpls,
    vpls: &[Vpl],
    maps: &[RsmLight],
    points: &[Endpoint],
) -> Result<(Vec<f32>, Disagreement), VerifyError> {
    let (device, queue) = (twins.device(), twins.queue());
    let d_min = rsm_importance::D_MIN_REL * twins.cpu.extent;
    let cpu = vplgi_cpu::rsm_importance::rsm_importance(vpls, maps, points, d_min);
    let gpu_points = storage(device, "importance points", points);
    let kernel = &twins.gpu.kernels().rsm_importance;
    let buffer = kernel.run(device, queue, gpu_vpls, maps, (&gpu_points, points.len() as u32), d_min)?;
    let gpu: Vec<f32> = read_back(device, queue, &buffer, cpu.len())?;
    let mut worst = (0.0f64, None);
    for m in maps {
        let texels = m.first as usize..(m.first + m.size * m.size) as usize;
        let max = cpu[texels.clone()].iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
        for t in texels {
            let d = (cpu[t] as f64 - gpu[t] as f64).abs() / max.max(f64::MIN_POSITIVE);
            if d > worst.0 || d.is_nan() {
                worst = (d, Some(format!("texel {t}: CPU {:e}, GPU {:e}, the map's largest {max:e}", cpu[t], gpu[t])));
            }
        }
    }
    let case = format!("{} VPLs seen from {} G-buffer points (of {} pixels)", count(vpls.len()), points.len(), rsm_importance::PIXELS);
    let check = Disagreement::at_most("cluster (rsm importance)", "largest texel difference over its map's largest importance", worst.0, RSM_IMPORTANCE_REL)
        .with_case(case)
        .with_worst(worst.1);
    Ok((cpu, check))
}
