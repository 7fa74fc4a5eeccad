//! VPL clustering in reflective-shadow-map space on the GPU (`shaders/rsm_cluster.wgsl`), the
//! twin of `vplgi_cpu::rsm_cluster::rsm_cluster`: the same seeds (warped through the same
//! integer weights of the importance map when given), the same Eq. 1 search over the
//! 5 × 5 cells around each VPL, a stable radix sort of the VPLs by cluster (one bit per pass,
//! each a scan), and each cluster's update summed over its contiguous members in the CPU's
//! order. Two read-backs: each map's first VPL (to share K among the maps on the host) and the
//! number of clusters kept.

use crate::buffers::{dispatch_bound, kernel_params, read_back, read_word, storage, storage_zeroed};
use crate::cluster::GpuClustering;
use crate::context::validated;
use crate::scan::ScanKernel;
use crate::shader::pipelines;
use crate::trace_vpls::GpuVpls;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_frame::RsmStart;
use vplgi_shared::rsm::{self, RsmCentre, RsmClusterParams, RsmLight};
use vplgi_shared::rsm_importance;
use vplgi_types::Endpoint;
use crate::backend::GpuBackend;
use vplgi_frame::ClusterCounts;

#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) n: u32,
    pub(crate) maps: u32,
    pub(crate) k: u32,
    pub(crate) bit: u32,
    pub(crate) w_position: f32,
    pub(crate) w_normal: f32,
    pub(crate) w_flux: f32,
    pub(crate) inv_extent: f32,
    pub(crate) importance: u32,
    pub(crate) rows: u32,
    /// `update` and `representatives`: the members [first, first + chunk) of each cluster.
    pub(crate) first: u32,
    pub(crate) chunk: u32,
}

/// Members of one cluster that one `update` or `representatives` dispatch reads: lavapipe ends an
/// invocation's loops after 65,535 iterations, and a cluster may hold every VPL.
const MEMBERS_PER_DISPATCH: u32 = 32_768;

/// `MapInfo` of `rsm_cluster.wgsl`: one map's VPLs, clusters and grid cells.
#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct MapInfo {
    pub(crate) vpl_start: u32,
    pub(crate) vpl_end: u32,
    pub(crate) cluster_first: u32,
    pub(crate) k: u32,
    pub(crate) grid: u32,
    pub(crate) cell_first: u32,
    pub(crate) row_first: u32,
    pub(crate) pad: u32,
}

/// A clustering on the device and what a next frame starts from.
pub struct GpuRsmClusters {
    pub clustering: GpuClustering,
    /// Clusters kept (non-empty).
    pub k: u32,
    /// With `start.carry`: the live clusters' states after the last update (empty otherwise).
    pub centres: Vec<RsmCentre>,
    /// Slots started from the previous frame's clusters, and slots seeded.
    pub kept: u32,
    pub fresh: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = RsmClusterKernel;

pub struct RsmClusterKernel {
    map_starts: wgpu::ComputePipeline,
    importance_max: wgpu::ComputePipeline,
    importance_rows: wgpu::ComputePipeline,
    importance_cumulate: wgpu::ComputePipeline,
    importance_cap: wgpu::ComputePipeline,
    seed: wgpu::ComputePipeline,
    grid_count: wgpu::ComputePipeline,
    grid_fill: wgpu::ComputePipeline,
    assign: wgpu::ComputePipeline,
    radix_flags: wgpu::ComputePipeline,
    radix_scatter: wgpu::ComputePipeline,
    ranges: wgpu::ComputePipeline,
    update: wgpu::ComputePipeline,
    representatives: wgpu::ComputePipeline,
    compact_clusters: wgpu::ComputePipeline,
    compact_labels: wgpu::ComputePipeline,
    scan: ScanKernel,
}

impl RsmClusterKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        let scan = ScanKernel::new(device)?;
        validated(device, "rsm_cluster pipelines", || {
            let names = [
                "map_starts",
                "importance_max",
                "importance_rows",
                "importance_cumulate",
                "importance_cap",
                "seed",
                "grid_count",
                "grid_fill",
                "assign",
                "radix_flags",
                "radix_scatter",
                "cluster_ranges",
                "update",
                "representatives",
                "compact_clusters",
                "compact_labels",
            ];
            let mut p = pipelines(device, "rsm_cluster.wgsl", &names).into_iter();
            let mut next = || p.next().expect("one pipeline per entry point");
            RsmClusterKernel {
                map_starts: next(),
                importance_max: next(),
                importance_rows: next(),
                importance_cumulate: next(),
                importance_cap: next(),
                seed: next(),
                grid_count: next(),
                grid_fill: next(),
                assign: next(),
                radix_flags: next(),
                radix_scatter: next(),
                ranges: next(),
                update: next(),
                representatives: next(),
                compact_clusters: next(),
                compact_labels: next(),
                scan,
            }
        })
    }

    /// Clusters the VPLs of `vpls` (made by `rsm_vpls` from `maps`, in texel order), seeded
    /// through `start.importance` (`rsm_importance`, one value per texel) if given, the previous
    /// frame's live clusters `start.previous` keeping their slots.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vpls: &GpuVpls,
        maps: &[RsmLight],
        p: &RsmClusterParams,
        start: RsmStart<'_, wgpu::Buffer>,
    ) -> Result<GpuRsmClusters, GpuError> {
        let n = vpls.count;
        let importance = start.importance;
        let empty = || GpuClustering {
            centroids: storage_zeroed::<Endpoint>(device, "rsm centroids", 1),
            k: 0,
            f: 1,
            labels: storage_zeroed::<u32>(device, "rsm labels", n.max(1) as usize),
            weights: storage(device, "rsm weights", &vec![1.0f32; n.max(1) as usize]),
            representatives: storage_zeroed::<u32>(device, "rsm representatives", 1),
            outcome: storage_zeroed::<u32>(device, "rsm outcome", n.max(1) as usize),
            kept: 0,
            fresh: 0,
        };
        let none = |clustering| GpuRsmClusters { clustering, k: 0, centres: Vec::new(), kept: 0, fresh: 0 };
        if n == 0 || p.k == 0 || maps.is_empty() {
            return Ok(none(empty()));
        }
        let m = maps.len() as u32;
        let groups = |count: u32| count.div_ceil(64);
        let mut params = Params {
            n,
            maps: m,
            k: 0,
            bit: 0,
            w_position: p.weights.position,
            w_normal: p.weights.normal,
            w_flux: p.weights.flux,
            inv_extent: 1.0 / p.extent.max(f32::MIN_POSITIVE),
            importance: importance.is_some() as u32,
            rows: maps.iter().map(|m| m.size).sum(),
            first: 0,
            chunk: MEMBERS_PER_DISPATCH,
        };
        let map_buf = storage(device, "rsm maps", maps);
        let vb = &vpls.buffer;

        // Each map's VPLs, then K shared among the maps and their grids, on the host.
        let starts = storage_zeroed::<u32>(device, "rsm map starts", m as usize + 1);
        validated(device, "rsm_cluster map_starts", || {
            let pb = kernel_params(device, "rsm params", &params);
            dispatch_bound(device, queue, &self.map_starts, &[(0, &pb), (1, &map_buf), (3, vb), (13, &starts)], groups(m + 1));
        })?;
        let starts: Vec<u32> = read_back(device, queue, &starts, m as usize + 1)?;
        let per_map = rsm::clusters_per_map(&starts.windows(2).map(|w| w[1] - w[0]).collect::<Vec<u32>>(), p.k);
        let (mut info, mut k, mut cells, mut rows) = (Vec::with_capacity(m as usize), 0u32, 0u32, 0u32);
        for (i, &km) in per_map.iter().enumerate() {
            let grid = ((km as f64).sqrt().ceil() as u32).max(1);
            info.push(MapInfo { vpl_start: starts[i], vpl_end: starts[i + 1], cluster_first: k, k: km, grid, cell_first: cells, row_first: rows, pad: 0 });
            k += km;
            cells += grid * grid;
            rows += maps[i].size;
        }
        if k == 0 {
            return Ok(none(empty()));
        }
        params.k = k;
        // The previous frame's live clusters fill each map's first slots; the seed kernel leaves
        // those (live = 1) and seeds the rest.
        let warm = rsm::warm_slots(start.previous.unwrap_or(&[]), &per_map);
        let (mut initial, mut live) = (vec![RsmCentre::default(); k as usize], vec![0u32; k as usize]);
        for (info, slots) in info.iter().zip(&warm) {
            for (s, c) in slots.iter().enumerate() {
                initial[info.cluster_first as usize + s] = *c;
                live[info.cluster_first as usize + s] = 1;
            }
        }
        let kept_slots = warm.iter().map(|w| w.len() as u32).sum::<u32>();
        let info = storage(device, "rsm map info", &info);
        let states = storage(device, "rsm cluster states", &initial);
        let live = storage(device, "rsm live slots", &live);
        let counts = storage_zeroed::<u32>(device, "rsm counts", cells.max(k) as usize + 1);
        let offsets = storage_zeroed::<u32>(device, "rsm offsets", n.max(cells).max(k) as usize + 1);
        let labels = storage_zeroed::<u32>(device, "rsm labels", n as usize);
        let identity: Vec<u32> = (0..n).collect();
        let identity = storage(device, "rsm identity", &identity);
        let sorted = [storage_zeroed::<u32>(device, "rsm order a", n.max(k) as usize), storage_zeroed::<u32>(device, "rsm order b", n.max(k) as usize)];
        let flags = storage_zeroed::<u32>(device, "rsm flags", n.max(k) as usize);
        let ranges = storage_zeroed::<[u32; 2]>(device, "rsm ranges", k as usize);
        let reps = storage_zeroed::<u32>(device, "rsm representatives", k as usize);
        let running = storage_zeroed::<[f32; 4]>(device, "rsm running sums", 3 * k as usize);
        let pb = kernel_params(device, "rsm params", &params);
        // The params of each range of members `update` and `representatives` read: every cluster
        // has at most n members.
        let ranges_of_members: Vec<wgpu::Buffer> = (0..n.div_ceil(MEMBERS_PER_DISPATCH))
            .map(|i| kernel_params(device, "rsm member range params", &Params { first: i * MEMBERS_PER_DISPATCH, ..params }))
            .collect();
        let zero = |b: &wgpu::Buffer| queue.write_buffer(b, 0, &vec![0u8; b.size() as usize]);

        // Each map's importance as integer weights summed by rows (Alg. 1 lines 5-7), then the
        // seeds. Without a map, one-word stand-ins keep the seed kernel's bindings filled.
        let map_max = storage_zeroed::<u32>(device, "rsm importance max", m as usize);
        let map_cap = storage(device, "rsm importance cap", &vec![u32::MAX; m as usize]);
        let row_sums = storage_zeroed::<u32>(device, "rsm importance rows", if importance.is_some() { rows as usize } else { 1 });
        let none = storage_zeroed::<f32>(device, "rsm no importance", 1);
        let imp = importance.unwrap_or(&none);
        validated(device, "rsm_cluster seed", || {
            if importance.is_some() {
                dispatch_bound(device, queue, &self.importance_max, &[(0, &pb), (2, &info), (3, vb), (16, imp), (17, &map_max)], groups(n));
                let row_pass = || {
                    let b = [(0, &pb), (1, &map_buf), (2, &info), (16, imp), (17, &map_max), (18, &row_sums), (20, &map_cap)];
                    dispatch_bound(device, queue, &self.importance_rows, &b, groups(rows));
                    dispatch_bound(device, queue, &self.importance_cumulate, &[(0, &pb), (1, &map_buf), (2, &info), (18, &row_sums)], groups(m));
                };
                for _ in 0..rsm_importance::CAP_PASSES {
                    row_pass();
                    dispatch_bound(device, queue, &self.importance_cap, &[(0, &pb), (1, &map_buf), (2, &info), (18, &row_sums), (20, &map_cap)], groups(m));
                }
                row_pass();
            }
            dispatch_bound(
                device,
                queue,
                &self.seed,
                &[(0, &pb), (1, &map_buf), (2, &info), (3, vb), (4, &states), (16, imp), (17, &map_max), (18, &row_sums), (19, &live), (20, &map_cap)],
                groups(k),
            );
        })?;
        let bits = 32 - (k - 1).leading_zeros();
        let mut sorted_at = 0usize;
        for _ in 0..=p.iterations {
            // The grid: clusters per cell, their offsets, then the cells' items.
            zero(&counts);
            validated(device, "rsm_cluster grid_count", || {
                dispatch_bound(device, queue, &self.grid_count, &[(0, &pb), (1, &map_buf), (2, &info), (4, &states), (5, &counts)], groups(k));
            })?;
            self.scan.run(device, queue, &counts, cells, &offsets)?;
            zero(&counts);
            validated(device, "rsm_cluster grid_fill + assign", || {
                let cell_items = &sorted[1];
                dispatch_bound(
                    device,
                    queue,
                    &self.grid_fill,
                    &[(0, &pb), (1, &map_buf), (2, &info), (4, &states), (5, &counts), (6, &offsets), (7, cell_items)],
                    groups(k),
                );
                dispatch_bound(
                    device,
                    queue,
                    &self.assign,
                    &[(0, &pb), (1, &map_buf), (2, &info), (3, vb), (4, &states), (6, &offsets), (7, cell_items), (8, &labels)],
                    groups(n),
                );
            })?;
            // Stable radix sort of the VPL indices by label, from the identity.
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("rsm order") });
            encoder.copy_buffer_to_buffer(&identity, 0, &sorted[0], 0, n as u64 * 4);
            queue.submit([encoder.finish()]);
            sorted_at = 0;
            for bit in 0..bits {
                let pass = kernel_params(device, "rsm radix params", &Params { bit, ..params });
                let (from, to) = (&sorted[sorted_at], &sorted[1 - sorted_at]);
                validated(device, "rsm_cluster radix flags", || {
                    dispatch_bound(device, queue, &self.radix_flags, &[(0, &pass), (8, &labels), (9, from), (10, &flags)], groups(n));
                })?;
                self.scan.run(device, queue, &flags, n, &offsets)?;
                validated(device, "rsm_cluster radix scatter", || {
                    dispatch_bound(device, queue, &self.radix_scatter, &[(0, &pass), (6, &offsets), (7, to), (9, from), (10, &flags)], groups(n));
                })?;
                sorted_at = 1 - sorted_at;
            }
            let order = &sorted[sorted_at];
            zero(&ranges);
            validated(device, "rsm_cluster ranges + update", || {
                dispatch_bound(device, queue, &self.ranges, &[(0, &pb), (8, &labels), (9, order), (11, &ranges)], groups(n));
                for range in &ranges_of_members {
                    dispatch_bound(
                        device,
                        queue,
                        &self.update,
                        &[(0, range), (1, &map_buf), (3, vb), (4, &states), (9, order), (11, &ranges), (21, &running)],
                        groups(k),
                    );
                }
            })?;
        }

        // The states a next frame starts from: those of clusters with members, map by map.
        let centres = if start.carry {
            let states: Vec<RsmCentre> = read_back(device, queue, &states, k as usize)?;
            let runs: Vec<[u32; 2]> = read_back(device, queue, &ranges, k as usize)?;
            states.into_iter().zip(runs).filter(|(_, r)| r[1] > r[0]).map(|(s, _)| s).collect()
        } else {
            Vec::new()
        };
        // Representatives, then the kept clusters renumbered.
        let order = &sorted[sorted_at];
        validated(device, "rsm_cluster representatives", || {
            for range in &ranges_of_members {
                dispatch_bound(
                    device,
                    queue,
                    &self.representatives,
                    &[(0, range), (3, vb), (4, &states), (9, order), (10, &flags), (11, &ranges), (12, &reps), (21, &running)],
                    groups(k),
                );
            }
        })?;
        self.scan.run(device, queue, &flags, k, &offsets)?;
        let kept = read_word(device, queue, &offsets, k as u64)?;
        let centroids = storage_zeroed::<Endpoint>(device, "rsm centroids", kept.max(1) as usize);
        let kept_reps = storage_zeroed::<u32>(device, "rsm kept representatives", kept.max(1) as usize);
        validated(device, "rsm_cluster compact", || {
            dispatch_bound(
                device,
                queue,
                &self.compact_clusters,
                &[(0, &pb), (4, &states), (6, &offsets), (10, &flags), (12, &reps), (14, &centroids), (15, &kept_reps)],
                groups(k),
            );
            dispatch_bound(device, queue, &self.compact_labels, &[(0, &pb), (6, &offsets), (8, &labels)], groups(n));
        })?;
        let clustering = GpuClustering {
            centroids,
            k: kept,
            f: 1,
            labels,
            weights: storage(device, "rsm weights", &vec![1.0f32; n as usize]),
            representatives: kept_reps,
            outcome: storage_zeroed::<u32>(device, "rsm outcome", n as usize),
            kept: 0,
            fresh: 0,
        };
        Ok(GpuRsmClusters { clustering, k: kept, centres, kept: kept_slots, fresh: k - kept_slots })
    }
}

impl vplgi_frame::stages::RsmCluster for GpuBackend<'_> {
    fn rsm_cluster(
        &self,
        vpls: &GpuVpls,
        rsm_size: u32,
        params: &RsmClusterParams,
        start: RsmStart<'_, wgpu::Buffer>,
    ) -> Result<(GpuClustering, ClusterCounts, Vec<RsmCentre>), GpuError> {
        let r = self.kernels.rsm_cluster.run(self.device, self.queue, vpls, &self.scene.sampler.rsm_maps(rsm_size), params, start)?;
        Ok((r.clustering, ClusterCounts { kept: r.kept, fresh: r.fresh, ..Default::default() }, r.centres))
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "rsm_cluster.wgsl" "Params" { n, maps, k, bit, w_position, w_normal, w_flux, inv_extent, importance, rows, first, chunk }
            [super::MapInfo] "rsm_cluster.wgsl" "MapInfo" { vpl_start, vpl_end, cluster_first, k, grid, cell_first, row_first }
        });
    }
}
