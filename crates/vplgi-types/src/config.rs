//! The parameters of one frame, shared by the CPU and GPU pipelines, the CLI, tests and benches.

use serde::{Deserialize, Serialize};

/// Which point sets are clustered: the paper's ablation (section 4). `None` is the reference:
/// every shading point against every VPL with its own shadow ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum ClusterMode {
    /// No clustering: the unclustered reference, every shading point x every VPL.
    None,
    /// Cluster shading points only: visibility per SP cluster x VPL.
    Sp,
    /// Cluster VPLs only: visibility per pixel x VPL cluster.
    Vpl,
    /// Cluster both shading points and VPLs (the paper's method).
    Both,
}

impl ClusterMode {
    pub fn clusters_sps(self) -> bool {
        matches!(self, ClusterMode::Sp | ClusterMode::Both)
    }
    pub fn clusters_vpls(self) -> bool {
        matches!(self, ClusterMode::Vpl | ClusterMode::Both)
    }
}

/// How the visibility of a shading point's F clusters is combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FuzzyMode {
    /// F = 1: the visibility of the nearest shading-point cluster only.
    Hard,
    /// Plain mean over the F nearest clusters (Eq. 8).
    Average,
    /// Inverse-distance weighted mean over the F nearest clusters (Eq. 9 and 10).
    Weighted,
}

/// What a VPL cluster's light is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum LightShape {
    /// A point at the representative, its geometry term clamped (the core paper).
    #[default]
    Point,
    /// A disk at the representative whose radius comes from the members' spread, lit through the
    /// point-to-disk form factor (Eq. 2 of Prutkin et al. 2012) with no clamp; a cluster of one
    /// VPL has no extent and stays a clamped point (`vplgi_shared::disk`).
    Disk,
    /// The same disk lit by its exact form factor, in closed form: the integral Eq. 2
    /// approximates, with both cosines taken over the whole disk and the part below a receiver's
    /// horizon left out. It costs more per light (most where the horizon cuts the disk) and
    /// loses far less of the clusters' light than Eq. 2 does (`vplgi_shared::disk`).
    #[serde(rename = "disk-exact")]
    DiskExact,
    /// A convex polygon around the members in the representative's plane (their extent in 8
    /// directions), lit by its exact form factor with no clamp: unlike the disk it ends where
    /// the members end, so a cluster against a wall does not shine through it. The paper's other
    /// shape (its Fig. 3); a cluster whose members span no area stays a clamped point
    /// (`vplgi_shared::polygon`).
    Polygon,
}

impl LightShape {
    /// Whether a cluster becomes an area light (a disk or a polygon) rather than a point.
    pub fn is_area(self) -> bool {
        self != LightShape::Point
    }

    /// The shape's code in the GPU's uniforms (`LIGHT_SHAPE_*` in the generated WGSL prelude).
    pub fn code(self) -> u32 {
        self as u32
    }
}

/// Where the VPLs come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum VplSource {
    /// Light particles traced through `bounces` surfaces (`trace_vpls`, the core paper).
    #[default]
    Paths,
    /// A reflective shadow map per light, one VPL per texel that hits a surface (`rsm_vpls`,
    /// Prutkin et al. 2012): single-bounce indirect light.
    Rsm,
}

/// How VPLs are clustered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum VplClustering {
    /// The core paper's k-means with Eq. 7 over positions and normals (`cluster`).
    #[default]
    Eq7,
    /// Prutkin et al.'s k-means in reflective-shadow-map space with the metric μ of their Eq. 1
    /// (`rsm_cluster`); needs `--vpl-source rsm`.
    Rsm,
}

/// What "nearest" means when shading points are clustered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum SpMetric {
    /// The core paper's Eq. 7: Euclidean distance, with normals beyond n_t never in one cluster.
    #[default]
    Eq7,
    /// Wang et al. 2009, Eq. 2: alpha |x - c| + sqrt(2 - 2 n . m), alpha relative to the scene's
    /// diagonal (`--alpha`); no normal threshold.
    Ward,
}

/// Which member stands for a shading-point cluster (its visibility row's shading point).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum SpRepresentative {
    /// The member nearest the centroid (the core paper).
    #[default]
    Nearest,
    /// The member of smallest Eq. 2 error to the centroid, position and normal (Wang et al.
    /// 2009), with `--alpha`.
    MinError,
}

/// How the shading-point clustering picks its K initial centroids.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Seeding {
    /// K points evenly spread over the downsampled shading points (the core paper).
    #[default]
    Stride,
    /// Wang et al. 2009: a screen-space quadtree hands the K seeds down in proportion to each
    /// node's geometric variation under Eq. 2 (with --alpha), jittered inside a node.
    Adaptive,
}

/// Where the RSM clustering's seeds come from (`--vpl-cluster rsm`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum RsmSeeding {
    /// Points of the 2-D Halton sequence over each map, evenly.
    #[default]
    Halton,
    /// The paper's: the Halton points warped by the bidirectional importance map, the texels'
    /// geometry terms toward 256 G-buffer pixels times their flux, so clusters go where the
    /// camera sees their light.
    Importance,
}

/// Where the indirect light of clustered shading points comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ShadeMode {
    /// Every shading point sums every VPL light, with the visibility of its F clusters'
    /// representatives (Eq. 8-10, the core paper).
    #[default]
    Fuzzy,
    /// Wang et al. 2009: the VPL lights are summed only at each cluster's sample point (its
    /// representative, with its own visibility row), and every shading point interpolates its F
    /// nearest clusters' sums with irradiance-caching weights, R_j measured by `--gather-rays`.
    /// Refused on scenes with rough metal: a glossy receiver's light is not a multiple of its
    /// irradiance.
    Interpolate,
}

/// Whether a frame of a sequence starts its shading-point clustering from the previous frame's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Temporal {
    /// Every frame clusters from its own seeds.
    #[default]
    Off,
    /// Wang et al. 2009: the previous frame's clusters that still admit a shading point are kept
    /// (each admits points up to its members' largest error), new clusters are seeded where
    /// none does, and the iterations start from both. With `--vpl-cluster rsm`, Prutkin et al.'s
    /// warm start too: the previous frame's live RSM clusters start the next frame's, and only
    /// the slots of clusters that emptied are seeded.
    On,
}

/// Which light a frame's image holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Lighting {
    /// Emission, direct light and indirect light.
    #[default]
    All,
    /// The VPLs' light only (with bias compensation, its levels too): what clustering changes,
    /// and what a sequence's flicker is measured on.
    Indirect,
}

/// Whether the light that reaches surfaces straight from mirrors and glass is in the image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Caustics {
    /// No: VPLs and shadow rays cannot carry it (a shadow ray stops at glass, and no VPL sits on
    /// a mirror), so mirrors and glass cast shadows and throw no light.
    #[default]
    Off,
    /// A caustic photon map (Jensen; Wang et al. 2009, section 3.4): light particles that pass a
    /// mirror or glass leave a photon at the next surface, and every shading point (and bias
    /// compensation point) adds the k nearest photons' density. Needs `--lighting all`.
    Photons,
}

/// What carries the indirect light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Gi {
    /// Virtual point lights with shadow rays (the core paper).
    #[default]
    Vpl,
    /// Wang et al. 2009: a global photon map, its illumination cut, and final gathering at the
    /// shading-point clusters' representatives, interpolated to every shading point. Needs
    /// clustered shading points and `--shade interpolate`; add `--caustics photons` for the
    /// light mirrors and glass throw. Rough metal takes the glossy last bounce: each
    /// representative's incident light in order-4 spherical harmonics, integrated against the
    /// receiver's lobe. Order 4 holds broad lobes only: glTF roughness 0.6 and above (GGX α
    /// ≥ 0.36) keeps its reflection; below, highlights widen to the bands' blur.
    Photon,
}

/// Named frame configurations: the paper's three settings (section 4), its unclustered
/// reference, and vplgi's default operating point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// `--cluster none`: every shading point against every VPL.
    Reference,
    /// The paper's light setting: 750 VPL / 1,000 SP clusters.
    Light,
    /// The paper's intermediate setting: 2,000 VPL / 8,000 SP clusters.
    Intermediate,
    /// The paper's high-quality setting: 4,000 VPL / 30,000 SP clusters.
    High,
    /// vplgi's default: 1,000 VPL / 8,000 SP clusters.
    Default,
    /// `vplgi verify`'s default: the default method on a small frame (128x128, 2,000 VPLs,
    /// 250 VPL / 1,500 SP clusters), so every stage runs on both backends in seconds.
    Verify,
    /// Wang et al. 2009's photon pipeline: `--gi photon` with 4,000 shading-point clusters
    /// (adaptive seeds, Eq. 2, min-error representatives), 256 final-gather rays each, and the
    /// caustic map.
    Photon,
}

impl Preset {
    pub fn config(self) -> FrameConfig {
        match self {
            Preset::Reference => FrameConfig::reference(),
            Preset::Light => FrameConfig::paper_light(),
            Preset::Intermediate => FrameConfig::paper_intermediate(),
            Preset::High => FrameConfig::paper_high(),
            Preset::Default => FrameConfig::default(),
            Preset::Verify => FrameConfig::verify(),
            Preset::Photon => FrameConfig::photon(),
        }
    }
}

/// Everything that determines one frame. Two runs with equal configs and scenes produce
/// bit-identical images.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameConfig {
    pub width: u32,
    pub height: u32,
    /// Camera samples (shading points) per pixel; > 1 jitters them inside the pixel.
    pub spp: u32,
    pub seed: u32,
    /// Number of VPLs created.
    pub vpls: u32,
    /// VPLs are deposited at the first `bounces` surfaces a light particle hits.
    pub bounces: u32,
    pub cluster: ClusterMode,
    pub fuzzy: FuzzyMode,
    /// Fuzziness: how many SP clusters a shading point belongs to (forced to 1 by `Hard`).
    pub f: u32,
    pub k_sp: u32,
    pub k_vpl: u32,
    /// Downsampling factor gamma of Alg. 1: the k-means iterations run on every gamma-th point.
    pub gamma: u32,
    /// K-means iterations of Alg. 1.
    pub iterations: u32,
    /// n_t of Eq. 7: points whose normals have a smaller dot product are never in one cluster.
    pub normal_threshold: f32,
    /// The geometry term cos*cos/d^2 is clamped at 1/d_min^2 with d_min = this times the scene's
    /// bounding-box diagonal (removes VPL splotches).
    pub g_clamp_rel: f32,
    /// Shadow-ray samples per shading point for area lights (direct light).
    pub direct_samples: u32,
    /// Put back the light the geometry-term clamp removes (Kollig and Keller's bias
    /// compensation): from each shading point, a cosine-sampled segment to the surface it sees;
    /// where the clamp bit that pair, the surface's reflected light weighted by the clamped share
    /// 1 - g_max / G is added, computed as a shading point of its own (`bias_points`), and so on
    /// for up to `bounces` levels. Unbiased with respect to the unclamped transport, at the cost of
    /// extra visibility rows where surfaces are close. Off in the paper's clustered settings,
    /// whose clamp is part of what they measure; on in the reference. Files written before the
    /// option existed read as off.
    #[serde(default)]
    pub bias_compensation: bool,
    /// Point or disk lights for VPL clusters (single VPLs are always points). Files written
    /// before the option existed read as points.
    #[serde(default)]
    pub light_shape: LightShape,
    /// Where the VPLs come from. Files written before the option existed read as paths.
    #[serde(default)]
    pub vpl_source: VplSource,
    /// With `VplSource::Rsm`: texels per side of the maps' budget, about `rsm_size²` texels over
    /// all lights, each light's map sized by its power.
    #[serde(default = "default_rsm_size")]
    pub rsm_size: u32,
    /// How VPLs are clustered (where they are: `cluster` vpl or both).
    #[serde(default)]
    pub vpl_cluster: VplClustering,
    /// With `VplClustering::Rsm`: the weights of Eq. 1 (position, normal, flux colour).
    #[serde(default)]
    pub rsm_weights: crate::rsm::RsmWeights,
    /// With `VplClustering::Rsm`: where its seeds come from. Files written before the option
    /// existed read as Halton.
    #[serde(default)]
    pub rsm_seeding: RsmSeeding,
    /// The metric of the shading points' clustering. Files written before the option existed
    /// read as Eq. 7.
    #[serde(default)]
    pub metric: SpMetric,
    /// α of Eq. 2 (Wang et al. 2009) per scene bounding-box diagonal, for `SpMetric::Ward` and
    /// `SpRepresentative::MinError`: an Eq. 2 error of 1 is a normal turned by 60° or a move of
    /// 1/α diagonals.
    #[serde(default = "default_alpha")]
    pub alpha: f32,
    /// Which member stands for each shading-point cluster. Files written before the option
    /// existed read as the nearest.
    #[serde(default)]
    pub representative: SpRepresentative,
    /// How the shading-point clustering is seeded. Files written before the option existed read
    /// as the stride.
    #[serde(default)]
    pub seeding: Seeding,
    /// Where clustered shading points' indirect light comes from. Files written before the
    /// option existed read as fuzzy visibility.
    #[serde(default)]
    pub shade: ShadeMode,
    /// Gather rays per sample point for R_j of `ShadeMode::Interpolate`.
    #[serde(default = "default_gather_rays")]
    pub gather_rays: u32,
    /// Which light the image holds. Files written before the option existed read as all.
    #[serde(default)]
    pub lighting: Lighting,
    /// Clusters carried between the frames of a sequence. Files written before the option
    /// existed read as off.
    #[serde(default)]
    pub temporal: Temporal,
    /// Mirrors and glass a camera ray follows to the surface that becomes its shading point.
    /// Files written before the option existed read as 6.
    #[serde(default = "default_specular_depth")]
    pub specular_depth: u32,
    /// Whether caustic light is in the image. Files written before the option existed read as
    /// off.
    #[serde(default)]
    pub caustics: Caustics,
    /// With `Caustics::Photons`: caustic photons to store.
    #[serde(default = "default_caustic_photons")]
    pub caustic_photons: u32,
    /// With `Caustics::Photons`: photons per density estimate.
    #[serde(default = "default_caustic_k")]
    pub caustic_k: u32,
    /// With `Caustics::Photons`: the largest estimate radius, per scene bounding-box diagonal.
    #[serde(default = "default_caustic_radius")]
    pub caustic_radius: f32,
    /// With `Caustics::Photons`: photons per leaf of the map's kd-tree at most.
    #[serde(default = "default_photon_leaf")]
    pub photon_leaf: u32,
    /// What carries the indirect light. Files written before the option existed read as VPLs.
    #[serde(default)]
    pub gi: Gi,
    /// With `Gi::Photon`: photons of the global map.
    #[serde(default = "default_global_photons")]
    pub global_photons: u32,
    /// With `Gi::Photon`: the illumination cut's target size, in tree nodes.
    #[serde(default = "default_cut_size")]
    pub cut_size: u32,
    /// With `Gi::Photon`: the cut's refinement passes.
    #[serde(default = "default_cut_refinements")]
    pub cut_refinements: u32,
    /// With `Gi::Photon`: photons per density estimate at a cut node.
    #[serde(default = "default_caustic_k")]
    pub photon_k: u32,
}

/// Within Wang et al.'s global maps (239k to 470k photons, Table 1).
fn default_global_photons() -> u32 {
    250_000
}

/// Wang et al.'s smaller cut (Table 1: 4k or 8k).
fn default_cut_size() -> u32 {
    4096
}

/// Within Wang et al.'s 3 to 5 passes.
fn default_cut_refinements() -> u32 {
    4
}

/// Within Wang et al.'s caustic maps (24k to 277k photons, Table 1).
fn default_caustic_photons() -> u32 {
    100_000
}

/// Jensen's usual k; Wang et al. do not give theirs.
fn default_caustic_k() -> u32 {
    50
}

/// Wide enough that only sparse regions meet it, where it bounds the blur.
fn default_caustic_radius() -> f32 {
    0.05
}

fn default_photon_leaf() -> u32 {
    crate::params::DEFAULT_PHOTON_LEAF
}

fn default_specular_depth() -> u32 {
    crate::params::DEFAULT_SPECULAR_DEPTH
}

fn default_gather_rays() -> u32 {
    crate::interpolation::DEFAULT_GATHER_RAYS
}

/// Wang et al. use α = 0.1 to 0.5 after normalising the scene's size; vplgi divides by the
/// bounding-box diagonal and takes the middle of that range.
fn default_alpha() -> f32 {
    0.3
}

/// The paper's Cornell-box RSM (Table 1): 128².
fn default_rsm_size() -> u32 {
    128
}

/// Largest `specular_depth`: a bound on the rays one camera sample may trace.
pub const MAX_SPECULAR_DEPTH: u32 = 32;

/// Largest `rsm_size`: 4096² texels hold 16 M VPL slots (768 MiB).
pub const MAX_RSM_SIZE: u32 = 4096;

impl FrameConfig {
    /// The unclustered reference.
    pub fn reference() -> Self {
        FrameConfig {
            width: 512,
            height: 512,
            spp: 1,
            seed: 1,
            vpls: 10_000,
            bounces: 3,
            cluster: ClusterMode::None,
            fuzzy: FuzzyMode::Weighted,
            f: 6,
            k_sp: 8_000,
            k_vpl: 1_000,
            gamma: 4,
            iterations: 10,
            normal_threshold: 0.866_025_4, // cos 30 degrees = sqrt(3)/2
            g_clamp_rel: 0.05,
            // Stratified (shade::direct): 8 samples cost the default Cornell box render about 4 %
            // more time than 4 and leave 0.73x the relMSE against a converged image.
            direct_samples: 8,
            bias_compensation: true,
            light_shape: LightShape::Point,
            vpl_source: VplSource::Paths,
            rsm_size: default_rsm_size(),
            vpl_cluster: VplClustering::Eq7,
            rsm_weights: crate::rsm::RsmWeights::default(),
            rsm_seeding: RsmSeeding::Importance,
            metric: SpMetric::Eq7,
            alpha: default_alpha(),
            representative: SpRepresentative::Nearest,
            seeding: Seeding::Stride,
            shade: ShadeMode::Fuzzy,
            gather_rays: default_gather_rays(),
            lighting: Lighting::All,
            temporal: Temporal::Off,
            specular_depth: default_specular_depth(),
            caustics: Caustics::Off,
            caustic_photons: default_caustic_photons(),
            caustic_k: default_caustic_k(),
            caustic_radius: default_caustic_radius(),
            photon_leaf: default_photon_leaf(),
            gi: Gi::Vpl,
            global_photons: default_global_photons(),
            cut_size: default_cut_size(),
            cut_refinements: default_cut_refinements(),
            photon_k: default_caustic_k(),
        }
    }

    fn clustered(k_vpl: u32, k_sp: u32) -> Self {
        FrameConfig {
            cluster: ClusterMode::Both,
            k_vpl,
            k_sp,
            bias_compensation: false,
            ..Self::reference()
        }
    }

    /// The paper's light setting: 0.75k VPL clusters, 1k SP clusters.
    pub fn paper_light() -> Self {
        Self::clustered(750, 1_000)
    }
    /// The paper's intermediate setting: 2k VPL clusters, 8k SP clusters.
    pub fn paper_intermediate() -> Self {
        Self::clustered(2_000, 8_000)
    }
    /// The paper's high-quality setting: 4k VPL clusters, 30k SP clusters.
    pub fn paper_high() -> Self {
        Self::clustered(4_000, 30_000)
    }

    /// Small enough for `vplgi verify` to run every stage of every mode on both backends in
    /// seconds, large enough that each cluster has about ten members.
    pub fn verify() -> Self {
        FrameConfig { width: 128, height: 128, vpls: 2_000, ..Self::clustered(250, 1_500) }
    }

    /// Wang et al. 2009's pipeline as they run it: shading points clustered by their adaptive
    /// seeding, Eq. 2 and min-error representatives into 4k clusters (Table 1: 1.6k to 5k),
    /// a final gather of 256 rays at each (their 250 to 500) lit by the global map's cut, and
    /// the caustic map.
    pub fn photon() -> Self {
        FrameConfig {
            cluster: ClusterMode::Sp,
            k_sp: 4_000,
            seeding: Seeding::Adaptive,
            metric: SpMetric::Ward,
            representative: SpRepresentative::MinError,
            shade: ShadeMode::Interpolate,
            gather_rays: 256,
            gi: Gi::Photon,
            caustics: Caustics::Photons,
            bias_compensation: false,
            ..Self::reference()
        }
    }

    /// The fuzziness actually used: `Hard` means one cluster whatever `f` says.
    pub fn effective_f(&self) -> u32 {
        crate::clustering::effective_f(self.fuzzy, self.f)
    }

    /// The clustering of the VPLs (hard, K_VPL clusters), as every backend runs it.
    pub fn vpl_cluster_params(&self) -> crate::clustering::ClusterParams {
        crate::clustering::ClusterParams {
            k: self.k_vpl,
            gamma: self.gamma,
            iterations: self.iterations,
            f: 1,
            fuzzy: FuzzyMode::Hard,
            metric: crate::clustering::Metric::Eq7 { normal_threshold: self.normal_threshold },
            representative: crate::clustering::Representative::Nearest,
            seed: self.seed,
        }
    }

    /// The clustering of the shading points (F-fuzzy, K_SP clusters) in a scene of bounding-box
    /// diagonal `extent`, as every backend runs it: `extent` turns the scene-relative α of
    /// Eq. 2 into one per unit length.
    pub fn sp_cluster_params(&self, extent: f32) -> crate::clustering::ClusterParams {
        use crate::clustering::{Metric, Representative};
        let alpha = self.alpha / extent.max(f32::MIN_POSITIVE);
        crate::clustering::ClusterParams {
            k: self.k_sp,
            gamma: self.gamma,
            iterations: self.iterations,
            f: self.effective_f(),
            fuzzy: self.fuzzy,
            metric: match self.metric {
                SpMetric::Eq7 => Metric::Eq7 { normal_threshold: self.normal_threshold },
                SpMetric::Ward => Metric::Ward { alpha },
            },
            representative: match self.representative {
                SpRepresentative::Nearest => Representative::Nearest,
                SpRepresentative::MinError => Representative::MinError { alpha },
            },
            seed: self.seed.wrapping_add(1),
        }
    }

    /// The adaptive seeding of the shading points (`Seeding::Adaptive`) in a scene of
    /// bounding-box diagonal `extent`: K_SP seeds, Eq. 2 with α per unit length, the
    /// shading-point clustering's seed.
    pub fn seed_params(&self, extent: f32) -> crate::params::SeedParams {
        crate::params::SeedParams {
            k: self.k_sp,
            alpha: self.alpha / extent.max(f32::MIN_POSITIVE),
            seed: self.seed.wrapping_add(1),
        }
    }

    /// The parameters of the sample points' gather rays (`ShadeMode::Interpolate`).
    pub fn gather_params(&self) -> crate::interpolation::GatherParams {
        crate::interpolation::GatherParams { seed: self.seed, rays: self.gather_rays }
    }

    /// The parameters of `trace_vpls`.
    pub fn rsm_params(&self) -> crate::RsmParams {
        crate::RsmParams {
            size: self.rsm_size,
            seed: self.seed,
            specular_depth: self.specular_depth,
        }
    }

    pub fn trace_params(&self) -> crate::TraceParams {
        crate::TraceParams {
            seed: self.seed,
            count: self.vpls,
            bounces: self.bounces,
            specular_depth: self.specular_depth,
            deposit: crate::Deposit::Vpls,
        }
    }

    /// The parameters of `trace_vpls` for the caustic photon map: stored at the first
    /// `bounces + 1` surfaces of each path, since a photon lights the surface it lies on
    /// (a VPL lights the next one).
    pub fn caustic_trace_params(&self) -> crate::TraceParams {
        crate::TraceParams {
            count: self.caustic_photons,
            bounces: self.bounces + 1,
            deposit: crate::Deposit::CausticPhotons,
            ..self.trace_params()
        }
    }

    /// The parameters of `trace_vpls` for the global photon map (`Gi::Photon`): every
    /// non-specular surface of the first `bounces` holds a photon with the power that arrived,
    /// caustic ones included (Jensen's global map). A photon lights the surface it lies on and a
    /// gather ray carries that light one bounce further, so paths are as long as with VPLs.
    pub fn global_trace_params(&self) -> crate::TraceParams {
        crate::TraceParams {
            count: self.global_photons,
            deposit: crate::Deposit::Photons,
            ..self.trace_params()
        }
    }

    /// The parameters of the illumination cut (`Gi::Photon`) in a scene of diagonal `extent`.
    pub fn cut_params(&self, extent: f32) -> crate::CutParams {
        crate::CutParams {
            size: self.cut_size,
            refinements: self.cut_refinements,
            k: self.photon_k,
            max_radius: self.caustic_radius * extent,
            min_radius: crate::params::MIN_CUT_RADIUS_REL * extent,
        }
    }

    /// Whether indirect light comes from photons.
    pub fn has_photons(&self) -> bool {
        self.gi == Gi::Photon
    }

    /// Whether the frame adds caustic light.
    pub fn has_caustics(&self) -> bool {
        self.caustics == Caustics::Photons
    }

    /// The parameters of `caustics` in a scene of diagonal `extent`, at bias-compensation level
    /// `level` (0: the camera's shading points): photons of paths that, with the level's
    /// surfaces, are no longer than the frame's.
    pub fn caustic_params(&self, extent: f32, level: u32) -> crate::CausticParams {
        crate::CausticParams {
            k: self.caustic_k,
            max_radius: self.caustic_radius * extent,
            max_bounce: (self.bounces + 1).saturating_sub(level),
            spp: self.spp,
        }
    }

    /// The RSM-space clustering of the VPLs (`VplClustering::Rsm`) in a scene of diagonal
    /// `extent`: K_VPL clusters, the frame's iterations and Eq. 1's weights.
    pub fn rsm_cluster_params(&self, extent: f32) -> crate::rsm::RsmClusterParams {
        crate::rsm::RsmClusterParams {
            k: self.k_vpl,
            iterations: self.iterations,
            weights: self.rsm_weights,
            extent,
        }
    }

    /// The parameters of `shading_points`.
    pub fn camera_params(&self, camera: crate::Camera) -> crate::CameraParams {
        crate::CameraParams {
            camera,
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            specular_depth: self.specular_depth,
        }
    }

    /// The clamp's bound on the geometry term for a scene of bounding-box diagonal `extent`:
    /// 1 / d_min² with d_min = `g_clamp_rel` * extent, or infinity without a clamp.
    pub fn g_max(&self, extent: f32) -> f32 {
        let d_min = self.g_clamp_rel * extent;
        if d_min > 0.0 {
            1.0 / (d_min * d_min)
        } else {
            f32::INFINITY
        }
    }

    /// The parameters of `shade` for a scene of bounding-box diagonal `extent`.
    pub fn shade_params(&self, extent: f32) -> crate::ShadeParams {
        crate::ShadeParams {
            spp: self.spp,
            seed: self.seed,
            direct_samples: self.direct_samples,
            g_max: self.g_max(extent),
            direct: self.lighting == Lighting::All,
        }
    }

    /// The parameters of `bias_points` at compensation level `level` (1 ..= `bounces`).
    pub fn bias_params(&self, extent: f32, level: u32) -> crate::BiasParams {
        crate::BiasParams {
            seed: crate::params::level_seed(self.seed, level),
            g_max: self.g_max(extent),
        }
    }

    /// Checks ranges; the message names the offending parameter.
    pub fn validate(&self) -> Result<(), String> {
        if self.specular_depth > MAX_SPECULAR_DEPTH {
            return Err(format!(
                "specular-depth must be at most {MAX_SPECULAR_DEPTH} (got {})",
                self.specular_depth
            ));
        }
        let positive = [
            ("width", self.width),
            ("height", self.height),
            ("spp", self.spp),
            ("bounces", self.bounces),
            ("k-sp", self.k_sp),
            ("k-vpl", self.k_vpl),
            ("gamma", self.gamma),
            ("F", self.f),
            ("direct-samples", self.direct_samples),
        ];
        for (name, v) in positive {
            if v == 0 {
                return Err(format!("{name} must be at least 1"));
            }
        }
        if self.f > MAX_F {
            return Err(format!("F must be at most {MAX_F} (got {})", self.f));
        }
        let points = self.width as u64 * self.height as u64 * self.spp as u64;
        if points > (1 << 28) {
            return Err(format!(
                "width x height x spp must be at most 2^28 shading points (got {points})"
            ));
        }
        if !(-1.0..1.0).contains(&self.normal_threshold) {
            // n1 . n2 > 1 never holds: every point would be incompatible with every centroid.
            return Err("normal threshold must be in [-1, 1)".into());
        }
        if !(self.alpha > 0.0 && self.alpha.is_finite()) {
            // Eq. 2 with alpha = 0 ignores positions: a cluster could span the whole scene.
            return Err(format!("alpha must be a finite number > 0 (got {})", self.alpha));
        }
        let rsm_clusters = self.cluster.clusters_vpls() && self.vpl_cluster == VplClustering::Rsm;
        if self.temporal == Temporal::On && !self.cluster.clusters_sps() && !rsm_clusters {
            return Err(format!(
                "temporal on carries shading-point clusters (--cluster sp or both) or RSM clusters (--cluster vpl or both with --vpl-cluster rsm) between frames (got --cluster {})",
                format!("{:?}", self.cluster).to_lowercase()
            ));
        }
        if self.shade == ShadeMode::Interpolate {
            if !self.cluster.clusters_sps() {
                // Sample points are the shading-point clusters' representatives.
                return Err(format!(
                    "shade interpolate interpolates between shading-point clusters: use --cluster sp or both (got {})",
                    format!("{:?}", self.cluster).to_lowercase()
                ));
            }
            let max = crate::interpolation::MAX_GATHER_RAYS;
            if !(1..=max).contains(&self.gather_rays) {
                return Err(format!(
                    "gather-rays must be between 1 and {max} (got {})",
                    self.gather_rays
                ));
            }
        }
        if !(self.g_clamp_rel >= 0.0 && self.g_clamp_rel.is_finite()) {
            return Err("g-clamp must be a finite number >= 0".into());
        }
        if self.vpl_source == VplSource::Rsm {
            if self.bounces != 1 {
                return Err(format!(
                    "vpl-source rsm makes single-bounce VPLs (one per shadow-map texel): use --bounces 1 (got {}), or --vpl-source paths for more bounces",
                    self.bounces
                ));
            }
            if !(1..=MAX_RSM_SIZE).contains(&self.rsm_size) {
                return Err(format!(
                    "rsm-size must be between 1 and {MAX_RSM_SIZE} texels per side (got {})",
                    self.rsm_size
                ));
            }
        }
        if self.vpl_cluster == VplClustering::Rsm {
            if self.vpl_source != VplSource::Rsm {
                return Err("vpl-cluster rsm clusters VPLs by their shadow-map texels: it needs --vpl-source rsm".into());
            }
            self.rsm_weights.validate()?;
        }
        if self.caustics == Caustics::Photons {
            if self.lighting != Lighting::All {
                return Err("caustics photons adds light that VPLs do not carry, and --lighting indirect keeps only the VPLs' light: use one or the other".into());
            }
            let max_k = crate::params::MAX_CAUSTIC_K;
            if !(1..=max_k).contains(&self.caustic_k) {
                return Err(format!(
                    "caustic-k must be between 1 and {max_k} (got {})",
                    self.caustic_k
                ));
            }
            if self.caustic_photons < self.caustic_k {
                return Err(format!(
                    "caustic-photons ({}) must be at least caustic-k ({}): an estimate takes the k nearest photons",
                    self.caustic_photons, self.caustic_k
                ));
            }
        }
        if self.gi == Gi::Photon {
            if !self.cluster.clusters_sps() || self.shade != ShadeMode::Interpolate {
                return Err("gi photon gathers at the shading-point clusters' representatives and interpolates between them: use --cluster sp (or both) with --shade interpolate, or --preset photon".into());
            }
            if self.vpl_source != VplSource::Paths {
                return Err(
                    "gi photon traces photons along light paths: use --vpl-source paths".into()
                );
            }
            let max_k = crate::params::MAX_CAUSTIC_K;
            // An estimate sums the k - 1 photons strictly inside the k-th: k = 1 sums none.
            if !(2..=max_k).contains(&self.photon_k) {
                return Err(format!(
                    "photon-k must be between 2 and {max_k} (got {})",
                    self.photon_k
                ));
            }
            if self.global_photons < self.photon_k {
                return Err(format!(
                    "global-photons ({}) must be at least photon-k ({}): an estimate takes the k nearest photons",
                    self.global_photons, self.photon_k
                ));
            }
            if self.cut_size == 0 {
                return Err("cut-size must be at least 1".into());
            }
            if self.cut_refinements > crate::params::MAX_CUT_REFINEMENTS {
                return Err(format!(
                    "cut-refinements must be at most {} (got {})",
                    crate::params::MAX_CUT_REFINEMENTS,
                    self.cut_refinements
                ));
            }
        }
        if (self.caustics == Caustics::Photons || self.gi == Gi::Photon)
            && !(self.caustic_radius > 0.0 && self.caustic_radius.is_finite())
        {
            return Err(format!(
                "caustic-radius must be a finite number > 0 (got {})",
                self.caustic_radius
            ));
        }
        if (self.caustics == Caustics::Photons || self.gi == Gi::Photon)
            && !(1..=crate::params::MAX_PHOTON_LEAF).contains(&self.photon_leaf)
        {
            return Err(format!(
                "photon-leaf must be between 1 and {} (got {})",
                crate::params::MAX_PHOTON_LEAF,
                self.photon_leaf
            ));
        }
        if self.light_shape.is_area() && self.cluster.clusters_vpls() && self.bias_compensation {
            return Err(
                "bias compensation puts back what the clamp takes from point lights, and disk and polygon lights have no clamp: use one or the other".into()
            );
        }
        Ok(())
    }
}

/// Largest supported fuzziness F (the per-point index and weight arrays are fixed-size).
pub const MAX_F: u32 = 16;

impl Default for FrameConfig {
    /// The paper's Cornell-box operating point: 1k VPL clusters, 8k SP clusters, F = 6 weighted.
    fn default() -> Self {
        Self::clustered(1_000, 8_000)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The presets are the paper's light, intermediate and high settings (VPL / SP clusters),
    /// vplgi's default, verify's small frame and the unclustered reference; the cluster modes
    /// cluster what they say.
    #[test]
    fn presets_are_the_documented_settings() {
        let ks = |p: Preset| {
            let c = p.config();
            (c.cluster, c.k_vpl, c.k_sp)
        };
        assert_eq!(ks(Preset::Light), (ClusterMode::Both, 750, 1_000));
        assert_eq!(ks(Preset::Intermediate), (ClusterMode::Both, 2_000, 8_000));
        assert_eq!(ks(Preset::High), (ClusterMode::Both, 4_000, 30_000));
        assert_eq!(ks(Preset::Default), (ClusterMode::Both, 1_000, 8_000));
        // The clamp's bias is what the clustered settings measure; the reference puts it back.
        let r = Preset::Reference.config();
        assert_eq!((r.cluster, r.bias_compensation), (ClusterMode::None, true));
        for p in
            [Preset::Light, Preset::Intermediate, Preset::High, Preset::Default, Preset::Verify]
        {
            assert!(!p.config().bias_compensation, "{p:?}");
        }
        let v = Preset::Verify.config();
        assert_eq!(
            (v.cluster, v.width, v.height, v.vpls, v.k_vpl, v.k_sp),
            (ClusterMode::Both, 128, 128, 2_000, 250, 1_500)
        );
        let modes = [ClusterMode::None, ClusterMode::Sp, ClusterMode::Vpl, ClusterMode::Both];
        assert_eq!(
            modes.map(|m| (m.clusters_sps(), m.clusters_vpls())),
            [(false, false), (true, false), (false, true), (true, true)]
        );
    }

    /// What a config hands the clustering stages: `Hard` means F = 1 whatever `f` says (and
    /// F is at least 1), and α per scene diagonal becomes α per unit length, divided by the
    /// diagonal, for the metric, the representative rule and the adaptive seeding alike.
    #[test]
    fn cluster_params_turn_options_into_stage_inputs() {
        use crate::clustering::{Metric, Representative};
        let c = FrameConfig {
            f: 6,
            alpha: 0.3,
            metric: SpMetric::Ward,
            representative: SpRepresentative::MinError,
            ..FrameConfig::default()
        };
        let p = c.sp_cluster_params(2.0);
        assert_eq!(
            (p.f, p.metric, p.representative),
            (6, Metric::Ward { alpha: 0.15 }, Representative::MinError { alpha: 0.15 })
        );
        assert_eq!(c.seed_params(2.0).alpha, 0.15);
        let hard = FrameConfig { fuzzy: FuzzyMode::Hard, ..c.clone() };
        assert_eq!((hard.effective_f(), hard.sp_cluster_params(2.0).f), (1, 1));
        assert_eq!(FrameConfig { f: 0, ..c }.effective_f(), 1);
    }

    /// A config file written before the later options existed reads with each option's
    /// documented default: 128² RSM texels (the paper's Cornell-box map), α = 0.3 (the middle
    /// of Wang et al.'s 0.1 to 0.5), 16 gather rays, Halton RSM seeds, and the rest as
    /// `FrameConfig::default()`.
    #[test]
    fn files_from_before_an_option_read_its_documented_default() {
        let mut json = serde_json::to_value(FrameConfig::default()).unwrap();
        let later = [
            "bias_compensation",
            "light_shape",
            "vpl_source",
            "rsm_size",
            "vpl_cluster",
            "rsm_weights",
            "rsm_seeding",
            "metric",
            "alpha",
            "representative",
            "seeding",
            "shade",
            "gather_rays",
            "lighting",
            "temporal",
            "specular_depth",
            "caustics",
            "caustic_photons",
            "caustic_k",
            "caustic_radius",
            "photon_leaf",
        ];
        for key in later {
            assert!(json.as_object_mut().unwrap().remove(key).is_some(), "no field {key}");
        }
        let old: FrameConfig = serde_json::from_value(json).unwrap();
        // RSM seeding predates its importance map: old files keep the Halton seeds they had.
        assert_eq!(old, FrameConfig { rsm_seeding: RsmSeeding::Halton, ..FrameConfig::default() });
        assert_eq!((old.rsm_size, old.alpha, old.gather_rays), (128, 0.3, 16));
        assert_eq!(old.specular_depth, 6);
        assert_eq!(
            (old.caustics, old.caustic_photons, old.caustic_k, old.caustic_radius, old.photon_leaf),
            (Caustics::Off, 100_000, 50, 0.05, 8)
        );
    }

    /// The caustic map's options are checked only when caustics are on, and each bad value is
    /// named.
    #[test]
    fn caustic_options_are_checked_and_named() {
        let with = |f: fn(&mut FrameConfig)| {
            let mut c = FrameConfig { caustics: Caustics::Photons, ..FrameConfig::default() };
            f(&mut c);
            c.validate()
        };
        assert_eq!(with(|_| {}), Ok(()));
        assert!(with(|c| c.caustic_k = 0).unwrap_err().contains("caustic-k"));
        assert!(with(|c| c.caustic_k = 129).unwrap_err().contains("caustic-k"));
        assert!(with(|c| c.caustic_photons = 49).unwrap_err().contains("caustic-photons"));
        assert!(with(|c| c.caustic_radius = 0.0).unwrap_err().contains("caustic-radius"));
        assert!(with(|c| c.caustic_radius = f32::NAN).unwrap_err().contains("caustic-radius"));
        assert!(with(|c| c.photon_leaf = 0).unwrap_err().contains("photon-leaf"));
        assert!(with(|c| c.lighting = Lighting::Indirect).unwrap_err().contains("--lighting"));
        let off = FrameConfig { caustic_k: 0, caustic_photons: 0, ..FrameConfig::default() };
        assert_eq!(off.validate(), Ok(()));
        // A photon lights the surface it lies on: one surface more than the VPLs, and one less
        // at each bias-compensation level.
        let c = FrameConfig { bounces: 3, ..FrameConfig::default() };
        assert_eq!(c.caustic_trace_params().bounces, 4);
        assert_eq!(c.caustic_params(2.0, 0).max_bounce, 4);
        assert_eq!(c.caustic_params(2.0, 3).max_bounce, 1);
        assert_eq!(c.caustic_params(2.0, 0).max_radius, 0.1);
    }

    #[test]
    fn presets_validate_and_bad_values_are_named() {
        for c in [
            FrameConfig::default(),
            FrameConfig::verify(),
            FrameConfig::reference(),
            FrameConfig::paper_light(),
            FrameConfig::paper_intermediate(),
            FrameConfig::paper_high(),
        ] {
            assert_eq!(c.validate(), Ok(()));
        }
        let bad = |f: fn(&mut FrameConfig)| {
            let mut c = FrameConfig::default();
            f(&mut c);
            c.validate().unwrap_err()
        };
        assert!(bad(|c| c.spp = 0).contains("spp"));
        assert!(bad(|c| {
            c.light_shape = LightShape::Disk;
            c.bias_compensation = true;
        })
        .contains("bias compensation"));
        assert!(bad(|c| c.vpl_source = VplSource::Rsm).contains("--bounces 1"));
        assert!(bad(|c| c.vpl_cluster = VplClustering::Rsm).contains("--vpl-source rsm"));
        assert!(bad(|c| {
            (c.vpl_cluster, c.vpl_source, c.bounces) = (VplClustering::Rsm, VplSource::Rsm, 1);
            c.rsm_weights.normal = -1.0;
        })
        .contains("rsm-weights"));
        assert!(bad(|c| {
            c.vpl_source = VplSource::Rsm;
            c.bounces = 1;
            c.rsm_size = 0;
        })
        .contains("rsm-size"));
        assert!(bad(|c| c.f = 17).contains('F'));
        assert!(bad(|c| c.normal_threshold = 1.0).contains("normal threshold"));
        for g in [f32::NAN, -0.01, f32::INFINITY] {
            let c = FrameConfig { g_clamp_rel: g, ..FrameConfig::default() };
            assert!(c.validate().unwrap_err().contains("g-clamp"), "g-clamp {g}");
        }
        // Temporal coherence carries clusters from frame to frame: shading-point clusters, or
        // VPL clusters in RSM space; Eq. 7's VPL clusters alone have nothing to carry.
        let temporal = |cluster: ClusterMode, rsm: bool| {
            let mut c = FrameConfig { temporal: Temporal::On, cluster, ..FrameConfig::default() };
            if rsm {
                (c.vpl_cluster, c.vpl_source, c.bounces) = (VplClustering::Rsm, VplSource::Rsm, 1);
            }
            c.validate()
        };
        for (cluster, rsm) in
            [(ClusterMode::None, false), (ClusterMode::Vpl, false), (ClusterMode::None, true)]
        {
            assert!(
                temporal(cluster, rsm).unwrap_err().contains("temporal on"),
                "{cluster:?}, rsm {rsm}"
            );
        }
        for (cluster, rsm) in [
            (ClusterMode::Sp, false),
            (ClusterMode::Both, false),
            (ClusterMode::Vpl, true),
            (ClusterMode::Sp, true),
        ] {
            assert_eq!(temporal(cluster, rsm), Ok(()), "{cluster:?}, rsm {rsm}");
        }
        assert!(bad(|c| c.alpha = 0.0).contains("alpha"));
        assert!(bad(|c| c.alpha = f32::INFINITY).contains("alpha"));
        assert!(bad(|c| (c.shade, c.cluster) = (ShadeMode::Interpolate, ClusterMode::Vpl))
            .contains("--cluster sp or both"));
        assert!(
            bad(|c| (c.shade, c.gather_rays) = (ShadeMode::Interpolate, 0)).contains("gather-rays")
        );
        assert!(bad(|c| (c.width, c.height, c.spp) = (1 << 14, 1 << 14, 2))
            .contains("2^28 shading points (got 536870912)"));
        assert!(bad(|c| (c.width, c.height, c.spp) = (1 << 13, 1 << 13, 8)).contains("2^28"));
        let largest =
            FrameConfig { width: 1 << 14, height: 1 << 14, spp: 1, ..FrameConfig::default() };
        assert_eq!(largest.validate(), Ok(()), "2^28 shading points are allowed");
    }
}
