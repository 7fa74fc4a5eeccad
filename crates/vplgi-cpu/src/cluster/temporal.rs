//! `cluster` started from the previous frame's clusters (`--temporal on`, `vplgi_types::temporal`):
//! which previous centres still admit a point, which points fit none, and each cluster's
//! admission threshold for the next frame.

use super::{assign, cosine, dist2, Clustering, Grid, Metric};
use glam::Vec3;
use rayon::prelude::*;
use vplgi_types::clustering::Centre;
use vplgi_types::temporal::admits;
use vplgi_types::MISS;

/// The previous centres against this frame's points.
#[derive(Clone, Debug, PartialEq)]
pub struct Admission {
    /// Indices of the previous centres that admit at least one point, increasing.
    pub kept: Vec<u32>,
    /// Per point: whether no previous centre admits it (its nearest does not).
    pub unfit: Vec<bool>,
}

/// Each point is tried against its nearest previous centre (the grid search of the k-means
/// iterations, on a grid of `geometry` filled with the centres).
pub fn admit(geometry: &Grid, positions: &[Vec3], normals: &[Vec3], previous: &[Centre], metric: Metric) -> Admission {
    let (cp, cn): (Vec<Vec3>, Vec<Vec3>) = previous.iter().map(|c| (c.position, c.normal)).unzip();
    let grid = geometry.fill(&cp, &cn);
    let nearest = assign(&grid, positions, normals, metric, None);
    let fits: Vec<bool> = (positions, normals, &nearest)
        .into_par_iter()
        .map(|(&p, &n, &l)| l != MISS && admits(metric, &previous[l as usize], dist2(p, cp[l as usize]), cosine(n, cn[l as usize])))
        .collect();
    let mut admitted = vec![false; previous.len()];
    for (&l, &fit) in nearest.iter().zip(&fits) {
        if fit {
            admitted[l as usize] = true;
        }
    }
    Admission { kept: (0..previous.len() as u32).filter(|&c| admitted[c as usize]).collect(), unfit: fits.iter().map(|f| !f).collect() }
}

/// The clusters of `c` (over `positions`, `normals`) as the next frame's centres: each
/// centroid with the largest metric key of its members by hard label (members Eq. 7 rules out,
/// placed by position alone, do not count).
pub fn centres(c: &Clustering, positions: &[Vec3], normals: &[Vec3], metric: Metric) -> Vec<Centre> {
    let k = c.k();
    let largest = (positions, normals)
        .into_par_iter()
        .enumerate()
        .fold(
            || vec![0f32; k],
            |mut worst, (i, (&p, &n))| {
                let l = c.hard_label(i) as usize;
                if let Some(key) = metric.key(dist2(p, c.positions[l]), cosine(n, c.normals[l])) {
                    worst[l] = worst[l].max(key);
                }
                worst
            },
        )
        .reduce(|| vec![0f32; k], |a, b| a.into_iter().zip(b).map(|(x, y)| x.max(y)).collect());
    (0..k).map(|j| Centre { position: c.positions[j], normal: c.normals[j], threshold: largest[j] }).collect()
}

#[cfg(test)]
mod tests {
    use super::super::{bounds, cluster_from, ClusterParams, ClusterStart, Representative};
    use super::*;
    use vplgi_types::{FuzzyMode, Rng, Stream};

    fn ward_params(k: u32, iterations: u32) -> ClusterParams {
        let metric = Metric::Ward { alpha: 2.0 };
        ClusterParams { k, gamma: 2, iterations, f: 3, fuzzy: FuzzyMode::Weighted, metric, representative: Representative::MinError { alpha: 2.0 }, seed: 5 }
    }

    /// Points on two faces of a unit box (floor and a wall), like a room corner.
    fn corner(n: usize, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut rng = Rng::new(seed, Stream::Oracle, 0);
        (0..n)
            .map(|i| {
                let (u, v) = (rng.next_f32(), rng.next_f32());
                if i % 2 == 0 {
                    (Vec3::new(u, 0.0, v), Vec3::Y)
                } else {
                    (Vec3::new(u, v, 0.0), Vec3::Z)
                }
            })
            .unzip()
    }

    /// Admission against all pairs: under Eq. 2 the grid search is exact, so a point is unfit
    /// exactly when its nearest centre (smallest key, ties to the lower index) does not admit
    /// it, and the kept centres are those some point fits.
    #[test]
    fn admission_against_all_pairs() {
        let (ps, ns) = corner(3000, 1);
        let params = ward_params(60, 4);
        let metric = params.metric;
        let mut previous = centres(&cluster_from(&ps, &ns, &params, ClusterStart::Stride), &ps, &ns, metric);
        // Halved thresholds, and the scene shifted, so that many points fit nowhere.
        for c in previous.iter_mut() {
            c.threshold *= 0.5;
        }
        let (moved, _) = corner(3000, 2);
        let moved: Vec<Vec3> = moved.iter().map(|p| *p + Vec3::new(0.3, 0.0, 0.0)).collect();
        let geometry = Grid::for_data(bounds(&moved), &moved, 60);
        let a = admit(&geometry, &moved, &ns, &previous, metric);
        let mut kept = vec![false; previous.len()];
        for (i, (&p, &n)) in moved.iter().zip(&ns).enumerate() {
            let key = |c: &Centre| metric.key(dist2(p, c.position), cosine(n, c.normal)).unwrap();
            let (best, j) = previous.iter().enumerate().map(|(j, c)| (key(c), j)).fold((f32::INFINITY, 0), |a, b| if b < a { b } else { a });
            let fits = best <= previous[j].threshold;
            assert_eq!(a.unfit[i], !fits, "point {i}");
            kept[j] |= fits;
        }
        let expected: Vec<u32> = (0..previous.len() as u32).filter(|&j| kept[j as usize]).collect();
        assert_eq!(a.kept, expected);
        let unfit = a.unfit.iter().filter(|&&u| u).count();
        println!("admission: {unfit} of {} points unfit, {} of {} centres kept", moved.len(), a.kept.len(), previous.len());
        assert!(unfit > 100 && unfit < 2900 && a.kept.len() < previous.len(), "the case exercises both outcomes");
    }

    /// Thresholds are each cluster's largest member key, against a direct maximum.
    #[test]
    fn thresholds_are_the_largest_member_errors() {
        let (ps, ns) = corner(2000, 3);
        let params = ward_params(40, 3);
        let c = cluster_from(&ps, &ns, &params, ClusterStart::Stride);
        let got = centres(&c, &ps, &ns, params.metric);
        for (j, centre) in got.iter().enumerate() {
            let worst = (0..ps.len())
                .filter(|&i| c.hard_label(i) as usize == j)
                .map(|i| params.metric.key(dist2(ps[i], c.positions[j]), cosine(ns[i], c.normals[j])).unwrap())
                .fold(0f32, f32::max);
            assert_eq!(centre.threshold, worst, "cluster {j}");
            assert_eq!((centre.position, centre.normal), (c.positions[j], c.normals[j]));
        }
    }

    /// A frame started from its own clusters keeps every one of them and seeds none: with no
    /// iterations the clustering is the same. With no previous clusters a warm start is the
    /// cold one.
    #[test]
    fn warm_starts_from_own_clusters_and_from_none() {
        let (ps, ns) = corner(2500, 4);
        let params = ward_params(50, 4);
        let cold = cluster_from(&ps, &ns, &params, ClusterStart::Stride);
        let own = centres(&cold, &ps, &ns, params.metric);
        let again = cluster_from(&ps, &ns, &ClusterParams { iterations: 0, ..params }, ClusterStart::Warm { previous: &own, seeds: None });
        assert_eq!((again.kept, again.fresh), (cold.k(), 0));
        assert_eq!((&again.labels, &again.positions), (&cold.labels, &cold.positions));
        let from_none = cluster_from(&ps, &ns, &params, ClusterStart::Warm { previous: &[], seeds: None });
        assert_eq!((from_none.kept, from_none.fresh), (0, 50));
        assert_eq!((&from_none.labels, &from_none.positions), (&cold.labels, &cold.positions));
    }
}
