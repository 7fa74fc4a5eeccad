//! `shading_points`: the GPU's camera samples against the CPU's (SPEC: >= 99.9 % same triangle,
//! positions within 1e-4), the watertightness of the GPU traversal for camera rays, and textures.
//! Each test prints the adapter it ran on and the measured disagreement.

use glam::Vec3;
use vplgi_cpu::CpuScene;
use vplgi_gpu::scene::GpuScene;
use vplgi_gpu::shading_points::ShadingPointsKernel;
use vplgi_scene::cornell::cornell_box;
use vplgi_tests::tolerance::{
    Disagreement, SHADING_POINTS_POSITION_REL, SHADING_POINTS_SAME_SURFACE,
};
use vplgi_types::{CameraParams, Rng, Stream};

/// Shading points on the Cornell box: ≥ 99.9 % of samples hit the same triangle, positions
/// within 1e-4 of the scene size (SPEC), at 1 and 3 jittered samples per pixel; chunked output
/// (forced small bindings) is identical to one dispatch.
#[test]
fn shading_points_match_the_cpu() {
    let Some(ctx) = vplgi_tests::gpu("shading_points_match_the_cpu") else {
        return;
    };
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let kernel = ShadingPointsKernel::new(&ctx.device).unwrap();
    for (w, h, spp) in [(96, 80, 1), (40, 40, 3)] {
        let cpu = vplgi_cpu::shading_points::shading_points(&cs, w, h, spp, 9);
        let gpu = kernel
            .run(
                &ctx.device,
                &ctx.queue,
                &gs,
                &CameraParams { camera: scene.camera, width: w, height: h, spp, seed: 9 },
                None,
            )
            .unwrap();
        assert_eq!(cpu.len(), gpu.len());
        let mut same = 0;
        let mut edge_ties = 0;
        let (mut pos_err, mut n_err, mut albedo_err) = (0.0f32, 0.0f32, 0.0f32);
        for (c, g) in cpu.iter().zip(&gpu) {
            assert_eq!(c.pixel, g.pixel);
            // A ray through an edge shared by two triangles (a quad's diagonal, or the concave
            // edge where ceiling meets wall) may legitimately return either: the hit point is the
            // same. The axis-aligned Cornell-box camera puts pixel centres exactly on such edges.
            let tie = c.triangle != g.triangle
                && !c.is_miss()
                && !g.is_miss()
                && (Vec3::from(c.position) - Vec3::from(g.position)).length() <= 1e-5 * cs.extent;
            edge_ties += tie as usize;
            if c.triangle == g.triangle {
                same += 1;
                if !c.is_miss() {
                    pos_err = pos_err.max(
                        (Vec3::from(c.position) - Vec3::from(g.position)).length() / cs.extent,
                    );
                    n_err = n_err.max((Vec3::from(c.normal) - Vec3::from(g.normal)).length());
                    albedo_err = albedo_err
                        .max((Vec3::from(c.albedo) - Vec3::from(g.albedo)).abs().max_element());
                    assert_eq!(c.emitted, g.emitted);
                }
            }
        }
        let frac = (same + edge_ties) as f64 / cpu.len() as f64;
        println!(
            "shading_points {w}x{h}x{spp}: same triangle {same}/{}, plus {edge_ties} ties on an edge shared by two triangles ({:.4} % agree), \
             max position error {pos_err:.2e} of the extent, normal {n_err:.2e}, albedo {albedo_err:.2e}",
            cpu.len(),
            100.0 * frac
        );
        // SPEC: >= 99.9 % hit the same triangle. Counting edge ties as agreement, that holds;
        // strictly by triangle index we measured 99.53 % at 96x80 (all 36 differences are hits
        // on an edge at the same point), so the strict check is 99.5 %.
        let case = format!("shading_points {w}x{h}x{spp}");
        Disagreement::at_least(
            &case,
            "share of samples on the same surface point",
            frac,
            SHADING_POINTS_SAME_SURFACE,
        )
        .check();
        assert!(
            same as f64 / cpu.len() as f64 >= 0.995,
            "only {same} samples hit the same triangle"
        );
        Disagreement::at_most(
            &case,
            "position error / scene extent",
            pos_err as f64,
            SHADING_POINTS_POSITION_REL,
        )
        .check();
        assert!(n_err <= 1e-4 && albedo_err <= 1e-5);
        let chunked = kernel
            .run(
                &ctx.device,
                &ctx.queue,
                &gs,
                &CameraParams { camera: scene.camera, width: w, height: h, spp, seed: 9 },
                Some(64 * 1000),
            )
            .unwrap();
        assert_eq!(chunked, gpu, "chunked dispatches must give the same shading points");
    }
}

/// No cracks between boxes: every camera ray that hits cornell-fine (the generated Cornell box,
/// walls tessellated into fine grids) on Embree hits it on the GPU. Its leaves have flat boxes
/// that meet at grid lines, and a slab test that is not conservative rejects some rays crossing
/// there from both neighbouring boxes.
#[test]
fn camera_rays_find_no_cracks_between_boxes() {
    let Some(ctx) = vplgi_tests::gpu("camera_rays_find_no_cracks_between_boxes") else {
        return;
    };
    let triangles = 400_000;
    let scene = vplgi_scene::generate::cornell_fine(triangles);
    let (w, h) = (512, 512);
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let gpu = ShadingPointsKernel::new(&ctx.device)
        .unwrap()
        .run(
            &ctx.device,
            &ctx.queue,
            &gs,
            &CameraParams { camera: scene.camera, width: w, height: h, spp: 1, seed: 1 },
            None,
        )
        .unwrap();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cpu = vplgi_cpu::shading_points::shading_points(&cs, w, h, 1, 1);
    let holes = cpu.iter().zip(&gpu).filter(|(c, g)| !c.is_miss() && g.is_miss()).count();
    let extra = cpu.iter().zip(&gpu).filter(|(c, g)| c.is_miss() && !g.is_miss()).count();
    println!("{} camera rays at cornell-fine ({triangles} triangles): {holes} hit on Embree but miss on the GPU, {extra} the other way", w * h);
    assert_eq!(holes, 0, "camera rays slip through the GPU's BVH");
}

/// Textures: an 8-bit sRGB texture is stored as its codes and decoded through the table both
/// backends share, a float texture as f32 words, and the texel words are paged over four
/// bindings. Shading points on a plane whose UVs repeat both textures must see the CPU's albedo,
/// and the same albedo, bit for bit, on a device whose bindings force the texel words over three
/// pages.
///
/// The textures are random 16x16-texel blocks: where the four texels of a bilinear lookup are
/// equal, the albedo does not depend on the hit point, so it must match to rounding (the SPEC's
/// 1e-6); elsewhere it moves with the barycentrics (positions agree to ~1e-7), by at most the
/// largest texel step times the UV error.
#[test]
fn textures_match_the_cpu_and_are_paged() {
    use vplgi_gpu::scene::{texel_words, TEXELS_F32, TEXELS_SRGB8};
    use vplgi_scene::{Material, Texture};

    let Some(ctx) = vplgi_tests::gpu("textures_match_the_cpu_and_are_paged") else {
        return;
    };
    let table = vplgi_scene::srgb8_table();
    let mut rng = Rng::new(11, Stream::Oracle, 0);
    let mut scene = vplgi_scene::cornell::plane_with_point_light(1.0, 0.9, 0.6, 3.0);
    // UVs repeat the textures a few times, offset so texel edges do not meet pixel centres.
    let uvs: Vec<glam::Vec2> = scene
        .positions
        .iter()
        .map(|p| glam::Vec2::new(p.x * 1.7 + 0.13, p.z * 1.3 - 0.41))
        .collect();
    scene.uvs = uvs;
    let blocks = |w: u32, h: u32, value: &mut dyn FnMut() -> f32| {
        let per_block: Vec<Vec3> = (0..w.div_ceil(16) * h.div_ceil(16))
            .map(|_| Vec3::new(value(), value(), value()))
            .collect();
        Texture {
            width: w,
            height: h,
            texels: (0..w * h)
                .map(|i| per_block[((i / w / 16) * w.div_ceil(16) + (i % w) / 16) as usize])
                .collect(),
        }
    };
    let coded = blocks(512, 384, &mut || table[(rng.next_u32() % 256) as usize]);
    let mut rng2 = Rng::new(12, Stream::Oracle, 0);
    let float = blocks(208, 160, &mut || rng2.next_f32());
    scene.textures = vec![coded, float];
    scene.materials[0].base_color = Vec3::ONE;
    scene.materials[0].base_color_texture = Some(0);
    scene.materials.push(Material {
        name: "float texture".into(),
        base_color: Vec3::ONE,
        base_color_texture: Some(1),
        emission: Vec3::ZERO,
        ..Material::default()
    });
    scene.material_ids[1] = 1;
    scene.validate().unwrap();

    let (words, infos) = texel_words(&scene);
    assert_eq!(infos.iter().map(|i| i.format).collect::<Vec<_>>(), [TEXELS_SRGB8, TEXELS_F32]);
    let bytes = words.len() as u64 * 4;
    // Three pages of texel words (every other array of this frame fits one binding).
    let limit = (bytes * 2 / 5).next_multiple_of(16);
    assert!(bytes > 2 * limit && bytes <= 3 * limit);
    let small = vplgi_gpu::GpuContext::with_limits(Some(limit), None).unwrap();

    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let (w, h) = (64, 64);
    let cpu = vplgi_cpu::shading_points::shading_points(&cs, w, h, 1, 5);
    let render = |c: &vplgi_gpu::GpuContext| {
        let gs = GpuScene::new(&c.device, &scene).unwrap();
        ShadingPointsKernel::new(&c.device)
            .unwrap()
            .run(
                &c.device,
                &c.queue,
                &gs,
                &CameraParams { camera: scene.camera, width: w, height: h, spp: 1, seed: 5 },
                None,
            )
            .unwrap()
    };
    let gpu = render(&ctx);
    let paged = render(&small);
    let (mut compared, mut exact, mut max_err) = (0usize, 0usize, 0.0f32);
    let mut albedos = std::collections::HashSet::new();
    for (a, b) in cpu.iter().zip(&gpu) {
        if a.is_miss() || a.triangle != b.triangle {
            continue;
        }
        compared += 1;
        let err = (Vec3::from(a.albedo) - Vec3::from(b.albedo)).abs().max_element();
        exact += (err <= 1e-6) as usize;
        max_err = max_err.max(err);
        albedos.insert(b.albedo.map(f32::to_bits));
    }
    let same_paged = gpu
        .iter()
        .zip(&paged)
        .filter(|(a, b)| a.albedo == b.albedo && a.triangle == b.triangle)
        .count();
    println!(
        "textures ({bytes} B of texel words): {compared} shading points, {} distinct albedos; within 1e-6 of the CPU {exact} ({:.1} %), max difference {max_err:.2e}; \
         texel words over three pages ({limit} B bindings): {same_paged}/{} identical",
        albedos.len(),
        100.0 * exact as f64 / compared as f64,
        gpu.len()
    );
    // The plane fills 83 % of the view (the camera keeps a 10 % margin).
    assert!(compared >= (w * h) as usize * 3 / 4, "only {compared} comparable shading points");
    assert!(albedos.len() > 200, "the textures were not sampled");
    // A lookup inside a block: its 4 texels are equal. With 16-texel blocks, (15/16)^2 = 88 % of
    // lookups are, less the points where the UV error crosses a texel edge.
    assert!(
        exact as f64 >= 0.8 * compared as f64,
        "only {exact} of {compared} albedos match to 1e-6"
    );
    // Texel steps are at most 1; UVs differ by ~1e-7 relative of 1.7 repeats of 512 texels.
    assert!(max_err <= 2e-3, "albedo differs by {max_err}");
    assert_eq!(same_paged, gpu.len(), "paged texel words read differently");
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Camera rays on random triangle soups and rooms (rooms tessellated so that rays cross shared
    /// edges), any jitter and seed: the SPEC's shading-points row, measured by `vplgi verify`'s
    /// comparison. At least 1,024 samples, so that one ray grazing a silhouette is within the
    /// SPEC's 0.1 % (at 4x28 one such ray was 0.9 %).
    #[test]
    fn shading_points_match_the_cpu_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), width in 32u32..64, height in 32u32..64, spp in 1u32..=3, seed in proptest::prelude::any::<u32>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("shading_points_match_the_cpu_on_random_scenes") else { return Ok(()) };
        println!("{}", scene.name);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::shading_points::compare(t, &CameraParams { camera: scene.camera, width, height, spp, seed })).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// Cracks between meshes: the seams rooms (walls and block faces separately transformed, meeting
/// a few ulps apart, seen by a centred camera whose pixel diagonals run along the long seams) at
/// 128 x 128: every camera ray that hits on Embree hits on the GPU, and `vplgi verify`'s
/// shading-point comparison holds at the SPEC's bound.
#[test]
fn centred_camera_rays_find_no_cracks_between_meshes() {
    let Some(gpu) = vplgi_tests::shared_gpu("centred_camera_rays_find_no_cracks_between_meshes")
    else {
        return;
    };
    for name in ["seams", "seams-rotated"] {
        let scene = vplgi_scene::generate::generate(name, 36).unwrap();
        let camera =
            CameraParams { camera: scene.camera, width: 128, height: 128, spp: 1, seed: 1 };
        let (cpu, gpu_points) = vplgi_tests::with_twins(gpu, &scene, |t| {
            vplgi_verify::shading_points::both(t, &camera)
        })
        .expect("GPU");
        let holes =
            cpu.iter().zip(&gpu_points).filter(|(c, g)| !c.is_miss() && g.is_miss()).count();
        let extra =
            cpu.iter().zip(&gpu_points).filter(|(c, g)| c.is_miss() && !g.is_miss()).count();
        println!("{name}: {} camera rays, {holes} hit on Embree but miss on the GPU, {extra} the other way", cpu.len());
        assert_eq!(holes, 0, "{name}: camera rays slip through cracks between meshes on the GPU");
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            vplgi_verify::shading_points::compare(t, &camera)
        })
        .expect("GPU");
        vplgi_tests::check_all(&format!("{name}: "), &checks);
    }
}
