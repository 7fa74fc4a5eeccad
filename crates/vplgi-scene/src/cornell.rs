//! The built-in procedural scenes: the Cornell box (the default scene) and a lit plane for
//! analytic tests. Both are deterministic: the same call always yields the same scene.

use crate::{Camera, Material, PunctualLight, Scene, Surface};
use glam::{Vec2, Vec3};

/// Centre of the short box's footprint on the floor, its half extents and its rotation about y.
const SHORT_BOX: BoxSpec = BoxSpec {
    center: Vec3::new(0.35, 0.0, 0.35),
    half: Vec3::new(0.3, 0.3, 0.3),
    angle_deg: -18.0,
};
/// The tall box, standing back left like in the classic arrangement.
const TALL_BOX: BoxSpec = BoxSpec {
    center: Vec3::new(-0.35, 0.0, -0.3),
    half: Vec3::new(0.3, 0.6, 0.3),
    angle_deg: 18.0,
};
/// Half size of the square ceiling light.
const LIGHT_HALF: f32 = 0.25;
/// Height of the ceiling light: a little below the ceiling (y = 2) so the two never coincide.
const LIGHT_Y: f32 = 1.98;

struct BoxSpec {
    /// Centre of the bottom face (the box stands on the floor).
    center: Vec3,
    half: Vec3,
    angle_deg: f32,
}

/// The classic Cornell box in a 2 x 2 x 2 room: x in [-1, 1], y in [0, 2], z in [-1, 1], open
/// towards +z where the camera is. Every triangle's front faces into the room or out of its box.
pub fn cornell_box() -> Scene {
    cornell_room("cornell-box", |s, white| {
        add_box(s, &SHORT_BOX, white);
        add_box(s, &TALL_BOX, white);
    })
}

/// The Cornell box with a mirror back wall, and a mirror sphere where the short box stood; the
/// sphere takes what `triangles` leaves (at least 8 rings).
pub fn cornell_mirror(triangles: usize) -> Scene {
    cornell_room("cornell-mirror", |s, white| {
        let mirror = add_surface(s, "mirror", Vec3::splat(0.9), Surface::Mirror);
        s.material_ids[BACK_WALL].fill(mirror);
        let rings = sphere_rings(triangles.saturating_sub(22));
        add_sphere(s, SHORT_BOX.center + Vec3::new(0.0, 0.3, 0.0), 0.3, mirror, rings);
        add_box(s, &TALL_BOX, white);
    })
}

/// The Cornell box with a closed glass cube where the short box stood and a glass sphere in
/// front of the tall box, both of index 1.5 and a hair above the floor (a glass face on the
/// floor would coincide with it). The sphere takes what `triangles` leaves.
pub fn cornell_glass(triangles: usize) -> Scene {
    cornell_room("cornell-glass", |s, white| {
        let glass = add_surface(s, "glass", Vec3::ONE, Surface::Dielectric { eta: 1.5 });
        let lifted = BoxSpec { center: SHORT_BOX.center + Vec3::new(0.0, LIFT, 0.0), ..SHORT_BOX };
        add_box(s, &lifted, glass);
        add_bottom(s, &lifted, glass);
        add_box(s, &TALL_BOX, white);
        let rings = sphere_rings(triangles.saturating_sub(34));
        add_sphere(s, SPHERE_CENTRE + Vec3::new(0.0, LIFT, 0.0), SPHERE_RADIUS, glass, rings);
    })
}

/// The Cornell box with rough metals of roughness 0.6 (the short box, copper), 0.3 (the tall box,
/// steel) and 0.1 (a gold sphere in front of it, taking what `triangles` leaves).
pub fn cornell_glossy(triangles: usize) -> Scene {
    cornell_room("cornell-glossy", |s, _| {
        let metal = |r: f32| Surface::RoughConductor { alpha: r * r };
        let copper =
            add_surface(s, "copper, roughness 0.6", Vec3::new(0.95, 0.64, 0.54), metal(0.6));
        let steel = add_surface(s, "steel, roughness 0.3", Vec3::splat(0.9), metal(0.3));
        let gold = add_surface(s, "gold, roughness 0.1", Vec3::new(1.0, 0.78, 0.34), metal(0.1));
        add_box(s, &SHORT_BOX, copper);
        add_box(s, &TALL_BOX, steel);
        add_sphere(
            s,
            SPHERE_CENTRE,
            SPHERE_RADIUS,
            gold,
            sphere_rings(triangles.saturating_sub(32)),
        );
    })
}

/// The Cornell box a third full of water (index 1.33, a closed mesh) whose surface is a sum of
/// two sine waves, over the white short box, lit by the ceiling light and by a point light above
/// the water (Wang et al.'s "box + water", Table 1): the waves focus the point light into bright
/// lines on the floor and the box, through the water. The surface's grid takes what `triangles`
/// leaves (at least 8 x 8 quads; 17,000 triangles is the paper's).
pub fn cornell_water(triangles: usize) -> Scene {
    let mut s = cornell_room("cornell-water", |s, white| {
        let water = add_surface(s, "water", Vec3::ONE, Surface::Dielectric { eta: 1.33 });
        add_box(s, &SHORT_BOX, white);
        // 2 n² triangles on top, 8 n around the sides, 4 n below.
        let n = ((triangles.saturating_sub(20) as f64 / 2.0).sqrt() - 3.0).max(8.0) as u32;
        add_water(s, water, n);
    });
    s.lights.push(PunctualLight::Point {
        position: Vec3::new(0.3, 1.6, 0.1),
        intensity: Vec3::splat(1.5),
    });
    s
}

/// The Cornell box with two mirrors, the back wall and the right wall (a mirror corner that
/// shows the room over again), the tall box in the right wall's green, a finely tessellated white sphere where the short
/// box stood taking what `triangles` leaves, and a point light besides the ceiling light (Wang
/// et al.'s elephant between two mirrors, ~84,000 triangles): the mirrors throw the point
/// light's caustics on the floor, the sphere and the red wall.
pub fn cornell_mirrors(triangles: usize) -> Scene {
    let mut s = cornell_room("cornell-mirrors", |s, white| {
        let mirror = add_surface(s, "mirror", Vec3::splat(0.9), Surface::Mirror);
        s.material_ids[BACK_WALL].fill(mirror);
        s.material_ids[RIGHT_WALL].fill(mirror);
        // The green of the right wall goes to the tall box, so the mirrors still show a colour.
        let green =
            s.materials.iter().position(|m| m.name == "green").expect("the room's green") as u32;
        add_box(s, &TALL_BOX, green);
        let rings = sphere_rings(triangles.saturating_sub(22));
        add_sphere(s, SHORT_BOX.center + Vec3::new(0.0, 0.32, 0.0), 0.32, white, rings);
    });
    s.lights.push(PunctualLight::Point {
        position: Vec3::new(-0.3, 1.5, 0.5),
        intensity: Vec3::splat(1.5),
    });
    s
}

/// The water's half width (a little inside the walls, so no face coincides with one) and its
/// mean depth, above the short box's top.
const WATER_HALF: f32 = 0.98;
const WATER_DEPTH: f32 = 0.66;

/// The water's height at (x, z): two crossing sine waves, 2 % of the room's height.
fn water_height(x: f32, z: f32) -> f32 {
    use std::f32::consts::TAU;
    WATER_DEPTH
        + 0.025 * (TAU * (1.3 * x + 0.4 * z) + 0.7).sin()
        + 0.015 * (TAU * (1.9 * z - 0.6 * x)).cos()
}

/// The water as a closed mesh with outward normals: its surface a grid of `n` x `n` quads with
/// the waves' own normals, four sides following the surface's edge, and a bottom a hair above
/// the floor.
fn add_water(s: &mut Scene, material: u32, n: u32) {
    use std::f32::consts::TAU;
    let a = WATER_HALF;
    let at = |i: u32| -a + 2.0 * a * i as f32 / n as f32;
    let base = s.positions.len() as u32;
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (at(i), at(j));
            let h = 0.025 * TAU * (TAU * (1.3 * x + 0.4 * z) + 0.7).cos();
            let g = -0.015 * TAU * (TAU * (1.9 * z - 0.6 * x)).sin();
            let (dx, dz) = (1.3 * h - 0.6 * g, 0.4 * h + 1.9 * g);
            s.positions.push(Vec3::new(x, water_height(x, z), z));
            s.normals.push(Vec3::new(-dx, 1.0, -dz).normalize());
            s.uvs.push(Vec2::ZERO);
        }
    }
    let v = |i: u32, j: u32| base + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            // Counter-clockwise seen from above: the front faces up, out of the water.
            s.indices.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            s.indices.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    s.material_ids.resize(s.indices.len(), material);
    let bottom = LIFT;
    let side = |s: &mut Scene, p: &dyn Fn(f32) -> (f32, f32), facing: Vec3| {
        for i in 0..n {
            let (x0, z0) = p(at(i));
            let (x1, z1) = p(at(i + 1));
            add_quad(
                s,
                [
                    Vec3::new(x0, bottom, z0),
                    Vec3::new(x1, bottom, z1),
                    Vec3::new(x1, water_height(x1, z1), z1),
                    Vec3::new(x0, water_height(x0, z0), z0),
                ],
                facing,
                material,
            );
        }
    };
    side(s, &|t| (-a, t), -Vec3::X);
    side(s, &|t| (a, t), Vec3::X);
    side(s, &|t| (t, -a), -Vec3::Z);
    side(s, &|t| (t, a), Vec3::Z);
    // The bottom: a fan from its centre to every vertex of the sides' bottom edges, so that each
    // edge borders exactly two triangles (a closed mesh, as glass needs).
    let ring: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new(at(i), bottom, -a))
        .chain((0..n).map(|i| Vec3::new(a, bottom, at(i))))
        .chain((0..n).map(|i| Vec3::new(at(n - i), bottom, a)))
        .chain((0..n).map(|i| Vec3::new(-a, bottom, at(n - i))))
        .collect();
    let centre = s.positions.len() as u32;
    for p in std::iter::once(Vec3::new(0.0, bottom, 0.0)).chain(ring.iter().copied()) {
        s.positions.push(p);
        s.normals.push(-Vec3::Y);
        s.uvs.push(Vec2::ZERO);
    }
    let m = ring.len() as u32;
    for k in 0..m {
        // The front faces down, out of the water.
        s.indices.push([centre, centre + 1 + k, centre + 1 + (k + 1) % m]);
    }
    s.material_ids.resize(s.indices.len(), material);
}

/// The triangles of the back wall (the third quad of [`cornell_room`]).
const BACK_WALL: std::ops::Range<usize> = 4..6;
/// The triangles of the right (green) wall, the fifth quad.
const RIGHT_WALL: std::ops::Range<usize> = 8..10;
/// How far the glass objects float above the floor.
const LIFT: f32 = 1e-3;
/// A sphere in front of the tall box, clear of both boxes.
const SPHERE_CENTRE: Vec3 = Vec3::new(-0.45, 0.25, 0.45);
const SPHERE_RADIUS: f32 = 0.25;

/// The room of [`cornell_box`] (walls, then `objects`, then the ceiling light, so the box's
/// triangles keep their order), its materials white, red, green and light first.
fn cornell_room(name: &str, objects: impl FnOnce(&mut Scene, u32)) -> Scene {
    let mut s = Scene { name: name.into(), ..Scene::default() };
    let white = add_material(&mut s, "white", Vec3::splat(0.73), Vec3::ZERO);
    let red = add_material(&mut s, "red", Vec3::new(0.63, 0.065, 0.05), Vec3::ZERO);
    let green = add_material(&mut s, "green", Vec3::new(0.14, 0.45, 0.09), Vec3::ZERO);
    // The classic spectrum-derived radiance (17, 12, 4), doubled: this light covers 1/16 of the
    // ceiling and sits 2 units from the floor, so directly lit white surfaces reach ~0.5 and
    // the walls land in the 0.3-1.0 range once indirect light adds up.
    let light = add_material(&mut s, "light", Vec3::splat(0.78), Vec3::new(34.0, 24.0, 8.0));

    let (x0, x1, y0, y1, z0, z1) = (-1.0, 1.0, 0.0, 2.0, -1.0, 1.0);
    let corners = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // Floor, ceiling and back wall: white.
    add_quad(
        &mut s,
        [corners(x0, y0, z0), corners(x1, y0, z0), corners(x1, y0, z1), corners(x0, y0, z1)],
        Vec3::Y,
        white,
    );
    add_quad(
        &mut s,
        [corners(x0, y1, z0), corners(x1, y1, z0), corners(x1, y1, z1), corners(x0, y1, z1)],
        -Vec3::Y,
        white,
    );
    add_quad(
        &mut s,
        [corners(x0, y0, z0), corners(x1, y0, z0), corners(x1, y1, z0), corners(x0, y1, z0)],
        Vec3::Z,
        white,
    );
    // Left wall red, right wall green.
    add_quad(
        &mut s,
        [corners(x0, y0, z0), corners(x0, y1, z0), corners(x0, y1, z1), corners(x0, y0, z1)],
        Vec3::X,
        red,
    );
    add_quad(
        &mut s,
        [corners(x1, y0, z0), corners(x1, y1, z0), corners(x1, y1, z1), corners(x1, y0, z1)],
        -Vec3::X,
        green,
    );

    objects(&mut s, white);

    let h = LIGHT_HALF;
    add_quad(
        &mut s,
        [
            Vec3::new(-h, LIGHT_Y, -h),
            Vec3::new(h, LIGHT_Y, -h),
            Vec3::new(h, LIGHT_Y, h),
            Vec3::new(-h, LIGHT_Y, h),
        ],
        -Vec3::Y,
        light,
    );

    // At z = 3.9 a 40 degree field of view sees 2 * 2.9 * tan(20 deg) = 2.1 units of height at
    // the opening (z = 1), so the whole 2-unit-high front fills the frame.
    s.camera = Camera {
        position: Vec3::new(0.0, 1.0, 3.9),
        forward: -Vec3::Z,
        up: Vec3::Y,
        yfov: 40f32.to_radians(),
    };
    s
}

/// A single square floor quad (y = 0, x and z in `[-half_size, half_size]`, front facing +y)
/// with a grey Lambertian albedo, lit by one point light of radiant intensity `intensity` per
/// channel at (0, `height`, 0). The camera looks straight down at it. Used by analytic tests:
/// the floor's direct irradiance is `intensity * h / (h^2 + r^2)^(3/2)`.
pub fn plane_with_point_light(half_size: f32, height: f32, albedo: f32, intensity: f32) -> Scene {
    let mut s = Scene { name: "plane-with-point-light".into(), ..Scene::default() };
    let floor = add_material(&mut s, "floor", Vec3::splat(albedo), Vec3::ZERO);
    let a = half_size;
    add_quad(
        &mut s,
        [
            Vec3::new(-a, 0.0, -a),
            Vec3::new(a, 0.0, -a),
            Vec3::new(a, 0.0, a),
            Vec3::new(-a, 0.0, a),
        ],
        Vec3::Y,
        floor,
    );
    s.lights.push(PunctualLight::Point {
        position: Vec3::new(0.0, height, 0.0),
        intensity: Vec3::splat(intensity),
    });

    let yfov = 45f32.to_radians();
    // Far enough that the plane's half size fits the half field of view, with a 10% margin.
    let distance = 1.1 * half_size / (0.5 * yfov).tan();
    // Looking down, "up" in the image must be horizontal; -z keeps +x to the right.
    s.camera =
        Camera { position: Vec3::new(0.0, distance, 0.0), forward: -Vec3::Y, up: -Vec3::Z, yfov };
    s
}

/// A material of colour `base_color` that scatters like `surface`; its index.
fn add_surface(s: &mut Scene, name: &str, base_color: Vec3, surface: Surface) -> u32 {
    let m = add_material(s, name, base_color, Vec3::ZERO);
    s.materials[m as usize].surface = surface;
    m
}

/// The rings of a sphere of about `triangles` triangles (4 R (R - 1) of them), at least 8.
fn sphere_rings(triangles: usize) -> u32 {
    ((0.25 + triangles as f64 / 4.0).sqrt() + 0.5).round().max(8.0) as u32
}

/// A sphere of `rings` rings of 2 `rings` quads (the poles' rings triangles), shared vertices,
/// normals pointing out: a closed mesh.
fn add_sphere(s: &mut Scene, centre: Vec3, radius: f32, material: u32, rings: u32) {
    let (ring_count, segments) = (rings, 2 * rings);
    let base = s.positions.len() as u32;
    let mut vertex = |n: Vec3| {
        s.positions.push(centre + radius * n);
        s.normals.push(n);
        s.uvs.push(Vec2::ZERO);
    };
    vertex(Vec3::Y);
    for ring in 1..ring_count {
        let theta = std::f32::consts::PI * ring as f32 / ring_count as f32;
        for seg in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * seg as f32 / segments as f32;
            vertex(Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()));
        }
    }
    vertex(-Vec3::Y);
    let at = |ring: u32, seg: u32| base + 1 + (ring - 1) * segments + seg % segments;
    let south = base + 1 + (ring_count - 1) * segments;
    for seg in 0..segments {
        s.indices.push([base, at(1, seg), at(1, seg + 1)]);
        s.indices.push([south, at(ring_count - 1, seg + 1), at(ring_count - 1, seg)]);
        for ring in 1..ring_count - 1 {
            let (a, b) = (at(ring, seg), at(ring, seg + 1));
            let (c, d) = (at(ring + 1, seg), at(ring + 1, seg + 1));
            s.indices.push([a, c, d]);
            s.indices.push([a, d, b]);
        }
    }
    s.material_ids.resize(s.indices.len(), material);
}

fn add_material(s: &mut Scene, name: &str, base_color: Vec3, emission: Vec3) -> u32 {
    s.materials.push(Material {
        name: name.into(),
        base_color,
        base_color_texture: None,
        emission,
        surface: crate::Surface::Diffuse,
    });
    (s.materials.len() - 1) as u32
}

/// Adds the planar quad `c` (corners in cyclic order, either orientation) as two triangles whose
/// front faces `facing`: the corner order is reversed when its winding points the other way, so
/// callers only state which side is the front.
fn add_quad(s: &mut Scene, mut c: [Vec3; 4], facing: Vec3, material: u32) {
    if (c[1] - c[0]).cross(c[2] - c[0]).dot(facing) < 0.0 {
        c.reverse();
    }
    let normal = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
    let base = s.positions.len() as u32;
    for p in c {
        s.positions.push(p);
        s.normals.push(normal);
        s.uvs.push(Vec2::ZERO);
    }
    s.indices.push([base, base + 1, base + 2]);
    s.indices.push([base, base + 2, base + 3]);
    s.material_ids.extend([material, material]);
}

/// Adds the box's four sides and top, fronts facing outwards. The bottom is left out: it rests
/// on the floor, where it could never be seen and would only coincide with the floor.
fn add_box(s: &mut Scene, b: &BoxSpec, material: u32) {
    let (at, centre) = box_corners(b);
    let mut face = |corners: [Vec3; 4]| {
        let mid = 0.25 * corners.iter().copied().sum::<Vec3>();
        add_quad(s, corners, mid - centre, material);
    };
    face([at(-1.0, -1.0, true), at(1.0, -1.0, true), at(1.0, 1.0, true), at(-1.0, 1.0, true)]);
    for (i0, k0, i1, k1) in [
        (-1.0, -1.0, 1.0, -1.0),
        (1.0, -1.0, 1.0, 1.0),
        (1.0, 1.0, -1.0, 1.0),
        (-1.0, 1.0, -1.0, -1.0),
    ] {
        face([at(i0, k0, false), at(i1, k1, false), at(i1, k1, true), at(i0, k0, true)]);
    }
}

/// The box's bottom face, facing down: with [`add_box`], a closed box (glass must be one).
fn add_bottom(s: &mut Scene, b: &BoxSpec, material: u32) {
    let (at, _) = box_corners(b);
    let corners =
        [at(-1.0, -1.0, false), at(1.0, -1.0, false), at(1.0, 1.0, false), at(-1.0, 1.0, false)];
    add_quad(s, corners, -Vec3::Y, material);
}

/// The box's corner at (±1, ±1) of its rotated footprint, on its bottom or top, and its centre.
fn box_corners(b: &BoxSpec) -> (impl Fn(f32, f32, bool) -> Vec3 + '_, Vec3) {
    let (sin, cos) = b.angle_deg.to_radians().sin_cos();
    // Local axes of the box, rotated about y.
    let ax = Vec3::new(cos, 0.0, -sin) * b.half.x;
    let az = Vec3::new(sin, 0.0, cos) * b.half.z;
    let up = Vec3::Y * (2.0 * b.half.y);
    let at = move |i: f32, k: f32, top: bool| {
        b.center + ax * i + az * k + if top { up } else { Vec3::ZERO }
    };
    (at, b.center + 0.5 * up)
}

#[cfg(test)]
mod tests {
    /// The glass of `cornell-glass` is closed, as solid glass must be: every edge of its cube
    /// and sphere borders exactly two of its triangles. One face fewer opens four edges.
    #[test]
    fn the_glass_is_closed() {
        let mut s = super::cornell_glass(2_000);
        let glass = s.materials.iter().position(|m| m.surface.is_glass()).expect("glass") as u32;
        assert_eq!(s.open_edges(glass), Vec::<[glam::Vec3; 2]>::new());
        let first = s.material_ids.iter().position(|m| *m == glass).expect("a glass triangle");
        // The cube's first face is two triangles: drop both.
        s.material_ids[first] = 0;
        s.material_ids[first + 1] = 0;
        assert_eq!(s.open_edges(glass).len(), 4);
    }

    use super::*;

    fn centroid(t: [Vec3; 3]) -> Vec3 {
        (t[0] + t[1] + t[2]) / 3.0
    }

    /// True when `p` lies on one of the room's five walls.
    fn on_room_boundary(p: Vec3) -> bool {
        let eps = 1e-4;
        (p.x.abs() - 1.0).abs() < eps
            || p.y.abs() < eps
            || (p.y - 2.0).abs() < eps
            || (p.z + 1.0).abs() < eps
    }

    #[test]
    fn validates_and_has_the_expected_size() {
        let s = cornell_box();
        assert_eq!(s.validate(), Ok(()));
        assert_eq!(s.name, "cornell-box");
        // 5 walls + 2 boxes x 5 faces + 1 light, two triangles each.
        assert_eq!(s.triangle_count(), 2 * (5 + 10 + 1));
        let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["white", "red", "green", "light"]);
        assert!(s.uvs.iter().all(|&uv| uv == Vec2::ZERO));
        let (min, max) = s.bounds();
        assert_eq!((min, max), (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0)));
    }

    #[test]
    fn is_deterministic() {
        let (a, b) = (cornell_box(), cornell_box());
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.indices, b.indices);
        assert_eq!(a.materials, b.materials);
    }

    #[test]
    fn every_front_faces_into_the_room_or_out_of_its_box() {
        let s = cornell_box();
        let box_centre = |b: &BoxSpec| b.center + Vec3::Y * b.half.y;
        let (short, tall) = (box_centre(&SHORT_BOX), box_centre(&TALL_BOX));
        let (mut walls, mut boxes) = (0, 0);
        for t in 0..s.triangle_count() {
            let tri = s.triangle(t);
            let (c, n) = (centroid(tri), s.geometric_normal(t));
            // Vertex normals are the flat face normals.
            for &v in &s.indices[t] {
                assert!(
                    (s.normals[v as usize] - n).length() < 1e-5,
                    "triangle {t}: vertex normal differs"
                );
            }
            if s.emission(t) != Vec3::ZERO {
                continue;
            }
            if tri.iter().all(|&p| on_room_boundary(p)) && on_room_boundary(c) {
                assert!(n.dot(Vec3::Y - c) > 0.0, "wall triangle {t} faces away from the room");
                walls += 1;
            } else {
                // The boxes are far apart: the nearer centre is the triangle's own box.
                let own = if c.distance(short) < c.distance(tall) { short } else { tall };
                assert!(n.dot(c - own) > 0.0, "box triangle {t} faces into its box");
                boxes += 1;
            }
        }
        assert_eq!((walls, boxes), (10, 20));
    }

    #[test]
    fn the_light_faces_down_and_is_the_only_emitter() {
        let s = cornell_box();
        let mut light_area = 0.0;
        for t in 0..s.triangle_count() {
            let m = &s.materials[s.material_ids[t] as usize];
            if m.name == "light" {
                assert!(s.geometric_normal(t).dot(-Vec3::Y) > 0.999);
                assert!(s.triangle(t).iter().all(|p| (p.y - LIGHT_Y).abs() < 1e-6));
                let [a, b, c] = s.triangle(t);
                light_area += 0.5 * (b - a).cross(c - a).length();
            }
        }
        assert!((light_area - 0.25f32).abs() < 1e-5);
        for m in &s.materials {
            assert_eq!(m.emission != Vec3::ZERO, m.name == "light", "material {}", m.name);
        }
        assert!(s.lights.is_empty());
    }

    #[test]
    fn boxes_stand_inside_the_room_on_the_floor() {
        let s = cornell_box();
        for t in 0..s.triangle_count() {
            for p in s.triangle(t) {
                assert!(p.x.abs() <= 1.0 && p.z.abs() <= 1.0 && (0.0..=2.0).contains(&p.y));
            }
        }
        // The tall box top is at 1.2, the short box top at 0.6.
        let max_box_y = (0..s.triangle_count())
            .flat_map(|t| s.triangle(t))
            .filter(|p| p.y < 1.9)
            .map(|p| p.y)
            .fold(0.0f32, f32::max);
        assert!((max_box_y - 1.2).abs() < 1e-6);
    }

    #[test]
    fn camera_sees_the_opening() {
        let s = cornell_box();
        let c = s.camera;
        assert_eq!(c.position, Vec3::new(0.0, 1.0, 3.9));
        // Rays through the top and bottom edges of the image pass the opening's plane (z = 1)
        // just outside the box, so the whole front is in view.
        for (sy, expect_outside) in [(0.0, 2.0), (100.0, 0.0)] {
            let d = c.ray_direction(50.0, sy, 100, 100);
            let p = c.position + d * ((1.0 - c.position.z) / d.z);
            assert!(
                (p.y - 1.0).abs() > 1.0 && (p.y - expect_outside).abs() < 0.1,
                "edge ray hits the opening at {p}"
            );
        }
    }

    #[test]
    fn plane_with_point_light_is_a_lit_floor() {
        let s = plane_with_point_light(2.0, 1.5, 0.5, 10.0);
        assert_eq!(s.validate(), Ok(()));
        assert_eq!(s.triangle_count(), 2);
        for t in 0..2 {
            assert_eq!(s.geometric_normal(t), Vec3::Y);
            assert!(s
                .triangle(t)
                .iter()
                .all(|p| p.y == 0.0 && p.x.abs() <= 2.0 && p.z.abs() <= 2.0));
        }
        assert_eq!(s.bounds(), (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 1.5, 2.0)));
        assert_eq!(
            s.lights,
            vec![PunctualLight::Point {
                position: Vec3::new(0.0, 1.5, 0.0),
                intensity: Vec3::splat(10.0)
            }]
        );
        assert_eq!(s.albedo(0, 0.2, 0.2), Vec3::splat(0.5));
        assert_eq!(s.emission(0), Vec3::ZERO);
        let c = s.camera;
        assert_eq!((c.forward, c.forward.dot(c.up)), (-Vec3::Y, 0.0));
        // The image corners see the plane's corners from inside the frame.
        let d = c.ray_direction(0.0, 0.0, 64, 64);
        let hit = c.position + d * (c.position.y / -d.y);
        assert!(hit.x < -2.0 && hit.z < -2.0, "corner ray lands at {hit}");
    }

    /// The specular Cornell boxes hold the surfaces they are named for; glass comes in closed
    /// meshes (every directed edge of its triangles matched by its reverse, once: a consistent
    /// outward winding), and the spheres' vertex normals point out of them.
    #[test]
    fn specular_cornell_boxes_hold_their_surfaces_in_closed_meshes() {
        let surfaces = |s: &Scene| s.materials.iter().map(|m| m.surface).collect::<Vec<_>>();
        let mirror = cornell_mirror(2_230);
        assert_eq!(mirror.triangle_count(), 2_230);
        assert!(surfaces(&mirror).contains(&Surface::Mirror));
        assert!(mirror.material_ids[BACK_WALL]
            .iter()
            .all(|&m| mirror.materials[m as usize].surface == Surface::Mirror));
        let glossy = cornell_glossy(2_240);
        let alphas: Vec<f32> = surfaces(&glossy)
            .into_iter()
            .filter_map(
                |s| if let Surface::RoughConductor { alpha } = s { Some(alpha) } else { None },
            )
            .collect();
        assert_eq!(alphas, [0.36, 0.09, 0.010000001]);
        let glass = cornell_glass(2_242);
        assert_eq!(glass.triangle_count(), 2_242);
        let glass_id =
            surfaces(&glass).iter().position(|s| *s == Surface::Dielectric { eta: 1.5 }).unwrap()
                as u32;
        let mut edges = std::collections::HashMap::new();
        for (t, _) in glass.indices.iter().zip(&glass.material_ids).filter(|(_, &m)| m == glass_id)
        {
            for k in 0..3 {
                let key = |a: u32| glass.positions[a as usize].to_array().map(f32::to_bits);
                *edges.entry((key(t[k]), key(t[(k + 1) % 3]))).or_insert(0) += 1;
            }
        }
        assert!(
            edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)),
            "an open or inconsistent glass mesh"
        );
        for (s, centre, radius) in [
            (&mirror, SHORT_BOX.center + Vec3::new(0.0, 0.3, 0.0), 0.3),
            (&glass, SPHERE_CENTRE + Vec3::new(0.0, LIFT, 0.0), SPHERE_RADIUS),
            (&glossy, SPHERE_CENTRE, SPHERE_RADIUS),
        ] {
            let on_sphere: Vec<(Vec3, Vec3)> = s
                .positions
                .iter()
                .zip(&s.normals)
                .filter(|(p, _)| ((**p - centre).length() - radius).abs() < 1e-4)
                .map(|(p, n)| (*p, *n))
                .collect();
            assert_eq!(on_sphere.len(), 2 + 23 * 48, "{}", s.name);
            assert!(
                on_sphere.iter().all(|(p, n)| n.dot(*p - centre) > 0.99 * radius),
                "{}",
                s.name
            );
        }
    }
}
