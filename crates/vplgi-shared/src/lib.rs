//! The host-side algorithms the CPU reference and the GPU twin share, each computed once on the
//! host (or transcribed to WGSL operation for operation), each a module named for what it
//! computes:
//!
//! * [`bsdf`]: surface scattering as Mitsuba 3 defines it (diffuse, mirror, GGX conductor,
//!   glass, thin glass, and glTF's metallic blend): eval, sample and pdf.
//! * [`disk`]: VPL clusters as disk-shaped area lights (Eq. 2 of Prutkin et al.).
//! * [`illumination_cut`]: the choice of the global photon map's cut from the node estimates
//!   (Wang et al. 2009), and the bounds final gathering walks.
//! * [`photon_tree`]: the balanced kd-tree over a photon map that `caustics`,
//!   `illumination_cut` and `final_gather` search.
//! * [`polygon`]: VPL clusters as convex polygons around their members, lit exactly.
//! * [`rsm`]: reflective shadow maps, the texel rays of each light's map, and Eq. 1 of Prutkin
//!   et al.
//! * [`rsm_importance`]: the bidirectional importance map and the warp of the RSM clustering's
//!   seeds.
//! * [`seeding`]: the adaptive quadtree seeding of the shading-point clustering (Wang et al.).
//! * [`sh`]: spherical harmonics of the incident light at `--gi photon`'s sample points, and the
//!   glossy last bounce that integrates them against a receiver's lobe.
//!
//! The records they read and write are `vplgi-types`'.

pub mod bsdf;
pub mod disk;
pub mod illumination_cut;
pub mod photon_tree;
pub mod polygon;
pub mod rsm;
pub mod rsm_importance;
pub mod seeding;
pub mod sh;
