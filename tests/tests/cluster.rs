//! `cluster`: assignment, update and the whole clustering, GPU against CPU (SPEC: >= 99.99 %
//! same labels, >= 99.9 % same F-sets, weights within 1e-5, bit-identical centroid sums).
//! Each test prints the adapter it ran on and the measured disagreement.

use glam::Vec3;
use proptest::prelude::*;
use vplgi_cpu::cluster::{bounds, cluster, update, ClusterParams, Grid};
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::cluster::{AssignRule, ClusterKernel};
use vplgi_gpu::visibility::Endpoint;
use vplgi_tests::tolerance::{Disagreement, ASSIGN_SAME_LABELS, FUZZY_SAME_SETS, FUZZY_WEIGHTS_ABS, UPDATE_DIFFERING_CENTROIDS};
use vplgi_types::clustering::{FixedPoint, GridGeometry};
use vplgi_types::FuzzyMode;

fn endpoints(ps: &[Vec3], ns: &[Vec3]) -> Vec<Endpoint> {
    ps.iter().zip(ns).map(|(&p, &n)| Endpoint::new(p, n)).collect()
}

/// How the GPU's assignment agrees with the CPU's on the same points, centroids and grid.
struct AssignAgreement {
    points: usize,
    hard_same: usize,
    set_same: usize,
    max_w: f32,
}

impl AssignAgreement {
    /// Checks the SPEC's rows for assignment and fuzzy assignment, printing the measurements.
    fn check(&self, case: &str) {
        let m = self.points as f64;
        Disagreement::at_least(case, "share of identical nearest labels", self.hard_same as f64 / m, ASSIGN_SAME_LABELS).check();
        Disagreement::at_least(case, "share of identical F-index sets", self.set_same as f64 / m, FUZZY_SAME_SETS).check();
        Disagreement::at_most(case, "largest weight difference", self.max_w as f64, FUZZY_WEIGHTS_ABS).check();
    }
}

/// Assigns the points to their `f` nearest of `centroids` (weighted) on the CPU's grid, on both
/// backends, and compares.
fn compare_assign(
    ctx: &vplgi_gpu::GpuContext,
    kernel: &ClusterKernel,
    (ps, ns): (&[Vec3], &[Vec3]),
    centroids: (&[Vec3], &[Vec3]),
    f: usize,
) -> AssignAgreement {
    let m = ps.len();
    let k = centroids.0.len();
    let grid = Grid::for_data(bounds(ps), ps, k).fill(centroids.0, centroids.1);
    let (cpu_labels, cpu_w): (Vec<Vec<u32>>, Vec<Vec<f32>>) = ps
        .iter()
        .zip(ns)
        .map(|(&p, &n)| {
            let mut best = vec![(f32::INFINITY, vplgi_types::MISS); f];
            let (count, _) = grid.search(p, n, 0.866, &mut best);
            let mut w = vec![0.0f32; f];
            vplgi_types::clustering::fuzzy_weights(&best[..count], FuzzyMode::Weighted, grid.cell, &mut w[..count]);
            (best.iter().map(|b| b.1).collect(), w)
        })
        .unzip();
    let pts = storage(&ctx.device, "points", &endpoints(ps, ns));
    let cents = storage(&ctx.device, "centroids", &endpoints(centroids.0, centroids.1));
    let geometry = GridGeometry { origin: grid.origin, cell: grid.cell, dims: grid.dims };
    let ggrid = kernel.fill_grid(&ctx.device, &ctx.queue, &geometry, &cents, k as u32).unwrap();
    let rule = AssignRule { threshold: 0.866, f: f as u32, fuzzy: FuzzyMode::Weighted };
    let a = kernel.assign(&ctx.device, &ctx.queue, &ggrid, (&pts, m as u32), (&cents, k as u32), rule).unwrap();
    let gl: Vec<u32> = read_back(&ctx.device, &ctx.queue, &a.labels, m * f).unwrap();
    let gw: Vec<f32> = read_back(&ctx.device, &ctx.queue, &a.weights, m * f).unwrap();
    let mut agreement = AssignAgreement { points: m, hard_same: 0, set_same: 0, max_w: 0.0 };
    for i in 0..m {
        agreement.hard_same += (gl[i * f] == cpu_labels[i][0]) as usize;
        let same_set = gl[i * f..(i + 1) * f] == cpu_labels[i][..];
        agreement.set_same += same_set as usize;
        if same_set {
            for j in 0..f {
                agreement.max_w = agreement.max_w.max((gw[i * f + j] - cpu_w[i][j]).abs());
            }
        }
    }
    agreement
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, failure_persistence: None, ..ProptestConfig::default() })]

    /// Assignment on random surface-like point sets (patches of any orientation, seen from one or
    /// both sides, at scales from 1e-2 to 1e2), with centroids from a CPU clustering of them:
    /// the SPEC's assignment and fuzzy-assignment rows.
    #[test]
    fn cluster_assign_matches_the_cpu_on_random_points((ps, ns) in vplgi_tests::inputs::surface_points(), k_div in 4usize..40, f in 1usize..=8) {
        let Some(ctx) = vplgi_tests::gpu("cluster_assign_matches_the_cpu_on_random_points") else { return Ok(()) };
        let kernel = ClusterKernel::new(&ctx.device).unwrap();
        let k = (ps.len() / k_div).max(1) as u32;
        let c = cluster(&ps, &ns, &ClusterParams { k, gamma: 1, iterations: 2, f: 1, fuzzy: FuzzyMode::Hard, normal_threshold: 0.866, seed: 5 });
        let agreement = compare_assign(&ctx, &kernel, (&ps, &ns), (&c.positions, &c.normals), f);
        agreement.check(&format!("cluster assign, {} random points, {} centroids, F = {f}", ps.len(), c.k()));
    }
}

/// Assignment given identical centroids and grid: ≥ 99.99 % identical nearest labels, ≥ 99.9 %
/// identical F-index sets, weights within 1e-5 (SPEC); centroid update given identical labels:
/// bit-identical (integer sums).
#[test]
fn cluster_assign_and_update_match_the_cpu() {
    let Some(ctx) = vplgi_tests::gpu("cluster_assign_and_update_match_the_cpu") else {
        return;
    };
    let kernel = ClusterKernel::new(&ctx.device).unwrap();
    let (ps, ns) = vplgi_tests::inputs::cornell_points(72, 64, 2);
    let m = ps.len();
    // Centroids from a CPU clustering: realistic, and shared by both sides.
    let c = cluster(&ps, &ns, &ClusterParams { k: 300, gamma: 2, iterations: 3, f: 1, fuzzy: FuzzyMode::Hard, normal_threshold: 0.866, seed: 3 });
    let f = 6;
    let agreement = compare_assign(&ctx, &kernel, (&ps, &ns), (&c.positions, &c.normals), f);
    println!(
        "cluster assign ({m} points, {} centroids, F = {f}): nearest label identical {}/{m}, F-sets identical {}/{m}, max weight difference {:.2e}",
        c.k(),
        agreement.hard_same,
        agreement.set_same,
        agreement.max_w
    );
    agreement.check("cluster assign");

    // Update given identical labels (the CPU's hard labels).
    let grid = Grid::for_data(bounds(&ps), &ps, c.k()).fill(&c.positions, &c.normals);
    let hard = vplgi_cpu::cluster::assign(&grid, &ps, &ns, 0.866, None);
    let pts = storage(&ctx.device, "points", &endpoints(&ps, &ns));
    let cents = storage(&ctx.device, "centroids", &endpoints(&c.positions, &c.normals));
    let (lo, hi) = bounds(&ps);
    let fix = FixedPoint::new(lo, hi);
    let (mut cp, mut cn) = (c.positions.clone(), c.normals.clone());
    let cpu_counts = update(&fix, &ps, &ns, &hard, &mut cp, &mut cn);
    let labels = storage(&ctx.device, "labels", &hard);
    let gcounts = kernel.update(&ctx.device, &ctx.queue, &fix, (&pts, m as u32), (&labels, 1), (&cents, c.k() as u32)).unwrap();
    let gc: Vec<Endpoint> = read_back(&ctx.device, &ctx.queue, &cents, c.k()).unwrap();
    let gcount: Vec<u32> = read_back(&ctx.device, &ctx.queue, &gcounts, c.k()).unwrap();
    assert_eq!(gcount, cpu_counts);
    let mut differ = 0;
    for k in 0..c.k() {
        let same = gc[k].position[..3] == cp[k].to_array() && gc[k].normal[..3] == cn[k].to_array();
        differ += !same as usize;
    }
    println!("cluster update: {differ} of {} centroids differ from the CPU's (bit-identical required)", c.k());
    Disagreement::at_most("cluster update", "centroids that differ", differ as f64, UPDATE_DIFFERING_CENTROIDS as f64).check();
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
    for (k, f, fuzzy) in [(400u32, 6u32, FuzzyMode::Weighted), (150, 1, FuzzyMode::Hard), (5000, 4, FuzzyMode::Average)] {
        let cpu = cluster(&ps, &ns, &ClusterParams { k, gamma: 4, iterations: 10, f, fuzzy, normal_threshold: 0.866, seed: 7 });
        let pts = storage(&ctx.device, "points", &endpoints(&ps, &ns));
        let g = kernel
            .cluster(&ctx.device, &ctx.queue, &pts, m as u32, &ClusterParams { k, gamma: 4, iterations: 10, f, fuzzy, normal_threshold: 0.866, seed: 7 })
            .unwrap();
        let gl: Vec<u32> = read_back(&ctx.device, &ctx.queue, &g.labels, m * g.f as usize).unwrap();
        let gr: Vec<u32> = read_back(&ctx.device, &ctx.queue, &g.representatives, g.k as usize).unwrap();
        let gc: Vec<Endpoint> = read_back(&ctx.device, &ctx.queue, &g.centroids, g.k as usize).unwrap();
        let same_k = g.k as usize == cpu.k();
        let labels_same = (0..m).filter(|&i| gl[i * g.f as usize..(i + 1) * g.f as usize] == cpu.labels[i * cpu.f..(i + 1) * cpu.f]).count();
        let centroids_same = same_k && (0..cpu.k()).all(|j| gc[j].position[..3] == cpu.positions[j].to_array());
        println!(
            "cluster end to end (K = {k}, F = {f}, {fuzzy:?}): clusters CPU {} / GPU {}; label rows identical {labels_same}/{m}; centroids bit-identical: {centroids_same}; representatives identical: {}",
            cpu.k(),
            g.k,
            same_k && gr == cpu.representatives
        );
        assert!(same_k, "cluster counts differ");
        assert!(labels_same as f64 >= 0.999 * m as f64);
        assert_eq!(gr, cpu.representatives);
    }
}
