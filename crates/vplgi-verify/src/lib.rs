//! Differential verification: every stage of the GPU twin against the CPU reference, measured
//! against the SPEC's tolerance table ([`tolerance`]).
//!
//! Each stage is judged **chained**: the GPU kernel is fed the CPU's outputs of the stages
//! before it, so a stage is compared on identical inputs and a disagreement belongs to it. The
//! whole frame, each backend chaining its own stages, is compared separately ([`frame`]), with
//! the differences the chain itself introduces (primary rays that tie on shared edges) counted
//! and explained.
//!
//! One module per stage, named like the stage, holds the comparison both `vplgi verify` and the
//! property tests in `tests/` run: the measurement is written once.

pub mod bsdf;
pub mod frame;
pub mod inputs;
pub mod map;
pub mod report;
pub mod rng;
pub mod segment;
pub mod tolerance;
use vplgi_frame::stage_table;
// One comparison module per stage of the table (its parts are compared in the stage's module).
macro_rules! verify_modules {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        $(pub mod $name;)*
    };
}
stage_table!(verify_modules);

use serde::Serialize;
use std::time::Instant;
use tolerance::Disagreement;
use vplgi_cpu::CpuScene;
use vplgi_gpu::{GpuBackend, GpuError};
use vplgi_scene::Scene;
use vplgi_types::{ClusterMode, FrameConfig, FuzzyMode, ShadeMode};

/// The two implementations of one scene: the CPU reference and the GPU twin.
pub struct Twins<'a> {
    pub scene: &'a Scene,
    pub cpu: &'a CpuScene<'a>,
    pub gpu: &'a GpuBackend<'a>,
}

impl Twins<'_> {
    pub fn device(&self) -> &wgpu::Device {
        self.gpu.device().0
    }
    pub fn queue(&self) -> &wgpu::Queue {
        self.gpu.device().1
    }
}

/// Why verification could not run (a failed comparison is not an error: it is a result).
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Frame(#[from] vplgi_frame::FrameError),
    #[error("{0}")]
    TooLarge(String),
}

macro_rules! verify_stages {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        /// What `verify` compares, in pipeline order: the RNG and the BSDFs, every stage of the table (each
        /// chained: on the CPU's outputs of the stages before it), and the whole frame.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
        #[serde(rename_all = "snake_case")]
        pub enum VerifyStage {
            /// The counter-based RNG streams.
            Rng,
            /// The BSDFs' eval, pdf and sampling.
            Bsdf,
            $($(#[$doc])* $Trait,)*
            /// The whole frame, each backend chaining its own stages.
            Frame,
        }

        impl VerifyStage {
            pub const ALL: [VerifyStage; [VerifyStage::Rng, VerifyStage::Bsdf, $(VerifyStage::$Trait,)* VerifyStage::Frame].len()] =
                [VerifyStage::Rng, VerifyStage::Bsdf, $(VerifyStage::$Trait,)* VerifyStage::Frame];

            /// The stage's name: the CPU module's, the GPU kernel's and the `.wgsl` file's.
            pub fn name(self) -> &'static str {
                match self {
                    VerifyStage::Rng => "rng",
                    VerifyStage::Bsdf => "bsdf",
                    $(VerifyStage::$Trait => stringify!($name),)*
                    VerifyStage::Frame => "frame",
                }
            }

            /// Measures this stage of the plan.
            fn verify(self, twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
                match self {
                    VerifyStage::Rng => rng::verify(twins, plan),
                    VerifyStage::Bsdf => bsdf::verify(twins, plan),
                    $(VerifyStage::$Trait => $name::verify(twins, plan),)*
                    VerifyStage::Frame => frame::verify(twins, plan),
                }
            }
        }
    };
}
stage_table!(verify_stages);

impl VerifyStage {
    pub fn from_name(name: &str) -> Option<VerifyStage> {
        VerifyStage::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// A frame mode: which point sets are clustered and how fuzzy visibility is combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Mode {
    pub cluster: ClusterMode,
    pub fuzzy: FuzzyMode,
}

impl Mode {
    /// Every distinct mode: the fuzzy choice matters only when shading points are clustered.
    pub const ALL: [Mode; 8] = [
        Mode { cluster: ClusterMode::None, fuzzy: FuzzyMode::Weighted },
        Mode { cluster: ClusterMode::Vpl, fuzzy: FuzzyMode::Weighted },
        Mode { cluster: ClusterMode::Sp, fuzzy: FuzzyMode::Hard },
        Mode { cluster: ClusterMode::Sp, fuzzy: FuzzyMode::Average },
        Mode { cluster: ClusterMode::Sp, fuzzy: FuzzyMode::Weighted },
        Mode { cluster: ClusterMode::Both, fuzzy: FuzzyMode::Hard },
        Mode { cluster: ClusterMode::Both, fuzzy: FuzzyMode::Average },
        Mode { cluster: ClusterMode::Both, fuzzy: FuzzyMode::Weighted },
    ];

    pub fn of(cfg: &FrameConfig) -> Mode {
        Mode { cluster: cfg.cluster, fuzzy: cfg.fuzzy }
    }

    /// `cfg` in this mode. Interpolation needs clustered shading points: a mode without them
    /// shades as the core paper does.
    pub fn apply(self, cfg: &FrameConfig) -> FrameConfig {
        let shade = if self.cluster.clusters_sps() { cfg.shade } else { ShadeMode::Fuzzy };
        FrameConfig { cluster: self.cluster, fuzzy: self.fuzzy, shade, ..cfg.clone() }
    }

    /// [`Self::name`], with `+interpolate` when `cfg` interpolates in this mode.
    pub fn name_in(self, cfg: &FrameConfig) -> String {
        match self.apply(cfg).shade {
            ShadeMode::Interpolate => format!("{}+interpolate", self.name()),
            ShadeMode::Fuzzy => self.name(),
        }
    }

    /// `both/weighted`; `none` and `vpl` alone (their fuzzy choice does not apply).
    pub fn name(self) -> String {
        let c = serde_json::to_value(self.cluster)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        if self.cluster.clusters_sps() {
            let f = serde_json::to_value(self.fuzzy)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default();
            format!("{c}/{f}")
        } else {
            c
        }
    }
}

/// `cfg` interpolating: its own clustering of shading points, or both point sets clustered if it
/// clusters none.
pub fn interpolating(cfg: &FrameConfig) -> FrameConfig {
    let cluster = if cfg.cluster.clusters_sps() { cfg.cluster } else { ClusterMode::Both };
    FrameConfig { shade: ShadeMode::Interpolate, cluster, ..cfg.clone() }
}

/// Two images of the same thing, one per backend, shown side by side in the report.
#[derive(Clone, Debug)]
pub struct ImagePair {
    pub case: String,
    pub width: u32,
    pub height: u32,
    pub cpu: Vec<[f32; 3]>,
    pub gpu: Vec<[f32; 3]>,
}

/// What one stage measured.
#[derive(Clone, Debug, Serialize)]
pub struct StageResult {
    pub stage: VerifyStage,
    pub checks: Vec<Disagreement>,
    /// Sentences that explain the numbers (what was compared, why a difference is expected).
    pub notes: Vec<String>,
    pub seconds: f64,
    #[serde(skip)]
    pub images: Vec<ImagePair>,
    /// Where the items of an image-space stage disagree, one map per case.
    #[serde(skip)]
    pub maps: Vec<map::DisagreementMap>,
}

impl StageResult {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(Disagreement::holds)
    }

    /// The judged checks that fail.
    pub fn failures(&self) -> impl Iterator<Item = &Disagreement> {
        self.checks.iter().filter(|c| !c.holds())
    }

    /// The largest share of its bound any judged check used ([`Disagreement::used`]); None when
    /// nothing was judged.
    pub fn worst_used(&self) -> Option<f64> {
        self.checks.iter().filter_map(Disagreement::used).reduce(f64::max)
    }
}

/// What to verify: the frame, its modes and stages.
pub struct Plan {
    /// The frame whose stages are compared (its mode is the first of `modes`' for the stages that
    /// depend on one).
    pub config: FrameConfig,
    /// Modes the shade and frame stages run in.
    pub modes: Vec<Mode>,
    pub stages: Vec<VerifyStage>,
}

/// Hears about each stage as it finishes.
pub trait Listener {
    fn started(&self, _stage: VerifyStage) {}
    fn finished(&self, _result: &StageResult) {}
}

/// A listener that hears nothing.
pub struct Quiet;
impl Listener for Quiet {}

/// Runs the plan's stages in pipeline order.
pub fn run(
    twins: &Twins,
    plan: &Plan,
    listener: &dyn Listener,
) -> Result<Vec<StageResult>, VerifyError> {
    let mut stages = plan.stages.clone();
    stages.sort();
    stages.dedup();
    let mut results = Vec::new();
    for stage in stages {
        listener.started(stage);
        let clock = Instant::now();
        let mut r = stage.verify(twins, plan)?;
        r.seconds = clock.elapsed().as_secs_f64();
        listener.finished(&r);
        results.push(r);
    }
    Ok(results)
}

/// A new result of `stage` with nothing measured yet.
fn result(stage: VerifyStage) -> StageResult {
    StageResult {
        stage,
        checks: Vec::new(),
        notes: Vec::new(),
        seconds: 0.0,
        images: Vec::new(),
        maps: Vec::new(),
    }
}

/// `v` with thousands separated: 16,384.
pub(crate) fn count(v: usize) -> String {
    let s = v.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// Three floats as `(x, y, z)` with 7 significant digits, for worst-item descriptions.
pub(crate) fn v3(v: [f32; 3]) -> String {
    format!("({:.7e}, {:.7e}, {:.7e})", v[0], v[1], v[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_modes_are_distinct() {
        for s in VerifyStage::ALL {
            assert_eq!(VerifyStage::from_name(s.name()), Some(s));
        }
        let names: std::collections::BTreeSet<String> =
            Mode::ALL.iter().map(|m| m.name()).collect();
        assert_eq!(names.len(), Mode::ALL.len());
        assert!(names.contains("both/weighted") && names.contains("none"));
        assert_eq!(count(16384), "16,384");
        assert_eq!(count(999), "999");
    }
}
