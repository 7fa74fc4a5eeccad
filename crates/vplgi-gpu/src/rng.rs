//! The RNG twin (`shaders/common/rng.wgsl`) and a diagnostic kernel that draws whole streams, for
//! the bit-identity test against `vplgi_types::Rng`.

use crate::buffers::{dispatch, kernel_params, read_back, storage_zeroed};
use crate::context::validated;
use crate::shader::pipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) seed: u32,
    pub(crate) stream: u32,
    pub(crate) first_index: u32,
    pub(crate) count: u32,
    pub(crate) draws: u32,
    pub(crate) pad: [u32; 3],
}

/// `draws` numbers from each of the streams (seed, stream, first_index + i), i < count, stream
/// after stream.
pub fn rng_streams(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    seed: u32,
    stream: u32,
    first_index: u32,
    count: u32,
    draws: u32,
) -> Result<Vec<u32>, GpuError> {
    let n = count as usize * draws as usize;
    let (pipe, params, out) = validated(device, "rng_streams", || {
        let pipe = pipeline(device, "rng_streams.wgsl", "main");
        let params = kernel_params(
            device,
            "rng params",
            &Params { seed, stream, first_index, count, draws, pad: [0; 3] },
        );
        let out = storage_zeroed::<u32>(device, "rng out", n);
        (pipe, params, out)
    })?;
    validated(device, "rng_streams dispatch", || {
        dispatch(device, queue, &pipe, &[&params, &out], count.div_ceil(64))
    })?;
    read_back(device, queue, &out, n)
}
