//! Stage `bias_points` on the GPU (`shaders/bias_points.wgsl`), the twin of
//! `vplgi_cpu::bias_points::bias_points`: the clamp's bias compensation, one level.

use crate::buffers::{dispatch_windows, kernel_params, storage_zeroed};
use crate::context::validated;
use crate::scene::GpuScene;
use crate::shader::RayPipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::{BiasParams, ShadingPoint};
use crate::backend::GpuBackend;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) first: u32,
    pub(crate) count: u32,
    pub(crate) seed: u32,
    pub(crate) g_max: f32,
    pub(crate) eps: f32,
    pub(crate) pad: [u32; 3],
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = BiasPointsKernel;

pub struct BiasPointsKernel {
    pipeline: RayPipeline,
}

impl BiasPointsKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "bias_points pipeline", || BiasPointsKernel { pipeline: RayPipeline::new(device, "bias_points.wgsl", "main") })
    }

    /// The compensation points of the shading points `parents` (camera samples `samples`) into a
    /// new device buffer.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        parents: &wgpu::Buffer,
        samples: std::ops::Range<u32>,
        params: &BiasParams,
    ) -> Result<wgpu::Buffer, GpuError> {
        let (first, count) = (samples.start, samples.end - samples.start);
        // g_max = infinity is passed as is: G > infinity never holds, so every point misses.
        let p = Params { first, count, seed: params.seed, g_max: params.g_max, eps: scene.eps, pad: [0; 3] };
        validated(device, "bias_points", || {
            let pb = kernel_params(device, "bias_points params", &p);
            let out = storage_zeroed::<ShadingPoint>(device, "bias points", count as usize);
            let mut bindings = vec![(0, pb.as_entire_buffer_binding()), (6, parents.as_entire_buffer_binding()), (7, out.as_entire_buffer_binding())];
            bindings.extend(self.pipeline.scene_bindings(scene));
            dispatch_windows(device, queue, self.pipeline.get(device, scene), &bindings, count.div_ceil(64));
            out
        })
    }
}

impl vplgi_frame::stages::BiasPoints for GpuBackend<'_> {
    fn bias_points(&self, parent: &wgpu::Buffer, samples: std::ops::Range<u32>, params: &BiasParams) -> Result<wgpu::Buffer, GpuError> {
        self.kernels.bias_points.run(self.device, self.queue, &self.scene, parent, samples, params)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "bias_points.wgsl" "Params" { first, count, seed, g_max, eps }
        });
    }
}
