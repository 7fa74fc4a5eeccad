use super::*;
use proptest::prelude::*;
use vplgi_types::clustering::{ward_error, FixedPoint};
use vplgi_types::{FuzzyMode, Rng, Stream};

/// Eq. 7 with normal threshold `nt`.
fn eq7(nt: f32) -> Metric {
    Metric::Eq7 { normal_threshold: nt }
}

fn compatible(n: Vec3, m: Vec3, nt: f32) -> bool {
    cosine(n, m) > nt
}

fn params(k: u32, f: u32, fuzzy: FuzzyMode) -> ClusterParams {
    ClusterParams { k, gamma: 2, iterations: 5, f, fuzzy, metric: eq7(0.866_025_4), representative: Representative::Nearest, seed: 3 }
}

/// Points on the six faces of a unit cube (normals outward), like shading points in a room.
fn cube_surface(n: usize, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng = Rng::new(seed, Stream::Oracle, 0);
    let mut ps = Vec::new();
    let mut ns = Vec::new();
    for i in 0..n {
        let (u, v) = (rng.next_f32(), rng.next_f32());
        let axis = i % 3;
        let side = if (i / 3) % 2 == 0 { 0.0 } else { 1.0 };
        let mut p = Vec3::ZERO;
        p[axis] = side;
        p[(axis + 1) % 3] = u;
        p[(axis + 2) % 3] = v;
        let mut nrm = Vec3::ZERO;
        nrm[axis] = if side == 0.0 { -1.0 } else { 1.0 };
        ps.push(p);
        ns.push(nrm);
    }
    (ps, ns)
}

fn brute_nearest(p: Vec3, n: Vec3, cs: &[Vec3], cn: &[Vec3], nt: f32) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for k in 0..cs.len() {
        if compatible(n, cn[k], nt) {
            let cand = (dist2(p, cs[k]), k as u32);
            if best.is_none_or(|b| cand < b) {
                best = Some(cand);
            }
        }
    }
    best
}

/// The 27-cell search against an all-pairs search, on surface-like data: the answer must be a
/// compatible centroid, exact whenever the search had to widen, and the approximation must
/// rarely differ. The measured disagreement is printed.
#[test]
fn grid_search_against_all_pairs() {
    let mut differ = 0usize;
    let mut total = 0usize;
    let mut worst_ratio = 1.0f32;
    for seed in 0..6 {
        let (ps, ns) = cube_surface(4000, seed);
        let (cs, cn) = cube_surface(60 + 40 * seed as usize, seed + 100);
        let geometry = Grid::for_data(bounds(&ps), &ps, cs.len());
        let grid = geometry.fill(&cs, &cn);
        for (&p, &n) in ps.iter().zip(&ns) {
            let mut best = [(f32::INFINITY, MISS)];
            let (count, outcome) = grid.search(p, n, eq7(0.866), &mut best);
            let brute = brute_nearest(p, n, &cs, &cn, 0.866);
            total += 1;
            match brute {
                None => assert_eq!(outcome, SearchOutcome::Incompatible),
                Some(b) => {
                    assert_eq!(count, 1);
                    assert!(compatible(n, cn[best[0].1 as usize], 0.866), "grid returned an incompatible centroid");
                    if outcome == SearchOutcome::Widened {
                        assert_eq!(best[0], b, "a widened search must be exact");
                    }
                    if best[0] != b {
                        differ += 1;
                        worst_ratio = worst_ratio.max((best[0].0 / b.0).sqrt());
                    }
                }
            }
        }
    }
    let rate = differ as f64 / total as f64;
    println!("27-cell approximation differs from all-pairs on {differ} of {total} points ({:.3} %), worst distance ratio {worst_ratio:.3}", 100.0 * rate);
    assert!(rate < 0.01, "27-cell approximation differs too often: {rate}");
}

#[test]
fn widened_search_when_neighbourhood_is_empty() {
    // Centroids at one corner, a point at the far corner: the 27 cells are empty.
    let cs: Vec<Vec3> = (0..64).map(|i| Vec3::new((i % 4) as f32, ((i / 4) % 4) as f32, (i / 16) as f32) * 0.01).collect();
    let cn = vec![Vec3::Z; cs.len()];
    let mut all = cs.clone();
    all.push(Vec3::splat(10.0));
    let grid = Grid::for_data(bounds(&all), &all, cs.len()).fill(&cs, &cn);
    let mut best = [(f32::INFINITY, MISS)];
    let (count, outcome) = grid.search(Vec3::splat(10.0), Vec3::Z, eq7(0.5), &mut best);
    assert_eq!((count, outcome), (1, SearchOutcome::Widened));
    assert_eq!(best[0], brute_nearest(Vec3::splat(10.0), Vec3::Z, &cs, &cn, 0.5).unwrap());
    // With a normal nobody shares, the nearest by position is taken.
    let (count, outcome) = grid.search(Vec3::splat(10.0), -Vec3::Z, eq7(0.5), &mut best);
    assert_eq!((count, outcome), (1, SearchOutcome::Incompatible));
    assert_eq!(best[0].1, 63);
}

/// A crowded neighbourhood (CROWDED_CENTROIDS cells and centroids around the point) is not
/// visited: every centroid is scanned, so Eq. 7 gives the exact nearest of all (here one just
/// outside the 27 cells, nearer than those inside them), reported as widened. With fewer
/// centroids inside, the neighbourhood's own nearest is the answer, as the paper has it.
#[test]
fn crowded_neighbourhoods_are_scanned_exactly() {
    // Data along x from 0 to 1; positions below are in cells of its grid along that line.
    let line: Vec<Vec3> = (0..=100).map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0)).collect();
    let geometry = Grid::for_data(bounds(&line), &line, 100);
    let at = |cells: f32| geometry.origin + Vec3::new(cells * geometry.cell, 0.0, 0.0);
    assert!(geometry.dims[0] > 60, "{:?}", geometry.dims);
    // The point near the top of cell 50: its neighbourhood is cells 49 to 51. A heap 1.9 cells
    // below (cell 49, inside), one centroid 1.1 cells above (cell 52, outside).
    let p = at(50.95);
    for heap in [CROWDED_CENTROIDS as usize, 100] {
        let mut cs = vec![at(49.05); heap];
        cs.push(at(52.05));
        let cn = vec![Vec3::Z; cs.len()];
        let grid = geometry.fill(&cs, &cn);
        let mut best = [(f32::INFINITY, MISS)];
        let (count, outcome) = grid.search(p, Vec3::Z, eq7(0.5), &mut best);
        if heap >= CROWDED_CENTROIDS as usize {
            let exact = brute_nearest(p, Vec3::Z, &cs, &cn, 0.5).unwrap();
            assert_eq!(exact.1 as usize, heap, "the lone centroid is the nearest");
            assert_eq!((count, outcome, best[0]), (1, SearchOutcome::Widened, exact), "crowded: the exact nearest");
        } else {
            assert_eq!((count, outcome, best[0].1), (1, SearchOutcome::Neighbourhood, 0), "the neighbourhood's own nearest");
        }
    }
}

#[test]
fn centroid_update_does_not_depend_on_point_order() {
    let (ps, ns) = cube_surface(5000, 9);
    let labels: Vec<u32> = (0..ps.len() as u32).map(|i| i % 17).collect();
    let (lo, hi) = bounds(&ps);
    let fix = FixedPoint::new(lo, hi);
    let mut c1 = vec![Vec3::ZERO; 17];
    let mut n1 = vec![Vec3::Z; 17];
    update(&fix, &ps, &ns, &labels, &mut c1, &mut n1);
    let order: Vec<usize> = (0..ps.len()).rev().collect();
    let ps2: Vec<Vec3> = order.iter().map(|&i| ps[i]).collect();
    let ns2: Vec<Vec3> = order.iter().map(|&i| ns[i]).collect();
    let l2: Vec<u32> = order.iter().map(|&i| labels[i]).collect();
    let mut c2 = vec![Vec3::ZERO; 17];
    let mut n2 = vec![Vec3::Z; 17];
    update(&fix, &ps2, &ns2, &l2, &mut c2, &mut n2);
    assert_eq!(c1, c2);
    assert_eq!(n1, n2);
    // And the fixed-point mean is close to the float mean.
    let mean: Vec3 =
        ps.iter().zip(&labels).filter(|(_, &l)| l == 0).map(|(p, _)| *p).sum::<Vec3>() / ps.iter().zip(&labels).filter(|(_, &l)| l == 0).count() as f32;
    assert!((mean - c1[0]).length() < 1e-5, "{mean} vs {}", c1[0]);
}

#[test]
fn fixed_point_sums_survive_huge_clusters() {
    // 2^32 points at the box's far corner would overflow 32-bit sums; 64-bit sums with a 2^25
    // range per value hold 2^39 of them. Check the mean of such a sum directly.
    let fix = FixedPoint { min: Vec3::ZERO, ext: Vec3::ONE };
    let q = fix.quantize(Vec3::ONE, Vec3::Z);
    let count = u32::MAX;
    let sums = q.map(|v| v as u64 * count as u64);
    let (p, n) = fix.mean(&sums, count);
    assert!((p - Vec3::ONE).length() < 1e-6, "{p}");
    assert_eq!(n, Some(Vec3::Z));
}

fn check_invariants(c: &Clustering, ps: &[Vec3], k_requested: u32) {
    let m = ps.len();
    assert!(c.k() <= (k_requested as usize).min(m));
    assert_eq!(c.labels.len(), m * c.f);
    assert_eq!(c.members.iter().map(|&x| x as usize).sum::<usize>(), m);
    // One count per kept cluster: the points whose nearest cluster it is.
    assert_eq!(c.members.len(), c.k());
    for (j, &n) in c.members.iter().enumerate() {
        assert_eq!(n as usize, (0..m).filter(|&i| c.hard_label(i) == j as u32).count(), "members of cluster {j}");
    }
    for (i, &p) in ps.iter().enumerate() {
        let row = &c.labels[i * c.f..(i + 1) * c.f];
        let w = &c.weights[i * c.f..(i + 1) * c.f];
        let valid = row.iter().take_while(|&&l| l != MISS).count();
        assert!(valid >= 1, "point {i} has no cluster");
        assert!(row[valid..].iter().all(|&l| l == MISS), "padding must be at the end");
        assert!(row[..valid].iter().all(|&l| (l as usize) < c.k()));
        let mut sorted = row[..valid].to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), valid, "labels of point {i} repeat: {row:?}");
        let d: Vec<f32> = row[..valid].iter().map(|&l| dist2(p, c.positions[l as usize])).collect();
        assert!(d.windows(2).all(|p| p[0] <= p[1]), "labels of point {i} not ordered by distance: {d:?}");
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "weights of point {i} sum to {sum}");
        assert!(w[valid..].iter().all(|&x| x == 0.0));
    }
    for (k, &r) in c.representatives.iter().enumerate() {
        assert_eq!(c.hard_label(r as usize), k as u32, "representative of {k} is not a member");
    }
}

#[test]
fn k_at_least_the_number_of_points_gives_one_cluster_per_point() {
    let (ps, ns) = cube_surface(50, 1);
    let c = cluster(&ps, &ns, &params(80, 1, FuzzyMode::Hard));
    assert_eq!(c.k(), 50);
    check_invariants(&c, &ps, 80);
    for i in 0..50 {
        assert_eq!(c.representatives[c.hard_label(i) as usize], i as u32);
    }
}

#[test]
fn coincident_points_share_a_cluster() {
    let ps = vec![Vec3::new(0.5, 0.5, 0.5); 40];
    let ns = vec![Vec3::Y; 40];
    let c = cluster(&ps, &ns, &params(10, 4, FuzzyMode::Weighted));
    assert_eq!(c.k(), 1, "coincident points: one non-empty cluster");
    check_invariants(&c, &ps, 10);
}

#[test]
fn opposite_normals_never_share_a_cluster_when_avoidable() {
    // Two coincident sheets with opposite normals (a thin wall seen from both sides).
    let (mut ps, mut ns) = (Vec::new(), Vec::new());
    let mut rng = Rng::new(5, Stream::Oracle, 0);
    for i in 0..2000 {
        ps.push(Vec3::new(rng.next_f32(), rng.next_f32(), 0.0));
        ns.push(if i % 2 == 0 { Vec3::Z } else { -Vec3::Z });
    }
    let c = cluster(&ps, &ns, &params(40, 6, FuzzyMode::Weighted));
    check_invariants(&c, &ps, 40);
    for (i, &n) in ns.iter().enumerate() {
        for j in 0..c.f {
            let l = c.labels[i * c.f + j];
            if l != MISS {
                assert!(c.normals[l as usize].dot(n) > 0.866, "point {i} joined a cluster facing the other way");
            }
        }
    }
    assert_eq!(c.incompatible, 0);
}

#[test]
fn empty_input_and_zero_k() {
    let c = cluster(&[], &[], &params(10, 6, FuzzyMode::Weighted));
    assert_eq!(c.k(), 0);
    assert!(c.labels.is_empty());
    // The row stride is the fuzziness asked for, even with nothing to cluster (and 1 when hard).
    assert_eq!(c.f, 6);
    assert_eq!(cluster(&[], &[], &params(10, 6, FuzzyMode::Hard)).f, 1);
    assert_eq!(cluster(&[Vec3::ZERO], &[Vec3::Z], &params(0, 4, FuzzyMode::Average)).f, 4);
}

#[test]
fn same_seed_same_clustering_on_one_and_two_threads() {
    let (ps, ns) = cube_surface(20_000, 2);
    let p = params(300, 6, FuzzyMode::Weighted);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| cluster(&ps, &ns, &p));
    let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap().install(|| cluster(&ps, &ns, &p));
    assert_eq!(one, two);
}

fn arb_points() -> impl Strategy<Value = (Vec<Vec3>, Vec<Vec3>)> {
    prop::collection::vec(
        (
            (0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0),
            prop_oneof![Just(Vec3::X), Just(-Vec3::X), Just(Vec3::Y), Just(Vec3::Z), Just(-Vec3::Z), Just(Vec3::new(0.6, 0.8, 0.0))],
            0u8..4,
        ),
        1..400,
    )
    .prop_map(|v| {
        // Some points are snapped to a coarse lattice so that coincident points occur.
        v.into_iter()
            .map(|((x, y, z), n, snap)| {
                let p = Vec3::new(x, y, z);
                (if snap == 0 { (p * 4.0).round() / 4.0 } else { p }, n)
            })
            .unzip()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    /// Every point gets a cluster; fuzzy rows are distinct, ordered by distance, and their
    /// weights sum to 1; representatives are members; K is never exceeded.
    #[test]
    fn clustering_invariants((ps, ns) in arb_points(), k in 1u32..600, f in 1u32..8, mode in prop_oneof![Just(FuzzyMode::Hard), Just(FuzzyMode::Average), Just(FuzzyMode::Weighted)], seed in 0u32..1000) {
        let c = cluster(&ps, &ns, &ClusterParams { k, gamma: 3, iterations: 4, f, fuzzy: mode, metric: eq7(0.866_025_4), representative: Representative::Nearest, seed });
        check_invariants(&c, &ps, k);
        if mode == FuzzyMode::Hard { prop_assert_eq!(c.f, 1); }
    }
}

/// A search that starts from a hint (the previous label) and skips cells by their distance
/// bound gives the answer of the plain search, for every kind of hint (the answer itself, any
/// centroid, a far or incompatible one, none), and keeps ties going to the lower index.
#[test]
fn hinted_search_equals_the_plain_search() {
    let mut compared = 0;
    for seed in 0..4 {
        let (ps, ns) = cube_surface(3000, seed);
        let (cs, cn) = cube_surface(150 + 50 * seed as usize, seed + 50);
        let grid = Grid::for_data(bounds(&ps), &ps, cs.len()).fill(&cs, &cn);
        let mut rng = Rng::new(seed, Stream::Oracle, 1);
        for (&p, &n) in ps.iter().zip(&ns) {
            let mut best = [(f32::INFINITY, MISS)];
            let (count, outcome) = grid.search(p, n, eq7(0.866), &mut best);
            let plain = if count > 0 { best[0].1 } else { MISS };
            // The oracle of the paper's approximation, without grid runs or distance bounds:
            // the nearest compatible centroid whose cell is one of the 27 around the point's.
            let pc = grid.coords(p);
            let oracle = (0..cs.len())
                .filter(|&k| compatible(n, cn[k], 0.866) && (0..3).all(|a| (grid.coords(cs[k])[a] - pc[a]).abs() <= 1))
                .map(|k| (dist2(p, cs[k]), k as u32))
                .fold(None, |b: Option<(f32, u32)>, c| if b.is_none_or(|b| c < b) { Some(c) } else { b });
            if outcome == SearchOutcome::Neighbourhood {
                assert_eq!(Some(best[0]), oracle, "point {p}");
            }
            for hint in [plain, rng.next_u32() % cs.len() as u32, rng.next_u32() % cs.len() as u32, MISS] {
                assert_eq!(grid.search_near(p, n, eq7(0.866), hint), (plain, outcome), "point {p}, hint {hint}");
                compared += 1;
            }
        }
    }
    println!("hinted search: {compared} searches identical to the plain search");

    // Exact ties: four centroids at the same distance 0.25 (exact in binary) around a point,
    // the highest index nearest the grid origin's corner of the point's cell.
    let p = Vec3::splat(0.5);
    let cs = vec![Vec3::new(0.5, 0.75, 0.5), Vec3::new(0.25, 0.5, 0.5), Vec3::new(0.5, 0.25, 0.5), Vec3::new(0.75, 0.5, 0.5)];
    let cn = vec![Vec3::Z; 4];
    let data: Vec<Vec3> = (0..64).map(|i| Vec3::new((i % 4) as f32 / 3.0, ((i / 4) % 4) as f32 / 3.0, (i / 16) as f32 / 3.0)).collect();
    let grid = Grid::for_data(bounds(&data), &data, cs.len()).fill(&cs, &cn);
    for hint in [0, 1, 2, 3, MISS] {
        assert_eq!(grid.search_near(p, Vec3::Z, eq7(0.5), hint).0, 0, "hint {hint}: the tie goes to the lowest index");
    }
}

/// The F nearest compatible centroids by brute force, nearest first, ties to the lower index.
fn brute_f_nearest(p: Vec3, n: Vec3, cs: &[Vec3], cn: &[Vec3], nt: f32, f: usize) -> Vec<(f32, u32)> {
    let mut all: Vec<(f32, u32)> = (0..cs.len()).filter(|&k| compatible(n, cn[k], nt)).map(|k| (dist2(p, cs[k]), k as u32)).collect();
    all.sort_by(|a, b| a.partial_cmp(b).unwrap());
    all.truncate(f);
    all
}

/// Points whose 27 cells hold no centroid: the widened search returns the exact F nearest, both
/// when the rings find them and when it switches to scanning every centroid (few centroids).
#[test]
fn widened_search_returns_the_exact_f_nearest() {
    let mut widened = 0;
    for (seed, k) in [(0u32, 6usize), (1, 40), (2, 300), (3, 2000)] {
        let mut rng = Rng::new(seed, Stream::Oracle, 2);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        // Centroids in two small clumps of a 10-unit box; points anywhere, normals in two
        // directions so that some centroids are incompatible.
        let cs: Vec<Vec3> = (0..k).map(|i| if i % 2 == 0 { v() } else { Vec3::splat(9.0) + v() }).collect();
        let cn: Vec<Vec3> = (0..k).map(|i| if i % 3 == 0 { -Vec3::Z } else { Vec3::Z }).collect();
        let ps: Vec<Vec3> = (0..400).map(|_| v() * 10.0).collect();
        let grid = Grid::for_data(bounds(&ps), &cs, cs.len()).fill(&cs, &cn);
        for (i, &p) in ps.iter().enumerate() {
            let n = if i % 4 == 0 { -Vec3::Z } else { Vec3::Z };
            for f in 1..=8usize {
                let mut best = [(f32::INFINITY, MISS); 8];
                let (count, outcome) = grid.search(p, n, eq7(0.5), &mut best[..f]);
                if outcome != SearchOutcome::Widened {
                    continue;
                }
                widened += 1;
                assert_eq!(&best[..count], &brute_f_nearest(p, n, &cs, &cn, 0.5, f)[..], "point {p}, F {f}, K {k}");
            }
        }
    }
    println!("{widened} widened searches equal to the brute-force F nearest");
    assert!(widened > 1000, "too few searches widened ({widened}) to test the rule");
}

/// The neighbourhood's bounds in world units: cells of about 100 units, so squared gaps are far
/// above 1 and a bound combined the wrong way (a product of the row's gaps instead of their sum,
/// say) would exceed the true distance and skip a diagonal cell holding one of the F nearest.
/// With Eq. 7 the answer is the paper's: the F nearest of the 27 cells around the point's own,
/// here by brute force over the centroids in those cells.
#[test]
fn large_cells_keep_the_neighbourhood_bounds_exact() {
    let mut rng = Rng::new(9, Stream::Oracle, 3);
    let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1000.0;
    let cs: Vec<Vec3> = (0..600).map(|_| v()).collect();
    let cn = vec![Vec3::Z; cs.len()];
    let ps: Vec<Vec3> = (0..2000).map(|_| v()).collect();
    let grid = Grid::for_data(bounds(&ps), &cs, cs.len()).fill(&cs, &cn);
    assert!(grid.cell > 50.0, "cells of {} units", grid.cell);
    let mut checked = 0;
    for &p in &ps {
        let pc = grid.coords(p);
        let block: Vec<usize> = (0..cs.len()).filter(|&k| (0..3).all(|a| (grid.coords(cs[k])[a] - pc[a]).abs() <= 1)).collect();
        if block.is_empty() {
            continue;
        }
        let (bcs, bcn): (Vec<Vec3>, Vec<Vec3>) = block.iter().map(|&k| (cs[k], cn[k])).unzip();
        for f in 1..=4usize {
            let mut best = [(f32::INFINITY, MISS); 4];
            let (count, outcome) = grid.search(p, Vec3::Z, eq7(0.5), &mut best[..f]);
            assert_eq!(outcome, SearchOutcome::Neighbourhood);
            let expected: Vec<(f32, u32)> = brute_f_nearest(p, Vec3::Z, &bcs, &bcn, 0.5, f).into_iter().map(|(d, i)| (d, block[i as usize] as u32)).collect();
            assert_eq!(&best[..count], &expected[..], "point {p}, F {f}");
            checked += 1;
        }
    }
    assert!(checked > 4000, "{checked} searches checked");
}

/// The neighbour-cell bounds are lowered by 1e-4 cell, so a centroid just across a face is never
/// skipped: a point 5e-5 cell inside its cell, a hint 1e-4 cell away in the same cell and the
/// true nearest 8e-5 cell away across the face, on both faces of each axis.
#[test]
fn centroid_just_across_a_face_beats_the_hint() {
    let data: Vec<Vec3> = (0..512).map(|i| Vec3::new((i % 8) as f32, ((i / 8) % 8) as f32, (i / 64) as f32)).collect();
    let geometry = Grid::for_data(bounds(&data), &data, 64);
    let at = |q: Vec3| geometry.origin + q * geometry.cell;
    let mid = Vec3::splat(geometry.dims[0].min(geometry.dims[1]).min(geometry.dims[2]) as f32 / 2.0).floor() + 0.5;
    for axis in 0..3 {
        for side in [0.0f32, 1.0] {
            let s = if side == 0.0 { 1.0 } else { -1.0 };
            let mut e = Vec3::ZERO;
            e[axis] = 1.0;
            let face = mid - 0.5 * e + side * e;
            let p = at(face + s * 5e-5 * e);
            let across = at(face - s * 3e-5 * e);
            let mut other = Vec3::ZERO;
            other[(axis + 1) % 3] = 1e-4;
            let hint = at(face + s * 5e-5 * e + other);
            let cs = vec![hint, across];
            let cn = vec![Vec3::Z; 2];
            let grid = geometry.fill(&cs, &cn);
            assert_ne!(grid.coords(p), grid.coords(across), "axis {axis}, side {side}: the test needs the face between them");
            assert_eq!(grid.coords(p), grid.coords(hint));
            assert!(dist2(p, across) < dist2(p, hint));
            assert_eq!(grid.search_near(p, Vec3::Z, eq7(0.5), 0).0, 1, "axis {axis}, side {side}");
        }
    }
}

/// Exact ties at distance 0: two centroids on the point, the hint the higher index. The own
/// row's bound (0) equals the limit (0) and must not be skipped, or the tie goes to the hint.
#[test]
fn tie_at_zero_distance_goes_to_the_lower_index_with_a_hint() {
    let data: Vec<Vec3> = (0..64).map(|i| Vec3::new((i % 4) as f32, ((i / 4) % 4) as f32, (i / 16) as f32)).collect();
    let p = Vec3::new(1.3, 1.6, 1.2);
    let grid = Grid::for_data(bounds(&data), &data, 8).fill(&[p, p], &[Vec3::Z, Vec3::Z]);
    assert_eq!(grid.search_near(p, Vec3::Z, eq7(0.5), 1).0, 0);
    assert_eq!(grid.search_near(p, Vec3::Z, eq7(0.5), 0).0, 0);
}

/// With no compatible centroid anywhere, the nearest by position is taken, ties to the lower
/// index.
#[test]
fn incompatible_tie_goes_to_the_lower_index() {
    let cs = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0)];
    let cn = vec![Vec3::Z; 3];
    let grid = Grid::for_data(bounds(&cs), &cs, cs.len()).fill(&cs, &cn);
    let mut best = [(f32::INFINITY, MISS)];
    assert_eq!(grid.search(Vec3::ZERO, -Vec3::Z, eq7(0.5), &mut best), (1, SearchOutcome::Incompatible));
    assert_eq!(best[0], (1.0, 0));
}

/// The counts the frame reports: points whose 27 cells held no compatible centroid (widened) and,
/// of those, points with no compatible centroid anywhere (incompatible), recounted by searching
/// the final centroids on a grid of the clustering's geometry. 200 points facing up and 3 facing
/// down: with K = 1 the centroid faces up, so exactly those 3 are incompatible.
#[test]
fn widened_and_incompatible_points_are_counted() {
    let mut rng = Rng::new(9, Stream::Oracle, 3);
    let mut ps: Vec<Vec3> = (0..200).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), 0.0)).collect();
    let mut ns = vec![Vec3::Z; 200];
    for p in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.5, 0.0, 0.0)] {
        ps.push(p);
        ns.push(-Vec3::Z);
    }
    for k in [1u32, 7, 40] {
        let p = params(k, 3, FuzzyMode::Weighted);
        let c = cluster(&ps, &ns, &p);
        // The geometry `cluster` uses: the downsampled points (gamma, never below K points).
        let gamma = (p.gamma as usize).clamp(1, (ps.len() / k as usize).max(1));
        let sample: Vec<Vec3> = vplgi_types::clustering::downsample(ps.len(), gamma, p.seed).iter().map(|&i| ps[i as usize]).collect();
        let grid = Grid::for_data(bounds(&ps), &sample, k as usize).fill(&c.positions, &c.normals);
        let (mut widened, mut incompatible) = (0, 0);
        for (&q, &n) in ps.iter().zip(&ns) {
            let mut best = [(f32::INFINITY, MISS); 3];
            match grid.search(q, n, p.metric, &mut best).1 {
                SearchOutcome::Neighbourhood => {}
                SearchOutcome::Widened => widened += 1,
                SearchOutcome::Incompatible => (widened, incompatible) = (widened + 1, incompatible + 1),
            }
        }
        println!("K = {k}: {} clusters, {widened} widened, {incompatible} incompatible", c.k());
        assert_eq!((c.widened, c.incompatible), (widened, incompatible), "K = {k}");
        if k == 1 {
            assert_eq!(incompatible, 3);
        }
    }
}

/// Eq. 2 of Wang et al. on hand-checked pairs: alpha |x - c| + sqrt(2 - 2 n . m).
#[test]
fn ward_error_on_hand_checked_pairs() {
    let m = Metric::Ward { alpha: 0.5 };
    let d2 = dist2(Vec3::ZERO, Vec3::new(3.0, 4.0, 0.0));
    // Distance 5, normals at 90°: 2.5 + sqrt 2.
    assert_eq!(m.key(d2, cosine(Vec3::Z, Vec3::X)), Some(2.5 + std::f32::consts::SQRT_2));
    // Same normal: the position term alone; opposite normals: + 2; 60° apart: + 1.
    assert_eq!(m.key(d2, 1.0), Some(2.5));
    assert_eq!(m.key(d2, -1.0), Some(4.5));
    assert_eq!(m.key(0.0, 0.5), Some(1.0));
    // A dot product a rounding above 1 (unit normals) gives no NaN.
    assert_eq!(m.key(0.0, 1.000_000_1), Some(0.0));
    // Never ruled out, where Eq. 7 rules out anything at or below n_t.
    assert_eq!(eq7(0.5).key(d2, 0.5), None);
    assert_eq!(eq7(0.5).key(d2, 0.6), Some(25.0));
    // The bounds a search skips cells by: nothing at distance 5 scores below 2.5 under Eq. 2,
    // and a key of 2.5 is settled once the unvisited cells are 5 away.
    assert_eq!(m.key_bound(d2), 2.5);
    assert!(m.settled(2.5, 5.0) && !m.settled(2.5, 4.9));
}

/// The F smallest Eq. 2 errors by brute force, ties to the lower index.
fn brute_f_ward(p: Vec3, n: Vec3, cs: &[Vec3], cn: &[Vec3], alpha: f32, f: usize) -> Vec<(f32, u32)> {
    let mut all: Vec<(f32, u32)> = (0..cs.len()).map(|k| (ward_error(alpha, dist2(p, cs[k]), cosine(n, cn[k])), k as u32)).collect();
    all.sort_by(|a, b| a.partial_cmp(b).unwrap());
    all.truncate(f);
    all
}

/// Under Eq. 2 the grid search is exact, neighbourhood or not: on room-like points with
/// centroids of every orientation (some unrelated to any surface), at alphas from one where
/// normals dominate to one where position does, every search equals the brute-force F
/// smallest errors, and a hinted search the plain one.
#[test]
fn ward_search_equals_brute_force() {
    let (mut searches, mut widened) = (0, 0);
    for (seed, alpha) in [(0u32, 0.05f32), (1, 0.3), (2, 3.0), (3, 30.0)] {
        let (ps, ns) = cube_surface(1500, seed);
        let (cs, mut cn) = cube_surface(40 + 90 * seed as usize, seed + 70);
        let mut rng = Rng::new(seed, Stream::Oracle, 4);
        for n in cn.iter_mut().step_by(3) {
            *n = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize_or(Vec3::Y);
        }
        let metric = Metric::Ward { alpha };
        let grid = Grid::for_data(bounds(&ps), &ps, cs.len()).fill(&cs, &cn);
        for (&p, &n) in ps.iter().zip(&ns) {
            for f in [1usize, 3, 8] {
                let mut best = [(f32::INFINITY, MISS); 8];
                let (count, outcome) = grid.search(p, n, metric, &mut best[..f]);
                assert_ne!(outcome, SearchOutcome::Incompatible);
                widened += (outcome == SearchOutcome::Widened) as usize;
                searches += 1;
                assert_eq!(&best[..count], &brute_f_ward(p, n, &cs, &cn, alpha, f)[..], "point {p}, F {f}, alpha {alpha}");
            }
            let nearest = brute_f_ward(p, n, &cs, &cn, alpha, 1)[0].1;
            for hint in [nearest, rng.next_u32() % cs.len() as u32, MISS] {
                assert_eq!(grid.search_near(p, n, metric, hint).0, nearest, "point {p}, hint {hint}, alpha {alpha}");
            }
        }
    }
    println!("{searches} Eq. 2 searches equal to brute force, {widened} of them beyond the 27 cells");
    assert!(widened > 100 && widened < searches, "the test must exercise both ways a search ends ({widened} of {searches} widened)");
}

/// `--representative min-error`: each cluster's representative is the member of smallest
/// Eq. 2 error to its centroid (brute force over the hard labels), and on a surface with a
/// crease it is a different member than the nearest.
#[test]
fn min_error_representative_is_the_brute_force_minimum() {
    let (ps, mut ns) = cube_surface(3000, 5);
    // Tilt a third of the normals, so that position and normal disagree on who is closest.
    let mut rng = Rng::new(5, Stream::Oracle, 5);
    for n in ns.iter_mut().step_by(3) {
        *n = (*n + 0.6 * (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5)).normalize();
    }
    let alpha = 0.4;
    let base = ClusterParams { metric: Metric::Ward { alpha }, ..params(60, 1, FuzzyMode::Hard) };
    let near = cluster(&ps, &ns, &base);
    let min_error = cluster(&ps, &ns, &ClusterParams { representative: Representative::MinError { alpha }, ..base });
    assert_eq!(near.labels, min_error.labels, "the representative rule must not change the clusters");
    let mut differ = 0;
    for j in 0..min_error.k() {
        let (c, cn) = (min_error.positions[j], min_error.normals[j]);
        let brute = (0..ps.len())
            .filter(|&i| min_error.hard_label(i) == j as u32)
            .map(|i| (ward_error(alpha, dist2(ps[i], c), cosine(ns[i], cn)), i as u32))
            .fold((f32::INFINITY, MISS), |b, x| if x < b { x } else { b });
        assert_eq!(min_error.representatives[j], brute.1, "cluster {j}");
        differ += (near.representatives[j] != brute.1) as usize;
    }
    println!("min-error representatives differ from the nearest in {differ} of {} clusters", min_error.k());
    assert!(differ > 0, "tilted normals must change some representatives");
}

/// Eq. 2 with a small alpha clusters by normal first: two perpendicular walls meeting at an
/// edge, two clusters, and every cluster lies on one wall; a huge alpha clusters by position
/// and mixes them near the edge.
#[test]
fn ward_with_a_small_alpha_separates_walls_by_normal() {
    let mut rng = Rng::new(8, Stream::Oracle, 6);
    let (mut ps, mut ns) = (Vec::new(), Vec::new());
    for i in 0..2000 {
        let (u, v) = (rng.next_f32(), rng.next_f32());
        // A long floor and a short wall: position alone would cut across the edge.
        if i % 2 == 0 {
            ps.push(Vec3::new(u * 4.0, 0.0, v));
            ns.push(Vec3::Y);
        } else {
            ps.push(Vec3::new(0.0, u * 0.5, v));
            ns.push(Vec3::X);
        }
    }
    let mixed = |alpha: f32| {
        let c = cluster(&ps, &ns, &ClusterParams { metric: Metric::Ward { alpha }, gamma: 1, iterations: 10, ..params(2, 1, FuzzyMode::Hard) });
        (0..c.k())
            .filter(|&j| {
                let walls: std::collections::HashSet<bool> = (0..ps.len()).filter(|&i| c.hard_label(i) == j as u32).map(|i| ns[i] == Vec3::X).collect();
                walls.len() > 1
            })
            .count()
    };
    assert_eq!(mixed(0.01), 0, "alpha 0.01: a cluster spans both walls");
    assert!(mixed(1000.0) > 0, "alpha 1000 should cluster by position alone");
}

/// The k-means iterations of [`cluster_from`] from stride seeds, every point searched in every
/// iteration ([`assign`] without hints, in the sample's own order): the final centroid of each
/// point.
fn kmeans_searching_every_point(ps: &[Vec3], ns: &[Vec3], p: &ClusterParams) -> Vec<Vec3> {
    let (m, k) = (ps.len(), (p.k as usize).min(ps.len()));
    let gamma = (p.gamma as usize).clamp(1, (m / k).max(1));
    let sample = downsample(m, gamma, p.seed);
    let sp: Vec<Vec3> = sample.iter().map(|&i| ps[i as usize]).collect();
    let sn: Vec<Vec3> = sample.iter().map(|&i| ns[i as usize]).collect();
    let geometry = Grid::for_data(bounds(ps), &sp, k);
    let seeds = seed_centroids(&sample, k, p.seed);
    let mut cpos: Vec<Vec3> = seeds.iter().map(|&i| ps[i as usize]).collect();
    let mut cnor: Vec<Vec3> = seeds.iter().map(|&i| ns[i as usize]).collect();
    let (lo, hi) = bounds(ps);
    let fix = FixedPoint::new(lo, hi);
    for _ in 0..p.iterations {
        let l = assign(&geometry.fill(&cpos, &cnor), &sp, &sn, p.metric, None);
        update(&fix, &sp, &sn, &l, &mut cpos, &mut cnor);
    }
    let hard = assign(&geometry.fill(&cpos, &cnor), ps, ns, p.metric, None);
    hard.iter().map(|&l| cpos[l as usize]).collect()
}

/// Starting each search from the previous label, and reusing the final hard assignment as the
/// labels when F = 1, change nothing: every point ends at the centroid of the k-means that
/// searches every point afresh in every iteration, on volumes and surfaces, with and without
/// the normal test, downsampled or not.
#[test]
fn hinted_iterations_equal_searching_every_point() {
    let mut compared = 0;
    for seed in 0..6u32 {
        let mut rng = Rng::new(seed, Stream::Oracle, 7);
        let (ps, ns) = if seed % 2 == 0 {
            let ps: Vec<Vec3> = (0..4000).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect();
            let ns: Vec<Vec3> = (0..4000).map(|_| vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32())).collect();
            (ps, ns)
        } else {
            cube_surface(4000, seed)
        };
        for (nt, k, gamma, iterations) in [(-2.0, 64, 1, 12), (0.5, 200, 1, 8), (0.866, 37, 2, 10), (-2.0, 500, 1, 3)] {
            let p = ClusterParams { k, gamma, iterations, f: 1, fuzzy: FuzzyMode::Hard, metric: eq7(nt), representative: Representative::Nearest, seed };
            let c = cluster(&ps, &ns, &p);
            let expected = kmeans_searching_every_point(&ps, &ns, &p);
            for (i, &e) in expected.iter().enumerate() {
                assert_eq!(c.positions[c.hard_label(i) as usize], e, "seed {seed}, nt {nt}, K {k}: point {i}");
            }
            compared += ps.len();
        }
    }
    println!("hinted k-means: {compared} final labels identical to searching every point");
}

/// The assignment searches the points of one cell together (`Grid::nearest_in_neighbourhood`)
/// and must give what the point-by-point search gives: label and outcome, for Eq. 7 (with
/// normals that rule centroids out, so some points widen or find nothing) and Eq. 2 (with errors
/// that need rings beyond the 27 cells), on points in cell order (long runs) and in their own
/// order (runs of one), and with exact ties (duplicated centroids).
#[test]
fn assignment_by_cell_equals_the_search_point_by_point() {
    let mut batched = 0;
    for (seed, metric) in [(0u32, eq7(0.866)), (1, eq7(0.3)), (2, Metric::Ward { alpha: 0.3 }), (3, Metric::Ward { alpha: 30.0 })] {
        let (ps, ns) = cube_surface(6000, seed);
        let (mut cs, mut cn) = cube_surface(120, seed + 90);
        // Ties: the first ten centroids again, at higher indices.
        cs.extend_from_within(..10);
        cn.extend_from_within(..10);
        let geometry = Grid::for_data(bounds(&ps), &ps, cs.len());
        let grid = geometry.fill(&cs, &cn);
        let (_, order) = geometry.cell_order(&ps);
        let (op, on): (Vec<Vec3>, Vec<Vec3>) = order.iter().map(|&i| (ps[i as usize], ns[i as usize])).unzip();
        for (points, normals) in [(&op, &on), (&ps, &ns)] {
            let (labels, widened, incompatible) = assign_with_outcomes(&grid, points, normals, metric, None);
            let (mut w, mut inc) = (0, 0);
            for (i, (&p, &n)) in points.iter().zip(normals.iter()).enumerate() {
                let (label, outcome) = grid.search_near(p, n, metric, MISS);
                assert_eq!(labels[i], label, "seed {seed}, point {p}");
                w += (outcome != SearchOutcome::Neighbourhood) as usize;
                inc += (outcome == SearchOutcome::Incompatible) as usize;
            }
            assert_eq!((widened, incompatible), (w, inc), "seed {seed}");
        }
        let cells: Vec<usize> = op.iter().map(|&p| grid.linear(grid.coords(p))).collect();
        batched += cells.chunk_by(|a, b| a == b).filter(|run| run.len() >= BATCH_MIN).map(|run| run.len()).sum::<usize>();
    }
    assert!(batched > 10_000, "only {batched} points were in runs long enough to be searched together");

    // Exact ties across cells: centroids on a lattice (coordinates in quarters, exact in
    // binary), numbered so that the higher index comes first in the grid's row order, and ten
    // points at each cell centre of the lattice, equidistant from 8 centroids.
    let lattice: Vec<Vec3> = (0..64).rev().map(|i| Vec3::new((i % 4) as f32, ((i / 4) % 4) as f32, (i / 16) as f32) * 0.25).collect();
    let normals = vec![Vec3::Z; 64];
    let points: Vec<Vec3> =
        (0..27).flat_map(|i| std::iter::repeat_n(Vec3::new((i % 3) as f32 + 0.5, ((i / 3) % 3) as f32 + 0.5, (i / 9) as f32 + 0.5) * 0.25, 10)).collect();
    let grid = Grid::for_data(bounds(&lattice), &lattice, lattice.len()).fill(&lattice, &normals);
    let (labels, _, _) = assign_with_outcomes(&grid, &points, &vec![Vec3::Z; points.len()], eq7(0.5), None);
    for (p, l) in points.iter().zip(labels) {
        assert_eq!(l, grid.search_near(*p, Vec3::Z, eq7(0.5), MISS).0, "point {p}: a tie goes to the lowest index");
    }
}
