//! The GPU twin of the CPU reference (`vplgi-cpu`): wgpu compute with WGSL from `shaders/`.
//!
//! A [`GpuContext`] (instance, adapter, device, queue, limits) is built once; each stage module
//! has a run function taking `&wgpu::Device` and `&wgpu::Queue`, so tests inject the device. The
//! WGSL of a stage is the shared files of `shaders/common/` followed by the stage's own file
//! ([`shader::compose`]).
//!
//! Stages: [`trace_vpls`], [`shading_points`], [`cluster`] (with [`seeding`]), [`visibility`], [`shade`],
//! [`bias_points`] (the clamp's bias compensation).
//! [`GpuBackend`] implements [`vplgi_frame::Backend`] with them on device buffers, so the one
//! frame driver ([`vplgi_frame::render`]) chains them.

pub mod backend;
pub mod bsdf;
pub mod buffers;
pub mod bvh;
pub mod context;
pub mod lights;
pub mod rng;
pub mod scan;
pub mod scene;
pub mod shader;
pub mod timing;
pub mod wait;

use vplgi_frame::stage_modules;
// One module per stage and part of the table, each implementing its stage trait.
vplgi_frame::stage_table!(stage_modules);

pub use backend::{render, GpuBackend, GpuHits, GpuKernels, GpuPoints};
pub use context::{GpuContext, GpuError};
