//! Exclusive prefix sums on the device (`shaders/scan.wgsl`), shared by the stages that compact.

use crate::buffers::{dispatch, kernel_params};
use crate::context::validated;
use crate::shader::pipeline;
use crate::GpuError;

pub struct ScanKernel {
    pipeline: wgpu::ComputePipeline,
}

impl ScanKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "scan pipeline", || ScanKernel { pipeline: pipeline(device, "scan.wgsl", "main") })
    }

    /// `offsets[i] = counts[0] + .. + counts[i - 1]` for i <= n (`offsets` holds n + 1 words; the
    /// last is the total).
    pub fn run(&self, device: &wgpu::Device, queue: &wgpu::Queue, counts: &wgpu::Buffer, n: u32, offsets: &wgpu::Buffer) -> Result<(), GpuError> {
        validated(device, "scan", || {
            let p = kernel_params(device, "scan params", &[n, 0u32, 0, 0]);
            dispatch(device, queue, &self.pipeline, &[&p, counts, offsets], 1);
        })
    }
}
