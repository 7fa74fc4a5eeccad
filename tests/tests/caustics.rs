//! `caustics` (`--caustics photons`): the GPU's estimates against the CPU's from one photon map
//! on random scenes with mirrors, glass and rough metal (SPEC rows in `vplgi_verify::tolerance`,
//! measured by `vplgi verify`'s comparison); the k nearest photons against kiddo's; and on both
//! backends, each with its own photons, the caustic a mirror throws against its image source.

use glam::Vec3;
use kiddo::{KdTree, SquaredEuclidean};
use proptest::prelude::*;
use std::f64::consts::PI;
use vplgi_cpu::caustics::{nearest, photon_map};
use vplgi_frame::prelude::*;
use vplgi_scene::Scene;
use vplgi_shared::bsdf::Surface;
use vplgi_types::params::CAUSTIC_NORMAL_COS;
use vplgi_types::{CameraParams, CausticParams, ShadingPoint, TraceParams, Vpl};

/// `scene` with its materials by turns diffuse, mirror, glass and rough metal (α 0.09): photons
/// reach diffuse and glossy receivers through both kinds of specular surface.
fn with_specular_and_glossy(mut scene: Scene) -> Scene {
    for (i, m) in scene.materials.iter_mut().enumerate() {
        m.surface = match i % 4 {
            1 => Surface::Mirror,
            2 => Surface::Dielectric { eta: 1.5 },
            3 => Surface::RoughConductor { alpha: 0.09 },
            _ => Surface::Diffuse,
        };
    }
    scene.name = format!("{} (diffuse, mirror, glass, rough metal)", scene.name);
    scene
}

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// The CPU's caustic photons of a random scene, estimated at its shading points by both
    /// backends with random k, radius, leaf size and bounce limit: the estimates agree but for
    /// the rate of differing photon sets the row allows, and the walks stop at the budget alike.
    #[test]
    fn caustics_match_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        photons in 200u32..6_000,
        k in 1u32..=128,
        radius in 0.005f32..0.2,
        leaf in 1u32..=16,
        max_bounce in 1u32..=4,
        spp in 1u32..=2,
        seed in any::<u32>(),
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("caustics_match_the_cpu_on_random_scenes") else { return Ok(()) };
        let scene = with_specular_and_glossy(scene);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            let trace = TraceParams::caustic_photons(seed, photons, 3);
            let map = vplgi_cpu::trace_vpls::trace_vpls(t.cpu, &trace, &vplgi_cpu::NoProgress).vpls;
            let camera = CameraParams { camera: scene.camera, width: 40, height: 32, spp, seed, specular_depth: 6 };
            let sps = vplgi_cpu::shading_points::shading_points(t.cpu, &camera);
            let params = CausticParams { k, max_radius: radius * t.cpu.extent, max_bounce, spp };
            println!("{}: {} caustic photons, k {k}, radius {radius:.3}, leaf {leaf}, max bounce {max_bounce}", scene.name, map.len());
            vplgi_verify::caustics::compare(t, &map, leaf, &sps, &params)
        }).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }

    /// The k nearest photons of a random cloud, some facing away from the query's normal, with
    /// a radius cap: the CPU's walk of the shared tree keeps exactly the photons kiddo's tree
    /// finds nearest among those that face the query and lie within the cap.
    #[test]
    fn the_k_nearest_photons_are_kiddos(
        n in 1usize..3_000,
        k in 1u32..=128,
        leaf in 1u32..=16,
        cap in 0.05f32..2.0,
        seed in any::<u32>(),
    ) {
        let mut rng = vplgi_types::Rng::new(seed, vplgi_types::Stream::LightPath, 0);
        let mut u = || rng.next_f32();
        let up = Vec3::Y;
        let photons: Vec<Vpl> = (0..n)
            .map(|_| {
                let position = Vec3::new(u() * 2.0, u() * 0.5, u() * 3.0);
                let normal = if u() < 0.7 { up } else { Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize_or(up) };
                Vpl { position: position.to_array(), normal: normal.to_array(), ..Vpl::default() }
            })
            .collect();
        let map = photon_map(&photons, leaf);
        let mut tree: KdTree<f32, 3> = KdTree::new();
        for (j, p) in map.photons.iter().enumerate() {
            if Vec3::from(p.normal).dot(up) > CAUSTIC_NORMAL_COS {
                tree.add(&p.position, j as u64);
            }
        }
        for q in 0..20 {
            let at = Vec3::new(u() * 2.4 - 0.2, u() * 0.5, u() * 3.4 - 0.2);
            let found = nearest(&map, at, up, k, cap * cap);
            prop_assert!(!found.truncated);
            let mut ours: Vec<u32> = found.heap.iter().map(|e| e.1).collect();
            ours.sort_unstable();
            let mut theirs: Vec<u32> = tree
                .nearest_n::<SquaredEuclidean>(&at.to_array(), k as usize)
                .into_iter()
                .filter(|nb| nb.distance < cap * cap)
                .map(|nb| nb.item as u32)
                .collect();
            theirs.sort_unstable();
            prop_assert_eq!(&ours, &theirs, "query {} at {}", q, at);
        }
    }
}

/// Each backend's caustic photons of [`vplgi_tests::inputs::point_light_between_mirror_and_ceiling`],
/// estimated at 400 points of the ceiling within 1.5 of the light's axis (the mirror's edge is
/// 10 away): the mean over the points of estimate / exact is 1 within 3 %, the exact caustic
/// radiance being ρ_c / π times the mirror image's irradiance ρ_m I cos θ′ / d′². Each estimate
/// is its own k photons (the points lie farther apart than the estimates' radii), so the mean's
/// noise is about 14 % / √400: 0.7 %.
#[test]
fn the_caustic_of_a_mirror_is_its_image_source_on_both_backends() {
    let scene = vplgi_tests::inputs::point_light_between_mirror_and_ceiling();
    let (light, ceiling, intensity, _) = vplgi_tests::inputs::MIRROR_ORACLE;
    let trace = TraceParams::caustic_photons(7, 200_000, 1);
    let params = CausticParams { k: 50, max_radius: 0.5, max_bounce: 1, spp: 1 };
    let mut points = Vec::new();
    let mut exact = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            let (x, z) =
                (-1.5 + 3.0 * (i as f64 + 0.5) / 20.0, -1.5 + 3.0 * (j as f64 + 0.5) / 20.0);
            points.push(ShadingPoint {
                position: [x as f32, ceiling as f32, z as f32],
                normal: [0.0, -1.0, 0.0],
                albedo: [0.5; 3],
                material: 1,
                view: [0.0, -1.0, 0.0],
                triangle: 0,
                ..ShadingPoint::default()
            });
            let d = ceiling + light;
            let d2 = x * x + z * z + d * d;
            let irradiance = 0.9 * intensity * d / d2.powf(1.5);
            exact.push(0.5 / PI * irradiance);
        }
    }
    let judge = |backend: &str, got: &[f32]| {
        let ratios: Vec<f64> = got.iter().zip(&exact).map(|(g, e)| *g as f64 / e).collect();
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>()
            / (ratios.len() - 1) as f64)
            .sqrt();
        println!(
            "{backend}: mean estimate / exact {mean:.4} (per point sd {sd:.3}, of the mean {:.4})",
            sd / (ratios.len() as f64).sqrt()
        );
        assert!(
            (mean - 1.0).abs() < 0.03,
            "{backend}: the caustic is {mean:.4} of the mirror image's"
        );
    };
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).expect("scene");
    let photons = vplgi_cpu::trace_vpls::trace_vpls(&cs, &trace, &vplgi_cpu::NoProgress).vpls;
    let map = photon_map(&photons, 8);
    let cpu: Vec<f32> = points
        .iter()
        .map(|sp| vplgi_cpu::caustics::estimate(&map, &scene.materials, sp, &params).0.x)
        .collect();
    judge("CPU", &cpu);
    let Some(gpu) =
        vplgi_tests::shared_gpu("the_caustic_of_a_mirror_is_its_image_source_on_both_backends")
    else {
        return;
    };
    let got = vplgi_tests::with_twins(gpu, &scene, |t| {
        let (photons, _) = t.gpu.trace_vpls(&trace, &vplgi_cpu::NoProgress).expect("trace");
        let map = t.gpu.photon_map(&photons, 8).expect("photon map");
        let sps = vplgi_gpu::buffers::storage(t.device(), "ceiling points", &points);
        let samples = vplgi_gpu::caustics::Samples { buffer: &sps, count: points.len() as u32 };
        let kernel = &t.gpu.kernels().caustics;
        kernel
            .run(t.device(), t.queue(), &map, &samples, &t.gpu.scene().lobes, &params)
            .expect("caustics")
    });
    judge("GPU", &got.iter().map(|l| l[0]).collect::<Vec<f32>>());
}
