//! The GPU twin's storage for a frame (device buffers) and the glue between its stages, chained
//! without read-backs except the few counters the host needs to size the next dispatches (the
//! VPL batch totals, the hit count and the hit numbers at block boundaries, each clustering's
//! data box and occupancy counts) and the shaded pixels. Each stage implements its trait of
//! [`vplgi_frame::stages`] in its own module; the frame itself is [`vplgi_frame::render`].

use crate::buffers::{
    dispatch_windows, kernel_params, read_word, storage_zeroed, sync, Window, WINDOW_ALIGN,
};
use crate::cluster::GpuClustering;
use crate::context::{validated, within_loop_limit};
use crate::interpolate::GpuIrradianceSamples;
use crate::scan::ScanKernel;
use crate::scene::GpuScene;
use crate::shade::{VplLight, VplLightSet};
use crate::shader::pipelines;
use crate::trace_vpls::GpuVpls;
use crate::visibility::{words_per_row, Endpoint};
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_frame::{Counted, Frame, FrameError, LightSet, NoProgress, SampleChunk, Storage};
use vplgi_scene::Scene;
use vplgi_types::{Camera, FrameConfig, LightOutline, LightShape, ShadingPoint};

/// The glue kernels of `frame.wgsl` between the stages.
struct GlueKernels {
    sp_flags: wgpu::ComputePipeline,
    sp_compact: wgpu::ComputePipeline,
    vpl_endpoints: wgpu::ComputePipeline,
    vpl_lights: wgpu::ComputePipeline,
    cluster_lights: wgpu::ComputePipeline,
    cluster_lights_finish: wgpu::ComputePipeline,
    light_endpoints: wgpu::ComputePipeline,
}

macro_rules! kernels {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        /// Every pipeline of the frame, compiled once per device: one kernel per stage and part of
        /// the table (each module's `Kernel`), and the glue. The stage kernels are public so a
        /// stage can be run alone on inputs from elsewhere (`vplgi verify` feeds them the CPU's).
        pub struct GpuKernels {
            $($(#[$doc])* pub $name: crate::$name::Kernel, $(pub $part: crate::$part::Kernel,)*)*
            scan: ScanKernel,
            glue: GlueKernels,
        }

        impl GpuKernels {
            pub fn new(device: &wgpu::Device) -> Result<GpuKernels, GpuError> {
                Ok(GpuKernels {
                    $($name: crate::$name::Kernel::new(device)?, $($part: crate::$part::Kernel::new(device)?,)*)*
                    scan: ScanKernel::new(device)?,
                    glue: GlueKernels::new(device)?,
                })
            }
        }
    };
}
vplgi_frame::stage_table!(kernels);

/// VPLs one `cluster_lights` dispatch reads per cluster: lavapipe ends an invocation's loops
/// after 65,535 iterations (see `shade::LOOP_BUDGET`).
const VPLS_PER_DISPATCH: u32 = 32_768;

/// `Params` of `frame.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct GlueParams {
    pub(crate) n: u32,
    pub(crate) k: u32,
    pub(crate) first: u32,
    pub(crate) end: u32,
    pub(crate) hit_first: u32,
    pub(crate) hit_count: u32,
    pub(crate) phase: u32,
    pub(crate) max_bounce: u32,
    /// cluster_lights: the lights' shape (`LightShape::code`).
    pub(crate) shape: u32,
    pub(crate) pad: [u32; 3],
}

impl GlueKernels {
    fn new(device: &wgpu::Device) -> Result<GlueKernels, GpuError> {
        validated(device, "frame pipelines", || {
            let [sp_flags, sp_compact, vpl_endpoints, vpl_lights, cluster_lights, cluster_lights_finish, light_endpoints]: [wgpu::ComputePipeline; 7] =
                pipelines(
                    device,
                    "frame.wgsl",
                    &["sp_flags", "sp_compact", "vpl_endpoints", "vpl_lights", "cluster_lights", "cluster_lights_finish", "light_endpoints"],
                )
                .try_into()
                .unwrap_or_else(|_| unreachable!("one pipeline per entry point"));
            GlueKernels {
                sp_flags,
                sp_compact,
                vpl_endpoints,
                vpl_lights,
                cluster_lights,
                cluster_lights_finish,
                light_endpoints,
            }
        })
    }
}

/// A scene on one device, ready to render frames of.
pub struct GpuBackend<'a> {
    pub(crate) device: &'a wgpu::Device,
    pub(crate) queue: &'a wgpu::Queue,
    pub(crate) kernels: &'a GpuKernels,
    pub(crate) scene: GpuScene,
    extent: f32,
}

/// Surface points on the device: `count` Endpoints.
pub struct GpuPoints {
    pub buffer: wgpu::Buffer,
    pub count: u32,
}

impl GpuPoints {
    /// `points` copied to the device.
    pub fn upload(device: &wgpu::Device, label: &str, points: &[Endpoint]) -> GpuPoints {
        GpuPoints {
            buffer: crate::buffers::storage(device, label, points),
            count: points.len() as u32,
        }
    }
}

impl Counted for GpuPoints {
    fn count(&self) -> u32 {
        self.count
    }
}

/// The hits of a frame on the device: each sample's hit number (an exclusive scan of the hit
/// flags, `n_samples + 1` words), each sample's row (or `MISS`), and the hits as Endpoints.
pub struct GpuHits {
    pub(crate) offsets: wgpu::Buffer,
    pub(crate) row_of: wgpu::Buffer,
    pub(crate) points: GpuPoints,
}

impl Counted for GpuHits {
    fn count(&self) -> u32 {
        self.points.count
    }
}

/// Renders one frame of `scene` on the device (uploading the scene first).
pub fn render(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    kernels: &GpuKernels,
    scene: &Scene,
    cfg: &FrameConfig,
) -> Result<Frame, GpuError> {
    vplgi_frame::render(&GpuBackend::new(device, queue, kernels, scene)?, cfg, &NoProgress)
}

impl<'a> GpuBackend<'a> {
    /// Uploads the scene (BVH, triangles, textures, light tables) and waits until it is on the
    /// device.
    pub fn new(
        device: &'a wgpu::Device,
        queue: &'a wgpu::Queue,
        kernels: &'a GpuKernels,
        scene: &Scene,
    ) -> Result<GpuBackend<'a>, GpuError> {
        let gs = GpuScene::new(device, scene)?;
        // wgpu copies buffers created mapped to the device with the next submission: without
        // one here, the scene's upload ran inside the frame's first stage (trace_vpls), a third
        // of its time on the conference room.
        queue.submit([]);
        sync(device)?;
        Ok(GpuBackend { device, queue, kernels, scene: gs, extent: scene.extent().max(1e-6) })
    }

    /// The scene on the device.
    pub fn scene(&self) -> &GpuScene {
        &self.scene
    }

    /// The device and queue the scene lives on.
    pub fn device(&self) -> (&wgpu::Device, &wgpu::Queue) {
        (self.device, self.queue)
    }

    /// The kernels this backend runs.
    pub fn kernels(&self) -> &GpuKernels {
        self.kernels
    }

    /// Runs a glue kernel of `frame.wgsl` over `threads` items.
    fn glue(
        &self,
        pipeline: &wgpu::ComputePipeline,
        params: GlueParams,
        bound: &[(u32, wgpu::BufferBinding)],
        threads: u32,
    ) -> Result<(), GpuError> {
        validated(self.device, "frame glue", || {
            let p = kernel_params(self.device, "frame params", &params);
            let mut all = vec![(0, p.as_entire_buffer_binding())];
            all.extend_from_slice(bound);
            dispatch_windows(self.device, self.queue, pipeline, &all, threads.div_ceil(64).max(1));
        })
    }

    fn limit(&self) -> u64 {
        self.device.limits().max_storage_buffer_binding_size
    }
}

impl Storage for GpuBackend<'_> {
    type Error = GpuError;
    type Vpls = GpuVpls;
    type Samples = wgpu::Buffer;
    type Points = GpuPoints;
    type Hits = GpuHits;
    type Lights = VplLightSet;
    type Clustering = GpuClustering;
    type Matrix = wgpu::Buffer;
    type Scalars = wgpu::Buffer;
    type IrradianceSamples = GpuIrradianceSamples;
    type PhotonMap = crate::caustics::GpuPhotonMap;
    type Cut = crate::illumination_cut::GpuCut;

    fn scene_extent(&self) -> f32 {
        self.extent
    }

    fn camera(&self) -> Camera {
        self.scene.camera
    }

    fn has_glossy(&self) -> bool {
        self.scene.glossy
    }

    fn has_specular(&self) -> bool {
        self.scene.specular
    }

    /// The per-sample hit flags, offsets and rows (4 B per sample) must fit one storage binding,
    /// and every per-point array (hit points, labels and weights: at most 64 B per point, bound in
    /// windows) one buffer.
    fn check_frame(&self, cfg: &FrameConfig) -> Result<(), GpuError> {
        let l = self.device.limits();
        let n_sp = cfg.width as u64 * cfg.height as u64 * cfg.spp as u64;
        let what = format!("a {}x{} frame at {} spp", cfg.width, cfg.height, cfg.spp);
        let per_sample = (n_sp + 1) * 4;
        if per_sample > l.max_storage_buffer_binding_size {
            return Err(GpuError::TooLarge {
                what: format!("bytes of per-sample hit offsets of {what} in one storage binding"),
                needed: per_sample,
                limit: l.max_storage_buffer_binding_size,
            });
        }
        if cfg.cluster.clusters_sps() {
            crate::cluster::searchable(cfg.k_sp, "--k-sp: shading-point clusters")?;
            if cfg.seeding == vplgi_types::Seeding::Adaptive {
                let levels = vplgi_shared::seeding::Quadtree::new(cfg.width, cfg.height).levels;
                within_loop_limit(
                    &format!("--spp with --seeding adaptive at {}x{}", cfg.width, cfg.height),
                    cfg.spp,
                    vplgi_shared::seeding::max_spp(levels),
                    "a pixel's GPU invocation walks its samples once per quadtree level",
                )?;
            }
        }
        if cfg.cluster.clusters_vpls() {
            match cfg.vpl_cluster {
                vplgi_types::VplClustering::Eq7 => {
                    crate::cluster::searchable(cfg.k_vpl, "--k-vpl: VPL clusters")?
                }
                vplgi_types::VplClustering::Rsm => within_loop_limit(
                    "--k-vpl: RSM-space clusters",
                    cfg.k_vpl,
                    vplgi_shared::rsm::MAX_RSM_CLUSTERS,
                    "a VPL's GPU assignment may visit all of its map's in one invocation",
                )?,
            }
        }
        let per_point =
            n_sp * (4 * cfg.effective_f() as u64).max(std::mem::size_of::<Endpoint>() as u64);
        if per_point > l.max_buffer_size {
            return Err(GpuError::TooLarge {
                what: format!("bytes of per-point labels of {what} in one buffer"),
                needed: per_point,
                limit: l.max_buffer_size,
            });
        }
        let photons = cfg.caustic_photons as u64 * std::mem::size_of::<vplgi_types::Vpl>() as u64;
        if cfg.has_caustics() && photons > l.max_storage_buffer_binding_size {
            return Err(GpuError::TooLarge {
                what: "bytes of the caustic photon map (--caustic-photons) in one storage binding"
                    .into(),
                needed: photons,
                limit: l.max_storage_buffer_binding_size,
            });
        }
        Ok(())
    }

    /// A chunk fits one storage binding less one window alignment: shade binds the chunk's hits'
    /// labels and weights (at most 64 B per hit, like a shading point) from the aligned hit at or
    /// below the chunk's first.
    fn max_samples_per_chunk(&self) -> u32 {
        (self.limit() / std::mem::size_of::<ShadingPoint>() as u64)
            .saturating_sub(WINDOW_ALIGN)
            .min(u32::MAX as u64) as u32
    }

    /// A block's words fit one storage binding, and so do its rows' Endpoints (bound from the
    /// aligned row at or below the first).
    fn max_visibility_rows(&self, cols: u32) -> u64 {
        let wpr = words_per_row(cols as usize).max(1) as u64;
        (self.limit() / 4 / wpr).min(
            (self.limit() / std::mem::size_of::<Endpoint>() as u64).saturating_sub(WINDOW_ALIGN),
        )
    }

    fn sync(&self) -> Result<(), GpuError> {
        sync(self.device)
    }

    fn compact_hits(
        &self,
        chunks: &[SampleChunk<wgpu::Buffer>],
        n_samples: u32,
    ) -> Result<GpuHits, GpuError> {
        let (device, g) = (self.device, &self.kernels.glue);
        let flags = storage_zeroed::<u32>(device, "hit flags", n_samples as usize);
        let offsets = storage_zeroed::<u32>(device, "hit offsets", n_samples as usize + 1);
        for c in chunks {
            let p = GlueParams { n: c.count, first: c.first, ..Default::default() };
            self.glue(
                &g.sp_flags,
                p,
                &[(1, c.samples.as_entire_buffer_binding()), (2, flags.as_entire_buffer_binding())],
                c.count,
            )?;
        }
        self.kernels.scan.run(device, self.queue, &flags, n_samples, &offsets)?;
        let hits = read_word(device, self.queue, &offsets, n_samples as u64)?;
        let row_of = storage_zeroed::<u32>(device, "row of", n_samples as usize);
        let points = storage_zeroed::<Endpoint>(device, "hit points", hits as usize);
        let windows =
            Window::split(hits as u64, std::mem::size_of::<Endpoint>() as u64, self.limit());
        for c in chunks {
            for w in &windows {
                let p = GlueParams {
                    n: c.count,
                    first: c.first,
                    hit_first: w.first as u32,
                    hit_count: w.count as u32,
                    ..Default::default()
                };
                let b = [
                    (1, c.samples.as_entire_buffer_binding()),
                    (3, offsets.as_entire_buffer_binding()),
                    (4, row_of.as_entire_buffer_binding()),
                    (5, w.of::<Endpoint>(&points, 1)),
                ];
                self.glue(&g.sp_compact, p, &b, c.count)?;
            }
        }
        Ok(GpuHits { offsets, row_of, points: GpuPoints { buffer: points, count: hits } })
    }

    fn hits_before(&self, hits: &GpuHits, sample: u32) -> Result<u32, GpuError> {
        read_word(self.device, self.queue, &hits.offsets, sample as u64)
    }

    fn hit_points<'h>(&self, hits: &'h GpuHits) -> &'h GpuPoints {
        &hits.points
    }

    fn vpl_points(&self, vpls: &GpuVpls) -> Result<GpuPoints, GpuError> {
        let n = vpls.count;
        let pts = storage_zeroed::<Endpoint>(self.device, "vpl points", n as usize);
        self.glue(
            &self.kernels.glue.vpl_endpoints,
            GlueParams { n, ..Default::default() },
            &[(5, pts.as_entire_buffer_binding()), (6, vpls.buffer.as_entire_buffer_binding())],
            n,
        )?;
        Ok(GpuPoints { buffer: pts, count: n })
    }

    fn vpl_lights(
        &self,
        vpls: &GpuVpls,
        set: LightSet<'_, GpuClustering>,
    ) -> Result<VplLightSet, GpuError> {
        let n = vpls.count;
        let g = &self.kernels.glue;
        let vb = vpls.buffer.as_entire_buffer_binding();
        Ok(match set {
            LightSet::Clusters { clusters: c, shape } => {
                let k = c.k;
                let lights = storage_zeroed::<VplLight>(self.device, "cluster lights", k as usize);
                let sums = storage_zeroed::<[f32; 4]>(
                    self.device,
                    "cluster light sums",
                    4 * k.max(1) as usize,
                );
                let polygons = shape == LightShape::Polygon;
                let outlines = storage_zeroed::<LightOutline>(
                    self.device,
                    "light outlines",
                    if polygons { k.max(1) as usize } else { 1 },
                );
                let b = [
                    (6, vb),
                    (7, c.labels.as_entire_buffer_binding()),
                    (8, c.representatives.as_entire_buffer_binding()),
                    (9, lights.as_entire_buffer_binding()),
                    (10, sums.as_entire_buffer_binding()),
                    (11, outlines.as_entire_buffer_binding()),
                ];
                // Each thread reads the VPLs in ranges of VPLS_PER_DISPATCH, continuing its sums
                // (lavapipe's loop limiter, see shade::LOOP_BUDGET); a disk or a polygon needs a
                // second pass.
                for pass in 0..=shape.is_area() as u32 {
                    let mut first = 0;
                    while first < n {
                        let end = n.min(first + VPLS_PER_DISPATCH);
                        let sum = [b[0].clone(), b[1].clone(), b[2].clone(), b[4].clone()];
                        self.glue(
                            &g.cluster_lights,
                            GlueParams {
                                n,
                                k,
                                first,
                                end,
                                phase: pass,
                                shape: shape.code(),
                                ..Default::default()
                            },
                            &sum,
                            k,
                        )?;
                        first = end;
                    }
                }
                let finish = [b[0].clone(), b[2].clone(), b[3].clone(), b[4].clone(), b[5].clone()];
                self.glue(
                    &g.cluster_lights_finish,
                    GlueParams { n, k, shape: shape.code(), ..Default::default() },
                    &finish,
                    k,
                )?;
                VplLightSet {
                    buffer: lights,
                    count: k,
                    outlines: polygons.then_some(outlines),
                    exact_shapes: matches!(shape, LightShape::DiskExact | LightShape::Polygon),
                }
            }
            LightSet::EachVpl { max_bounce } => {
                let lights = storage_zeroed::<VplLight>(self.device, "vpl lights", n as usize);
                self.glue(
                    &g.vpl_lights,
                    GlueParams { n, max_bounce, ..Default::default() },
                    &[(6, vb), (9, lights.as_entire_buffer_binding())],
                    n,
                )?;
                VplLightSet { buffer: lights, count: n, outlines: None, exact_shapes: false }
            }
            LightSet::Nothing => VplLightSet {
                buffer: storage_zeroed::<VplLight>(self.device, "no lights", 0),
                count: 0,
                outlines: None,
                exact_shapes: false,
            },
        })
    }

    fn light_points(&self, lights: &VplLightSet) -> Result<GpuPoints, GpuError> {
        let n = lights.count;
        let cols = storage_zeroed::<Endpoint>(self.device, "light endpoints", n as usize);
        self.glue(
            &self.kernels.glue.light_endpoints,
            GlueParams { n, ..Default::default() },
            &[(5, cols.as_entire_buffer_binding()), (9, lights.buffer.as_entire_buffer_binding())],
            n,
        )?;
        Ok(GpuPoints { buffer: cols, count: n })
    }
}

impl From<FrameError> for GpuError {
    fn from(e: FrameError) -> GpuError {
        match e {
            FrameError::InvalidConfig(message) => {
                GpuError::Validation { what: "the frame configuration".into(), message }
            }
        }
    }
}
