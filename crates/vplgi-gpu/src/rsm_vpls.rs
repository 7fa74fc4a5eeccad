//! Stage 1 with `--vpl-source rsm` on the GPU, `rsm_vpls` (`shaders/rsm_vpls.wgsl`), the twin of
//! `vplgi_cpu::rsm_vpls::rsm_vpls`: the same maps (built on the host, `vplgi_shared::rsm`), the
//! same texel rays through the same specular chains, the VPLs compacted in texel order. One
//! read-back: the VPL count.

use crate::buffers::{dispatch_bound, dispatch_windows, kernel_params, read_word, storage, storage_zeroed};
use crate::context::validated;
use crate::scan::ScanKernel;
use crate::scene::GpuScene;
use crate::shader::{pipelines, RayPipeline};
use crate::trace_vpls::GpuVpls;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_types::{RsmParams, Vpl};
use crate::backend::GpuBackend;
use vplgi_frame::Progress;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) texels: u32,
    pub(crate) maps: u32,
    pub(crate) eps: f32,
    pub(crate) seed: u32,
    pub(crate) specular_depth: u32,
    pub(crate) pad: [u32; 3],
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = RsmVplsKernel;

pub struct RsmVplsKernel {
    texel: RayPipeline,
    compact: wgpu::ComputePipeline,
    scan: ScanKernel,
}

impl RsmVplsKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        let scan = ScanKernel::new(device)?;
        validated(device, "rsm_vpls pipelines", || RsmVplsKernel {
            texel: RayPipeline::new(device, "rsm_vpls.wgsl", "rsm_texel"),
            compact: pipelines(device, "rsm_vpls.wgsl", &["compact"]).remove(0),
            scan,
        })
    }

    /// The VPLs of `maps` (`LightSampler::rsm_maps(rsm.size)`), in texel order.
    pub fn run(&self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &GpuScene, maps: &[RsmLight], rsm: &RsmParams) -> Result<GpuVpls, GpuError> {
        let texels = rsm::texel_count(maps);
        if texels == 0 {
            return Ok(GpuVpls { buffer: storage_zeroed::<Vpl>(device, "vpls", 1), count: 0, particles: 0 });
        }
        let limit = device.limits().max_storage_buffer_binding_size;
        let bytes = texels as u64 * std::mem::size_of::<Vpl>() as u64;
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what: format!("bytes of VPL slots for the {texels} texels of the reflective shadow maps (--rsm-size)"),
                needed: bytes,
                limit,
            });
        }
        let map_buf = storage(device, "rsm maps", maps);
        let slots = storage_zeroed::<Vpl>(device, "rsm slots", texels as usize);
        let counts = storage_zeroed::<u32>(device, "rsm counts", texels as usize);
        let offsets = storage_zeroed::<u32>(device, "rsm offsets", texels as usize + 1);
        let params = kernel_params(device, "rsm params", &Params { texels, maps: maps.len() as u32, eps: scene.eps, seed: rsm.seed, specular_depth: rsm.specular_depth, pad: [0; 3] });
        validated(device, "rsm_vpls texel", || {
            let own = [(0, &params), (1, &map_buf), (11, &slots), (12, &counts)];
            let mut bindings: Vec<(u32, wgpu::BufferBinding)> = own.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
            bindings.extend(self.texel.scene_bindings(scene));
            dispatch_windows(device, queue, self.texel.get(device, scene), &bindings, texels.div_ceil(64));
        })?;
        self.scan.run(device, queue, &counts, texels, &offsets)?;
        let count = read_word(device, queue, &offsets, texels as u64)?;
        let vpls = storage_zeroed::<Vpl>(device, "vpls", count.max(1) as usize);
        validated(device, "rsm_vpls compact", || {
            dispatch_bound(device, queue, &self.compact, &[(0, &params), (11, &slots), (12, &counts), (13, &offsets), (15, &vpls)], texels.div_ceil(64));
        })?;
        Ok(GpuVpls { buffer: vpls, count, particles: texels })
    }
}

impl vplgi_frame::stages::RsmVpls for GpuBackend<'_> {
    fn rsm_vpls(&self, params: &RsmParams, _progress: &dyn Progress) -> Result<(GpuVpls, u32), GpuError> {
        let v = self.kernels.rsm_vpls.run(self.device, self.queue, &self.scene, &self.scene.sampler.rsm_maps(params.size), params)?;
        let particles = v.particles;
        Ok((v, particles))
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "rsm_vpls.wgsl" "Params" { texels, maps, eps, seed, specular_depth }
        });
    }
}
