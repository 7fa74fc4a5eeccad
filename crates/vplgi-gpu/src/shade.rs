//! Stage 5 on the GPU, `shade` (`shaders/shade.wgsl`), the twin of `vplgi_cpu::shade::shade`.

use crate::buffers::{dispatch, storage_zeroed, uniform};
use crate::context::validated;
use crate::lights::GpuLights;
use crate::scene::GpuScene;
use crate::shader::pipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};

/// A VPL (cluster) as a light for indirect shading (`VplLight` in `shade.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VplLight {
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub flux: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    spp: u32,
    seed: u32,
    direct_samples: u32,
    light_count: u32,
    f: u32,
    mode: u32,
    first_row: u32,
    words_per_row: u32,
    first_pixel: u32,
    pixel_count: u32,
    g_max: f32,
    eps: f32,
    sp_first: u32,
    pad: [u32; 3],
}

/// Where each shading point's visibility comes from (the twin of
/// `vplgi_cpu::shade::VisibilitySource`): its own row of `words` (row `row_of[i] - first_row`),
/// or its `f` clusters' rows with `labels` and `weights`.
pub enum Visibility<'a> {
    Own { first_row: u32 },
    Fuzzy { labels: &'a wgpu::Buffer, weights: &'a wgpu::Buffer, f: u32 },
}

/// Device buffers shade reads.
pub struct ShadeInputs<'a> {
    /// Shading points from sample `sp_first` on (a chunk, or all of them with `sp_first = 0`).
    pub sps: &'a wgpu::Buffer,
    pub sp_first: u32,
    pub row_of: &'a wgpu::Buffer,
    pub words: &'a wgpu::Buffer,
    pub words_per_row: u32,
    pub vpl_lights: &'a wgpu::Buffer,
    pub light_count: u32,
    pub visibility: Visibility<'a>,
}

pub struct ShadeKernel {
    pipeline: wgpu::ComputePipeline,
}

impl ShadeKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "shade pipeline", || ShadeKernel { pipeline: pipeline(device, "shade.wgsl", "main") })
    }

    /// Shades `pixels` and returns a device buffer of one `vec4<f32>` (RGB, 0) per pixel of the
    /// range.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        lights: &GpuLights,
        inputs: &ShadeInputs,
        pixels: std::ops::Range<u32>,
        spp: u32,
        seed: u32,
        direct_samples: u32,
        g_max: f32,
    ) -> Result<wgpu::Buffer, GpuError> {
        let count = pixels.end - pixels.start;
        let dummy = storage_zeroed::<u32>(device, "unused", 4);
        let (mode, first_row, f, labels, weights) = match inputs.visibility {
            Visibility::Own { first_row } => (0, first_row, 1, &dummy, &dummy),
            Visibility::Fuzzy { labels, weights, f } => (1, 0, f, labels, weights),
        };
        let params = Params {
            spp,
            seed,
            direct_samples,
            light_count: inputs.light_count,
            f,
            mode,
            first_row,
            words_per_row: inputs.words_per_row,
            first_pixel: pixels.start,
            pixel_count: count,
            g_max,
            eps: scene.eps,
            sp_first: inputs.sp_first,
            pad: [0; 3],
        };
        validated(device, "shade", || {
            let p = uniform(device, "shade params", &params);
            let out = storage_zeroed::<[f32; 4]>(device, "pixels", count as usize);
            let bindings = [
                &p,
                &lights.counts,
                &scene.bvh_nodes,
                &scene.bvh_tris,
                &lights.emitters,
                &lights.area_table,
                &lights.punctual,
                inputs.sps,
                inputs.row_of,
                inputs.words,
                labels,
                weights,
                inputs.vpl_lights,
                &out,
                &scene.bvh_nodes_hi,
                &scene.bvh_tris_hi,
            ];
            dispatch(device, queue, &self.pipeline, &bindings, count.div_ceil(64));
            out
        })
    }
}
