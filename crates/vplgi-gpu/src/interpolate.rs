//! Stage `interpolate` on the GPU (`shaders/interpolate.wgsl`), the twin of
//! `vplgi_cpu::interpolate`: the irradiance samples at the shading-point clusters'
//! representatives (summed by `shade.wgsl`'s `shade_lights`, each sample point on its own
//! visibility row), then per shading point the interpolation of its F clusters' samples.

use crate::buffers::{dispatch_windows, kernel_params, storage_zeroed, Window};
use crate::context::validated;
use crate::shade::{ShadeInputs, ShadeKernel, Visibility};
use crate::shader::pipelines;
use crate::timing::in_kernel;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use std::ops::Range;
use vplgi_shared::sh::ShRgb;
use vplgi_types::ShadingPoint;
use crate::backend::{GpuBackend, GpuPoints};
use crate::shade::VplLightSet;
use crate::visibility::words_per_row;

#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) count: u32,
    pub(crate) first_sample: u32,
    pub(crate) sp_first: u32,
    pub(crate) f: u32,
    pub(crate) first_row: u32,
    /// 1 where the samples carry spherical harmonics.
    pub(crate) sh: u32,
    pub(crate) pad: [u32; 2],
}

/// The sample points of a frame on the device (the twin of
/// `vplgi_cpu::interpolate::IrradianceSamples`): Endpoints, 1 / R_j (f32), the irradiance
/// (`vec4<f32>`, RGB and 0) and, from `--gi photon`'s final gather, the spherical harmonics
/// (`ShRgb`), `count` of each.
pub struct GpuIrradianceSamples {
    pub points: wgpu::Buffer,
    pub inv_radius: wgpu::Buffer,
    pub irradiance: wgpu::Buffer,
    pub sh: Option<wgpu::Buffer>,
    pub count: u32,
}

/// The visibility matrix and lights the sample points are lit by.
pub struct SampleLighting<'a> {
    /// One row per sample point.
    pub words: &'a wgpu::Buffer,
    pub words_per_row: u32,
    pub vpl_lights: &'a wgpu::Buffer,
    /// [`crate::shade::ShadeInputs::outlines`].
    pub outlines: Option<&'a wgpu::Buffer>,
    pub light_count: u32,
    /// [`crate::shade::ShadeInputs::exact_shapes`].
    pub exact_shapes: bool,
    /// [`crate::shade::ShadeInputs::lobes`].
    pub lobes: Option<&'a wgpu::Buffer>,
    pub g_max: f32,
}

/// The shading points to interpolate at and their clusters.
pub struct InterpolateInputs<'a> {
    /// Shading points from sample `sp_first` on.
    pub sps: &'a wgpu::Buffer,
    pub sp_first: u32,
    pub row_of: &'a wgpu::Buffer,
    /// `f` labels per hit, of which the hits in `window` are bound.
    pub labels: &'a wgpu::Buffer,
    pub f: u32,
    pub window: Window,
    /// Each material's BSDF in white (`GpuScene::lobes`), for glossy receivers.
    pub lobes: &'a wgpu::Buffer,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = InterpolateKernel;

pub struct InterpolateKernel {
    sample_points: wgpu::ComputePipeline,
    interpolate: wgpu::ComputePipeline,
}

impl InterpolateKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "interpolate pipelines", || {
            let [sample_points, interpolate]: [wgpu::ComputePipeline; 2] = pipelines(device, "interpolate.wgsl", &["sample_points", "interpolate"])
                .try_into()
                .unwrap_or_else(|_| unreachable!("one pipeline per entry point"));
            InterpolateKernel { sample_points, interpolate }
        })
    }

    /// The irradiance samples at the `n` sample points `points` (Endpoints), whose 1 / R_j are
    /// `inv_radius`, from `lighting`.
    pub fn sample_irradiance(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadeKernel,
        (points, n): (wgpu::Buffer, u32),
        inv_radius: wgpu::Buffer,
        lighting: &SampleLighting,
    ) -> Result<GpuIrradianceSamples, GpuError> {
        let (sps, rows) = validated(device, "interpolate sample points", || {
            let sps = storage_zeroed::<ShadingPoint>(device, "sample points", n as usize);
            let rows = storage_zeroed::<u32>(device, "sample rows", n as usize);
            let p = kernel_params(device, "interpolate params", &Params { count: n, ..Default::default() });
            let b = [(0, &p), (6, &points), (7, &sps), (8, &rows)].map(|(i, b)| (i, b.as_entire_buffer_binding()));
            dispatch_windows(device, queue, &self.sample_points, &b, n.div_ceil(64).max(1));
            (sps, rows)
        })?;
        let inputs = ShadeInputs {
            sps: &sps,
            sp_first: 0,
            row_of: &rows,
            words: lighting.words,
            words_per_row: lighting.words_per_row,
            vpl_lights: lighting.vpl_lights,
            outlines: lighting.outlines,
            light_count: lighting.light_count,
            exact_shapes: lighting.exact_shapes,
            lobes: lighting.lobes,
            visibility: Visibility::Own { first_row: 0 },
        };
        let irradiance = shade.light_sums(device, queue, &inputs, 0..n, 1, lighting.g_max)?;
        Ok(GpuIrradianceSamples { points, inv_radius, irradiance, sh: None, count: n })
    }

    /// The interpolated irradiance of camera samples `samples` (all in `inputs.sps`), one
    /// `vec4<f32>` per sample, 0 for a miss: what `ShadeKernel::finish` reads.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        samples: &GpuIrradianceSamples,
        inputs: &InterpolateInputs,
        range: Range<u32>,
    ) -> Result<wgpu::Buffer, GpuError> {
        let count = range.end - range.start;
        let params = Params {
            count,
            first_sample: range.start,
            sp_first: inputs.sp_first,
            f: inputs.f,
            first_row: inputs.window.first as u32,
            sh: samples.sh.is_some() as u32,
            pad: [0; 2],
        };
        validated(device, "interpolate", || {
            let running = storage_zeroed::<[f32; 4]>(device, "interpolated irradiance", count as usize);
            // The VPL lights' samples carry none, and the kernel reads none (Params::sh is 0).
            let no_sh;
            let sh = match &samples.sh {
                Some(b) => b,
                None => {
                    no_sh = storage_zeroed::<ShRgb>(device, "no harmonics", 1);
                    &no_sh
                }
            };
            let p = kernel_params(device, "interpolate params", &params);
            let b = vec![
                (0, p.as_entire_buffer_binding()),
                (6, samples.points.as_entire_buffer_binding()),
                (9, inputs.sps.as_entire_buffer_binding()),
                (10, inputs.row_of.as_entire_buffer_binding()),
                (11, inputs.window.of::<u32>(inputs.labels, inputs.f as u64)),
                (12, samples.inv_radius.as_entire_buffer_binding()),
                (13, samples.irradiance.as_entire_buffer_binding()),
                (14, running.as_entire_buffer_binding()),
                (15, sh.as_entire_buffer_binding()),
                (16, inputs.lobes.as_entire_buffer_binding()),
            ];
            in_kernel("interpolate", || dispatch_windows(device, queue, &self.interpolate, &b, count.div_ceil(64).max(1)));
            running
        })
    }
}

impl vplgi_frame::stages::Interpolate for GpuBackend<'_> {
    fn sample_irradiance(
        &self,
        points: GpuPoints,
        inv_radius: wgpu::Buffer,
        lights: &VplLightSet,
        matrix: &wgpu::Buffer,
        g_max: f32,
    ) -> Result<GpuIrradianceSamples, GpuError> {
        let lighting = SampleLighting {
            words: matrix,
            words_per_row: words_per_row(lights.count as usize) as u32,
            vpl_lights: &lights.buffer,
            outlines: lights.outlines.as_ref(),
            light_count: lights.count,
            exact_shapes: lights.exact_shapes,
            lobes: self.scene.glossy_lobes(),
            g_max,
        };
        let k = self.kernels;
        k.interpolate.sample_irradiance(self.device, self.queue, &k.shade, (points.buffer, points.count), inv_radius, &lighting)
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "interpolate.wgsl" "Params" { count, first_sample, sp_first, f, first_row, sh }
        });
    }
}
