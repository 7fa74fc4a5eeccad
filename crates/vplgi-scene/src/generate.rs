//! Procedural scenes at the paper's scale (`vplgi scene generate`), deterministic for a given
//! triangle budget:
//!
//! * `cornell-fine`: the built-in Cornell box with every non-emissive triangle split into n²
//!   (about 1.9 M triangles by default, the paper's tessellated Cornell box);
//! * `conference`: a closed meeting room with rows of tables and chairs on thin legs, lit from
//!   ceiling panels, so that the light under the furniture is indirect and its shadows matter
//!   (about 300 k triangles, like the paper's 331 k conference room);
//! * `living-room`: large smooth walls and floor, two sofas, a low table with a glass top and a
//!   mirror on the back wall, lit mostly through a bright window-like panel in one wall (about
//!   300 k triangles, like the paper's 313 k room);
//! * `sunlit-living-room`: the same room, with a wooden table top and no mirror, with an open
//!   window in that wall and the sun (a
//!   directional light) shining through it onto the floor: the sun-lit room of Prutkin et al.'s
//!   comparisons, whose indirect light all comes from one bright patch;
//! * `seams` and `seams-rotated`: a Cornell box built as an exporter writes one, every wall and
//!   block face a separately transformed mesh, so that surfaces meet at hairline cracks a few
//!   ulps wide, seen by a centred camera whose pixel rays run along them ([`crate::seams`]).
//!
//! * `cornell-mirror`, `cornell-glass` and `cornell-glossy`: the Cornell box with a mirror wall
//!   and sphere, a closed glass cube and sphere, and rough metals (roughness 0.6, 0.3, 0.1); the
//!   sphere takes the budget.
//! * `cornell-water`: the Cornell box a third full of wavy water, with a point light above it
//!   (Wang et al.'s "box + water"); the water's surface takes the budget.
//! * `cornell-mirrors`: the Cornell box with a mirror back and right wall, a fine white sphere
//!   and a point light (Wang et al.'s elephant between two mirrors); the sphere takes the budget.
//!
//! [`camera_walk`] adds a camera path to any of them (`--camera-walk`), for frame sequences.
//!
//! Budgets are met by subdividing the large surfaces; furniture detail is fixed, so a small
//! budget still gives the whole scene (tests use a few thousand triangles).

use crate::{Camera, CameraPath, Material, PunctualLight, Scene, Track};
use glam::{Mat4, Quat, Vec2, Vec3};

/// The generators, by name: (name, default triangle budget, what it is).
pub const GENERATORS: [(&str, usize, &str); 11] = [
    ("cornell-fine", 1_900_000, "the Cornell box tessellated to the paper's 1.9 M triangles"),
    (
        "conference",
        300_000,
        "a meeting room with rows of tables and chairs on thin legs, ceiling panels",
    ),
    (
        "living-room",
        300_000,
        "large smooth walls, two sofas, a glass-topped table and a wall mirror, lit through a window-like panel",
    ),
    (
        "sunlit-living-room",
        300_000,
        "the living room with an open window and the sun shining through it",
    ),
    (
        "seams",
        36,
        "a Cornell box of separately transformed meshes meeting at hairline cracks, centred camera",
    ),
    ("seams-rotated", 36, "the same room turned about a tilted axis and moved off the origin"),
    ("cornell-mirror", 2_230, "the Cornell box with a mirror back wall and a mirror sphere"),
    ("cornell-glass", 2_242, "the Cornell box with a closed glass cube and a glass sphere"),
    ("cornell-glossy", 2_240, "the Cornell box with rough metals of roughness 0.6, 0.3 and 0.1"),
    (
        "cornell-mirrors",
        84_000,
        "the Cornell box with a mirror back and right wall, a fine white sphere and a point light",
    ),
    (
        "cornell-water",
        17_000,
        "the Cornell box a third full of wavy water over the short box, with a point light above it",
    ),
];

/// The scene `name` with about `triangles` triangles (at least the furniture's own count).
pub fn generate(name: &str, triangles: usize) -> Result<Scene, String> {
    let scene = match name {
        "cornell-fine" => cornell_fine(triangles),
        "conference" => conference(triangles),
        "living-room" => living_room(triangles),
        "sunlit-living-room" => sunlit_living_room(triangles),
        "seams" => crate::seams::seam_room(crate::seams::Placement::AXIS_ALIGNED, triangles).scene,
        "seams-rotated" => Scene {
            name: "seams-rotated".into(),
            ..crate::seams::seam_room(crate::seams::Placement::rotated(), triangles).scene
        },
        "cornell-mirror" => crate::cornell::cornell_mirror(triangles),
        "cornell-glass" => crate::cornell::cornell_glass(triangles),
        "cornell-glossy" => crate::cornell::cornell_glossy(triangles),
        "cornell-water" => crate::cornell::cornell_water(triangles),
        "cornell-mirrors" => crate::cornell::cornell_mirrors(triangles),
        _ => {
            return Err(format!(
                "unknown scene {name:?}; the generators are {}",
                GENERATORS.map(|g| g.0).join(", ")
            ))
        }
    };
    scene.validate()?;
    Ok(scene)
}

/// A walk from the scene's camera: `keys` keyframes one second apart (at least 2), moving
/// forward (level with the floor) by 12 % of the scene's diagonal while swaying sideways by
/// up to 2 % and turning left and right by up to 8 degrees, one full sway over the walk. The
/// generators' cameras have that much free room ahead of them.
pub fn camera_walk(scene: &Scene, keys: u32) -> Result<CameraPath, String> {
    if keys < 2 {
        return Err(format!("a camera walk needs at least 2 keyframes, not {keys}"));
    }
    let c = scene.camera;
    let diagonal = scene.extent();
    let ahead = Vec3::new(c.forward.x, 0.0, c.forward.z).try_normalize().unwrap_or(Vec3::NEG_Z);
    let side = ahead.cross(Vec3::Y);
    let base = c.rotation();
    let (mut times, mut positions, mut rotations) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..keys {
        let s = i as f32 / (keys - 1) as f32;
        let sway = (std::f32::consts::TAU * s).sin();
        times.push(i as f32);
        positions
            .push(c.position + ahead * (0.12 * diagonal * s) + side * (0.02 * diagonal * sway));
        rotations.push((Quat::from_rotation_y(8f32.to_radians() * sway) * base).normalize());
    }
    Ok(CameraPath {
        parent: Mat4::IDENTITY,
        translation: Track::new(times.clone(), positions, false)?,
        rotation: Track::new(times, rotations, false)?,
        scale: Vec3::ONE,
        yfov: c.yfov,
    })
}

/// The Cornell box with each non-emissive triangle split into n² (n chosen for the budget). An
/// edge's split points are computed from its endpoints in vertex-index order, so the two
/// triangles sharing an edge get bit-identical vertices there: no cracks for shadow rays.
pub fn cornell_fine(triangles: usize) -> Scene {
    let base = crate::cornell::cornell_box();
    let split: Vec<usize> = (0..base.triangle_count())
        .filter(|&t| base.materials[base.material_ids[t] as usize].emission == Vec3::ZERO)
        .collect();
    let kept = base.triangle_count() - split.len();
    let n = (((triangles.saturating_sub(kept)) as f64 / split.len().max(1) as f64).sqrt().round()
        as usize)
        .max(1);
    let mut s = Scene {
        name: "cornell-fine".into(),
        materials: base.materials.clone(),
        camera: base.camera,
        ..Scene::default()
    };
    for t in 0..base.triangle_count() {
        let [a, b, c] = base.indices[t];
        let m = base.material_ids[t];
        let k = if split.contains(&t) { n } else { 1 };
        let vert = |i: u32| (base.positions[i as usize], base.uvs[i as usize]);
        // Point (i, j) of the k-subdivision: weight i/k on b, j/k on c.
        let point = |i: usize, j: usize| -> (Vec3, Vec2) {
            let edge = |u: u32, v: u32, t: usize| {
                // Interpolate from the lower vertex index, whichever triangle asks.
                let (lo, hi, t) = if u < v { (u, v, t) } else { (v, u, k - t) };
                let ((p0, uv0), (p1, uv1)) = (vert(lo), vert(hi));
                let f = t as f32 / k as f32;
                (p0 + (p1 - p0) * f, uv0 + (uv1 - uv0) * f)
            };
            if j == 0 {
                edge(a, b, i)
            } else if i == 0 {
                edge(a, c, j)
            } else if i + j == k {
                edge(b, c, j)
            } else {
                let (fb, fc) = (i as f32 / k as f32, j as f32 / k as f32);
                let ((pa, ua), (pb, ub), (pc, uc)) = (vert(a), vert(b), vert(c));
                (pa + (pb - pa) * fb + (pc - pa) * fc, ua + (ub - ua) * fb + (uc - ua) * fc)
            }
        };
        let normal = base.normals[a as usize];
        let first = s.positions.len() as u32;
        // Row-major grid of the (k+1)(k+2)/2 points: row j holds i = 0 ..= k - j.
        let mut row_start = Vec::with_capacity(k + 1);
        for j in 0..=k {
            row_start.push(s.positions.len() as u32 - first);
            for i in 0..=(k - j) {
                let (p, uv) = point(i, j);
                s.positions.push(p);
                s.normals.push(normal);
                s.uvs.push(uv);
            }
        }
        let at = |i: usize, j: usize| first + row_start[j] + i as u32;
        for j in 0..k {
            for i in 0..(k - j) {
                s.indices.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                s.material_ids.push(m);
                if i + 1 < k - j {
                    s.indices.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                    s.material_ids.push(m);
                }
            }
        }
    }
    s
}

/// Collects geometry with a few shapes.
struct Builder {
    s: Scene,
}

/// The materials of a room's faces.
#[derive(Clone, Copy)]
struct RoomMaterials {
    floor: u32,
    walls: u32,
    ceiling: u32,
}

impl Builder {
    fn new(name: &str) -> Builder {
        Builder { s: Scene { name: name.into(), ..Scene::default() } }
    }

    fn material(&mut self, name: &str, base_color: Vec3, emission: Vec3) -> u32 {
        self.s.materials.push(Material {
            name: name.into(),
            base_color,
            base_color_texture: None,
            emission,
            surface: crate::Surface::Diffuse,
        });
        (self.s.materials.len() - 1) as u32
    }

    /// The parallelogram `o + u s + v t` (s, t in [0, 1]) as an `nu` x `nv` grid of quads, front
    /// side towards `u x v`.
    fn grid(&mut self, o: Vec3, u: Vec3, v: Vec3, nu: usize, nv: usize, material: u32) {
        let (nu, nv) = (nu.max(1), nv.max(1));
        let normal = u.cross(v).normalize();
        let first = self.s.positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                let (fs, ft) = (i as f32 / nu as f32, j as f32 / nv as f32);
                self.s.positions.push(o + u * fs + v * ft);
                self.s.normals.push(normal);
                self.s.uvs.push(Vec2::new(fs, ft));
            }
        }
        let at = |i: usize, j: usize| first + (j * (nu + 1) + i) as u32;
        for j in 0..nv {
            for i in 0..nu {
                self.s.indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                self.s.indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                self.s.material_ids.extend([material, material]);
            }
        }
    }

    /// An axis-aligned box from `lo` to `hi`, fronts outwards, each face an `n` x `n` grid; the
    /// bottom face is left out when `bottom` is false (the box stands on something).
    fn boxed(&mut self, lo: Vec3, hi: Vec3, n: usize, bottom: bool, material: u32) {
        let d = hi - lo;
        let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        self.grid(lo + y, z, x, n, n, material); // top (+y)
        if bottom {
            self.grid(lo, x, z, n, n, material); // bottom (-y)
        }
        self.grid(lo, y, x, n, n, material); // back (-z)
        self.grid(lo + z, x, y, n, n, material); // front (+z)
        self.grid(lo, z, y, n, n, material); // left (-x)
        self.grid(lo + x, y, z, n, n, material); // right (+x)
    }

    /// A vertical cylinder (a thin leg): `segments` side quads and a top cap.
    fn cylinder(&mut self, base: Vec3, radius: f32, height: f32, segments: usize, material: u32) {
        let first = self.s.positions.len() as u32;
        let dir = |k: usize| {
            let a = std::f32::consts::TAU * k as f32 / segments as f32;
            Vec3::new(a.cos(), 0.0, -a.sin())
        };
        for k in 0..=segments {
            for h in [0.0, height] {
                self.s.positions.push(base + dir(k) * radius + Vec3::Y * h);
                self.s.normals.push(dir(k));
                self.s.uvs.push(Vec2::new(k as f32 / segments as f32, h / height));
            }
        }
        for k in 0..segments as u32 {
            let (b0, t0, b1, t1) =
                (first + 2 * k, first + 2 * k + 1, first + 2 * k + 2, first + 2 * k + 3);
            self.s.indices.push([b0, b1, t1]);
            self.s.indices.push([b0, t1, t0]);
            self.s.material_ids.extend([material, material]);
        }
        let centre = self.s.positions.len() as u32;
        self.s.positions.push(base + Vec3::Y * height);
        self.s.normals.push(Vec3::Y);
        self.s.uvs.push(Vec2::ZERO);
        for k in 0..segments as u32 {
            self.s.indices.push([centre, first + 2 * k + 1, first + 2 * k + 3]);
            self.s.material_ids.push(material);
        }
    }

    /// The inside of the room from `lo` to `hi` (all six faces facing in), each face split so
    /// that the room takes about `triangles` triangles.
    fn room(&mut self, lo: Vec3, hi: Vec3, triangles: usize, materials: RoomMaterials) {
        self.room_with_window(lo, hi, triangles, materials, None);
    }

    /// [`Builder::room`], the left wall (x = lo.x) with an open window over the (y, z) rectangle
    /// `window` when given: the wall is then four grids around the opening.
    fn room_with_window(
        &mut self,
        lo: Vec3,
        hi: Vec3,
        triangles: usize,
        materials: RoomMaterials,
        window: Option<(Vec2, Vec2)>,
    ) {
        let RoomMaterials { floor, walls, ceiling } = materials;
        let d = hi - lo;
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        // Square cells of one size everywhere: cells = triangles / 2.
        let cell = (area / (triangles.max(12) as f32 / 2.0)).sqrt();
        let n = |len: f32| ((len / cell).round() as usize).max(1);
        let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        self.grid(lo, z, x, n(d.z), n(d.x), floor); // floor faces +y
        self.grid(lo + y, x, z, n(d.x), n(d.z), ceiling); // ceiling faces -y
        self.grid(lo, x, y, n(d.x), n(d.y), walls); // back wall faces +z
        self.grid(lo + z, y, x, n(d.y), n(d.x), walls); // front wall faces -z
        match window {
            None => self.grid(lo, y, z, n(d.y), n(d.z), walls), // left wall faces +x
            Some((w_lo, w_hi)) => {
                // Below, above, and either side of the opening, each facing +x.
                let at = |yy: f32, zz: f32| Vec3::new(lo.x, yy, zz);
                let (dy_lo, dy_hi, dz_lo, dz_hi) =
                    (w_lo.x - lo.y, hi.y - w_hi.x, w_lo.y - lo.z, hi.z - w_hi.y);
                let wy = w_hi.x - w_lo.x;
                self.grid(at(lo.y, lo.z), Vec3::Y * dy_lo, z, n(dy_lo), n(d.z), walls);
                self.grid(at(w_hi.x, lo.z), Vec3::Y * dy_hi, z, n(dy_hi), n(d.z), walls);
                self.grid(at(w_lo.x, lo.z), Vec3::Y * wy, Vec3::Z * dz_lo, n(wy), n(dz_lo), walls);
                self.grid(
                    at(w_lo.x, w_hi.y),
                    Vec3::Y * wy,
                    Vec3::Z * dz_hi,
                    n(wy),
                    n(dz_hi),
                    walls,
                );
            }
        }
        self.grid(lo + x, z, y, n(d.z), n(d.y), walls); // right wall faces -x
    }
}

/// A meeting room 12 x 3 x 8: three rows of two tables (tops on four thin legs), eight chairs
/// around each table (seat, back, four thin legs), six emissive ceiling panels.
pub fn conference(triangles: usize) -> Scene {
    let mut b = Builder::new("conference");
    let floor = b.material("carpet", Vec3::new(0.35, 0.33, 0.30), Vec3::ZERO);
    let walls = b.material("walls", Vec3::splat(0.75), Vec3::ZERO);
    let ceiling = b.material("ceiling", Vec3::splat(0.8), Vec3::ZERO);
    let wood = b.material("table", Vec3::new(0.55, 0.38, 0.22), Vec3::ZERO);
    let seat = b.material("chair", Vec3::new(0.15, 0.25, 0.55), Vec3::ZERO);
    let metal = b.material("legs", Vec3::splat(0.6), Vec3::ZERO);
    let panel = b.material("ceiling panel", Vec3::splat(0.8), Vec3::splat(12.0));
    let segments = 16;
    for row in [-2.5f32, 0.0, 2.5] {
        for side in [-3.0f32, 3.0] {
            let c = Vec3::new(side, 0.0, row);
            b.boxed(
                c + Vec3::new(-1.2, 0.72, -0.45),
                c + Vec3::new(1.2, 0.76, 0.45),
                2,
                true,
                wood,
            );
            for (lx, lz) in [(-1.1, -0.38), (1.1, -0.38), (-1.1, 0.38), (1.1, 0.38)] {
                b.cylinder(c + Vec3::new(lx, 0.0, lz), 0.025, 0.72, segments, metal);
            }
            for k in 0..4 {
                for dir in [-1.0f32, 1.0] {
                    let s = c + Vec3::new(-0.9 + 0.6 * k as f32, 0.0, dir * 0.75);
                    b.boxed(
                        s + Vec3::new(-0.22, 0.44, -0.22),
                        s + Vec3::new(0.22, 0.48, 0.22),
                        1,
                        true,
                        seat,
                    );
                    let back = s + Vec3::new(0.0, 0.0, dir * 0.2);
                    b.boxed(
                        back + Vec3::new(-0.22, 0.48, -0.02),
                        back + Vec3::new(0.22, 0.95, 0.02),
                        1,
                        true,
                        seat,
                    );
                    for (lx, lz) in [(-0.19, -0.19), (0.19, -0.19), (-0.19, 0.19), (0.19, 0.19)] {
                        b.cylinder(s + Vec3::new(lx, 0.0, lz), 0.015, 0.44, segments, metal);
                    }
                }
            }
        }
    }
    // Ceiling panels, just below the ceiling, facing down (front side -y).
    for x in [-4.0f32, 0.0, 4.0] {
        for z in [-2.0f32, 2.0] {
            b.grid(Vec3::new(x - 0.6, 2.98, z - 0.3), Vec3::X * 1.2, Vec3::Z * 0.6, 1, 1, panel);
        }
    }
    let used = b.s.triangle_count();
    b.room(
        Vec3::new(-6.0, 0.0, -4.0),
        Vec3::new(6.0, 3.0, 4.0),
        triangles.saturating_sub(used),
        RoomMaterials { floor, walls, ceiling },
    );
    b.s.camera = Camera {
        position: Vec3::new(0.0, 1.6, 3.8),
        forward: Vec3::new(0.0, -0.25, -1.0).normalize(),
        up: Vec3::new(0.0, 1.0, -0.25).normalize(),
        yfov: 60f32.to_radians(),
    };
    b.s
}

/// A living room 7 x 2.8 x 6: two sofas (base, seat cushions, back, arms) facing a low table
/// with a glass top (index 1.5, a closed slab), a mirror on the back wall above the sofa, a
/// bright window-like panel in the left wall and a dim lamp panel on the ceiling.
pub fn living_room(triangles: usize) -> Scene {
    furnished_living_room("living-room", triangles, false)
}

/// The direction [`sunlit_living_room`]'s sun travels in: into the room through the left wall's
/// window, 31 degrees down from the horizontal and a little towards the back wall, so its patch
/// lies on the floor in front of the camera.
pub const LIVING_ROOM_SUN: Vec3 = Vec3::new(0.776, -0.517, -0.362);

/// [`living_room`] with the window open (a hole in the left wall, no emissive panel) and the sun
/// shining through it along [`LIVING_ROOM_SUN`] with irradiance (20, 19, 17), about a quarter of
/// what the panel emitted, so its bright patch on the floor lights the room indirectly. The sun's
/// particles and shadow-map texels cover the room's bounding sphere, and only about 4 % of them
/// come in through the window: the rest land on the outside of the walls and roof, where they
/// light nothing the camera sees (give it more `--vpls` or a larger `--rsm-size`).
pub fn sunlit_living_room(triangles: usize) -> Scene {
    furnished_living_room("sunlit-living-room", triangles, true)
}

fn furnished_living_room(name: &str, triangles: usize, sun: bool) -> Scene {
    let mut b = Builder::new(name);
    let floor = b.material("wooden floor", Vec3::new(0.45, 0.32, 0.2), Vec3::ZERO);
    let walls = b.material("walls", Vec3::new(0.8, 0.78, 0.72), Vec3::ZERO);
    let ceiling = b.material("ceiling", Vec3::splat(0.85), Vec3::ZERO);
    let fabric = b.material("sofa", Vec3::new(0.6, 0.2, 0.15), Vec3::ZERO);
    let cushion = b.material("cushions", Vec3::new(0.7, 0.6, 0.45), Vec3::ZERO);
    let wood = b.material("table", Vec3::new(0.3, 0.2, 0.12), Vec3::ZERO);
    let window =
        (!sun).then(|| b.material("window", Vec3::splat(0.9), Vec3::new(20.0, 19.0, 17.0)));
    let lamp = b.material("lamp", Vec3::splat(0.9), Vec3::new(4.0, 3.5, 2.8));
    // The living room's glass table top and wall mirror. The sunlit room keeps a wooden top and
    // no mirror: docs/RSM.md measures its one-bounce shadow-map clusters against references.
    let (top, mirror) = if sun {
        (wood, None)
    } else {
        let glass = b.material("glass table top", Vec3::ONE, Vec3::ZERO);
        b.s.materials[glass as usize].surface = crate::Surface::Dielectric { eta: 1.5 };
        let mirror = b.material("wall mirror", Vec3::splat(0.9), Vec3::ZERO);
        b.s.materials[mirror as usize].surface = crate::Surface::Mirror;
        (glass, Some(mirror))
    };
    // Sofas: against the back wall (facing +z) and the right wall (facing -x).
    let sofa = |b: &mut Builder, lo: Vec3, hi: Vec3, along_x: bool| {
        let n = 4;
        b.boxed(lo, Vec3::new(hi.x, 0.4, hi.z), n, false, fabric);
        let d = hi - lo;
        let seats = 3;
        for k in 0..seats {
            let f0 = k as f32 / seats as f32;
            let f1 = (k + 1) as f32 / seats as f32;
            let (a, c) = if along_x {
                (
                    Vec3::new(lo.x + d.x * f0 + 0.02, 0.4, lo.z + 0.2),
                    Vec3::new(lo.x + d.x * f1 - 0.02, 0.52, hi.z - 0.02),
                )
            } else {
                (
                    Vec3::new(lo.x + 0.02, 0.4, lo.z + d.z * f0 + 0.02),
                    Vec3::new(hi.x - 0.2, 0.52, lo.z + d.z * f1 - 0.02),
                )
            };
            b.boxed(a, c, n, false, cushion);
        }
        if along_x {
            b.boxed(Vec3::new(lo.x, 0.4, lo.z), Vec3::new(hi.x, 0.9, lo.z + 0.2), n, false, fabric);
        } else {
            b.boxed(Vec3::new(hi.x - 0.2, 0.4, lo.z), Vec3::new(hi.x, 0.9, hi.z), n, false, fabric);
        }
    };
    sofa(&mut b, Vec3::new(-1.5, 0.0, -2.95), Vec3::new(1.5, 0.9, -2.05), true);
    sofa(&mut b, Vec3::new(2.55, 0.0, -1.2), Vec3::new(3.45, 0.9, 1.6), false);
    b.boxed(Vec3::new(-0.7, 0.38, -1.3), Vec3::new(0.7, 0.42, -0.5), 2, true, top);
    if let Some(mirror) = mirror {
        // On the back wall above the sofa, facing into the room.
        b.grid(Vec3::new(-1.0, 1.1, -2.99), Vec3::X * 2.0, Vec3::Y * 1.0, 1, 1, mirror);
    }
    for (x, z) in [(-0.62, -1.22), (0.62, -1.22), (-0.62, -0.58), (0.62, -0.58)] {
        b.cylinder(Vec3::new(x, 0.0, z), 0.03, 0.38, 16, wood);
    }
    // The window: in the left wall (x = -3.5), front side facing into the room (+x); or, sunlit,
    // an opening there.
    let opening = (Vec2::new(0.8, -1.5), Vec2::new(2.2, 0.9));
    match window {
        Some(window) => b.grid(
            Vec3::new(-3.49, opening.0.x, opening.0.y),
            Vec3::Y * 1.4,
            Vec3::Z * 2.4,
            1,
            1,
            window,
        ),
        None => b.s.lights.push(PunctualLight::Directional {
            direction: LIVING_ROOM_SUN.normalize(),
            irradiance: Vec3::new(20.0, 19.0, 17.0),
        }),
    }
    b.grid(Vec3::new(-0.3, 2.79, -0.3), Vec3::X * 0.6, Vec3::Z * 0.6, 1, 1, lamp);
    let used = b.s.triangle_count();
    b.room_with_window(
        Vec3::new(-3.5, 0.0, -3.0),
        Vec3::new(3.5, 2.8, 3.0),
        triangles.saturating_sub(used),
        RoomMaterials { floor, walls, ceiling },
        sun.then_some(opening),
    );
    b.s.camera = Camera {
        position: Vec3::new(1.5, 1.5, 2.8),
        forward: Vec3::new(-0.45, -0.3, -1.0).normalize(),
        up: Vec3::Y,
        yfov: 60f32.to_radians(),
    };
    // Keep `up` orthogonal to `forward`.
    let f = b.s.camera.forward;
    b.s.camera.up = (Vec3::Y - f * f.dot(Vec3::Y)).normalize();
    b.s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_generator_meets_its_budget_deterministically() {
        for (name, _, _) in GENERATORS {
            // At least the furniture's own triangles (about 12 k in the conference room).
            for budget in [20_000usize, 60_000] {
                let s = generate(name, budget).unwrap();
                let t = s.triangle_count();
                println!("{name} at a budget of {budget}: {t} triangles");
                assert!(
                    (t as f64) > 0.8 * budget as f64 && (t as f64) < 1.25 * budget as f64,
                    "{name}: {t} triangles for {budget}"
                );
                assert!(
                    s.materials.iter().any(|m| m.emission.max_element() > 0.0),
                    "{name} has no light"
                );
                let again = generate(name, budget).unwrap();
                assert_eq!(s.positions, again.positions, "{name} is not deterministic");
                assert_eq!(s.indices, again.indices);
            }
        }
        assert!(generate("nowhere", 100).unwrap_err().contains("cornell-fine"));
    }

    /// Front faces point into the room: the camera sees the front of whatever it looks at
    /// (one-sided area lights and the shading both depend on it).
    #[test]
    fn room_surfaces_face_inwards() {
        for name in ["conference", "living-room", "sunlit-living-room"] {
            let s = generate(name, 3_000).unwrap();
            let (lo, hi) = s.bounds();
            let centre = (lo + hi) * 0.5;
            for t in 0..s.triangle_count() {
                let [a, b, c] = s.triangle(t);
                let mid = (a + b + c) / 3.0;
                let on_boundary =
                    (0..3).any(|k| (mid[k] - lo[k]).abs() < 1e-4 || (mid[k] - hi[k]).abs() < 1e-4);
                if on_boundary {
                    assert!(
                        s.geometric_normal(t).dot(centre - mid) > 0.0,
                        "{name}: triangle {t} of the room faces outwards"
                    );
                }
            }
        }
    }

    /// Lights shine into the room: ceiling panels down, the window into the room.
    #[test]
    fn lights_face_into_the_room() {
        for name in ["conference", "living-room"] {
            let s = generate(name, 20_000).unwrap();
            let (lo, hi) = s.bounds();
            let centre = (lo + hi) * 0.5;
            let mut lights = 0;
            for t in 0..s.triangle_count() {
                if s.materials[s.material_ids[t] as usize].emission.max_element() > 0.0 {
                    let [a, b, c] = s.triangle(t);
                    assert!(
                        s.geometric_normal(t).dot(centre - (a + b + c) / 3.0) > 0.0,
                        "{name}: light triangle {t} faces away"
                    );
                    lights += 1;
                }
            }
            assert!(lights >= 2, "{name}");
        }
    }

    /// Splitting keeps the Cornell box's surface: every point of the fine box lies on the
    /// original's faces, the area is the same, and shared edges have bit-identical vertices.
    #[test]
    fn cornell_fine_is_the_cornell_box_split() {
        let coarse = crate::cornell::cornell_box();
        let fine = cornell_fine(5_000);
        let area = |s: &Scene| {
            (0..s.triangle_count())
                .map(|t| {
                    let [a, b, c] = s.triangle(t);
                    0.5 * (b - a).cross(c - a).length() as f64
                })
                .sum::<f64>()
        };
        assert!((area(&coarse) - area(&fine)).abs() < 1e-3 * area(&coarse));
        // Vertices on the shared diagonal of the floor quad (from (-1, 0, 1) to (1, 0, -1)) appear
        // in both halves, bitwise equal.
        let on_floor: Vec<Vec3> = fine
            .positions
            .iter()
            .copied()
            .filter(|p| p.y == 0.0 && (p.x + p.z).abs() < 1e-6 && p.x.abs() < 1.0)
            .collect();
        let distinct: std::collections::HashSet<[u32; 3]> =
            on_floor.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
        assert!(distinct.len() > 10);
        assert_eq!(
            on_floor.len(),
            2 * distinct.len(),
            "{} diagonal vertices, {} distinct",
            on_floor.len(),
            distinct.len()
        );
    }

    /// The water of `cornell-water` is a closed mesh whose faces all point out of it: every edge
    /// borders two of its triangles, once in each direction, and its volume by the divergence
    /// theorem (Σ over faces of p · n A / 3) is the room's floor times the waves' mean height.
    #[test]
    fn the_water_is_closed_and_faces_out() {
        let s = generate("cornell-water", 17_000).unwrap();
        let water = s.materials.iter().position(|m| m.name == "water").unwrap() as u32;
        let tris: Vec<[Vec3; 3]> = s
            .indices
            .iter()
            .zip(&s.material_ids)
            .filter(|(_, m)| **m == water)
            .map(|(t, _)| t.map(|i| s.positions[i as usize]))
            .collect();
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut edges = std::collections::HashMap::new();
        for t in &tris {
            for k in 0..3 {
                *edges.entry((key(t[k]), key(t[(k + 1) % 3]))).or_insert(0) += 1;
            }
        }
        for ((a, b), n) in &edges {
            assert_eq!((*n, edges.get(&(*b, *a))), (1, Some(&1)), "edge {a:?} -> {b:?}");
        }
        let volume: f64 = tris
            .iter()
            .map(|t| (t[0].as_dvec3().dot(t[1].as_dvec3().cross(t[2].as_dvec3()))) / 6.0)
            .sum();
        let footprint = (2.0 * 0.98f64).powi(2);
        println!(
            "water: {} triangles, volume {volume:.4}, footprint x depth {:.4}",
            tris.len(),
            footprint * 0.659
        );
        assert!((volume / (footprint * (0.66 - 0.001)) - 1.0).abs() < 0.02, "volume {volume}");
    }

    /// The specular scenes survive their own binary glTF: the loader reads back the surfaces
    /// the writer wrote (α through roughness = √α, within rounding).
    #[test]
    fn specular_scenes_read_back_from_gltf() {
        for name in [
            "cornell-mirror",
            "cornell-glass",
            "cornell-glossy",
            "cornell-water",
            "cornell-mirrors",
        ] {
            let s = generate(name, 2_240).unwrap();
            let bytes = crate::gltf_write::glb(&s).unwrap();
            let back =
                crate::gltf_load::load_slice(std::path::Path::new("specular.glb"), &bytes).unwrap();
            assert_eq!(back.triangle_count(), s.triangle_count(), "{name}");
            let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * a.abs().max(1.0);
            for (a, b) in s.materials.iter().zip(&back.materials) {
                let (ra, rb) = (
                    a.surface.with_colour(a.base_color).record(),
                    b.surface.with_colour(b.base_color).record(),
                );
                assert!(
                    ra.kind == rb.kind
                        && close(ra.alpha, rb.alpha)
                        && close(ra.eta, rb.eta)
                        && close(ra.metallic, rb.metallic),
                    "{name}: {:?} read back as {:?}",
                    a.surface,
                    b.surface
                );
            }
        }
    }
}
