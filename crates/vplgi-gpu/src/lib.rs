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
pub mod bias_points;
pub mod buffers;
pub mod bvh;
pub mod cluster;
pub mod context;
pub mod gather_radius;
pub mod interpolate;
pub mod lights;
pub mod rng;
pub mod rsm_cluster;
pub mod rsm_importance;
pub mod rsm_vpls;
pub mod scan;
pub mod scene;
pub mod seeding;
pub mod shade;
pub mod shader;
pub mod shading_points;
pub mod timing;
pub mod trace_vpls;
pub mod visibility;
pub mod wait;

pub use backend::{render, GpuBackend, GpuKernels};
pub use context::{GpuContext, GpuError};
