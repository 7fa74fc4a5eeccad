//! What a backend provides: one method per stage, on the backend's own storage (host vectors on
//! the CPU, device buffers on the GPU). The frame driver ([`crate::render`]) calls these and
//! nothing else, so a backend never sees the frame's bookkeeping and the bookkeeping exists once.

use crate::frame::{FrameError, Progress};
use std::ops::Range;
use vplgi_types::clustering::Centre;
use vplgi_types::clustering::{ClusterParams, ClusterStart, Metric};
use vplgi_types::interpolation::GatherParams;
use vplgi_types::rsm::{RsmCentre, RsmClusterParams};
use vplgi_types::seeding::SeedParams;
use vplgi_types::{BiasParams, Camera, CameraParams, FrameConfig, LightShape, ShadeParams, TraceParams};

/// What `trace_vpls` made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VplCounts {
    pub vpls: u32,
    /// Light particles traced to make them.
    pub particles: u32,
}

/// What a clustering made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterCounts {
    /// Non-empty clusters.
    pub k: u32,
    /// Points whose 27-cell neighbourhood held no compatible centroid.
    pub widened: u32,
    /// Started warm: the previous centres kept and the new clusters seeded.
    pub kept: u32,
    pub fresh: u32,
}

/// How `rsm_cluster` starts.
#[derive(Clone, Copy)]
pub struct RsmStart<'a, S> {
    /// The importance map its seeds are warped by (`--rsm-seeding importance`).
    pub importance: Option<&'a S>,
    /// The previous frame's live clusters (`--temporal on`): they keep their slots.
    pub previous: Option<&'a [RsmCentre]>,
    /// Return the live clusters' states, for the next frame.
    pub carry: bool,
}

/// Shading points of the camera samples `first .. first + count`.
pub struct SampleChunk<S> {
    pub first: u32,
    pub count: u32,
    pub samples: S,
}

/// Where the visibility of a shaded point comes from (SPEC, Eq. 6-10), or, interpolating, its
/// irradiance.
pub enum ShadeVisibility<'a, C, S> {
    /// Row `row_of(i) - first_row` of the matrix belongs to hit i itself (shading points not
    /// clustered).
    Own { first_row: u32 },
    /// The matrix has one row per shading-point cluster; a hit combines its F clusters' rows by
    /// the clustering's labels and weights. `hits` are the hits of the shaded samples.
    Fuzzy { clustering: &'a C, hits: Range<u32> },
    /// `--shade interpolate`: a hit's irradiance is interpolated from the irradiance samples of
    /// its F clusters (by the clustering's labels); the matrix is not read.
    Interpolated { clustering: &'a C, hits: Range<u32>, samples: &'a S },
}

/// Which lights [`Backend::vpl_lights`] makes.
pub enum LightSet<'a, C> {
    /// One light per VPL. VPLs deposited at more than `max_bounce` surfaces carry no flux: the
    /// lights of a bias-compensation level, whose paths already have surfaces of their own.
    EachVpl { max_bounce: u32 },
    /// One light per VPL cluster of a clustering into `k` clusters: at its representative, with
    /// its members' summed flux, a point or a disk of the members' spread (`vplgi_types::disk`).
    Clusters { clusters: &'a C, k: u32, shape: LightShape },
}

/// Everything `shade` reads for a range of pixels whose samples lie in `chunk`.
pub struct ShadeInput<'a, B: Backend + ?Sized> {
    pub chunk: &'a SampleChunk<B::Samples>,
    pub hits: &'a B::Hits,
    pub lights: &'a B::Lights,
    pub light_count: u32,
    pub matrix: &'a B::Matrix,
    pub visibility: ShadeVisibility<'a, B::Clustering, B::IrradianceSamples>,
}

/// One implementation of every stage. Counts travel beside the data (a device buffer does not
/// know how many of its elements are valid); the driver keeps them.
pub trait Backend {
    type Error: From<FrameError>;
    /// The VPLs of a frame.
    type Vpls;
    /// The shading points of a range of camera samples.
    type Samples;
    /// Surface points (position, normal): clustering input and shadow-ray ends.
    type Points;
    /// The shading points that hit a surface, numbered in sample order, with each sample's hit
    /// number (its row).
    type Hits;
    /// Lights for indirect shading: one per VPL or per VPL cluster.
    type Lights;
    type Clustering;
    /// A block of rows of the visibility matrix.
    type Matrix;
    /// One f32 per point (`gather_radius`'s 1 / R_j).
    type Scalars;
    /// The sample points of `--shade interpolate` with their 1 / R_j and irradiance.
    type IrradianceSamples;

    /// The scene's bounding-box diagonal (what the geometry-term clamp is relative to).
    fn scene_extent(&self) -> f32;

    /// The scene's own camera (frames without a camera of their own are seen from it).
    fn camera(&self) -> Camera;

    /// Refuses, before any work, a frame this backend cannot hold.
    fn check_frame(&self, _cfg: &FrameConfig) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Most camera samples one [`SampleChunk`] may hold.
    fn max_samples_per_chunk(&self) -> u32 {
        u32::MAX
    }

    /// Most rows of `cols` columns one visibility block may hold (beyond the driver's own
    /// memory bound).
    fn max_visibility_rows(&self, _cols: u32) -> u64 {
        u64::MAX
    }

    /// Waits until submitted work is done, so a stage's wall time is its own.
    fn sync(&self) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Stage 1: VPLs from light particles.
    fn trace_vpls(&self, params: &TraceParams, progress: &dyn Progress) -> Result<(Self::Vpls, VplCounts), Self::Error>;

    /// Stage 1 with `--vpl-source rsm`: VPLs from the reflective shadow maps of every light for a
    /// budget of about `size²` texels (`particles` counts the texels).
    fn rsm_vpls(&self, size: u32, progress: &dyn Progress) -> Result<(Self::Vpls, VplCounts), Self::Error>;

    /// Stage 2: the shading points of camera samples `samples`.
    fn shading_points(&self, params: &CameraParams, samples: Range<u32>) -> Result<Self::Samples, Self::Error>;

    /// The hits among all chunks' samples (`n_samples` in the image), numbered in sample order,
    /// and how many there are.
    fn compact_hits(&self, chunks: &[SampleChunk<Self::Samples>], n_samples: u32) -> Result<(Self::Hits, u32), Self::Error>;

    /// How many hits come before camera sample `sample`.
    fn hits_before(&self, hits: &Self::Hits, sample: u32) -> Result<u32, Self::Error>;

    /// The hits as surface points.
    fn hit_points<'h>(&self, hits: &'h Self::Hits) -> &'h Self::Points;

    /// The VPLs as surface points.
    fn vpl_points(&self, vpls: &Self::Vpls, n: u32) -> Result<Self::Points, Self::Error>;

    /// Stage 3: Alg. 1 and 2 over `n` points, from the initial centroids `start` says.
    fn cluster(&self, points: &Self::Points, n: u32, params: &ClusterParams, start: ClusterStart<'_>)
        -> Result<(Self::Clustering, ClusterCounts), Self::Error>;

    /// Stage 3 with `--temporal on`: the `k` clusters of a clustering of the `n` points as the
    /// next frame's centres, each with its admission threshold (`vplgi_types::temporal`).
    fn cluster_centres(&self, clustering: &Self::Clustering, k: u32, points: &Self::Points, n: u32, metric: Metric) -> Result<Vec<Centre>, Self::Error>;

    /// Stage 3's seeds with `--seeding adaptive`: at most K of the `n` hits of the image of
    /// `camera`, by Wang et al.'s quadtree (`vplgi_types::seeding`), as hit indices.
    fn seeding(&self, hits: &Self::Hits, n: u32, camera: &CameraParams, params: &SeedParams) -> Result<Vec<u32>, Self::Error>;

    /// Stage 3's seeds with `--vpl-cluster rsm --rsm-seeding importance`: the importance of each
    /// texel of the maps of budget `rsm_size` (`vplgi_types::rsm_importance`) for the `n` VPLs of
    /// `rsm_vpls`, seen from the hits of camera samples `samples`, distances floored at `d_min`.
    fn rsm_importance(&self, vpls: &Self::Vpls, n: u32, rsm_size: u32, hits: &Self::Hits, samples: &[u32], d_min: f32) -> Result<Self::Scalars, Self::Error>;

    /// Stage 3 with `--vpl-cluster rsm`: the `n` VPLs of `rsm_vpls` (maps of budget `rsm_size`)
    /// clustered in reflective-shadow-map space, started as `start` says; with `start.carry`,
    /// also the live clusters' states for the next frame (empty otherwise).
    fn rsm_cluster(
        &self,
        vpls: &Self::Vpls,
        n: u32,
        rsm_size: u32,
        params: &RsmClusterParams,
        start: RsmStart<'_, Self::Scalars>,
    ) -> Result<(Self::Clustering, ClusterCounts, Vec<RsmCentre>), Self::Error>;

    /// Each cluster's representative member, as surface points.
    fn representatives(&self, clustering: &Self::Clustering, k: u32, points: &Self::Points, n: u32) -> Result<Self::Points, Self::Error>;

    /// The lights of `n` VPLs: one per VPL or per VPL cluster.
    fn vpl_lights(&self, vpls: &Self::Vpls, n: u32, set: LightSet<'_, Self::Clustering>) -> Result<Self::Lights, Self::Error>;

    /// The lights as surface points (visibility columns).
    fn light_points(&self, lights: &Self::Lights, n: u32) -> Result<Self::Points, Self::Error>;

    /// Stage 4: the visibility matrix between rows `rows` of `row_points` (of `n_rows`) and all
    /// `n_cols` columns, with the number of shadow rays traced if the backend counts them.
    fn visibility(
        &self,
        row_points: &Self::Points,
        n_rows: u32,
        rows: Range<u32>,
        cols: &Self::Points,
        n_cols: u32,
        progress: &dyn Progress,
    ) -> Result<(Self::Matrix, Option<u64>), Self::Error>;

    /// Stage 5: the radiance of `pixels` (all of whose samples are in `input.chunk`).
    fn shade(&self, input: &ShadeInput<'_, Self>, pixels: Range<u32>, params: &ShadeParams) -> Result<Vec<[f32; 3]>, Self::Error>;

    /// `--shade interpolate`: 1 / R_j, the inverse harmonic mean distance to the surfaces each of
    /// the `n` sample points `points` sees, from `params.rays` gather rays.
    fn gather_radius(&self, points: &Self::Points, n: u32, params: &GatherParams) -> Result<Self::Scalars, Self::Error>;

    /// `--shade interpolate`: the irradiance of the `n_lights` `lights` at each of the `n` sample
    /// points `points`, sample point j seeing the lights of row j of `matrix`, kept with the
    /// points and their `inv_radius` for interpolation.
    #[allow(clippy::too_many_arguments)]
    fn sample_irradiance(
        &self,
        points: Self::Points,
        n: u32,
        inv_radius: Self::Scalars,
        lights: &Self::Lights,
        n_lights: u32,
        matrix: &Self::Matrix,
        g_max: f32,
    ) -> Result<Self::IrradianceSamples, Self::Error>;

    /// Bias compensation: from each shading point of `parent` (camera samples `samples`), a
    /// cosine-sampled segment to the surface it sees, kept as a shading point where the clamp
    /// bites (albedo = its albedo x the parent's x the clamped share 1 - g_max / G, no emission,
    /// the parent's pixel), and a miss elsewhere.
    fn bias_points(&self, parent: &Self::Samples, samples: Range<u32>, params: &BiasParams) -> Result<Self::Samples, Self::Error>;
}
