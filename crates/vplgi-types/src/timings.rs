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

    /// The five stages by name, in pipeline order (`total` left out).
    pub fn stages(&self) -> [(&'static str, f64); 5] {
        [
            ("trace_vpls", self.trace_vpls),
            ("shading_points", self.shading_points),
            ("cluster", self.cluster),
            ("visibility", self.visibility),
            ("shade", self.shade),
        ]
    }

    /// Each field's median over `runs` (the upper median for an even count; zeros for none).
    pub fn median(runs: &[StageTimings]) -> StageTimings {
        let m = |f: fn(&StageTimings) -> f64| {
            let mut v: Vec<f64> = runs.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        };
        StageTimings {
            trace_vpls: m(|t| t.trace_vpls),
            shading_points: m(|t| t.shading_points),
            cluster: m(|t| t.cluster),
            visibility: m(|t| t.visibility),
            shade: m(|t| t.shade),
            total: m(|t| t.total),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_takes_each_stage_on_its_own() {
        let t = |a: f64, b: f64| StageTimings { trace_vpls: a, shade: b, total: a + b, ..Default::default() };
        let m = StageTimings::median(&[t(1.0, 30.0), t(3.0, 10.0), t(2.0, 20.0)]);
        assert_eq!((m.trace_vpls, m.shade, m.total), (2.0, 20.0, 22.0));
        assert_eq!(StageTimings::median(&[]).total, 0.0);
        assert_eq!(t(1.0, 2.0).stages()[4], ("shade", 2.0));
    }
}
