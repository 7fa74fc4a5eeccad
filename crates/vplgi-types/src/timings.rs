//! Per-stage wall times, reported alike by every backend.

use serde::Serialize;

/// Wall time of each stage, in milliseconds. `total` is the sum of the five stages (the frame);
/// building acceleration structures and uploading the scene are reported separately.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StageTimings {
    pub trace_vpls: f64,
    pub shading_points: f64,
    pub cluster: f64,
    pub visibility: f64,
    pub shade: f64,
    pub total: f64,
}

impl StageTimings {
    /// Sets `total` to the sum of the stages.
    pub fn sum(&mut self) {
        self.total = self.trace_vpls + self.shading_points + self.cluster + self.visibility + self.shade;
    }
}
