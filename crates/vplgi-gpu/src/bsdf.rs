//! The BSDF twin (`shaders/common/bsdf.wgsl`) and a diagnostic kernel that answers eval, pdf and
//! sample queries, for the twin test against `vplgi_shared::bsdf`.

use crate::buffers::{dispatch, kernel_params, read_back, storage, storage_zeroed};
use crate::context::validated;
use crate::shader::pipeline;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::BsdfRecord;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) count: u32,
    pub(crate) radiance: u32,
    pub(crate) pad: [u32; 2],
}

/// One query: eval and pdf of `bsdf` for (`wi`, `wo`), and a sample for `wi` from the uniform
/// numbers `u` (which lobe, then where in it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BsdfQuery {
    pub bsdf: BsdfRecord,
    pub wi: [f32; 3],
    pub pad0: u32,
    pub wo: [f32; 3],
    pub pad1: u32,
    pub u: [f32; 3],
    pub pad2: u32,
}

/// The GPU's answer to a [`BsdfQuery`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BsdfAnswer {
    pub eval: [f32; 3],
    pub pdf: f32,
    /// The sample.
    pub wo: [f32; 3],
    pub sample_pdf: f32,
    pub weight: [f32; 3],
    /// Bit 0: a sample was made; bit 1: it came from a delta lobe.
    pub flags: u32,
}

/// The answers to `queries`, samples weighted for radiance transport if `radiance`.
pub fn bsdf_queries(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    queries: &[BsdfQuery],
    radiance: bool,
) -> Result<Vec<BsdfAnswer>, GpuError> {
    let count = queries.len() as u32;
    let (pipe, params, input, out) = validated(device, "bsdf_queries", || {
        let pipe = pipeline(device, "bsdf_queries.wgsl", "main");
        let p = Params { count, radiance: radiance as u32, pad: [0; 2] };
        let params = kernel_params(device, "bsdf params", &p);
        let input = storage(device, "bsdf queries", queries);
        let out = storage_zeroed::<BsdfAnswer>(device, "bsdf answers", queries.len());
        (pipe, params, input, out)
    })?;
    validated(device, "bsdf_queries dispatch", || {
        dispatch(device, queue, &pipe, &[&params, &input, &out], count.div_ceil(64).max(1))
    })?;
    read_back(device, queue, &out, queries.len())
}

#[cfg(test)]
mod layout_tests {
    /// The queries, answers and records have the size and field offsets naga lays out.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [vplgi_types::BsdfRecord] "bsdf_queries.wgsl" "BsdfRecord" { reflectance, kind, alpha, eta, metallic }
            [super::Params] "bsdf_queries.wgsl" "Params" { count, radiance }
            [super::BsdfQuery] "bsdf_queries.wgsl" "Query" { bsdf, wi, wo, u }
            [super::BsdfAnswer] "bsdf_queries.wgsl" "Answer" { eval, pdf, wo, sample_pdf, weight, flags }
        });
    }
}
