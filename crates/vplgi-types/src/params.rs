//! The parameters of each stage, as every backend takes them. [`FrameConfig`](crate::FrameConfig)
//! derives them for a frame; tests and benches build them directly. (The clustering's are in
//! [`crate::clustering::ClusterParams`].)

/// `trace_vpls`: light particles until `count` VPLs exist.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceParams {
    pub seed: u32,
    /// VPLs to create.
    pub count: u32,
    /// VPLs are deposited at the first `bounces` non-specular surfaces a particle hits.
    pub bounces: u32,
    /// Mirrors and glass a particle passes between two of those before the surface it meets
    /// is taken whatever it is (0: every surface holds a VPL).
    pub specular_depth: u32,
    /// What a particle leaves at the surfaces it hits.
    pub deposit: Deposit,
}

/// What `trace_vpls` leaves at a non-specular surface a particle hits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Deposit {
    /// A VPL at every one: the light leaving it (flux times albedo).
    #[default]
    Vpls,
    /// A caustic photon at those the particle reached straight from a mirror or glass: the
    /// light arriving (flux before the albedo), which `caustics` estimates the density of. The
    /// same paths as `Vpls` with the same seed, which is why they are one stage.
    CausticPhotons,
    /// A photon at every one, with the light arriving: Jensen's global map (`--gi photon`),
    /// whose illumination cut lights the final gather's hits. It holds the caustic photons too,
    /// so light from a caustic reaches a gather ray like any other.
    Photons,
}

impl TraceParams {
    /// `count` VPLs over `bounces` bounces, chains to the default depth.
    pub fn new(seed: u32, count: u32, bounces: u32) -> Self {
        TraceParams {
            seed,
            count,
            bounces,
            specular_depth: DEFAULT_SPECULAR_DEPTH,
            deposit: Deposit::Vpls,
        }
    }

    /// `count` caustic photons at the first `bounces` non-specular surfaces of each path.
    pub fn caustic_photons(seed: u32, count: u32, bounces: u32) -> Self {
        TraceParams { deposit: Deposit::CausticPhotons, ..Self::new(seed, count, bounces) }
    }
}

/// `caustics`: the caustic light at shading points, by k-nearest-neighbour density estimation
/// in the caustic photon map (Jensen's estimator, as Wang et al. use it for caustics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticParams {
    /// Photons per estimate: the radius is the k-th nearest's distance.
    pub k: u32,
    /// The largest radius, in scene units: where fewer than k photons lie within it, it is the
    /// radius.
    pub max_radius: f32,
    /// Photons deposited at more than this many surfaces are not counted (a bias-compensation
    /// level's points already have surfaces of their own on their path).
    pub max_bounce: u32,
    /// Camera samples per pixel: the stage returns pixel means.
    pub spp: u32,
}

/// Largest `k` of [`CausticParams`]: the GPU keeps the k nearest in a fixed array.
pub const MAX_CAUSTIC_K: u32 = 128;

/// Photons per kd-tree leaf unless told otherwise (`--photon-leaf`).
pub const DEFAULT_PHOTON_LEAF: u32 = 8;

/// Largest leaf: a leaf's photons are tested one by one.
pub const MAX_PHOTON_LEAF: u32 = 256;

/// Least cosine between a photon's surface normal and the shading point's for the photon to
/// count: photons on a wall around a corner, or on the other side of a thin wall, lie near in
/// space but light another surface.
pub const CAUSTIC_NORMAL_COS: f32 = 0.5;

/// Node visits and photon tests one estimate may make, the same on both backends: an estimate
/// that would need more keeps what it found by then and is counted. Far above what a query in a
/// balanced tree needs, and far enough below lavapipe's 65,535 loop iterations per invocation
/// for the heap's own loops.
pub const CAUSTIC_VISITS: u32 = 12_000;

/// The illumination cut of the global photon map (`--gi photon`, Wang et al. 2009, section 3.3;
/// `vplgi_shared::illumination_cut`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutParams {
    /// The target size: E_min is the mean of Eq. 3's estimates at the tree level of this many
    /// nodes.
    pub size: u32,
    /// Passes that replace a cut node by its children where the density estimate at it and
    /// Eq. 3's differ by more than `CUT_REFINE_RATIO` of the latter.
    pub refinements: u32,
    /// Photons per density estimate at a cut node.
    pub k: u32,
    /// The density estimates' largest radius, in scene units.
    pub max_radius: f32,
    /// The least node radius r_p, in scene units: a node whose photons lie at one point (or a
    /// single photon) has a box of size 0, where Eq. 3 would divide by 0 and Eq. 4's kernel
    /// reach nothing.
    pub min_radius: f32,
}

/// The refinement's threshold: a node is split where |E_p − Ẽ_p| > 1.2 Ẽ_p (Wang et al.'s ΔE).
pub const CUT_REFINE_RATIO: f32 = 1.2;

/// Where in its box a node's representative is sought (the member nearest that point): at
/// 0.5 + k / 64 of the box along axis k = 1, 2, 3, just off the centre. The two or three photons
/// of a small leaf lie on its box's corners, at exactly the same distance from the centre: a tie
/// that rounding (a fused multiply-add on a GPU) would settle either way. Off the centre, by a
/// different fraction on each axis, no two corners tie.
pub const CUT_CENTRE_SKEW: f32 = 1.0 / 64.0;

/// Most refinement passes (`--cut-refinements`): each may double the cut.
pub const MAX_CUT_REFINEMENTS: u32 = 8;

/// [`CutParams::min_radius`] per scene bounding-box diagonal.
pub const MIN_CUT_RADIUS_REL: f32 = 1e-3;

/// How far, in node radii, a gather hit that no Eq. 4 kernel reaches looks for light: such a
/// hit (in a gap between kernels, or at a corner where the near nodes lie on the other wall)
/// takes Σ w′ E / Σ w′ with w′ = K(d / (2 r_j)) max(0, n_j · n_y), Eq. 4 over twice the reach.
/// Continuous in the hit's position, as Eq. 4 is, so the twins' rounding cannot jump it; a hit
/// beyond twice every radius (behind a light close to the ceiling, where no photon lands) stays
/// dark.
pub const GATHER_FALLBACK_REACH: f32 = 2.0;

/// Real spherical-harmonic coefficients per colour channel that a `--gi photon` sample point
/// keeps of its incident light for glossy receivers: the bands l = 0..3, Wang et al.'s order 4.
pub const SH_COEFFICIENTS: usize = 16;

/// Directions of a glossy receiver's lobe over which the glossy last bounce integrates the
/// interpolated spherical harmonics (`vplgi_shared::sh::glossy_irradiance`): a fixed
/// Hammersley set, so both backends sum the same terms and a pixel's value has no noise of its
/// own. An order-4 reconstruction varies slowly: 64 directions hold the integral within 2 % of
/// a dense integration (`vplgi_shared::sh`'s tests).
pub const GLOSSY_DIRECTIONS: u32 = 64;

/// Cut-tree nodes one gather hit's lookup may visit, the same on both backends (a lookup that
/// would need more keeps what it summed and is counted): kernels of a few cut nodes overlap at
/// any point, so a lookup needs a few tree paths.
pub const GATHER_VISITS: u32 = 2048;

/// `rsm_vpls`: the reflective shadow maps of every light for a budget of about `size²` texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RsmParams {
    /// Texels per side of the budget.
    pub size: u32,
    /// Seeds the reflect-or-refract choices at glass, the maps' only randomness.
    pub seed: u32,
    /// Mirrors and glass a texel's ray passes before the surface it meets holds its VPL,
    /// whatever that surface is (0: the first hit).
    pub specular_depth: u32,
}

impl RsmParams {
    /// Maps of budget `size`², chains to the default depth.
    pub fn new(size: u32, seed: u32) -> Self {
        RsmParams { size, seed, specular_depth: DEFAULT_SPECULAR_DEPTH }
    }
}

/// `shading_points`: the camera samples of a `width` x `height` image, `spp` per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraParams {
    /// Where the image is seen from (the scene's camera, or a path's camera for this frame).
    pub camera: crate::Camera,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    /// Mirrors and glass a camera ray passes before the surface it stops at is its shading
    /// point, whatever that surface is (0: the first hit).
    pub specular_depth: u32,
}

/// Specular vertices a camera ray follows unless told otherwise (`--specular-depth`): the core
/// paper follows specular paths without a stated bound; six pass a ray through two glass
/// objects (four interfaces) and two mirrors.
pub const DEFAULT_SPECULAR_DEPTH: u32 = 6;

impl CameraParams {
    /// `width` x `height` pixels of `camera`, `spp` samples each, chains to the default depth.
    pub fn new(camera: crate::Camera, width: u32, height: u32, spp: u32, seed: u32) -> Self {
        CameraParams { camera, width, height, spp, seed, specular_depth: DEFAULT_SPECULAR_DEPTH }
    }
}

/// Jittered camera samples (`spp` > 1) estimate the emission their pixel sees from
/// `EMISSION_STRATA`² extra primary rays, one jittered in each cell of a square grid over the
/// pixel, instead of from their own ray. Where an emitter's edge crosses a pixel, one ray sees
/// all or none of its radiance: on the Cornell box that noise made the standard error of a
/// reference's top third (the rows showing the light) 18 times that of pixel-centre samples.
/// The extra rays only look up what the camera sees directly, a small part of shading a sample.
pub const EMISSION_STRATA: u32 = 4;

/// `shade`: how a pixel's radiance is gathered from its shading points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadeParams {
    /// Shading points per pixel, averaged in sample order.
    pub spp: u32,
    pub seed: u32,
    /// Shadow-ray samples per shading point towards area lights.
    pub direct_samples: u32,
    /// The clamped geometry term's bound 1 / d_min² (infinity: no clamp).
    pub g_max: f32,
    /// Whether emission and direct light are added (false: the VPLs' light only).
    pub direct: bool,
}

/// `bias_points`: one segment of a bias-compensation path per shading point, which puts back the
/// light the geometry-term clamp removes (Kollig and Keller 2004).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasParams {
    /// The seed of this compensation level ([`level_seed`]).
    pub seed: u32,
    /// The clamp's bound 1 / d_min² (the same as [`ShadeParams::g_max`]).
    pub g_max: f32,
}

/// The seed of the random decisions of compensation level `level` (0: the frame's own shading
/// points, whose seed is the frame's): each level's directions and direct-light samples are
/// independent of every other level's.
pub fn level_seed(seed: u32, level: u32) -> u32 {
    if level == 0 {
        seed
    } else {
        crate::rng::pcg_hash(seed ^ crate::rng::pcg_hash(0x6a09_e667 ^ level))
    }
}

/// Russian roulette never keeps more than this share of paths (`trace_vpls`), so paths end in
/// finite time even in a white furnace.
pub const MAX_SURVIVAL: f32 = 0.95;

/// Shadow segments start at this fraction of their length, not at 0 (`visibility`, direct
/// light). A point in a concave corner (a camera ray that hit exactly the edge where ceiling
/// meets wall) is pushed off its own surface into the plane of the other one, which the segment
/// then touches at t = 0: whether such a touch counts differs between ray tracers (Embree no,
/// Möller–Trumbore yes). Starting a hair later (1e-5 of the segment, well inside the eps offset)
/// makes every backend ignore it.
pub const SEGMENT_TNEAR: f32 = 1e-5;

/// Shadow segments between two surface points end at this fraction of their length, not at 1:
/// the same corner case at the other end. A point on the edge where a box stands on the floor,
/// pushed off the box's side, stays in the floor's plane, and the segment touches the floor at
/// t = 1 (Embree counted that touch as a blocker, obvhs and the WGSL test did not: found by the
/// visibility property test, with endpoints on edges of random rooms).
pub const SEGMENT_TFAR: f32 = 1.0 - SEGMENT_TNEAR;

/// Two surface points face each other when each one's normal makes a cosine above this with the
/// direction to the other. Points on one plane (a shading point and a VPL on the same tilted
/// wall) have cosines of 0 give or take rounding, so with a bound of 0 the sign of the rounding
/// decided whether a shadow ray was traced, and where it ran (grazing the plane, pushed to either
/// side) the answer differed between ray tracers (found by the visibility property test on random
/// triangle soups). Their transport is cos x cos = 1e-8 of a head-on pair's at most: 0 changes
/// no image, and every backend agrees.
pub const FACING_COS: f32 = 1e-4;

/// Parameters of the adaptive seeding.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeedParams {
    /// Seeds wanted (the clustering's K).
    pub k: u32,
    /// α of Eq. 2 per unit length.
    pub alpha: f32,
    pub seed: u32,
}
