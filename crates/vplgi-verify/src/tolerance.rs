//! The agreement contract of `../shared/SPEC.md` ("Stated tolerances"), one named constant per
//! bound, and [`Disagreement`]: what a comparison measured against its bound, printed by every
//! test and written by `vplgi verify`, so the margin is visible when it passes, not only when it
//! fails.

use serde::Serialize;

/// RNG: bit-identical streams.
pub const RNG_DIFFERING_DRAWS: u64 = 0;
/// BSDFs (`vplgi_shared::bsdf` and `common/bsdf.wgsl`) on the same queries: eval, pdf, sampled
/// directions, weights and densities within this, relative. The VPL row's bound: a VPL's flux is
/// a product of sample weights.
pub const BSDF_REL: f64 = 1e-4;
/// BSDF sampling: at least this share of samples leave by the same lobe with direction, weight
/// and density within [`BSDF_REL`]; the others diverge, as the VPL row lets 0.1 % of paths do:
/// a reflect-or-refract choice whose number lies within rounding of the Fresnel reflectance goes
/// either way, and a direction near the surface's plane, or from the rim of the visible-normal
/// disk, is ill-conditioned (its cosine is a small difference of nearly equal numbers).
pub const BSDF_AGREEING_SAMPLES: f64 = 0.999;
/// VPL tracing: positions, normals and fluxes within this, relative.
pub const TRACE_VPLS_REL: f64 = 1e-4;
/// VPL tracing: at most this share of paths may diverge at grazing hits.
pub const TRACE_VPLS_DIVERGED_PATHS: f64 = 1e-3;
/// Shading points: at least this share hit the same triangle (or the same point on a shared edge).
pub const SHADING_POINTS_SAME_SURFACE: f64 = 0.999;
/// Shading points: positions within this share of the scene extent.
pub const SHADING_POINTS_POSITION_REL: f64 = 1e-4;
/// Specular chains (SPEC): of the shading points reached through one mirror or glass surface,
/// at most this share may end on another surface; likewise the light paths (`trace_vpls`) whose
/// VPLs passed one. A chain diverges where the Fresnel number lies within
/// rounding of the reflectance, at total internal reflection's edge, or where a direction's
/// rounding carries it past an edge beyond the mirror; the rows above judge unchained samples.
pub const SPECULAR_CHAINS_DIVERGED: f64 = 1e-3;
/// The same for chains of two or more vertices, whose directions' rounding compounds.
pub const LONG_SPECULAR_CHAINS_DIVERGED: f64 = 5e-3;
/// Specular chains: a sample whose backends end on different surfaces is set aside as a tie
/// (and reported) where the CPU, tracing the sample's camera ray turned by this many radians
/// (or a tenth or a hundredth of it) in one of 8 directions, ends where the GPU did; likewise a
/// light path or shadow-map texel whose VPLs part beyond a tie, its emission direction turned. Each
/// backend rounds a chain's vertices its own way, so the segment after one leaves in a
/// direction a few ulps off the other's, and may pass the other side of an edge it nearly
/// meets, of a surface that crosses the mirror, or of total internal reflection's critical
/// angle. Turned by 1e-5, a ray moves by 1e-5 of the distance it goes, the unchained rows' tie
/// distance for a scene about as deep as its extent; no one-sided error of a kernel (a wrong
/// normal, index or Fresnel term) hides within it.
pub const SPECULAR_CHAIN_NUDGE: f64 = 1e-5;

/// The classes of specular chains judged apart, by the most vertices either backend passed:
/// how the rows name each, and its bound.
pub const CHAIN_CLASSES: [(&str, f64); 2] = [
    ("one mirror or glass surface", SPECULAR_CHAINS_DIVERGED),
    ("two or more", LONG_SPECULAR_CHAINS_DIVERGED),
];

/// Items of one class (light paths, texels) and those among them that diverge, the worst
/// described; and those set aside because a nudge of the CPU's emission reproduces the GPU's.
#[derive(Default)]
pub struct Diverged {
    pub items: usize,
    pub diverged: usize,
    pub nudged: usize,
    pub worst_diff: f32,
    pub worst: Option<String>,
}

impl Diverged {
    /// Counts one item that diverged by `diff`, described by `describe` if the worst so far.
    pub fn diverge(&mut self, diff: f32, describe: impl FnOnce() -> String) {
        self.diverged += 1;
        if diff > self.worst_diff || self.worst.is_none() {
            self.worst_diff = diff;
            self.worst = Some(describe());
        }
    }
}

/// The rows of `classes` ([`CHAIN_CLASSES`] order) that hold items: each one's share of
/// divergences, named by `diverge(label)`, and its nudged items, by `nudged(label)`.
pub fn chain_rows(
    stage: &str,
    case: &str,
    classes: [Diverged; 2],
    diverge: impl Fn(&str) -> String,
    nudged: impl Fn(&str) -> String,
) -> Vec<Disagreement> {
    let mut rows = Vec::new();
    for ((label, bound), class) in CHAIN_CLASSES.into_iter().zip(classes) {
        if class.items > 0 {
            rows.push(
                share_of_diverged(stage, &diverge(label), (class.diverged, class.items), bound)
                    .with_case(case)
                    .with_worst(class.worst),
            );
            rows.push(
                Disagreement::info(stage, nudged(label), class.nudged as f64).with_case(case),
            );
        }
    }
    rows
}

/// How often a row of rare events may breach its bound by chance alone: once in this many runs.
pub const CHANCE: f64 = 1e-3;

/// The most of `items` events (divergences) that a true rate of `rate` gives more often than
/// [`CHANCE`]: the smallest k with P(X > k) < CHANCE for X ~ Poisson(items × rate), the
/// binomial's limit for rare events (the normal approximation past a mean of 600).
pub fn allowed_by_chance(items: usize, rate: f64) -> usize {
    let mean = items as f64 * rate;
    if mean > 600.0 {
        return (mean + 3.1 * mean.sqrt()).ceil() as usize;
    }
    let (mut pmf, mut cdf, mut k) = ((-mean).exp(), 0.0, 0usize);
    loop {
        cdf += pmf;
        if 1.0 - cdf < CHANCE {
            return k;
        }
        k += 1;
        pmf *= mean / k as f64;
    }
}

/// The row of a divergence rate (light paths, shadow-map texels, specular chains): the share of
/// `items` of which `diverged` diverge, against
/// what a rate of `bound` gives `items` at most, but for one run in [`CHANCE`]. Divergences at
/// edges, crossings and Fresnel choices are rare independent events: a flat share would fail a
/// thousand items on their second, once in four runs at the bound's own rate. Fewer than
/// 1 / `bound` items expect less than one divergence, too few to tell a rate by: the share is
/// reported, not judged.
pub fn share_of_diverged(
    stage: &str,
    what: &str,
    (diverged, items): (usize, usize),
    bound: f64,
) -> Disagreement {
    if (items as f64) * bound < 1.0 {
        let what = format!(
            "share of the {} {what} (too few to judge against {bound}: one would be {:.1e})",
            crate::count(items),
            1.0 / items.max(1) as f64
        );
        return Disagreement::info(stage, what, diverged as f64 / items.max(1) as f64);
    }
    let allowed = allowed_by_chance(items, bound);
    Disagreement::at_most(
        stage,
        format!("share of the {} {what} (a rate of {bound} gives {allowed} or fewer but once in {:.0} runs)", crate::count(items), 1.0 / CHANCE),
        diverged as f64 / items.max(1) as f64,
        allowed as f64 / items.max(1) as f64,
    )
}
/// Bias-compensation points (`bias_points`): the same surfaces as shading points (the bound
/// above), and weights (albedo x parent albedo x clamped share 1 - g_max / G, each at most 1)
/// within this absolute difference of the weight the CPU's arithmetic gives at the GPU's point.
/// At the GPU's point, because the share moves with the pair's distance d (by about 2 δd / d
/// for a position rounding δd, already judged by the position row): compared at their own
/// points, corner pairs differed by up to 1.1e-4. Absolute, because where G barely exceeds
/// g_max the share is near 0 and its relative rounding large.
pub const BIAS_POINTS_WEIGHT_ABS: f64 = 1e-5;
/// K-means assignment given the same centroids: at least this share of identical labels. The
/// same row judges both metrics, Eq. 7 and Eq. 2 (`--metric ward`): each backend evaluates a
/// metric in the same order of operations.
pub const ASSIGN_SAME_LABELS: f64 = 0.9999;
/// Adaptive seeding (`--seeding adaptive`, Wang et al.'s quadtree) of the same hits: the same
/// seeds in the same order. Node sums are integers and the shares the same f32 operations on
/// both backends, so no seed may differ.
pub const SEEDING_DIFFERING_SEEDS: u64 = 0;
/// `--temporal on`, the admission of the same points by the same previous centres: at least this
/// share of points with the same verdict. A verdict is the assignment's nearest centre and one
/// comparison of its key, both in the same operations on both backends, so the assignment row.
pub const TEMPORAL_SAME_ADMISSION: f64 = ASSIGN_SAME_LABELS;
/// `--temporal on`, each cluster's threshold (its members' largest key) from the same clustering:
/// the maximum of keys computed in the same operations, so bit-identical.
pub const TEMPORAL_DIFFERING_THRESHOLDS: u64 = 0;
/// Centroid update given the same labels: bit-identical (integer sums): no differing centroid.
pub const UPDATE_DIFFERING_CENTROIDS: u64 = 0;
/// The RSM-space centroid update (`--vpl-cluster rsm`): float sums in the same order on both
/// backends, so the SPEC's "else 1e-6 relative", relative to the scene's diagonal.
pub const RSM_UPDATE_REL: f64 = 1e-6;
/// The RSM importance map (`rsm_importance`) of the same VPLs seen from the same G-buffer
/// points: each texel within this of its map's largest importance. Sums of 256 geometry terms
/// in the same order on both backends, but each term has a division and a square root, which
/// WGSL may round differently (2.5 ulp); the seeds depend on the map only relative to its
/// largest value. The clustering is then judged fed the CPU's map.
pub const RSM_IMPORTANCE_REL: f64 = 1e-5;
/// Fuzzy assignment: at least this share of points with identical F-index sets (either metric).
pub const FUZZY_SAME_SETS: f64 = 0.999;
/// Fuzzy assignment: weights within this, absolute, and summing to 1 within this.
pub const FUZZY_WEIGHTS_ABS: f64 = 1e-5;
/// Visibility: at least this share of identical bits between any two of Embree, obvhs, GPU.
pub const VISIBILITY_SAME_BITS: f64 = 0.999;
/// Shading and the final image on the same inputs: relMSE(GPU, CPU) at most this.
pub const SHADE_REL_MSE: f64 = 1e-4;
/// Caustic estimates (`caustics`) from the same photon map at the same shading points: each
/// channel within this, relative to the estimate's largest channel, for all but the estimates
/// whose k nearest differ ([`CAUSTICS_DIFFERING_SETS`]). The same walk and heap on both sides;
/// only a fused multiply-add in a distance or the sum separates them.
pub const CAUSTICS_REL: f64 = 1e-5;
/// Caustic estimates whose k nearest photons differ: a rate of at most this. Two photons at
/// distances a rounding apart swap places across the k-th; when that moves one photon in or out
/// of the sum the estimate moves by a photon's share, about 1 / k.
pub const CAUSTICS_DIFFERING_SETS: f64 = 1e-3;
/// `illumination_cut`: Eq. 3's estimate of a node (and the density estimate at a cut node) from
/// the same photon map, each channel within this relative to its largest channel, for all but
/// the nodes whose representative or k nearest differ ([`CUT_DIFFERING_NODES`]). Sums in member
/// order on both sides; only a fused multiply-add separates them.
pub const CUT_REL: f64 = 1e-5;
/// Nodes whose representative differs (two members a rounding apart from the centroid), density
/// estimates whose k nearest differ, and cut nodes chosen differently from each backend's own
/// numbers (a refinement decided at its threshold): a rate of at most this, as for caustics'
/// k-nearest sets.
pub const CUT_DIFFERING_NODES: f64 = 1e-3;
/// `final_gather`: a sample point's gathered irradiance from the same cut within this, relative
/// to its largest channel. The rays are `gather_radius`' and share its bound for 1 / R_j; a ray
/// whose hit moves by a rounding moves Eq. 4's kernel weights continuously, by far less.
pub const FINAL_GATHER_REL: f64 = 1e-4;
/// The lights of VPL clusters made from the same clustering (flux summed in VPL order; a disk's
/// R² from the members' moments, `vplgi_shared::disk`): within this, relative. Sums in the same
/// order, but a kernel compiler may fuse a multiply and an add the CPU rounds twice. A polygon's
/// outline (and R², its area / π) is judged by [`polygon_outline_bounds`] instead.
pub const CLUSTER_LIGHTS_REL: f64 = 1e-5;

/// How far apart the backends may place the outline of one polygon light (`--light-shape
/// polygon`): its area (so R² = area / π) and each vertex, from what rounding does to an outline,
/// and never tighter than [`CLUSTER_LIGHTS_REL`] (relative to the area, and to √area for a
/// vertex). Returns (area, vertex distance), absolute.
///
/// Why a relative bound alone cannot hold: the outline is cut from support values s_a = u_a ·
/// (x − c) over the members x around the representative c (`vplgi_shared::polygon::support`).
/// x − c rounds alike on both backends (one correctly rounded subtraction), but u_a is built
/// from the normal in multiplies and adds a kernel compiler may fuse, the dot product adds
/// three more, and so do the clip's crossings: we allow each side of the outline to sit
/// δ = 16 ε R apart, R = `reach` / cos(π/8) (every s_a is at most the members' reach from c, so
/// the outline lies in the regular octagon of that inradius, whose corners are R from c): about
/// one ulp at magnitude R for each of the ~16 operations on the way. Moving every side by δ
/// changes the area by at most `perimeter` δ; the shoelace sum adds 8 terms of 3 roundings at
/// magnitude ≤ R², on either backend: 24 ε R² more. A sliver (a cluster along a crease, seen
/// from a representative at its end) has a perimeter of twice its length and an area of length ×
/// width, so its relative bound grows as length / width: a 0.23 × 0.0014 sliver gets 1.2e-3.
/// One a random soup made was measured 1.4e-5 apart, beyond the flat 1e-5, on correct kernels. A vertex is where two
/// sides at least 45° apart meet: each moved by δ moves it by at most √(2 + √2) / sin(π/4) δ =
/// 2.61 δ; placing it in space (c + t q_x + b q_y) rounds 3 times at magnitude ≤
/// `centre_distance` (|c|) + R on either backend. Derived from this rounding model, not
/// measured; round outlines keep the flat bound (a regular octagon gets 43 ε = 5.1e-6 < 1e-5).
pub fn polygon_outline_bounds(
    area: f64,
    perimeter: f64,
    reach: f64,
    centre_distance: f64,
) -> (f64, f64) {
    let eps = f32::EPSILON as f64;
    let corner = reach / (std::f64::consts::PI / 8.0).cos();
    let delta = 16.0 * eps * corner;
    let area_bound =
        (perimeter * delta + 24.0 * eps * corner * corner).max(CLUSTER_LIGHTS_REL * area);
    let vertex_bound = (2.61 * delta + 6.0 * eps * (centre_distance + corner))
        .max(CLUSTER_LIGHTS_REL * area.sqrt());
    (area_bound, vertex_bound)
}

/// `gather_radius` (`--shade interpolate`) of the same sample points: 1 / R_j, the mean of 1 / t
/// over its rays, within [`gather_radius_bound`]. Directions differ only by the rounding of cos
/// and sin, which moves a hit by about as much.
pub const GATHER_RADIUS_REL: f64 = 1e-4;

/// How far the two backends' 1 / R of one sample point may be apart: [`GATHER_RADIUS_REL`]
/// relative, plus what the shading-point row allows a hit to move. Hits agree to
/// [`SHADING_POINTS_POSITION_REL`] × the scene's extent E, not relative to their distance: a ray
/// that meets a surface at t ≈ 4e-3 E, at a grazing angle, may move its hit by 2.5e-4 of t
/// (measured on a random soup). A move δt ≤ 1e-4 E changes 1 / t by δt / t² ≤ 1e-4 E (1 / t)²,
/// and the mean of (1 / t)² over the rays is at least (1 / R)², so 1e-4 E (1 / R)² is the
/// smallest allowance the hits' own bound implies. Derived from the SPEC's shading-point row.
pub fn gather_radius_bound(inv_radius: f64, extent: f64) -> f64 {
    GATHER_RADIUS_REL * inv_radius.abs()
        + SHADING_POINTS_POSITION_REL * extent * inv_radius * inv_radius
}

/// `shading_points`: the share of samples on the same triangle (or both missing) whose emitted
/// radiance agrees is at least 1 − rays × (1 − [`SHADING_POINTS_SAME_SURFACE`]), where `rays` are
/// the extra primary rays that find a jittered sample's emission (`EMISSION_STRATA`² at spp > 1,
/// none at spp = 1, where the emission is the hit triangle's own and must agree exactly): each of
/// them may see another surface as often as a camera ray may. Derived, not measured. At spp > 1
/// this share is loose: 1.6 % of samples may differ, so a 1 % error in every jittered sample's
/// emission passes it on the Cornell box (emitters are about 1 % of its samples); at spp = 1,
/// verify's default, the same error fails it (share 0.993 against 1). What catches that error at
/// any spp is [`SHADING_POINTS_UNREACHABLE_EMISSION`], judged per sample.
pub fn shading_points_same_emission_share(spp: u32) -> f64 {
    same_share_after(if spp > 1 { shading_points_emission_rays(spp) } else { 0 })
}

/// The rays whose emission a sample's emitted radiance is the mean of: its own at spp = 1,
/// `EMISSION_STRATA`² extra primary rays at spp > 1.
pub fn shading_points_emission_rays(spp: u32) -> u32 {
    if spp > 1 {
        vplgi_types::params::EMISSION_STRATA * vplgi_types::params::EMISSION_STRATA
    } else {
        1
    }
}

/// `shading_points`: samples whose emitted radiance is not a value the scene can give, at most
/// this many. Whichever triangles each backend's rays meet (edge ties included), a sample's
/// emission is the mean of `rays` ([`shading_points_emission_rays`]) values, each the emission of
/// one of the scene's materials or 0 (a back side, a surface that does not emit, a miss): `rays`
/// times it is a sum of `rays` of them, up to [`shading_points_emission_rounding`]. So no sample
/// of a correct kernel misses, at any spp, and a kernel that scales, offsets or mis-divides its
/// emission misses on every sample that carries any: 1 % more emission puts `rays` × it 0.01 j E
/// from the nearest sum j E, far beyond the rounding (on the Cornell box, E = (34, 24, 8): at
/// least 0.08 against 1.0e-3). Judged on the GPU's samples alone; the share above compares them
/// with the CPU's. Not judged (reported) where the scene has so many distinct emissions that
/// the sums would number more than [`SHADING_POINTS_EMISSION_SUMS`].
pub const SHADING_POINTS_UNREACHABLE_EMISSION: u64 = 0;

/// The most sums the per-sample emission row enumerates (sums of 16 values, each one of M
/// distinct emissions or 0, number C(16 + M, M): 17 for one, 74,613 for six).
pub const SHADING_POINTS_EMISSION_SUMS: u128 = 100_000;

/// How far a sum of `rays` emission values, each at most `largest` in every channel, added in
/// f32 one after another as both backends do, may round from the exact sum: each of the `rays`
/// additions rounds by at most half an ulp of a partial sum of at most `rays` × `largest`, so
/// `rays`² ε `largest` / 2 in all; twice that, which also covers dividing by `rays` (exact for
/// 16, half an ulp of the mean otherwise).
pub fn shading_points_emission_rounding(rays: u32, largest: f64) -> f64 {
    let rays = rays as f64;
    rays * rays * f32::EPSILON as f64 * largest
}

/// 1 − rays × (1 − [`SHADING_POINTS_SAME_SURFACE`]): the share of items that must agree when each
/// depends on `rays` rays, each of which may see another surface as often as a camera ray may.
fn same_share_after(rays: u32) -> f64 {
    (1.0 - rays as f64 * (1.0 - SHADING_POINTS_SAME_SURFACE)).max(0.0)
}

/// `gather_radius`: the share of sample points within [`gather_radius_bound`] is at least
/// 1 − rays × (1 − [`SHADING_POINTS_SAME_SURFACE`]): each gather ray may see a different surface
/// (or escape past a silhouette) as often as a camera ray may, and one such ray moves its point's
/// 1 / R_j by a whole term. Derived from the shading-point row, not measured.
pub fn gather_radius_same_share(rays: u32) -> f64 {
    same_share_after(rays)
}

/// The side of its bound a measurement must be on.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bound {
    AtMost(f64),
    AtLeast(f64),
    /// Measured and reported, not judged (context for the judged rows).
    Info,
}

/// A measured disagreement between two implementations of a stage, with its bound.
#[derive(Clone, Debug, Serialize)]
pub struct Disagreement {
    /// The SPEC row (and, in tests, the case) compared.
    pub stage: String,
    /// The inputs it was measured on ("both/weighted", "1,843 hit points, F = 6"); may be empty.
    pub case: String,
    /// What was measured, in words ("share of identical labels", "relMSE(GPU, CPU)").
    pub what: String,
    pub measured: f64,
    pub bound: Bound,
    /// The item that disagrees most, with both backends' values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst: Option<String>,
}

impl Disagreement {
    fn new(
        stage: impl Into<String>,
        what: impl Into<String>,
        measured: f64,
        bound: Bound,
    ) -> Disagreement {
        Disagreement {
            stage: stage.into(),
            case: String::new(),
            what: what.into(),
            measured,
            bound,
            worst: None,
        }
    }

    /// `measured` must be at most `bound`.
    pub fn at_most(
        stage: impl Into<String>,
        what: impl Into<String>,
        measured: f64,
        bound: f64,
    ) -> Disagreement {
        Disagreement::new(stage, what, measured, Bound::AtMost(bound))
    }

    /// `measured` must be at least `bound` (agreement shares).
    pub fn at_least(
        stage: impl Into<String>,
        what: impl Into<String>,
        measured: f64,
        bound: f64,
    ) -> Disagreement {
        Disagreement::new(stage, what, measured, Bound::AtLeast(bound))
    }

    /// A measurement reported beside the judged ones.
    pub fn info(stage: impl Into<String>, what: impl Into<String>, measured: f64) -> Disagreement {
        Disagreement::new(stage, what, measured, Bound::Info)
    }

    pub fn with_case(mut self, case: impl Into<String>) -> Disagreement {
        self.case = case.into();
        self
    }

    pub fn with_worst(mut self, worst: Option<String>) -> Disagreement {
        self.worst = worst;
        self
    }

    /// Whether the measurement is judged against a bound.
    pub fn judged(&self) -> bool {
        self.bound != Bound::Info
    }

    /// Whether the bound holds (always, for a measurement that is not judged). NaN never holds.
    pub fn holds(&self) -> bool {
        match self.bound {
            Bound::AtMost(b) => self.measured <= b,
            Bound::AtLeast(b) => self.measured >= b,
            Bound::Info => true,
        }
    }

    /// The measured value as the report prints it: shares to the digit their bounds need,
    /// counts as integers, other measures in scientific form.
    pub fn measured_text(&self) -> String {
        let m = self.measured;
        match self.bound {
            Bound::AtLeast(_) => format!("{m:.6}"),
            _ if m.fract() == 0.0 && m.abs() < 1e15 => format!("{m:.0}"),
            _ => format!("{m:.3e}"),
        }
    }

    /// The bound as the report prints it (`<= 1e-4`, `>= 0.999`, or `-`).
    pub fn bound_text(&self) -> String {
        let show =
            |b: f64| if b != 0.0 && b.abs() < 1e-3 { format!("{b:e}") } else { b.to_string() };
        match self.bound {
            Bound::AtMost(b) => format!("<= {}", show(b)),
            Bound::AtLeast(b) => format!(">= {}", show(b)),
            Bound::Info => "-".into(),
        }
    }

    /// How much of its bound the check used, 1 at the bound, above 1 failing: measured / bound
    /// for an upper bound, and for a lower bound on a share the disagreeing share over the
    /// allowed one, (1 - measured) / (1 - bound). None for information.
    pub fn used(&self) -> Option<f64> {
        let ratio = |num: f64, den: f64| {
            if den > 0.0 {
                num.max(0.0) / den
            } else if num <= 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        };
        match self.bound {
            Bound::AtMost(b) => Some(ratio(self.measured, b)),
            Bound::AtLeast(b) if b <= 1.0 => Some(ratio(1.0 - self.measured, 1.0 - b)),
            Bound::AtLeast(b) => Some(ratio(b - self.measured, b)),
            Bound::Info => None,
        }
    }

    /// `ok`, `FAILS`, or `info`.
    pub fn verdict(&self) -> &'static str {
        match (self.judged(), self.holds()) {
            (false, _) => "info",
            (true, true) => "ok",
            (true, false) => "FAILS",
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
        let case = if self.case.is_empty() { String::new() } else { format!(" ({})", self.case) };
        write!(f, "[{}{case}] {}: {}", self.stage, self.what, self.measured_text())?;
        if self.judged() {
            write!(f, " (bound {}) {}", self.bound_text(), self.verdict())?;
        }
        if let Some(w) = &self.worst {
            write!(f, "; worst: {w}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The share of a bound a check used: 1 at the bound, above it failing, for both kinds of
    /// bound, zero bounds included; none for information.
    #[test]
    fn used_is_the_measured_share_of_the_bound() {
        let used = |d: Disagreement| d.used().unwrap();
        assert_eq!(used(Disagreement::at_most("s", "w", 0.5e-4, 1e-4)), 0.5);
        assert_eq!(used(Disagreement::at_most("s", "w", 2e-4, 1e-4)), 2.0);
        assert_eq!(used(Disagreement::at_most("s", "w", 0.0, 0.0)), 0.0);
        assert!(used(Disagreement::at_most("s", "w", 1.0, 0.0)).is_infinite());
        assert!((used(Disagreement::at_least("s", "w", 0.9995, 0.999)) - 0.5).abs() < 1e-9);
        assert!((used(Disagreement::at_least("s", "w", 0.99, 0.999)) - 10.0).abs() < 1e-6);
        assert_eq!(used(Disagreement::at_least("s", "w", 1.0, 0.999)), 0.0);
        assert_eq!(Disagreement::info("s", "w", 3.0).used(), None);
        for d in
            [Disagreement::at_most("s", "w", 3.0, 2.0), Disagreement::at_least("s", "w", 0.5, 0.9)]
        {
            assert_eq!(d.holds(), d.used().unwrap() <= 1.0);
        }
    }

    #[test]
    fn chance_allows_what_a_poisson_tail_gives() {
        // Mean 1: P(X > 4) = 3.7e-3, P(X > 5) = 5.9e-4.
        assert_eq!(allowed_by_chance(1000, 1e-3), 5);
        // Mean 0.1: P(X > 1) = 4.7e-3, P(X > 2) = 1.5e-4.
        assert_eq!(allowed_by_chance(100, 1e-3), 2);
        assert_eq!(allowed_by_chance(0, 1e-3), 0);
        // Mean 1,000, past the exact sum: about 3.1 sigma over the mean.
        assert_eq!(allowed_by_chance(1_000_000, 1e-3), 1099);
        let row = |d| share_of_diverged("s", "x", (d, 1000), 1e-3).holds();
        assert!(row(5) && !row(6));
        assert!(
            matches!(share_of_diverged("s", "x", (2, 999), 1e-3).bound, Bound::Info),
            "too few to judge"
        );
        // The row holds at exactly the allowed count and fails one past it, whatever the items.
        for items in 1000..3000 {
            let allowed = allowed_by_chance(items, 1e-3);
            let row = |d| share_of_diverged("s", "x", (d, items), 1e-3).holds();
            assert!(row(allowed) && !row(allowed + 1), "{items} items, {allowed} allowed");
        }
    }

    #[test]
    fn bounds_hold_and_fail_on_the_right_side() {
        assert!(Disagreement::at_most("s", "x", 1e-5, SHADE_REL_MSE).holds());
        assert!(!Disagreement::at_most("s", "x", 2e-4, SHADE_REL_MSE).holds());
        assert!(Disagreement::at_least("s", "x", 0.9995, VISIBILITY_SAME_BITS).holds());
        assert!(!Disagreement::at_least("s", "x", 0.99, VISIBILITY_SAME_BITS).holds());
        assert!(!Disagreement::at_most("s", "x", f64::NAN, SHADE_REL_MSE).holds(), "NaN must fail");
        assert!(
            Disagreement::info("s", "x", f64::NAN).holds()
                && !Disagreement::info("s", "x", 1.0).judged()
        );
        assert!(
            std::panic::catch_unwind(|| Disagreement::at_most("s", "x", 1.0, 0.0).check()).is_err()
        );
    }

    #[test]
    fn the_printed_line_names_case_bound_verdict_and_worst_item() {
        let d = Disagreement::at_most("shade", "relMSE(GPU, CPU)", 3.2e-2, SHADE_REL_MSE)
            .with_case("both/weighted")
            .with_worst(Some("pixel (3, 4)".into()));
        assert_eq!(d.to_string(), "[shade (both/weighted)] relMSE(GPU, CPU): 3.200e-2 (bound <= 1e-4) FAILS; worst: pixel (3, 4)");
        assert_eq!(
            Disagreement::at_most("rng", "draws that differ", 0.0, 0.0).to_string(),
            "[rng] draws that differ: 0 (bound <= 0) ok"
        );
    }
}
