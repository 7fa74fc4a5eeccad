//! `--temporal on` (Wang et al. 2009, section 3.2): shading-point clusters carried from frame to
//! frame. A frame keeps the previous frame's cluster centres, each with the largest error of its
//! members as its admission threshold. Every shading point is tried against its nearest previous
//! centre: it is admitted when its error is at most that centre's threshold. Centres that admit
//! nobody are dropped; K minus the kept ones start new clusters on points admitted nowhere: the
//! frame's own seeds (stride or adaptive) that fall on such points first, then more of those
//! points evenly spread, so the count stays at K while there are points to seed. The k-means
//! iterations then start from the kept centres and the new seeds.
//!
//! Errors are the clustering metric's keys (`Metric::key`): Eq. 2 itself, or Eq. 7's squared
//! distance (a point whose normal Eq. 7 rules out fits no centre).

use crate::clustering::{seed_centroids, Centre, Metric};

/// Whether the point at squared distance `d2` from `centre`, with normal dot product `cos`,
/// fits it.
#[inline]
pub fn admits(metric: Metric, centre: &Centre, d2: f32, cos: f32) -> bool {
    metric.key(d2, cos).is_some_and(|key| key <= centre.threshold)
}

/// The new clusters' seeds, at most `room`: the frame's own `seeds` (point indices) that lie on
/// points fitting no kept centre (`unfit[i]`), in their order; then, while there is room, the
/// other unfit points spread evenly ([`seed_centroids`] with `seed`).
pub fn new_seeds(seeds: &[u32], unfit: &[bool], room: usize, seed: u32) -> Vec<u32> {
    let mut chosen: Vec<u32> =
        seeds.iter().copied().filter(|&s| unfit[s as usize]).take(room).collect();
    let taken: std::collections::HashSet<u32> = chosen.iter().copied().collect();
    let rest: Vec<u32> =
        (0..unfit.len() as u32).filter(|&i| unfit[i as usize] && !taken.contains(&i)).collect();
    let more = (room - chosen.len()).min(rest.len());
    if more > 0 {
        chosen.extend(seed_centroids(&rest, more, seed));
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_point_fits_within_the_threshold_of_the_metric_key() {
        let c = Centre { position: Vec3::ZERO, normal: Vec3::Z, threshold: 0.25 };
        let eq7 = Metric::Eq7 { normal_threshold: 0.5 };
        assert!(admits(eq7, &c, 0.25, 1.0), "on the threshold fits");
        assert!(!admits(eq7, &c, 0.2501, 1.0));
        assert!(!admits(eq7, &c, 0.0, 0.5), "a normal Eq. 7 rules out never fits");
        let ward = Metric::Ward { alpha: 0.5 };
        // 0.5 * sqrt(0.04) + sqrt(2 - 2 * 0.995) = 0.1 + 0.1
        assert!(admits(ward, &c, 0.04, 0.995));
        assert!(!admits(ward, &c, 0.04, 0.9));
    }

    /// The frame's seeds on unfit points come first, in order; the room left is filled with
    /// the other unfit points, each point at most once, never beyond the unfit points there are.
    #[test]
    fn new_seeds_take_the_unfit_seeds_then_spread_over_the_unfit_points() {
        let unfit = [false, true, true, false, true, true, false, true];
        assert_eq!(new_seeds(&[4, 0, 2, 1], &unfit, 2, 1), vec![4, 2]);
        let all = new_seeds(&[4, 0, 2], &unfit, 10, 1);
        assert_eq!(&all[..2], &[4, 2]);
        let mut sorted = all.clone();
        sorted.sort();
        assert_eq!(sorted, vec![1, 2, 4, 5, 7], "every unfit point once: {all:?}");
        let topped = new_seeds(&[0, 3], &unfit, 3, 1);
        assert_eq!(topped.len(), 3);
        assert!(topped.iter().all(|&i| unfit[i as usize]));
        assert!(new_seeds(&[1], &[false, false], 4, 1).is_empty());
    }
}
