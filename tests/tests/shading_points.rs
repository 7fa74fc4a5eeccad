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
        let cpu = vplgi_cpu::shading_points::shading_points(
            &cs,
            &CameraParams::new(cs.scene.camera, w, h, spp, 9),
        );
        let gpu = kernel
            .run(&ctx.device, &ctx.queue, &gs, &CameraParams::new(scene.camera, w, h, spp, 9), None)
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
                &CameraParams::new(scene.camera, w, h, spp, 9),
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
        .run(&ctx.device, &ctx.queue, &gs, &CameraParams::new(scene.camera, w, h, 1, 1), None)
        .unwrap();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cpu = vplgi_cpu::shading_points::shading_points(
        &cs,
        &CameraParams::new(cs.scene.camera, w, h, 1, 1),
    );
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
    let cpu = vplgi_cpu::shading_points::shading_points(
        &cs,
        &CameraParams::new(cs.scene.camera, w, h, 1, 5),
    );
    let render = |c: &vplgi_gpu::GpuContext| {
        let gs = GpuScene::new(&c.device, &scene).unwrap();
        ShadingPointsKernel::new(&c.device)
            .unwrap()
            .run(&c.device, &c.queue, &gs, &CameraParams::new(scene.camera, w, h, 1, 5), None)
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
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::shading_points::compare(t, &CameraParams::new(scene.camera, width, height, spp, seed))).expect("GPU");
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
        let camera = CameraParams::new(scene.camera, 128, 128, 1, 1);
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

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Camera rays through mirrors and glass on random soups and rooms (every third material a
    /// mirror, every third glass, open meshes included), any jitter, seed and chain depth: the
    /// SPEC's shading-points rows and its specular-chain rows (chains of one vertex and of more
    /// judged apart, each where it has enough samples for its bound), measured by `vplgi
    /// verify`'s comparison. Images of 4,096 samples or more, so that chains usually number
    /// more than a thousand.
    #[test]
    fn specular_chains_match_the_cpu_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), width in 64u32..128, height in 64u32..128, spp in 1u32..=2, seed in proptest::prelude::any::<u32>(), depth in 1u32..=8) {
        let Some(gpu) = vplgi_tests::shared_gpu("specular_chains_match_the_cpu_on_random_scenes") else { return Ok(()) };
        let scene = vplgi_tests::inputs::with_mirrors_and_glass(scene);
        println!("{}", scene.name);
        let camera = CameraParams { specular_depth: depth, ..CameraParams::new(scene.camera, width, height, spp, seed) };
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| vplgi_verify::shading_points::compare(t, &camera)).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// The Cornell box with a mirror wall and sphere, and with glass: every row of `vplgi verify`'s
/// comparison holds at 1 and 2 samples per pixel, and the scenes do exercise chains of one
/// vertex and of several.
#[test]
fn specular_chains_match_the_cpu_in_the_specular_cornell_boxes() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("specular_chains_match_the_cpu_in_the_specular_cornell_boxes")
    else {
        return;
    };
    for name in ["cornell-mirror", "cornell-glass"] {
        let scene = vplgi_scene::generate::generate(name, 2_000).expect("a generated scene");
        for spp in [1, 2] {
            let camera = CameraParams::new(scene.camera, 96, 96, spp, 3);
            let (checks, (one, more)) = vplgi_tests::with_twins(gpu, &scene, |t| {
                let (cpu, _) = vplgi_verify::shading_points::both(t, &camera)?;
                let one = cpu.iter().filter(|s| s.specular == 1).count();
                let more = cpu.iter().filter(|s| s.specular > 1).count();
                Ok::<_, vplgi_verify::VerifyError>((
                    vplgi_verify::shading_points::compare(t, &camera)?,
                    (one, more),
                ))
            })
            .expect("GPU");
            println!(
                "{name}, {spp} spp: {one} samples through one specular vertex, {more} through more"
            );
            assert!(one > 50 && more > 50, "{name}: too few chains to judge ({one}, {more})");
            vplgi_tests::check_all(&format!("{name}, {spp} spp"), &checks);
        }
    }
}

/// Fresnel's reflectance for unpolarised light from `n1` into `n2` at incidence cosine `cos_i`,
/// in f64 from Snell's law: independent of the shared BSDF code.
fn fresnel_f64(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The shading points of both backends (the CPU's alone without a GPU).
fn on_each_backend(
    test: &str,
    scene: &vplgi_scene::Scene,
    camera: &CameraParams,
) -> Vec<(&'static str, Vec<vplgi_types::ShadingPoint>)> {
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = CpuScene::new(scene, &device).expect("scene");
    let mut out = vec![("CPU", vplgi_cpu::shading_points::shading_points(&cs, camera))];
    if let Some(gpu) = vplgi_tests::shared_gpu(test) {
        let (_, g) =
            vplgi_tests::with_twins(gpu, scene, |t| vplgi_verify::shading_points::both(t, camera))
                .expect("GPU");
        out.push(("GPU", g));
    }
    out
}

/// A glass slab (index 1.5) before a diffuse wall, against Snell's and Fresnel's laws in f64: a
/// pixel-centre ray that crosses both faces of the slab ends on the wall where the refracted ray,
/// shifted and leaving parallel to itself, meets it (within the SPEC's 1e-4 of the extent),
/// with the wall's albedo (the η² of entering and leaving cancel); it does so with probability
/// (1 - F)², F the Fresnel reflectance at its incidence (equal at both faces), so the number that
/// do is within 4 standard deviations of the sum of those probabilities. On both backends.
#[test]
fn rays_through_a_glass_slab_obey_snell_and_fresnel() {
    use vplgi_tests::inputs::SLAB_HALF;
    let scene = vplgi_tests::inputs::glass_slab_before_wall();
    let (w, h) = (96u32, 96u32);
    let camera = CameraParams::new(scene.camera, w, h, 1, 11);
    let extent = scene.extent() as f64;
    for (backend, points) in
        on_each_backend("rays_through_a_glass_slab_obey_snell_and_fresnel", &scene, &camera)
    {
        let o = scene.camera.position.as_dvec3();
        let (mut crossing, mut through, mut expected, mut variance) =
            (0usize, 0usize, 0.0f64, 0.0f64);
        let (mut worst_position, mut worst_albedo) = (0.0f64, 0.0f64);
        let slab = SLAB_HALF as f64;
        let inside = |p: glam::DVec3| p.x.abs() < 0.95 && p.y.abs() < 0.95;
        for (i, sp) in points.iter().enumerate() {
            let (x, y) = ((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
            let d = scene.camera.ray_direction(x, y, w, h).as_dvec3();
            let front = o + d * ((slab - o.z) / d.z);
            let cos_i = -d.z;
            let eta = 1.0 / 1.5;
            let refracted = d * eta
                + glam::DVec3::Z * (eta * cos_i - (1.0 - eta * eta * (1.0 - cos_i * cos_i)).sqrt());
            let back = front + refracted * ((-slab - front.z) / refracted.z);
            if !inside(front) || !inside(back) {
                continue;
            }
            let wall = back + d * ((-1.0 - back.z) / d.z);
            let p = (1.0 - fresnel_f64(cos_i, 1.0, 1.5)).powi(2);
            crossing += 1;
            expected += p;
            variance += p * (1.0 - p);
            if sp.specular == 2 && !sp.is_miss() && (sp.position[2] + 1.0).abs() < 1e-4 {
                through += 1;
                worst_position = worst_position
                    .max((Vec3::from(sp.position).as_dvec3() - wall).length() / extent);
                worst_albedo = worst_albedo
                    .max((Vec3::from(sp.albedo) - Vec3::splat(0.5)).abs().max_element() as f64);
            }
        }
        let sigma = variance.sqrt();
        println!(
            "{backend}: {crossing} rays cross the slab, {through} pass straight through (Fresnel expects {expected:.1} ± {sigma:.1}); \
             position error {worst_position:.2e} of the extent, albedo error {worst_albedo:.2e}"
        );
        assert!(crossing > 2_000, "{backend}: only {crossing} rays cross the slab");
        assert!(
            (through as f64 - expected).abs() <= 4.0 * sigma + 1.0,
            "{backend}: {through} rays passed, Fresnel expects {expected:.1} ± {sigma:.1}"
        );
        Disagreement::at_most(
            backend,
            "refracted hit against Snell's law, / scene extent",
            worst_position,
            SHADING_POINTS_POSITION_REL,
        )
        .check();
        assert!(
            worst_albedo <= 1e-5,
            "{backend}: the wall seen through the slab has albedo off by {worst_albedo}"
        );
    }
}

/// The Cornell box's mirror wall (z = -1, reflectance 0.9), against the law of reflection in
/// f64: a pixel-centre ray whose first hit is on the wall continues along (d.x, d.y, -d.z) from
/// where it meets the plane, and where that ray first hits a diffuse surface is the sample's
/// shading point (the same surface point for at least the SPEC's 99.9 %, another triangle at
/// the same point counting as the same, as in `vplgi verify`; positions within 1e-4 of the
/// extent), seen through one specular vertex with 0.9 times that surface's
/// albedo. On both backends.
#[test]
fn rays_off_a_mirror_wall_obey_the_law_of_reflection() {
    let scene =
        vplgi_scene::generate::generate("cornell-mirror", 2_000).expect("a generated scene");
    let (w, h) = (128u32, 128u32);
    let camera = CameraParams::new(scene.camera, w, h, 1, 5);
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = CpuScene::new(&scene, &device).expect("scene");
    let extent = cs.extent as f64;
    for (backend, points) in
        on_each_backend("rays_off_a_mirror_wall_obey_the_law_of_reflection", &scene, &camera)
    {
        let o = scene.camera.position.as_dvec3();
        let (mut compared, mut same, mut ties, mut worst_position, mut worst_albedo) =
            (0usize, 0usize, 0usize, 0.0f64, 0.0f32);
        let mut first_other = None;
        for (i, sp) in points.iter().enumerate() {
            let (x, y) = ((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
            let d32 = scene.camera.ray_direction(x, y, w, h);
            let Some(first) = cs.trace(scene.camera.position, d32) else { continue };
            if !first.bsdf().is_specular() || (first.position.z + 1.0).abs() > 1e-5 {
                continue;
            }
            let d = d32.as_dvec3();
            let on_wall = o + d * ((-1.0 - o.z) / d.z);
            let reflected = glam::DVec3::new(d.x, d.y, -d.z);
            let Some(next) =
                cs.trace((on_wall + glam::DVec3::Z * cs.eps as f64).as_vec3(), reflected.as_vec3())
            else {
                continue;
            };
            if next.bsdf().is_specular() {
                continue;
            }
            compared += 1;
            let apart = (Vec3::from(sp.position) - next.position).length() as f64 / extent;
            if sp.triangle != next.triangle && sp.specular == 1 && apart <= 1e-5 {
                // The reflected ray runs along an edge two triangles share (the room's corners
                // seen in the mirror), and rounding gave it to the other.
                ties += 1;
            } else if sp.triangle == next.triangle && sp.specular == 1 {
                same += 1;
                worst_position = worst_position
                    .max((Vec3::from(sp.position) - next.position).length() as f64 / extent);
                worst_albedo = worst_albedo
                    .max((Vec3::from(sp.albedo) - 0.9 * next.albedo).abs().max_element());
            } else {
                first_other.get_or_insert(format!(
                    "pixel {i}: triangle {} through {} specular, reflection hits {}",
                    sp.triangle, sp.specular, next.triangle
                ));
            }
        }
        println!(
            "{backend}: {compared} rays off the mirror wall, {same} on the reflected ray's surface and {ties} on another triangle at the same point \
             (an edge); position error {worst_position:.2e}, albedo error {worst_albedo:.2e}"
        );
        assert!(compared > 1_500, "{backend}: only {compared} rays meet the mirror wall");
        Disagreement::at_least(
            backend,
            "share on the reflected ray's surface point",
            (same + ties) as f64 / compared as f64,
            SHADING_POINTS_SAME_SURFACE,
        )
        .with_worst(first_other)
        .check();
        Disagreement::at_most(
            backend,
            "position against the law of reflection, / scene extent",
            worst_position,
            SHADING_POINTS_POSITION_REL,
        )
        .check();
        assert!(worst_albedo <= 1e-6, "{backend}: albedo through the mirror off by {worst_albedo}");
    }
}

/// `--specular-depth 0` keeps the first hit: mirrors and glass become shading points as their
/// base colour, and no sample passes a specular vertex.
#[test]
fn specular_depth_zero_keeps_the_first_hit() {
    let scene =
        vplgi_scene::generate::generate("cornell-mirror", 2_000).expect("a generated scene");
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = CpuScene::new(&scene, &device).expect("scene");
    let camera =
        CameraParams { specular_depth: 0, ..CameraParams::new(scene.camera, 48, 48, 1, 1) };
    let points = vplgi_cpu::shading_points::shading_points(&cs, &camera);
    let mut on_mirrors = 0;
    for (i, sp) in points.iter().enumerate() {
        let (x, y) = ((i as u32 % 48) as f32 + 0.5, (i as u32 / 48) as f32 + 0.5);
        let first = cs.trace(scene.camera.position, scene.camera.ray_direction(x, y, 48, 48));
        assert_eq!(sp.specular, 0);
        assert_eq!(sp.triangle, first.map_or(vplgi_types::MISS, |h| h.triangle));
        on_mirrors += first.is_some_and(|h| h.bsdf().is_specular()) as usize;
    }
    assert!(on_mirrors > 100, "only {on_mirrors} samples see a mirror");
}
