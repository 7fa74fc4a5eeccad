//! Stage `final_gather` on the GPU (`shaders/final_gather.wgsl`), the twin of
//! `vplgi_cpu::final_gather`: each sample point's gather rays, lit by the illumination cut, giving
//! its irradiance, 1 / R_j and the spherical harmonics of its incident light in one pass.

use crate::backend::{GpuBackend, GpuPoints};
use crate::buffers::{dispatch_windows, kernel_params, read_back, storage_zeroed};
use crate::context::validated;
// The same parameters as gather_radius' rays: final_gather.wgsl declares them alike.
use crate::gather_radius::Params;
use crate::illumination_cut::GpuCut;
use crate::interpolate::GpuIrradianceSamples;
use crate::scene::GpuScene;
use crate::shader::RayPipeline;
use crate::GpuError;
use vplgi_frame::GatherCounts;
use vplgi_shared::sh::ShRgb;
use vplgi_types::interpolation::GatherParams;

/// Gather rays one dispatch traces per point: each ray's traversal and its cut lookup (at most
/// `GATHER_VISITS` nodes) stay well inside lavapipe's 65,535 loop iterations per invocation.
pub const RAYS_PER_DISPATCH: u32 = 4;

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = FinalGatherKernel;

pub struct FinalGatherKernel {
    pipeline: RayPipeline,
}

/// A final gather's results on the device: the irradiance samples, and each point's counts of
/// gather hits no kernel reached and truncated lookups (`vec2<u32>`).
pub struct Gathered {
    pub samples: GpuIrradianceSamples,
    pub counts: wgpu::Buffer,
}

impl FinalGatherKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "final_gather pipeline", || FinalGatherKernel { pipeline: RayPipeline::new(device, "final_gather.wgsl", "main") })
    }

    /// The gather at the sample points `points`, lit by `cut`.
    pub fn run(&self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &GpuScene, points: GpuPoints, cut: &GpuCut, params: &GatherParams) -> Result<Gathered, GpuError> {
        let n = points.count;
        let (inv_radius, irradiance, sh, counts) = validated(device, "final_gather", || {
            let inv_radius = storage_zeroed::<f32>(device, "inverse radii", n.max(1) as usize);
            let irradiance = storage_zeroed::<[f32; 4]>(device, "gathered irradiance", n.max(1) as usize);
            let sh = storage_zeroed::<ShRgb>(device, "gathered harmonics", n.max(1) as usize);
            let counts = storage_zeroed::<[u32; 2]>(device, "gather counts", n.max(1) as usize);
            let mut first = 0;
            while first < params.rays && n > 0 {
                let end = params.rays.min(first + RAYS_PER_DISPATCH);
                let p = Params { count: n, seed: params.seed, rays: params.rays, ray_first: first, ray_end: end, eps: scene.eps, pad: [0; 2] };
                let pb = kernel_params(device, "final_gather params", &p);
                let own = [(0, &pb), (6, &points.buffer), (7, &inv_radius), (8, &irradiance), (9, &cut.nodes), (10, &cut.bounds), (11, &counts), (12, &cut.wide_bounds), (13, &sh)];
                let mut bindings: Vec<(u32, wgpu::BufferBinding)> = own.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
                bindings.extend(self.pipeline.scene_bindings(scene));
                dispatch_windows(device, queue, self.pipeline.get(device, scene), &bindings, n.div_ceil(64));
                first = end;
            }
            (inv_radius, irradiance, sh, counts)
        })?;
        Ok(Gathered { samples: GpuIrradianceSamples { points: points.buffer, inv_radius, irradiance, sh: Some(sh), count: n }, counts })
    }
}

impl vplgi_frame::stages::FinalGather for GpuBackend<'_> {
    fn final_gather(&self, points: GpuPoints, cut: &GpuCut, params: &GatherParams) -> Result<(GpuIrradianceSamples, GatherCounts), GpuError> {
        let n = points.count as usize;
        let g = self.kernels.final_gather.run(self.device, self.queue, &self.scene, points, cut, params)?;
        let counts = read_back::<[u32; 2]>(self.device, self.queue, &g.counts, n)?;
        let counts = GatherCounts {
            fallback: counts.iter().map(|c| c[0] as u64).sum(),
            truncated: counts.iter().map(|c| c[1] as u64).sum(),
        };
        Ok((g.samples, counts))
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [crate::gather_radius::Params] "final_gather.wgsl" "Params" { count, seed, rays, ray_first, ray_end, eps }
        });
    }
}
