//! `report.json`: what `vplgi render` writes beside an image, and what the tools (bench, sweep,
//! results, perf report) read back, as one typed record.

use crate::frame::{FrameStats, StageTimings};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use vplgi_types::FrameConfig;

/// Everything known about one rendered frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub vplgi_version: String,
    /// `cpu` or `gpu`.
    pub backend: String,
    /// The GPU adapter, for GPU frames.
    pub adapter: Option<Adapter>,
    /// Worker threads of the CPU (rayon).
    pub threads: usize,
    pub scene: SceneInfo,
    pub triangles: u64,
    pub params: FrameConfig,
    pub vpls: u32,
    pub clusters: Clusters,
    pub g_clamp: GClamp,
    pub stats: FrameStats,
    pub timings_ms: StageTimings,
    pub setup_ms: Setup,
    /// Peak resident memory of the whole process (scene, acceleration structure, frame buffers,
    /// the GPU driver's), in MiB, where the OS reports it.
    pub peak_rss_mib: Option<f64>,
    /// Device time of every GPU kernel (`--profile`), most expensive first.
    pub gpu_profile: Option<Vec<KernelTime>>,
    pub outputs: Outputs,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Adapter {
    pub name: String,
    pub device_type: String,
    /// The features that matter to vplgi's kernels.
    pub features: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneInfo {
    /// The file, or `builtin:NAME`.
    pub source: String,
    pub name: String,
    pub emissive_triangles: u64,
    pub punctual_lights: u64,
    /// Bounding-box diagonal.
    pub extent: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clusters {
    pub vpl: u32,
    pub sp: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GClamp {
    /// d_min as a fraction of the scene's extent (`--g-clamp`).
    pub relative: f32,
    pub d_min: f32,
    /// Whether the light the clamp removes was put back (`--bias-compensation`; how many points
    /// it shaded is `stats.bias_points`).
    #[serde(default)]
    pub compensated: bool,
}

/// Work before the frame, in milliseconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    pub load: f64,
    /// Building the acceleration structure (and, on the GPU, uploading the scene).
    pub scene_build: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KernelTime {
    pub kernel: String,
    pub passes: u32,
    pub device_ms: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outputs {
    pub exr: PathBuf,
    pub png: PathBuf,
}
