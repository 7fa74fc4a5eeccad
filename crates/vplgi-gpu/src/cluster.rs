//! Stage 3 on the GPU, `cluster` (one pass per file, `shaders/cluster_*.wgsl`), the twin of
//! `vplgi_cpu::cluster::cluster`: Alg. 1 (grid-accelerated k-means with fixed-point centroid
//! sums) and Alg. 2 (F nearest clusters with weights), then empty-cluster removal and
//! representatives. The host makes the same choices as the CPU through
//! `vplgi_types::clustering` (downsampled set, seeds, grid geometry from occupancy counts,
//! fixed-point box); the GPU does every per-point and per-centroid step. Read back: the data's
//! bounding box (6 words), four occupancy counts and the number of surviving clusters.
//!
//! Per-point arrays (points, labels, weights, search outcomes) may be larger than one storage
//! binding: every per-point step runs over [`Window`]s of them, and gathers by index (seeds, the
//! downsampled set, representatives) run over every pair of output and point windows.

use crate::buffers::{batched, dispatch_windows, kernel_params, read_back, record, storage, storage_zeroed, Window};
use crate::context::{validated, within_loop_limit};
use crate::scan::ScanKernel;
use crate::shader::{
    pipeline_with, pipelines, METRIC_EQ7, METRIC_WARD, REDUCE_ITEMS, REPRESENTATIVE_MIN_ERROR, REPRESENTATIVE_NEAREST, WEIGHTS_INVERSE_DISTANCE,
    WEIGHTS_PLAIN_MEAN,
};
use crate::visibility::Endpoint;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::OnceLock;
use vplgi_types::clustering::{
    downsample, grid_geometry, seed_centroids, ClusterParams, ClusterStart, FixedPoint, GridGeometry, Metric, Representative, MAX_ASSIGN_CENTROIDS,
};
use vplgi_types::config::MAX_F;
use vplgi_types::temporal::new_seeds;
use vplgi_types::FuzzyMode;
use crate::backend::{GpuBackend, GpuPoints};
use vplgi_frame::ClusterCounts;
use vplgi_types::clustering::Centre;

mod temporal;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub(crate) struct Params {
    pub(crate) origin: [f32; 4],
    pub(crate) dims: [i32; 4],
    pub(crate) fix_min: [f32; 4],
    pub(crate) fix_ext: [f32; 4],
    pub(crate) n: u32,
    pub(crate) k: u32,
    pub(crate) f: u32,
    pub(crate) threshold: f32,
    pub(crate) fuzzy: u32,
    pub(crate) cells: u32,
    pub(crate) first: u32,
    pub(crate) window: u32,
    pub(crate) alpha: f32,
    pub(crate) representative: u32,
    /// METRIC_EQ7 or METRIC_WARD, for the passes that take it as data (cluster_temporal.wgsl).
    pub(crate) metric: u32,
    pub(crate) pad: u32,
}

/// Refuses K beyond [`MAX_ASSIGN_CENTROIDS`]: a search may scan every centroid in one
/// invocation, and lavapipe would end it early, silently.
pub fn searchable(k: u32, what: &str) -> Result<(), GpuError> {
    within_loop_limit(what, k, MAX_ASSIGN_CENTROIDS, "a GPU search may scan all of them in one invocation")
}

/// A grid filled with centroids, on the device.
pub struct GpuGrid {
    pub geometry: GridGeometry,
    /// First ring at which the search scans all centroids instead.
    pub brute_ring: i32,
    offsets: wgpu::Buffer,
    items: wgpu::Buffer,
}

/// Points assigned to their F nearest clusters.
pub struct Assignment {
    /// `f` labels per point, [`vplgi_types::MISS`]-padded.
    pub labels: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    /// Per point: 0 found in the 27 cells, 1 after widening, 2 no compatible centroid.
    pub outcome: wgpu::Buffer,
}

/// The result, on the device (the twin of `vplgi_cpu::cluster::Clustering`).
pub struct GpuClustering {
    /// `k` centroids as Endpoints.
    pub centroids: wgpu::Buffer,
    pub k: u32,
    pub f: u32,
    pub labels: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    /// `k` point indices.
    pub representatives: wgpu::Buffer,
    pub outcome: wgpu::Buffer,
    /// Started warm: the previous centres kept and the new clusters seeded (0 and 0 otherwise).
    pub kept: u32,
    pub fresh: u32,
}

impl GpuClustering {
    /// A hard clustering (F = 1) given by its labels and `representatives` (point indices), for
    /// the stages after clustering (`vpl_lights`) to run on another backend's clustering: no
    /// centroids, weights or search outcomes, which those stages do not read.
    pub fn of_labels(device: &wgpu::Device, labels: &[u32], representatives: &[u32]) -> GpuClustering {
        GpuClustering {
            centroids: storage::<Endpoint>(device, "centroids", &[]),
            k: representatives.len() as u32,
            f: 1,
            labels: storage(device, "labels", labels),
            weights: storage::<f32>(device, "weights", &[]),
            representatives: storage(device, "representatives", representatives),
            outcome: storage::<u32>(device, "outcome", &[]),
            kept: 0,
            fresh: 0,
        }
    }
}

/// How [`ClusterKernel::assign`] assigns: the metric, clusters per point, their weights.
#[derive(Clone, Copy, Debug)]
pub struct AssignRule {
    pub metric: Metric,
    pub f: u32,
    pub fuzzy: FuzzyMode,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = ClusterKernel;

/// The clustering passes, one shader file each (`shaders/cluster_*.wgsl`).
pub struct ClusterKernel {
    gather: Pass,
    bounds: Pass,
    outcome_counts: Pass,
    occupancy: Pass,
    count_bits: Pass,
    grid_count: Pass,
    grid_scatter: Pass,
    /// The assignment, by metric and F (1 ..= MAX_F) ([`ClusterKernel::assign_pass`]),
    /// compiled on first use: F fixes the trip count of every loop over a point's list of
    /// nearest clusters (cluster_assign.wgsl), the metric which key the list holds.
    assign: Vec<OnceLock<Pass>>,
    accumulate: Pass,
    finalize: Pass,
    count_labels: Pass,
    flags: Pass,
    compact: Pass,
    relabel: Pass,
    rep_d2: Pass,
    rep_index: Pass,
    admit: Pass,
    largest_key: Pass,
    scan: ScanKernel,
}

/// The ring from which scanning every centroid is cheaper than the rings: the CPU's test
/// `(2r + 1)^3 > 8K + 64`, evaluated once.
pub fn brute_ring(k: usize) -> i32 {
    let mut r = 2;
    while ((2 * r + 1) as f64).powi(3) <= 8.0 * k as f64 + 64.0 {
        r += 1;
    }
    r
}

/// A clustering pass: its pipeline, and the name its device time is reported under
/// (`vplgi render --profile`).
struct Pass {
    name: String,
    pipeline: wgpu::ComputePipeline,
}

/// The passes of the `N` entry points of one pass file, in order.
fn passes<const N: usize>(device: &wgpu::Device, file: &str, entries: [&str; N]) -> [Pass; N] {
    let mut pipelines = pipelines(device, file, &entries).into_iter();
    entries.map(|e| Pass { name: format!("cluster {e}"), pipeline: pipelines.next().unwrap_or_else(|| unreachable!("one pipeline per entry point")) })
}

fn groups(n: u32) -> u32 {
    n.div_ceil(64).max(1)
}

impl ClusterKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        let scan = ScanKernel::new(device)?;
        validated(device, "cluster pipelines", || {
            let [gather, bounds, outcome_counts] = passes(device, "cluster_points.wgsl", ["gather", "bounds", "outcome_counts"]);
            let [occupancy, count_bits] = passes(device, "cluster_occupancy.wgsl", ["occupancy", "count_bits"]);
            let [grid_count, grid_scatter] = passes(device, "cluster_grid.wgsl", ["grid_count", "grid_scatter"]);
            let assign = (0..2 * (MAX_F + 1)).map(|_| OnceLock::new()).collect();
            let [accumulate, finalize] = passes(device, "cluster_update.wgsl", ["accumulate", "finalize"]);
            let [count_labels, flags, compact, relabel] = passes(device, "cluster_compact.wgsl", ["count_labels", "flags", "compact", "relabel"]);
            let [rep_d2, rep_index] = passes(device, "cluster_representatives.wgsl", ["rep_d2", "rep_index"]);
            let [admit, largest_key] = passes(device, "cluster_temporal.wgsl", ["admit", "largest_key"]);
            let kernel = ClusterKernel {
                gather,
                bounds,
                outcome_counts,
                occupancy,
                count_bits,
                grid_count,
                grid_scatter,
                assign,
                accumulate,
                finalize,
                count_labels,
                flags,
                compact,
                relabel,
                rep_d2,
                rep_index,
                admit,
                largest_key,
                scan,
            };
            // The variants every default frame uses are compiled now, with the other passes: a
            // pipeline first created after the device is lost is only "invalid", and the frame's
            // error would not say that the device was lost.
            for f in [1, vplgi_types::FrameConfig::default().f] {
                kernel.assign_pass(device, f, METRIC_EQ7);
            }
            kernel
        })
    }

    /// The assignment pass for `f` clusters per point under `metric` (a `METRIC_*` code),
    /// compiled on first use.
    fn assign_pass(&self, device: &wgpu::Device, f: u32, metric: u32) -> &Pass {
        self.assign[(metric * (MAX_F + 1) + f) as usize].get_or_init(|| Pass {
            name: "cluster assign".into(),
            pipeline: pipeline_with(device, "cluster_assign.wgsl", "assign", &[("F", f as f64), ("METRIC", metric as f64)]),
        })
    }

    fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pass: &Pass,
        params: &Params,
        bound: &[(u32, &wgpu::Buffer)],
        threads: u32,
    ) -> Result<(), GpuError> {
        let whole: Vec<(u32, wgpu::BufferBinding)> = bound.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
        self.run_windows(device, queue, pass, params, &whole, threads)
    }

    fn run_windows(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pass: &Pass,
        params: &Params,
        bound: &[(u32, wgpu::BufferBinding)],
        threads: u32,
    ) -> Result<(), GpuError> {
        validated(device, &pass.name, || {
            let p = kernel_params(device, "cluster params", params);
            let mut all = vec![(0, p.as_entire_buffer_binding())];
            all.extend_from_slice(bound);
            dispatch_windows(device, queue, &pass.pipeline, &all, groups(threads));
        })
    }

    /// Windows of `n` points whose widest per-point array (an Endpoint, or `f` labels) fits one
    /// storage binding.
    fn windows(device: &wgpu::Device, n: u32, f: u32) -> Vec<Window> {
        let item = (4 * f as u64).max(std::mem::size_of::<Endpoint>() as u64);
        Window::split(n as u64, item, device.limits().max_storage_buffer_binding_size)
    }

    /// `out[t] = points[index[t]]` for the `n` indices (Endpoints), over `m` points.
    pub fn gather(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        out: &wgpu::Buffer,
        (index, n): (&wgpu::Buffer, u32),
        (points, m): (&wgpu::Buffer, u32),
    ) -> Result<(), GpuError> {
        for wo in Self::windows(device, n, 1) {
            for wi in Self::windows(device, m, 1) {
                let p = Params { n: wo.count as u32, first: wi.first as u32, window: wi.count as u32, ..Default::default() };
                let b = [(1, wi.of::<Endpoint>(points, 1)), (2, wo.of::<u32>(index, 1)), (3, wo.of::<Endpoint>(out, 1))];
                self.run_windows(device, queue, &self.gather, &p, &b, wo.count as u32)?;
            }
        }
        Ok(())
    }

    fn grid_params(&self, g: &GridGeometry, brute: i32) -> Params {
        Params { origin: [g.origin.x, g.origin.y, g.origin.z, g.cell], dims: [g.dims[0], g.dims[1], g.dims[2], brute], ..Default::default() }
    }

    /// The bounding box of `n` points.
    pub fn bounds(&self, device: &wgpu::Device, queue: &wgpu::Queue, points: &wgpu::Buffer, n: u32) -> Result<(Vec3, Vec3), GpuError> {
        let init = [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0];
        let keys = storage(device, "bounds", &init);
        for w in Self::windows(device, n, 1) {
            let b = [(1, w.of::<Endpoint>(points, 1)), (9, keys.as_entire_buffer_binding())];
            self.run_windows(device, queue, &self.bounds, &Params { n: w.count as u32, ..Default::default() }, &b, (w.count as u32).div_ceil(REDUCE_ITEMS))?;
        }
        let k = read_back::<u32>(device, queue, &keys, 6)?;
        let decode = |u: u32| f32::from_bits(if u & 0x8000_0000 != 0 { u & 0x7fff_ffff } else { !u });
        Ok((Vec3::new(decode(k[0]), decode(k[1]), decode(k[2])), Vec3::new(decode(k[3]), decode(k[4]), decode(k[5]))))
    }

    /// Distinct cells `floor((p - min) / cell)` among the `s` sample points.
    fn occupied(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (sample, s): (&wgpu::Buffer, u32),
        min: Vec3,
        ext: Vec3,
        cell: f32,
    ) -> Result<usize, GpuError> {
        let dims = [0, 1, 2].map(|a| (ext[a] / cell).floor() as i32 + 1);
        let cells = dims.iter().map(|&d| d as u64).product::<u64>();
        let words = cells.div_ceil(32) as u32;
        let bitmap = storage_zeroed::<u32>(device, "occupancy bitmap", words as usize);
        let total = storage_zeroed::<u32>(device, "occupied", 1);
        let mut p = self.grid_params(&GridGeometry { origin: min, cell, dims }, 0);
        p.cells = words;
        for w in Self::windows(device, s, 1) {
            p.n = w.count as u32;
            self.run_windows(device, queue, &self.occupancy, &p, &[(1, w.of::<Endpoint>(sample, 1)), (9, bitmap.as_entire_buffer_binding())], w.count as u32)?;
        }
        self.run(device, queue, &self.count_bits, &p, &[(4, &total), (9, &bitmap)], words)?;
        Ok(read_back::<u32>(device, queue, &total, 1)?[0] as usize)
    }

    /// Fills the grid `geometry` with `k` centroids (counting sort by cell).
    pub fn fill_grid(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        geometry: &GridGeometry,
        centroids: &wgpu::Buffer,
        k: u32,
    ) -> Result<GpuGrid, GpuError> {
        let cells = geometry.dims.iter().map(|&d| d as u32).product::<u32>();
        let brute = brute_ring(k as usize);
        let mut p = self.grid_params(geometry, brute);
        p.k = k;
        let counts = storage_zeroed::<u32>(device, "cell counts", cells as usize);
        let offsets = storage_zeroed::<u32>(device, "cell offsets", cells as usize + 1);
        let cursor = storage_zeroed::<u32>(device, "cell cursor", cells as usize);
        let items = storage_zeroed::<u32>(device, "cell items", k as usize);
        self.run(device, queue, &self.grid_count, &p, &[(3, centroids), (4, &counts)], k)?;
        self.scan.run(device, queue, &counts, cells, &offsets)?;
        self.run(device, queue, &self.grid_scatter, &p, &[(3, centroids), (5, &offsets), (6, &items), (9, &cursor)], k)?;
        Ok(GpuGrid { geometry: *geometry, brute_ring: brute, offsets, items })
    }

    /// Each of the `n` points gets its `rule.f` nearest compatible centroids (of `k`), with
    /// weights for `rule.fuzzy`.
    pub fn assign(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        grid: &GpuGrid,
        (points, n): (&wgpu::Buffer, u32),
        (centroids, k): (&wgpu::Buffer, u32),
        rule: AssignRule,
    ) -> Result<Assignment, GpuError> {
        searchable(k, "centroids one assignment searches")?;
        let AssignRule { metric, f, fuzzy } = rule;
        let mut p = self.grid_params(&grid.geometry, grid.brute_ring);
        (p.k, p.f) = (k, f);
        let code = match metric {
            Metric::Eq7 { normal_threshold } => {
                p.threshold = normal_threshold;
                METRIC_EQ7
            }
            Metric::Ward { alpha } => {
                p.alpha = alpha;
                METRIC_WARD
            }
        };
        p.fuzzy = if fuzzy == FuzzyMode::Weighted { WEIGHTS_INVERSE_DISTANCE } else { WEIGHTS_PLAIN_MEAN };
        let a = Assignment {
            labels: storage_zeroed::<u32>(device, "labels", (n * f) as usize),
            weights: storage_zeroed::<f32>(device, "weights", (n * f) as usize),
            outcome: storage_zeroed::<u32>(device, "outcome", n as usize),
        };
        let f64 = f as u64;
        for w in Self::windows(device, n, f) {
            p.n = w.count as u32;
            let b = [
                (1, w.of::<Endpoint>(points, 1)),
                (3, centroids.as_entire_buffer_binding()),
                (5, grid.offsets.as_entire_buffer_binding()),
                (6, grid.items.as_entire_buffer_binding()),
                (7, w.of::<u32>(&a.labels, f64)),
                (8, w.of::<f32>(&a.weights, f64)),
                (10, w.of::<u32>(&a.outcome, 1)),
            ];
            self.run_windows(device, queue, self.assign_pass(device, f, code), &p, &b, w.count as u32)?;
        }
        Ok(a)
    }

    /// Recomputes the `k` centroids from the first label of each of the `n` points (labels `f`
    /// per point) with fixed-point sums; clusters without members keep their centroid. Returns
    /// the member counts.
    pub fn update(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        fix: &FixedPoint,
        (points, n): (&wgpu::Buffer, u32),
        (labels, f): (&wgpu::Buffer, u32),
        (centroids, k): (&wgpu::Buffer, u32),
    ) -> Result<wgpu::Buffer, GpuError> {
        let mut p = Params { fix_min: [fix.min.x, fix.min.y, fix.min.z, 0.0], fix_ext: [fix.ext.x, fix.ext.y, fix.ext.z, 0.0], n, k, f, ..Default::default() };
        let sums = storage_zeroed::<u32>(device, "centroid sums", (k * 12) as usize);
        let counts = storage_zeroed::<u32>(device, "centroid counts", k as usize);
        for w in Self::windows(device, n, f) {
            p.n = w.count as u32;
            let b = [
                (1, w.of::<Endpoint>(points, 1)),
                (4, counts.as_entire_buffer_binding()),
                (7, w.of::<u32>(labels, f as u64)),
                (9, sums.as_entire_buffer_binding()),
            ];
            self.run_windows(device, queue, &self.accumulate, &p, &b, w.count as u32)?;
        }
        p.n = n;
        self.run(device, queue, &self.finalize, &p, &[(3, centroids), (4, &counts), (9, &sums)], k)?;
        Ok(counts)
    }

    /// Clusters `m` points (Endpoints on the device) like `vplgi_cpu::cluster::cluster`.
    pub fn cluster(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        points: &wgpu::Buffer,
        m: u32,
        params: &ClusterParams,
    ) -> Result<GpuClustering, GpuError> {
        self.cluster_from(device, queue, (points, m), params, ClusterStart::Stride)
    }

    /// [`ClusterKernel::cluster`] from other initial centroids, like
    /// `vplgi_cpu::cluster::cluster_from`: given seeds (their number is K) or the previous
    /// frame's clusters (`cluster_temporal.wgsl`).
    pub fn cluster_from(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (points, m): (&wgpu::Buffer, u32),
        params: &ClusterParams,
        start: ClusterStart<'_>,
    ) -> Result<GpuClustering, GpuError> {
        // One submission per run of dispatches between the host's reads, not one per dispatch.
        batched(device, queue, || self.cluster_batched(device, queue, (points, m), params, start))
    }

    fn cluster_batched(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (points, m): (&wgpu::Buffer, u32),
        params: &ClusterParams,
        start: ClusterStart<'_>,
    ) -> Result<GpuClustering, GpuError> {
        let f = params.effective_f();
        let k = match start {
            ClusterStart::Seeds(given) => given.len() as u32,
            _ => params.k,
        }
        .min(m);
        if m == 0 || k == 0 {
            return Ok(self.empty(device, f));
        }
        let gamma = (params.gamma as usize).clamp(1, (m as usize / k as usize).max(1));
        let sample = downsample(m as usize, gamma, params.seed);
        let s = sample.len() as u32;
        // The downsampled set is gathered once, so the iterations read it as plain points.
        let sample_points = storage_zeroed::<Endpoint>(device, "sample points", s as usize);
        self.gather(device, queue, &sample_points, (&storage(device, "sample", &sample), s), (points, m))?;

        let (min, max) = self.bounds(device, queue, points, m)?;
        let ext = (max - min).max(Vec3::splat(1e-12));
        let mut occ_err = None;
        let geometry = grid_geometry(min, max, k as usize, |cell| match self.occupied(device, queue, (&sample_points, s), min, ext, cell) {
            Ok(c) => c,
            Err(e) => {
                occ_err = Some(e);
                1
            }
        });
        if let Some(e) = occ_err {
            return Err(e);
        }
        let fix = FixedPoint::new(min, max);
        let metric = params.metric;
        let seed_points = |seeds: &[u32]| -> Result<wgpu::Buffer, GpuError> {
            let out = storage_zeroed::<Endpoint>(device, "centroids", seeds.len());
            self.gather(device, queue, &out, (&storage(device, "seeds", seeds), seeds.len() as u32), (points, m))?;
            Ok(out)
        };
        let (centroids, k, warm_kept, fresh) = match start {
            ClusterStart::Stride => (seed_points(&seed_centroids(&sample, k as usize, params.seed))?, k, 0, 0),
            ClusterStart::Seeds(given) => (seed_points(&given[..k as usize])?, k, 0, 0),
            ClusterStart::Warm { previous, seeds } => {
                let (kept, unfit) = self.admit(device, queue, &geometry, (points, m), previous, metric)?;
                let stride;
                let candidates = match seeds {
                    Some(s) => s,
                    None => {
                        stride = seed_centroids(&sample, k as usize, params.seed);
                        &stride[..]
                    }
                };
                let fresh = new_seeds(candidates, &unfit, (k as usize).saturating_sub(kept.len()), params.seed);
                // The kept centres, then the new seeds' points: the CPU's order.
                let mut start: Vec<Endpoint> = kept.iter().map(|&c| Endpoint::new(previous[c as usize].position, previous[c as usize].normal)).collect();
                start.resize(kept.len() + fresh.len(), Endpoint::default());
                let centroids = storage(device, "centroids", &start);
                if !fresh.is_empty() {
                    let points_of_fresh = seed_points(&fresh)?;
                    let size = std::mem::size_of::<Endpoint>() as u64;
                    record(device, queue, |e| e.copy_buffer_to_buffer(&points_of_fresh, 0, &centroids, kept.len() as u64 * size, fresh.len() as u64 * size));
                }
                let (kept, fresh) = (kept.len() as u32, fresh.len() as u32);
                (centroids, kept + fresh, kept, fresh)
            }
        };
        if k == 0 {
            return Ok(self.empty(device, f));
        }
        // The iterations visit the sample in cell order, so the invocations of a workgroup search
        // the same few cells (coherent branches and loads); the centroid sums are fixed-point
        // integers, so the order changes nothing. The counting sort is the centroid grid's fill,
        // run over the sample; a sample too large for one binding keeps its order.
        let sample_points = if params.iterations > 0 && Self::windows(device, s, 1).len() == 1 {
            let by_cell = self.fill_grid(device, queue, &geometry, &sample_points, s)?;
            let sorted = storage_zeroed::<Endpoint>(device, "sample points by cell", s as usize);
            self.gather(device, queue, &sorted, (&by_cell.items, s), (&sample_points, s))?;
            sorted
        } else {
            sample_points
        };
        for _ in 0..params.iterations {
            let grid = self.fill_grid(device, queue, &geometry, &centroids, k)?;
            let a = self.assign(device, queue, &grid, (&sample_points, s), (&centroids, k), AssignRule { metric, f: 1, fuzzy: FuzzyMode::Hard })?;
            self.update(device, queue, &fix, (&sample_points, s), (&a.labels, 1), (&centroids, k))?;
        }

        // Final hard assignment; drop clusters nobody is nearest to.
        let grid = self.fill_grid(device, queue, &geometry, &centroids, k)?;
        let hard = self.assign(device, queue, &grid, (points, m), (&centroids, k), AssignRule { metric, f: 1, fuzzy: FuzzyMode::Hard })?;
        let counts = storage_zeroed::<u32>(device, "member counts", k as usize);
        for w in Self::windows(device, m, 1) {
            let p = Params { n: w.count as u32, k, f: 1, ..Default::default() };
            self.run_windows(
                device,
                queue,
                &self.count_labels,
                &p,
                &[(4, counts.as_entire_buffer_binding()), (7, w.of::<u32>(&hard.labels, 1))],
                w.count as u32,
            )?;
        }
        let flags = storage_zeroed::<u32>(device, "flags", k as usize);
        let remap = storage_zeroed::<u32>(device, "remap", k as usize + 1);
        self.run(device, queue, &self.flags, &Params { k, ..Default::default() }, &[(4, &counts), (9, &flags)], k)?;
        self.scan.run(device, queue, &flags, k, &remap)?;
        let kept = read_back::<u32>(device, queue, &remap, k as usize + 1)?[k as usize];
        let survivors = storage_zeroed::<Endpoint>(device, "surviving centroids", kept as usize);
        let members = storage_zeroed::<u32>(device, "members", kept as usize);
        self.run(
            device,
            queue,
            &self.compact,
            &Params { k, ..Default::default() },
            &[(3, &centroids), (4, &counts), (5, &remap), (6, &members), (11, &survivors)],
            k,
        )?;

        // Fuzzy assignment (Alg. 2) against the survivors on a grid of the same geometry; with
        // F = 1 it would find the hard labels again (with weight 1 and the same search outcomes),
        // so those are renumbered instead, as on the CPU.
        let a = if f == 1 {
            let labels = storage_zeroed::<u32>(device, "labels", m as usize);
            for w in Self::windows(device, m, 1) {
                let p = Params { n: w.count as u32, k, f: 1, ..Default::default() };
                let b = [(5, remap.as_entire_buffer_binding()), (7, w.of::<u32>(&hard.labels, 1)), (12, w.of::<u32>(&labels, 1))];
                self.run_windows(device, queue, &self.relabel, &p, &b, w.count as u32)?;
            }
            Assignment { labels, weights: hard.weights, outcome: hard.outcome }
        } else {
            let grid = self.fill_grid(device, queue, &geometry, &survivors, kept)?;
            self.assign(device, queue, &grid, (points, m), (&survivors, kept), AssignRule { metric, f, fuzzy: params.fuzzy })?
        };

        // Representatives: per cluster the member of smallest key (nearest, or smallest Eq. 2
        // error), ties to the lower index.
        let (representative, alpha) = match params.representative {
            Representative::Nearest => (REPRESENTATIVE_NEAREST, 0.0),
            Representative::MinError { alpha } => (REPRESENTATIVE_MIN_ERROR, alpha),
        };
        let rep_d2 = storage(device, "rep d2", &vec![u32::MAX; kept as usize]);
        let reps = storage(device, "representatives", &vec![u32::MAX; kept as usize]);
        let windows = Self::windows(device, m, f);
        for (pass, name) in [(&self.rep_d2, "rep_d2"), (&self.rep_index, "rep_index")] {
            for w in &windows {
                let p = Params { n: w.count as u32, k: kept, f, first: w.first as u32, alpha, representative, ..Default::default() };
                let b = [
                    (1, w.of::<Endpoint>(points, 1)),
                    (3, survivors.as_entire_buffer_binding()),
                    (4, rep_d2.as_entire_buffer_binding()),
                    (7, w.of::<u32>(&a.labels, f as u64)),
                    (9, reps.as_entire_buffer_binding()),
                ];
                // rep_d2 does not use binding 9.
                let b = if name == "rep_d2" { &b[..4] } else { &b[..] };
                self.run_windows(device, queue, pass, &p, b, w.count as u32)?;
            }
        }
        Ok(GpuClustering {
            centroids: survivors,
            k: kept,
            f,
            labels: a.labels,
            weights: a.weights,
            representatives: reps,
            outcome: a.outcome,
            kept: warm_kept,
            fresh,
        })
    }

    /// A clustering of nothing.
    fn empty(&self, device: &wgpu::Device, f: u32) -> GpuClustering {
        let e = |name| storage_zeroed::<u32>(device, name, 1);
        GpuClustering {
            centroids: storage_zeroed::<Endpoint>(device, "centroids", 1),
            k: 0,
            f,
            labels: e("labels"),
            weights: e("weights"),
            representatives: e("representatives"),
            outcome: e("outcome"),
            kept: 0,
            fresh: 0,
        }
    }

    /// Counts of search outcomes over `n` points: [neighbourhood, widened, incompatible].
    pub fn outcome_counts(&self, device: &wgpu::Device, queue: &wgpu::Queue, outcome: &wgpu::Buffer, n: u32) -> Result<[u32; 3], GpuError> {
        let counts = storage_zeroed::<u32>(device, "outcome counts", 3);
        for w in Self::windows(device, n, 1) {
            let b = [(4, counts.as_entire_buffer_binding()), (10, w.of::<u32>(outcome, 1))];
            self.run_windows(
                device,
                queue,
                &self.outcome_counts,
                &Params { n: w.count as u32, ..Default::default() },
                &b,
                (w.count as u32).div_ceil(REDUCE_ITEMS),
            )?;
        }
        let c = read_back::<u32>(device, queue, &counts, 3)?;
        Ok([c[0], c[1], c[2]])
    }
}

impl vplgi_frame::Counted for GpuClustering {
    fn count(&self) -> u32 {
        self.k
    }
}

impl vplgi_frame::stages::Cluster for GpuBackend<'_> {
    fn cluster(&self, points: &GpuPoints, params: &ClusterParams, start: ClusterStart<'_>) -> Result<(GpuClustering, ClusterCounts), GpuError> {
        let k = &self.kernels.cluster;
        let c = k.cluster_from(self.device, self.queue, (&points.buffer, points.count), params, start)?;
        let [_, widened, incompatible] = k.outcome_counts(self.device, self.queue, &c.outcome, points.count)?;
        let counts = ClusterCounts { widened: widened + incompatible, kept: c.kept, fresh: c.fresh };
        Ok((c, counts))
    }

    fn cluster_centres(&self, c: &GpuClustering, points: &GpuPoints, metric: Metric) -> Result<Vec<Centre>, GpuError> {
        self.kernels.cluster.centres(self.device, self.queue, c, (&points.buffer, points.count), metric)
    }

    fn representatives(&self, c: &GpuClustering, points: &GpuPoints) -> Result<GpuPoints, GpuError> {
        let rows = storage_zeroed::<Endpoint>(self.device, "cluster rows", c.k as usize);
        self.kernels.cluster.gather(self.device, self.queue, &rows, (&c.representatives, c.k), (&points.buffer, points.count))?;
        Ok(GpuPoints { buffer: rows, count: c.k })
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "cluster_assign.wgsl" "Params" { origin, dims, fix_min, fix_ext, n, k, f, threshold, fuzzy, cells, first, window, alpha, representative, metric }
        });
    }
}
