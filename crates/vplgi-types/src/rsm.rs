//! The records of reflective shadow maps (Prutkin et al. 2012) that cross between host and
//! device or between frames: each light's map, the RSM-space clustering's parameters and the
//! state of one of its clusters. The arithmetic on them is `vplgi_shared::rsm`.

use bytemuck::{Pod, Zeroable};
use serde::{Deserialize, Serialize};

/// [`RsmLight::kind`]: one emissive triangle.
pub const RSM_AREA: u32 = 0;
/// [`RsmLight::kind`]: a point light.
pub const RSM_POINT: u32 = 1;
/// [`RsmLight::kind`]: a spot light.
pub const RSM_SPOT: u32 = 2;
/// [`RsmLight::kind`]: a directional light.
pub const RSM_DIRECTIONAL: u32 = 3;

/// One light's map. The same bytes as `RsmLight` in `rsm_vpls.wgsl` (five `vec4`s).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RsmLight {
    /// Area: the triangle's first vertex; point and spot: the light's position; directional: the
    /// centre of the square its rays start from.
    pub origin: [f32; 3],
    pub kind: u32,
    /// Area: the edge to the second vertex; spot: the map's right axis times tan θ_outer;
    /// directional: the square's right axis times its half side.
    pub e1: [f32; 3],
    /// Texels per side (0 until `vplgi_shared::rsm::sized`).
    pub size: u32,
    /// Area: the edge to the third vertex; spot: the map's up axis times tan θ_outer;
    /// directional: the square's up axis times its half side.
    pub e2: [f32; 3],
    /// Global index of the map's first texel.
    pub first: u32,
    /// Area: the unit geometric normal; spot: the unit direction it points to; directional: the
    /// unit direction the light travels in.
    pub axis: [f32; 3],
    /// Spot: cosine of the inner cone angle.
    pub cos_inner: f32,
    /// Area: emitted power π A L_e; point: 4π I; spot: the intensity I; directional: the
    /// irradiance E. Per texel: see `vplgi_shared::rsm::texel_ray`.
    pub power: [f32; 3],
    /// Spot: cosine of the outer cone angle.
    pub cos_outer: f32,
}

/// The weights of Eq. 1 of Prutkin et al.: position, normal and flux colour.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RsmWeights {
    /// w_d, on squared distances in units of the scene's bounding-box diagonal.
    pub position: f32,
    /// w_n, on 1 - n_p · n_c.
    pub normal: f32,
    /// w_Φ, on the squared distance between the normalised RGB fluxes.
    pub flux: f32,
}

impl Default for RsmWeights {
    /// The paper's Cornell-box choice (section 6): w_d = 1, w_n = 10, w_Φ = 0.
    fn default() -> Self {
        RsmWeights { position: 1.0, normal: 10.0, flux: 0.0 }
    }
}

impl RsmWeights {
    /// The paper's choice for scenes with fine colour detail (POWER PLANT, SPONZA): 1, 1, 10.
    pub const COLOUR: RsmWeights = RsmWeights { position: 1.0, normal: 1.0, flux: 10.0 };

    /// Finite, non-negative and not all zero; the message names the problem.
    pub fn validate(&self) -> Result<(), String> {
        let w = [self.position, self.normal, self.flux];
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(format!(
                "rsm-weights must be finite and >= 0 (got {},{},{})",
                self.position, self.normal, self.flux
            ));
        }
        if w.iter().all(|&x| x == 0.0) {
            return Err(
                "rsm-weights cannot all be 0: every texel would tie with every cluster".into()
            );
        }
        Ok(())
    }
}

/// Parameters of the RSM-space clustering (`--vpl-cluster rsm`), the same for every backend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsmClusterParams {
    /// About this many clusters over all maps.
    pub k: u32,
    pub iterations: u32,
    pub weights: RsmWeights,
    /// The scene's bounding-box diagonal: positions enter Eq. 1 in its units.
    pub extent: f32,
}

/// One RSM-space cluster's state (`rsm_cluster`): its flux-weighted centre and normal, the
/// chroma of its flux, its position in its map (texels) and the map's index. Carried from frame
/// to frame with `--temporal on` (the paper's warm start), and the same bytes as
/// `ClusterState` in `rsm_cluster.wgsl` (three `vec4`s).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RsmCentre {
    pub centre: [f32; 3],
    pub texel_x: f32,
    pub normal: [f32; 3],
    pub texel_y: f32,
    pub chroma: [f32; 3],
    pub map: u32,
}

/// How far (in grid cells, Chebyshev) a VPL looks for clusters: the paper's r = 2.
pub const NEIGHBOURHOOD: i32 = 2;

/// The most RSM-space clusters (`--k-vpl` with `--vpl-cluster rsm`): a VPL's assignment on the
/// GPU visits the clusters of its 5 x 5 cells, up to all of its map's, in one invocation, which
/// lavapipe's loop limiter ends after 65,535 loop iterations. Larger K is refused up front.
pub const MAX_RSM_CLUSTERS: u32 = 32_768;
