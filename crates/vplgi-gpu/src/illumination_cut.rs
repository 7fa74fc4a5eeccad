//! Stage `illumination_cut` on the GPU (`shaders/illumination_cut.wgsl`), the twin of
//! `vplgi_cpu::illumination_cut`: Eq. 3 at every node of the photon tree, in member ranges one
//! dispatch each, and the density estimates at the cut nodes' representatives, by the search
//! `caustics` uses. The estimates are read back for the host's choice of the cut
//! (`vplgi_shared::illumination_cut`), and the chosen cut is uploaded for final gathering.

use crate::backend::GpuBackend;
use crate::buffers::{dispatch_bound, kernel_params, read_back, storage, storage_zeroed};
use crate::caustics::GpuPhotonMap;
use crate::context::validated;
use crate::shader::pipelines;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_shared::illumination_cut::{Densities, GatherCut};
use vplgi_types::{CutNode, CutParams, Endpoint};

#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Params {
    pub(crate) count: u32,
    pub(crate) first: u32,
    pub(crate) end: u32,
    pub(crate) phase: u32,
    pub(crate) min_radius: f32,
    pub(crate) k: u32,
    pub(crate) max_r2: f32,
    pub(crate) pad: u32,
}

/// Members of each node one dispatch of a phase reads: one loop per invocation, well inside
/// lavapipe's 65,535 iterations.
pub const MEMBERS_PER_DISPATCH: u32 = 16_384;

/// The cut on the device, as `final_gather.wgsl` reads it.
pub struct GpuCut {
    /// [`CutNode`]s, one per cut node.
    pub nodes: wgpu::Buffer,
    /// [`vplgi_types::CutBound`]s, one per tree node, around the kernels and around the
    /// fallback's wider kernels.
    pub bounds: wgpu::Buffer,
    pub wide_bounds: wgpu::Buffer,
    /// The cut's size.
    pub count: u32,
}

/// The name `GpuKernels` knows this stage's kernel by (`vplgi_frame::stage_table!`).
pub type Kernel = IlluminationCutKernel;

pub struct IlluminationCutKernel {
    estimates: wgpu::ComputePipeline,
    densities: wgpu::ComputePipeline,
}

impl IlluminationCutKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "illumination_cut pipelines", || {
            let [estimates, densities]: [wgpu::ComputePipeline; 2] = pipelines(device, "illumination_cut.wgsl", &["node_estimates", "densities"])
                .try_into()
                .unwrap_or_else(|_| unreachable!("one pipeline per entry point"));
            IlluminationCutKernel { estimates, densities }
        })
    }

    /// Every node's representative, radius and Eq. 3 estimate, read back.
    pub fn node_estimates(&self, device: &wgpu::Device, queue: &wgpu::Queue, map: &GpuPhotonMap, nodes: u32, params: &CutParams) -> Result<Vec<CutNode>, GpuError> {
        // The root holds every photon: the most members any node has.
        let largest = map.count;
        let sums = storage_zeroed::<[f32; 4]>(device, "cut sums", nodes as usize);
        let out = storage_zeroed::<CutNode>(device, "cut node estimates", nodes as usize);
        validated(device, "illumination_cut estimates", || {
            for phase in 0..2 {
                let mut first = 0;
                loop {
                    let end = first + MEMBERS_PER_DISPATCH;
                    let p = Params { count: nodes, first, end, phase, min_radius: params.min_radius, ..Default::default() };
                    let pb = kernel_params(device, "illumination_cut params", &p);
                    let bound = [(0, &pb), (1, &map.photons), (2, &map.nodes), (3, &sums), (4, &out)];
                    dispatch_bound(device, queue, &self.estimates, &bound, nodes.div_ceil(64).max(1));
                    if end >= largest {
                        break;
                    }
                    first = end;
                }
            }
        })?;
        read_back::<CutNode>(device, queue, &out, nodes as usize)
    }

    /// The density estimates at `points`, read back.
    pub fn densities(&self, device: &wgpu::Device, queue: &wgpu::Queue, map: &GpuPhotonMap, points: &[Endpoint], params: &CutParams) -> Result<Densities, GpuError> {
        let count = points.len() as u32;
        if count == 0 {
            return Ok(Vec::new());
        }
        let out = storage_zeroed::<[f32; 4]>(device, "cut densities", count as usize);
        validated(device, "illumination_cut densities", || {
            let p = Params { count, k: params.k, max_r2: params.max_radius * params.max_radius, min_radius: params.min_radius, ..Default::default() };
            let pb = kernel_params(device, "illumination_cut params", &p);
            let at = storage(device, "cut points", points);
            let bound = [(0, &pb), (1, &map.photons), (2, &map.nodes), (5, &at), (6, &out)];
            dispatch_bound(device, queue, &self.densities, &bound, count.div_ceil(64));
        })?;
        let got = read_back::<[f32; 4]>(device, queue, &out, count as usize)?;
        Ok(got.into_iter().map(|d| ([d[0], d[1], d[2]], d[3] != 0.0)).collect())
    }

    /// The cut, uploaded.
    pub fn upload(&self, device: &wgpu::Device, cut: &GatherCut) -> GpuCut {
        GpuCut {
            nodes: storage(device, "cut nodes", &cut.nodes),
            bounds: storage(device, "cut bounds", &cut.bounds),
            wide_bounds: storage(device, "cut wide bounds", &cut.wide_bounds),
            count: cut.nodes.len() as u32,
        }
    }
}

impl vplgi_frame::stages::IlluminationCut for GpuBackend<'_> {
    fn node_estimates(&self, map: &GpuPhotonMap, params: &CutParams) -> Result<Vec<CutNode>, GpuError> {
        self.kernels.illumination_cut.node_estimates(self.device, self.queue, map, map.nodes_count, params)
    }

    fn densities(&self, map: &GpuPhotonMap, points: &[Endpoint], params: &CutParams) -> Result<Densities, GpuError> {
        self.kernels.illumination_cut.densities(self.device, self.queue, map, points, params)
    }

    fn upload_cut(&self, cut: GatherCut) -> Result<GpuCut, GpuError> {
        Ok(self.kernels.illumination_cut.upload(self.device, &cut))
    }
}

#[cfg(test)]
mod layout_tests {
    /// The stage's records have the size and field offsets naga lays out for its shader.
    #[test]
    fn records_match_their_wgsl_layouts() {
        crate::shader::layout::check(crate::layout_rows! {
            [super::Params] "illumination_cut.wgsl" "Params" { count, first, end, phase, min_radius, k, max_r2 }
        });
    }
}
