//! Stage 2 on the GPU, `shading_points` (`shaders/shading_points.wgsl`), the twin of
//! `vplgi_cpu::shading_points::shading_points`.

use crate::buffers::{dispatch_windows, kernel_params, read_back, storage_zeroed};
use crate::context::validated;
use crate::scene::GpuScene;
use crate::shader::RayPipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::{CameraParams, ShadingPoint};
use crate::backend::GpuBackend;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) cam_pos: [f32; 4],
    pub(crate) cam_forward: [f32; 4],
    pub(crate) cam_up: [f32; 4],
    pub(crate) cam_right: [f32; 4],
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) spp: u32,
    pub(crate) seed: u32,
    pub(crate) first: u32,
    pub(crate) count: u32,
    pub(crate) specular_depth: u32,
    pub(crate) eps: f32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = ShadingPointsKernel;

pub struct ShadingPointsKernel {
    pipeline: RayPipeline,
}

impl ShadingPointsKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "shading_points pipeline", || ShadingPointsKernel { pipeline: RayPipeline::new(device, "shading_points.wgsl", "main") })
    }

    /// Shading points of camera samples `samples` into a new device buffer.
    pub fn dispatch_range(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        camera: &CameraParams,
        samples: std::ops::Range<u32>,
    ) -> Result<wgpu::Buffer, GpuError> {
        let CameraParams { camera: cam, width, height, spp, seed, specular_depth } = *camera;
        let (first, count) = (samples.start, samples.end - samples.start);
        let right = cam.forward.cross(cam.up).normalize();
        let v4 = |v: glam::Vec3, w: f32| [v.x, v.y, v.z, w];
        let params = Params {
            cam_pos: v4(cam.position, 0.0),
            cam_forward: v4(cam.forward, 0.0),
            cam_up: v4(cam.up, 0.0),
            cam_right: v4(right, (0.5 * cam.yfov).tan()),
            width,
            height,
            spp,
            seed,
            first,
            count,
            specular_depth,
            eps: scene.eps,
        };
        validated(device, "shading_points", || {
            let p = kernel_params(device, "shading_points params", &params);
            let buf = storage_zeroed::<ShadingPoint>(device, "shading points", count as usize);
            let mut bindings = vec![(0, p.as_entire_buffer_binding()), (7, buf.as_entire_buffer_binding())];
            bindings.extend(self.pipeline.scene_bindings(scene));
            dispatch_windows(device, queue, self.pipeline.get(device, scene), &bindings, count.div_ceil(64));
            buf
        })
    }

    /// All `width * height * spp` shading points, read back. Output is produced in chunks of at
    /// most `max_binding_bytes` (the adapter's storage-binding limit unless a test forces less).
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        camera: &CameraParams,
        max_binding_bytes: Option<u64>,
    ) -> Result<Vec<ShadingPoint>, GpuError> {
        let total = camera.width * camera.height * camera.spp;
        let limit = max_binding_bytes.unwrap_or(device.limits().max_storage_buffer_binding_size);
        let per_chunk = (limit / std::mem::size_of::<ShadingPoint>() as u64).clamp(1, u32::MAX as u64) as u32;
        let mut out = Vec::with_capacity(total as usize);
        let mut first = 0u32;
        while first < total {
            let count = (total - first).min(per_chunk);
            let buf = self.dispatch_range(device, queue, scene, camera, first..first + count)?;
            out.extend(read_back::<ShadingPoint>(device, queue, &buf, count as usize)?);
            first += count;
        }
        Ok(out)
    }
}

impl vplgi_frame::stages::ShadingPoints for GpuBackend<'_> {
    fn shading_points(&self, p: &CameraParams, samples: std::ops::Range<u32>) -> Result<wgpu::Buffer, GpuError> {
        self.kernels.shading_points.dispatch_range(self.device, self.queue, &self.scene, p, samples)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "shading_points.wgsl" "Params" { cam_pos, cam_forward, cam_up, cam_right, width, height, spp, seed, first, count, specular_depth, eps }
        });
    }
}
