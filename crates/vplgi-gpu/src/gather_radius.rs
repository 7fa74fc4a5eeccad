//! Stage `gather_radius` on the GPU (`shaders/gather_radius.wgsl`), the twin of
//! `vplgi_cpu::gather_radius::gather_radius`: 1 / R_j of each sample point from its gather rays.

use crate::buffers::{dispatch_windows, kernel_params, storage_zeroed};
use crate::context::validated;
use crate::scene::GpuScene;
use crate::shader::RayPipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::interpolation::GatherParams;
use crate::backend::{GpuBackend, GpuPoints};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) count: u32,
    pub(crate) seed: u32,
    pub(crate) rays: u32,
    pub(crate) ray_first: u32,
    pub(crate) ray_end: u32,
    pub(crate) eps: f32,
    pub(crate) pad: [u32; 2],
}

/// Gather rays one dispatch traces per point: with their traversal loops well inside lavapipe's
/// 65,535 iterations per invocation (see `shade::LOOP_BUDGET`) in scenes of millions of
/// triangles.
pub const RAYS_PER_DISPATCH: u32 = 8;

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = GatherRadiusKernel;

pub struct GatherRadiusKernel {
    pipeline: RayPipeline,
}

impl GatherRadiusKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "gather_radius pipeline", || GatherRadiusKernel { pipeline: RayPipeline::new(device, "gather_radius.wgsl", "main") })
    }

    /// 1 / R_j of each of the `n` sample points in `points` (Endpoints), as a new buffer of `n`
    /// f32 (at least one).
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        points: &wgpu::Buffer,
        n: u32,
        params: &GatherParams,
    ) -> Result<wgpu::Buffer, GpuError> {
        validated(device, "gather_radius", || {
            let out = storage_zeroed::<f32>(device, "inverse radii", n.max(1) as usize);
            let mut first = 0;
            while first < params.rays && n > 0 {
                let end = params.rays.min(first + RAYS_PER_DISPATCH);
                let p = Params { count: n, seed: params.seed, rays: params.rays, ray_first: first, ray_end: end, eps: scene.eps, pad: [0; 2] };
                let pb = kernel_params(device, "gather_radius params", &p);
                let mut bindings = vec![(0, pb.as_entire_buffer_binding()), (6, points.as_entire_buffer_binding()), (7, out.as_entire_buffer_binding())];
                bindings.extend(self.pipeline.scene_bindings(scene));
                dispatch_windows(device, queue, self.pipeline.get(device, scene), &bindings, n.div_ceil(64));
                first = end;
            }
            out
        })
    }
}

impl vplgi_frame::stages::GatherRadius for GpuBackend<'_> {
    fn gather_radius(&self, points: &GpuPoints, params: &GatherParams) -> Result<wgpu::Buffer, GpuError> {
        self.kernels.gather_radius.run(self.device, self.queue, &self.scene, &points.buffer, points.count, params)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "gather_radius.wgsl" "Params" { count, seed, rays, ray_first, ray_end, eps }
        });
    }
}
