//! Inputs the differential tests share: fixed point sets from real scenes, and proptest
//! strategies for random ones: point sets, triangle soups and rooms with random lights.

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use vplgi_cpu::CpuScene;
use vplgi_scene::cornell::cornell_box;
use vplgi_scene::{Camera, Material, PunctualLight, Scene, Surface};
use vplgi_types::{CameraParams, Rng, Stream};

/// The Cornell box with a coloured spot light added (cones of 25.8 and 45.6 degrees, aimed
/// off the vertical): a scene with every light kind but the point light.
pub fn cornell_box_with_spot() -> Scene {
    let mut scene = cornell_box();
    scene.lights.push(PunctualLight::Spot {
        position: Vec3::new(0.5, 1.5, 0.5),
        direction: Vec3::new(-0.3, -1.0, -0.4).normalize(),
        intensity: Vec3::new(3.0, 2.0, 1.0),
        cos_inner: 0.9,
        cos_outer: 0.7,
    });
    scene
}

/// A plane of half size 1 and albedo 0.6 with a cube of side 0.5 standing on it, lit by a directional
/// light (the sun) from 40 degrees off the vertical with irradiance (3, 2.5, 2): parallel rays
/// with a shadow, the cube's walls lit or not, and light bounced between cube and plane.
pub fn sunlit_plane_with_box() -> Scene {
    let mut scene = vplgi_scene::cornell::plane_with_point_light(1.0, 1.0, 0.6, 1.0);
    scene.lights = vec![PunctualLight::Directional {
        direction: sun_direction(),
        irradiance: Vec3::new(3.0, 2.5, 2.0),
    }];
    let m = material(&mut scene, Vec3::new(0.7, 0.4, 0.3), Vec3::ZERO);
    open_box(&mut scene, Vec3::new(-0.05, 0.25, -0.05), Vec3::splat(0.25), 2, m);
    scene.name = "sunlit plane with a box".into();
    scene.validate().expect("a valid scene");
    scene
}

/// A lone emissive square of half size `half` in the plane z = 0, facing the default camera at
/// (0, 0, 5) (looking down -z, yfov 0.7), radiance `radiance`, albedo 0: seen against the
/// background, its image is `radiance` times the part of each pixel it covers.
pub fn emissive_square(half: f32, radiance: Vec3) -> Scene {
    let mut scene = Scene { name: "emissive square".into(), ..Scene::default() };
    let m = material(&mut scene, Vec3::ZERO, radiance);
    grid_quad(
        &mut scene,
        Vec3::new(-half, -half, 0.0),
        (Vec3::X * (2.0 * half), Vec3::Y * (2.0 * half)),
        1,
        Vec3::Z,
        m,
    );
    scene.validate().expect("a valid scene");
    scene
}

/// [`sunlit_plane_with_box`]'s sun: 40 degrees from straight down, towards -x and +z.
pub fn sun_direction() -> Vec3 {
    let a = 40f32.to_radians();
    Vec3::new(-a.sin() * 0.8, -a.cos(), a.sin() * 0.6).normalize()
}

/// The Cornell box's shading points (surfaces meeting at edges, both orientations of thin walls)
/// at `width` x `height`, one per pixel: positions and normals of the hits.
pub fn cornell_points(width: u32, height: u32, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = CpuScene::new(&scene, &device).expect("Embree scene");
    let sps = vplgi_cpu::shading_points::shading_points(
        &cs,
        &CameraParams::new(cs.scene.camera, width, height, 1, seed),
    );
    sps.iter()
        .filter(|s| !s.is_miss())
        .map(|s| (Vec3::from(s.position), Vec3::from(s.normal)))
        .unzip()
}

/// A unit vector from two numbers in [0, 1).
fn direction(u: f32, v: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Surface-like point sets, as clustering sees them: 1 to 6 planar patches of random orientation,
/// size and offset, with 100 to 1,500 points in all, some patches seen from both sides (normals
/// flipped at random per point), at a random scale of the scene (1e-2 to 1e2).
pub fn surface_points() -> impl Strategy<Value = (Vec<Vec3>, Vec<Vec3>)> {
    let patch = (
        0f32..1.0,
        0f32..1.0,
        0f32..1.0,
        0f32..1.0,
        -1f32..1.0,
        -1f32..1.0,
        -1f32..1.0,
        0.05f32..1.0,
        any::<bool>(),
    );
    (prop::collection::vec(patch, 1..=6), 100usize..1500, -2f32..2.0, any::<u64>()).prop_map(
        |(patches, n, log_scale, seed)| {
            let scale = 10f32.powf(log_scale);
            let mut rng = Rng::new(seed as u32, Stream::Oracle, (seed >> 32) as u32);
            let (mut ps, mut ns) = (Vec::with_capacity(n), Vec::with_capacity(n));
            for i in 0..n {
                let (nu, nv, tu, tv, ox, oy, oz, size, two_sided) = patches[i % patches.len()];
                let normal = direction(nu, nv);
                let tangent = normal
                    .cross(direction(tu, tv))
                    .try_normalize()
                    .unwrap_or(normal.any_orthonormal_vector());
                let bitangent = normal.cross(tangent);
                let (a, b) = (rng.next_f32() - 0.5, rng.next_f32() - 0.5);
                let p = Vec3::new(ox, oy, oz) + (tangent * a + bitangent * b) * size;
                let flip = two_sided && rng.next_f32() < 0.5;
                ps.push(p * scale);
                ns.push(if flip { -normal } else { normal });
            }
            (ps, ns)
        },
    )
}

/// A material with albedo `albedo` and emission `emission`; its index.
fn material(s: &mut Scene, albedo: Vec3, emission: Vec3) -> u32 {
    s.materials.push(Material {
        name: format!("m{}", s.materials.len()),
        base_color: albedo,
        base_color_texture: None,
        emission,
        ..Material::default()
    });
    s.materials.len() as u32 - 1
}

/// Adds triangle `t` (any winding) with its front facing `facing`, flat-shaded.
fn triangle(s: &mut Scene, mut t: [Vec3; 3], facing: Vec3, material: u32) {
    if (t[1] - t[0]).cross(t[2] - t[0]).dot(facing) < 0.0 {
        t.swap(1, 2);
    }
    let normal = (t[1] - t[0])
        .cross(t[2] - t[0])
        .try_normalize()
        .unwrap_or(facing.try_normalize().unwrap_or(Vec3::Y));
    let base = s.positions.len() as u32;
    for p in t {
        s.positions.push(p);
        s.normals.push(normal);
        s.uvs.push(Vec2::ZERO);
    }
    s.indices.push([base, base + 1, base + 2]);
    s.material_ids.push(material);
}

/// Adds the parallelogram `origin + [0, 1] u + [0, 1] v` as an `n` x `n` grid of cells of two
/// triangles over shared vertices (so shared edges and diagonals, as in the generated scenes),
/// front facing `facing`.
fn grid_quad(
    s: &mut Scene,
    origin: Vec3,
    (u, v): (Vec3, Vec3),
    n: u32,
    facing: Vec3,
    material: u32,
) {
    let (u, v) = if u.cross(v).dot(facing) < 0.0 { (v, u) } else { (u, v) };
    let normal = u.cross(v).try_normalize().unwrap_or(Vec3::Y);
    let base = s.positions.len() as u32;
    for j in 0..=n {
        for i in 0..=n {
            s.positions.push(origin + u * (i as f32 / n as f32) + v * (j as f32 / n as f32));
            s.normals.push(normal);
            s.uvs.push(Vec2::ZERO);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let at = |di: u32, dj: u32| base + (j + dj) * (n + 1) + i + di;
            s.indices.push([at(0, 0), at(1, 0), at(1, 1)]);
            s.indices.push([at(0, 0), at(1, 1), at(0, 1)]);
            s.material_ids.extend([material, material]);
        }
    }
}

/// A box standing on the floor without its bottom: centre `c`, half extents `half`, each face an
/// `n` x `n` grid facing out.
fn open_box(s: &mut Scene, c: Vec3, half: Vec3, n: u32, material: u32) {
    let (hx, hy, hz) = (Vec3::X * half.x, Vec3::Y * half.y, Vec3::Z * half.z);
    for (o, u, v, out) in [
        (c - hx - hz + hy, 2.0 * hx, 2.0 * hz, Vec3::Y),
        (c - hx - hy - hz, 2.0 * hx, 2.0 * hy, -Vec3::Z),
        (c - hx - hy + hz, 2.0 * hx, 2.0 * hy, Vec3::Z),
        (c - hx - hy - hz, 2.0 * hy, 2.0 * hz, -Vec3::X),
        (c + hx - hy - hz, 2.0 * hy, 2.0 * hz, Vec3::X),
    ] {
        grid_quad(s, o, (u, v), n, out, material);
    }
}

/// What lights a random scene.
#[derive(Clone, Copy, Debug)]
pub enum LightKind {
    /// Emissive triangles (area lights).
    Area,
    Point,
    Spot,
}

fn light_kind() -> impl Strategy<Value = LightKind> {
    prop_oneof![Just(LightKind::Area), Just(LightKind::Point), Just(LightKind::Spot)]
}

/// A camera at `position` looking at `target`.
fn camera(position: Vec3, target: Vec3, yfov: f32) -> Camera {
    let forward = (target - position).try_normalize().unwrap_or(-Vec3::Z);
    let up =
        (Vec3::Y - forward * forward.y).try_normalize().unwrap_or(forward.any_orthonormal_vector());
    Camera { position, forward, up, yfov }
}

/// A punctual light of `kind` at `position`, aimed at `target` if a spot.
fn punctual(kind: LightKind, position: Vec3, target: Vec3, rng: &mut Rng) -> PunctualLight {
    let intensity =
        Vec3::new(0.5 + rng.next_f32(), 0.5 + rng.next_f32(), 0.5 + rng.next_f32()) * 3.0;
    match kind {
        LightKind::Spot => {
            let cos_outer = 0.3 + 0.6 * rng.next_f32();
            let cos_inner = cos_outer + (1.0 - cos_outer) * rng.next_f32();
            let direction = (target - position).try_normalize().unwrap_or(-Vec3::Y);
            PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer }
        }
        _ => PunctualLight::Point { position, intensity },
    }
}

/// A triangle soup: 4 to 80 random triangles in [-1, 1]^3, each sharing an edge with the next
/// (a strip of copied vertices), lit by 1 to 3 lights of random kinds (emissive triangles among
/// them, or point and spot lights outside the cube), seen from a random direction.
pub fn triangle_soup() -> impl Strategy<Value = Scene> {
    (4usize..80, prop::collection::vec(light_kind(), 1..=3), any::<u64>()).prop_map(
        |(n, lights, seed)| {
            let mut rng = Rng::new(seed as u32, Stream::Oracle, (seed >> 32) as u32);
            let mut s = Scene { name: format!("soup of {n}"), ..Scene::default() };
            let mut point =
                || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            let corners: Vec<Vec3> = (0..n + 2).map(|_| point()).collect();
            let mut rng = Rng::new(seed as u32, Stream::Oracle, !(seed >> 32) as u32);
            let albedos: Vec<u32> = (0..3)
                .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.8 + 0.1)
                .map(|a| material(&mut s, a, Vec3::ZERO))
                .collect();
            let emitter = material(&mut s, Vec3::splat(0.5), Vec3::new(4.0, 3.0, 2.0));
            let areas = lights.iter().filter(|k| matches!(k, LightKind::Area)).count();
            for i in 0..n {
                let t = [corners[i], corners[i + 1], corners[i + 2]];
                let m = if i < areas { emitter } else { albedos[i % 3] };
                let facing = (t[1] - t[0]).cross(t[2] - t[0]);
                triangle(&mut s, t, if i % 2 == 0 { facing } else { -facing }, m);
            }
            // Punctual lights outside the soup's cube, aimed at its centre. Inside it, a light a few
            // hundredths from two folded triangles sees their crease nearly edge-on, and rays that
            // graze it (hit on one backend, missed on the other by rounding: both legitimately) were
            // 0.1 % of the paths on their own.
            for k in lights.iter().filter(|k| !matches!(k, LightKind::Area)) {
                let at = direction(rng.next_f32(), rng.next_f32()) * (1.8 + rng.next_f32());
                s.lights.push(punctual(*k, at, Vec3::ZERO, &mut rng));
            }
            let dir = direction(rng.next_f32(), rng.next_f32());
            s.camera = camera(dir * 3.5, Vec3::ZERO, 0.6 + 0.6 * rng.next_f32());
            s
        },
    )
}

/// A closed room of random size (1 to 4 units a side) whose walls are tessellated 1x1 to 4x4,
/// with 0 to 4 boxes standing on the floor, lit by a ceiling area light, a point light or a spot
/// light aimed down, and seen from inside, near the front wall.
pub fn room() -> impl Strategy<Value = Scene> {
    (1u32..=4, 0usize..=4, light_kind(), any::<u64>()).prop_map(|(n, boxes, kind, seed)| {
        let mut rng = Rng::new(seed as u32, Stream::Oracle, (seed >> 32) as u32);
        let mut r = || rng.next_f32();
        let size = Vec3::new(1.0 + 3.0 * r(), 1.0 + 3.0 * r(), 1.0 + 3.0 * r());
        let mut s = Scene {
            name: format!("room {:.2} x {:.2} x {:.2}, {boxes} boxes", size.x, size.y, size.z),
            ..Scene::default()
        };
        let wall = material(
            &mut s,
            Vec3::new(0.2 + 0.6 * r(), 0.2 + 0.6 * r(), 0.2 + 0.6 * r()),
            Vec3::ZERO,
        );
        let other = material(
            &mut s,
            Vec3::new(0.2 + 0.6 * r(), 0.2 + 0.6 * r(), 0.2 + 0.6 * r()),
            Vec3::ZERO,
        );
        let (x, y, z) = (Vec3::X * size.x, Vec3::Y * size.y, Vec3::Z * size.z);
        // Six walls facing in: origin, two sides, and the inward direction.
        for (o, u, v, inward) in [
            (Vec3::ZERO, x, z, Vec3::Y),
            (y, x, z, -Vec3::Y),
            (Vec3::ZERO, x, y, Vec3::Z),
            (z, x, y, -Vec3::Z),
            (Vec3::ZERO, y, z, Vec3::X),
            (x, y, z, -Vec3::X),
        ] {
            grid_quad(&mut s, o, (u, v), n, inward, if inward == Vec3::X { other } else { wall });
        }
        for _ in 0..boxes {
            let half = Vec3::new(0.05 + 0.2 * r(), 0.05 + 0.3 * r(), 0.05 + 0.2 * r()) * size;
            let c = Vec3::new(
                half.x + (size.x - 2.0 * half.x) * r(),
                half.y,
                half.z + (size.z - 2.0 * half.z) * r(),
            );
            open_box(&mut s, c, half, 1, other);
        }
        let centre = size * 0.5;
        match kind {
            LightKind::Area => {
                let emitter = material(
                    &mut s,
                    Vec3::splat(0.5),
                    Vec3::new(8.0, 6.0, 4.0) / (size.x * size.z),
                );
                let (lx, lz) = (size.x * (0.1 + 0.3 * r()), size.z * (0.1 + 0.3 * r()));
                let o = Vec3::new(centre.x - 0.5 * lx, size.y * 0.999, centre.z - 0.5 * lz);
                grid_quad(&mut s, o, (Vec3::X * lx, Vec3::Z * lz), 1, -Vec3::Y, emitter);
            }
            _ => {
                let at =
                    Vec3::new(size.x * (0.2 + 0.6 * r()), size.y * 0.9, size.z * (0.2 + 0.6 * r()));
                let below = Vec3::new(at.x, 0.0, at.z);
                s.lights.push(punctual(kind, at, below, &mut rng));
            }
        }
        let eye = Vec3::new(
            size.x * (0.3 + 0.4 * rng.next_f32()),
            size.y * (0.3 + 0.4 * rng.next_f32()),
            size.z * 0.95,
        );
        s.camera = camera(eye, centre - Vec3::Z * size.z * 0.2, 1.0);
        s
    })
}

/// A closed glass slab (index 1.5) x, y in [-1, 1], z in [-`SLAB_HALF`, `SLAB_HALF`], in front
/// of a diffuse wall of albedo 0.5 at z = -1, seen by the default camera at (0, 0, 5) looking
/// down -z: a ray through the slab's front and back faces leaves parallel to itself, shifted
/// by Snell's law.
pub fn glass_slab_before_wall() -> Scene {
    let mut s = Scene { name: "glass slab before a wall".into(), ..Scene::default() };
    let wall = material(&mut s, Vec3::splat(0.5), Vec3::ZERO);
    grid_quad(
        &mut s,
        Vec3::new(-3.0, -3.0, -1.0),
        (Vec3::X * 6.0, Vec3::Y * 6.0),
        1,
        Vec3::Z,
        wall,
    );
    let glass = material(&mut s, Vec3::ONE, Vec3::ZERO);
    s.materials[glass as usize].surface = Surface::Dielectric { eta: 1.5 };
    closed_box(&mut s, Vec3::ZERO, Vec3::new(1.0, 1.0, SLAB_HALF), glass);
    s.validate().expect("a valid scene");
    s
}

/// Half the thickness of [`glass_slab_before_wall`]'s slab.
pub const SLAB_HALF: f32 = 0.3;

/// A point light of intensity [`MIRROR_ORACLE`]`.2` at height `.0` between a mirror floor (y = 0,
/// reflectance 0.9) and a diffuse ceiling (y = `.1`, albedo 0.5, facing down), both 20 wide: the
/// ceiling is lit by the light and by its mirror image at y = -`.0`.
pub fn point_light_between_mirror_and_ceiling() -> Scene {
    let (light, ceiling, intensity, _) = MIRROR_ORACLE;
    let mut s =
        Scene { name: "point light between a mirror and a ceiling".into(), ..Scene::default() };
    let mirror = material(&mut s, Vec3::splat(0.9), Vec3::ZERO);
    s.materials[mirror as usize].surface = Surface::Mirror;
    let ceiling_material = material(&mut s, Vec3::splat(0.5), Vec3::ZERO);
    let (corner, u, v) = (Vec3::new(-10.0, 0.0, -10.0), Vec3::X * 20.0, Vec3::Z * 20.0);
    grid_quad(&mut s, corner, (u, v), 1, Vec3::Y, mirror);
    grid_quad(&mut s, corner + Vec3::Y * ceiling as f32, (u, v), 1, -Vec3::Y, ceiling_material);
    s.lights.push(PunctualLight::Point {
        position: Vec3::Y * light as f32,
        intensity: Vec3::splat(intensity as f32),
    });
    s.validate().expect("a valid scene");
    s
}

/// [`point_light_between_mirror_and_ceiling`] with a floor of rough metal (GGX α 0.09, colour
/// 0.9) instead of the mirror, seen from above the light at a slant: the floor's glossy peak
/// reflects the lit ceiling, one unit above it.
pub fn point_light_between_rough_metal_and_ceiling() -> Scene {
    let mut s = point_light_between_mirror_and_ceiling();
    s.name = "point light between rough metal and a ceiling".into();
    s.materials[0].surface = Surface::RoughConductor { alpha: 0.09 };
    let eye = Vec3::new(0.0, 0.8, 3.0);
    s.camera = vplgi_scene::Camera {
        position: eye,
        forward: (Vec3::new(0.0, 0.0, -1.0) - eye).normalize(),
        up: Vec3::Y,
        yfov: 50f32.to_radians(),
    };
    s.validate().expect("a valid scene");
    s
}

/// [`point_light_between_mirror_and_ceiling`]'s light height, ceiling height and intensity, and
/// the radius of the disk under the light that [`check_mirror_image_flux`] judges.
pub const MIRROR_ORACLE: (f64, f64, f64, f64) = (0.5, 1.0, 2.0, 0.5);

/// Each backend's VPLs of [`point_light_between_mirror_and_ceiling`]: none on the mirror, and
/// the flux of those whose particle passed it, on the disk under the light, within `bound`
/// (relative) of what the mirror image sends there once reflected. The image at depth h under
/// the floor gives irradiance ρ_m I cos θ′ / d′², which integrates over the disk of radius R to
/// ρ_c ρ_m I 2π D (1 / D − 1 / √(D² + R²)), D = H + h. Prints both.
pub fn check_mirror_image_flux(sets: &[(&str, Vec<vplgi_types::Vpl>)], bound: f64) {
    let (light, ceiling, intensity, radius) = MIRROR_ORACLE;
    let d = ceiling + light;
    let expected = 0.5
        * 0.9
        * intensity
        * 2.0
        * std::f64::consts::PI
        * d
        * (1.0 / d - 1.0 / (d * d + radius * radius).sqrt());
    for &(backend, ref vpls) in sets {
        let on_mirror = vpls.iter().filter(|v| v.position[1].abs() < 1e-4).count();
        let inside =
            |v: &&vplgi_types::Vpl| (v.position[0] as f64).hypot(v.position[2] as f64) < radius;
        let flux: f64 =
            vpls.iter().filter(|v| v.specular == 1).filter(inside).map(|v| v.flux[0] as f64).sum();
        let rel = (flux - expected).abs() / expected;
        println!("{backend}: flux through the mirror on the disk {flux:.5}, the mirror image gives {expected:.5} ({:.3} % off); {on_mirror} VPLs on the mirror", 100.0 * rel);
        assert_eq!(on_mirror, 0, "{backend}: VPLs on the mirror");
        vplgi_verify::tolerance::Disagreement::at_most(
            backend,
            "mirror-lit flux on the disk against the mirror image's, relative",
            rel,
            bound,
        )
        .check();
    }
}

/// `scene` with every third material a mirror and every third glass (index 1.5), starting at the
/// second: random scenes with specular chains, glass in open meshes included.
pub fn with_mirrors_and_glass(mut scene: Scene) -> Scene {
    for (i, m) in scene.materials.iter_mut().enumerate() {
        m.surface = match i % 3 {
            1 => Surface::Mirror,
            2 => Surface::Dielectric { eta: 1.5 },
            _ => Surface::Diffuse,
        };
    }
    scene.name = format!("{} with mirrors and glass", scene.name);
    scene
}

/// `scene` with every third material rough metal (GGX α 0.01, 0.09 or 0.36 in turn: glTF
/// roughness 0.1, 0.3 and 0.6) and every third half metal on diffuse, starting at the second:
/// random scenes with glossy receivers and glossy VPLs.
pub fn with_rough_metal(mut scene: Scene) -> Scene {
    const ALPHAS: [f32; 3] = [0.01, 0.09, 0.36];
    for (i, m) in scene.materials.iter_mut().enumerate() {
        let alpha = ALPHAS[(i / 3) % 3];
        m.surface = match i % 3 {
            1 => Surface::RoughConductor { alpha },
            2 => Surface::Blend { metallic: 0.5, alpha },
            _ => Surface::Diffuse,
        };
    }
    scene.name = format!("{} with rough metal", scene.name);
    scene
}

/// A box of centre `c` and half extents `half`, all six faces facing out.
fn closed_box(s: &mut Scene, c: Vec3, half: Vec3, material: u32) {
    let (hx, hy, hz) = (Vec3::X * half.x, Vec3::Y * half.y, Vec3::Z * half.z);
    open_box(s, c, half, 1, material);
    grid_quad(s, c - hx - hy - hz, (2.0 * hx, 2.0 * hz), 1, -Vec3::Y, material);
}

/// A random scene: a triangle soup or a room.
pub fn random_scene() -> impl Strategy<Value = Scene> {
    prop_oneof![triangle_soup(), room()].prop_map(|s| {
        s.validate().unwrap_or_else(|e| panic!("a generated scene is invalid: {e}"));
        s
    })
}

/// `n` points on the surfaces of `scene`, each with its triangle's normal (flipped for a fifth of
/// them: a shadow ray may start on either side of a thin surface). A share `on_edges` lies
/// exactly on a triangle's edge (two thirds) or vertex (one third), where triangles meet and rays
/// graze; the rest inside a triangle. No two points share a position: a vertex drawn twice would
/// repeat every segment through it, so one grazing tie would count as two (it once did, and
/// doubled a 1-in-1,900 tie past the SPEC's 0.1 %).
pub fn surface_endpoints(
    scene: &Scene,
    n: usize,
    seed: u64,
    on_edges: f32,
) -> Vec<vplgi_types::Endpoint> {
    let mut rng = Rng::new(seed as u32, Stream::Oracle, (seed >> 32) as u32);
    let mut taken = std::collections::HashSet::new();
    std::iter::repeat_with(|| {
        let t = scene.indices[(rng.next_u32() as usize) % scene.indices.len()];
        let [a, b, c] = t.map(|i| scene.positions[i as usize]);
        let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let place = rng.next_f32();
        if place < on_edges / 3.0 {
            (u, v) = (1.0, 0.0);
        } else if place < on_edges {
            v = 0.0;
        }
        let p = a + (b - a) * u + (c - a) * v;
        let normal = (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::Y);
        vplgi_types::Endpoint::new(p, if rng.next_f32() < 0.2 { -normal } else { normal })
    })
    .filter(|e| taken.insert(e.p().to_array().map(f32::to_bits)))
    .take(n)
    .collect()
}
