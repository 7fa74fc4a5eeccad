//! The stages of a frame, written once.
//!
//! [`stage_table!`] is the list: each row is a stage's name (its CPU module, GPU module, `.wgsl`
//! file, verify comparison, property test and bench are all named after it), the trait that
//! declares what it computes, and its parts (variants chosen by [`crate::FrameConfig`], timed
//! with the stage: their modules and shaders are named after the part, their comparisons, tests
//! and benches live in the stage's). Everything that enumerates stages expands the table:
//! [`Stage`], the [`Backend`] bound, the backends' module lists, the GPU pipelines, `vplgi
//! verify`'s rows, the bench binary and the Makefile's test and mutant lists; a test checks that
//! every row has all of its files.
//!
//! Below the table, one trait per stage and part: what the frame driver asks of it. A backend
//! implements each in the stage's own module (`vplgi-cpu/src/<stage>.rs`,
//! `vplgi-gpu/src/<stage>.rs`), on the storage its [`Storage`] names.

use crate::backend::{ClusterCounts, GatherCounts, RsmStart, ShadeInput, Storage};
use crate::frame::Progress;
use std::ops::Range;
use vplgi_shared::illumination_cut::{Densities, GatherCut};
use vplgi_shared::rsm::{RsmCentre, RsmClusterParams};
use vplgi_shared::seeding::SeedParams;
use vplgi_types::clustering::{Centre, ClusterParams, ClusterStart, Metric};
use vplgi_types::interpolation::GatherParams;
use vplgi_types::{
    BiasParams, CameraParams, CausticParams, CutNode, CutParams, Endpoint, RsmParams, ShadeParams,
    TraceParams,
};

/// The stages in pipeline order: `name Trait [part PartTrait, ...],`, one row per line (the
/// Makefile reads the names from these lines). Calls `$then!` with the rows.
#[macro_export]
macro_rules! stage_table {
    ($then:ident) => {
        $then! {
            /// Stage 1: VPLs from light particles.
            trace_vpls TraceVpls [],
            /// Stage 1 with `--vpl-source rsm`: VPLs from reflective shadow maps.
            rsm_vpls RsmVpls [],
            /// `--gi photon`: the global photon map's illumination cut (Eq. 3 and the density estimates of its refinement).
            illumination_cut IlluminationCut [],
            /// Stage 2: the camera rays' first hits.
            shading_points ShadingPoints [],
            /// Stage 3: Alg. 1 and 2, with its seeds (`--seeding adaptive`) and the RSM-space clustering of VPLs (`--vpl-cluster rsm`) with its importance seeds.
            cluster Cluster [seeding Seeding, rsm_importance RsmImportance, rsm_cluster RsmCluster],
            /// Stage 4: shadow rays between rows and columns.
            visibility Visibility [],
            /// `--shade interpolate`: the sample points' gather rays.
            gather_radius GatherRadius [],
            /// `--gi photon`: the sample points' gather rays, lit by the illumination cut (Eq. 4 and 5).
            final_gather FinalGather [],
            /// `--shade interpolate`: the irradiance at the sample points (the interpolation itself is part of `shade`).
            interpolate Interpolate [],
            /// Stage 5: the pixels' radiance.
            shade Shade [],
            /// `--caustics photons`: the caustic photon map's light at the shading points.
            caustics Caustics [],
            /// The bias compensation's segments (their visibility and shading count as `visibility` and `shade`).
            bias_points BiasPoints [],
        }
    };
}

/// `pub mod` of every stage and part: a backend's stage modules.
#[macro_export]
macro_rules! stage_modules {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        $(pub mod $name; $(pub mod $part;)*)*
    };
}

macro_rules! declare_stages {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        /// The stages of a frame, in pipeline order: what [`crate::StageTimings`] times.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Stage {
            $($(#[$doc])* $Trait,)*
        }

        impl Stage {
            /// Every stage, in pipeline order.
            pub const ALL: [Stage; [$(Stage::$Trait),*].len()] = [$(Stage::$Trait),*];

            /// The stage's name: the same for the CPU function, the GPU kernel, the shader, the
            /// verify comparison, the test and the bench.
            pub fn name(self) -> &'static str {
                match self {
                    $(Stage::$Trait => stringify!($name),)*
                }
            }

            /// The names of the stage's parts (variants timed as the stage).
            pub fn parts(self) -> &'static [&'static str] {
                match self {
                    $(Stage::$Trait => &[$(stringify!($part)),*],)*
                }
            }
        }

        /// One implementation of every stage and part, on the storage of [`Storage`]: what the
        /// frame driver ([`crate::render`]) needs of a backend.
        pub trait Backend: Storage $(+ $Trait $(+ $Part)*)* {}
        impl<B: Storage $(+ $Trait $(+ $Part)*)*> Backend for B {}

        /// Every stage trait and [`Storage`], for calling a backend's methods outside the driver:
        /// `use vplgi_frame::prelude::*`.
        pub mod prelude {
            pub use super::{Backend $(, $Trait $(, $Part)*)*};
            pub use crate::backend::{Counted, Storage};
        }
    };
}

stage_table!(declare_stages);

impl Stage {
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Stage 1: VPLs from light particles.
pub trait TraceVpls: Storage {
    /// The VPLs, and how many light particles were traced to make them.
    fn trace_vpls(
        &self,
        params: &TraceParams,
        progress: &dyn Progress,
    ) -> Result<(Self::Vpls, u32), Self::Error>;
}

/// Stage 1 with `--vpl-source rsm`.
pub trait RsmVpls: Storage {
    /// VPLs from the reflective shadow maps of every light for a budget of about `size²` texels,
    /// each texel's ray followed through mirrors and glass, and how many texels that was.
    fn rsm_vpls(
        &self,
        params: &RsmParams,
        progress: &dyn Progress,
    ) -> Result<(Self::Vpls, u32), Self::Error>;
}

/// `--gi photon`: the illumination cut of the global photon map (Wang et al. 2009, section
/// 3.3). The backend does the per-node arithmetic; `vplgi_shared::illumination_cut` chooses the
/// cut from it.
pub trait IlluminationCut: Storage {
    /// Every node of `map`'s tree: its representative (the member nearest its box's centre),
    /// radius r_p, and Eq. 3's estimate Ẽ_p, in tree order.
    fn node_estimates(
        &self,
        map: &Self::PhotonMap,
        params: &CutParams,
    ) -> Result<Vec<CutNode>, Self::Error>;

    /// The density estimate of irradiance at each of `points` from the `params.k` nearest
    /// photons of `map`, and whether its search stopped at the visit budget.
    fn densities(
        &self,
        map: &Self::PhotonMap,
        points: &[Endpoint],
        params: &CutParams,
    ) -> Result<Densities, Self::Error>;

    /// The chosen cut where final gathering reads it.
    fn upload_cut(&self, cut: GatherCut) -> Result<Self::Cut, Self::Error>;
}

/// Stage 2.
pub trait ShadingPoints: Storage {
    /// The shading points of camera samples `samples`.
    fn shading_points(
        &self,
        params: &CameraParams,
        samples: Range<u32>,
    ) -> Result<Self::Samples, Self::Error>;
}

/// Stage 3: Alg. 1 and 2.
pub trait Cluster: Storage {
    /// The clustering of `points`, from the initial centroids `start` says.
    fn cluster(
        &self,
        points: &Self::Points,
        params: &ClusterParams,
        start: ClusterStart<'_>,
    ) -> Result<(Self::Clustering, ClusterCounts), Self::Error>;

    /// `--temporal on`: the clusters of a clustering of `points` as the next frame's centres,
    /// each with its admission threshold (`vplgi_types::temporal`).
    fn cluster_centres(
        &self,
        clustering: &Self::Clustering,
        points: &Self::Points,
        metric: Metric,
    ) -> Result<Vec<Centre>, Self::Error>;

    /// Each cluster's representative member, as surface points.
    fn representatives(
        &self,
        clustering: &Self::Clustering,
        points: &Self::Points,
    ) -> Result<Self::Points, Self::Error>;
}

/// Stage 3's seeds with `--seeding adaptive`.
pub trait Seeding: Storage {
    /// At most K of the hits of the image of `camera`, by Wang et al.'s quadtree
    /// (`vplgi_shared::seeding`), as hit indices.
    fn seeding(
        &self,
        hits: &Self::Hits,
        camera: &CameraParams,
        params: &SeedParams,
    ) -> Result<Vec<u32>, Self::Error>;
}

/// Stage 3's seeds with `--vpl-cluster rsm --rsm-seeding importance`.
pub trait RsmImportance: Storage {
    /// The importance of each texel of the maps of budget `rsm_size`
    /// (`vplgi_shared::rsm_importance`) for the VPLs of `rsm_vpls`, seen from the hits of camera
    /// samples `samples`, distances floored at `d_min`.
    fn rsm_importance(
        &self,
        vpls: &Self::Vpls,
        rsm_size: u32,
        hits: &Self::Hits,
        samples: &[u32],
        d_min: f32,
    ) -> Result<Self::Scalars, Self::Error>;
}

/// Stage 3 with `--vpl-cluster rsm`.
pub trait RsmCluster: Storage {
    /// The VPLs of `rsm_vpls` (maps of budget `rsm_size`) clustered in reflective-shadow-map
    /// space, started as `start` says; with `start.carry`, also the live clusters' states for the
    /// next frame (empty otherwise).
    fn rsm_cluster(
        &self,
        vpls: &Self::Vpls,
        rsm_size: u32,
        params: &RsmClusterParams,
        start: RsmStart<'_, Self::Scalars>,
    ) -> Result<(Self::Clustering, ClusterCounts, Vec<RsmCentre>), Self::Error>;
}

/// Stage 4.
pub trait Visibility: Storage {
    /// The visibility matrix between rows `rows` of `row_points` and all of `cols`, with the
    /// number of shadow rays traced if the backend counts them.
    fn visibility(
        &self,
        row_points: &Self::Points,
        rows: Range<u32>,
        cols: &Self::Points,
        progress: &dyn Progress,
    ) -> Result<(Self::Matrix, Option<u64>), Self::Error>;
}

/// `--shade interpolate`: the sample points' gather rays.
pub trait GatherRadius: Storage {
    /// 1 / R_j, the inverse harmonic mean distance to the surfaces each of `points` sees, from
    /// `params.rays` gather rays.
    fn gather_radius(
        &self,
        points: &Self::Points,
        params: &GatherParams,
    ) -> Result<Self::Scalars, Self::Error>;
}

/// `--gi photon`: the final gather at the sample points.
pub trait FinalGather: Storage {
    /// The irradiance at each of the sample points `points` from `params.rays` gather rays lit
    /// by the cut (Eq. 4 and 5), kept with the points and the same rays' 1 / R_j; and what the
    /// lookups counted.
    fn final_gather(
        &self,
        points: Self::Points,
        cut: &Self::Cut,
        params: &GatherParams,
    ) -> Result<(Self::IrradianceSamples, GatherCounts), Self::Error>;
}

/// `--shade interpolate`: the irradiance at the sample points.
pub trait Interpolate: Storage {
    /// The irradiance of `lights` at each of the sample points `points`, sample point j seeing
    /// the lights of row j of `matrix`, kept with the points and their `inv_radius` for
    /// interpolation.
    fn sample_irradiance(
        &self,
        points: Self::Points,
        inv_radius: Self::Scalars,
        lights: &Self::Lights,
        matrix: &Self::Matrix,
        g_max: f32,
    ) -> Result<Self::IrradianceSamples, Self::Error>;
}

/// Stage 5.
pub trait Shade: Storage {
    /// The radiance of `pixels` (all of whose samples are in `input.chunk`).
    fn shade(
        &self,
        input: &ShadeInput<'_, Self>,
        pixels: Range<u32>,
        params: &ShadeParams,
    ) -> Result<Vec<[f32; 3]>, Self::Error>;
}

/// The bias compensation's segments.
pub trait BiasPoints: Storage {
    /// From each shading point of `parent` (camera samples `samples`), a cosine-sampled segment
    /// to the surface it sees, kept as a shading point where the clamp bites (albedo = its
    /// albedo x the parent's x the clamped share 1 - g_max / G, no emission, the parent's pixel),
    /// and a miss elsewhere.
    fn bias_points(
        &self,
        parent: &Self::Samples,
        samples: Range<u32>,
        params: &BiasParams,
    ) -> Result<Self::Samples, Self::Error>;
}

/// `--caustics photons`: the light that reaches surfaces straight from mirrors and glass.
pub trait Caustics: Storage {
    /// The photon map of `photons` (`trace_vpls`' caustic photons): ordered by its balanced
    /// kd-tree (`vplgi_shared::photon_tree`, built on the host), leaves of at most `leaf`.
    fn photon_map(&self, photons: &Self::Vpls, leaf: u32) -> Result<Self::PhotonMap, Self::Error>;

    /// The caustic radiance of the pixels of camera samples `samples` (whole pixels, whose
    /// shading points are `points`), each the mean of its samples', and how many estimates
    /// stopped at the visit budget (`vplgi_types::params::CAUSTIC_VISITS`).
    fn caustics(
        &self,
        map: &Self::PhotonMap,
        points: &Self::Samples,
        samples: Range<u32>,
        params: &CausticParams,
    ) -> Result<(Vec<[f32; 3]>, u32), Self::Error>;
}
