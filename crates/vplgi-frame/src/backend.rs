//! What a backend stores a frame in, and the glue between stages: how hits are compacted and
//! numbered, and how VPLs and clusters become lights and surface points. The stages themselves
//! are the traits of [`crate::stages`]. The frame driver ([`crate::render`]) calls these and
//! nothing else, so a backend never sees the frame's bookkeeping and the bookkeeping exists once.

use crate::frame::FrameError;
use std::ops::Range;
use vplgi_shared::rsm::RsmCentre;
use vplgi_types::{Camera, FrameConfig, LightShape};

/// A value that knows how many items it holds (a device buffer alone does not).
pub trait Counted {
    fn count(&self) -> u32;
}

impl<T> Counted for Vec<T> {
    fn count(&self) -> u32 {
        self.len() as u32
    }
}

/// What a clustering made, beside its clusters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterCounts {
    /// Points whose 27-cell neighbourhood held no compatible centroid.
    pub widened: u32,
    /// Started warm: the previous centres kept and the new clusters seeded.
    pub kept: u32,
    pub fresh: u32,
}

/// What a final gather counted, beside its samples: gather hits on a non-specular surface that
/// no cut node's kernel reached (lit by kernels twice as wide instead), and
/// lookups stopped at the visit budget.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GatherCounts {
    pub fallback: u64,
    pub truncated: u64,
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

/// Which lights [`Storage::vpl_lights`] makes.
pub enum LightSet<'a, C> {
    /// One light per VPL. VPLs deposited at more than `max_bounce` surfaces carry no flux: the
    /// lights of a bias-compensation level, whose paths already have surfaces of their own.
    EachVpl { max_bounce: u32 },
    /// One light per VPL cluster of `clusters`: at its representative, with its members' summed
    /// flux, a point or a disk of the members' spread (`vplgi_shared::disk`).
    Clusters { clusters: &'a C, shape: LightShape },
    /// No light: the last bias-compensation level, whose paths are as long as the frame's.
    Nothing,
}

/// Everything `shade` reads for a range of pixels whose samples lie in `chunk`.
pub struct ShadeInput<'a, B: Storage + ?Sized> {
    pub chunk: &'a SampleChunk<B::Samples>,
    pub hits: &'a B::Hits,
    pub lights: &'a B::Lights,
    pub matrix: &'a B::Matrix,
    pub visibility: ShadeVisibility<'a, B::Clustering, B::IrradianceSamples>,
}

/// A backend's storage for a frame and the glue between its stages. Every value the driver
/// needs the size of knows it ([`Counted`]).
pub trait Storage {
    type Error: From<FrameError>;
    /// The VPLs of a frame.
    type Vpls: Counted;
    /// The shading points of a range of camera samples.
    type Samples;
    /// Surface points (position, normal): clustering input and shadow-ray ends.
    type Points: Counted;
    /// The shading points that hit a surface, numbered in sample order, with each sample's hit
    /// number (its row).
    type Hits: Counted;
    /// Lights for indirect shading: one per VPL or per VPL cluster.
    type Lights: Counted;
    /// A clustering; its count is its number of non-empty clusters.
    type Clustering: Counted;
    /// A block of rows of the visibility matrix.
    type Matrix;
    /// One f32 per point (a sample point's 1 / R_j).
    type Scalars;
    /// The sample points of `--shade interpolate` with their 1 / R_j and irradiance.
    type IrradianceSamples;
    /// A photon map ordered by its kd-tree, with the tree.
    type PhotonMap: Counted;
    /// An illumination cut, ready for final gathering.
    type Cut;

    /// The scene's bounding-box diagonal (what the geometry-term clamp is relative to).
    fn scene_extent(&self) -> f32;

    /// The scene's own camera (frames without a camera of their own are seen from it).
    fn camera(&self) -> Camera;

    /// Whether some material of the scene is glossy (`Surface::is_glossy`).
    fn has_glossy(&self) -> bool;

    /// Whether some material of the scene is a mirror or glass (`Bsdf::is_specular`): only
    /// such a scene has caustics.
    fn has_specular(&self) -> bool;

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

    /// The hits among all chunks' samples (`n_samples` in the image), numbered in sample order.
    fn compact_hits(
        &self,
        chunks: &[SampleChunk<Self::Samples>],
        n_samples: u32,
    ) -> Result<Self::Hits, Self::Error>;

    /// How many hits come before camera sample `sample`.
    fn hits_before(&self, hits: &Self::Hits, sample: u32) -> Result<u32, Self::Error>;

    /// The hits as surface points.
    fn hit_points<'h>(&self, hits: &'h Self::Hits) -> &'h Self::Points;

    /// The VPLs as surface points.
    fn vpl_points(&self, vpls: &Self::Vpls) -> Result<Self::Points, Self::Error>;

    /// The lights of the VPLs: one per VPL or per VPL cluster.
    fn vpl_lights(
        &self,
        vpls: &Self::Vpls,
        set: LightSet<'_, Self::Clustering>,
    ) -> Result<Self::Lights, Self::Error>;

    /// The lights as surface points (visibility columns).
    fn light_points(&self, lights: &Self::Lights) -> Result<Self::Points, Self::Error>;
}
