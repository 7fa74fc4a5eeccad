//! `visibility`: Embree, obvhs' CPU traversal and the GPU compared three ways (SPEC: >= 99.9 %
//! identical bits), and shadow segments through shared edges.
//! Each test prints the adapter it ran on and the measured disagreement.

use glam::{Vec3, Vec3A};
use vplgi_cpu::CpuScene;
use vplgi_gpu::scene::GpuScene;
use vplgi_gpu::visibility::{words_per_row, Endpoint, VisibilityKernel};
use vplgi_scene::cornell::cornell_box;
use vplgi_tests::tolerance::{Disagreement, VISIBILITY_SAME_BITS};
use vplgi_types::{CameraParams, Rng, Stream, TraceParams};

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
    let ray = obvhs::ray::Ray::new(
        Vec3A::from(p),
        Vec3A::from(q - p),
        vplgi_cpu::SEGMENT_TNEAR,
        vplgi_cpu::SEGMENT_TFAR,
    );
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
    let sps = vplgi_cpu::shading_points::shading_points(
        &cs,
        &CameraParams::new(cs.scene.camera, 48, 48, 1, 1),
    );
    let rows: Vec<vplgi_cpu::visibility::Endpoint> =
        sps.iter().filter(|s| !s.is_miss()).map(vplgi_cpu::visibility::Endpoint::of).collect();
    let vpls = vplgi_cpu::trace_vpls::trace_vpls(
        &cs,
        &TraceParams::new(3, 300, 3),
        &vplgi_cpu::NoProgress,
    )
    .vpls;
    let cols: Vec<vplgi_cpu::visibility::Endpoint> = vpls.iter().map(Endpoint::of_vpl).collect();
    let (embree, rays) =
        vplgi_cpu::visibility::visibility(&cs, &rows, &cols, &vplgi_cpu::NoProgress);

    let tris = vplgi_gpu::bvh::triangles(&scene);
    let mut bt = std::time::Duration::ZERO;
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut bt,
    );

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
    assert!(
        visible > total / 10 && visible < total,
        "the test needs both visible and blocked pairs"
    );
    for (name, d) in [("Embree/obvhs", e_o), ("Embree/GPU", e_g), ("obvhs/GPU", o_g)] {
        Disagreement::at_least(
            format!("visibility {name}"),
            "share of identical bits",
            (total - d) as f64 / total as f64,
            VISIBILITY_SAME_BITS,
        )
        .check();
    }
    let chunked = kernel
        .run(&ctx.device, &ctx.queue, &gs, &grows, &gcols, Some((wpr * 4 * 7) as u64))
        .unwrap();
    assert_eq!(chunked, words, "row-chunked dispatches must give the same matrix");
}

/// A wall in z = 0 over [-1, 1]^2, tessellated like the generated scenes' walls: n x n cells of two
/// triangles with shared vertices.
fn grid_wall(n: u32) -> vplgi_scene::Scene {
    let mut scene = vplgi_scene::Scene {
        materials: vec![vplgi_scene::Material::default()],
        ..vplgi_scene::Scene::default()
    };
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
            for (dx, dy) in
                [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h), (0.5 * h, 0.5 * h), (1.5 * h, 1.5 * h)]
            {
                let t = Vec3::new(at(i) + dx, at(j) + dy, 0.0);
                cols.push(Endpoint::new(2.0 * t - a0, -Vec3::Z));
            }
        }
    }
    let mut rng = Rng::new(9, Stream::Oracle, 0);
    let mut rows = vec![Endpoint::new(a0, Vec3::Z)];
    for _ in 0..31 {
        rows.push(Endpoint::new(
            a0 + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 0.0) * 0.2,
            Vec3::Z,
        ));
    }
    let gs = GpuScene::new(&ctx.device, &scene).unwrap();
    let words = VisibilityKernel::new(&ctx.device)
        .unwrap()
        .run(&ctx.device, &ctx.queue, &gs, &rows, &cols, None)
        .unwrap();
    let wpr = words_per_row(cols.len());
    let gpu_leaks = |r: usize| {
        (0..cols.len()).filter(|&c| (words[r * wpr + c / 32] >> (c % 32)) & 1 == 1).count()
    };
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cpu = |e: &Endpoint| *e;
    let (embree, _) = vplgi_cpu::visibility::visibility(
        &cs,
        &rows.iter().map(cpu).collect::<Vec<_>>(),
        &cols.iter().map(cpu).collect::<Vec<_>>(),
        &vplgi_cpu::NoProgress,
    );
    let embree_leaks = |r: usize| (0..cols.len()).filter(|&c| embree.get(r, c)).count();
    let (aimed_gpu, aimed_embree) = (gpu_leaks(0), embree_leaks(0));
    let (other_gpu, other_embree) = (
        (1..rows.len()).map(gpu_leaks).sum::<usize>(),
        (1..rows.len()).map(embree_leaks).sum::<usize>(),
    );
    println!("{} segments aimed at shared vertices and edges: {aimed_gpu} leak on the GPU, {aimed_embree} on Embree; {} others: {other_gpu} leak on the GPU, {other_embree} on Embree", cols.len(), cols.len() * (rows.len() - 1));
    assert_eq!((aimed_embree, other_embree), (0, 0), "Embree leaks through the wall");
    assert_eq!((aimed_gpu, other_gpu), (0, 0), "the GPU leaks through shared edges");
}

/// Visibility three ways between random points on the surfaces of `scene`, a share `on_edges`
/// of them on edges and vertices, as `vplgi verify` compares it.
fn three_ways(
    gpu: &vplgi_tests::SharedGpu,
    scene: &vplgi_scene::Scene,
    (rows, cols): (usize, usize),
    seed: u64,
    on_edges: f32,
) -> Vec<vplgi_verify::tolerance::Disagreement> {
    let r = vplgi_tests::inputs::surface_endpoints(scene, rows, seed, on_edges);
    let c = vplgi_tests::inputs::surface_endpoints(scene, cols, !seed, on_edges);
    let obvhs = vplgi_verify::visibility::ObvhsScene::new(scene);
    println!("{}: {rows} x {cols}", scene.name);
    vplgi_tests::with_twins(gpu, scene, |t| vplgi_verify::visibility::compare(t, &obvhs, &r, &c))
        .expect("GPU")
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Shadow rays on random triangle soups and rooms between random points on their surfaces,
    /// 5 % of them exactly on a triangle's edge or vertex (about ten times the share of camera hits
    /// on edges in the axis-aligned Cornell box), some normals flipped, three ways: the SPEC's
    /// visibility row, measured by `vplgi verify`'s comparison. At least 1,024 segments, so that
    /// one grazing a silhouette is within the SPEC's 0.1 % (one of 44 was 2.3 %).
    #[test]
    fn visibility_agrees_three_ways_on_random_scenes(scene in vplgi_tests::inputs::random_scene(), rows in 32usize..64, cols in 32usize..64, seed in proptest::prelude::any::<u64>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("visibility_agrees_three_ways_on_random_scenes") else { return Ok(()) };
        let checks = three_ways(gpu, &scene, (rows, cols), seed, 0.05);
        vplgi_tests::hold(&checks)?;
    }

    /// The same with 40 % of the endpoints on edges and vertices: segments that touch an edge or
    /// lie in a surface's plane (two points on the line where a box meets the floor). Here
    /// rounding ties are common enough to decide the SPEC's raw share: at 10,000 cases two
    /// points on one fold's edge made Embree and the GPU differ on 2 of 1,184 pairs, each
    /// segment passing a triangle 6e-6 from its offset end, at t 1e-8 from `SEGMENT_TFAR`; and
    /// obvhs' Möller–Trumbore test leaks through shared edges. So each pair of backends is
    /// judged with the f64 oracle's ties set aside, and the raw shares are printed.
    #[test]
    fn watertight_visibility_agrees_on_grazing_rays(scene in vplgi_tests::inputs::random_scene(), rows in 32usize..64, cols in 32usize..64, seed in proptest::prelude::any::<u64>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("watertight_visibility_agrees_on_grazing_rays") else { return Ok(()) };
        let checks = three_ways(gpu, &scene, (rows, cols), seed, 0.4);
        let (judged, others): (Vec<_>, Vec<_>) = checks.into_iter().partition(|c| c.what.contains("apart from rounding ties"));
        others.iter().for_each(|c| println!("(not judged) {c}"));
        proptest::prop_assert_eq!(judged.len(), 3);
        vplgi_tests::hold(&judged)?;
    }
}

/// A random placement of the seams room: turned about a random axis, moved, and scaled by up to
/// 2x per axis (non-uniformly), so cracks fall at every orientation and coordinate size.
fn seam_placement() -> impl proptest::strategy::Strategy<Value = vplgi_scene::seams::Placement> {
    use proptest::prelude::*;
    (
        prop::array::uniform3(-1.0f32..1.0),
        0.0f32..std::f32::consts::PI,
        prop::array::uniform3(-3.0f32..3.0),
        prop::array::uniform3(0.5f32..2.0),
    )
        .prop_map(|(axis, angle, offset, scale)| vplgi_scene::seams::Placement {
            scale: Vec3::from(scale),
            rotation: glam::Quat::from_axis_angle(
                Vec3::from(axis).try_normalize().unwrap_or(Vec3::Y),
                angle,
            ),
            offset: Vec3::from(offset),
        })
}

/// Shadow segments aimed at the cracks of `room` (seams picked by `seed`), on Embree and on the
/// GPU: (segments judged, blocked on Embree but not on the GPU, the other way, visible on both),
/// and the first segment that leaks.
/// Those blocked on the GPU alone must be ties for the f64 oracle: within rounding of a triangle.
/// Each seam gets `rows` x `cols` segments, every one through it: row r starts at a point A0
/// inside the room moved along the seam by a little, column c ends at 2 t_c - A0 for a point
/// t_c of the seam (its ends, the corners, among them), so the segment's midpoint t_c + (A_r -
/// A0) / 2 lies on the seam's line. The ends' normals are opposite, so pushing both off their
/// surfaces keeps the midpoint.
fn seam_leaks(
    gpu: &vplgi_tests::SharedGpu,
    room: &vplgi_scene::seams::SeamRoom,
    seams: usize,
    (rows, cols): (usize, usize),
    seed: u32,
) -> ([u64; 4], Option<String>) {
    let mut rng = Rng::new(seed, Stream::Oracle, 0);
    let mut r = || rng.next_f32();
    let mut counts = [0u64; 4];
    let mut first_leak = None;
    let oracle = vplgi_verify::segment::TieOracle::new(&room.scene);
    vplgi_tests::with_twins(gpu, &room.scene, |t| {
        for _ in 0..seams {
            let [a, b] =
                room.seams[((r() * room.seams.len() as f32) as usize).min(room.seams.len() - 1)];
            // Above the blocks (whose tops are at y = 0.2 in the room's frame), inside the room.
            let local = Vec3::new(1.8 * r() - 0.9, 0.3 + 0.6 * r(), 2.2 * r() - 0.9);
            let a0 = room.placement.transform_point3(local);
            let along = (b - a).normalize();
            let n = ((a + b) * 0.5 - a0).normalize();
            let row_ends: Vec<Endpoint> =
                (0..rows).map(|_| Endpoint::new(a0 + along * (0.1 * r() - 0.05), n)).collect();
            let col_ends: Vec<Endpoint> = (0..cols)
                .map(|_| {
                    let u = r();
                    let s = if u < 0.125 {
                        0.0
                    } else if u < 0.25 {
                        1.0
                    } else {
                        r()
                    };
                    Endpoint::new(2.0 * a.lerp(b, s) - a0, -n)
                })
                .collect();
            let (embree, _) = vplgi_cpu::visibility::visibility(
                t.cpu,
                &row_ends,
                &col_ends,
                &vplgi_cpu::NoProgress,
            );
            let words = t
                .gpu
                .kernels()
                .visibility
                .run(t.device(), t.queue(), t.gpu.scene(), &row_ends, &col_ends, None)
                .expect("GPU");
            let wpr = words_per_row(cols);
            for (i, p) in row_ends.iter().enumerate() {
                for (j, q) in col_ends.iter().enumerate() {
                    if !vplgi_cpu::visibility::facing(p, q) {
                        continue;
                    }
                    let (e, g) = (embree.get(i, j), (words[i * wpr + j / 32] >> (j % 32)) & 1 == 1);
                    counts[0] += 1;
                    counts[1] += (!e && g) as u64;
                    if !e && g && first_leak.is_none() {
                        let (pp, qq) = (
                            t.cpu.offset_toward(p.p(), p.n(), q.p()),
                            t.cpu.offset_toward(q.p(), q.n(), p.p()),
                        );
                        first_leak = Some(format!("{pp} to {qq} through the seam {a} to {b}"));
                    }
                    counts[2] += (e && !g) as u64;
                    counts[3] += (e && g) as u64;
                    if e && !g {
                        // Blocked on the GPU alone: a crack Embree leaks through, never a segment
                        // clear of every triangle by more than rounding.
                        let (pp, qq) = (
                            t.cpu.offset_toward(p.p(), p.n(), q.p()),
                            t.cpu.offset_toward(q.p(), q.n(), p.p()),
                        );
                        let verdict = oracle.verdict(pp.as_dvec3(), qq.as_dvec3());
                        assert_ne!(
                            verdict,
                            vplgi_verify::segment::Verdict::Visible,
                            "the GPU blocks {pp} to {qq}, clear of every triangle"
                        );
                    }
                }
            }
        }
    });
    (counts, first_leak)
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(16))]

    /// Cracks: on seams rooms in random placements (separate meshes a few ulps apart, a
    /// T-junction, tessellated 1 to 3 cells a side), no shadow segment aimed at a seam or a
    /// corner passes the GPU where Embree finds it blocked. 512 segments a case: 8,192 in `make
    /// test`, 5.1 million in `make verify-long`.
    #[test]
    fn segments_through_random_seams_never_leak(placement in seam_placement(), cells in 1usize..4, seed in proptest::prelude::any::<u32>()) {
        let Some(gpu) = vplgi_tests::shared_gpu("segments_through_random_seams_never_leak") else { return Ok(()) };
        let room = vplgi_scene::seams::seam_room(placement, 36 * cells * cells);
        let ([judged, leaks, extra, visible], first) = seam_leaks(gpu, &room, 4, (8, 16), seed);
        println!("{judged} segments through seams: {leaks} blocked on Embree pass the GPU, {extra} the other way (Embree passes a crack; ties in f64), {visible} visible on both");
        proptest::prop_assert!(judged >= 256, "only {} of 512 segments face both ends", judged);
        proptest::prop_assert_eq!(leaks, 0, "the GPU leaks through cracks Embree closes, first {:?}", first);
    }
}
