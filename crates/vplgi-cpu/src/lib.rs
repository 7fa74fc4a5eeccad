//! The CPU reference of the clustered-VPL pipeline (`../shared/SPEC.md`).
//!
//! One module per stage, each exposing a function named after the stage:
//! [`trace_vpls::trace_vpls`] (or [`rsm_vpls::rsm_vpls`]), [`shading_points::shading_points`], [`cluster::cluster`],
//! [`visibility::visibility`], [`shade::shade`] and [`bias_points::bias_points`] (the clamp's
//! bias compensation). [`CpuScene`] implements
//! [`vplgi_frame::Backend`] with them, so [`render`] (the one frame driver) chains them for one
//! frame. Every stage is parallel with rayon and deterministic: each item (particle, pixel,
//! point, matrix row) is a pure function of its inputs and of the counter-based RNG, and all
//! reductions are either integer sums or fixed-order sequential folds, so 1 and N threads give
//! bit-identical results.

mod backend;
use vplgi_frame::stage_modules;
// One module per stage and part of the table, each implementing its stage trait.
vplgi_frame::stage_table!(stage_modules);

/// Light tables live with the scene so every backend shares them.
pub use vplgi_scene::lights;

mod accel;
pub use accel::{CpuScene, ShadowSpan, SurfaceHit, SEGMENT_TFAR, SEGMENT_TNEAR};
pub use backend::CpuHits;
/// The frame driver is the same for every backend: `render(&cpu_scene, &cfg, &progress)`.
pub use vplgi_frame::{
    render, render_rows, Frame, FrameError, FrameStats, NoProgress, Progress, StageTimings,
};
