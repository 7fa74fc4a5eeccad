//! Scenes: one flat, world-space triangle soup with per-triangle materials, punctual lights and a
//! camera. Every backend consumes this one representation.
//!
//! * [`cornell`]: the built-in procedural Cornell box (the default scene).
//! * [`generate`]: procedural scenes at the paper's scale (`vplgi scene generate`).
//! * [`gltf_load`]: glTF 2.0 (`.gltf` / `.glb`) loading; [`gltf_write`]: `.glb` writing.
//! * [`mitsuba`]: export for Mitsuba 3 (XML and PLY), for cross-checking references.
//! * [`lights`]: light-selection tables shared by the backends.

pub mod cornell;
pub mod generate;
pub mod glb;
pub mod gltf_load;
pub mod gltf_write;
pub mod lights;
pub mod mitsuba;
pub mod seams;

pub use vplgi_types::camera::{Camera, CameraPath, Track};

use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};
pub use vplgi_shared::bsdf::Surface;

/// A scene ready to render. All geometry is in world space (node transforms applied).
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals (unit length). Flat normals are computed for meshes that have none.
    pub normals: Vec<Vec3>,
    /// Vertex texture coordinates (zero when the mesh has none).
    pub uvs: Vec<Vec2>,
    /// Triangles as three vertex indices, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
    /// Material index per triangle.
    pub material_ids: Vec<u32>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<PunctualLight>,
    pub camera: Camera,
    /// The camera node's animation, if the file has one (`render --frames`); `camera` is its
    /// pose in the file, not necessarily the path's first.
    pub camera_path: Option<CameraPath>,
}

/// A Lambertian material, optionally emissive.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGB base colour factor (alpha ignored).
    pub base_color: Vec3,
    /// Index into [`Scene::textures`], multiplied with `base_color`.
    pub base_color_texture: Option<u32>,
    /// Emitted radiance, linear RGB (glTF `emissiveFactor` times `KHR_materials_emissive_strength`).
    /// Emission leaves the front side of the triangle only.
    pub emission: Vec3,
    /// What it scatters like (glTF's metallic-roughness and transmission); its colour is the
    /// base colour.
    pub surface: Surface,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: Vec3::splat(0.8),
            base_color_texture: None,
            emission: Vec3::ZERO,
            surface: Surface::Diffuse,
        }
    }
}

/// An RGB texture in linear space (sRGB decoded at load time).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major texels, row 0 at the top (v = 0).
    pub texels: Vec<Vec3>,
}

/// The sRGB EOTF (IEC 61966-2-1): encoded value in [0, 1] to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear values of the 256 8-bit sRGB codes. Loaders decode 8-bit images through it, and the
/// GPU backend stores such textures as the codes and decodes them through the same table, so
/// both backends see identical texels at a quarter of the memory.
pub fn srgb8_table() -> [f32; 256] {
    std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0))
}

impl Texture {
    /// Bilinear lookup with repeat wrapping. `uv` follows glTF: (0,0) is the top-left corner.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: i64, j: i64| -> Vec3 {
            let i = i.rem_euclid(w) as usize;
            let j = j.rem_euclid(h) as usize;
            self.texels[j * self.width as usize + i]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = at(x0, y0).lerp(at(x0 + 1, y0), fx);
        let bottom = at(x0, y0 + 1).lerp(at(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

/// `KHR_lights_punctual` lights. `intensity` is radiant intensity (W/sr per channel), i.e. the
/// glTF colour times intensity, read as radiometric units; a directional light's glTF intensity
/// (lux) is read the same way as irradiance (W/m² per channel on a surface facing it).
#[derive(Clone, Debug, PartialEq)]
pub enum PunctualLight {
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        intensity: Vec3,
        /// Cosines of the glTF inner and outer cone angles (`cos_inner >= cos_outer`).
        cos_inner: f32,
        cos_outer: f32,
    },
    /// Light from one direction everywhere (the sun, at infinity). Its particles and its shadow
    /// map start on a disk or square just outside the scene's bounding sphere
    /// (`lights::SunFrame`).
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        irradiance: Vec3,
    },
}

impl PunctualLight {
    /// The glTF spot falloff: 1 inside the inner cone, 0 outside the outer cone, a quadratic
    /// ramp between them. Point lights return 1.
    pub fn falloff(&self, dir_from_light: Vec3) -> f32 {
        match *self {
            PunctualLight::Point { .. } | PunctualLight::Directional { .. } => 1.0,
            PunctualLight::Spot { direction, .. } => {
                self.falloff_cos(direction.dot(dir_from_light))
            }
        }
    }

    /// [`falloff`](Self::falloff) of a direction whose cosine to the spot's axis is `cos_axis`.
    pub fn falloff_cos(&self, cos_axis: f32) -> f32 {
        match *self {
            PunctualLight::Point { .. } | PunctualLight::Directional { .. } => 1.0,
            PunctualLight::Spot { cos_inner, cos_outer, .. } => {
                let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
                let t = ((cos_axis - cos_outer) * scale).clamp(0.0, 1.0);
                t * t
            }
        }
    }

    /// The light turned by `rotation` about `pivot`: positions move, directions turn.
    pub fn turned(&self, rotation: glam::Quat, pivot: Vec3) -> PunctualLight {
        let mut l = self.clone();
        match &mut l {
            PunctualLight::Point { position, .. } => {
                *position = pivot + rotation * (*position - pivot)
            }
            PunctualLight::Spot { position, direction, .. } => {
                *position = pivot + rotation * (*position - pivot);
                *direction = rotation * *direction;
            }
            PunctualLight::Directional { direction, .. } => *direction = rotation * *direction,
        }
        l
    }

    /// Where the light is; `None` for a directional light, which is at infinity.
    pub fn position(&self) -> Option<Vec3> {
        match *self {
            PunctualLight::Point { position, .. } | PunctualLight::Spot { position, .. } => {
                Some(position)
            }
            PunctualLight::Directional { .. } => None,
        }
    }
}

/// Why a scene could not be loaded. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: unsupported: {message}")]
    Unsupported { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

impl Scene {
    /// Loads a `.gltf` or `.glb` file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        gltf_load::load(path)
    }

    /// Loads `.gltf` or `.glb` content already in memory, as if read from `path` (which names
    /// it in errors and against which relative URIs resolve).
    pub fn load_slice(path: &Path, bytes: &[u8]) -> Result<Scene, SceneError> {
        gltf_load::load_slice(path, bytes)
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The three corner positions of triangle `t`.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Axis-aligned bounds of all vertices referenced by triangles, and of the punctual lights.
    /// The scene with its punctual lights turned by `degrees` about the vertical (y) axis through
    /// the centre of its bounds (`vplgi render --light-orbit`).
    pub fn with_lights_turned(&self, degrees: f32) -> Scene {
        let (lo, hi) = self.bounds();
        let turn = glam::Quat::from_rotation_y(degrees.to_radians());
        Scene {
            lights: self.lights.iter().map(|l| l.turned(turn, 0.5 * (lo + hi))).collect(),
            ..self.clone()
        }
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for tri in &self.indices {
            for &v in tri {
                let p = self.positions[v as usize];
                min = min.min(p);
                max = max.max(p);
            }
        }
        for p in self.lights.iter().filter_map(PunctualLight::position) {
            min = min.min(p);
            max = max.max(p);
        }
        if min.x > max.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (min, max)
        }
    }

    /// A 64-bit FNV-1a hash of everything that affects a render (geometry, materials, texels,
    /// lights, camera), as recorded beside reference images: equal hashes, same scene.
    pub fn content_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bits: u32| {
            for b in bits.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        let v3 =
            |v: Vec3, eat: &mut dyn FnMut(u32)| v.to_array().iter().for_each(|x| eat(x.to_bits()));
        for p in self.positions.iter().chain(&self.normals) {
            v3(*p, &mut eat);
        }
        self.uvs.iter().for_each(|t| t.to_array().iter().for_each(|x| eat(x.to_bits())));
        self.indices.iter().flatten().chain(&self.material_ids).for_each(|&i| eat(i));
        for m in &self.materials {
            v3(m.base_color, &mut eat);
            v3(m.emission, &mut eat);
            eat(m.base_color_texture.unwrap_or(u32::MAX));
            // Diffuse surfaces add nothing, so the hashes recorded before surfaces existed hold.
            if m.surface != Surface::Diffuse {
                let r = m.surface.with_colour(Vec3::ZERO).record();
                [r.kind, r.alpha.to_bits(), r.eta.to_bits(), r.metallic.to_bits()]
                    .into_iter()
                    .for_each(&mut eat);
            }
        }
        for t in &self.textures {
            eat(t.width);
            eat(t.height);
            t.texels.iter().for_each(|c| v3(*c, &mut eat));
        }
        for l in &self.lights {
            match l {
                PunctualLight::Point { position, intensity } => {
                    v3(*position, &mut eat);
                    v3(*intensity, &mut eat);
                }
                PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                    v3(*position, &mut eat);
                    v3(*direction, &mut eat);
                    v3(*intensity, &mut eat);
                    eat(cos_inner.to_bits());
                    eat(cos_outer.to_bits());
                }
                PunctualLight::Directional { direction, irradiance } => {
                    v3(*direction, &mut eat);
                    v3(*irradiance, &mut eat);
                }
            }
        }
        let c = self.camera;
        v3(c.position, &mut eat);
        v3(c.forward, &mut eat);
        v3(c.up, &mut eat);
        eat(c.yfov.to_bits());
        h
    }

    /// Length of the bounding-box diagonal: the scene's size for relative parameters.
    pub fn extent(&self) -> f32 {
        let (min, max) = self.bounds();
        (max - min).length()
    }

    /// How far ray end points are pushed off their surfaces, shared by every backend: 1e-4 of
    /// the extent, but never below ~64 ulps of the largest coordinate, so a small scene far from
    /// the origin does not shadow itself.
    pub fn ray_epsilon(&self) -> f32 {
        let (min, max) = self.bounds();
        let far = min.abs().max(max.abs()).max_element();
        (1e-4 * self.extent().max(1e-6)).max(far * 64.0 * f32::EPSILON)
    }

    /// Albedo at barycentrics (`b1`, `b2`) of triangle `t`: base colour times texture.
    pub fn albedo(&self, t: usize, b1: f32, b2: f32) -> Vec3 {
        let m = &self.materials[self.material_ids[t] as usize];
        match m.base_color_texture {
            Some(tex) => {
                let [a, b, c] = self.indices[t];
                let uv = self.uvs[a as usize] * (1.0 - b1 - b2)
                    + self.uvs[b as usize] * b1
                    + self.uvs[c as usize] * b2;
                m.base_color * self.textures[tex as usize].sample(uv)
            }
            None => m.base_color,
        }
    }

    /// Interpolated, normalised shading normal at barycentrics (`b1`, `b2`) of triangle `t`.
    pub fn shading_normal(&self, t: usize, b1: f32, b2: f32) -> Vec3 {
        let [a, b, c] = self.indices[t];
        let n = self.normals[a as usize] * (1.0 - b1 - b2)
            + self.normals[b as usize] * b1
            + self.normals[c as usize] * b2;
        n.try_normalize().unwrap_or_else(|| self.geometric_normal(t))
    }

    /// Unit geometric normal of triangle `t` from its winding (front side).
    pub fn geometric_normal(&self, t: usize) -> Vec3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::Z)
    }

    /// Emitted radiance of triangle `t` (front side).
    pub fn emission(&self, t: usize) -> Vec3 {
        self.materials[self.material_ids[t] as usize].emission
    }

    /// What triangle `t` scatters like.
    pub fn surface(&self, t: usize) -> Surface {
        self.materials[self.material_ids[t] as usize].surface
    }

    /// The edges of material `material`'s triangles that do not border exactly two of them,
    /// corners compared by position, each as its two corners. Solid glass must have none: a ray
    /// could enter through such a mesh and never leave it.
    pub fn open_edges(&self, material: u32) -> Vec<[Vec3; 2]> {
        // A corner by its coordinates' bits; an edge by its two corners, in order.
        type Corner = [u32; 3];
        let key = |v: Vec3| -> Corner { v.to_array().map(f32::to_bits) };
        let mut borders: std::collections::HashMap<(Corner, Corner), (u32, [Vec3; 2])> =
            std::collections::HashMap::new();
        for (t, _) in self.material_ids.iter().enumerate().filter(|(_, m)| **m == material) {
            let [a, b, c] = self.triangle(t);
            for (p, q) in [(a, b), (b, c), (c, a)] {
                let edge = if key(p) <= key(q) { (key(p), key(q)) } else { (key(q), key(p)) };
                borders.entry(edge).or_insert((0, [p, q])).0 += 1;
            }
        }
        let mut open: Vec<_> =
            borders.into_values().filter(|(n, _)| *n != 2).map(|(_, e)| e).collect();
        open.sort_by(|x, y| {
            x[0].to_array().partial_cmp(&y[0].to_array()).unwrap_or(std::cmp::Ordering::Equal)
        });
        open
    }

    /// Whether some triangle is a mirror or glass: a camera ray may then follow a specular chain.
    pub fn has_specular(&self) -> bool {
        self.materials.iter().any(|m| m.surface.is_specular())
    }

    /// Checks internal consistency (index ranges, array lengths, finite values). Loaders call
    /// this so that a broken file is reported instead of crashing a stage.
    pub fn validate(&self) -> Result<(), String> {
        let nv = self.positions.len();
        if self.normals.len() != nv || self.uvs.len() != nv {
            return Err(format!(
                "{} positions but {} normals and {} uvs",
                nv,
                self.normals.len(),
                self.uvs.len()
            ));
        }
        if self.material_ids.len() != self.indices.len() {
            return Err("one material id per triangle is required".into());
        }
        if let Some(t) = self.indices.iter().position(|tri| tri.iter().any(|&i| i as usize >= nv)) {
            return Err(format!("triangle {t} refers to a vertex past the {nv} vertices"));
        }
        if let Some(t) = self.material_ids.iter().position(|&m| m as usize >= self.materials.len())
        {
            return Err(format!("triangle {t} refers to a missing material"));
        }
        if let Some(v) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {v} has a non-finite position"));
        }
        if let Some(v) = self.normals.iter().position(|n| !n.is_finite()) {
            return Err(format!("vertex {v} has a non-finite normal"));
        }
        if let Some(v) = self.uvs.iter().position(|t| !t.is_finite()) {
            return Err(format!("vertex {v} has non-finite texture coordinates"));
        }
        for (i, m) in self.materials.iter().enumerate() {
            if !m.base_color.is_finite()
                || !m.emission.is_finite()
                || m.emission.min_element() < 0.0
            {
                return Err(format!(
                    "material {i} ({}) has a non-finite or negative colour or emission",
                    m.name
                ));
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            match *l {
                PunctualLight::Point { position, intensity }
                | PunctualLight::Spot { position, intensity, .. } => {
                    if !position.is_finite()
                        || !intensity.is_finite()
                        || intensity.min_element() < 0.0
                    {
                        return Err(format!("light {i} has a non-finite position or a non-finite or negative intensity"));
                    }
                }
                PunctualLight::Directional { direction, irradiance } => {
                    if !direction.is_normalized()
                        || !irradiance.is_finite()
                        || irradiance.min_element() < 0.0
                    {
                        return Err(format!("directional light {i} has no direction or a non-finite or negative irradiance"));
                    }
                    if self.indices.is_empty() {
                        return Err(format!(
                            "directional light {i} in a scene without geometry: its light starts on the scene's bounding sphere, and there is none"
                        ));
                    }
                }
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            if let Some(t) = m.base_color_texture {
                if t as usize >= self.textures.len() {
                    return Err(format!("material {i} refers to a missing texture"));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--light-orbit`: a quarter turn about the vertical axis through the bounds' centre moves a
    /// point light around that axis, turns a sun's and a spot's directions the same way (+x to
    /// -z, counter-clockwise seen from above) and keeps everything else.
    #[test]
    fn lights_turn_about_the_vertical_axis_through_the_centre() {
        let mut scene = cornell::cornell_box();
        let (lo, hi) = scene.bounds();
        let c = 0.5 * (lo + hi);
        scene.lights = vec![
            PunctualLight::Point { position: c + Vec3::new(1.0, 0.5, 0.0), intensity: Vec3::ONE },
            PunctualLight::Directional {
                direction: Vec3::new(1.0, -1.0, 0.0).normalize(),
                irradiance: Vec3::ONE,
            },
            PunctualLight::Spot {
                position: c,
                direction: Vec3::X,
                intensity: Vec3::ONE,
                cos_inner: 0.9,
                cos_outer: 0.8,
            },
        ];
        let turned = scene.with_lights_turned(90.0);
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        match (&turned.lights[0], &turned.lights[1], &turned.lights[2]) {
            (
                PunctualLight::Point { position, .. },
                PunctualLight::Directional { direction: d, .. },
                PunctualLight::Spot { position: sp, direction: sd, cos_outer, .. },
            ) => {
                assert!(close(*position, c + Vec3::new(0.0, 0.5, -1.0)), "{position}");
                assert!(close(*d, Vec3::new(0.0, -1.0, -1.0).normalize()), "{d}");
                assert!(close(*sp, c) && close(*sd, Vec3::NEG_Z) && *cos_outer == 0.8);
            }
            other => panic!("light kinds changed: {other:?}"),
        }
        assert_eq!(turned.indices, scene.indices);
        assert_eq!(scene.with_lights_turned(0.0).lights, scene.lights);
    }
}
