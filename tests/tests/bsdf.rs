//! `bsdf`: the WGSL twin of the BSDFs against `vplgi_shared::bsdf` on random queries (SPEC, by
//! the VPL row: eval and pdf within 1e-4 relative; at least 99.9 % of samples from the same
//! lobe and within it),
//! measured by `vplgi verify`'s comparison. Each test prints the adapter it ran on and the
//! measured disagreement.

use glam::Vec3;
use proptest::prelude::*;
use vplgi_shared::bsdf::Bsdf;

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Any reflectance, roughness in (0, 1], index of refraction either side of 1 and blend
    /// weight, on directions all over the sphere.
    #[test]
    fn bsdfs_match_the_cpu_on_random_queries(
        seed in any::<u32>(),
        colour in prop::array::uniform3(0.0f32..1.0),
        alpha in 0.02f32..1.0,
        eta in prop_oneof![1.01f32..2.5, 0.4f32..0.99],
        metallic in 0.0f32..1.0,
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("bsdfs_match_the_cpu_on_random_queries") else { return Ok(()) };
        let c = Vec3::from(colour);
        let models = [
            Bsdf::Diffuse { reflectance: c },
            Bsdf::Mirror { reflectance: c },
            Bsdf::RoughConductor { reflectance: c, alpha },
            Bsdf::Dielectric { eta },
            Bsdf::ThinDielectric { eta: eta.max(1.0 / eta) },
            Bsdf::Blend { metallic, base: c, alpha },
        ];
        let checks = vplgi_verify::bsdf::compare(&gpu.ctx.device, &gpu.ctx.queue, &models, 2048, seed).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}
