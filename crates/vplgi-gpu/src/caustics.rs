//! Stage `caustics` on the GPU (`shaders/caustics.wgsl`), the twin of
//! `vplgi_cpu::caustics::caustics`: each sample's k nearest caustic photons in the kd-tree the
//! host built (`vplgi_shared::photon_tree`), walked node for node as the CPU walks it. The map is
//! read back once to build the tree, as the BVH is built on the host; the per-sample radiance is
//! read back and averaged per pixel in the CPU's order.

use crate::backend::GpuBackend;
use crate::buffers::{dispatch_bound, kernel_params, read_back, storage, storage_zeroed};
use crate::context::validated;
use crate::shader::pipelines;
use crate::trace_vpls::GpuVpls;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use vplgi_types::{CausticParams, PhotonNode, Vpl};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) count: u32,
    pub(crate) k: u32,
    pub(crate) max_bounce: u32,
    pub(crate) max_r2: f32,
}

/// A photon map on the device: photons in tree order and the tree's nodes.
pub struct GpuPhotonMap {
    pub photons: wgpu::Buffer,
    pub nodes: wgpu::Buffer,
    pub count: u32,
    /// Nodes of the tree.
    pub nodes_count: u32,
}

impl vplgi_frame::Counted for GpuPhotonMap {
    fn count(&self) -> u32 {
        self.count
    }
}

/// Shading points on the device: `count` [`vplgi_types::ShadingPoint`]s of `buffer`.
#[derive(Clone, Copy)]
pub struct Samples<'a> {
    pub buffer: &'a wgpu::Buffer,
    pub count: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = CausticsKernel;

pub struct CausticsKernel {
    pipeline: wgpu::ComputePipeline,
}

impl CausticsKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "caustics pipeline", || {
            let mut p = pipelines(device, "caustics.wgsl", &["main"]);
            CausticsKernel { pipeline: p.remove(0) }
        })
    }

    /// The map of `photons` (host order), uploaded in tree order with the tree.
    pub fn upload(&self, device: &wgpu::Device, photons: &[Vpl], nodes: &[PhotonNode]) -> GpuPhotonMap {
        GpuPhotonMap {
            photons: storage(device, "photon map", photons),
            nodes: storage(device, "photon tree", nodes),
            count: photons.len() as u32,
            nodes_count: nodes.len() as u32,
        }
    }

    /// Each of the shading points' caustic radiance (rgb) and whether its walk was truncated
    /// (w = 1); `lobes` is the scene's white BSDF per material (`GpuScene::lobes`).
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        map: &GpuPhotonMap,
        points: &Samples,
        lobes: &wgpu::Buffer,
        params: &CausticParams,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        let Samples { buffer: points, count } = *points;
        if count == 0 {
            return Ok(Vec::new());
        }
        let out = storage_zeroed::<[f32; 4]>(device, "caustic radiance", count as usize);
        let p = Params { count, k: params.k, max_bounce: params.max_bounce, max_r2: params.max_radius * params.max_radius };
        validated(device, "caustics", || {
            let pb = kernel_params(device, "caustics params", &p);
            let photons: &wgpu::Buffer = &map.photons;
            // An empty map still binds one (zero) photon; the kernel reads its count from `p`.
            let bound = [(0, &pb), (1, photons), (2, &map.nodes), (3, points), (4, lobes), (5, &out)];
            dispatch_bound(device, queue, &self.pipeline, &bound, count.div_ceil(64));
        })?;
        read_back::<[f32; 4]>(device, queue, &out, count as usize)
    }
}

impl vplgi_frame::stages::Caustics for GpuBackend<'_> {
    fn photon_map(&self, photons: &GpuVpls, leaf: u32) -> Result<GpuPhotonMap, GpuError> {
        let host = read_back::<Vpl>(self.device, self.queue, &photons.buffer, photons.count as usize)?;
        let (ordered, nodes) = vplgi_shared::photon_tree::ordered(&host, leaf);
        Ok(self.kernels.caustics.upload(self.device, &ordered, &nodes))
    }

    fn caustics(
        &self,
        map: &GpuPhotonMap,
        points: &wgpu::Buffer,
        samples: Range<u32>,
        params: &CausticParams,
    ) -> Result<(Vec<[f32; 3]>, u32), GpuError> {
        let count = samples.end - samples.start;
        let points = Samples { buffer: points, count };
        let per_sample = self.kernels.caustics.run(self.device, self.queue, map, &points, &self.scene.lobes, params)?;
        Ok(pixel_means(&per_sample, params.spp))
    }
}

/// Each pixel's mean of its `spp` samples' radiance, summed in sample order as the CPU sums, and
/// the truncated walks.
pub fn pixel_means(per_sample: &[[f32; 4]], spp: u32) -> (Vec<[f32; 3]>, u32) {
    let spp = spp.max(1) as usize;
    let mut truncated = 0;
    let pixels = per_sample
        .chunks(spp)
        .map(|pixel| {
            let mut sum = Vec3::ZERO;
            for s in pixel {
                sum += Vec3::new(s[0], s[1], s[2]);
                truncated += (s[3] != 0.0) as u32;
            }
            (sum / spp as f32).to_array()
        })
        .collect();
    (pixels, truncated)
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "caustics.wgsl" "Params" { count, k, max_bounce, max_r2 }
        });
    }
}
