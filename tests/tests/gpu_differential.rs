//! CPU ↔ GPU differential tests, stage by stage, with the tolerances of SPEC.md. Each test
//! prints the adapter it ran on and the measured disagreement.

use glam::{Vec3, Vec3A};
use proptest::prelude::*;
use vplgi_cpu::CpuScene;
use vplgi_gpu::scene::GpuScene;
use vplgi_gpu::shading_points::ShadingPointsKernel;
use vplgi_gpu::visibility::{words_per_row, Endpoint, VisibilityKernel};
use vplgi_scene::cornell::cornell_box;
use vplgi_types::{CameraParams, Rng, ShadeParams, Stream, TraceParams};

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, failure_persistence: None, ..ProptestConfig::default() })]

    /// RNG: the WGSL twin gives bit-identical u32 streams (SPEC: bit-identical).
    #[test]
    fn rng_streams_are_bit_identical(seed in any::<u32>(), stream in 1u32..6, first in any::<u32>()) {
        let Some(ctx) = vplgi_tests::gpu("rng_streams_are_bit_identical") else { return Ok(()) };
        let (count, draws) = (512u32, 8u32);
        let first = first.min(u32::MAX - count);
        let gpu = vplgi_gpu::rng::rng_streams(&ctx.device, &ctx.queue, seed, stream, first, count, draws).unwrap();
        let stream_enum = [Stream::LightPath, Stream::Direct, Stream::Camera, Stream::Cluster, Stream::Oracle][(stream - 1) as usize];
        let mut mismatches = 0;
        for i in 0..count {
            let mut r = Rng::new(seed, stream_enum, first + i);
            for k in 0..draws {
                if r.next_u32() != gpu[(i * draws + k) as usize] {
                    mismatches += 1;
                }
            }
        }
        println!("rng: {mismatches} of {} draws differ", count * draws);
        prop_assert_eq!(mismatches, 0);
    }
}

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
        let gpu = kernel.run(&ctx.device, &ctx.queue, &gs, &CameraParams { width: w, height: h, spp, seed: 9 }, None).unwrap();
        assert_eq!(cpu.len(), gpu.len());
        let mut same = 0;
        let mut edge_ties = 0;
        let (mut pos_err, mut n_err, mut albedo_err) = (0.0f32, 0.0f32, 0.0f32);
        for (c, g) in cpu.iter().zip(&gpu) {
            assert_eq!(c.pixel, g.pixel);
            // A ray through an edge shared by two triangles (a quad's diagonal, or the concave
            // edge where ceiling meets wall) may legitimately return either: the hit point is the
            // same. The axis-aligned Cornell-box camera puts pixel centres exactly on such edges.
            let tie =
                c.triangle != g.triangle && !c.is_miss() && !g.is_miss() && (Vec3::from(c.position) - Vec3::from(g.position)).length() <= 1e-5 * cs.extent;
            edge_ties += tie as usize;
            if c.triangle == g.triangle {
                same += 1;
                if !c.is_miss() {
                    pos_err = pos_err.max((Vec3::from(c.position) - Vec3::from(g.position)).length() / cs.extent);
                    n_err = n_err.max((Vec3::from(c.normal) - Vec3::from(g.normal)).length());
                    albedo_err = albedo_err.max((Vec3::from(c.albedo) - Vec3::from(g.albedo)).abs().max_element());
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
        assert!(frac >= 0.999, "only {frac} of the samples hit the same surface point");
        assert!(same as f64 / cpu.len() as f64 >= 0.995, "only {same} samples hit the same triangle");
        assert!(pos_err <= 1e-4 && n_err <= 1e-4 && albedo_err <= 1e-5);
        let chunked = kernel.run(&ctx.device, &ctx.queue, &gs, &CameraParams { width: w, height: h, spp, seed: 9 }, Some(64 * 1000)).unwrap();
        assert_eq!(chunked, gpu, "chunked dispatches must give the same shading points");
    }
}

/// obvhs' own CPU traversal, the third opinion on visibility.
fn obvhs_visible(
    bvh: &obvhs::cwbvh::CwBvh,
    tris: &[obvhs::triangle::Triangle],
    cs: &CpuScene,
    a: &vplgi_cpu::visibility::Endpoint,
    b: &vplgi_cpu::visibility::Endpoint,
) -> bool {
    let p = cs.offset_toward(a.p(), a.n(), b.p());
    let q = cs.offset_toward(b.p(), b.n(), a.p());
    let ray = obvhs::ray::Ray::new(Vec3A::from(p), Vec3A::from(q - p), vplgi_cpu::SEGMENT_TNEAR, 1.0);
    bvh.ray_traverse_miss(ray, |r, id| tris[bvh.primitive_indices[id] as usize].intersect(r))
}

/// Visibility three ways — Embree (the CPU stage), obvhs' CPU traversal and the GPU — on shading
/// points × VPLs of the Cornell box: ≥ 99.9 % identical bits between every pair (SPEC).
#[test]
fn visibility_agrees_three_ways() {
    let Some(ctx) = vplgi_tests::gpu("visibility_agrees_three_ways") else {
        return;
    };
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let sps = vplgi_cpu::shading_points::shading_points(&cs, 48, 48, 1, 1);
    let rows: Vec<vplgi_cpu::visibility::Endpoint> = sps.iter().filter(|s| !s.is_miss()).map(vplgi_cpu::visibility::Endpoint::of).collect();
    let vpls = vplgi_cpu::trace_vpls::trace_vpls(&cs, 3, 300, 3, &vplgi_cpu::NoProgress).vpls;
    let cols: Vec<vplgi_cpu::visibility::Endpoint> = vpls.iter().map(Endpoint::of_vpl).collect();
    let (embree, rays) = vplgi_cpu::visibility::visibility(&cs, &rows, &cols, &vplgi_cpu::NoProgress);

    let tris = vplgi_gpu::bvh::triangles(&scene);
    let mut bt = std::time::Duration::ZERO;
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut bt);

    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let kernel = VisibilityKernel::new(&ctx.device).unwrap();
    // The CPU's and the GPU's shadow-ray ends are the same records.
    let (grows, gcols) = (rows.clone(), cols.clone());
    let words = kernel.run(&ctx.device, &ctx.queue, &gs, &grows, &gcols, None).unwrap();
    let wpr = words_per_row(cols.len());
    let gpu_bit = |r: usize, c: usize| (words[r * wpr + c / 32] >> (c % 32)) & 1 == 1;

    let (mut e_o, mut e_g, mut o_g) = (0u64, 0u64, 0u64);
    let mut visible = 0u64;
    for (r, a) in rows.iter().enumerate() {
        for (c, b) in cols.iter().enumerate() {
            let e = embree.get(r, c);
            let o = vplgi_cpu::visibility::facing(a, b) && obvhs_visible(&cw, &tris, &cs, a, b);
            let g = gpu_bit(r, c);
            visible += e as u64;
            e_o += (e != o) as u64;
            e_g += (e != g) as u64;
            o_g += (o != g) as u64;
        }
    }
    let total = (rows.len() * cols.len()) as u64;
    println!(
        "visibility {} x {} ({rays} rays, {visible} visible): bits differing Embree/obvhs {e_o}, Embree/GPU {e_g}, obvhs/GPU {o_g} of {total}",
        rows.len(),
        cols.len()
    );
    assert!(visible > total / 10 && visible < total, "the test needs both visible and blocked pairs");
    for (name, d) in [("Embree/obvhs", e_o), ("Embree/GPU", e_g), ("obvhs/GPU", o_g)] {
        assert!(d as f64 <= 1e-3 * total as f64, "{name}: {d} of {total} bits differ");
    }
    let chunked = kernel.run(&ctx.device, &ctx.queue, &gs, &grows, &gcols, Some((wpr * 4 * 7) as u64)).unwrap();
    assert_eq!(chunked, words, "row-chunked dispatches must give the same matrix");
}

/// A wall in z = 0 over [-1, 1]^2, tessellated like the generated scenes' walls: n x n cells of two
/// triangles with shared vertices.
fn grid_wall(n: u32) -> vplgi_scene::Scene {
    let mut scene = vplgi_scene::Scene { materials: vec![vplgi_scene::Material::default()], ..vplgi_scene::Scene::default() };
    let at = |i: u32| i as f32 * (2.0 / n as f32) - 1.0; // exact: the spacing is a power of two
    for j in 0..=n {
        for i in 0..=n {
            scene.positions.push(Vec3::new(at(i), at(j), 0.0));
            scene.normals.push(Vec3::Z);
            scene.uvs.push(glam::Vec2::ZERO);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = |di: u32, dj: u32| (j + dj) * (n + 1) + i + di;
            scene.indices.push([v(0, 0), v(1, 0), v(1, 1)]);
            scene.indices.push([v(0, 0), v(1, 1), v(0, 1)]);
            scene.material_ids.extend([0, 0]);
        }
    }
    scene.validate().unwrap();
    scene
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
    let gpu =
        ShadingPointsKernel::new(&ctx.device).unwrap().run(&ctx.device, &ctx.queue, &gs, &CameraParams { width: w, height: h, spp: 1, seed: 1 }, None).unwrap();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cpu = vplgi_cpu::shading_points::shading_points(&cs, w, h, 1, 1);
    let holes = cpu.iter().zip(&gpu).filter(|(c, g)| !c.is_miss() && g.is_miss()).count();
    let extra = cpu.iter().zip(&gpu).filter(|(c, g)| c.is_miss() && !g.is_miss()).count();
    println!("{} camera rays at cornell-fine ({triangles} triangles): {holes} hit on Embree but miss on the GPU, {extra} the other way", w * h);
    assert_eq!(holes, 0, "camera rays slip through the GPU's BVH");
}

/// No cracks: a wall tessellated like the generated scenes' (64 x 64 cells of two triangles,
/// shared vertices) blocks every shadow segment, including those aimed exactly at its shared
/// vertices, edges and diagonals, on the CPU (Embree) and on the GPU. A triangle test that is not
/// watertight lets some of those through.
#[test]
fn segments_through_shared_edges_find_no_cracks() {
    let Some(ctx) = vplgi_tests::gpu("segments_through_shared_edges_find_no_cracks") else {
        return;
    };
    let n = 64u32;
    let scene = grid_wall(n);
    let at = |i: u32| i as f32 * (2.0 / n as f32) - 1.0;
    // Row 0 is A; column k is the reflection of A through target t_k on a vertex, an edge or a
    // diagonal, so segment (A, column k) crosses the wall at t_k (pushing both ends off their
    // surfaces along z keeps the midpoint). Other rows cross at t_k shifted by at most 0.1.
    let h = 1.0 / n as f32;
    let a0 = Vec3::new(0.137, -0.211, -1.0);
    let mut cols = Vec::new();
    for j in (n / 4..3 * n / 4).step_by(3) {
        for i in (n / 4..3 * n / 4).step_by(3) {
            for (dx, dy) in [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h), (0.5 * h, 0.5 * h), (1.5 * h, 1.5 * h)] {
                let t = Vec3::new(at(i) + dx, at(j) + dy, 0.0);
                cols.push(Endpoint::new(2.0 * t - a0, -Vec3::Z));
            }
        }
    }
    let mut rng = Rng::new(9, Stream::Oracle, 0);
    let mut rows = vec![Endpoint::new(a0, Vec3::Z)];
    for _ in 0..31 {
        rows.push(Endpoint::new(a0 + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 0.0) * 0.2, Vec3::Z));
    }
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let words = VisibilityKernel::new(&ctx.device).unwrap().run(&ctx.device, &ctx.queue, &gs, &rows, &cols, None).unwrap();
    let wpr = words_per_row(cols.len());
    let gpu_leaks = |r: usize| (0..cols.len()).filter(|&c| (words[r * wpr + c / 32] >> (c % 32)) & 1 == 1).count();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cpu = |e: &Endpoint| *e;
    let (embree, _) =
        vplgi_cpu::visibility::visibility(&cs, &rows.iter().map(cpu).collect::<Vec<_>>(), &cols.iter().map(cpu).collect::<Vec<_>>(), &vplgi_cpu::NoProgress);
    let embree_leaks = |r: usize| (0..cols.len()).filter(|&c| embree.get(r, c)).count();
    let (aimed_gpu, aimed_embree) = (gpu_leaks(0), embree_leaks(0));
    let (other_gpu, other_embree) = ((1..rows.len()).map(gpu_leaks).sum::<usize>(), (1..rows.len()).map(embree_leaks).sum::<usize>());
    println!("{} segments aimed at shared vertices and edges: {aimed_gpu} leak on the GPU, {aimed_embree} on Embree; {} others: {other_gpu} leak on the GPU, {other_embree} on Embree", cols.len(), cols.len() * (rows.len() - 1));
    assert_eq!((aimed_embree, other_embree), (0, 0), "Embree leaks through the wall");
    assert_eq!((aimed_gpu, other_gpu), (0, 0), "the GPU leaks through shared edges");
}

/// Shading given identical inputs — the CPU's shading points, VPL lights, visibility matrix and
/// fuzzy clusters — in both visibility modes: relMSE(GPU, CPU) ≤ 1e-4 (SPEC).
#[test]
fn shade_matches_the_cpu_on_identical_inputs() {
    use vplgi_cpu::cluster::{cluster, ClusterParams};
    use vplgi_cpu::shade::{shade, VisibilitySource};
    use vplgi_gpu::buffers::{read_back, storage};
    use vplgi_gpu::shade::{ShadeInputs, ShadeKernel, Visibility, VplLight};
    use vplgi_types::{FuzzyMode, MISS};

    let Some(ctx) = vplgi_tests::gpu("shade_matches_the_cpu_on_identical_inputs") else {
        return;
    };
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let gl = vplgi_gpu::lights::GpuLights::new(&ctx.device, &scene, &cs.lights);
    let kernel = ShadeKernel::new(&ctx.device).unwrap();
    let (w, h, spp, seed, direct) = (40u32, 36u32, 2u32, 5u32, 3u32);
    let sps = vplgi_cpu::shading_points::shading_points(&cs, w, h, spp, seed);
    let hits: Vec<u32> = (0..sps.len() as u32).filter(|&i| !sps[i as usize].is_miss()).collect();
    let mut row_of = vec![MISS; sps.len()];
    for (r, &i) in hits.iter().enumerate() {
        row_of[i as usize] = r as u32;
    }
    let vpls = vplgi_cpu::trace_vpls::trace_vpls(&cs, seed, 400, 3, &vplgi_cpu::NoProgress).vpls;
    let g_max = 1.0 / (0.05 * cs.extent).powi(2);
    // The CPU's and the GPU's lights are the same records.
    let to_gpu_lights = |ls: &[VplLight]| -> Vec<VplLight> { ls.to_vec() };
    let n_pixels = (w * h) as usize;
    let sps_buf = storage(&ctx.device, "sps", &sps);
    let row_buf = storage(&ctx.device, "row_of", &row_of);

    // (a) Unclustered shading points: each hit has its own row; VPLs unclustered.
    let lights = vplgi_cpu::shade::vpl_lights(&vpls, None);
    let cols: Vec<vplgi_cpu::visibility::Endpoint> = lights.iter().map(|l| l.endpoint()).collect();
    let rows: Vec<vplgi_cpu::visibility::Endpoint> = hits.iter().map(|&i| vplgi_cpu::visibility::Endpoint::of(&sps[i as usize])).collect();
    let (m, _) = vplgi_cpu::visibility::visibility(&cs, &rows, &cols, &vplgi_cpu::NoProgress);
    let src = VisibilitySource::Own { matrix: &m, row_of: &row_of, first_row: 0 };
    let cpu_own = shade(&cs, &sps, 0, 0..n_pixels, &lights, &src, &ShadeParams { spp, seed, direct_samples: direct, g_max });
    let words = storage(&ctx.device, "words", bytemuck::cast_slice::<u64, u32>(m.words()));
    let light_buf = storage(&ctx.device, "lights", &to_gpu_lights(&lights));
    let inputs = ShadeInputs {
        scene_lights: &gl,
        sps: &sps_buf,
        sp_first: 0,
        row_of: &row_buf,
        words: &words,
        words_per_row: words_per_row(cols.len()) as u32,
        vpl_lights: &light_buf,
        light_count: lights.len() as u32,
        visibility: Visibility::Own { first_row: 0 },
    };
    let out = kernel.run(&ctx.device, &ctx.queue, &gs, &inputs, 0..n_pixels as u32, &ShadeParams { spp, seed, direct_samples: direct, g_max }).unwrap();
    let gpu_own: Vec<[f32; 4]> = read_back(&ctx.device, &ctx.queue, &out, n_pixels).unwrap();

    // (b) Both clustered, fuzzy weighted F = 6.
    let pos: Vec<Vec3> = vpls.iter().map(|v| v.position.into()).collect();
    let nor: Vec<Vec3> = vpls.iter().map(|v| v.normal.into()).collect();
    let vc = cluster(&pos, &nor, &ClusterParams { k: 60, gamma: 2, iterations: 5, f: 1, fuzzy: FuzzyMode::Hard, normal_threshold: 0.866, seed });
    let lights_c = vplgi_cpu::shade::vpl_lights(&vpls, Some(&vc));
    let cols_c: Vec<vplgi_cpu::visibility::Endpoint> = lights_c.iter().map(|l| l.endpoint()).collect();
    let sp_pos: Vec<Vec3> = hits.iter().map(|&i| sps[i as usize].position.into()).collect();
    let sp_nor: Vec<Vec3> = hits.iter().map(|&i| sps[i as usize].normal.into()).collect();
    let sc = cluster(&sp_pos, &sp_nor, &ClusterParams { k: 80, gamma: 2, iterations: 5, f: 6, fuzzy: FuzzyMode::Weighted, normal_threshold: 0.866, seed });
    let reps: Vec<vplgi_cpu::visibility::Endpoint> =
        sc.representatives.iter().map(|&r| vplgi_cpu::visibility::Endpoint::of(&sps[hits[r as usize] as usize])).collect();
    let (mc, _) = vplgi_cpu::visibility::visibility(&cs, &reps, &cols_c, &vplgi_cpu::NoProgress);
    let src = VisibilitySource::Fuzzy { matrix: &mc, row_of: &row_of, labels: &sc.labels, weights: &sc.weights, f: sc.f };
    let cpu_fuzzy = shade(&cs, &sps, 0, 0..n_pixels, &lights_c, &src, &ShadeParams { spp, seed, direct_samples: direct, g_max });
    let words_c = storage(&ctx.device, "words", bytemuck::cast_slice::<u64, u32>(mc.words()));
    let light_buf_c = storage(&ctx.device, "lights", &to_gpu_lights(&lights_c));
    let labels = storage(&ctx.device, "labels", &sc.labels);
    let weights = storage(&ctx.device, "weights", &sc.weights);
    let inputs = ShadeInputs {
        scene_lights: &gl,
        sps: &sps_buf,
        sp_first: 0,
        row_of: &row_buf,
        words: &words_c,
        words_per_row: words_per_row(cols_c.len()) as u32,
        vpl_lights: &light_buf_c,
        light_count: lights_c.len() as u32,
        visibility: Visibility::Fuzzy {
            labels: &labels,
            weights: &weights,
            f: sc.f as u32,
            window: vplgi_gpu::buffers::Window { first: 0, count: hits.len() as u64 },
        },
    };
    let out = kernel.run(&ctx.device, &ctx.queue, &gs, &inputs, 0..n_pixels as u32, &ShadeParams { spp, seed, direct_samples: direct, g_max }).unwrap();
    let gpu_fuzzy: Vec<[f32; 4]> = read_back(&ctx.device, &ctx.queue, &out, n_pixels).unwrap();

    for (name, cpu, gpu) in [("own rows", &cpu_own, &gpu_own), ("fuzzy clusters", &cpu_fuzzy, &gpu_fuzzy)] {
        let img = |p: Vec<[f32; 3]>| vplgi_image::Image { width: w, height: h, pixels: p };
        let g: Vec<[f32; 3]> = gpu.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let metrics = vplgi_image::compare(&img(cpu.clone()), &img(g.clone())).unwrap().metrics;
        let max_rel = cpu.iter().zip(&g).flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / a[c].abs().max(1e-3))).fold(0.0f32, f32::max);
        println!("shade ({name}): relMSE(GPU, CPU) {:.2e}, max relative pixel difference {max_rel:.2e}", metrics.rel_mse);
        assert!(cpu.iter().any(|p| p[0] > 0.0), "the image must not be black");
        assert!(metrics.rel_mse <= 1e-4, "{name}: relMSE {}", metrics.rel_mse);
        // Tightened beyond the SPEC: a uniform 1 % bias still passes relMSE <= 1e-4 (measured
        // 4e-5 when injected), while the twins agree bit for bit on lavapipe. Per-pixel
        // relative differences above 1e-4 would expose such a bias.
        assert!(max_rel <= 1e-4, "{name}: a pixel differs by {max_rel} relative");
    }
}

/// VPL tracing: the same count, particles and VPLs; positions within 1e-4 of the scene size,
/// normals and fluxes within 1e-4 relative; at most 0.1 % of paths may diverge (SPEC), counted.
/// Area light (Cornell box, 3 bounces), point light (plane, 1 bounce), spot light (Cornell box).
#[test]
fn trace_vpls_matches_the_cpu() {
    use std::collections::BTreeMap;
    use vplgi_gpu::buffers::read_back;
    use vplgi_gpu::trace_vpls::TraceVplsKernel;
    use vplgi_scene::PunctualLight;
    use vplgi_types::Vpl;

    let Some(ctx) = vplgi_tests::gpu("trace_vpls_matches_the_cpu") else {
        return;
    };
    let kernel = TraceVplsKernel::new(&ctx.device).unwrap();
    let mut spot_box = cornell_box();
    spot_box.lights.push(PunctualLight::Spot {
        position: Vec3::new(0.5, 1.5, 0.5),
        direction: Vec3::new(-0.3, -1.0, -0.4).normalize(),
        intensity: Vec3::new(3.0, 2.0, 1.0),
        cos_inner: 0.9,
        cos_outer: 0.7,
    });
    let cases = [
        ("cornell box, area light", cornell_box(), 3000u32, 3u32),
        ("plane, point light", vplgi_scene::cornell::plane_with_point_light(1.0, 0.7, 0.5, 3.0), 2000, 1),
        ("cornell box + spot light", spot_box, 3000, 3),
    ];
    for (name, scene, count, bounces) in cases {
        let device = vplgi_embree::Device::new(None).unwrap();
        let cs = CpuScene::new(&scene, &device).unwrap();
        let gs = GpuScene::new(&ctx.device, &scene).unwrap();
        let gl = vplgi_gpu::lights::GpuLights::new(&ctx.device, &scene, &cs.lights);
        let cpu = vplgi_cpu::trace_vpls::trace_vpls(&cs, 4, count, bounces, &vplgi_cpu::NoProgress);
        let g = kernel.run(&ctx.device, &ctx.queue, &gs, &gl, &TraceParams { seed: 4, count, bounces }).unwrap();
        let gpu: Vec<Vpl> = read_back(&ctx.device, &ctx.queue, &g.buffer, g.count as usize).unwrap();
        assert_eq!(gpu.len(), cpu.vpls.len(), "{name}: VPL count");
        let by_path = |v: &[Vpl]| {
            let mut m: BTreeMap<u32, Vec<Vpl>> = BTreeMap::new();
            for x in v {
                m.entry(x.path).or_default().push(*x);
            }
            m
        };
        let (cp, gp) = (by_path(&cpu.vpls), by_path(&gpu));
        let close = |a: &Vpl, b: &Vpl| {
            let pos = (Vec3::from(a.position) - Vec3::from(b.position)).length() <= 1e-4 * cs.extent;
            let nor = (Vec3::from(a.normal) - Vec3::from(b.normal)).length() <= 1e-4;
            let flux = (Vec3::from(a.flux) - Vec3::from(b.flux)).abs().max_element() <= 1e-4 * Vec3::from(a.flux).abs().max_element().max(1e-12);
            pos && nor && flux && a.bounce == b.bounce
        };
        let mut diverged = 0;
        let paths: std::collections::BTreeSet<u32> = cp.keys().chain(gp.keys()).copied().collect();
        let last = *paths.iter().next_back().unwrap();
        for p in &paths {
            let (a, b) = (cp.get(p), gp.get(p));
            let same = match (a, b) {
                (Some(a), Some(b)) => {
                    // The last path may be cut at a different length if an earlier one diverged.
                    let n = if *p == last { a.len().min(b.len()) } else { a.len() };
                    (a.len() == b.len() || *p == last) && a.iter().zip(b).take(n).all(|(x, y)| close(x, y))
                }
                _ => false,
            };
            diverged += !same as usize;
        }
        println!(
            "trace_vpls ({name}): {} VPLs from {} (CPU) / {} (GPU) particles; {diverged} of {} paths diverge",
            gpu.len(),
            cpu.particles,
            g.particles,
            paths.len()
        );
        assert!(gpu.len() == count as usize);
        assert!(diverged as f64 <= 1e-3 * paths.len() as f64, "{name}: {diverged} paths diverge");
        assert!((cpu.particles as i64 - g.particles as i64).abs() <= diverged as i64 * bounces as i64, "{name}: particle counts");
    }
}

/// Points for the clustering tests: the Cornell box's shading points (surfaces meeting at edges,
/// both orientations of thin walls) at 72x64.
fn cornell_points() -> (Vec<Vec3>, Vec<Vec3>) {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let sps = vplgi_cpu::shading_points::shading_points(&cs, 72, 64, 1, 2);
    sps.iter().filter(|s| !s.is_miss()).map(|s| (Vec3::from(s.position), Vec3::from(s.normal))).unzip()
}

fn endpoints(ps: &[Vec3], ns: &[Vec3]) -> Vec<Endpoint> {
    ps.iter().zip(ns).map(|(&p, &n)| Endpoint::new(p, n)).collect()
}

/// Assignment given identical centroids and grid: ≥ 99.99 % identical nearest labels, ≥ 99.9 %
/// identical F-index sets, weights within 1e-5 (SPEC); centroid update given identical labels:
/// bit-identical (integer sums).
#[test]
fn cluster_assign_and_update_match_the_cpu() {
    use vplgi_cpu::cluster::{bounds, cluster, update, ClusterParams, Grid};
    use vplgi_gpu::buffers::{read_back, storage};
    use vplgi_gpu::cluster::{AssignRule, ClusterKernel};
    use vplgi_types::clustering::{FixedPoint, GridGeometry};
    use vplgi_types::FuzzyMode;

    let Some(ctx) = vplgi_tests::gpu("cluster_assign_and_update_match_the_cpu") else {
        return;
    };
    let kernel = ClusterKernel::new(&ctx.device).unwrap();
    let (ps, ns) = cornell_points();
    let m = ps.len();
    // Centroids from a CPU clustering: realistic, and shared by both sides.
    let c = cluster(&ps, &ns, &ClusterParams { k: 300, gamma: 2, iterations: 3, f: 1, fuzzy: FuzzyMode::Hard, normal_threshold: 0.866, seed: 3 });
    let grid = Grid::for_data(bounds(&ps), &ps, c.k()).fill(&c.positions, &c.normals);
    let f = 6usize;
    let (cpu_labels, cpu_w): (Vec<Vec<u32>>, Vec<Vec<f32>>) = ps
        .iter()
        .zip(&ns)
        .map(|(&p, &n)| {
            let mut best = [(f32::INFINITY, vplgi_types::MISS); 6];
            let (count, _) = grid.search(p, n, 0.866, &mut best);
            let mut w = [0.0f32; 6];
            vplgi_types::clustering::fuzzy_weights(&best[..count], FuzzyMode::Weighted, grid.cell, &mut w[..count]);
            (best.iter().map(|b| b.1).collect(), w.to_vec())
        })
        .unzip();

    let pts = storage(&ctx.device, "points", &endpoints(&ps, &ns));
    let cents = storage(&ctx.device, "centroids", &endpoints(&c.positions, &c.normals));
    let geometry = GridGeometry { origin: grid.origin, cell: grid.cell, dims: grid.dims };
    let ggrid = kernel.fill_grid(&ctx.device, &ctx.queue, &geometry, &cents, c.k() as u32).unwrap();
    let a = kernel
        .assign(
            &ctx.device,
            &ctx.queue,
            &ggrid,
            (&pts, m as u32),
            (&cents, c.k() as u32),
            AssignRule { threshold: 0.866, f: f as u32, fuzzy: FuzzyMode::Weighted },
        )
        .unwrap();
    let gl: Vec<u32> = read_back(&ctx.device, &ctx.queue, &a.labels, m * f).unwrap();
    let gw: Vec<f32> = read_back(&ctx.device, &ctx.queue, &a.weights, m * f).unwrap();
    let (mut hard_same, mut set_same, mut max_w) = (0, 0, 0.0f32);
    for i in 0..m {
        hard_same += (gl[i * f] == cpu_labels[i][0]) as usize;
        let same_set = gl[i * f..(i + 1) * f] == cpu_labels[i][..];
        set_same += same_set as usize;
        if same_set {
            for j in 0..f {
                max_w = max_w.max((gw[i * f + j] - cpu_w[i][j]).abs());
            }
        }
    }
    println!("cluster assign ({m} points, {} centroids, F = {f}): nearest label identical {hard_same}/{m}, F-sets identical {set_same}/{m}, max weight difference {max_w:.2e}", c.k());
    assert!(hard_same as f64 >= 0.9999 * m as f64);
    assert!(set_same as f64 >= 0.999 * m as f64);
    assert!(max_w <= 1e-5);

    // Update given identical labels (the CPU's hard labels).
    let hard: Vec<u32> = cpu_labels.iter().map(|l| l[0]).collect();
    let (lo, hi) = bounds(&ps);
    let fix = FixedPoint::new(lo, hi);
    let (mut cp, mut cn) = (c.positions.clone(), c.normals.clone());
    let cpu_counts = update(&fix, &ps, &ns, &hard, &mut cp, &mut cn);
    let labels = storage(&ctx.device, "labels", &hard);
    let gcounts = kernel.update(&ctx.device, &ctx.queue, &fix, (&pts, m as u32), (&labels, 1), (&cents, c.k() as u32)).unwrap();
    let gc: Vec<Endpoint> = read_back(&ctx.device, &ctx.queue, &cents, c.k()).unwrap();
    let gcount: Vec<u32> = read_back(&ctx.device, &ctx.queue, &gcounts, c.k()).unwrap();
    assert_eq!(gcount, cpu_counts);
    let mut differ = 0;
    for k in 0..c.k() {
        let same = gc[k].position[..3] == cp[k].to_array() && gc[k].normal[..3] == cn[k].to_array();
        differ += !same as usize;
    }
    println!("cluster update: {differ} of {} centroids differ from the CPU's (bit-identical required)", c.k());
    assert_eq!(differ, 0);
}

/// The whole clustering (Alg. 1 iterations, empty-cluster removal, Alg. 2, representatives)
/// on both backends from the same data and seed.
#[test]
fn cluster_end_to_end_matches_the_cpu() {
    use vplgi_cpu::cluster::{cluster, ClusterParams};
    use vplgi_gpu::buffers::{read_back, storage};
    use vplgi_gpu::cluster::ClusterKernel;
    use vplgi_types::FuzzyMode;

    let Some(ctx) = vplgi_tests::gpu("cluster_end_to_end_matches_the_cpu") else {
        return;
    };
    let kernel = ClusterKernel::new(&ctx.device).unwrap();
    let (ps, ns) = cornell_points();
    let m = ps.len();
    for (k, f, fuzzy) in [(400u32, 6u32, FuzzyMode::Weighted), (150, 1, FuzzyMode::Hard), (5000, 4, FuzzyMode::Average)] {
        let cpu = cluster(&ps, &ns, &ClusterParams { k, gamma: 4, iterations: 10, f, fuzzy, normal_threshold: 0.866, seed: 7 });
        let pts = storage(&ctx.device, "points", &endpoints(&ps, &ns));
        let g = kernel
            .cluster(&ctx.device, &ctx.queue, &pts, m as u32, &ClusterParams { k, gamma: 4, iterations: 10, f, fuzzy, normal_threshold: 0.866, seed: 7 })
            .unwrap();
        let gl: Vec<u32> = read_back(&ctx.device, &ctx.queue, &g.labels, m * g.f as usize).unwrap();
        let gr: Vec<u32> = read_back(&ctx.device, &ctx.queue, &g.representatives, g.k as usize).unwrap();
        let gc: Vec<Endpoint> = read_back(&ctx.device, &ctx.queue, &g.centroids, g.k as usize).unwrap();
        let same_k = g.k as usize == cpu.k();
        let labels_same = (0..m).filter(|&i| gl[i * g.f as usize..(i + 1) * g.f as usize] == cpu.labels[i * cpu.f..(i + 1) * cpu.f]).count();
        let centroids_same = same_k && (0..cpu.k()).all(|j| gc[j].position[..3] == cpu.positions[j].to_array());
        println!(
            "cluster end to end (K = {k}, F = {f}, {fuzzy:?}): clusters CPU {} / GPU {}; label rows identical {labels_same}/{m}; centroids bit-identical: {centroids_same}; representatives identical: {}",
            cpu.k(),
            g.k,
            same_k && gr == cpu.representatives
        );
        assert!(same_k, "cluster counts differ");
        assert!(labels_same as f64 >= 0.999 * m as f64);
        assert_eq!(gr, cpu.representatives);
    }
}

/// Whole frames: the chained GPU pipeline against the CPU reference on the Cornell box in every
/// `--cluster` x `--fuzzy` mode.
///
/// The two backends' primary rays may legitimately pick different triangles where a pixel
/// centre lies exactly on an edge (the axis-aligned camera puts some on the ceiling/wall edges,
/// see `shading_points_match_the_cpu`), and such a pixel then shades a different surface. So the
/// SPEC's relMSE ≤ 1e-4 (and, with nothing clustered, a per-pixel 1e-4 on all but 0.1 % of them) is asserted on the pixels whose shading points hit
/// the same triangles in both backends, and the whole image is compared by FLIP, measured and
/// printed. With shading points clustered, whole frames are compared by FLIP (the SPEC's
/// fallback when clustering trajectories legitimately diverge). VPL positions agree to ~1e-7, not bit for bit (Embree's and the WGSL triangle test
/// round barycentrics differently), so a clustering can move a borderline point to a neighbouring
/// cluster: in clustered modes individual pixels may differ by a few percent while the relMSE
/// bound holds; the counts of clusters must still agree.
#[test]
fn whole_frames_match_the_cpu_in_every_mode() {
    use vplgi_gpu::{render, GpuKernels};
    use vplgi_types::{ClusterMode, FrameConfig, FuzzyMode};

    let Some(ctx) = vplgi_tests::gpu("whole_frames_match_the_cpu_in_every_mode") else {
        return;
    };
    let kernels = GpuKernels::new(&ctx.device).unwrap();
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let spk = ShadingPointsKernel::new(&ctx.device).unwrap();
    let modes = [
        (ClusterMode::None, FuzzyMode::Weighted),
        (ClusterMode::Vpl, FuzzyMode::Weighted),
        (ClusterMode::Sp, FuzzyMode::Hard),
        (ClusterMode::Sp, FuzzyMode::Average),
        (ClusterMode::Sp, FuzzyMode::Weighted),
        (ClusterMode::Both, FuzzyMode::Hard),
        (ClusterMode::Both, FuzzyMode::Average),
        (ClusterMode::Both, FuzzyMode::Weighted),
    ];
    for (cluster, fuzzy) in modes {
        let cfg = FrameConfig { width: 40, height: 32, spp: 1, vpls: 1500, k_sp: 200, k_vpl: 120, cluster, fuzzy, ..FrameConfig::default() };
        let cpu = vplgi_cpu::render(&cs, &cfg, &vplgi_cpu::NoProgress).unwrap();
        let gpu = render(&ctx.device, &ctx.queue, &kernels, &scene, &cfg).unwrap();
        assert_eq!((gpu.stats.vpl_clusters, gpu.stats.sp_clusters), (cpu.stats.vpl_clusters, cpu.stats.sp_clusters), "{cluster:?}/{fuzzy:?}: cluster counts");
        if !cluster.clusters_sps() {
            assert_eq!(gpu.stats.vpl_widened, cpu.stats.vpl_widened, "{cluster:?}: widened VPL searches");
        }
        // Pixels whose primary rays agree on the triangle in both backends.
        let c_sp = vplgi_cpu::shading_points::shading_points(&cs, cfg.width, cfg.height, cfg.spp, cfg.seed);
        let g_sp = spk.run(&ctx.device, &ctx.queue, &gs, &cfg.camera_params(), None).unwrap();
        let same: Vec<bool> = c_sp.iter().zip(&g_sp).map(|(a, b)| a.triangle == b.triangle).collect();
        let (mut num, mut den, mut n_same) = (0.0f64, 0usize, 0usize);
        let mut max_rel = 0.0f32;
        let mut over = 0usize; // agreeing pixels with a channel beyond 1e-4 relative
        for (i, (a, b)) in cpu.pixels.iter().zip(&gpu.pixels).enumerate() {
            if !same[i] {
                continue;
            }
            n_same += 1;
            over += (0..3).any(|c| (a[c] - b[c]).abs() / a[c].abs().max(1e-3) > 1e-4) as usize;
            for c in 0..3 {
                let (x, y) = (a[c] as f64, b[c] as f64);
                num += (x - y).powi(2) / (x * x + vplgi_image::REL_MSE_EPSILON);
                den += 1;
                max_rel = max_rel.max((a[c] - b[c]).abs() / a[c].abs().max(1e-3));
            }
        }
        let rel_mse_same = num / den as f64;
        let img = |p: Vec<[f32; 3]>| vplgi_image::Image { width: cfg.width, height: cfg.height, pixels: p };
        let whole = vplgi_image::compare(&img(cpu.pixels.clone()), &img(gpu.pixels.clone())).unwrap().metrics;
        println!(
            "frame {cluster:?}/{fuzzy:?}: {n_same}/{} pixels with agreeing primary hits: relMSE {rel_mse_same:.2e}, max relative difference {max_rel:.2e} ({over} over 1e-4); whole image relMSE {:.2e}, FLIP {:.2e}",
            same.len(),
            whole.rel_mse,
            whole.flip
        );
        // Every disagreeing primary hit is an edge tie: the same point, another triangle.
        for (a, b) in c_sp.iter().zip(&g_sp).filter(|(a, b)| a.triangle != b.triangle) {
            let d = (Vec3::from(a.position) - Vec3::from(b.position)).length();
            assert!(!a.is_miss() && !b.is_miss() && d <= 1e-5 * cs.extent, "{cluster:?}/{fuzzy:?}: primary hits differ by more than a tie: {a:?} vs {b:?}");
        }
        if cluster == ClusterMode::None {
            // Nothing clustered: agreeing pixels see the same VPLs (to ~1e-7) and so differ only
            // where a shadow ray's answer does: the SPEC lets 0.1 % of visibility bits differ, at
            // grazing ties. A pixel sums ~1,500 shadow rays, so one tie moves it by ~1e-3. Measured:
            // one pixel, a floor point 2.4e-7 from the right wall, 2.8e-3 darker on the GPU (the
            // watertight triangle test counts a segment grazing the wall as blocked, Embree not).
            assert!(over as f64 <= (1e-3 * n_same as f64).max(1.0), "{cluster:?}/{fuzzy:?}: {over} pixels differ by more than 1e-4");
            assert!(max_rel <= 1e-2, "{cluster:?}/{fuzzy:?}: a pixel differs by {max_rel} relative");
        }
        if !cluster.clusters_sps() {
            assert!(rel_mse_same <= 1e-4, "{cluster:?}/{fuzzy:?}: relMSE {rel_mse_same} on agreeing pixels");
        }
        // With shading points clustered, the edge-tie points (other normals) enter the k-means:
        // the trajectories legitimately diverge (given the same points they agree bit for bit,
        // `cluster_end_to_end_matches_the_cpu`), so these frames are compared by FLIP only.
        // Measured at 40x32: relMSE 5e-5 to 6e-4 on agreeing pixels, whole-image FLIP 0.024-0.028.
        // Measured 0.022 at this size, all of it at edge-tie pixels; the bound is a sanity check.
        assert!(whole.flip <= 0.05, "{cluster:?}/{fuzzy:?}: FLIP {}", whole.flip);
    }
}

/// Chunking under forced small limits: a device whose storage bindings are too small for the
/// frame's shading points (and whose dispatches are limited to 64 workgroups per dimension) must
/// render the very same image, bit for bit, as the unrestricted device. At the tighter limit the
/// per-point arrays (hit points, clustering labels, weights and search outcomes) need several
/// windows too, and so do the visibility rows of unclustered shading points.
#[test]
fn frames_are_identical_under_forced_small_limits() {
    use vplgi_gpu::{render, GpuKernels};
    use vplgi_types::{ClusterMode, FrameConfig, FuzzyMode};

    let Some(ctx) = vplgi_tests::gpu("frames_are_identical_under_forced_small_limits") else {
        return;
    };
    let scene = cornell_box();
    let kernels = GpuKernels::new(&ctx.device).unwrap();
    for (cluster, spp, tight) in
        [(ClusterMode::None, 1, false), (ClusterMode::Both, 2, false), (ClusterMode::None, 2, true), (ClusterMode::Both, 2, true), (ClusterMode::Sp, 2, true)]
    {
        let cfg = FrameConfig { width: 48, height: 40, spp, vpls: 800, k_sp: 150, k_vpl: 80, cluster, fuzzy: FuzzyMode::Weighted, ..FrameConfig::default() };
        let n_sp = (cfg.width * cfg.height * cfg.spp) as u64;
        let full = render(&ctx.device, &ctx.queue, &kernels, &scene, &cfg).unwrap();
        let hits = full.stats.shading_point_hits as u64;
        let label_bytes = hits * 4 * cfg.effective_f() as u64;
        let limit = if tight {
            // Hit points (32 B each) need three or more windows, labels and weights two or more;
            // the 800 VPLs (48 B each) still fit one binding.
            let limit = 40 << 10;
            assert!(hits * 32 > 2 * limit && label_bytes > limit, "{hits} hits do not exercise the windows");
            limit
        } else {
            // Shading points (64 B) need more than one binding, every other array fits in one.
            let limit = n_sp * 64 / 2 - 64 * 7;
            assert!(hits * 32 <= limit && label_bytes <= limit);
            limit
        };
        let small = vplgi_gpu::GpuContext::with_limits(Some(limit), Some(64)).unwrap();
        assert_eq!(small.device.limits().max_storage_buffer_binding_size, limit);
        let chunked = render(&small.device, &small.queue, &GpuKernels::new(&small.device).unwrap(), &scene, &cfg).unwrap();
        println!(
            "{cluster:?}, spp {spp}: binding limit {limit} B for {n_sp} shading points ({} B), {hits} hit points ({} B), labels {label_bytes} B, 64 workgroups per dimension: images identical: {}",
            n_sp * 64,
            hits * 32,
            full.pixels == chunked.pixels
        );
        assert!(full.pixels.iter().any(|p| p[0] > 0.0));
        assert_eq!(full.pixels, chunked.pixels, "{cluster:?} (limit {limit} B): chunked frame differs");
        assert!(small.take_uncaptured_errors().is_empty());
    }
}

/// Scene arrays paged over several bindings: a cluttered scene whose BVH nodes and BVH triangles
/// each need two (forced) bindings, and its per-triangle shading data three or four, renders the
/// same frame, bit for bit, as on the unrestricted device; past the pages the backend refuses
/// with a clear error.
#[test]
fn scene_arrays_are_paged_under_forced_small_limits() {
    use vplgi_gpu::{render, GpuKernels};
    use vplgi_types::{ClusterMode, FrameConfig, FuzzyMode};

    let Some(ctx) = vplgi_tests::gpu("scene_arrays_are_paged_under_forced_small_limits") else {
        return;
    };
    let mut scene = vplgi_scene::cornell::plane_with_point_light(1.0, 0.9, 0.6, 3.0);
    let mut rng = Rng::new(4, Stream::Oracle, 0);
    for _ in 0..3000 {
        let c = Vec3::new(rng.next_f32() * 2.0 - 1.0, 0.1 + 0.6 * rng.next_f32(), rng.next_f32() * 2.0 - 1.0);
        let base = scene.positions.len() as u32;
        for _ in 0..3 {
            scene.positions.push(c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.02);
            scene.normals.push(Vec3::Y);
            scene.uvs.push(glam::Vec2::ZERO);
        }
        scene.indices.push([base, base + 1, base + 2]);
        scene.material_ids.push(0);
    }
    scene.validate().unwrap();
    let t = scene.triangle_count() as u64;
    let arrays = vplgi_gpu::bvh::build(&scene).unwrap();
    let (node_bytes, tri_bytes, shading_bytes) = (arrays.nodes.len() as u64 * 32, arrays.tris.len() as u64 * 48, t * 96);
    // A binding smaller than each BVH array (obvhs collapses leaves: ~0.8 nodes per triangle
    // here) that still holds half of each, and a quarter of the shading data.
    let limit = (arrays.nodes.len().div_ceil(2) as u64 * 32).max(arrays.tris.len().div_ceil(2) as u64 * 48).max(t.div_ceil(4) * 96) + 96;
    assert!(limit < node_bytes && limit < tri_bytes && shading_bytes > 2 * limit, "the arrays do not need their pages");
    let small = vplgi_gpu::GpuContext::with_limits(Some(limit), None).unwrap();
    for cluster in [ClusterMode::None, ClusterMode::Both] {
        let cfg = FrameConfig { width: 24, height: 24, vpls: 300, k_sp: 60, k_vpl: 40, cluster, fuzzy: FuzzyMode::Weighted, ..FrameConfig::default() };
        let full = render(&ctx.device, &ctx.queue, &GpuKernels::new(&ctx.device).unwrap(), &scene, &cfg).unwrap();
        let paged = render(&small.device, &small.queue, &GpuKernels::new(&small.device).unwrap(), &scene, &cfg).unwrap();
        println!("{cluster:?}: {t} triangles, binding limit {limit} B (BVH nodes {node_bytes} B, BVH triangles {tri_bytes} B, shading data {shading_bytes} B): images identical: {}", full.pixels == paged.pixels);
        assert!(full.pixels.iter().any(|p| p[0] > 0.0));
        assert_eq!(full.pixels, paged.pixels, "{cluster:?}: paged frame differs");
    }
    // Beyond the pages: a clear error, not a panic.
    let tiny = vplgi_gpu::GpuContext::with_limits(Some(limit / 4), None).unwrap();
    let cfg = FrameConfig { width: 8, height: 8, vpls: 10, cluster: ClusterMode::None, ..FrameConfig::default() };
    match render(&tiny.device, &tiny.queue, &GpuKernels::new(&tiny.device).unwrap(), &scene, &cfg) {
        Err(e @ vplgi_gpu::GpuError::TooLarge { .. }) => println!("refused past the pages: {e}"),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("a scene past its pages was accepted"),
    }
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
    let uvs: Vec<glam::Vec2> = scene.positions.iter().map(|p| glam::Vec2::new(p.x * 1.7 + 0.13, p.z * 1.3 - 0.41)).collect();
    scene.uvs = uvs;
    let blocks = |w: u32, h: u32, value: &mut dyn FnMut() -> f32| {
        let per_block: Vec<Vec3> = (0..w.div_ceil(16) * h.div_ceil(16)).map(|_| Vec3::new(value(), value(), value())).collect();
        Texture { width: w, height: h, texels: (0..w * h).map(|i| per_block[((i / w / 16) * w.div_ceil(16) + (i % w) / 16) as usize]).collect() }
    };
    let coded = blocks(512, 384, &mut || table[(rng.next_u32() % 256) as usize]);
    let mut rng2 = Rng::new(12, Stream::Oracle, 0);
    let float = blocks(208, 160, &mut || rng2.next_f32());
    scene.textures = vec![coded, float];
    scene.materials[0].base_color = Vec3::ONE;
    scene.materials[0].base_color_texture = Some(0);
    scene.materials.push(Material { name: "float texture".into(), base_color: Vec3::ONE, base_color_texture: Some(1), emission: Vec3::ZERO });
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
        ShadingPointsKernel::new(&c.device).unwrap().run(&c.device, &c.queue, &gs, &CameraParams { width: w, height: h, spp: 1, seed: 5 }, None).unwrap()
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
    let same_paged = gpu.iter().zip(&paged).filter(|(a, b)| a.albedo == b.albedo && a.triangle == b.triangle).count();
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
    assert!(exact as f64 >= 0.8 * compared as f64, "only {exact} of {compared} albedos match to 1e-6");
    // Texel steps are at most 1; UVs differ by ~1e-7 relative of 1.7 repeats of 512 texels.
    assert!(max_err <= 2e-3, "albedo differs by {max_err}");
    assert_eq!(same_paged, gpu.len(), "paged texel words read differently");
}
