//! The stage contract: what every backend provides and the one frame driver written over it.
//!
//! * [`Backend`]: one method per stage (and per piece of glue between stages). The CPU reference
//!   implements it on host vectors, the GPU twin on device buffers.
//! * [`render`] / [`render_from`] / [`render_rows`]: the frame, written once: chunking, hit compaction, the
//!   geometry-term clamp, the choice of stage variants from [`FrameConfig`]'s enums, timings
//!   and statistics live here and nowhere else.
//! * [`Frame`], [`FrameStats`], [`Stage`], [`StageTimings`]: what a frame returns, the same type
//!   whatever ran it; [`Report`]: the `report.json` that `vplgi render` writes and the tools read
//!   back.

mod backend;
mod driver;
mod frame;
mod report;

pub use backend::{Backend, ClusterCounts, LightSet, RsmStart, SampleChunk, ShadeInput, ShadeVisibility, VplCounts};
pub use driver::{render, render_from, render_rows, View, ROW_CHUNK_BITS};
pub use frame::{Frame, FrameError, FrameStats, NoProgress, Progress, Stage, StageTimings};
pub use report::{Adapter, Clusters, GClamp, KernelTime, Outputs, Report, SceneInfo, Setup};
pub use vplgi_types::FrameConfig;
