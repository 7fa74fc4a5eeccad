//! The one backend choice of every subcommand: `--backend cpu|gpu|auto`, and the scene made
//! ready on it.

use anyhow::{Context, Result};
use clap::ValueEnum;
use std::time::Instant;
use vplgi_frame::{Adapter, Frame, FrameConfig, Progress, View};
use vplgi_scene::{Camera, Scene};

#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum)]
pub enum BackendArg {
    /// The CPU reference (rayon + Embree 4).
    Cpu,
    /// The GPU twin (wgpu); on machines without a GPU, Mesa's lavapipe.
    Gpu,
    /// The GPU when an adapter exists, else the CPU.
    Auto,
}

/// Renders a frame of a sequence, or from the scene's camera when `None`.
type RenderFn<'a> = &'a dyn Fn(&FrameConfig, Option<&View>, &dyn Progress) -> Result<Frame>;

/// Renders a frame of a sequence of another scene on the same device (built and uploaded anew).
type RelitFn<'a> = &'a dyn Fn(&Scene, &FrameConfig, &View, &dyn Progress) -> Result<Frame>;

/// A scene ready to render on one backend.
pub struct Engine<'a> {
    render: RenderFn<'a>,
    relit: RelitFn<'a>,
    /// `cpu` or `gpu`.
    pub name: &'static str,
    pub adapter: Option<Adapter>,
    /// For GPU frames: the context (device time of kernels, `--profile`).
    pub gpu: Option<&'a vplgi_gpu::GpuContext>,
    /// Building the acceleration structure (and on the GPU uploading the scene), ms.
    pub setup_ms: f64,
}

impl Engine<'_> {
    /// A frame from the scene's camera.
    pub fn render(&self, cfg: &FrameConfig, progress: &dyn Progress) -> Result<Frame> {
        (self.render)(cfg, None, progress)
    }

    /// A frame of a sequence.
    pub fn render_from(
        &self,
        cfg: &FrameConfig,
        view: &View,
        progress: &dyn Progress,
    ) -> Result<Frame> {
        (self.render)(cfg, Some(view), progress)
    }

    /// A sequence along `cameras`: each frame starts from the clusters of the one before (used
    /// with `--temporal on`; the first frame has none) and is handed to `each` with its index,
    /// then dropped, so a sequence never holds more than one frame. With `lit`, frame i is of
    /// scene `lit(i)` (its lights moved), built on the device for that frame.
    pub fn walk(
        &self,
        cfg: &FrameConfig,
        cameras: &[Camera],
        lit: Option<&dyn Fn(usize) -> Scene>,
        progress: &dyn Progress,
        mut each: impl FnMut(usize, Frame) -> Result<()>,
    ) -> Result<()> {
        let (mut centres, mut rsm_centres) = (Vec::new(), Vec::new());
        for (i, camera) in cameras.iter().enumerate() {
            let view = View {
                camera: *camera,
                previous: (i > 0).then_some(&centres[..]),
                previous_rsm: (i > 0).then_some(&rsm_centres[..]),
            };
            let mut frame = match lit {
                Some(scene_of) => (self.relit)(&scene_of(i), cfg, &view, progress)?,
                None => self.render_from(cfg, &view, progress)?,
            };
            centres = std::mem::take(&mut frame.centres);
            rsm_centres = std::mem::take(&mut frame.rsm_centres);
            each(i, frame)?;
        }
        Ok(())
    }
}

/// Makes `scene` ready on the chosen backend and runs `work` with it.
pub fn with_engine<T>(
    backend: BackendArg,
    scene: &Scene,
    source: &str,
    work: impl FnOnce(&Engine) -> Result<T>,
) -> Result<T> {
    let gpu = match backend {
        BackendArg::Cpu => None,
        BackendArg::Gpu => Some(vplgi_gpu::GpuContext::new()?),
        BackendArg::Auto => match vplgi_gpu::GpuContext::new() {
            Ok(ctx) => Some(ctx),
            Err(e) => {
                eprintln!("note: no GPU adapter ({e}); rendering on the CPU");
                None
            }
        },
    };
    match &gpu {
        None => {
            let clock = Instant::now();
            let device = vplgi_embree::Device::new(None)?;
            let cs = vplgi_cpu::CpuScene::new(scene, &device)
                .with_context(|| format!("building the Embree scene for {source}"))?;
            let setup_ms = clock.elapsed().as_secs_f64() * 1e3;
            let render = |cfg: &FrameConfig, v: Option<&View>, p: &dyn Progress| match v {
                Some(v) => Ok(vplgi_frame::render_from(&cs, cfg, v, p)?),
                None => Ok(vplgi_frame::render(&cs, cfg, p)?),
            };
            let relit = |scene: &Scene, cfg: &FrameConfig, v: &View, p: &dyn Progress| {
                let cs = vplgi_cpu::CpuScene::new(scene, &device)
                    .with_context(|| format!("building the Embree scene for {source}"))?;
                Ok(vplgi_frame::render_from(&cs, cfg, v, p)?)
            };
            work(&Engine {
                render: &render,
                relit: &relit,
                name: "cpu",
                adapter: None,
                gpu: None,
                setup_ms,
            })
        }
        Some(ctx) => {
            eprintln!("rendering on {} (GPU timings on lavapipe are CPU-emulated)", ctx.describe());
            let kernels = vplgi_gpu::GpuKernels::new(&ctx.device)?;
            let clock = Instant::now();
            let gb = vplgi_gpu::GpuBackend::new(&ctx.device, &ctx.queue, &kernels, scene)
                .with_context(|| format!("uploading {source} to the GPU"))?;
            let setup_ms = clock.elapsed().as_secs_f64() * 1e3;
            let render = |cfg: &FrameConfig, v: Option<&View>, p: &dyn Progress| match v {
                Some(v) => Ok(vplgi_frame::render_from(&gb, cfg, v, p)?),
                None => Ok(vplgi_frame::render(&gb, cfg, p)?),
            };
            let relit = |scene: &Scene, cfg: &FrameConfig, v: &View, p: &dyn Progress| {
                let gb = vplgi_gpu::GpuBackend::new(&ctx.device, &ctx.queue, &kernels, scene)
                    .with_context(|| format!("uploading {source} to the GPU"))?;
                Ok(vplgi_frame::render_from(&gb, cfg, v, p)?)
            };
            let adapter = Adapter {
                name: ctx.describe(),
                device_type: format!("{:?}", ctx.info.device_type),
                features: ctx.notable_features().into_iter().map(String::from).collect(),
            };
            work(&Engine {
                render: &render,
                relit: &relit,
                name: "gpu",
                adapter: Some(adapter),
                gpu: Some(ctx),
                setup_ms,
            })
        }
    }
}
