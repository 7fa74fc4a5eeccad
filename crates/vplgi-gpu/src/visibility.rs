//! Stage 4 on the GPU, `visibility` (`shaders/visibility.wgsl`), the twin of
//! `vplgi_cpu::visibility::visibility`. The result is the CPU's bit matrix as 32-bit words:
//! row r, column c is bit c % 32 of word `r * words_per_row + c / 32`, with `words_per_row`
//! twice the CPU's 64-bit words per row, so the bytes are identical.

use crate::buffers::{dispatch_windows, kernel_params, read_back, storage, storage_zeroed, Window};
use crate::context::validated;
use crate::scene::GpuScene;
use crate::shader::{RayPipeline, VISIBILITY_ROW_LANES};
use crate::GpuError;
use bytemuck::{Pod, Zeroable};

pub use vplgi_types::Endpoint;
use crate::backend::{GpuBackend, GpuPoints};
use std::ops::Range;
use vplgi_frame::Progress;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) rows: u32,
    pub(crate) cols: u32,
    pub(crate) words_per_row: u32,
    pub(crate) first_row: u32,
    pub(crate) row_count: u32,
    pub(crate) eps: f32,
    pub(crate) pad: [u32; 2],
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = VisibilityKernel;

pub struct VisibilityKernel {
    pipeline: RayPipeline,
}


/// 32-bit words per matrix row: the CPU's 64-bit words, doubled.
pub fn words_per_row(cols: usize) -> usize {
    cols.div_ceil(64) * 2
}

impl VisibilityKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "visibility pipeline", || VisibilityKernel { pipeline: RayPipeline::new(device, "visibility.wgsl", "main") })
    }

    /// Rows `range` of the matrix between the `n_cols` Endpoints of `cols` and the `n_rows`
    /// Endpoints of `rows`, as a new device buffer of 32-bit words.
    pub fn run_on_device(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        (rows, n_rows): (&wgpu::Buffer, u32),
        (cols, n_cols): (&wgpu::Buffer, u32),
        range: std::ops::Range<u32>,
    ) -> Result<wgpu::Buffer, GpuError> {
        let (first_row, row_count) = (range.start, range.end - range.start);
        let wpr = words_per_row(n_cols as usize) as u32;
        // Rows are bound from the aligned row at or below first_row, so that `rows` may be
        // larger than one binding.
        let window = Window::covering(first_row as u64, (first_row + row_count) as u64);
        let params =
            Params { rows: n_rows, cols: n_cols, words_per_row: wpr, first_row: first_row - window.first as u32, row_count, eps: scene.eps, pad: [0; 2] };
        validated(device, "visibility", || {
            let p = kernel_params(device, "visibility params", &params);
            let words = storage_zeroed::<u32>(device, "visibility words", (row_count * wpr) as usize);
            let mut b = vec![(0, p.as_entire_buffer_binding()), (3, window.of::<Endpoint>(rows, 1))];
            for (i, x) in [(4, cols), (5, &words)] {
                b.push((i, x.as_entire_buffer_binding()));
            }
            b.extend(self.pipeline.scene_bindings(scene));
            dispatch_windows(device, queue, self.pipeline.get(device, scene), &b, (row_count.div_ceil(VISIBILITY_ROW_LANES) * VISIBILITY_ROW_LANES * wpr).div_ceil(64));
            words
        })
    }

    /// The visibility matrix between `rows` and `cols`, read back as 32-bit words. Rows are
    /// processed in chunks whose words fit `max_binding_bytes` (default: the adapter's limit).
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &GpuScene,
        rows: &[Endpoint],
        cols: &[Endpoint],
        max_binding_bytes: Option<u64>,
    ) -> Result<Vec<u32>, GpuError> {
        let wpr = words_per_row(cols.len());
        let mut out = Vec::with_capacity(rows.len() * wpr);
        if wpr == 0 || rows.is_empty() {
            out.resize(rows.len() * wpr, 0);
            return Ok(out);
        }
        let limit = max_binding_bytes.unwrap_or(device.limits().max_storage_buffer_binding_size);
        let rows_per_chunk = ((limit / 4) as usize / wpr).max(1);
        let (row_buf, col_buf) = validated(device, "visibility inputs", || (storage(device, "rows", rows), storage(device, "cols", cols)))?;
        let mut first = 0;
        while first < rows.len() {
            let n = (rows.len() - first).min(rows_per_chunk);
            let words =
                self.run_on_device(device, queue, scene, (&row_buf, rows.len() as u32), (&col_buf, cols.len() as u32), first as u32..(first + n) as u32)?;
            out.extend(read_back::<u32>(device, queue, &words, n * wpr)?);
            first += n;
        }
        Ok(out)
    }
}

impl vplgi_frame::stages::Visibility for GpuBackend<'_> {
    fn visibility(&self, row_points: &GpuPoints, rows: Range<u32>, cols: &GpuPoints, _progress: &dyn Progress) -> Result<(wgpu::Buffer, Option<u64>), GpuError> {
        let words = self.kernels.visibility.run_on_device(
            self.device,
            self.queue,
            &self.scene,
            (&row_points.buffer, row_points.count),
            (&cols.buffer, cols.count),
            rows,
        )?;
        Ok((words, None))
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "visibility.wgsl" "Params" { rows, cols, words_per_row, first_row, row_count, eps }
        });
    }
}
