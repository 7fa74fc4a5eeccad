//! Stage 3's first step with `--seeding adaptive` on the GPU, `seeding` (`shaders/seeding.wgsl`),
//! the twin of `vplgi_cpu::seeding::seeding`: the quadtree's counts and fixed-point sums level
//! by level from the pixels up, every node's Eq. 2 variation in one pass over the pixels, then
//! the seeds handed down level by level. The K seed slots are read back and their unused slots
//! dropped on the host, where the clustering's other host-side choices are made too.

use crate::buffers::{dispatch_bound, kernel_params, read_back, storage, storage_zeroed};
use crate::cluster::ClusterKernel;
use crate::context::validated;
use crate::shader::pipelines;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::clustering::FixedPoint;
use vplgi_shared::seeding::{Quadtree, SeedParams};
use vplgi_types::MISS;
use crate::backend::{GpuBackend, GpuHits};
use vplgi_types::CameraParams;

#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) fix_min: [f32; 4],
    pub(crate) fix_ext: [f32; 4],
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) spp: u32,
    pub(crate) levels: u32,
    pub(crate) level: u32,
    pub(crate) side: u32,
    pub(crate) level_first: u32,
    pub(crate) seed: u32,
    pub(crate) alpha: f32,
    pub(crate) pad: [u32; 3],
}

/// The hits of an image on the device: `points` (Endpoints, numbered in sample order) and
/// `offsets`, the hits before each camera sample (`spp` per pixel, one entry past the last).
pub struct GpuImageHits<'a> {
    pub points: &'a wgpu::Buffer,
    pub count: u32,
    pub offsets: &'a wgpu::Buffer,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = SeedingKernel;

pub struct SeedingKernel {
    node_sums: wgpu::ComputePipeline,
    node_variation: wgpu::ComputePipeline,
    distribute: wgpu::ComputePipeline,
}

impl SeedingKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "seeding pipelines", || {
            let mut p = pipelines(device, "seeding.wgsl", &["node_sums", "node_variation", "distribute"]).into_iter();
            let mut next = || p.next().expect("one pipeline per entry point");
            SeedingKernel { node_sums: next(), node_variation: next(), distribute: next() }
        })
    }

    /// The adaptive seeds of `hits`: at most `params.k` hit indices, in quadtree order.
    /// `cluster` measures the hits' bounding box, as the clustering does.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        cluster: &ClusterKernel,
        hits: &GpuImageHits,
        params: &SeedParams,
    ) -> Result<Vec<u32>, GpuError> {
        if hits.count == 0 || params.k == 0 {
            return Ok(Vec::new());
        }
        let q = Quadtree::new(hits.width, hits.height);
        let (lo, hi) = cluster.bounds(device, queue, hits.points, hits.count)?;
        let fix = FixedPoint::new(lo, hi);
        let nodes = q.nodes() as usize;
        let counts = storage_zeroed::<u32>(device, "seeding counts", nodes);
        let sums = storage_zeroed::<u32>(device, "seeding sums", nodes * 12);
        let variation = storage_zeroed::<u32>(device, "seeding variation", nodes * 2);
        let total = params.k.min(hits.count);
        let mut given = vec![0u32; nodes * 2];
        given[q.node(q.levels, 0, 0) as usize * 2] = total;
        let given = storage(device, "seeding given", &given);
        let slots = storage(device, "seeding slots", &vec![MISS; total as usize]);
        let base = Params {
            fix_min: [fix.min.x, fix.min.y, fix.min.z, 0.0],
            fix_ext: [fix.ext.x, fix.ext.y, fix.ext.z, 0.0],
            width: hits.width,
            height: hits.height,
            spp: hits.spp,
            levels: q.levels,
            seed: params.seed,
            alpha: params.alpha,
            ..Default::default()
        };
        let at_level = |l: u32| Params { level: l, side: q.side(l), level_first: q.level_offset(l), ..base };
        let run = |name: &str, pipeline: &wgpu::ComputePipeline, p: Params, bound: &[(u32, &wgpu::Buffer)], threads: u32| {
            validated(device, name, || {
                let pb = kernel_params(device, "seeding params", &p);
                let mut all = vec![(0, &pb)];
                all.extend_from_slice(bound);
                dispatch_bound(device, queue, pipeline, &all, threads.div_ceil(64).max(1));
            })
        };
        for l in 1..=q.levels {
            let side = q.side(l);
            run("seeding node_sums", &self.node_sums, at_level(l), &[(1, hits.points), (2, hits.offsets), (3, &counts), (4, &sums)], side * side)?;
        }
        let pixels = hits.width * hits.height;
        run("seeding node_variation", &self.node_variation, base, &[(1, hits.points), (2, hits.offsets), (3, &counts), (4, &sums), (5, &variation)], pixels)?;
        for l in (1..=q.levels).rev() {
            let side = q.side(l);
            let bound = [(2, hits.offsets), (3, &counts), (5, &variation), (6, &given), (7, &slots)];
            run("seeding distribute", &self.distribute, at_level(l), &bound, side * side)?;
        }
        let slots: Vec<u32> = read_back(device, queue, &slots, total as usize)?;
        Ok(slots.into_iter().filter(|&h| h != MISS).collect())
    }
}

impl vplgi_frame::stages::Seeding for GpuBackend<'_> {
    fn seeding(&self, hits: &GpuHits, camera: &CameraParams, params: &SeedParams) -> Result<Vec<u32>, GpuError> {
        let image = GpuImageHits {
            points: &hits.points.buffer,
            count: hits.points.count,
            offsets: &hits.offsets,
            width: camera.width,
            height: camera.height,
            spp: camera.spp,
        };
        self.kernels.seeding.run(self.device, self.queue, &self.kernels.cluster, &image, params)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "seeding.wgsl" "Params" { fix_min, fix_ext, width, height, spp, levels, level, side, level_first, seed, alpha }
        });
    }
}
