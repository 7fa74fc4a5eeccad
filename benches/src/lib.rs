//! Shared set-up of the criterion benches (`benches/benches/stages/<stage>.rs`, one per stage plus
//! `frame`): the two sizes, every stage's inputs made once by the CPU reference (not timed), the
//! GPU context with device copies of those inputs, and the GPU clock.
//!
//! GPU variants report device time from timestamp queries where the adapter has them (the sum of
//! the stage's compute passes, `vplgi_gpu::timing`), else wall time; each bench says which when
//! it starts. On this project's machines the GPU is Mesa lavapipe on the same 2 CPU cores.

use criterion::measurement::WallTime;
use criterion::BenchmarkGroup;
use glam::Vec3;
use std::time::{Duration, Instant};
use vplgi_cpu::cluster::{cluster, Clustering};
use vplgi_cpu::shade::VplLights;
use vplgi_cpu::visibility::{visibility, BitMatrix, Endpoint};
use vplgi_cpu::{CpuScene, NoProgress};
use vplgi_gpu::buffers::{storage, sync};
use vplgi_gpu::GpuContext;
use vplgi_scene::Scene;
use vplgi_types::{FrameConfig, ShadingPoint, Vpl, MISS};

/// A named frame configuration (always `--cluster both`, the paper's method).
pub struct Size {
    pub name: &'static str,
    pub cfg: FrameConfig,
}

/// Whether `VPLGI_BENCH_SMOKE` asks for tiny sizes: `make test` runs every bench once that way
/// (`cargo test --benches`), to prove they work, not to measure.
pub fn smoke() -> bool {
    std::env::var("VPLGI_BENCH_SMOKE").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// `small` (128x128, 2,000 VPLs, 200 / 1,000 clusters) and `paper` (the paper's Cornell-box
/// setting: 512x512, 10,000 VPLs, 1,000 / 8,000 clusters, F = 6), or tiny stand-ins for both
/// under [`smoke`].
pub fn sizes() -> Vec<Size> {
    let paper = FrameConfig::default();
    let (small, large) = if smoke() {
        (
            FrameConfig { width: 24, height: 24, vpls: 100, k_vpl: 20, k_sp: 60, ..paper.clone() },
            FrameConfig { width: 40, height: 40, vpls: 300, k_vpl: 40, k_sp: 150, ..paper.clone() },
        )
    } else {
        (
            FrameConfig {
                width: 128,
                height: 128,
                vpls: 2000,
                k_vpl: 200,
                k_sp: 1000,
                ..paper.clone()
            },
            paper,
        )
    };
    vec![Size { name: "small", cfg: small }, Size { name: "paper", cfg: large }]
}

/// The k-means comparison with faiss (`make perf-report`): `n` positions uniform in the unit cube
/// with unit normals, and the parameters that make `cluster` plain Euclidean k-means on all of
/// them: gamma 1, and Eq. 7's normal test disabled (it is `dot > threshold`, and a dot product is
/// never below -1).
pub fn kmeans_problem(
    n: usize,
    k: u32,
    iterations: u32,
) -> (Vec<Vec3>, Vec<Vec3>, vplgi_types::clustering::ClusterParams) {
    let mut rng = vplgi_types::Rng::new(2026, vplgi_types::Stream::Oracle, 0);
    let ps: Vec<Vec3> =
        (0..n).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).collect();
    let ns: Vec<Vec3> = (0..n)
        .map(|_| vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32()))
        .collect();
    let params = vplgi_types::clustering::ClusterParams {
        k,
        gamma: 1,
        iterations,
        f: 1,
        fuzzy: vplgi_types::FuzzyMode::Hard,
        metric: vplgi_types::clustering::Metric::Eq7 { normal_threshold: -2.0 },
        representative: vplgi_types::clustering::Representative::Nearest,
        seed: 7,
    };
    (ps, ns, params)
}

/// The k-means problem's size: 1,000,000 points, K = 8,192, 10 iterations (20,000 / 256 / 3
/// under [`smoke`]).
pub fn kmeans_size() -> (usize, u32, u32) {
    if smoke() {
        (20_000, 256, 3)
    } else {
        (1_000_000, 8192, 10)
    }
}

/// Few samples: a paper-size GPU stage on lavapipe takes seconds per run.
pub fn configure(group: &mut BenchmarkGroup<WallTime>) {
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
}

/// The built-in Cornell box, for the life of the bench process.
pub fn scene() -> &'static Scene {
    static SCENE: std::sync::OnceLock<Scene> = std::sync::OnceLock::new();
    SCENE.get_or_init(vplgi_scene::cornell::cornell_box)
}

/// The CPU scene (Embree) of [`scene`].
pub fn cpu_scene() -> CpuScene<'static> {
    static DEVICE: std::sync::OnceLock<vplgi_embree::Device> = std::sync::OnceLock::new();
    let device = DEVICE.get_or_init(|| vplgi_embree::Device::new(None).expect("Embree device"));
    CpuScene::new(scene(), device).expect("Embree scene")
}

/// Every stage's inputs for one size, made by the CPU reference stage by stage.
pub struct Inputs {
    pub cfg: FrameConfig,
    pub cs: CpuScene<'static>,
    pub vpls: Vec<Vpl>,
    pub sps: Vec<ShadingPoint>,
    /// Per sample: its row among the hits, or MISS.
    pub row_of: Vec<u32>,
    /// Hit shading points and VPLs as clustering points (position, normal).
    pub sp_points: (Vec<Vec3>, Vec<Vec3>),
    pub vpl_points: (Vec<Vec3>, Vec<Vec3>),
    pub sp_clusters: Clustering,
    pub vpl_clusters: Clustering,
    pub lights: VplLights,
    /// Visibility rows (the SP clusters' representatives) and columns (the lights).
    pub rows: Vec<Endpoint>,
    pub cols: Vec<Endpoint>,
    pub matrix: BitMatrix,
}

impl Inputs {
    /// The inputs of `size`'s frame with `--gi photon`'s global photon map (2,000 photons under
    /// [`smoke`]), traced once by the CPU: the frame's inputs and the map.
    pub fn with_global_map(size: &Size) -> (Inputs, vplgi_cpu::caustics::PhotonMap) {
        let cfg = FrameConfig {
            global_photons: if smoke() { 2_000 } else { size.cfg.global_photons },
            ..size.cfg.clone()
        };
        let inputs = Inputs::new(&cfg);
        let photons =
            vplgi_cpu::trace_vpls::trace_vpls(&inputs.cs, &cfg.global_trace_params(), &NoProgress)
                .vpls;
        let map = vplgi_cpu::caustics::photon_map(&photons, cfg.photon_leaf);
        (inputs, map)
    }

    pub fn new(cfg: &FrameConfig) -> Inputs {
        let cs = cpu_scene();
        let vpls = vplgi_cpu::trace_vpls::trace_vpls(&cs, &cfg.trace_params(), &NoProgress).vpls;
        let sps =
            vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera));
        let hits: Vec<usize> = (0..sps.len()).filter(|&i| sps[i].triangle != MISS).collect();
        let mut row_of = vec![MISS; sps.len()];
        for (r, &i) in hits.iter().enumerate() {
            row_of[i] = r as u32;
        }
        let sp_points: (Vec<Vec3>, Vec<Vec3>) =
            hits.iter().map(|&i| (Vec3::from(sps[i].position), Vec3::from(sps[i].normal))).unzip();
        let vpl_points: (Vec<Vec3>, Vec<Vec3>) =
            vpls.iter().map(|v| (Vec3::from(v.position), Vec3::from(v.normal))).unzip();
        let sp_clusters = cluster(&sp_points.0, &sp_points.1, &cfg.sp_cluster_params(cs.extent));
        let vpl_clusters = cluster(&vpl_points.0, &vpl_points.1, &cfg.vpl_cluster_params());
        let lights = vplgi_cpu::shade::vpl_lights(&vpls, Some(&vpl_clusters), cfg.light_shape);
        let rows: Vec<Endpoint> = sp_clusters
            .representatives
            .iter()
            .map(|&r| Endpoint::of(&sps[hits[r as usize]]))
            .collect();
        let cols: Vec<Endpoint> = lights.lights.iter().map(|l| l.endpoint()).collect();
        let (matrix, _) = visibility(&cs, &rows, &cols, &NoProgress);
        Inputs {
            cfg: cfg.clone(),
            cs,
            vpls,
            sps,
            row_of,
            sp_points,
            vpl_points,
            sp_clusters,
            vpl_clusters,
            lights,
            rows,
            cols,
            matrix,
        }
    }

    pub fn pixels(&self) -> usize {
        (self.cfg.width * self.cfg.height) as usize
    }
}

/// The GPU of the benches, announced with the clock its timings come from. Without an adapter
/// the GPU variants are skipped with a message (and fail under `CI=true`, as the tests do).
pub struct Gpu {
    pub ctx: GpuContext,
    /// The scene on the device, with its light tables.
    pub scene: vplgi_gpu::scene::GpuScene,
}

impl Gpu {
    pub fn new(bench: &str) -> Option<Gpu> {
        match GpuContext::new() {
            Ok(ctx) => {
                let clock = if vplgi_gpu::timing::supported(&ctx.device) {
                    "device time from timestamp queries"
                } else {
                    "wall time (no timestamp queries)"
                };
                eprintln!("{bench}: GPU variants on {} ({clock})", ctx.describe());
                let gs = vplgi_gpu::scene::GpuScene::new(&ctx.device, scene()).expect("GPU scene");
                Some(Gpu { ctx, scene: gs })
            }
            Err(e) => {
                if std::env::var("CI").is_ok_and(|v| v == "true") {
                    panic!("{bench}: no GPU adapter under CI: {e}");
                }
                eprintln!("\n*** {bench}: GPU variants SKIPPED: {e} ***\n");
                None
            }
        }
    }

    /// Total time of `iters` runs of `work` (criterion's `iter_custom`): device time where the
    /// adapter has timestamp queries, else wall time up to the device going idle.
    pub fn time(&self, iters: u64, mut work: impl FnMut()) -> Duration {
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let mut total = Duration::ZERO;
        for _ in 0..iters {
            let t0 = Instant::now();
            let ((), device_time) = vplgi_gpu::timing::device_time(device, queue, || {
                work();
                sync(device).expect("device");
            })
            .expect("timestamp read-back");
            total += device_time.unwrap_or_else(|| t0.elapsed());
        }
        total
    }

    /// Points as device Endpoints.
    pub fn endpoints(&self, (ps, ns): &(Vec<Vec3>, Vec<Vec3>)) -> wgpu::Buffer {
        let e: Vec<vplgi_gpu::visibility::Endpoint> =
            ps.iter().zip(ns).map(|(&p, &n)| vplgi_gpu::visibility::Endpoint::new(p, n)).collect();
        storage(&self.ctx.device, "points", &e)
    }

    /// The CPU's shadow-ray ends on the device: the same records.
    pub fn visibility_endpoints(&self, e: &[Endpoint]) -> wgpu::Buffer {
        storage(&self.ctx.device, "endpoints", e)
    }

    /// The CPU's lights on the device, and their outlines if any are polygons: the same records.
    pub fn lights(&self, lights: &VplLights) -> (wgpu::Buffer, Option<wgpu::Buffer>) {
        let outlines = (!lights.outlines.is_empty())
            .then(|| storage(&self.ctx.device, "light outlines", &lights.outlines));
        (storage(&self.ctx.device, "lights", &lights.lights), outlines)
    }
}
