//! `rsm_vpls`: the GPU's reflective-shadow-map VPLs against the CPU's, texel by texel (the SPEC's
//! trace_vpls row: 1e-4 relative, at most 0.1 % of texels differ; edge ties counted apart).
//! Each test prints the adapter it ran on and the measured disagreement.

use vplgi_scene::cornell::cornell_box;
use vplgi_types::RsmParams;

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
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            vplgi_verify::rsm_vpls::compare(t, &RsmParams::new(128, 1))
        })
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
    fn rsm_vpls_matches_the_cpu_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), size in 34u32..96, seed in proptest::prelude::any::<u32>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("rsm_vpls_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        println!("{}, --rsm-size {size}", scene.name);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::rsm_vpls::compare(t, &RsmParams::new(size, seed))).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// The shadow map of a point light between a mirror floor and a diffuse ceiling: texels that
/// meet the mirror go on to the ceiling, where their VPLs carry what the light's mirror image
/// sends to the disk under it ([`vplgi_tests::inputs::check_mirror_image_flux`], within 0.5 %:
/// the sphere map's texels resolve the disk's edge), and none sits on the mirror. On both
/// backends.
#[test]
fn texels_that_meet_a_mirror_light_the_ceiling_as_the_mirror_image_does() {
    use vplgi_gpu::buffers::read_back;
    let scene = vplgi_tests::inputs::point_light_between_mirror_and_ceiling();
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).expect("scene");
    let params = RsmParams::new(512, 1);
    let mut sets =
        vec![("CPU", vplgi_cpu::rsm_vpls::rsm_vpls(&cs, &params, &vplgi_cpu::NoProgress).vpls)];
    if let Some(gpu) = vplgi_tests::shared_gpu(
        "texels_that_meet_a_mirror_light_the_ceiling_as_the_mirror_image_does",
    ) {
        let vpls = vplgi_tests::with_twins(gpu, &scene, |t| {
            let maps = t.gpu.scene().sampler.rsm_maps(params.size);
            let g = t
                .gpu
                .kernels()
                .rsm_vpls
                .run(t.device(), t.queue(), t.gpu.scene(), &maps, &params)
                .expect("GPU");
            read_back::<vplgi_types::Vpl>(t.device(), t.queue(), &g.buffer, g.count as usize)
                .expect("read back")
        });
        sets.push(("GPU", vpls));
    }
    vplgi_tests::inputs::check_mirror_image_flux(&sets, 0.005);
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Shadow maps of random soups and rooms whose materials are by turns mirrors and glass: the
    /// texels whose rays pass them judged apart, one vertex and more, against the SPEC's chain
    /// rows (a texel that parts where the CPU, its ray nudged, makes the GPU's VPL is a tie).
    #[test]
    fn specular_rsm_vpls_match_the_cpu_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), size in 34u32..96, seed in proptest::prelude::any::<u32>(), depth in 1u32..=8) {
        let Some(gpu) = vplgi_tests::shared_gpu("specular_rsm_vpls_match_the_cpu_on_random_scenes") else { return Ok(()) };
        let scene = vplgi_tests::inputs::with_mirrors_and_glass(scene);
        println!("{}, --rsm-size {size}", scene.name);
        let params = RsmParams { specular_depth: depth, ..RsmParams::new(size, seed) };
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::rsm_vpls::compare(t, &params)).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}
