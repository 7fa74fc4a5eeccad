//! `cluster`: assignment, update and the whole clustering, GPU against CPU (SPEC: >= 99.99 %
//! same labels, >= 99.9 % same F-sets, weights within 1e-5, bit-identical centroid sums).
//! Each test prints the adapter it ran on and the measured disagreement. Its parts' tests are
//! modules of this one: `seeding`.

#[path = "cluster/seeding.rs"]
mod seeding;

use glam::Vec3;
use proptest::prelude::*;
use vplgi_cpu::cluster::{bounds, cluster, ClusterParams, Grid};
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::cluster::{AssignRule, ClusterKernel};
use vplgi_gpu::visibility::Endpoint;
use vplgi_types::clustering::{Metric, Representative};
use vplgi_types::FuzzyMode;
use vplgi_verify::cluster::{compare_assign, compare_update};

fn endpoints(ps: &[Vec3], ns: &[Vec3]) -> Vec<Endpoint> {
    ps.iter().zip(ns).map(|(&p, &n)| Endpoint::new(p, n)).collect()
}

fn fuzzy_mode() -> impl Strategy<Value = FuzzyMode> {
    prop_oneof![Just(FuzzyMode::Hard), Just(FuzzyMode::Average), Just(FuzzyMode::Weighted)]
}

/// Eq. 7 at the paper's n_t, or Eq. 2 with alpha from 0.01 to 30 per diagonal of the point set
/// (normals dominate at one end, positions at the other): `None` is Eq. 7, `Some(a)` Eq. 2 with
/// `a` per diagonal.
fn metric_choice() -> impl Strategy<Value = Option<f32>> {
    prop_oneof![Just(None), (-2f32..1.5).prop_map(|e| Some(10f32.powf(e)))]
}

/// The metric of [`metric_choice`] for points spanning `ps`.
fn metric_for(choice: Option<f32>, ps: &[Vec3]) -> Metric {
    let (lo, hi) = bounds(ps);
    match choice {
        None => Metric::Eq7 { normal_threshold: 0.866 },
        Some(a) => Metric::Ward { alpha: a / (hi - lo).length().max(1e-6) },
    }
}

/// Centroids for a point set: `k` of its points, each moved by up to `jitter` of the set's size
/// and given a random normal in a quarter of the cases (centroids far from any point's normal
/// make the search widen).
fn centroids_of(
    (ps, ns): (&[Vec3], &[Vec3]),
    k: usize,
    jitter: f32,
    seed: u64,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng =
        vplgi_types::Rng::new(seed as u32, vplgi_types::Stream::Oracle, (seed >> 32) as u32);
    let (lo, hi) = bounds(ps);
    let size = (hi - lo).length().max(1e-6);
    (0..k)
        .map(|_| {
            let i = rng.next_u32() as usize % ps.len();
            let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            let n = if rng.next_u32().is_multiple_of(4) {
                (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5)
                    .normalize_or(Vec3::Y)
            } else {
                ns[i]
            };
            (ps[i] + d * jitter * size, n)
        })
        .unzip()
}

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(12))]

    /// Assignment on random surface-like point sets (patches of any orientation, seen from one or
    /// both sides, at scales from 1e-2 to 1e2) to random centroids (points of the set moved by up
    /// to 20 % of its size, some with unrelated normals), any K, F and weighting: the SPEC's
    /// assignment and fuzzy-assignment rows, measured by `vplgi verify`'s comparison.
    #[test]
    fn cluster_assign_matches_the_cpu_on_random_points((ps, ns) in vplgi_tests::inputs::surface_points(), k_div in 2usize..60, f in 1u32..=8, fuzzy in fuzzy_mode(), metric in metric_choice(), jitter in 0f32..0.2, seed in any::<u64>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("cluster_assign_matches_the_cpu_on_random_points") else { return Ok(()) };
        let k = (ps.len() / k_div).max(1);
        let (cp, cn) = centroids_of((&ps, &ns), k, jitter, seed);
        let f = if fuzzy == FuzzyMode::Hard { 1 } else { f };
        let rule = AssignRule { metric: metric_for(metric, &ps), f, fuzzy };
        let checks = compare_assign(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster, (&ps, &ns), (&cp, &cn), rule).expect("GPU");
        println!("{} points, {k} centroids, F = {f} {fuzzy:?}, {:?}", ps.len(), rule.metric);
        vplgi_tests::hold(&checks)?;
    }

    /// The centroid update on random point sets with random labels (some clusters left empty):
    /// bit-identical centroids and member counts (SPEC).
    #[test]
    fn cluster_update_matches_the_cpu_on_random_labels((ps, ns) in vplgi_tests::inputs::surface_points(), k in 1usize..200, seed in any::<u64>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("cluster_update_matches_the_cpu_on_random_labels") else { return Ok(()) };
        let (cp, cn) = centroids_of((&ps, &ns), k, 0.1, seed);
        let mut rng = vplgi_types::Rng::new(seed as u32, vplgi_types::Stream::Oracle, 1);
        let labels: Vec<u32> = ps.iter().map(|_| rng.next_u32() % (k as u32 * 3 / 2 + 1)).map(|l| l.min(k as u32 - 1)).collect();
        let d = compare_update(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster, (&ps, &ns), (&cp, &cn), &labels).expect("GPU");
        println!("{} points, {k} clusters", ps.len());
        vplgi_tests::hold(&[d])?;
    }

    /// `--temporal on`'s pieces on random point sets, any K, F and metric: each cluster's
    /// threshold from the same clustering (bit-identical), the admission of every point by the
    /// same previous centres with halved thresholds (the assignment row), and the whole warm
    /// clustering (the fuzzy row), by `vplgi verify`'s comparison.
    #[test]
    fn cluster_warm_start_matches_the_cpu_on_random_points((ps, ns) in vplgi_tests::inputs::surface_points(), k_div in 2usize..60, f in 1u32..=8, fuzzy in fuzzy_mode(), metric in metric_choice(), seed in any::<u32>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("cluster_warm_start_matches_the_cpu_on_random_points") else { return Ok(()) };
        let k = (ps.len() / k_div).max(1) as u32;
        let f = if fuzzy == FuzzyMode::Hard { 1 } else { f };
        let metric = metric_for(metric, &ps);
        let representative = match metric {
            Metric::Ward { alpha } => Representative::MinError { alpha },
            Metric::Eq7 { .. } => Representative::Nearest,
        };
        let params = ClusterParams { k, gamma: 2, iterations: 3, f, fuzzy, metric, representative, seed };
        let checks = vplgi_verify::cluster::compare_temporal(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster, (&ps, &ns), &params, None).expect("GPU");
        println!("{} points, K = {k}, F = {f} {fuzzy:?}, {metric:?}", ps.len());
        vplgi_tests::hold(&checks)?;
    }
}

/// Assignment given identical centroids and grid on the Cornell box's shading points: ≥ 99.99 %
/// identical nearest labels, ≥ 99.9 % identical F-index sets, weights within 1e-5 (SPEC);
/// centroid update given identical labels: bit-identical (integer sums).
#[test]
fn cluster_assign_and_update_match_the_cpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("cluster_assign_and_update_match_the_cpu") else {
        return;
    };
    let (ps, ns) = vplgi_tests::inputs::cornell_points(72, 64, 2);
    // Centroids from a CPU clustering: realistic, and shared by both sides.
    let c = cluster(
        &ps,
        &ns,
        &ClusterParams {
            k: 300,
            gamma: 2,
            iterations: 3,
            f: 1,
            fuzzy: FuzzyMode::Hard,
            metric: vplgi_types::clustering::Metric::Eq7 { normal_threshold: 0.866 },
            representative: vplgi_types::clustering::Representative::Nearest,
            seed: 3,
        },
    );
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    let rule = AssignRule {
        metric: vplgi_types::clustering::Metric::Eq7 { normal_threshold: 0.866 },
        f: 6,
        fuzzy: FuzzyMode::Weighted,
    };
    for d in
        compare_assign(device, queue, kernel, (&ps, &ns), (&c.positions, &c.normals), rule).unwrap()
    {
        d.with_case("cornell points").check();
    }
    let grid = Grid::for_data(bounds(&ps), &ps, c.k()).fill(&c.positions, &c.normals);
    let hard = vplgi_cpu::cluster::assign(
        &grid,
        &ps,
        &ns,
        vplgi_types::clustering::Metric::Eq7 { normal_threshold: 0.866 },
        None,
    );
    compare_update(device, queue, kernel, (&ps, &ns), (&c.positions, &c.normals), &hard)
        .unwrap()
        .with_case("cornell points")
        .check();
}

/// Points far from every centroid: 6,000 centroids packed into a tenth of a square of 20,000
/// points in a cube, so a point across the square walks a dozen or more rings of cells before
/// its F nearest are settled. lavapipe stops every loop of a shader invocation once they have
/// run 65,535 iterations between them (llvmpipe's loop limiter), silently: a walk that exhausts
/// it ends the search's last loops early and leaves points with farther clusters than the
/// nearest, or none. The GPU's labels must be the exact nearest compatible centroids, found by
/// brute force.
#[test]
fn long_searches_find_the_exact_nearest_centroids() {
    let Some(gpu) = vplgi_tests::shared_gpu("long_searches_find_the_exact_nearest_centroids")
    else {
        return;
    };
    let mut rng = vplgi_types::rng::Rng::new(11, vplgi_types::rng::Stream::Oracle, 0);
    // A unit square of points in a unit cube (one point at its far corner): the grid's cells
    // are sized for the square, so a search's rings are shells of a 3-D grid, tens of thousands
    // of cells deep, as for the visible walls of a room.
    let mut ps: Vec<Vec3> =
        (0..20_000).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), 0.0)).collect();
    ps.push(Vec3::ONE);
    let ns = vec![Vec3::Z; ps.len()];
    let cp: Vec<Vec3> = ps
        .iter()
        .filter(|p| p.x < 0.1)
        .take(1_500)
        .flat_map(|&p| (0..4).map(move |i| p + Vec3::new(0.0, 0.0, i as f32 * 1e-3)))
        .collect();
    let cn = vec![Vec3::Z; cp.len()];
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    let metric = Metric::Eq7 { normal_threshold: 0.866 };
    let grid = Grid::for_data(bounds(&ps), &ps, cp.len()).fill(&cp, &cn);
    let geometry = vplgi_types::clustering::GridGeometry {
        origin: grid.origin,
        cell: grid.cell,
        dims: grid.dims,
    };
    let cents = storage(device, "centroids", &endpoints(&cp, &cn));
    let points = storage(device, "points", &endpoints(&ps, &ns));
    let ggrid = kernel.fill_grid(device, queue, &geometry, &cents, cp.len() as u32).unwrap();
    for (f, fuzzy) in [(1usize, FuzzyMode::Hard), (6, FuzzyMode::Weighted)] {
        let a = kernel
            .assign(
                device,
                queue,
                &ggrid,
                (&points, ps.len() as u32),
                (&cents, cp.len() as u32),
                AssignRule { metric, f: f as u32, fuzzy },
            )
            .unwrap();
        let labels: Vec<u32> = read_back(device, queue, &a.labels, ps.len() * f).unwrap();
        let outcome: Vec<u32> = read_back(device, queue, &a.outcome, ps.len()).unwrap();
        let (mut wrong, mut widened, mut first) = (0usize, 0usize, None);
        for (i, &p) in ps.iter().enumerate() {
            // Every centroid is compatible; any with another in its 27 cells is Eq. 7's
            // neighbourhood answer, so only the widened searches are held to the exact order.
            if outcome[i] == 0 {
                continue;
            }
            widened += 1;
            let mut all: Vec<(f32, u32)> =
                cp.iter().enumerate().map(|(k, &c)| ((p - c).length_squared(), k as u32)).collect();
            all.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let exact: Vec<u32> = all[..f].iter().map(|x| x.1).collect();
            if labels[i * f..(i + 1) * f] != exact[..] {
                wrong += 1;
                first.get_or_insert_with(|| {
                    format!(
                        "point {i} at {p}: GPU {:?}, exact {exact:?}",
                        &labels[i * f..(i + 1) * f]
                    )
                });
            }
        }
        println!("F = {f}: {widened} widened searches, {wrong} not the exact nearest");
        assert!(widened > 10_000, "the case must make long searches ({widened} widened)");
        assert_eq!(wrong, 0, "F = {f}: the first is {}", first.unwrap_or_default());
    }
}

/// The whole clustering (Alg. 1 iterations, empty-cluster removal, Alg. 2, representatives)
/// on both backends from the same data and seed.
#[test]
fn cluster_end_to_end_matches_the_cpu() {
    let Some(ctx) = vplgi_tests::gpu("cluster_end_to_end_matches_the_cpu") else {
        return;
    };
    let kernel = ClusterKernel::new(&ctx.device).unwrap();
    let (ps, ns) = vplgi_tests::inputs::cornell_points(72, 64, 2);
    let m = ps.len();
    // Eq. 2 with the frame's default alpha (0.3 per diagonal) and the min-error representatives.
    let diagonal = {
        let (lo, hi) = bounds(&ps);
        (hi - lo).length()
    };
    let eq7 = (Metric::Eq7 { normal_threshold: 0.866 }, Representative::Nearest);
    let ward = (
        Metric::Ward { alpha: 0.3 / diagonal },
        Representative::MinError { alpha: 0.3 / diagonal },
    );
    for (k, f, fuzzy, (metric, representative)) in [
        (400u32, 6u32, FuzzyMode::Weighted, eq7),
        (150, 1, FuzzyMode::Hard, eq7),
        (5000, 4, FuzzyMode::Average, eq7),
        (400, 6, FuzzyMode::Weighted, ward),
        (150, 1, FuzzyMode::Hard, ward),
    ] {
        let params = ClusterParams {
            k,
            gamma: 4,
            iterations: 10,
            f,
            fuzzy,
            metric,
            representative,
            seed: 7,
        };
        let cpu = cluster(&ps, &ns, &params);
        let pts = storage(&ctx.device, "points", &endpoints(&ps, &ns));
        let g = kernel.cluster(&ctx.device, &ctx.queue, &pts, m as u32, &params).unwrap();
        let gl: Vec<u32> = read_back(&ctx.device, &ctx.queue, &g.labels, m * g.f as usize).unwrap();
        let gr: Vec<u32> =
            read_back(&ctx.device, &ctx.queue, &g.representatives, g.k as usize).unwrap();
        let gc: Vec<Endpoint> =
            read_back(&ctx.device, &ctx.queue, &g.centroids, g.k as usize).unwrap();
        let same_k = g.k as usize == cpu.k();
        let labels_same = (0..m)
            .filter(|&i| {
                gl[i * g.f as usize..(i + 1) * g.f as usize]
                    == cpu.labels[i * cpu.f..(i + 1) * cpu.f]
            })
            .count();
        let centroids_same =
            same_k && (0..cpu.k()).all(|j| gc[j].position[..3] == cpu.positions[j].to_array());
        println!(
            "cluster end to end (K = {k}, F = {f}, {fuzzy:?}, {metric:?}, {representative:?}): clusters CPU {} / GPU {}; label rows identical {labels_same}/{m}; centroids bit-identical: {centroids_same}; representatives identical: {}",
            cpu.k(),
            g.k,
            same_k && gr == cpu.representatives
        );
        assert!(same_k, "cluster counts differ");
        assert!(labels_same as f64 >= 0.999 * m as f64);
        assert_eq!(gr, cpu.representatives);
    }
}

/// The two reductions of the clustering against a plain count: the points' bounding box (the
/// grid's geometry) and the totals of the search outcomes. Each invocation folds a run of
/// `REDUCE_ITEMS` points, so every extreme sits at the last point of a run, the first, or the
/// very last point; on the default device and on one whose small bindings split the points into
/// windows.
#[test]
fn cluster_bounds_and_outcome_counts_are_exact() {
    let Some(ctx) = vplgi_tests::gpu("cluster_bounds_and_outcome_counts_are_exact") else {
        return;
    };
    let small = vplgi_gpu::GpuContext::with_limits(Some(64 * 1024), None)
        .expect("a device with small bindings");
    let run = vplgi_gpu::shader::REDUCE_ITEMS as usize;
    let n = 40 * run + 37;
    let mut rng = vplgi_types::Rng::new(11, vplgi_types::Stream::Oracle, 0);
    let mut ps: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0)
        .collect();
    // The extremes: -x at the end of a run, +x at the start of one, -y and +z at the very end
    // and beginning, +y and -z in the middle of runs.
    ps[run - 1].x = -5.0;
    ps[3 * run].x = 4.0;
    ps[n - 1].y = -3.0;
    ps[0].z = 6.0;
    ps[7 * run + 5].y = 2.5;
    ps[20 * run + 31].z = -7.0;
    let outcome: Vec<u32> = (0..n).map(|_| rng.next_u32() % 3).collect();
    let want = [0, 1, 2].map(|o| outcome.iter().filter(|&&x| x == o).count() as u32);
    for c in [&ctx, &small] {
        let kernel = ClusterKernel::new(&c.device).unwrap();
        let pts = storage(&c.device, "points", &endpoints(&ps, &vec![Vec3::Y; n]));
        let (lo, hi) = kernel.bounds(&c.device, &c.queue, &pts, n as u32).unwrap();
        println!("bounds: GPU {lo} .. {hi}, CPU {:?}", bounds(&ps));
        assert_eq!((lo, hi), bounds(&ps));
        assert_eq!((lo, hi), (Vec3::new(-5.0, -3.0, -7.0), Vec3::new(4.0, 2.5, 6.0)));
        let counts = kernel
            .outcome_counts(&c.device, &c.queue, &storage(&c.device, "outcome", &outcome), n as u32)
            .unwrap();
        println!("outcome counts: GPU {counts:?}, CPU {want:?}");
        assert_eq!(counts, want);
    }
}

/// An oracle of the RSM clustering's search: a VPL with no cluster within r = 2 grid cells takes
/// the cluster of smallest μ among all, not the first. A 32² map whose left half lies on a floor
/// (+y) and right half on a wall (-x), importance only in the floor's leftmost 6 texel columns,
/// K = 36 (a 6 x 6 grid): every seed is there, and the wall's VPLs beyond column 24 see no
/// cluster near. Each takes the floor cluster nearest in its own row, so they spread over
/// several clusters; taking the first would put them all in one.
#[test]
fn rsm_vpls_without_a_near_cluster_take_the_best_of_all() {
    use vplgi_shared::rsm::{point, RsmClusterParams, RsmLight, RsmWeights};
    let n = 32u32;
    let vpls: Vec<vplgi_types::Vpl> = (0..n * n)
        .map(|t| {
            let (i, j) = ((t % n) as f32 / n as f32, (t / n) as f32 / n as f32);
            let (position, normal) = if t % n < n / 2 {
                ([i, 0.0, j], [0.0, 1.0, 0.0])
            } else {
                ([0.5, i - 0.5, j], [-1.0, 0.0, 0.0])
            };
            vplgi_types::Vpl {
                position,
                path: t,
                normal,
                bounce: 1,
                flux: [1e-3; 3],
                specular: 0,
                ..Default::default()
            }
        })
        .collect();
    let map = RsmLight { size: n, ..point(Vec3::ZERO, Vec3::ONE) };
    let importance: Vec<f32> = (0..n * n).map(|t| if t % n < 6 { 1.0 } else { 0.0 }).collect();
    let params = RsmClusterParams {
        k: 36,
        iterations: 0,
        weights: RsmWeights::default(),
        extent: 3f32.sqrt(),
    };
    let c = vplgi_cpu::rsm_cluster::rsm_cluster(&vpls, &[map], &params, Some(&importance));
    let far: std::collections::BTreeSet<u32> =
        (0..vpls.len()).filter(|&t| t as u32 % n >= 24).map(|t| c.hard_label(t)).collect();
    println!("the wall's far VPLs (no cluster within 2 cells) are in {} clusters", far.len());
    assert!(far.len() >= 4, "the far VPLs share {} clusters", far.len());
}

/// One map of `flux.len()` texels in a row (map side that count), VPL t at `positions[t]`
/// facing +y with flux `flux[t]`, clustered with K = `k` and no iteration beyond the first update.
fn rsm_row(positions: &[[f32; 3]], flux: &[[f32; 3]], k: u32) -> vplgi_cpu::cluster::Clustering {
    use vplgi_shared::rsm::{point, RsmClusterParams, RsmLight, RsmWeights};
    let vpls: Vec<vplgi_types::Vpl> = (0..positions.len())
        .map(|t| vplgi_types::Vpl {
            position: positions[t],
            path: t as u32,
            normal: [0.0, 1.0, 0.0],
            bounce: 1,
            flux: flux[t],
            specular: 0,
            ..Default::default()
        })
        .collect();
    let map =
        RsmLight { size: positions.len() as u32, ..point(Vec3::new(0.0, 1.0, 0.0), Vec3::ONE) };
    let params = RsmClusterParams { k, iterations: 0, weights: RsmWeights::default(), extent: 4.0 };
    vplgi_cpu::rsm_cluster::rsm_cluster(&vpls, &[map], &params, None)
}

/// A cluster's representative is its member nearest the centre, ties to the lower index, as on
/// the GPU (`representatives` in rsm_cluster.wgsl). Two members of equal flux at x = 0 and 2 have
/// their centre at x = 1 exactly, so both are at squared distance 1: the first must win.
#[test]
fn rsm_cluster_representative_ties_go_to_the_lower_index() {
    let c = rsm_row(&[[0.0; 3], [2.0, 0.0, 0.0]], &[[1.0, 0.0, 0.0]; 2], 1);
    println!("centre {:?}, representative {:?}", c.positions, c.representatives);
    assert_eq!(c.positions, vec![Vec3::new(1.0, 0.0, 0.0)]);
    assert_eq!(c.representatives, vec![0]);
}

/// VPLs on a black surface carry no flux (rsm_vpls keeps them: the texel did hit). A cluster of
/// only such members has no flux-weighted centre (Prutkin et al.'s update divides by the summed
/// flux), so it keeps its seed's position rather than 0/0.
#[test]
fn rsm_clusters_without_flux_keep_a_finite_centre() {
    let c = rsm_row(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[[0.0; 3]; 3], 1);
    println!("centre {:?}, representative {:?}", c.positions, c.representatives);
    assert_eq!(c.k(), 1);
    assert!(c.positions[0].is_finite(), "centre {:?}", c.positions[0]);
    assert!(
        [0.0, 1.0, 2.0].contains(&c.positions[0].x),
        "the centre {:?} is not a member's position",
        c.positions[0]
    );
}

/// Without VPLs or with K = 0 the clustering is empty but still hard: `f` is the stride of its
/// labels, and consumers divide label counts by it.
#[test]
fn an_empty_rsm_clustering_has_stride_one() {
    let none = rsm_row(&[], &[], 4);
    let zero_k = rsm_row(&[[0.0; 3]], &[[1.0; 3]], 0);
    for c in [none, zero_k] {
        assert_eq!((c.k(), c.f), (0, 1));
    }
}

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// The RSM-space clustering (`--vpl-cluster rsm`) of random scenes' shadow-map VPLs, any map
    /// size, K, iteration count, Eq. 1 weights and seeding, whole on both backends: with the
    /// importance map, its row (each texel within 1e-5 of its map's largest) and then the
    /// clustering from the CPU's map; the SPEC's assignment row (same clusters) and update row
    /// (centres within 1e-6 of the scene's diagonal), measured by `vplgi verify`'s comparison.
    #[test]
    fn rsm_cluster_matches_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        (rsm_size, k_vpl, iterations) in (8u32..64, 1u32..300, 0u32..8),
        (wd, wn, wphi) in (0f32..4.0, 0f32..20.0, 0f32..20.0),
        importance in proptest::bool::ANY,
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("rsm_cluster_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        let weights = vplgi_shared::rsm::RsmWeights { position: wd, normal: wn, flux: wphi + 0.01 };
        let rsm_seeding = if importance { vplgi_types::RsmSeeding::Importance } else { vplgi_types::RsmSeeding::Halton };
        let cfg = vplgi_types::FrameConfig {
            rsm_size,
            k_vpl,
            iterations,
            rsm_weights: weights,
            rsm_seeding,
            vpl_source: vplgi_types::VplSource::Rsm,
            vpl_cluster: vplgi_types::VplClustering::Rsm,
            bounces: 1,
            ..vplgi_types::FrameConfig::verify()
        };
        println!("{}: --rsm-size {rsm_size}, K {k_vpl}, {iterations} iterations, weights {wd},{wn},{}, {rsm_seeding:?} seeds", scene.name, wphi + 0.01);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            let frame = vplgi_verify::inputs::CpuFrame::new(t.cpu, &cfg);
            vplgi_verify::cluster::compare_rsm(t, &frame, &cfg)
        })
        .expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// `n` points drawn from `distinct` positions on `shape` (in [0, 10]^3 flattened by `shape`),
/// normals +z, in a scrambled order: few distinct cells, so the grid shrinks to its bound.
fn degenerate_points(n: usize, distinct: usize, shape: Vec3, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng = vplgi_types::Rng::new(seed, vplgi_types::Stream::Oracle, 0);
    let spots: Vec<Vec3> = (0..distinct)
        .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0 * shape)
        .collect();
    let ps: Vec<Vec3> = (0..n).map(|_| spots[rng.next_u32() as usize % distinct]).collect();
    (ps, vec![Vec3::Z; n])
}

/// Flat and degenerate data: points on a plane, on a line, or all at one point, with few
/// distinct positions so that the grid shrinks as far as it may. The grid stays within
/// MAX_CELLS cells (a degenerate axis gets at most two, not thousands), and the whole clustering
/// agrees on both backends (SPEC: cluster count, label rows), for Eq. 7 and Eq. 2.
#[test]
fn degenerate_point_sets_get_bounded_grids_and_the_same_clusters() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("degenerate_point_sets_get_bounded_grids_and_the_same_clusters")
    else {
        return;
    };
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    for (name, shape, distinct) in [
        ("a plane", Vec3::new(1.0, 1.0, 0.0), 100),
        ("a near-plane", Vec3::new(1.0, 1.0, 1e-4), 100),
        ("a line", Vec3::new(1.0, 0.0, 0.0), 100),
        ("one point", Vec3::ZERO, 1),
    ] {
        let (ps, ns) = degenerate_points(20_000, distinct, shape, 3);
        let k = 1_000;
        let grid = Grid::for_data(bounds(&ps), &ps, k);
        let cells: f64 = grid.dims.iter().map(|&d| d as f64).product();
        println!("{name}: grid {:?} ({cells} cells)", grid.dims);
        assert!(
            cells <= 1.1 * vplgi_types::clustering::MAX_CELLS,
            "{name}: {:?} is {cells} cells",
            grid.dims
        );
        for a in 0..3 {
            if shape[a] < 1e-3 {
                assert!(
                    grid.dims[a] <= 2,
                    "{name}: axis {a} of extent {} gets {} cells",
                    10.0 * shape[a],
                    grid.dims[a]
                );
            }
        }
        for metric in [Metric::Eq7 { normal_threshold: 0.866 }, Metric::Ward { alpha: 0.03 }] {
            let params = ClusterParams {
                k: k as u32,
                gamma: 4,
                iterations: 4,
                f: 4,
                fuzzy: FuzzyMode::Weighted,
                metric,
                representative: Representative::Nearest,
                seed: 5,
            };
            let checks = vplgi_verify::cluster::compare_clustering(
                device,
                queue,
                kernel,
                (&ps, &ns),
                &params,
                vplgi_types::clustering::ClusterStart::Stride,
            )
            .unwrap();
            vplgi_tests::check_all(&format!("{name}, {metric:?}: "), &checks);
        }
    }
}

/// K = 100,000 centroids in one grid cell, the nearest of them the last: points there search
/// all of them in their 27 cells, points at the far corner of the data scan them all. The
/// assignment finds each point's F nearest (ties to the lower index) on the GPU as on the CPU:
/// lavapipe's loop limiter must not end either search early.
#[test]
fn a_hundred_thousand_centroids_in_one_cell_are_all_searched() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("a_hundred_thousand_centroids_in_one_cell_are_all_searched")
    else {
        return;
    };
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    let ps: Vec<Vec3> = (0..512).map(|i| if i % 2 == 0 { Vec3::ZERO } else { Vec3::ONE }).collect();
    let ns = vec![Vec3::Z; ps.len()];
    let mut cp = vec![Vec3::splat(1e-4); 100_000];
    cp[99_999] = Vec3::ZERO;
    let cn = vec![Vec3::Z; cp.len()];
    let grid = Grid::for_data(bounds(&ps), &ps, cp.len()).fill(&cp, &cn);
    assert!(grid.cell > 1e-3, "the centroids must share a cell: {}", grid.cell);
    for rule in [
        AssignRule {
            metric: Metric::Eq7 { normal_threshold: 0.866 },
            f: 1,
            fuzzy: FuzzyMode::Hard,
        },
        AssignRule { metric: Metric::Ward { alpha: 0.03 }, f: 6, fuzzy: FuzzyMode::Weighted },
    ] {
        let checks = compare_assign(device, queue, kernel, (&ps, &ns), (&cp, &cn), rule).unwrap();
        vplgi_tests::check_all(&format!("{:?}: ", rule.metric), &checks);
    }
}

/// K = 100,000 shading-point clusters of a 640x480 Cornell box frame (about 250,000 points),
/// whole on both backends: the SPEC's cluster count and label rows.
#[test]
fn a_hundred_thousand_shading_point_clusters_match_the_cpu() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("a_hundred_thousand_shading_point_clusters_match_the_cpu")
    else {
        return;
    };
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    let (ps, ns) = vplgi_tests::inputs::cornell_points(640, 480, 2);
    let params = ClusterParams {
        k: 100_000,
        gamma: 2,
        iterations: 2,
        f: 6,
        fuzzy: FuzzyMode::Weighted,
        metric: Metric::Eq7 { normal_threshold: 0.866 },
        representative: Representative::Nearest,
        seed: 7,
    };
    println!("{} points, K = {}", ps.len(), params.k);
    let checks = vplgi_verify::cluster::compare_clustering(
        device,
        queue,
        kernel,
        (&ps, &ns),
        &params,
        vplgi_types::clustering::ClusterStart::Stride,
    )
    .unwrap();
    vplgi_tests::check_all("", &checks);
}

/// Shadow-map VPLs at --rsm-size 512 (over 200,000) in two clusters, so each cluster's update
/// and representative walk over about 100,000 members: the RSM clustering agrees on both
/// backends (SPEC: assignment and update rows), cold and warm.
#[test]
fn two_hundred_thousand_rsm_vpls_in_two_clusters_match_the_cpu() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("two_hundred_thousand_rsm_vpls_in_two_clusters_match_the_cpu")
    else {
        return;
    };
    let cfg = vplgi_types::FrameConfig {
        rsm_size: 512,
        k_vpl: 2,
        iterations: 2,
        rsm_seeding: vplgi_types::RsmSeeding::Halton,
        vpl_source: vplgi_types::VplSource::Rsm,
        vpl_cluster: vplgi_types::VplClustering::Rsm,
        bounces: 1,
        ..vplgi_types::FrameConfig::verify()
    };
    let scene = vplgi_scene::cornell::cornell_box();
    let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
        let frame = vplgi_verify::inputs::CpuFrame::new(t.cpu, &cfg);
        vplgi_verify::cluster::compare_rsm(t, &frame, &cfg)
    })
    .expect("GPU");
    assert!(!checks.is_empty(), "no RSM rows");
    vplgi_tests::check_all("", &checks);
}
