//! Stage 3, `cluster`: grid-accelerated k-means (Alg. 1) and the fuzzy F-nearest assignment
//! (Alg. 2), used for both shading points and VPLs.
//!
//! Rules that make the result well defined (and reproducible by the GPU twin):
//!
//! * **Distance** (Eq. 7): Euclidean between positions when the normals' dot product exceeds
//!   `n_t`, infinite otherwise. Squared distances are summed in the order x, y, z. Or, for
//!   shading points after Wang et al. 2009, Eq. 2: `alpha |x - c| + sqrt(2 - 2 n . m)`, finite
//!   for every pair ([`Metric`]).
//! * **Ties** go to the lower centroid index, whatever the visiting order.
//! * **Grid**: one uniform grid for the whole run, laid over the data's bounding box, with a cell
//!   size chosen from the data so that about two centroids share an occupied cell
//!   ([`Grid::for_data`]). A point looks at the 27 cells around its own (the paper's
//!   approximation).
//! * **Eq. 2 is searched exactly**: its normal term is non-negative, so a centroid r cells away
//!   has an error of at least `alpha r cell`; the rings widen until the F-th best is below that,
//!   and the 27 cells are only where the search starts.
//! * **No compatible centroid in the 27 cells** (Eq. 7): the search widens ring by ring (Chebyshev
//!   distance 2, 3, ...) until no unvisited ring can hold a centroid nearer than the F-th found,
//!   so a widened search returns the exact F nearest compatible centroids, whichever way it ends:
//!   once the rings would hold more cells than 8x the centroids, all centroids are scanned
//!   instead. If no centroid anywhere has a compatible normal, the point
//!   takes the nearest centroid by position alone. Both cases are counted.
//! * **Weights** (Eq. 10) use the distances to the centroids, as Alg. 2 computes them; Eq. 10's
//!   text names the representatives, which lie within a fraction of a cell of their centroids.
//! * **Centroid sums** are fixed-point integers (see [`FixedPoint`]), so they do not depend on
//!   summation order; a cluster that loses all members keeps its previous centroid.
//! * **Empty clusters** after the final assignment are dropped, so every reported cluster has a
//!   member, and its **representative** is the member nearest its centroid (a real surface point),
//!   or the member of smallest Eq. 2 error ([`Representative`]).

use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;
use vplgi_types::clustering::{downsample, fuzzy_weights, grid_geometry, seed_centroids, FixedPoint, CROWDED_CENTROIDS};
pub use vplgi_types::clustering::{ClusterParams, ClusterStart, Metric, Representative};
use vplgi_types::config::MAX_F;
use vplgi_types::temporal::new_seeds;
use vplgi_types::MISS;
use crate::visibility::Endpoint;
use crate::CpuScene;
use vplgi_frame::{ClusterCounts, FrameError};
use vplgi_types::clustering::Centre;

/// The result of clustering M points into K' <= K non-empty clusters.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clustering {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Index (into the clustered points) of each cluster's representative member.
    pub representatives: Vec<u32>,
    /// Number of points whose nearest cluster this is.
    pub members: Vec<u32>,
    /// Row stride of `labels` and `weights`.
    pub f: usize,
    /// `f` cluster indices per point, nearest first, padded with [`MISS`].
    pub labels: Vec<u32>,
    /// `f` weights per point, summing to 1 over the valid labels, 0 for padding.
    pub weights: Vec<f32>,
    /// Points whose 27-cell neighbourhood held no compatible centroid (final assignment).
    pub widened: usize,
    /// Of those, points that found no compatible centroid anywhere (took the nearest by position).
    pub incompatible: usize,
    /// Started warm ([`ClusterStart::Warm`]): the previous centres kept, and the new clusters
    /// seeded on points none of them admits (0 and 0 otherwise).
    pub kept: usize,
    pub fresh: usize,
}

impl Clustering {
    pub fn k(&self) -> usize {
        self.positions.len()
    }
    /// The nearest cluster of point `i`.
    pub fn hard_label(&self, i: usize) -> u32 {
        self.labels[i * self.f]
    }
}

/// Squared distance, summed x, y, z in that order (the GPU twin keeps this order).
#[inline]
pub(crate) fn dist2(a: Vec3, b: Vec3) -> f32 {
    let dx = a.x - b.x;
    let dy = a.y - b.y;
    let dz = a.z - b.z;
    let mut s = dx * dx;
    s += dy * dy;
    s += dz * dz;
    s
}

/// Dot product, summed x, y, z in that order (the GPU twin keeps this order).
#[inline]
pub(crate) fn cosine(n: Vec3, m: Vec3) -> f32 {
    let mut d = n.x * m.x;
    d += n.y * m.y;
    d += n.z * m.z;
    d
}

/// A uniform grid over centroid positions, stored as a counting sort: `items[starts[c]..
/// starts[c + 1]]` are the centroids in cell `c`, in increasing index order. Each item carries a
/// copy of its centroid's position and normal, so a search reads the cells it visits as
/// contiguous memory; the cells of one grid row are contiguous too, so the 27-cell
/// neighbourhood is 9 runs of items.
#[derive(Clone, Debug)]
pub struct Grid {
    pub origin: Vec3,
    pub cell: f32,
    pub dims: [i32; 3],
    starts: Vec<u32>,
    items: Vec<u32>,
    item_positions: Vec<Vec3>,
    item_normals: Vec<Vec3>,
    /// The centroids by index (for a search that starts from a known centroid).
    centroids: Vec<Vec3>,
    centroid_normals: Vec<Vec3>,
    /// Whether some neighbourhood may be crowded ([`CROWDED_CENTROIDS`]): its 27 cells could hold
    /// that many cells and centroids. False for any grid whose fullest cell is small, so most
    /// searches skip the count.
    may_crowd: bool,
}

impl Grid {
    /// The grid geometry of [`vplgi_types::clustering::grid_geometry`] for data spanning
    /// `bounds`, with occupancy counted on `sample`.
    pub fn for_data(bounds: (Vec3, Vec3), sample: &[Vec3], k: usize) -> Grid {
        let g = grid_geometry(bounds.0, bounds.1, k, |cell| occupied_cells(sample, bounds.0, cell));
        Grid {
            origin: g.origin,
            cell: g.cell,
            dims: g.dims,
            starts: Vec::new(),
            items: Vec::new(),
            item_positions: Vec::new(),
            item_normals: Vec::new(),
            centroids: Vec::new(),
            centroid_normals: Vec::new(),
            may_crowd: false,
        }
    }

    /// Same geometry, filled with the centroids (`centroids`, `normals`).
    pub fn fill(&self, centroids: &[Vec3], normals: &[Vec3]) -> Grid {
        let (starts, items) = self.cell_order(centroids);
        let item_positions = items.iter().map(|&k| centroids[k as usize]).collect();
        let item_normals = items.iter().map(|&k| normals[k as usize]).collect();
        let fullest = starts.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0) as u64;
        let may_crowd = 27 * (fullest + 1) >= CROWDED_CENTROIDS as u64;
        Grid { starts, items, item_positions, item_normals, centroids: centroids.to_vec(), centroid_normals: normals.to_vec(), may_crowd, ..self.clone() }
    }

    /// A counting sort of `points` by grid cell: where each cell's run starts (one entry per cell,
    /// and the end), and the indices of the points in cell order (cells in memory order, points of
    /// a cell in index order). The grid's own items are its centroids in this order; the k-means
    /// iterations search their points in it too, so consecutive points share their neighbourhood
    /// and the centroids they test stay in cache.
    pub fn cell_order(&self, points: &[Vec3]) -> (Vec<u32>, Vec<u32>) {
        let n_cells = self.dims.iter().map(|&d| d as usize).product::<usize>();
        let cells: Vec<u32> = points.par_iter().map(|&p| self.linear(self.coords(p)) as u32).collect();
        let mut starts = vec![0u32; n_cells + 1];
        for &c in &cells {
            starts[c as usize + 1] += 1;
        }
        for i in 0..n_cells {
            starts[i + 1] += starts[i];
        }
        let mut cursor = starts.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[cursor[c as usize] as usize] = i as u32;
            cursor[c as usize] += 1;
        }
        (starts, order)
    }

    /// Cell coordinates of `p`, clamped into the grid (centroids always lie inside it; points of
    /// the clustered data too, as the grid spans their bounding box).
    #[inline]
    pub fn coords(&self, p: Vec3) -> [i32; 3] {
        let q = (p - self.origin) / self.cell;
        // floor() as i32 without the libm call baseline x86-64 makes of floor(): the same value
        // for every f32, NaN included (0).
        let floor = |x: f32| {
            let i = x as i32;
            if (i as f32) > x {
                i - 1
            } else {
                i
            }
        };
        [floor(q.x).clamp(0, self.dims[0] - 1), floor(q.y).clamp(0, self.dims[1] - 1), floor(q.z).clamp(0, self.dims[2] - 1)]
    }

    #[inline]
    fn linear(&self, c: [i32; 3]) -> usize {
        (c[0] as usize) + self.dims[0] as usize * ((c[1] as usize) + self.dims[1] as usize * c[2] as usize)
    }

    /// Whether the 27-cell neighbourhood of cell `c` is crowded: its cells inside the grid and
    /// their centroids number at least [`CROWDED_CENTROIDS`].
    fn crowded(&self, c: [i32; 3]) -> bool {
        if !self.may_crowd {
            return false;
        }
        let (x0, x1) = ((c[0] - 1).max(0), (c[0] + 1).min(self.dims[0] - 1));
        let mut load = 0usize;
        for z in (c[2] - 1).max(0)..=(c[2] + 1).min(self.dims[2] - 1) {
            for y in (c[1] - 1).max(0)..=(c[1] + 1).min(self.dims[1] - 1) {
                load += (x1 - x0 + 1) as usize + self.row_items(x0, x1, y, z).len();
            }
        }
        load >= CROWDED_CENTROIDS as usize
    }

    /// The item range of cells `x0..=x1` of row (`y`, `z`), all inside the grid.
    #[inline]
    fn row_items(&self, x0: i32, x1: i32, y: i32, z: i32) -> std::ops::Range<usize> {
        self.starts[self.linear([x0, y, z])] as usize..self.starts[self.linear([x1, y, z]) + 1] as usize
    }

    /// Visits the cells at Chebyshev distance exactly `r` >= 2 from `c` that lie in the grid, as
    /// item ranges (a run of cells of one row is one range). Only the shell is walked, so a ring
    /// costs O(r²) cells.
    fn visit_ring(&self, c: [i32; 3], r: i32, mut f: impl FnMut(std::ops::Range<usize>)) {
        let lo = |a: usize| (c[a] - r).max(0);
        let hi = |a: usize| (c[a] + r).min(self.dims[a] - 1);
        for z in lo(2)..=hi(2) {
            for y in lo(1)..=hi(1) {
                if (z - c[2]).abs() == r || (y - c[1]).abs() == r {
                    f(self.row_items(lo(0), hi(0), y, z));
                } else {
                    for x in [c[0] - r, c[0] + r] {
                        if x >= 0 && x < self.dims[0] {
                            f(self.row_items(x, x, y, z));
                        }
                    }
                }
            }
        }
    }

    /// Largest ring that still touches the grid from cell `c`.
    fn max_ring(&self, c: [i32; 3]) -> i32 {
        (0..3).map(|a| c[a].max(self.dims[a] - 1 - c[a])).max().unwrap_or(0).max(1)
    }

    /// The points as runs of consecutive points in one cell (points in cell order, as
    /// [`Grid::cell_order`] puts them, make one run per occupied cell).
    pub fn runs(&self, points: &[Vec3]) -> Vec<Range<usize>> {
        let cells: Vec<usize> = points.par_iter().map(|&p| self.linear(self.coords(p))).collect();
        let mut runs = Vec::new();
        let mut start = 0;
        for i in 1..=points.len() {
            if i == points.len() || cells[i] != cells[start] {
                runs.push(start..i);
                start = i;
            }
        }
        runs
    }

    /// The nearest centroid of each of `points` (with `normals`), all in cell `c`, over the 27
    /// cells around it: Some((index, Neighbourhood)) where that settles the search as
    /// [`Grid::search`] would (for Eq. 7, any compatible centroid; for Eq. 2, a best error that
    /// no centroid beyond the 27 cells can beat), None where the point needs the full search.
    /// The keys are [`Metric::key`]'s of the same [`dist2`] and [`cosine`]; the centroids are
    /// visited in index order and replace the best only when strictly nearer, so ties go to the
    /// lower index as in the search. Keys are finite for finite data.
    pub fn nearest_in_neighbourhood(&self, c: [i32; 3], points: &[Vec3], normals: &[Vec3], metric: Metric) -> Vec<Option<(u32, SearchOutcome)>> {
        let mut items: Vec<usize> = Vec::new();
        for dz in -1..=1 {
            for dy in -1..=1 {
                let (y, z) = (c[1] + dy, c[2] + dz);
                if y < 0 || y >= self.dims[1] || z < 0 || z >= self.dims[2] {
                    continue;
                }
                items.extend(self.row_items((c[0] - 1).max(0), (c[0] + 1).min(self.dims[0] - 1), y, z));
            }
        }
        items.sort_unstable_by_key(|&t| self.items[t]);
        let n = points.len();
        let axis = |v: &[Vec3], a: usize| -> Vec<f32> { v.iter().map(|x| x[a]).collect() };
        let (px, py, pz) = (axis(points, 0), axis(points, 1), axis(points, 2));
        let (nx, ny, nz) = (axis(normals, 0), axis(normals, 1), axis(normals, 2));
        let mut key = vec![f32::INFINITY; n];
        let mut label = vec![MISS; n];
        let candidates: Vec<(Vec3, Vec3, u32)> = items.iter().map(|&t| (self.item_positions[t], self.item_normals[t], self.items[t])).collect();
        let points = Soa { px: &px, py: &py, pz: &pz, nx: &nx, ny: &ny, nz: &nz };
        match metric {
            Metric::Eq7 { normal_threshold } => {
                nearest_of_run(&candidates, &points, &mut key, &mut label, |d2, cos| if cos > normal_threshold { d2 } else { f32::INFINITY })
            }
            Metric::Ward { alpha } => nearest_of_run(&candidates, &points, &mut key, &mut label, |d2, cos| vplgi_types::clustering::ward_error(alpha, d2, cos)),
        }
        key.iter()
            .zip(label)
            .map(|(&k, l)| {
                let settled = match metric {
                    Metric::Eq7 { .. } => l != MISS,
                    Metric::Ward { .. } => l != MISS && metric.settled(k, self.cell),
                };
                settled.then_some((l, SearchOutcome::Neighbourhood))
            })
            .collect()
    }

    /// The `best.len()` nearest compatible centroids of point (`p`, `n`), nearest first (ties:
    /// lower index), written to `best` as (squared distance, index); returns how many were found
    /// and how the search ended. This one search serves both the k-means iterations (one entry)
    /// and the fuzzy assignment (F entries), so its first entry is always the hard label.
    pub fn search(&self, p: Vec3, n: Vec3, metric: Metric, best: &mut [(f32, u32)]) -> (usize, SearchOutcome) {
        self.search_from(p, n, self.coords(p), metric, best, None)
    }

    /// [`Grid::search`] for the nearest centroid, knowing a candidate: centroid `hint` (the
    /// point's label in the previous k-means iteration). The answer is the same; only cells that
    /// cannot hold anything as near as the candidate are skipped, so most of the 27 are.
    pub fn search_near(&self, p: Vec3, n: Vec3, metric: Metric, hint: u32) -> (u32, SearchOutcome) {
        let mut best = [(f32::INFINITY, MISS)];
        let pc = self.coords(p);
        let start = self.centroids.get(hint as usize).and_then(|&c| {
            let cc = self.coords(c);
            let near = (0..3).all(|a| (cc[a] - pc[a]).abs() <= 1);
            let key = metric.key(dist2(p, c), cosine(n, self.centroid_normals[hint as usize]));
            key.filter(|_| near).map(|key| (key, hint))
        });
        let (count, outcome) = self.search_from(p, n, pc, metric, &mut best, start);
        (if count > 0 { best[0].1 } else { MISS }, outcome)
    }

    /// The search, with `best` starting as `start` (a compatible centroid of the 27-cell
    /// neighbourhood) if given. In the neighbourhood, cells farther from the point than the
    /// current F-th best cannot change the answer and are skipped. The bound of a neighbour cell
    /// is the point's distance to the shared faces ([`Metric::key_bound`]); it is lowered by
    /// 1e-4 cell against rounding in [`Grid::coords`] and compared with a relative margin of
    /// 1e-5, so only cells that cannot even tie are skipped (ties go to the lower index). A
    /// crowded neighbourhood ([`CROWDED_CENTROIDS`]) is not visited: every centroid is scanned.
    fn search_from(&self, p: Vec3, n: Vec3, c: [i32; 3], metric: Metric, best: &mut [(f32, u32)], start: Option<(f32, u32)>) -> (usize, SearchOutcome) {
        let f = best.len();
        let mut count = 0usize;
        if let Some(s) = start {
            best[0] = s;
            count = 1;
        }
        let consider = |items: std::ops::Range<usize>, best: &mut [(f32, u32)], count: &mut usize| {
            for t in items {
                let Some(key) = metric.key(dist2(p, self.item_positions[t]), cosine(n, self.item_normals[t])) else {
                    continue;
                };
                let cand = (key, self.items[t]);
                if f == 1 {
                    // The k-means iterations: only the nearest (ties to the lower index).
                    if *count == 0 || cand < best[0] {
                        best[0] = cand;
                        *count = 1;
                    }
                    continue;
                }
                // Insertion into the sorted list of the f best (Alg. 2, lines 9-17).
                let mut pos = *count;
                while pos > 0 && cand < best[pos - 1] {
                    pos -= 1;
                }
                if pos < f {
                    let end = (*count).min(f - 1);
                    best.copy_within(pos..end, pos + 1);
                    best[pos] = cand;
                    *count = (*count + 1).min(f);
                }
            }
        };
        if self.crowded(c) {
            // Too many centroids around the point to visit (CROWDED_CENTROIDS): all of them,
            // exactly, as the GPU's search does.
            count = 0;
            consider(0..self.items.len(), best, &mut count);
            return self.widened_or_nearest(p, count, best);
        }
        // Squared gaps to the lower and upper neighbour cells along each axis (0 for the own).
        let q = (p - self.origin) / self.cell;
        let gaps = |a: usize| {
            let below = ((q[a] - c[a] as f32) - 1e-4).max(0.0) * self.cell;
            let above = ((c[a] as f32 + 1.0 - q[a]) - 1e-4).max(0.0) * self.cell;
            [below * below, 0.0, above * above]
        };
        let (gx, gy, gz) = (gaps(0), gaps(1), gaps(2));
        // The point's own row first, then the rows sharing a face with it, then the diagonal ones.
        const ROWS: [(i32, i32); 9] = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)];
        for (dy, dz) in ROWS {
            let (y, z) = (c[1] + dy, c[2] + dz);
            if y < 0 || y >= self.dims[1] || z < 0 || z >= self.dims[2] {
                continue;
            }
            let limit = if count == f { best[f - 1].0 * (1.0 + 1e-5) } else { f32::INFINITY };
            let row = gy[(dy + 1) as usize] + gz[(dz + 1) as usize];
            if metric.key_bound(row) > limit {
                continue;
            }
            let x0 = if c[0] > 0 && metric.key_bound(row + gx[0]) <= limit { c[0] - 1 } else { c[0] };
            let x1 = if c[0] + 1 < self.dims[0] && metric.key_bound(row + gx[2]) <= limit { c[0] + 1 } else { c[0] };
            consider(self.row_items(x0, x1, y, z), best, &mut count);
        }
        // Eq. 7 keeps the paper's approximation: what the 27 cells hold, if anything. Eq. 2 is
        // searched exactly: cells beyond are at least one cell away.
        let done = match metric {
            Metric::Eq7 { .. } => count > 0,
            Metric::Ward { .. } => count == f && metric.settled(best[f - 1].0, self.cell),
        };
        if done {
            return (count, SearchOutcome::Neighbourhood);
        }
        let last = self.max_ring(c);
        for r in 2..=last {
            if ((2 * r + 1) as f64).powi(3) > 8.0 * self.items.len() as f64 + 64.0 {
                // The rings now hold more cells than there are centroids: scanning all
                // centroids is cheaper, and exact.
                count = 0;
                consider(0..self.items.len(), best, &mut count);
                break;
            }
            self.visit_ring(c, r, |items| consider(items, best, &mut count));
            // A centroid in ring r + 1 or beyond has r whole cells between it and the point's cell,
            // so it is at least r cells away: once the F-th best is that near, nothing unvisited
            // can enter the list, and the widened answer is the exact F nearest.
            if count == f && metric.settled(best[f - 1].0, r as f32 * self.cell) {
                return (count, SearchOutcome::Widened);
            }
        }
        self.widened_or_nearest(p, count, best)
    }

    /// How a search beyond the 27 cells ends: its `count` compatible centroids in `best`, or, if
    /// none is compatible, the nearest centroid by position.
    fn widened_or_nearest(&self, p: Vec3, count: usize, best: &mut [(f32, u32)]) -> (usize, SearchOutcome) {
        if count > 0 {
            return (count, SearchOutcome::Widened);
        }
        // No centroid anywhere has a compatible normal: nearest by position.
        let mut nearest = (f32::INFINITY, MISS);
        for (&k, &c) in self.items.iter().zip(&self.item_positions) {
            let cand = (dist2(p, c), k);
            if cand < nearest {
                nearest = cand;
            }
        }
        if nearest.1 == MISS {
            return (0, SearchOutcome::Incompatible);
        }
        best[0] = nearest;
        (1, SearchOutcome::Incompatible)
    }
}

/// How a [`Grid::search`] found its answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchOutcome {
    /// In the 27-cell neighbourhood (the paper's case).
    Neighbourhood,
    /// Only after widening the search beyond the 27 cells.
    Widened,
    /// No centroid has a compatible normal; nearest by position.
    Incompatible,
}

/// How many cells of size `cell` from `min` hold at least one of `points` (which lie at or
/// above `min`). A cell's coordinate is (p − min) / cell truncated: the floor, as the points are
/// not below `min` (and a negative or NaN quotient would become 0 either way). Marked in a
/// bitmap where the cells in reach of the points are few enough (a few bits per point), else
/// counted by sorting the cells' keys.
fn occupied_cells(points: &[Vec3], min: Vec3, cell: f32) -> usize {
    let coords = |p: Vec3| {
        let q = (p - min) / cell;
        [q.x as u64, q.y as u64, q.z as u64]
    };
    let top = points.par_iter().map(|&p| coords(p)).reduce(|| [0; 3], |a, b| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])]);
    let dims = top.map(|t| t as u128 + 1);
    let cells = dims[0] * dims[1] * dims[2];
    if cells <= (64 * points.len() as u128).max(1 << 16) {
        // One bitmap per thread's share of the points, then their union (atomic marks in one
        // shared bitmap would bounce its cache lines between the cores).
        let words = cells.div_ceil(64) as usize;
        let share = points.len().div_ceil(rayon::current_num_threads()).max(1);
        let bits = points
            .par_chunks(share)
            .map(|ps| {
                let mut bits = vec![0u64; words];
                for &p in ps {
                    let c = coords(p);
                    let i = c[0] as u128 + dims[0] * (c[1] as u128 + dims[1] * c[2] as u128);
                    bits[(i / 64) as usize] |= 1 << (i % 64);
                }
                bits
            })
            .reduce(
                || vec![0u64; words],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x |= y);
                    a
                },
            );
        return bits.iter().map(|w| w.count_ones() as usize).sum();
    }
    let mut keys: Vec<u64> = points
        .par_iter()
        .map(|&p| {
            let [x, y, z] = coords(p);
            (x << 42) | (y << 21) | z
        })
        .collect();
    keys.par_sort_unstable();
    keys.dedup();
    keys.len()
}

pub fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), &p| (a.min(p), b.max(p)))
}

/// Assigns each point to its nearest compatible centroid (Alg. 1, lines 6-11). `previous`
/// labels (of the last iteration) only speed the search up: the labels are the same.
pub fn assign(grid: &Grid, points: &[Vec3], normals: &[Vec3], metric: Metric, previous: Option<&[u32]>) -> Vec<u32> {
    assign_with_outcomes(grid, points, normals, metric, previous).0
}

/// [`assign`], also counting the searches that widened and the points with no compatible
/// centroid (as [`Clustering::widened`] and [`Clustering::incompatible`]).
///
/// Points that share a grid cell share their 27-cell neighbourhood, so consecutive points of one
/// cell (the k-means iterations visit them in cell order) are searched together
/// ([`Grid::nearest_in_neighbourhood`]): the neighbourhood's centroids are gathered once, and
/// each is tested against all the run's points in a loop the compiler vectorises across points,
/// instead of one pruned search per point. The answer is the same: the nearest over the 27
/// cells, ties to the lower index. A point the 27 cells do not settle (no compatible centroid
/// for Eq. 7; for Eq. 2 a best error that a centroid farther out could still beat), and every
/// point of a run too short to share the gathering, takes the per-point search from its
/// `previous` label.
fn assign_with_outcomes(grid: &Grid, points: &[Vec3], normals: &[Vec3], metric: Metric, previous: Option<&[u32]>) -> (Vec<u32>, usize, usize) {
    assign_runs(grid, points, normals, metric, previous, &grid.runs(points))
}

/// [`assign_with_outcomes`] over `runs`, the points' [`Grid::runs`] (which the k-means
/// iterations compute once: their points keep their cells).
fn assign_runs(grid: &Grid, points: &[Vec3], normals: &[Vec3], metric: Metric, previous: Option<&[u32]>, runs: &[Range<usize>]) -> (Vec<u32>, usize, usize) {
    let found: Vec<(u32, SearchOutcome)> = runs
        .par_iter()
        .flat_map_iter(|run| {
            let one = |i: usize| grid.search_near(points[i], normals[i], metric, previous.map_or(MISS, |l| l[i]));
            if run.len() < BATCH_MIN {
                return run.clone().map(one).collect::<Vec<_>>();
            }
            let best = grid.nearest_in_neighbourhood(grid.coords(points[run.start]), &points[run.clone()], &normals[run.clone()], metric);
            run.clone().zip(best).map(|(i, b)| b.unwrap_or_else(|| one(i))).collect()
        })
        .collect();
    let widened = found.iter().filter(|f| f.1 != SearchOutcome::Neighbourhood).count();
    let incompatible = found.iter().filter(|f| f.1 == SearchOutcome::Incompatible).count();
    (found.into_iter().map(|f| f.0).collect(), widened, incompatible)
}

/// Runs of points in one cell shorter than this are searched point by point: gathering the
/// neighbourhood costs about as much as a few pruned searches.
const BATCH_MIN: usize = 8;

/// A run's points and normals, one array per component.
struct Soa<'a> {
    px: &'a [f32],
    py: &'a [f32],
    pz: &'a [f32],
    nx: &'a [f32],
    ny: &'a [f32],
    nz: &'a [f32],
}

/// For each candidate (position, normal, index) in index order, each point whose key (`key_of`
/// its squared distance and normal cosine, computed as [`dist2`] and [`cosine`] do) is strictly
/// below its best takes it. Straight-line code over the points, monomorphised per metric, so
/// the loop vectorises across points.
#[inline(always)]
fn nearest_of_run(candidates: &[(Vec3, Vec3, u32)], p: &Soa, key: &mut [f32], label: &mut [u32], key_of: impl Fn(f32, f32) -> f32) {
    let n = key.len();
    let (px, py, pz, nx, ny, nz, label) = (&p.px[..n], &p.py[..n], &p.pz[..n], &p.nx[..n], &p.ny[..n], &p.nz[..n], &mut label[..n]);
    for &(cp, cn, id) in candidates {
        for q in 0..n {
            let (dx, dy, dz) = (px[q] - cp.x, py[q] - cp.y, pz[q] - cp.z);
            let mut d2 = dx * dx;
            d2 += dy * dy;
            d2 += dz * dz;
            let mut cos = nx[q] * cn.x;
            cos += ny[q] * cn.y;
            cos += nz[q] * cn.z;
            let k = key_of(d2, cos);
            let best = key[q];
            // Selects as masks, not branches, so that the loop vectorises.
            let nearer = ((k < best) as u32).wrapping_neg();
            key[q] = f32::from_bits((k.to_bits() & nearer) | (best.to_bits() & !nearer));
            label[q] = (id & nearer) | (label[q] & !nearer);
        }
    }
}

/// Recomputes the centroids from the labels with fixed-point sums (Alg. 1, lines 12-18).
/// Clusters without members keep their previous centroid. Returns the member counts.
pub fn update(fix: &FixedPoint, points: &[Vec3], normals: &[Vec3], labels: &[u32], centroids: &mut [Vec3], cnormals: &mut [Vec3]) -> Vec<u32> {
    let k = centroids.len();
    // A few chunks per thread: each chunk's sums are a K-sized table, zeroed and then reduced.
    let chunk = 1 << 14;
    let (sums, counts) = points
        .par_chunks(chunk)
        .zip(normals.par_chunks(chunk))
        .zip(labels.par_chunks(chunk))
        .map(|((ps, ns), ls)| {
            let mut sums = vec![[0u64; 6]; k];
            let mut counts = vec![0u32; k];
            for ((&p, &n), &l) in ps.iter().zip(ns).zip(ls) {
                if l == MISS {
                    continue;
                }
                let q = fix.quantize(p, n);
                let s = &mut sums[l as usize];
                for a in 0..6 {
                    s[a] += q[a] as u64;
                }
                counts[l as usize] += 1;
            }
            (sums, counts)
        })
        .reduce(
            || (vec![[0u64; 6]; k], vec![0u32; k]),
            |(mut sa, mut ca), (sb, cb)| {
                // Integer addition is associative: any reduction order gives the same sums.
                for i in 0..k {
                    for a in 0..6 {
                        sa[i][a] += sb[i][a];
                    }
                    ca[i] += cb[i];
                }
                (sa, ca)
            },
        );
    for i in 0..k {
        if counts[i] > 0 {
            let (p, n) = fix.mean(&sums[i], counts[i]);
            centroids[i] = p;
            if let Some(n) = n {
                cnormals[i] = n;
            }
        }
    }
    counts
}

/// Clusters the points (`positions`, unit `normals`) with Alg. 1 and assigns every point to its
/// F nearest clusters with Alg. 2, from K seeds spread evenly over the downsampled points.
pub fn cluster(positions: &[Vec3], normals: &[Vec3], params: &ClusterParams) -> Clustering {
    cluster_from(positions, normals, params, ClusterStart::Stride)
}

/// [`cluster`] from other initial centroids: given seeds (point indices, such as
/// [`crate::seeding::seeding`]'s; their number is K), or the previous frame's clusters
/// ([`temporal::admit`]).
pub fn cluster_from(positions: &[Vec3], normals: &[Vec3], params: &ClusterParams, start: ClusterStart<'_>) -> Clustering {
    let m = positions.len();
    let f = params.effective_f() as usize;
    let k = match start {
        ClusterStart::Seeds(given) => given.len(),
        _ => params.k as usize,
    }
    .min(m);
    if m == 0 || k == 0 {
        return Clustering { f, ..Default::default() };
    }
    // Downsample by gamma, but never below K points.
    let gamma = (params.gamma as usize).clamp(1, (m / k).max(1));
    let sample = downsample(m, gamma, params.seed);
    let sp: Vec<Vec3> = sample.iter().map(|&i| positions[i as usize]).collect();
    let sn: Vec<Vec3> = sample.iter().map(|&i| normals[i as usize]).collect();
    let geometry = Grid::for_data(bounds(positions), &sp, k);
    let metric = params.metric;

    let point = |seeds: &[u32]| -> (Vec<Vec3>, Vec<Vec3>) { seeds.iter().map(|&i| (positions[i as usize], normals[i as usize])).unzip() };
    let (mut cpos, mut cnor, warm_kept, fresh) = match start {
        ClusterStart::Stride => {
            let (p, n) = point(&seed_centroids(&sample, k, params.seed));
            (p, n, 0, 0)
        }
        ClusterStart::Seeds(given) => {
            let (p, n) = point(&given[..k]);
            (p, n, 0, 0)
        }
        ClusterStart::Warm { previous, seeds } => {
            let admission = temporal::admit(&geometry, positions, normals, previous, metric);
            let stride;
            let candidates = match seeds {
                Some(s) => s,
                None => {
                    stride = seed_centroids(&sample, k, params.seed);
                    &stride
                }
            };
            let fresh = new_seeds(candidates, &admission.unfit, k.saturating_sub(admission.kept.len()), params.seed);
            let (mut p, mut n): (Vec<Vec3>, Vec<Vec3>) = admission.kept.iter().map(|&c| (previous[c as usize].position, previous[c as usize].normal)).unzip();
            let (fp, fnor) = point(&fresh);
            p.extend(fp);
            n.extend(fnor);
            (p, n, admission.kept.len(), fresh.len())
        }
    };
    let k = cpos.len();
    if k == 0 {
        return Clustering { f, ..Default::default() };
    }
    let (lo, hi) = bounds(positions);
    let fix = FixedPoint::new(lo, hi);
    // The iterations visit the sample in cell order (the centroid sums do not depend on order)
    // and start each point's search from its previous label.
    let (_, order) = geometry.cell_order(&sp);
    let (op, on): (Vec<Vec3>, Vec<Vec3>) = order.iter().map(|&i| (sp[i as usize], sn[i as usize])).unzip();
    let mut ordered: Option<Vec<u32>> = None;
    let runs = geometry.runs(&op);
    for _ in 0..params.iterations {
        let grid = geometry.fill(&cpos, &cnor);
        let (l, _, _) = assign_runs(&grid, &op, &on, metric, ordered.as_deref(), &runs);
        update(&fix, &op, &on, &l, &mut cpos, &mut cnor);
        ordered = Some(l);
    }

    // Final hard assignment of every point; drop the clusters nobody is nearest to. Without
    // downsampling the sample is every point, so it is assigned in cell order from the last
    // iteration's labels.
    let grid = geometry.fill(&cpos, &cnor);
    let (hard, hard_widened, hard_incompatible) = if sp.len() == m {
        let (ordered_hard, w, i) = assign_runs(&grid, &op, &on, metric, ordered.as_deref(), &runs);
        let mut hard = vec![MISS; m];
        for (&i, &label) in order.iter().zip(&ordered_hard) {
            hard[i as usize] = label;
        }
        (hard, w, i)
    } else {
        assign_with_outcomes(&grid, positions, normals, metric, None)
    };
    let mut counts = vec![0u32; k];
    for &l in &hard {
        counts[l as usize] += 1;
    }
    let mut remap = vec![MISS; k];
    let mut kept = 0u32;
    for i in 0..k {
        if counts[i] > 0 {
            remap[i] = kept;
            kept += 1;
        }
    }
    let keep = |v: &[Vec3]| -> Vec<Vec3> { (0..k).filter(|&i| counts[i] > 0).map(|i| v[i]).collect() };
    let (cpos, cnor) = (keep(&cpos), keep(&cnor));
    let members: Vec<u32> = counts.iter().copied().filter(|&c| c > 0).collect();

    let (labels, weights, widened, incompatible) = if f == 1 {
        // One label per point: the fuzzy search would find the hard label again (its cluster
        // survived), with weight 1 and the same outcome, so the hard pass is reused.
        (hard.iter().map(|&l| remap[l as usize]).collect(), vec![1.0; m], hard_widened, hard_incompatible)
    } else {
        fuzzy_assign(&geometry.fill(&cpos, &cnor), (positions, normals), f, params)
    };
    debug_assert!((0..m).all(|i| labels[i * f] == remap[hard[i] as usize]));

    let representatives = representatives((positions, normals), &labels, f, (&cpos, &cnor), params.representative);
    Clustering { positions: cpos, normals: cnor, representatives, members, f, labels, weights, widened, incompatible, kept: warm_kept, fresh }
}

/// Fuzzy assignment (Alg. 2) of every point to its `f` nearest clusters in `grid` (the surviving
/// centroids, on the run's grid geometry: a point's nearest centroid survived, so its first
/// label is its hard label). Returns labels and weights (`f` per point) and the counts of
/// widened and incompatible searches.
fn fuzzy_assign(grid: &Grid, (positions, normals): (&[Vec3], &[Vec3]), f: usize, params: &ClusterParams) -> (Vec<u32>, Vec<f32>, usize, usize) {
    let rows: Vec<([u32; MAX_F as usize], [f32; MAX_F as usize], SearchOutcome)> = positions
        .par_iter()
        .zip(normals)
        .map(|(&p, &n)| {
            let mut best = [(f32::INFINITY, MISS); MAX_F as usize];
            let (count, outcome) = grid.search(p, n, params.metric, &mut best[..f]);
            let mut labels = [MISS; MAX_F as usize];
            let mut weights = [0f32; MAX_F as usize];
            for j in 0..count {
                labels[j] = best[j].1;
            }
            fuzzy_weights(&best[..count], params.fuzzy, params.metric, grid.cell, &mut weights[..count]);
            (labels, weights, outcome)
        })
        .collect();
    let mut labels = Vec::with_capacity(positions.len() * f);
    let mut weights = Vec::with_capacity(positions.len() * f);
    let (mut widened, mut incompatible) = (0, 0);
    for (l, w, outcome) in &rows {
        labels.extend_from_slice(&l[..f]);
        weights.extend_from_slice(&w[..f]);
        match outcome {
            SearchOutcome::Neighbourhood => {}
            SearchOutcome::Widened => widened += 1,
            SearchOutcome::Incompatible => {
                widened += 1;
                incompatible += 1
            }
        }
    }
    (labels, weights, widened, incompatible)
}

/// For each cluster, the member (by hard label) of smallest `rule` key to the centroid: the
/// nearest, or the one of smallest Eq. 2 error; ties to the lower index.
fn representatives(
    (positions, normals): (&[Vec3], &[Vec3]),
    labels: &[u32],
    f: usize,
    (centroids, cnormals): (&[Vec3], &[Vec3]),
    rule: Representative,
) -> Vec<u32> {
    let k = centroids.len();
    positions
        .par_iter()
        .enumerate()
        .fold(
            || vec![(f32::INFINITY, MISS); k],
            |mut best, (i, &p)| {
                let l = labels[i * f] as usize;
                let cand = (rule.key(dist2(p, centroids[l]), cosine(normals[i], cnormals[l])), i as u32);
                if cand < best[l] {
                    best[l] = cand;
                }
                best
            },
        )
        .reduce(|| vec![(f32::INFINITY, MISS); k], |a, b| a.into_iter().zip(b).map(|(x, y)| if y < x { y } else { x }).collect())
        .into_iter()
        .map(|(_, i)| i)
        .collect()
}

pub mod temporal;

impl vplgi_frame::Counted for Clustering {
    fn count(&self) -> u32 {
        self.k() as u32
    }
}

/// The points' positions and normals, as the clustering reads them.
pub(crate) fn positions_and_normals(points: &[Endpoint]) -> (Vec<Vec3>, Vec<Vec3>) {
    (points.iter().map(Endpoint::p).collect(), points.iter().map(Endpoint::n).collect())
}

impl vplgi_frame::stages::Cluster for CpuScene<'_> {
    fn cluster(&self, points: &Vec<Endpoint>, params: &ClusterParams, start: ClusterStart<'_>) -> Result<(Clustering, ClusterCounts), FrameError> {
        let (pos, nor) = positions_and_normals(points);
        let c = cluster_from(&pos, &nor, params, start);
        let counts = ClusterCounts { widened: c.widened as u32, kept: c.kept as u32, fresh: c.fresh as u32 };
        Ok((c, counts))
    }

    fn cluster_centres(&self, c: &Clustering, points: &Vec<Endpoint>, metric: Metric) -> Result<Vec<Centre>, FrameError> {
        let (pos, nor) = positions_and_normals(points);
        Ok(temporal::centres(c, &pos, &nor, metric))
    }

    fn representatives(&self, c: &Clustering, points: &Vec<Endpoint>) -> Result<Vec<Endpoint>, FrameError> {
        Ok(c.representatives.iter().map(|&r| points[r as usize]).collect())
    }
}

#[cfg(test)]
mod tests;
