use super::*;
use glam::{DVec3, Vec3A};
use vplgi_types::{Rng, Stream};

fn one_triangle() -> (Device, Scene) {
    let device = Device::new(Some(1)).expect("device");
    let positions =
        [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let scene = Scene::new(&device, &positions, &[[0, 1, 2]]).expect("scene");
    (device, scene)
}

#[test]
fn intersect_writes_nothing_past_the_hit_struct() {
    #[repr(C)]
    struct Guarded {
        rh: RayHit,
        sentinel: [u32; 8],
    }
    let (_d, scene) = one_triangle();
    let mut g = Guarded {
        rh: RayHit::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z, 0.0, f32::INFINITY),
        sentinel: [0xDEAD_BEEF; 8],
    };
    g.rh.hit.inst_prim_id = [0x1234_5678];
    scene.intersect_raw(&mut g.rh);
    assert_eq!(g.rh.hit.prim_id, 0);
    assert!((g.rh.ray.tfar - 1.0).abs() < 1e-6);
    // The 4.4 runtime writes instPrimID (invalid for a non-instanced hit): the field the 4.2
    // bindings lack. If this ever stops being written, the runtime's layout changed again.
    assert_eq!(
        g.rh.hit.inst_prim_id,
        [u32::MAX],
        "instPrimID not written: is the runtime Embree 4.4?"
    );
    assert_eq!(g.sentinel, [0xDEAD_BEEF; 8], "Embree wrote past the hit struct");
    assert_eq!(std::mem::size_of::<RayHit>(), 96);
}

#[test]
fn occlusion_respects_the_segment() {
    let (_d, scene) = one_triangle();
    let o = Vec3::new(0.0, 0.0, 1.0);
    assert!(scene.occluded(o, -Vec3::Z, 0.0, 2.0));
    assert!(!scene.occluded(o, -Vec3::Z, 0.0, 0.99), "blocker beyond tfar");
    assert!(!scene.occluded(o, -Vec3::Z, 1.01, 2.0), "blocker before tnear");
    assert!(!scene.occluded(o, Vec3::Z, 0.0, 10.0));
}

#[test]
fn empty_scene_misses() {
    let device = Device::new(None).expect("device");
    let scene = Scene::new(&device, &[], &[]).expect("scene");
    assert!(scene.intersect(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY).is_none());
    assert!(!scene.occluded(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY));
}

#[test]
fn out_of_range_indices_are_rejected() {
    let device = Device::new(None).expect("device");
    assert!(Scene::new(&device, &[Vec3::ZERO], &[[0, 1, 2]]).is_err());
}

/// Möller–Trumbore in double precision: the brute-force oracle.
fn brute_intersect(tri: [DVec3; 3], o: DVec3, d: DVec3) -> Option<f64> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - tri[0];
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

/// Embree, obvhs' CWBVH traversal and a brute-force loop must find the same closest triangle.
/// Disagreements are allowed only where two triangles are hit at (nearly) the same distance, or
/// where the ray grazes an edge: those are counted and reported, and must stay rare.
#[test]
fn embree_obvhs_and_brute_force_agree_on_random_rays() {
    let mut rng = Rng::new(11, Stream::Oracle, 0);
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for i in 0..1500u32 {
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let size = if i % 100 == 0 { 1.0 } else { 0.08 };
        for _ in 0..3 {
            positions
                .push(c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * size);
        }
        indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let device = Device::new(None).expect("device");
    let scene = Scene::new(&device, &positions, &indices).expect("scene");
    let tris: Vec<obvhs::triangle::Triangle> = indices
        .iter()
        .map(|t| obvhs::triangle::Triangle {
            v0: Vec3A::from(positions[t[0] as usize]),
            v1: Vec3A::from(positions[t[1] as usize]),
            v2: Vec3A::from(positions[t[2] as usize]),
        })
        .collect();
    let mut build_time = std::time::Duration::ZERO;
    let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut build_time,
    );

    let n_rays = 20_000;
    let (mut hits, mut embree_vs_brute, mut obvhs_vs_brute, mut occl_mismatch) = (0, 0, 0, 0);
    for _ in 0..n_rays {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0 - 1.5;
        let d = vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
        let tfar = 0.5 + 2.0 * rng.next_f32();

        let (od, dd) = (o.as_dvec3(), d.as_dvec3());
        let mut best: Option<(f64, u32)> = None;
        for (i, t) in indices.iter().enumerate() {
            let tri = [
                positions[t[0] as usize].as_dvec3(),
                positions[t[1] as usize].as_dvec3(),
                positions[t[2] as usize].as_dvec3(),
            ];
            if let Some(th) = brute_intersect(tri, od, dd) {
                if best.is_none_or(|(bt, _)| th < bt) {
                    best = Some((th, i as u32));
                }
            }
        }
        // Two answers agree when they name the same triangle, or both miss, or their distances
        // agree to 1e-4 (a tie between touching triangles).
        let agrees = |got: Option<(f32, u32)>| match (got, best) {
            (None, None) => true,
            (Some((t, id)), Some((bt, bid))) => {
                id == bid || (t as f64 - bt).abs() < 1e-4 * bt.max(1.0)
            }
            _ => false,
        };
        if best.is_some() {
            hits += 1;
        }
        let e = scene.intersect(o, d, 0.0, f32::INFINITY).map(|h| (h.t, h.triangle));
        if !agrees(e) {
            embree_vs_brute += 1;
        }
        let mut hit = obvhs::ray::RayHit::none();
        let ray = obvhs::ray::Ray::new_inf(Vec3A::from(o), Vec3A::from(d));
        let found = bvh.ray_traverse(ray, &mut hit, |r, id| {
            tris[bvh.primitive_indices[id] as usize].intersect(r)
        });
        let ob = found.then(|| (hit.t, bvh.primitive_indices[hit.primitive_id as usize]));
        if !agrees(ob) {
            obvhs_vs_brute += 1;
        }
        let brute_occluded = best.is_some_and(|(t, _)| t < tfar as f64);
        if scene.occluded(o, d, 0.0, tfar) != brute_occluded {
            // Only a hit within a hair of tfar may legitimately flip.
            let near_end = best.is_some_and(|(t, _)| (t - tfar as f64).abs() < 1e-4);
            if !near_end {
                occl_mismatch += 1;
            }
        }
    }
    println!(
        "{n_rays} rays, {hits} hit: Embree vs brute force {embree_vs_brute} mismatches, obvhs vs brute force {obvhs_vs_brute}, \
         occlusion mismatches {occl_mismatch}"
    );
    assert!(hits > n_rays / 10, "the test scene must actually be hit ({hits} hits)");
    // Grazing hits can fall either side of an edge in f32: allow 1 in 2,000.
    let bound = n_rays / 2_000;
    assert!(
        embree_vs_brute <= bound,
        "Embree disagrees with brute force on {embree_vs_brute} rays"
    );
    assert!(obvhs_vs_brute <= bound, "obvhs disagrees with brute force on {obvhs_vs_brute} rays");
    assert!(occl_mismatch <= bound, "occlusion disagrees with brute force on {occl_mismatch} rays");
}

/// A committed scene is queried from many rayon workers at once.
#[test]
fn concurrent_queries_match_serial_ones() {
    use rayon::prelude::*;
    let (_d, scene) = one_triangle();
    let dirs: Vec<Vec3> = (0..10_000)
        .map(|i| {
            vplgi_types::sampling::uniform_sphere(
                (i as f32 + 0.5) / 10_000.0,
                (i * 7 % 13) as f32 / 13.0,
            )
        })
        .collect();
    let o = Vec3::new(0.1, 0.1, 1.0);
    let serial: Vec<bool> = dirs.iter().map(|&d| scene.occluded(o, d, 0.0, 10.0)).collect();
    let parallel: Vec<bool> = dirs.par_iter().map(|&d| scene.occluded(o, d, 0.0, 10.0)).collect();
    assert_eq!(serial, parallel);
    assert!(serial.iter().any(|&b| b) && serial.iter().any(|&b| !b));
}

/// The packet queries of every width agree with the one-ray query ray by ray; lanes past `count`
/// are ignored.
#[test]
fn packet_queries_agree_with_occluded() {
    let device = Device::new(None).unwrap();
    // A unit quad in z = 0 blocks segments from z = 1 to z = -1 that cross it.
    let positions = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let scene = Scene::new(&device, &positions, &[[0, 1, 2], [0, 2, 3]]).unwrap();
    let origins: [Vec3; 16] = std::array::from_fn(|k| Vec3::new(-1.9 + 0.25 * k as f32, 0.3, 1.0));
    let dirs = [Vec3::new(0.0, 0.0, -2.0); 16];
    let one: u16 =
        (0..16).fold(0, |b, k| b | ((scene.occluded(origins[k], dirs[k], 0.0, 1.0) as u16) << k));
    assert_eq!(one, 0b0000_1111_1111_0000, "segments over the quad are blocked, the others not");
    let (o8, d8): ([Vec3; 8], [Vec3; 8]) =
        (std::array::from_fn(|k| origins[k + 4]), std::array::from_fn(|k| dirs[k + 4]));
    let (o4, d4): ([Vec3; 4], [Vec3; 4]) =
        (std::array::from_fn(|k| origins[k + 2]), std::array::from_fn(|k| dirs[k + 2]));
    assert_eq!(scene.occluded16(&origins, &dirs, 16, 0.0, 1.0), one);
    assert_eq!(scene.occluded16(&origins, &dirs, 6, 0.0, 1.0), one & 0b11_1111);
    assert_eq!(scene.occluded8(&o8, &d8, 8, 0.0, 1.0), one >> 4 & 0xff);
    assert_eq!(scene.occluded8(&o8, &d8, 3, 0.0, 1.0), one >> 4 & 0b111);
    // From one origin: the 8 segments from (0.3, 0.3, 1) to z = -1 at x = -3.5 .. 3.5 in steps
    // of 1 cross z = 0 half-way, at x = -1.6 .. 1.9: the middle 4 inside the quad.
    let ends: [Vec3; 8] = std::array::from_fn(|k| Vec3::new(-3.5 + k as f32, 0.3, -1.0));
    let from = Vec3::new(0.3, 0.3, 1.0);
    let dirs_from =
        [ends.map(|e| e.x - from.x), ends.map(|e| e.y - from.y), ends.map(|e| e.z - from.z)];
    let one_from: u16 =
        (0..8).fold(0, |b, k| b | ((scene.occluded(from, ends[k] - from, 0.0, 1.0) as u16) << k));
    assert_eq!(one_from, 0b0011_1100);
    assert_eq!(scene.occluded8_from(from, &dirs_from, 8, 0.0, 1.0), one_from);
    assert_eq!(scene.occluded8_from(from, &dirs_from, 3, 0.0, 1.0), one_from & 0b111);
    assert_eq!(scene.occluded4(&o4, &d4, 4, 0.0, 1.0), one >> 2 & 0xf);
    assert_eq!(scene.occluded4(&o4, &d4, 3, 0.0, 1.0), one >> 2 & 0b111);
}
