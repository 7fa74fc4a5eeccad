//! Stage 1 on the GPU, `trace_vpls` (`shaders/trace_vpls.wgsl`), the twin of
//! `vplgi_cpu::trace_vpls::trace_vpls`: the same particles, the same exact count, the same
//! normalisation. The VPLs stay on the device; only two counters per batch are read back to
//! decide whether another batch is needed.

use crate::buffers::{dispatch_bound, dispatch_windows, kernel_params, read_back, storage_zeroed};
use crate::context::validated;
use crate::scan::ScanKernel;
use crate::scene::GpuScene;
use crate::shader::{pipelines, RayPipeline};
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_types::{Deposit, TraceParams, Vpl};
use crate::backend::GpuBackend;
use vplgi_frame::Progress;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) seed: u32,
    pub(crate) bounces: u32,
    pub(crate) first: u32,
    pub(crate) count: u32,
    pub(crate) wanted: u32,
    pub(crate) kept: u32,
    pub(crate) eps: f32,
    pub(crate) specular_depth: u32,
    /// 0: VPLs, 1: caustic photons (`Deposit::CausticPhotons`), 2: photons (`Deposit::Photons`).
    pub(crate) deposit: u32,
}

/// VPLs on the device.
pub struct GpuVpls {
    /// `count` [`Vpl`]s (at least one element is allocated).
    pub buffer: wgpu::Buffer,
    pub count: u32,
    /// Light particles traced to make them.
    pub particles: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = TraceVplsKernel;

pub struct TraceVplsKernel {
    trace: RayPipeline,
    compact: wgpu::ComputePipeline,
    normalize: wgpu::ComputePipeline,
    scan: ScanKernel,
}

impl TraceVplsKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        let scan = ScanKernel::new(device)?;
        validated(device, "trace_vpls pipelines", || {
            let mut p = pipelines(device, "trace_vpls.wgsl", &["compact", "normalize_flux"]).into_iter();
            let mut next = || p.next().expect("two entry points");
            TraceVplsKernel { trace: RayPipeline::new(device, "trace_vpls.wgsl", "trace"), compact: next(), normalize: next(), scan }
        })
    }

    /// Exactly `count` VPLs (fewer only if a budget of `64 count + 65536` particles runs out).
    pub fn run(&self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &GpuScene, p: &TraceParams) -> Result<GpuVpls, GpuError> {
        let lights = &scene.lights;
        let TraceParams { seed, count, bounces, specular_depth, deposit } = *p;
        let deposit = match deposit {
            Deposit::Vpls => 0,
            Deposit::CausticPhotons => 1,
            Deposit::Photons => 2,
        };
        let vpls = storage_zeroed::<Vpl>(device, "vpls", count.max(1) as usize);
        if count == 0 || bounces == 0 || lights.emitter_count + lights.punctual_count == 0 {
            return Ok(GpuVpls { buffer: vpls, count: 0, particles: 0 });
        }
        let budget = (count as u64 * 64 + 65_536).min(u32::MAX as u64) as u32;
        let limit = device.limits().max_storage_buffer_binding_size;
        let max_batch = (limit / (bounces as u64 * std::mem::size_of::<Vpl>() as u64)).clamp(1, 1 << 20) as u32;
        let mut batch = count.clamp(1024, 1 << 16).min(max_batch);
        let slots = storage_zeroed::<Vpl>(device, "vpl slots", (batch * bounces) as usize);
        let counts = storage_zeroed::<u32>(device, "vpl counts", batch as usize);
        let offsets = storage_zeroed::<u32>(device, "vpl offsets", batch as usize + 1);
        let totals = storage_zeroed::<u32>(device, "vpl totals", 4);
        let (mut next, mut kept, mut recorded) = (0u32, 0u32, 0u32);
        while kept < count && next < budget {
            let n = batch.min(budget - next);
            let params = Params { seed, bounces, first: next, count: n, wanted: count, kept, eps: scene.eps, specular_depth, deposit };
            let params_buf = validated(device, "trace_vpls", || {
                let p = kernel_params(device, "trace params", &params);
                let own = [(0, &p), (11, &slots), (12, &counts)];
                let mut bindings: Vec<(u32, wgpu::BufferBinding)> = own.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
                bindings.extend(self.trace.scene_bindings(scene));
                dispatch_windows(device, queue, self.trace.get(device, scene), &bindings, n.div_ceil(64));
                p
            })?;
            self.scan.run(device, queue, &counts, n, &offsets)?;
            validated(device, "trace_vpls compact", || {
                dispatch_bound(
                    device,
                    queue,
                    &self.compact,
                    &[(0, &params_buf), (11, &slots), (12, &counts), (13, &offsets), (14, &totals), (15, &vpls)],
                    n.div_ceil(64),
                )
            })?;
            // One read per batch: the batch's VPLs (the scan's total, copied by compact) and the
            // particle that closed the set, if one did.
            let t = read_back::<u32>(device, queue, &totals, 3)?;
            recorded = t[1];
            kept += t[2].min(count - kept);
            next += n;
            // Size the next batch from the yield so far, like the CPU.
            let per_particle = (kept as f64 / next as f64).max(0.05);
            batch = batch.max((((count - kept) as f64 / per_particle) as u32).clamp(1024, 1 << 20)).min(max_batch);
            if batch as usize * bounces as usize > slots.size() as usize / std::mem::size_of::<Vpl>() {
                batch = (slots.size() as usize / std::mem::size_of::<Vpl>() / bounces as usize) as u32;
            }
        }
        let particles = if recorded != 0 { recorded } else { next };
        let params = Params { seed, bounces, first: 0, count: particles, wanted: count, kept, eps: scene.eps, specular_depth, deposit };
        validated(device, "trace_vpls normalize", || {
            let p = kernel_params(device, "normalize params", &params);
            dispatch_bound(device, queue, &self.normalize, &[(0, &p), (14, &totals), (15, &vpls)], kept.div_ceil(64));
        })?;
        Ok(GpuVpls { buffer: vpls, count: kept, particles })
    }
}

impl vplgi_frame::Counted for GpuVpls {
    fn count(&self) -> u32 {
        self.count
    }
}

impl vplgi_frame::stages::TraceVpls for GpuBackend<'_> {
    fn trace_vpls(&self, p: &TraceParams, _progress: &dyn Progress) -> Result<(GpuVpls, u32), GpuError> {
        let v = self.kernels.trace_vpls.run(self.device, self.queue, &self.scene, p)?;
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
            [super::Params] "trace_vpls.wgsl" "Params" { seed, bounces, first, count, wanted, kept, eps, specular_depth, deposit }
        });
    }
}
