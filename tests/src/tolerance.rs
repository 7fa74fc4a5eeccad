//! The agreement contract of `../shared/SPEC.md` ("Stated tolerances"), one named constant per
//! bound, and [`Disagreement`]: what a differential test measured against its bound, printed by
//! every test so the margin is visible when it passes, not only when it fails.

/// RNG: bit-identical streams.
pub const RNG_DIFFERING_DRAWS: u64 = 0;
/// VPL tracing: positions, normals and fluxes within this, relative.
pub const TRACE_VPLS_REL: f64 = 1e-4;
/// VPL tracing: at most this share of paths may diverge at grazing hits.
pub const TRACE_VPLS_DIVERGED_PATHS: f64 = 1e-3;
/// Shading points: at least this share hit the same triangle (or the same point on a shared edge).
pub const SHADING_POINTS_SAME_SURFACE: f64 = 0.999;
/// Shading points: positions within this share of the scene extent.
pub const SHADING_POINTS_POSITION_REL: f64 = 1e-4;
/// K-means assignment given the same centroids: at least this share of identical labels.
pub const ASSIGN_SAME_LABELS: f64 = 0.9999;
/// Centroid update given the same labels: bit-identical (integer sums): no differing centroid.
pub const UPDATE_DIFFERING_CENTROIDS: u64 = 0;
/// Fuzzy assignment: at least this share of points with identical F-index sets.
pub const FUZZY_SAME_SETS: f64 = 0.999;
/// Fuzzy assignment: weights within this, absolute.
pub const FUZZY_WEIGHTS_ABS: f64 = 1e-5;
/// Visibility: at least this share of identical bits between any two of Embree, obvhs, GPU.
pub const VISIBILITY_SAME_BITS: f64 = 0.999;
/// Shading and the final image on the same inputs: relMSE(GPU, CPU) at most this.
pub const SHADE_REL_MSE: f64 = 1e-4;

/// A measured disagreement between two implementations of a stage, with its bound.
#[derive(Clone, Debug)]
pub struct Disagreement {
    /// The stage (and case) compared.
    pub stage: String,
    /// What was measured, in words ("labels differ", "relMSE", ...).
    pub what: &'static str,
    pub measured: f64,
    pub bound: f64,
    /// Whether `measured` must be at least (`true`) or at most (`false`) `bound`.
    pub at_least: bool,
}

impl Disagreement {
    /// `measured` must be at most `bound`.
    pub fn at_most(stage: impl Into<String>, what: &'static str, measured: f64, bound: f64) -> Disagreement {
        Disagreement { stage: stage.into(), what, measured, bound, at_least: false }
    }

    /// `measured` must be at least `bound` (agreement shares).
    pub fn at_least(stage: impl Into<String>, what: &'static str, measured: f64, bound: f64) -> Disagreement {
        Disagreement { stage: stage.into(), what, measured, bound, at_least: true }
    }

    pub fn holds(&self) -> bool {
        if self.at_least {
            self.measured >= self.bound
        } else {
            self.measured <= self.bound
        }
    }

    /// Prints the measurement and panics if the bound does not hold.
    pub fn check(&self) {
        println!("{self}");
        assert!(self.holds(), "{self}");
    }
}

impl std::fmt::Display for Disagreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (op, verdict) = (if self.at_least { ">=" } else { "<=" }, if self.holds() { "ok" } else { "FAILS" });
        // Shares are printed to the digit their bounds need, other measures in scientific form.
        let measured = if self.at_least { format!("{:.6}", self.measured) } else { format!("{:.3e}", self.measured) };
        write!(f, "[{}] {}: {measured} (bound {op} {}) {verdict}", self.stage, self.what, self.bound)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_hold_and_fail_on_the_right_side() {
        assert!(Disagreement::at_most("s", "x", 1e-5, SHADE_REL_MSE).holds());
        assert!(!Disagreement::at_most("s", "x", 2e-4, SHADE_REL_MSE).holds());
        assert!(Disagreement::at_least("s", "x", 0.9995, VISIBILITY_SAME_BITS).holds());
        assert!(!Disagreement::at_least("s", "x", 0.99, VISIBILITY_SAME_BITS).holds());
        assert!(std::panic::catch_unwind(|| Disagreement::at_most("s", "x", 1.0, 0.0).check()).is_err());
    }
}
