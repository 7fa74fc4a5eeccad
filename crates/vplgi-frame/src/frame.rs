//! What a frame returns, whatever backend rendered it.

use crate::stages::Stage;
use serde::de::Error as _;
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;
use vplgi_shared::rsm::RsmCentre;
use vplgi_types::clustering::Centre;

/// Wall time of each stage in milliseconds, an ordered list over [`Stage`], and of the frame.
/// A frame's total is the sum of its stages; a summary of several frames ([`Self::combine`])
/// summarises the totals on their own, as the paper's timing method does. Loading and building
/// acceleration structures are reported separately. Serialised as
/// `{ "trace_vpls": ms, ..., "total": ms }`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageTimings {
    ms: [f64; Stage::ALL.len()],
    total: f64,
}

impl StageTimings {
    pub fn get(&self, stage: Stage) -> f64 {
        self.ms[stage as usize]
    }

    /// Adds `ms` to the stage and to the total.
    pub fn add(&mut self, stage: Stage, ms: f64) {
        self.ms[stage as usize] += ms;
        self.total += ms;
    }

    /// The frame's time: the sum of its stages, or the summary of several frames' totals.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// The stages with their times, in pipeline order.
    pub fn iter(&self) -> impl Iterator<Item = (Stage, f64)> + '_ {
        Stage::ALL.into_iter().map(|s| (s, self.get(s)))
    }

    /// Each stage's time, and the total, by `pick` over the runs' times of that stage (a median,
    /// the mean of the best few, ...): each on its own, so the total need not be the sum.
    pub fn combine(runs: &[StageTimings], pick: impl Fn(&mut Vec<f64>) -> f64) -> StageTimings {
        let mut t = StageTimings {
            total: pick(&mut runs.iter().map(|r| r.total).collect()),
            ..Default::default()
        };
        for s in Stage::ALL {
            t.ms[s as usize] = pick(&mut runs.iter().map(|r| r.get(s)).collect());
        }
        t
    }

    /// Each stage's median over `runs` (the upper median for an even count; zeros for none).
    pub fn median(runs: &[StageTimings]) -> StageTimings {
        StageTimings::combine(runs, |v| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        })
    }
}

impl Serialize for StageTimings {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(Stage::ALL.len() + 1))?;
        for (stage, ms) in self.iter() {
            m.serialize_entry(stage.name(), &ms)?;
        }
        m.serialize_entry("total", &self.total())?;
        m.end()
    }
}

impl<'de> Deserialize<'de> for StageTimings {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let map = BTreeMap::<String, f64>::deserialize(d)?;
        let mut t = StageTimings::default();
        for (key, ms) in map {
            match Stage::from_name(&key) {
                Some(stage) => t.ms[stage as usize] = ms,
                None if key == "total" => t.total = ms,
                None => return Err(D::Error::custom(format!("unknown stage `{key}` in timings"))),
            }
        }
        Ok(t)
    }
}

/// Counts that describe what a frame did, the same for every backend.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    pub vpls: u32,
    pub light_particles: u32,
    pub vpl_clusters: u32,
    pub shading_points: u32,
    pub shading_point_hits: u32,
    pub sp_clusters: u32,
    /// Shading points whose 27-cell neighbourhood had no compatible centroid.
    pub sp_widened: u32,
    pub vpl_widened: u32,
    /// Shadow rays traced by `visibility`, where the backend counts them (pairs whose surfaces
    /// face away get no ray).
    pub visibility_rays: Option<u64>,
    /// Those rays per second inside `visibility` (millions).
    pub visibility_mrays_per_s: Option<f64>,
    /// The geometry-term clamp: G <= 1 / d_min², d_min = g_clamp_rel * scene extent.
    pub g_clamp_d_min: f32,
    pub scene_extent: f32,
    /// Surface points shaded for the bias compensation, over all levels (0 without it).
    #[serde(default)]
    pub bias_points: u64,
    /// `--temporal on` after the first frame: the previous frame's shading-point clusters kept,
    /// and the new ones seeded on shading points none of them admits.
    #[serde(default)]
    pub sp_kept: u32,
    #[serde(default)]
    pub sp_fresh: u32,
    /// `--temporal on` with `--vpl-cluster rsm` after the first frame: the previous frame's VPL
    /// clusters kept, and the slots seeded anew (those that emptied or were never filled).
    #[serde(default)]
    pub vpl_kept: u32,
    #[serde(default)]
    pub vpl_fresh: u32,
    /// `--caustics photons`: the caustic map's photons, the light particles traced for them,
    /// and the estimates (camera and bias-compensation points) that stopped at the visit budget.
    #[serde(default)]
    pub caustic_photons: u32,
    #[serde(default)]
    pub caustic_particles: u32,
    #[serde(default)]
    pub caustic_truncated: u64,
    /// `--gi photon`: the global map's photons and the light particles traced for them.
    #[serde(default)]
    pub global_photons: u32,
    #[serde(default)]
    pub global_particles: u32,
    /// `--gi photon`: the illumination cut's size before and after its refinements, the density
    /// estimates it made and how many of those stopped at the visit budget.
    #[serde(default)]
    pub cut_coarse: u32,
    #[serde(default)]
    pub cut_size: u32,
    #[serde(default)]
    pub cut_estimates: u32,
    #[serde(default)]
    pub cut_truncated: u32,
    /// `--gi photon`: gather hits on a non-specular surface that no cut node's kernel reached
    /// (lit by kernels twice as wide instead), and lookups stopped at the visit
    /// budget (`GATHER_VISITS`).
    #[serde(default)]
    pub gather_fallback: u64,
    #[serde(default)]
    pub gather_truncated: u64,
}

/// A rendered frame: linear RGB, row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
    pub timings: StageTimings,
    pub stats: FrameStats,
    /// With `--temporal on`: the shading-point clusters, for the next frame (empty otherwise).
    pub centres: Vec<Centre>,
    /// With `--temporal on` and `--vpl-cluster rsm`: the live VPL clusters, for the next frame.
    pub rsm_centres: Vec<RsmCentre>,
}

/// Why a frame could not be rendered, before any backend work.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("invalid parameters: {0}")]
    InvalidConfig(String),
}

/// Progress of long stages. Implementations must be cheap and thread-safe: `inc` is called from
/// worker threads.
pub trait Progress: Sync {
    fn start(&self, _stage: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn set(&self, _done: u64) {}
    fn finish(&self) {}
}

/// Reports nothing.
pub struct NoProgress;
impl Progress for NoProgress {}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(a: f64, b: f64) -> StageTimings {
        let mut t = StageTimings::default();
        t.add(Stage::TraceVpls, a);
        t.add(Stage::Shade, b);
        t
    }

    #[test]
    fn median_takes_each_stage_on_its_own() {
        let m = StageTimings::median(&[t(1.0, 30.0), t(3.0, 10.0), t(2.0, 20.0)]);
        assert_eq!((m.get(Stage::TraceVpls), m.get(Stage::Shade), m.total()), (2.0, 20.0, 22.0));
        // The total is summarised on its own: the median frame, not the sum of the medians.
        let m = StageTimings::median(&[t(1.0, 1.0), t(10.0, 10.0), t(0.5, 30.0)]);
        assert_eq!((m.get(Stage::TraceVpls), m.get(Stage::Shade), m.total()), (1.0, 10.0, 20.0));
        assert_eq!(StageTimings::median(&[]).total(), 0.0);
        assert_eq!(t(1.0, 2.0).iter().last(), Some((Stage::BiasPoints, 0.0)));
        assert_eq!(t(1.0, 2.0).iter().nth(9), Some((Stage::Shade, 2.0)));
    }

    #[test]
    fn timings_round_trip_through_json_with_their_total() {
        let json = serde_json::to_value(t(1.5, 2.0)).unwrap();
        assert_eq!(json["trace_vpls"], 1.5);
        assert_eq!(json["total"], 3.5);
        let back: StageTimings = serde_json::from_value(json).unwrap();
        assert_eq!(back, t(1.5, 2.0));
        let bad = serde_json::from_str::<StageTimings>(r#"{"trace":1}"#).unwrap_err();
        assert!(bad.to_string().contains("unknown stage `trace`"), "{bad}");
    }

    #[test]
    fn stage_names_are_unique_and_parse_back() {
        for s in Stage::ALL {
            assert_eq!(Stage::from_name(s.name()), Some(s));
        }
    }
}
