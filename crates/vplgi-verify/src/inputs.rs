//! The CPU's intermediate results of a frame: what the chained GPU stages are fed.

use glam::Vec3;
use vplgi_cpu::cluster::{cluster, cluster_from, ClusterStart, Clustering};
use vplgi_cpu::seeding::{seeding, ImageHits};
use vplgi_cpu::shade::{VplLight, VplLights};
use vplgi_cpu::CpuScene;
use vplgi_shared::rsm_importance;
use vplgi_types::{
    Endpoint, FrameConfig, RsmSeeding, Seeding, ShadingPoint, Vpl, VplClustering, VplSource, MISS,
};

/// Points as clustering takes them: positions and normals.
pub type PointSet = (Vec<Vec3>, Vec<Vec3>);

/// The CPU's stages 1 and 2 of a frame, and the hits among its samples.
pub struct CpuFrame {
    pub sps: Vec<ShadingPoint>,
    /// Each sample's hit number (its visibility row), or [`MISS`].
    pub row_of: Vec<u32>,
    /// The samples that hit a surface, in sample order.
    pub hits: Vec<u32>,
    pub vpls: Vec<Vpl>,
}

impl CpuFrame {
    pub fn new(cs: &CpuScene, cfg: &FrameConfig) -> CpuFrame {
        let sps =
            vplgi_cpu::shading_points::shading_points(cs, &cfg.camera_params(cs.scene.camera));
        let hits: Vec<u32> =
            (0..sps.len() as u32).filter(|&i| !sps[i as usize].is_miss()).collect();
        let mut row_of = vec![MISS; sps.len()];
        for (r, &i) in hits.iter().enumerate() {
            row_of[i as usize] = r as u32;
        }
        let vpls = match cfg.vpl_source {
            VplSource::Paths => {
                vplgi_cpu::trace_vpls::trace_vpls(cs, &cfg.trace_params(), &vplgi_cpu::NoProgress)
                    .vpls
            }
            VplSource::Rsm => {
                vplgi_cpu::rsm_vpls::rsm_vpls(cs, &cfg.rsm_params(), &vplgi_cpu::NoProgress).vpls
            }
        };
        CpuFrame { sps, row_of, hits, vpls }
    }

    /// The hits as surface points (visibility rows when shading points are not clustered).
    pub fn hit_endpoints(&self) -> Vec<Endpoint> {
        self.hits.iter().map(|&i| Endpoint::of(&self.sps[i as usize])).collect()
    }

    /// The hits as clustering input.
    pub fn hit_points(&self) -> PointSet {
        self.hits
            .iter()
            .map(|&i| {
                (Vec3::from(self.sps[i as usize].position), Vec3::from(self.sps[i as usize].normal))
            })
            .unzip()
    }

    /// Hits before each camera sample, one entry past the last (the GPU's hit offsets).
    pub fn sample_offsets(&self) -> Vec<u32> {
        let mut offsets = Vec::with_capacity(self.sps.len() + 1);
        let mut before = 0u32;
        for &row in &self.row_of {
            offsets.push(before);
            before += (row != MISS) as u32;
        }
        offsets.push(before);
        offsets
    }

    /// The adaptive seeds of the frame's hits (`--seeding adaptive`), on the CPU.
    pub fn adaptive_seeds(&self, cfg: &FrameConfig, extent: f32) -> Vec<u32> {
        let (p, n) = self.hit_points();
        let offsets = self.sample_offsets();
        let pixel_first: Vec<u32> = offsets.iter().step_by(cfg.spp as usize).copied().collect();
        let image = ImageHits {
            positions: &p,
            normals: &n,
            pixel_first: &pixel_first,
            width: cfg.width,
            height: cfg.height,
        };
        seeding(&image, &cfg.seed_params(extent))
    }

    /// The G-buffer points the RSM importance map is accumulated from (the hits among
    /// `rsm_importance::pixel_samples`).
    pub fn gbuffer_points(&self, cfg: &FrameConfig) -> Vec<Endpoint> {
        let samples = rsm_importance::pixel_samples(cfg.width, cfg.height, cfg.spp);
        samples
            .iter()
            .filter(|&&s| self.row_of[s as usize] != MISS)
            .map(|&s| Endpoint::of(&self.sps[s as usize]))
            .collect()
    }

    /// The importance map of the frame's RSM clustering, if it is seeded by one.
    pub fn rsm_importance(&self, cs: &CpuScene, cfg: &FrameConfig) -> Option<Vec<f32>> {
        (cfg.vpl_cluster == VplClustering::Rsm && cfg.rsm_seeding == RsmSeeding::Importance).then(
            || {
                let maps = cs.lights.rsm_maps(cfg.rsm_size);
                vplgi_cpu::rsm_importance::rsm_importance(
                    &self.vpls,
                    &maps,
                    &self.gbuffer_points(cfg),
                    rsm_importance::D_MIN_REL * cs.extent,
                )
            },
        )
    }

    /// The VPLs as clustering input.
    pub fn vpl_points(&self) -> PointSet {
        self.vpls.iter().map(|v| (Vec3::from(v.position), Vec3::from(v.normal))).unzip()
    }
}

/// The CPU's stage 3 of a frame in the frame's mode: lights, the visibility rows and columns, and
/// the shading-point clustering if there is one.
pub struct CpuClusters {
    pub lights: VplLights,
    /// The VPL clustering the lights come from, if VPLs are clustered.
    pub vpl_clusters: Option<Clustering>,
    pub cols: Vec<Endpoint>,
    /// One per hit, or one per shading-point cluster (its representative).
    pub rows: Vec<Endpoint>,
    pub sp_clusters: Option<Clustering>,
}

impl CpuClusters {
    pub fn new(cs: &CpuScene, frame: &CpuFrame, cfg: &FrameConfig) -> CpuClusters {
        let vpl_clusters =
            (cfg.cluster.clusters_vpls() && !frame.vpls.is_empty()).then(|| {
                match cfg.vpl_cluster {
                    VplClustering::Eq7 => {
                        let (p, n) = frame.vpl_points();
                        cluster(&p, &n, &cfg.vpl_cluster_params())
                    }
                    VplClustering::Rsm => {
                        let importance = frame.rsm_importance(cs, cfg);
                        vplgi_cpu::rsm_cluster::rsm_cluster(
                            &frame.vpls,
                            &cs.lights.rsm_maps(cfg.rsm_size),
                            &cfg.rsm_cluster_params(cs.extent),
                            importance.as_deref(),
                        )
                    }
                }
            });
        let lights =
            vplgi_cpu::shade::vpl_lights(&frame.vpls, vpl_clusters.as_ref(), cfg.light_shape);
        let cols = lights.lights.iter().map(VplLight::endpoint).collect();
        let sp_clusters = (cfg.cluster.clusters_sps() && !frame.hits.is_empty()).then(|| {
            let (p, n) = frame.hit_points();
            let seeds =
                (cfg.seeding == Seeding::Adaptive).then(|| frame.adaptive_seeds(cfg, cs.extent));
            cluster_from(
                &p,
                &n,
                &cfg.sp_cluster_params(cs.extent),
                seeds.as_deref().map_or(ClusterStart::Stride, ClusterStart::Seeds),
            )
        });
        let rows = match &sp_clusters {
            Some(c) => c
                .representatives
                .iter()
                .map(|&r| Endpoint::of(&frame.sps[frame.hits[r as usize] as usize]))
                .collect(),
            None => frame.hit_endpoints(),
        };
        CpuClusters { lights, vpl_clusters, cols, rows, sp_clusters }
    }

    /// The sample points' 1 / R_j (`--shade interpolate`: the rows are the sample points).
    pub fn inv_radius(&self, cs: &CpuScene, cfg: &FrameConfig) -> Vec<f32> {
        vplgi_cpu::gather_radius::gather_radius(cs, &self.rows, &cfg.gather_params())
    }
}
