//! Host-side pieces of the clustering (Alg. 1 and 2) that every backend shares, so that given
//! the same data they make the same choices: the downsampled set, the initial centroids, the
//! grid geometry, the fixed-point format of the centroid sums and the fuzzy weights. Each
//! backend supplies only the data-parallel work (occupancy counts, assignment, sums).

use crate::{FuzzyMode, Rng, Stream};
use glam::Vec3;

/// Parameters of one clustering run, the same for every backend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterParams {
    /// Requested number of clusters K.
    pub k: u32,
    /// Downsampling factor gamma.
    pub gamma: u32,
    pub iterations: u32,
    /// Clusters per point in the final assignment (1 = hard).
    pub f: u32,
    /// How the F clusters of a point are weighted.
    pub fuzzy: FuzzyMode,
    /// What "nearest" means.
    pub metric: Metric,
    /// Which member stands for each cluster.
    pub representative: Representative,
    pub seed: u32,
}

/// The clusters each point keeps: 1 for a hard assignment, else F within 1 ..= MAX_F. The one
/// place F is decided, for the frame and both backends' clusterings.
pub fn effective_f(fuzzy: FuzzyMode, f: u32) -> u32 {
    match fuzzy {
        FuzzyMode::Hard => 1,
        _ => f.clamp(1, crate::config::MAX_F),
    }
}

impl ClusterParams {
    /// [`effective_f`] of these parameters.
    pub fn effective_f(&self) -> u32 {
        effective_f(self.fuzzy, self.f)
    }
}

/// Where a clustering's initial centroids come from.
#[derive(Clone, Copy, Debug)]
pub enum ClusterStart<'a> {
    /// K points evenly spread over the downsampled set ([`seed_centroids`]).
    Stride,
    /// These point indices (`--seeding adaptive`'s); their number is K.
    Seeds(&'a [u32]),
    /// `--temporal on` ([`crate::temporal`]): the previous frame's centres that still admit a
    /// point, then new seeds on the points none admits, taken from `seeds` (or, if `None`, from
    /// the stride seeds of K), up to K in all.
    Warm { previous: &'a [Centre], seeds: Option<&'a [u32]> },
}

/// A cluster carried to the next frame (`--temporal on`, [`crate::temporal`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Centre {
    pub position: Vec3,
    pub normal: Vec3,
    /// The largest key of its members (by hard label) to the centre.
    pub threshold: f32,
}

/// The dissimilarity between a point and a centroid that the clustering minimises. Both
/// metrics are compared through a key (smaller is nearer, ties to the lower centroid index):
/// Eq. 7's squared distance, or Eq. 2's error itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Metric {
    /// Eq. 7 of the core paper: Euclidean distance between positions, infinite when the
    /// normals' dot product is at most `normal_threshold` (n_t).
    Eq7 { normal_threshold: f32 },
    /// Eq. 2 of Wang et al. 2009, the irradiance-caching change term without its R_k:
    /// `alpha |x - c| + sqrt(2 - 2 n . m)`, with `alpha` per unit length (a frame divides its
    /// scene-relative α by the scene's diagonal). Never infinite: every centroid is a candidate.
    Ward { alpha: f32 },
}

impl Metric {
    /// The key of a centroid at squared distance `d2` whose normal has dot product `cos` with
    /// the point's (both summed x, y, z in that order, as the GPU does), or `None` when Eq. 7
    /// rules it out.
    #[inline]
    pub fn key(self, d2: f32, cos: f32) -> Option<f32> {
        match self {
            Metric::Eq7 { normal_threshold } => (cos > normal_threshold).then_some(d2),
            Metric::Ward { alpha } => Some(ward_error(alpha, d2, cos)),
        }
    }

    /// The smallest key a centroid at squared distance `d2` can have, whatever its normal
    /// (Eq. 2's normal term is non-negative).
    #[inline]
    pub fn key_bound(self, d2: f32) -> f32 {
        match self {
            Metric::Eq7 { .. } => d2,
            Metric::Ward { alpha } => alpha * d2.sqrt(),
        }
    }

    /// Whether every centroid at least `reach` away has a key above `key`: then a search
    /// that has found `key` need look no farther. The GPU makes the same test in the same
    /// operations (`cluster_assign.wgsl`), so both stop at the same ring.
    #[inline]
    pub fn settled(self, key: f32, reach: f32) -> bool {
        match self {
            Metric::Eq7 { .. } => key.sqrt() <= reach,
            Metric::Ward { alpha } => key <= alpha * reach,
        }
    }

    /// The distance Eq. 10's weights invert, from a key; and the floor it is held above for a
    /// grid of cell size `cell` (1e-4 cell, in the metric's own units).
    #[inline]
    pub fn weight_distance(self, key: f32, cell: f32) -> f32 {
        match self {
            Metric::Eq7 { .. } => key.sqrt().max(1e-4 * cell),
            Metric::Ward { alpha } => key.max(1e-4 * (alpha * cell)),
        }
    }
}

/// Eq. 2 of Wang et al. 2009 from the squared distance `d2` and the normals' dot product
/// `cos`: `alpha sqrt(d2) + sqrt(2 - 2 cos)`, the root's argument held at 0 or more (unit
/// normals can have a dot product a rounding above 1).
#[inline]
pub fn ward_error(alpha: f32, d2: f32, cos: f32) -> f32 {
    alpha * d2.sqrt() + (2.0 - 2.0 * cos).max(0.0).sqrt()
}

/// Which member of a cluster stands for it (the shading point whose visibility the cluster
/// takes, or the irradiance sample point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Representative {
    /// The member nearest the centroid by position (the core paper).
    Nearest,
    /// The member of smallest Eq. 2 error to the centroid (Wang et al. 2009), `alpha` per unit
    /// length.
    MinError { alpha: f32 },
}

impl Representative {
    /// The key a member at squared distance `d2` from the centroid, with normal dot product
    /// `cos`, is chosen by (smallest wins, ties to the lower point index). Non-negative, so its
    /// bits order like the value (the GPU's atomicMin relies on it).
    #[inline]
    pub fn key(self, d2: f32, cos: f32) -> f32 {
        match self {
            Representative::Nearest => d2,
            Representative::MinError { alpha } => ward_error(alpha, d2, cos),
        }
    }
}

/// A search's 27-cell neighbourhood holding at least this many cells and centroids together is
/// crowded: instead of visiting it, the search scans every centroid and returns the exact F
/// nearest (`Grid::search`, `cluster_assign.wgsl`). Eq. 7's neighbourhood answer is meant for
/// grids of about two centroids per occupied cell; thousands in one neighbourhood come only from
/// degenerate data (many centroids at one point), where the GPU's visit would otherwise outrun
/// lavapipe's loop limiter (65,535 loop iterations per invocation, all loops together).
pub const CROWDED_CENTROIDS: u32 = 8_192;

/// The most centroids one assignment may search: a GPU search costs at most the crowded budget,
/// the ring walk's (`WALK_BUDGET` in `cluster_assign.wgsl`, a few thousand iterations) and a
/// scan of K / 4 iterations, which stays well inside lavapipe's loop limiter up to here. Larger
/// K is refused up front (`vplgi_gpu::cluster`), never truncated.
pub const MAX_ASSIGN_CENTROIDS: u32 = 131_072;

/// At most about this many grid cells; the cell size grows to respect it.
pub const MAX_CELLS: f64 = (1u64 << 21) as f64;

/// The uniform grid laid over the data: cell `(i, j, k)` covers
/// `origin + [i, i+1) x [j, j+1) x [k, k+1) * cell`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    pub origin: Vec3,
    pub cell: f32,
    pub dims: [i32; 3],
}

/// Smallest cell size allowed for data of extent `ext`: keeps the cell count near [`MAX_CELLS`]
/// and at most 4096 cells per axis, whatever the data's dimension. A volume's bound alone lets
/// flat data (a wall, a floor: one extent near 0) take 4097 x 4097 x 1 cells; so the two largest
/// extents are bounded as an area too, and an axis thinner than the cell gets one cell.
pub fn min_cell(ext: Vec3) -> f64 {
    let mut e = ext.to_array().map(f64::from);
    e.sort_by(|a, b| b.total_cmp(a));
    let volume = (e[0] * e[1] * e[2] / MAX_CELLS).cbrt();
    let area = (e[0] * e[1] / MAX_CELLS).sqrt();
    volume.max(area).max(e[0] / 4096.0).max(1e-12)
}

/// Chooses the grid for clustering data spanning [`min`, `max`] into `k` clusters. The cell size
/// is adjusted in four fixed steps until the occupied cells number about k / 2, i.e. about two
/// centroids per occupied cell when centroids follow the data. The square-root update assumes
/// surface-like data, where occupied cells scale with 1 / cell². `occupied(cell)` counts the
/// distinct cells `floor((p - min) / cell)` (f32 arithmetic) of the downsampled points.
pub fn grid_geometry(
    min: Vec3,
    max: Vec3,
    k: usize,
    mut occupied: impl FnMut(f32) -> usize,
) -> GridGeometry {
    let ext = (max - min).max(Vec3::splat(1e-12));
    let target = (k as f64 / 2.0).max(1.0);
    let mut cell = (ext.x as f64 * ext.y as f64 * ext.z as f64 / k.max(1) as f64)
        .cbrt()
        .max(ext.max_element() as f64 / 1024.0);
    for _ in 0..4 {
        cell = cell.max(min_cell(ext));
        let occ = occupied(cell as f32) as f64;
        cell *= (occ / target).sqrt().clamp(0.25, 4.0);
    }
    let cell = cell.max(min_cell(ext)) as f32;
    GridGeometry { origin: min, cell, dims: [0, 1, 2].map(|a| (ext[a] / cell).floor() as i32 + 1) }
}

/// Alg. 1, line 1: one point from each block of `gamma` consecutive points, at a random offset
/// inside the block (jittered stride). A fixed stride would alias with periodic data, such as
/// alternating normals.
pub fn downsample(m: usize, gamma: usize, seed: u32) -> Vec<u32> {
    (0..m.div_ceil(gamma))
        .map(|s| {
            let offset = Rng::new(seed, Stream::Cluster, s as u32 + 1).next_u32() as usize % gamma;
            ((s * gamma + offset).min(m - 1)) as u32
        })
        .collect()
}

/// The initial centroids: K points spread evenly over the downsampled set with a random offset.
pub fn seed_centroids(sample: &[u32], k: usize, seed: u32) -> Vec<u32> {
    let u = Rng::new(seed, Stream::Cluster, 0).next_f32() as f64;
    let s = sample.len() as f64;
    (0..k)
        .map(|i| sample[(((i as f64 + u) * s / k as f64) as usize).min(sample.len() - 1)])
        .collect()
}

/// Fixed-point format of the centroid sums.
///
/// Positions are stored as unsigned 24-bit fractions of the data's bounding box per axis
/// (resolution 6e-8 of the box), normals as `round(n * 2^24) + 2^24` in [0, 2^25]. A sum of
/// M points needs 25 + log2(M) bits: 64-bit sums cannot overflow below 2^39 points per
/// cluster. Means are formed in f32 from the two 32-bit halves of a sum, the operations a GPU
/// with 32-bit atomics performs (WGSL `round` is ties-to-even like `round_ties_even`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedPoint {
    pub min: Vec3,
    pub ext: Vec3,
}

pub const FIX_ONE: f32 = 16_777_216.0; // 2^24

impl FixedPoint {
    /// For data spanning [`min`, `max`].
    pub fn new(min: Vec3, max: Vec3) -> FixedPoint {
        FixedPoint { min, ext: (max - min).max(Vec3::splat(1e-30)) }
    }

    #[inline]
    pub fn quantize(&self, p: Vec3, n: Vec3) -> [u32; 6] {
        let q = ((p - self.min) / self.ext * FIX_ONE).clamp(Vec3::ZERO, Vec3::splat(FIX_ONE));
        let m = (n.clamp(Vec3::NEG_ONE, Vec3::ONE) * FIX_ONE + FIX_ONE)
            .clamp(Vec3::ZERO, Vec3::splat(2.0 * FIX_ONE));
        [q.x, q.y, q.z, m.x, m.y, m.z].map(|v| round_ties_even_nonnegative(v) as u32)
    }

    /// The mean position and (normalised) mean normal of `count` points whose quantised values
    /// sum to `sums`. The normal is `None` when the normals cancel out.
    #[inline]
    pub fn mean(&self, sums: &[u64; 6], count: u32) -> (Vec3, Option<Vec3>) {
        let m = sums.map(|s| u64_mean(s, count));
        let p = self.min + Vec3::new(m[0], m[1], m[2]) / FIX_ONE * self.ext;
        let n = Vec3::new(m[3] - FIX_ONE, m[4] - FIX_ONE, m[5] - FIX_ONE) / FIX_ONE;
        (p, n.try_normalize())
    }
}

/// `v.round_ties_even()` for `v` ≥ 0 (or NaN), without the libm call baseline x86-64 makes of
/// it (the centroid update rounds six values per point): below 2^23, adding 2^23 leaves no
/// fraction bits, so the addition itself rounds to the nearest integer, ties to even, and the
/// subtraction is exact; from 2^23 on every f32 is an integer already.
#[inline]
pub fn round_ties_even_nonnegative(v: f32) -> f32 {
    const TWO_23: f32 = 8_388_608.0;
    if v < TWO_23 {
        (v + TWO_23) - TWO_23
    } else {
        v
    }
}

/// `sum / count` in f32 from the two halves of the 64-bit sum.
#[inline]
pub fn u64_mean(sum: u64, count: u32) -> f32 {
    let hi = (sum >> 32) as u32;
    let lo = sum as u32;
    (hi as f32 * 4_294_967_296.0 + lo as f32) / count as f32
}

/// Normalised weights of a point's clusters given their keys under `metric` (Eq. 10 for
/// `Weighted`: inverse distance, or inverse Eq. 2 error; Eq. 8's plain mean for `Average`).
/// Distances are floored at 1e-4 of a grid cell ([`Metric::weight_distance`]), so a point
/// sitting on a centroid gets a large but finite weight.
pub fn fuzzy_weights(
    best: &[(f32, u32)],
    mode: FuzzyMode,
    metric: Metric,
    cell: f32,
    out: &mut [f32],
) {
    let mut total = 0.0f32;
    for (w, &(key, _)) in out.iter_mut().zip(best) {
        *w = match mode {
            FuzzyMode::Weighted => 1.0 / metric.weight_distance(key, cell),
            FuzzyMode::Average | FuzzyMode::Hard => 1.0,
        };
        total += *w;
    }
    if !(total.is_finite() && total > 0.0) {
        // Distances overflowed (coordinates ~1e19 apart): fall back to the plain mean.
        total = out.len() as f32;
        out.iter_mut().for_each(|w| *w = 1.0);
    }
    for w in out.iter_mut() {
        *w /= total;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alg. 1's downsampling takes exactly one point from each block of gamma consecutive
    /// points (the last block may be short), and its jitter reaches every offset of a block.
    #[test]
    fn downsampling_takes_one_point_per_block_at_every_offset() {
        for (m, gamma, seed) in [(1000, 7, 1), (999, 10, 2), (5, 8, 3), (64, 1, 4)] {
            let s = downsample(m, gamma, seed);
            assert_eq!(s.len(), m.div_ceil(gamma));
            let mut offsets = vec![0; gamma];
            for (b, &i) in s.iter().enumerate() {
                let i = i as usize;
                assert!(
                    i >= b * gamma && i < ((b + 1) * gamma).min(m),
                    "m {m}, gamma {gamma}: block {b} took point {i}"
                );
                offsets[i - b * gamma] += 1;
            }
            if m > 100 * gamma {
                assert!(
                    offsets.iter().all(|&c| c > 0),
                    "m {m}, gamma {gamma}: offsets {offsets:?}"
                );
            }
        }
    }

    /// The grid's size is bounded whatever the data reports: however few cells the points
    /// occupy (each step then shrinks the cell fourfold), at most 4096 cells per axis, and for
    /// a volume about MAX_CELLS in all. On a surface the cell settles where about k / 2 cells
    /// are occupied (two centroids per occupied cell), within a factor 2.
    /// F is 1 for a hard assignment whatever is asked, else what is asked within 1 ..= MAX_F;
    /// the frame's F is the same.
    #[test]
    fn effective_f_is_one_when_hard_and_within_max_f_otherwise() {
        let max = crate::config::MAX_F;
        assert_eq!([0, 6, 40].map(|f| effective_f(FuzzyMode::Hard, f)), [1, 1, 1]);
        assert_eq!([0, 6, 40].map(|f| effective_f(FuzzyMode::Weighted, f)), [1, 6, max]);
        assert_eq!(effective_f(FuzzyMode::Average, max), max);
        let frame = crate::FrameConfig {
            fuzzy: FuzzyMode::Weighted,
            f: 6,
            ..crate::FrameConfig::default()
        };
        assert_eq!(frame.effective_f(), 6);
    }

    #[test]
    fn grid_is_bounded_and_settles_near_half_k_occupied_cells() {
        let cube = grid_geometry(Vec3::ZERO, Vec3::splat(10.0), 1 << 20, |_| 1);
        let cells: f64 = cube.dims.iter().map(|&d| d as f64).product();
        assert!(cells <= 1.1 * MAX_CELLS, "{cube:?}: {cells} cells");
        // Flat, near-flat, linear and point-like data: at most about MAX_CELLS cells too, and
        // at most two cells across an axis far thinner than the others.
        for max in [
            Vec3::new(100.0, 1e-3, 1.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(10.0, 1e-3, 10.0),
            Vec3::new(0.0, 0.0, 7.0),
            Vec3::ZERO,
        ] {
            let g = grid_geometry(Vec3::ZERO, max, 1 << 20, |_| 1);
            let cells: f64 = g.dims.iter().map(|&d| d as f64).product();
            assert!(
                g.dims.iter().all(|&d| (1..=4097).contains(&d)) && cells <= 1.1 * MAX_CELLS,
                "{max}: {g:?}, {cells} cells"
            );
            for a in 0..3 {
                if max[a] <= 1e-3 {
                    assert!(g.dims[a] <= 2, "{max}: axis {a}: {g:?}");
                }
            }
        }
        let n = 100;
        let mut points = Vec::new();
        for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
            let (u, v) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            points.extend(
                [(u, v, 0.0), (u, v, 1.0), (u, 0.0, v), (u, 1.0, v), (0.0, u, v), (1.0, u, v)]
                    .map(Vec3::from),
            );
        }
        let occupied = |cell: f32| {
            points
                .iter()
                .map(|&p| (p / cell).floor().as_ivec3().to_array())
                .collect::<std::collections::HashSet<_>>()
                .len()
        };
        for k in [100, 2000, 20000] {
            let g = grid_geometry(Vec3::ZERO, Vec3::ONE, k, occupied);
            let occ = occupied(g.cell);
            println!("k = {k}: cell {}, {occ} cells occupied", g.cell);
            assert!(occ * 4 >= k && occ <= k, "k = {k}: cell {} occupies {occ} cells", g.cell);
        }
    }

    /// Eq. 10's inverse-distance weights hold a distance of zero at 1e-4 of a grid cell in the
    /// metric's own units (a length for Eq. 7, alpha x length for Eq. 2): a point sitting on one
    /// centroid still leaves the others a share, in the ratio of the floor to their distances.
    #[test]
    fn weights_floor_a_zero_distance_at_a_ten_thousandth_of_a_cell() {
        let mut w = [0.0; 2];
        // Eq. 7 keys are squared distances: 0 is held at 1e-4 x 0.5 = 5e-5, against 1e-4.
        fuzzy_weights(
            &[(0.0, 0), (1e-8, 1)],
            FuzzyMode::Weighted,
            Metric::Eq7 { normal_threshold: 0.5 },
            0.5,
            &mut w,
        );
        assert!((w[0] - 2.0 / 3.0).abs() < 1e-5 && (w[1] - 1.0 / 3.0).abs() < 1e-5, "{w:?}");
        // Eq. 2 keys are errors: 0 is held at 1e-4 x (4 x 0.5) = 2e-4, against 1e-3.
        fuzzy_weights(
            &[(0.0, 0), (1e-3, 1)],
            FuzzyMode::Weighted,
            Metric::Ward { alpha: 4.0 },
            0.5,
            &mut w,
        );
        assert!((w[0] - 5.0 / 6.0).abs() < 1e-5 && (w[1] - 1.0 / 6.0).abs() < 1e-5, "{w:?}");
        // Squared distances that overflowed (points ~1e19 apart) leave no inverse distance to
        // weigh by: the weights fall back to Eq. 8's plain mean instead of 0 / 0.
        for metric in [Metric::Eq7 { normal_threshold: 0.5 }, Metric::Ward { alpha: 4.0 }] {
            fuzzy_weights(
                &[(f32::INFINITY, 0), (f32::INFINITY, 1)],
                FuzzyMode::Weighted,
                metric,
                0.5,
                &mut w,
            );
            assert_eq!(w, [0.5, 0.5], "{metric:?}");
        }
    }

    #[test]
    fn rounding_without_libm_is_round_ties_even() {
        // Ties at every magnitude, their neighbours one ulp away, and sweeps of the range the
        // quantiser produces ([0, 2^25]), against the standard library.
        let mut values = vec![
            0.0f32,
            0.5,
            1.5,
            2.5,
            8_388_607.5,
            8_388_608.0,
            16_777_216.0,
            33_554_432.0,
            f32::NAN,
        ];
        for e in 0..24 {
            let t = (1u32 << e) as f32 + 0.5;
            values.extend([t, f32::from_bits(t.to_bits() - 1), f32::from_bits(t.to_bits() + 1)]);
        }
        let mut rng = crate::Rng::new(5, crate::Stream::Oracle, 9);
        values.extend((0..200_000).map(|_| rng.next_f32() * 33_554_432.0));
        values.extend((0..200_000).map(|_| rng.next_f32() * 64.0));
        for v in values {
            assert_eq!(round_ties_even_nonnegative(v) as u32, v.round_ties_even() as u32, "{v}");
            if !v.is_nan() {
                assert_eq!(round_ties_even_nonnegative(v), v.round_ties_even(), "{v}");
            }
        }
    }
}
