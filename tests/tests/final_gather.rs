//! `final_gather` (`--gi photon`): the GPU's gather against the CPU's at random points of random
//! scenes lit by the CPU's cut (SPEC rows in `vplgi_verify::tolerance`, measured by `vplgi
//! verify`'s comparison); and on both backends, a point above a plane whose cut holds one
//! irradiance everywhere gathers the plane's albedo times it (Eq. 1, 4 and 5 together).

use glam::Vec3;
use proptest::prelude::*;
use vplgi_cpu::caustics::photon_map;
use vplgi_shared::illumination_cut::{coarse, for_gathering};
use vplgi_types::interpolation::GatherParams;
use vplgi_types::{CutParams, Endpoint, TraceParams, Vpl};

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// The CPU's cut of a random scene's global photons, gathered at random points of its
    /// surfaces (some on edges and corners) with random ray counts: irradiance and 1 / R_j agree
    /// as the rows require.
    #[test]
    fn final_gather_matches_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        photons in 100u32..20_000,
        size in 1u32..4_096,
        points in 1usize..300,
        rays in 1u32..=64,
        seed in any::<u32>(),
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("final_gather_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            let trace = TraceParams { deposit: vplgi_types::Deposit::Photons, ..TraceParams::new(seed, photons, 3) };
            let global = vplgi_cpu::trace_vpls::trace_vpls(t.cpu, &trace, &vplgi_cpu::NoProgress).vpls;
            let params = CutParams { size, refinements: 2, k: 20, max_radius: 0.1 * t.cpu.extent, min_radius: 1e-3 * t.cpu.extent };
            let cut = vplgi_cpu::illumination_cut::cut_of(&photon_map(&global, 8), &params);
            let at = vplgi_tests::inputs::surface_endpoints(&scene, points, seed as u64, 0.2);
            println!("{}: {} photons, a cut of {}, {points} points, {rays} rays", scene.name, global.len(), cut.nodes.len());
            vplgi_verify::final_gather::compare(t, &at, &cut, &GatherParams { seed, rays })
        }).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// The plane y = 0 (albedo 0.5, 200 wide) under a cut whose nodes all hold irradiance 2: photons
/// on a grid 0.2 apart over its middle 80 x 80, every cut node's kernel covering its box. Eight
/// points at height 1 looking down gather with 1,024 rays each; a ray lands on the grid but with
/// chance 1 / 1,601 (past 40 at height 1), where no kernel reaches. Σ w E / Σ w of equal E is E
/// whatever the weights, so each ray adds ρ E = 1 and the gathered irradiance is 1 to within
/// those misses: Eq. 1's π / N with Eq. 4's normalisation, on both backends.
#[test]
fn a_point_over_a_uniformly_lit_plane_gathers_albedo_times_irradiance_on_both_backends() {
    let scene = vplgi_scene::cornell::plane_with_point_light(100.0, 1.0, 0.5, 1.0);
    let photons: Vec<Vpl> = (0..400 * 400)
        .map(|i| Vpl {
            position: [-40.0 + 0.2 * (i % 400) as f32, 0.0, -40.0 + 0.2 * (i / 400) as f32],
            normal: [0.0, 1.0, 0.0],
            flux: [1.0; 3],
            incoming: [0.0, 1.0, 0.0],
            ..Vpl::default()
        })
        .collect();
    let map = photon_map(&photons, 8);
    let params = CutParams { size: 256, refinements: 0, k: 20, max_radius: 1.0, min_radius: 1e-3 };
    let estimates = vplgi_cpu::illumination_cut::node_estimates(&map, &params);
    let cut = coarse(&estimates, params.size);
    let cut = for_gathering(&estimates, &cut, &vec![Some([2.0; 3]); estimates.len()]);
    let points: Vec<Endpoint> =
        (0..8).map(|j| Endpoint::new(Vec3::new(0.3 * j as f32, 1.0, 0.1), -Vec3::Y)).collect();
    let gather = GatherParams { seed: 5, rays: 1_024 };
    let judge = |backend: &str, got: &[f32]| {
        let mean = got.iter().map(|&e| e as f64).sum::<f64>() / got.len() as f64;
        println!("{backend}: gathered {mean:.5} (exact 1 less the rays past the grid, 6.2e-4 expected); per point {got:?}");
        assert!((mean - (1.0 - 1.0 / 1601.0)).abs() < 2e-3, "{backend}: gathered {mean:.5}");
    };
    let device = vplgi_embree::Device::new(None).expect("embree");
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).expect("scene");
    let (cpu, _) = vplgi_cpu::final_gather::final_gather(&cs, points.clone(), &cut, &gather);
    judge("CPU", &cpu.irradiance.iter().map(|e| e[0]).collect::<Vec<_>>());
    let Some(gpu) = vplgi_tests::shared_gpu(
        "a_point_over_a_uniformly_lit_plane_gathers_albedo_times_irradiance_on_both_backends",
    ) else {
        return;
    };
    let got = vplgi_tests::with_twins(gpu, &scene, |t| {
        let k = t.gpu.kernels();
        let on_device = k.illumination_cut.upload(t.device(), &cut);
        let g = k
            .final_gather
            .run(
                t.device(),
                t.queue(),
                t.gpu.scene(),
                vplgi_gpu::GpuPoints::upload(t.device(), "points", &points),
                &on_device,
                &gather,
            )
            .expect("final gather");
        vplgi_gpu::buffers::read_back::<[f32; 4]>(
            t.device(),
            t.queue(),
            &g.samples.irradiance,
            points.len(),
        )
        .expect("read back")
    });
    judge("GPU", &got.iter().map(|e| e[0]).collect::<Vec<_>>());
}
