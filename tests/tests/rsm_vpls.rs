//! `rsm_vpls`: the GPU's reflective-shadow-map VPLs against the CPU's, texel by texel (the SPEC's
//! trace_vpls row: 1e-4 relative, at most 0.1 % of texels differ; edge ties counted apart).
//! Each test prints the adapter it ran on and the measured disagreement.

use vplgi_scene::cornell::cornell_box;

/// The Cornell box's area light, the box with a spot added, a plane under a point light and a
/// sunlit plane with a box: one map per light kind, at the paper's Cornell-box size (128²).
#[test]
fn rsm_vpls_matches_the_cpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("rsm_vpls_matches_the_cpu") else { return };
    for scene in [
        cornell_box(),
        vplgi_tests::inputs::cornell_box_with_spot(),
        vplgi_scene::cornell::plane_with_point_light(1.0, 0.7, 0.5, 3.0),
        vplgi_tests::inputs::sunlit_plane_with_box(),
    ] {
        println!("{}", scene.name);
        let checks =
            vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::rsm_vpls::compare(t, 128))
                .expect("GPU");
        vplgi_tests::check_all("", &checks);
    }
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Reflective shadow maps of random triangle soups and rooms with random lights (area,
    /// point, spot) at random sizes: the SPEC's trace_vpls row, measured by `vplgi verify`'s
    /// comparison. At least about 1,000 texels, so that one texel differing at a grazing hit is
    /// within 0.1 %.
    #[test]
    fn rsm_vpls_matches_the_cpu_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), size in 34u32..96) {
        let Some(gpu) = vplgi_tests::shared_gpu("rsm_vpls_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        println!("{}, --rsm-size {size}", scene.name);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::rsm_vpls::compare(t, size)).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}
