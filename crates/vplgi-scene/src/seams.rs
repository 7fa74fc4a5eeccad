//! Rooms whose surfaces meet at hairline cracks, as scenes exported from other tools do: every
//! wall, every face of the two blocks and the light is a separate mesh, a square in its own frame
//! placed by its own transform (rotations by a right angle whose cosine is not 0 in f32,
//! non-uniform scales, translations), baked into float32 vertices. Where two meshes meet, their
//! vertices differ by a few ulps, and the floor is three meshes with a T-junction (a corner of
//! two of them on the middle of the third's edge). No vertex is shared between meshes.
//!
//! The room is a Cornell box centred on the origin (x and y in [-1, 1], z from -1 to the open
//! front at 1.4), seen by a camera on its axis: at a square resolution the pixel centres on the
//! image diagonals look straight along the four long seams, the worst case for a traversal that
//! closes cracks only between triangles sharing vertices. [`Placement`] moves, turns and scales
//! the whole room (and its camera) for the rotated variant and for property tests.

use crate::{Camera, Material, Scene};
use glam::{Mat4, Quat, Vec2, Vec3};
use std::f32::consts::FRAC_PI_2;

/// Where the whole room goes: scaled per axis, then rotated, then moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub scale: Vec3,
    pub rotation: Quat,
    pub offset: Vec3,
}

impl Placement {
    /// The room as built: axis-aligned, centred on the origin.
    pub const AXIS_ALIGNED: Placement =
        Placement { scale: Vec3::ONE, rotation: Quat::IDENTITY, offset: Vec3::ZERO };

    /// The room turned 40 degrees about a tilted axis and moved off the origin, so that no
    /// seam is axis-aligned and every coordinate is rounded.
    pub fn rotated() -> Placement {
        Placement {
            scale: Vec3::ONE,
            rotation: Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7),
            offset: Vec3::new(0.31, 1.27, -0.53),
        }
    }

    fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.offset)
    }
}

/// A room with cracks, and where they are.
pub struct SeamRoom {
    pub scene: Scene,
    /// The lines along which separate meshes meet (each as its two ends, placed as the room is):
    /// the room's eight inner edges, the floor's two inner seams and the blocks' eight edges
    /// each. A ray aimed at a point of one of them runs into a crack.
    pub seams: Vec<[Vec3; 2]>,
    /// The placement as the matrix that took the room's frame to the scene's.
    pub placement: Mat4,
}

/// The room's half width and height, and the z of its back wall and open front.
const HALF: f32 = 1.0;
const BACK: f32 = -1.0;
const FRONT: f32 = 1.4;

/// A block standing on the floor: the centre of its bottom face, its size and its turn about y.
struct Block {
    base: Vec3,
    size: Vec3,
    angle_deg: f32,
}

const BLOCKS: [Block; 2] = [
    Block { base: Vec3::new(0.35, -HALF, 0.35), size: Vec3::new(0.6, 0.6, 0.6), angle_deg: -18.0 },
    Block { base: Vec3::new(-0.35, -HALF, -0.3), size: Vec3::new(0.6, 1.2, 0.6), angle_deg: 18.0 },
];

/// The room with every mesh an n x n grid of cells (n from the triangle budget; at least 1),
/// placed by `placement`.
pub fn seam_room(placement: Placement, triangles: usize) -> SeamRoom {
    let place = placement.matrix();
    let mut s = Scene { name: "seams".into(), ..Scene::default() };
    for (name, base_color, emission) in [
        ("white", Vec3::splat(0.73), Vec3::ZERO),
        ("red", Vec3::new(0.63, 0.065, 0.05), Vec3::ZERO),
        ("green", Vec3::new(0.14, 0.45, 0.09), Vec3::ZERO),
        ("light", Vec3::splat(0.78), Vec3::new(34.0, 24.0, 8.0)),
    ] {
        s.materials.push(Material {
            name: name.into(),
            base_color,
            base_color_texture: None,
            emission,
            surface: crate::Surface::Diffuse,
        });
    }
    let (white, red, green, light) = (0, 1, 2, 3);

    // Each mesh is the unit square in z = 0 (front +z) under scale, then rotation, then
    // translation, then the placement: one f32 matrix, as an exporter bakes a node's transform.
    let depth = FRONT - BACK;
    let mid = 0.5 * (FRONT + BACK);
    let width = 2.0 * HALF;
    let wall = |size: Vec2, rotation: Quat, centre: Vec3| {
        place * Mat4::from_scale_rotation_translation(size.extend(1.0), rotation, centre)
    };
    let mut meshes = vec![
        (wall(Vec2::splat(width), Quat::IDENTITY, Vec3::new(0.0, 0.0, BACK)), white),
        (
            wall(
                Vec2::new(width, depth),
                Quat::from_rotation_x(FRAC_PI_2),
                Vec3::new(0.0, HALF, mid),
            ),
            white,
        ),
        (
            wall(
                Vec2::new(depth, width),
                Quat::from_rotation_y(FRAC_PI_2),
                Vec3::new(-HALF, 0.0, mid),
            ),
            red,
        ),
        (
            wall(
                Vec2::new(depth, width),
                Quat::from_rotation_y(-FRAC_PI_2),
                Vec3::new(HALF, 0.0, mid),
            ),
            green,
        ),
        // The floor: its left half whole, its right half in two, so the right halves' shared
        // corner lies on the middle of the left half's edge (a T-junction).
        (
            wall(
                Vec2::new(HALF, depth),
                Quat::from_rotation_x(-FRAC_PI_2),
                Vec3::new(-0.5 * HALF, -HALF, mid),
            ),
            white,
        ),
        (
            wall(
                Vec2::new(HALF, 0.5 * depth),
                Quat::from_rotation_x(-FRAC_PI_2),
                Vec3::new(0.5 * HALF, -HALF, mid - 0.25 * depth),
            ),
            white,
        ),
        (
            wall(
                Vec2::new(HALF, 0.5 * depth),
                Quat::from_rotation_x(-FRAC_PI_2),
                Vec3::new(0.5 * HALF, -HALF, mid + 0.25 * depth),
            ),
            white,
        ),
        (
            wall(
                Vec2::splat(0.5),
                Quat::from_rotation_x(FRAC_PI_2),
                Vec3::new(0.0, 0.98 * HALF, 0.0),
            ),
            light,
        ),
    ];
    let mut seams = Vec::new();
    let corner = |x: f32, y: f32, z: f32| place.transform_point3(Vec3::new(x, y, z));
    for (x, y) in [(-HALF, -HALF), (-HALF, HALF), (HALF, -HALF), (HALF, HALF)] {
        seams.push([corner(x, y, BACK), corner(x, y, FRONT)]);
    }
    for (a, b) in [
        ((-HALF, -HALF), (HALF, -HALF)),
        ((-HALF, HALF), (HALF, HALF)),
        ((-HALF, -HALF), (-HALF, HALF)),
        ((HALF, -HALF), (HALF, HALF)),
    ] {
        seams.push([corner(a.0, a.1, BACK), corner(b.0, b.1, BACK)]);
    }
    seams.push([corner(0.0, -HALF, BACK), corner(0.0, -HALF, FRONT)]);
    seams.push([corner(0.0, -HALF, mid), corner(HALF, -HALF, mid)]);

    // A block's faces: the unit cube's top and sides, each a square turned and pushed out to its
    // face, then the block's scale, turn and position.
    for b in &BLOCKS {
        let block = place
            * Mat4::from_scale_rotation_translation(
                b.size,
                Quat::from_rotation_y(b.angle_deg.to_radians()),
                b.base + Vec3::new(0.0, 0.5 * b.size.y, 0.0),
            );
        let faces = [
            (Quat::from_rotation_x(-FRAC_PI_2), Vec3::Y),
            (Quat::IDENTITY, Vec3::Z),
            (Quat::from_rotation_y(FRAC_PI_2), Vec3::X),
            (Quat::from_rotation_y(std::f32::consts::PI), -Vec3::Z),
            (Quat::from_rotation_y(-FRAC_PI_2), -Vec3::X),
        ];
        for (turn, out) in faces {
            meshes.push((block * Mat4::from_rotation_translation(turn, 0.5 * out), white));
        }
        let at = |x: f32, y: f32, z: f32| block.transform_point3(Vec3::new(x, y, z));
        for (x, z) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
            seams.push([at(x, -0.5, z), at(x, 0.5, z)]);
        }
        for ((x0, z0), (x1, z1)) in [
            ((-0.5, -0.5), (0.5, -0.5)),
            ((0.5, -0.5), (0.5, 0.5)),
            ((0.5, 0.5), (-0.5, 0.5)),
            ((-0.5, 0.5), (-0.5, -0.5)),
        ] {
            seams.push([at(x0, 0.5, z0), at(x1, 0.5, z1)]);
        }
    }

    let n = ((triangles as f64 / (2 * meshes.len()) as f64).sqrt().round() as u32).max(1);
    for (m, material) in meshes {
        add_grid(&mut s, m, n, material);
    }

    let eye = place.transform_point3(Vec3::new(0.0, 0.0, 3.9));
    let forward = place.transform_vector3(-Vec3::Z).normalize();
    let up = place.transform_vector3(Vec3::Y);
    let up = (up - forward * up.dot(forward)).normalize();
    s.camera = Camera { position: eye, forward, up, yfov: 40f32.to_radians() };
    SeamRoom { scene: s, seams, placement: place }
}

/// The unit square in z = 0 as n x n cells of two triangles under `m`, front +z carried along.
/// Vertices inside the mesh are shared; its edge vertices belong to it alone.
fn add_grid(s: &mut Scene, m: Mat4, n: u32, material: u32) {
    let first = s.positions.len() as u32;
    let normal = m.transform_vector3(Vec3::X).cross(m.transform_vector3(Vec3::Y)).normalize();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
            s.positions.push(m.transform_point3(Vec3::new(u - 0.5, v - 0.5, 0.0)));
            s.normals.push(normal);
            s.uvs.push(Vec2::new(u, v));
        }
    }
    let at = |i: u32, j: u32| first + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            s.indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            s.indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            s.material_ids.extend([material, material]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Meshes meet at vertices a few ulps apart and share none: the cracks the scene is for.
    /// Every triangle faces into the room or out of its block (the camera sees fronts).
    #[test]
    fn meshes_meet_a_few_ulps_apart_and_share_no_vertex() {
        for placement in [Placement::AXIS_ALIGNED, Placement::rotated()] {
            let room = seam_room(placement, 0);
            let s = &room.scene;
            assert_eq!(s.validate(), Ok(()));
            assert_eq!(s.triangle_count(), 2 * (8 + 10));
            let (mut apart, mut same) = (0, 0);
            for (i, a) in s.positions.iter().enumerate() {
                for (j, b) in s.positions.iter().enumerate().skip(i + 1) {
                    let d = (*a - *b).abs().max_element();
                    if i / 4 != j / 4 && d < 1e-5 {
                        if d == 0.0 {
                            same += 1;
                        } else {
                            apart += 1;
                            assert!(d < 1e-6, "{a} and {b}: {d} apart, more than a few ulps");
                        }
                    }
                }
            }
            assert!(
                apart >= 8,
                "{placement:?}: only {apart} meeting vertices differ ({same} are equal): no cracks"
            );
            // Fronts: the room's inner side, the blocks' outer side, the light's downward side.
            let centre = placement.matrix().transform_point3(Vec3::ZERO);
            let up = placement.rotation * Vec3::Y;
            // A block's centre: the mean of its five faces' vertices (ten triangles each block).
            let block_centre = |t: usize| {
                let first = 16 + (t - 16) / 10 * 10;
                (first..first + 10).flat_map(|u| s.triangle(u)).sum::<Vec3>() / 30.0
            };
            for t in 0..s.triangle_count() {
                let [a, b, c] = s.triangle(t);
                let front = (b - a).cross(c - a).normalize();
                let mid = (a + b + c) / 3.0;
                let facing = if s.material_ids[t] == 3 {
                    front.dot(up) < -0.99
                } else if t >= 16 {
                    (mid - block_centre(t)).dot(front) > 0.0
                } else {
                    (centre - mid).dot(front) > 0.0
                };
                assert!(facing, "{placement:?}: triangle {t} faces {front}");
            }
        }
    }

    /// The seams are where meshes meet: each seam's midpoint is within a few ulps of two
    /// triangles' edges of different meshes.
    #[test]
    fn every_seam_runs_between_two_meshes() {
        let room = seam_room(Placement::rotated(), 0);
        let s = &room.scene;
        let near_edge = |p: Vec3, t: usize| {
            let [a, b, c] = s.triangle(t);
            [(a, b), (b, c), (c, a)].iter().any(|&(u, v)| {
                let along = ((p - u).dot(v - u) / (v - u).length_squared()).clamp(0.0, 1.0);
                (u + (v - u) * along - p).length() < 1e-5
            })
        };
        for (k, [a, b]) in room.seams.iter().enumerate() {
            let p = (*a + *b) * 0.5;
            let meshes: std::collections::BTreeSet<usize> =
                (0..s.triangle_count()).filter(|&t| near_edge(p, t)).map(|t| t / 2).collect();
            assert!(
                meshes.len() >= 2,
                "seam {k} ({a} to {b}) lies on the edge of meshes {meshes:?} only"
            );
        }
    }

    /// The camera of the axis-aligned room looks along its axis from its centre line, so the
    /// image diagonals project onto the long seams.
    #[test]
    fn the_camera_is_centred() {
        let room = seam_room(Placement::AXIS_ALIGNED, 0);
        let c = room.scene.camera;
        assert_eq!((c.position.x, c.position.y, c.forward), (0.0, 0.0, -Vec3::Z));
    }
}
