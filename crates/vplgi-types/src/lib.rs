//! Types shared by every vplgi backend.
//!
//! * [`pod`]: `#[repr(C)]` plain-old-data records (VPLs, shading points) whose bytes the CPU
//!   reference and the GPU twin read alike.
//! * [`rng`]: the counter-based hash RNG keyed by (seed, stream, index). It is written so that
//!   the same integer operations can be transcribed to WGSL and give bit-identical streams.
//! * [`camera`]: the pinhole camera and camera paths (keyframed glTF camera animation).
//! * [`sampling`]: the few warps used to turn uniform numbers into directions and points.
//! * [`config`]: [`FrameConfig`], the parameters of one frame, with the paper's presets.
//! * [`clustering`]: the host-side choices of Alg. 1 and 2 every backend shares.
//! * [`device`]: the records the GPU reads, built on the host (BVH, shading data, lights).
//! * [`params`]: the parameters of each stage, as every backend takes them.
//! * [`light_groups`]: how direct light chooses among groups of area lights at a shading point.
//! * [`rsm`]: the records of reflective shadow maps (their arithmetic is in `vplgi-shared`).
//! * [`interpolation`]: `--shade interpolate`'s weights and radii (Wang et al.).
//! * [`temporal`]: clusters carried from frame to frame with admission thresholds (Wang et al.).

pub mod camera;
pub mod clustering;
pub mod config;
pub mod device;
pub mod interpolation;
pub mod light_groups;
pub mod params;
pub mod pod;
pub mod rng;
pub mod rsm;
pub mod sampling;
pub mod temporal;

pub use camera::{Camera, CameraPath};
pub use config::{
    Caustics, ClusterMode, FrameConfig, FuzzyMode, Gi, LightShape, Lighting, Preset, RsmSeeding,
    Seeding, ShadeMode, SpMetric, SpRepresentative, Temporal, VplClustering, VplSource,
};
pub use params::{
    BiasParams, CameraParams, CausticParams, CutParams, Deposit, RsmParams, SeedParams,
    ShadeParams, TraceParams,
};
pub use pod::{
    BsdfRecord, CutBound, CutNode, Endpoint, LightOutline, PhotonNode, ShadingPoint, Vpl, VplLight,
    MISS,
};
pub use rng::{Rng, Stream};
