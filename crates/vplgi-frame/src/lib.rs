//! The stage contract: what every backend provides and the one frame driver written over it.
//!
//! * [`stage_table!`] and [`stages`]: the stages, listed once, and one trait per stage. The CPU
//!   reference implements them on host vectors, the GPU twin on device buffers, each in the
//!   stage's own module; [`Storage`] is what a backend stores a frame in and the glue between
//!   stages, and [`Backend`] is all of it.
//! * [`render`] / [`render_from`] / [`render_rows`]: the frame, written once: chunking, hit
//!   compaction, the geometry-term clamp, the choice of stage variants from [`FrameConfig`]'s
//!   enums, timings and statistics live here and nowhere else.
//! * [`Frame`], [`FrameStats`], [`Stage`], [`StageTimings`]: what a frame returns, the same type
//!   whatever ran it; [`Report`]: the `report.json` that `vplgi render` writes and the tools read
//!   back.

mod backend;
mod driver;
mod frame;
mod report;
pub mod stages;

pub use backend::{
    ClusterCounts, Counted, GatherCounts, LightSet, RsmStart, SampleChunk, ShadeInput,
    ShadeVisibility, Storage,
};
pub use driver::{render, render_from, render_rows, View, ROW_CHUNK_BITS};
pub use frame::{Frame, FrameError, FrameStats, NoProgress, Progress, StageTimings};
pub use report::{Adapter, Clusters, GClamp, KernelTime, Outputs, Report, SceneInfo, Setup};
pub use stages::{prelude, Backend, Stage};
pub use vplgi_types::FrameConfig;
