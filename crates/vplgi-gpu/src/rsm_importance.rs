//! The bidirectional importance map of the RSM clustering on the GPU, `rsm_importance`
//! (`shaders/rsm_importance.wgsl`), the twin of `vplgi_cpu::rsm_importance`: the G-buffer points
//! of the listed camera samples gathered on the device, then each VPL's texel weighted by its
//! geometry terms toward them, summed in the CPU's order. No read-back.

use crate::buffers::{dispatch_bound, kernel_params, storage, storage_zeroed};
use crate::context::validated;
use crate::shader::pipelines;
use crate::trace_vpls::GpuVpls;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_types::Endpoint;
use crate::backend::{GpuBackend, GpuHits};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) n: u32,
    pub(crate) count: u32,
    pub(crate) d_min2: f32,
    pub(crate) pad: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = RsmImportanceKernel;

pub struct RsmImportanceKernel {
    points: wgpu::ComputePipeline,
    texels: wgpu::ComputePipeline,
}

impl RsmImportanceKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "rsm_importance pipelines", || {
            let mut p = pipelines(device, "rsm_importance.wgsl", &["importance_points", "importance_of_texels"]).into_iter();
            let mut next = || p.next().expect("one pipeline per entry point");
            RsmImportanceKernel { points: next(), texels: next() }
        })
    }

    /// The G-buffer points of camera samples `samples`: hit `offsets[s]` of `hit_points` where
    /// sample s hit (`offsets`: the hits before each sample, one more than the samples), a point
    /// with a zero normal (which adds no importance) where it missed.
    pub fn gbuffer_points(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        samples: &[u32],
        offsets: &wgpu::Buffer,
        hit_points: &wgpu::Buffer,
    ) -> Result<wgpu::Buffer, GpuError> {
        let count = samples.len() as u32;
        let points = storage_zeroed::<Endpoint>(device, "importance points", samples.len());
        if count == 0 {
            return Ok(points);
        }
        let list = storage(device, "importance samples", samples);
        let pb = kernel_params(device, "importance params", &Params { n: 0, count, d_min2: 0.0, pad: 0 });
        validated(device, "rsm_importance points", || {
            dispatch_bound(device, queue, &self.points, &[(0, &pb), (2, &list), (3, offsets), (4, hit_points), (5, &points)], count.div_ceil(64));
        })?;
        Ok(points)
    }

    /// The importance of every texel of `maps` (0 where no VPL is) for the VPLs of `vpls`, seen
    /// from the `count` G-buffer points `points`, distances floored at `d_min`.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vpls: &GpuVpls,
        maps: &[RsmLight],
        (points, count): (&wgpu::Buffer, u32),
        d_min: f32,
    ) -> Result<wgpu::Buffer, GpuError> {
        let n = vpls.count;
        let importance = storage_zeroed::<f32>(device, "rsm importance", rsm::texel_count(maps) as usize);
        if n == 0 {
            return Ok(importance);
        }
        let pb = kernel_params(device, "importance params", &Params { n, count, d_min2: d_min * d_min, pad: 0 });
        validated(device, "rsm_importance texels", || {
            dispatch_bound(device, queue, &self.texels, &[(0, &pb), (1, &vpls.buffer), (5, points), (6, &importance)], n.div_ceil(64));
        })?;
        Ok(importance)
    }
}

impl vplgi_frame::stages::RsmImportance for GpuBackend<'_> {
    fn rsm_importance(&self, vpls: &GpuVpls, rsm_size: u32, hits: &GpuHits, samples: &[u32], d_min: f32) -> Result<wgpu::Buffer, GpuError> {
        let k = &self.kernels.rsm_importance;
        let points = k.gbuffer_points(self.device, self.queue, samples, &hits.offsets, &hits.points.buffer)?;
        k.run(self.device, self.queue, vpls, &self.scene.sampler.rsm_maps(rsm_size), (&points, samples.len() as u32), d_min)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "rsm_importance.wgsl" "Params" { n, count, d_min2 }
        });
    }
}
