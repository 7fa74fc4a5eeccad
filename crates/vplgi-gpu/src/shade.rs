//! Stage 5 on the GPU, `shade` (`shaders/shade.wgsl`), the twin of `vplgi_cpu::shade::shade`.

use crate::buffers::{dispatch_windows, kernel_params, storage_zeroed, Window};
use crate::context::validated;
use crate::scene::GpuScene;
use crate::shader::{pipeline_with, RayPipeline, SHADE_FUZZY, SHADE_OWN_ROW, SHADE_POINTS};
use crate::timing::in_kernel;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use std::ops::Range;
use std::sync::OnceLock;
use vplgi_types::config::MAX_F;
use vplgi_types::ShadeParams;

pub use vplgi_types::VplLight;
use crate::backend::GpuBackend;
use crate::buffers::read_back;
use crate::interpolate::InterpolateInputs;
use crate::visibility::words_per_row;
use vplgi_frame::{ShadeInput, ShadeVisibility};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) spp: u32,
    pub(crate) seed: u32,
    pub(crate) direct_samples: u32,
    pub(crate) f: u32,
    pub(crate) mode: u32,
    pub(crate) first_row: u32,
    pub(crate) words_per_row: u32,
    pub(crate) first_pixel: u32,
    pub(crate) pixel_count: u32,
    pub(crate) g_max: f32,
    pub(crate) eps: f32,
    pub(crate) sp_first: u32,
    pub(crate) light_first: u32,
    pub(crate) light_end: u32,
    /// 1: shade_finish adds emission and direct light (`ShadeParams::direct`).
    pub(crate) direct: u32,
    /// shade_finish: the samples of each pixel this dispatch adds, `sample_first .. sample_end`.
    pub(crate) sample_first: u32,
    pub(crate) sample_end: u32,
}

/// Loop iterations one invocation may run. lavapipe (llvmpipe) ends every loop of an invocation
/// once all its loops together have run 65,535 iterations (gallivm's loop limiter, against
/// hangs), silently: a pixel of a fuzzy frame with 10,000 VPL lights and F = 6 summed only its
/// first 7,131 lights. So one dispatch of `shade_lights` sums a range of lights small enough for
/// the limiter. Each shading point's running sum is kept between the dispatches and continued, so
/// the sum is the CPU's one sequential sum, cut, not re-associated.
pub const LOOP_BUDGET: u32 = 48_000;

/// Lights one dispatch of `shade_lights` sums: whole blocks of 64, at least one, with `rows`
/// visibility rows per shading point. Counted as if the loops over points and rows, whose trip
/// counts are constants, were not unrolled (llvmpipe's NIR unrolls them today, but the budget
/// must not depend on an optimiser's choice): per light, the light loop and, per point, its rows
/// and the geometry term.
pub fn lights_per_dispatch(rows: u32) -> u32 {
    let per_light = SHADE_POINTS * (rows + 1) + 2;
    (LOOP_BUDGET / per_light / 64 * 64).max(64)
}

/// Loop iterations a shadow ray's traversal is budgeted: node visits and triangle tests, about
/// what the paper-scale scenes' deepest rays take, with room to spare.
pub const RAY_ITERATIONS: u32 = 2_048;

/// Samples of each pixel one dispatch of `shade_finish` adds: a sample's direct light loops over
/// the light groups, then per direct sample over them again, through the emitter table's binary
/// search and a shadow ray, then a shadow ray per punctual light. At least one.
pub fn samples_per_dispatch(direct_samples: u32, punctual_lights: u32) -> u32 {
    let groups = vplgi_types::light_groups::MAX_GROUPS as u32;
    let per_sample = groups + direct_samples * (groups + 32 + RAY_ITERATIONS) + punctual_lights * RAY_ITERATIONS + 1;
    (LOOP_BUDGET / per_sample).max(1)
}

/// Where each shading point's visibility comes from (the twin of
/// `vplgi_cpu::shade::VisibilitySource`): its own row of `words` (row `row_of[i] - first_row`),
/// or its `f` clusters' rows with `labels` and `weights` (`f` per hit), of which the hits in
/// `window` are bound: it must hold every hit of the shaded pixels.
pub enum Visibility<'a> {
    Own { first_row: u32 },
    Fuzzy { labels: &'a wgpu::Buffer, weights: &'a wgpu::Buffer, f: u32, window: Window },
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
    /// The polygon lights' outlines (`LightOutline`, one per light), if any light is a polygon.
    pub outlines: Option<&'a wgpu::Buffer>,
    pub light_count: u32,
    /// Whether any of the lights is a disk or a polygon lit by its exact form factor
    /// (`VplLight::exact`): such lights are only evaluated by the pipeline compiled for them.
    pub exact_shapes: bool,
    /// The scene's white BSDFs (`GpuScene::glossy_lobes`) where it has glossy surfaces: the
    /// lights are summed by the pipeline that evaluates lobes. None where every surface is
    /// diffuse.
    pub lobes: Option<&'a wgpu::Buffer>,
    pub visibility: Visibility<'a>,
}

/// Lights for indirect shading on the device, the polygon lights' outlines, and whether any
/// light is an exact disk or a polygon (the GPU backend's `Lights`).
pub struct VplLightSet {
    /// `count` lights.
    pub buffer: wgpu::Buffer,
    pub count: u32,
    pub outlines: Option<wgpu::Buffer>,
    pub exact_shapes: bool,
}

fn bind<'a>(own: &[(u32, &'a wgpu::Buffer)]) -> Vec<(u32, wgpu::BufferBinding<'a>)> {
    own.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect()
}

/// What `shade_finish` reads: the shaded samples (`sps`, from camera sample `sp_first` on), the
/// irradiance summed for each (`running`, one per shading point of the range) and the pixels.
pub struct FinishInput<'a> {
    pub sps: &'a wgpu::Buffer,
    pub sp_first: u32,
    pub running: &'a wgpu::Buffer,
    pub pixels: Range<u32>,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = ShadeKernel;

pub struct ShadeKernel {
    /// Emission, direct light and the per-point light sums, per pixel.
    finish: RayPipeline,
    /// The light sums, by the number of visibility rows per point (1 ..= MAX_F), then with exact
    /// disks and polygons (`EXACT_SHAPES`) at index MAX_F + 1 + rows, then all of these with
    /// glossy lobes (`GLOSSY`) 2 (MAX_F + 1) further on, compiled on first use.
    lights: Vec<OnceLock<wgpu::ComputePipeline>>,
}

impl ShadeKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "shade pipeline", || {
            let kernel =
                ShadeKernel { finish: RayPipeline::new(device, "shade.wgsl", "shade_finish"), lights: (0..4 * (MAX_F + 1)).map(|_| OnceLock::new()).collect() };
            // The variants every default frame uses are compiled now, with the other kernels:
            // a pipeline first created after the device is lost is only "invalid", and the
            // frame's error would not say that the device was lost.
            for rows in [1, vplgi_types::FrameConfig::default().f] {
                kernel.lights_pipeline(device, rows, false, false);
            }
            kernel
        })
    }

    fn lights_pipeline(&self, device: &wgpu::Device, rows: u32, exact_shapes: bool, glossy: bool) -> &wgpu::ComputePipeline {
        let stride = MAX_F as usize + 1;
        let index = rows as usize + exact_shapes as usize * stride + glossy as usize * 2 * stride;
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        self.lights[index].get_or_init(|| {
            pipeline_with(device, "shade.wgsl", "shade_lights", &[("ROWS", rows as f64), ("EXACT_SHAPES", flag(exact_shapes)), ("GLOSSY", flag(glossy))])
        })
    }

    /// Shades `pixels` and returns a device buffer of one `vec4<f32>` (RGB, 0) per pixel of the
    /// range: the light sums of [`Self::light_sums`], then [`Self::finish`].
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        inputs: &ShadeInputs,
        pixels: std::ops::Range<u32>,
        shade: &ShadeParams,
    ) -> Result<wgpu::Buffer, GpuError> {
        let running = self.light_sums(device, queue, inputs, pixels.clone(), shade.spp, shade.g_max)?;
        self.finish(device, queue, scene, &FinishInput { sps: inputs.sps, sp_first: inputs.sp_first, running: &running, pixels }, shade)
    }

    /// `shade_lights`: the irradiance of the VPL lights at every shading point of `pixels` (`spp`
    /// each), one `vec4<f32>` per shading point of the range.
    pub fn light_sums(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        inputs: &ShadeInputs,
        pixels: std::ops::Range<u32>,
        spp: u32,
        g_max: f32,
    ) -> Result<wgpu::Buffer, GpuError> {
        let count = pixels.end - pixels.start;
        let dummy = storage_zeroed::<u32>(device, "unused", 4);
        let no_lobes = storage_zeroed::<vplgi_types::BsdfRecord>(device, "no lobes", 1);
        let (mode, first_row, f, labels, weights) = match inputs.visibility {
            Visibility::Own { first_row } => (SHADE_OWN_ROW, first_row, 1, dummy.as_entire_buffer_binding(), dummy.as_entire_buffer_binding()),
            Visibility::Fuzzy { labels, weights, f, window } => {
                (SHADE_FUZZY, window.first as u32, f, window.of::<u32>(labels, f as u64), window.of::<f32>(weights, f as u64))
            }
        };
        // f is also the number of visibility rows per shading point (1 for a point's own row).
        let chunk = lights_per_dispatch(f);
        let params = Params {
            spp,
            seed: 0,
            direct_samples: 0,
            f,
            mode,
            first_row,
            words_per_row: inputs.words_per_row,
            first_pixel: pixels.start,
            pixel_count: count,
            g_max,
            eps: 0.0,
            sp_first: inputs.sp_first,
            light_first: 0,
            light_end: 0,
            direct: 0,
            sample_first: 0,
            sample_end: 0,
        };
        validated(device, "shade lights", || {
            let running = storage_zeroed::<[f32; 4]>(device, "light sums", (count * spp).max(1) as usize);
            let lights_pipeline = self.lights_pipeline(device, f, inputs.exact_shapes, inputs.lobes.is_some());
            let invocations = (count * spp).div_ceil(SHADE_POINTS);
            let mut first = 0;
            while first < inputs.light_count {
                let end = inputs.light_count.min(first + chunk);
                let p = kernel_params(device, "shade params", &Params { light_first: first, light_end: end, ..params });
                let outlines = inputs.outlines.unwrap_or(&dummy);
                let lobes = inputs.lobes.unwrap_or(&no_lobes);
                let mut bindings = bind(&[
                    (0, &p),
                    (7, inputs.sps),
                    (8, inputs.row_of),
                    (9, inputs.words),
                    (12, inputs.vpl_lights),
                    (14, &running),
                    (15, outlines),
                    (16, lobes),
                ]);
                bindings.push((10, labels.clone()));
                bindings.push((11, weights.clone()));
                in_kernel("shade lights", || dispatch_windows(device, queue, lights_pipeline, &bindings, invocations.div_ceil(64)));
                first = end;
            }
            running
        })
    }

    /// `shade_finish`: per pixel of `input.pixels`, the mean over its samples of emitted +
    /// direct light + albedo / π × the sample's irradiance in `input.running`.
    pub fn finish(&self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &GpuScene, input: &FinishInput<'_>, shade: &ShadeParams) -> Result<wgpu::Buffer, GpuError> {
        let FinishInput { sps, sp_first, running, ref pixels } = *input;
        let pixels = pixels.clone();
        let ShadeParams { spp, seed, direct_samples, g_max, direct } = *shade;
        let count = pixels.end - pixels.start;
        let params = Params {
            spp,
            seed,
            direct_samples,
            f: 1,
            mode: SHADE_OWN_ROW,
            first_row: 0,
            words_per_row: 0,
            first_pixel: pixels.start,
            pixel_count: count,
            g_max,
            eps: scene.eps,
            sp_first,
            light_first: 0,
            light_end: 0,
            direct: direct as u32,
            sample_first: 0,
            sample_end: 0,
        };
        let chunk = if direct { samples_per_dispatch(direct_samples, scene.lights.punctual_count) } else { spp };
        validated(device, "shade", || {
            let out = storage_zeroed::<[f32; 4]>(device, "pixels", count as usize);
            let mut first = 0;
            while first < spp {
                let end = spp.min(first + chunk);
                let p = kernel_params(device, "shade params", &Params { sample_first: first, sample_end: end, ..params });
                let mut bindings = bind(&[(0, &p), (7, sps), (13, &out), (14, running), (16, &scene.lobes)]);
                bindings.extend(self.finish.scene_bindings(scene));
                in_kernel("shade finish", || dispatch_windows(device, queue, self.finish.get(device, scene), &bindings, count.div_ceil(64)));
                first = end;
            }
            out
        })
    }
}

impl vplgi_frame::Counted for VplLightSet {
    fn count(&self) -> u32 {
        self.count
    }
}

impl vplgi_frame::stages::Shade for GpuBackend<'_> {
    fn shade(&self, input: &ShadeInput<'_, Self>, pixels: Range<u32>, params: &ShadeParams) -> Result<Vec<[f32; 3]>, GpuError> {
        let (device, queue, k) = (self.device, self.queue, self.kernels);
        let sps = &input.chunk.samples;
        let lights = input.lights;
        let own = |visibility| ShadeInputs {
            sps,
            sp_first: input.chunk.first,
            row_of: &input.hits.row_of,
            words: input.matrix,
            words_per_row: words_per_row(lights.count as usize) as u32,
            vpl_lights: &lights.buffer,
            outlines: lights.outlines.as_ref(),
            light_count: lights.count,
            exact_shapes: lights.exact_shapes,
            lobes: self.scene.glossy_lobes(),
            visibility,
        };
        let running = match input.visibility {
            ShadeVisibility::Own { first_row } => {
                k.shade.light_sums(device, queue, &own(Visibility::Own { first_row }), pixels.clone(), params.spp, params.g_max)?
            }
            ShadeVisibility::Fuzzy { clustering: c, ref hits } => {
                let window = Window::covering(hits.start as u64, hits.end as u64);
                let inputs = own(Visibility::Fuzzy { labels: &c.labels, weights: &c.weights, f: c.f, window });
                k.shade.light_sums(device, queue, &inputs, pixels.clone(), params.spp, params.g_max)?
            }
            ShadeVisibility::Interpolated { clustering: c, ref hits, samples } => {
                let window = Window::covering(hits.start as u64, hits.end as u64);
                let inputs = InterpolateInputs { sps, sp_first: input.chunk.first, row_of: &input.hits.row_of, labels: &c.labels, f: c.f, window, lobes: &self.scene.lobes };
                k.interpolate.run(device, queue, samples, &inputs, pixels.start * params.spp..pixels.end * params.spp)?
            }
        };
        let n = (pixels.end - pixels.start) as usize;
        let out = k.shade.finish(device, queue, &self.scene, &FinishInput { sps, sp_first: input.chunk.first, running: &running, pixels }, params)?;
        Ok(read_back::<[f32; 4]>(device, queue, &out, n)?.into_iter().map(|p| [p[0], p[1], p[2]]).collect())
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "shade.wgsl" "Params" { spp, seed, direct_samples, f, mode, first_row, words_per_row, first_pixel, pixel_count, g_max, eps, sp_first, light_first, light_end, direct, sample_first, sample_end }
        });
    }
}
