//! Flattening a glTF document's default scene into a world-space [`Scene`].

use super::checks::{check_accessor, INDEX_KINDS, ROTATION_KINDS, SCALAR_F32, UV_KINDS, VEC3_F32};
use super::checks::{check_uri, short_uri};
use super::invalid;
use super::material::{surface, Factors};
use super::texture::linear_texture;
use crate::Surface;
use crate::{Camera, CameraPath, Material, PunctualLight, Scene, SceneError, Track};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use gltf::mesh::Mode;
use std::collections::HashSet;
use std::path::Path;

/// Flattening state: the scene being built and what has been converted so far.
pub(super) struct Loader<'a> {
    path: &'a Path,
    base: &'a Path,
    document: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    scene: Scene,
    /// Scene material index per glTF material, filled on first use.
    material_ids: Vec<Option<u32>>,
    /// Scene index of `Material::default()`, for primitives without a material.
    default_material: Option<u32>,
    /// Scene texture index per glTF image, decoded on first use.
    texture_ids: Vec<Option<u32>>,
    camera: Option<Camera>,
    /// The node of `camera` and its parent's world transform (for the camera's animation).
    camera_node: Option<(usize, Mat4)>,
    /// Descriptions of skipped primitives, for the "no triangles" message.
    skipped: Vec<String>,
    warned: HashSet<String>,
}

impl<'a> Loader<'a> {
    pub(super) fn new(
        path: &'a Path,
        base: &'a Path,
        document: &'a gltf::Document,
        buffers: &'a [gltf::buffer::Data],
        name: String,
    ) -> Loader<'a> {
        Loader {
            path,
            base,
            document,
            buffers,
            scene: Scene { name, ..Scene::default() },
            material_ids: vec![None; document.materials().len()],
            default_material: None,
            texture_ids: vec![None; document.images().len()],
            camera: None,
            camera_node: None,
            skipped: Vec::new(),
            warned: HashSet::new(),
        }
    }
    fn warn(&mut self, message: String) {
        if !self.warned.contains(&message) {
            eprintln!("warning: {}: {message}", self.path.display());
            self.warned.insert(message);
        }
    }

    fn error(&self, message: impl Into<String>) -> SceneError {
        invalid(self.path, message)
    }

    /// Visits the scene's node tree depth-first, children in order, accumulating world
    /// transforms (world = parent * local).
    pub(super) fn traverse(&mut self) -> Result<(), SceneError> {
        let document = self.document;
        let roots: Vec<gltf::Node> =
            match document.default_scene().or_else(|| document.scenes().next()) {
                Some(scene) => scene.nodes().collect(),
                None => {
                    // No scene at all: take every node that is nobody's child.
                    let children: HashSet<usize> = document
                        .nodes()
                        .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                        .collect();
                    document.nodes().filter(|n| !children.contains(&n.index())).collect()
                }
            };
        let mut visited = vec![false; document.nodes().len()];
        let mut stack: Vec<(gltf::Node, Mat4)> =
            roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            // glTF node graphs must be trees; a node reached twice would mean a cycle (endless
            // recursion) or a shared child.
            if std::mem::replace(&mut visited[node.index()], true) {
                self.warn(format!(
                    "node {} is reached more than once (not a tree); later visits ignored",
                    node.index()
                ));
                continue;
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() {
                    self.warn(
                        "skinned meshes are drawn in their bind pose with the node transform"
                            .into(),
                    );
                }
                self.add_mesh(&mesh, &world)?;
            }
            if let Some(light) = node.light() {
                self.add_light(&light, &world);
            }
            if let Some(camera) = node.camera() {
                if self.read_camera(&camera, &world) {
                    self.camera_node = Some((node.index(), parent));
                }
            }
            let children: Vec<gltf::Node> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    fn add_mesh(&mut self, mesh: &gltf::Mesh, world: &Mat4) -> Result<(), SceneError> {
        let linear = Mat3::from_mat4(*world);
        let det = linear.determinant();
        if det == 0.0 || !det.is_finite() {
            self.warn(format!(
                "mesh {} sits under a degenerate (zero-scale) transform; skipped",
                mesh.index()
            ));
            return Ok(());
        }
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns counter-clockwise windings clockwise; swapping two
        // corners keeps the front (and so the emitting side) where the file meant it.
        let flip = det < 0.0;
        for primitive in mesh.primitives() {
            let mode = primitive.mode();
            if mode != Mode::Triangles {
                self.warn(format!(
                    "primitives of mode {mode:?} are not rendered (only triangle lists are)"
                ));
                self.skipped.push(format!(
                    "mesh {} primitive {} ({mode:?})",
                    mesh.index(),
                    primitive.index()
                ));
                continue;
            }
            let material = self.material_id(&primitive.material())?;
            self.add_primitive(&primitive, world, &normal_matrix, flip, material).map_err(|m| {
                self.error(format!("mesh {} primitive {}: {m}", mesh.index(), primitive.index()))
            })?;
        }
        Ok(())
    }

    fn add_primitive(
        &mut self,
        primitive: &gltf::Primitive,
        world: &Mat4,
        normal_matrix: &Mat3,
        flip: bool,
        material: u32,
    ) -> Result<(), String> {
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));

        let position_accessor =
            primitive.get(&gltf::Semantic::Positions).ok_or("no POSITION attribute")?;
        check_accessor(&position_accessor, VEC3_F32).map_err(|m| format!("POSITION: {m}"))?;
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or("POSITION data is unreadable")?
            .map(|p| world.transform_point3(Vec3::from(p)))
            .collect();
        let n = positions.len();
        if n != position_accessor.count() {
            return Err(format!(
                "POSITION has {n} readable elements, expected {}",
                position_accessor.count()
            ));
        }

        let normals: Option<Vec<Vec3>> = match primitive.get(&gltf::Semantic::Normals) {
            Some(accessor) => {
                check_accessor(&accessor, VEC3_F32).map_err(|m| format!("NORMAL: {m}"))?;
                let normals: Vec<Vec3> = reader
                    .read_normals()
                    .ok_or("NORMAL data is unreadable")?
                    // Unusable normals become zero here and are replaced by face normals below.
                    .map(|v| (*normal_matrix * Vec3::from(v)).normalize_or_zero())
                    .collect();
                if normals.len() != n {
                    return Err(format!("{} normals for {n} positions", normals.len()));
                }
                Some(normals)
            }
            None => None,
        };

        let uvs: Vec<Vec2> = match primitive.get(&gltf::Semantic::TexCoords(0)) {
            Some(accessor) => {
                check_accessor(&accessor, UV_KINDS).map_err(|m| format!("TEXCOORD_0: {m}"))?;
                let uvs: Vec<Vec2> = reader
                    .read_tex_coords(0)
                    .ok_or("TEXCOORD_0 data is unreadable")?
                    .into_f32()
                    .map(Vec2::from)
                    .collect();
                if uvs.len() != n {
                    return Err(format!("{} texture coordinates for {n} positions", uvs.len()));
                }
                uvs
            }
            None => vec![Vec2::ZERO; n],
        };

        let corners: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                check_accessor(&accessor, INDEX_KINDS).map_err(|m| format!("indices: {m}"))?;
                let indices: Vec<u32> =
                    reader.read_indices().ok_or("index data is unreadable")?.into_u32().collect();
                if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
                    return Err(format!("index {bad} is out of range for {n} vertices"));
                }
                indices
            }
            None => (0..n as u32).collect(),
        };
        let chunks = corners.chunks_exact(3);
        if !chunks.remainder().is_empty() {
            self.warn(format!(
                "a triangle list has {} indices, not a multiple of 3; the rest is ignored",
                corners.len()
            ));
        }
        let triangles = chunks.map(|t| if flip { [t[0], t[2], t[1]] } else { [t[0], t[1], t[2]] });

        let face_normal = |t: [u32; 3]| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            // The same fallback as `Scene::geometric_normal` for degenerate triangles.
            (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::Z)
        };
        let s = &mut self.scene;
        let first = s.positions.len();
        let added = if normals.is_some() { n } else { corners.len() };
        if first + added > u32::MAX as usize {
            return Err("the scene has more vertices than 32-bit indices can address".into());
        }
        let base = first as u32;
        match normals {
            Some(normals) => {
                s.positions.extend_from_slice(&positions);
                s.normals.extend_from_slice(&normals);
                s.uvs.extend_from_slice(&uvs);
                for t in triangles {
                    let n = face_normal(t);
                    for v in t {
                        let normal = &mut s.normals[first + v as usize];
                        if *normal == Vec3::ZERO {
                            *normal = n;
                        }
                    }
                    s.indices.push(t.map(|v| base + v));
                    s.material_ids.push(material);
                }
            }
            None => {
                // Flat shading: every triangle gets its own three vertices carrying its normal.
                for (k, t) in triangles.enumerate() {
                    let n = face_normal(t);
                    for v in t {
                        s.positions.push(positions[v as usize]);
                        s.normals.push(n);
                        s.uvs.push(uvs[v as usize]);
                    }
                    let v0 = base + 3 * k as u32;
                    s.indices.push([v0, v0 + 1, v0 + 2]);
                    s.material_ids.push(material);
                }
            }
        }
        Ok(())
    }

    /// The scene material for a glTF material, converted on first use.
    fn material_id(&mut self, material: &gltf::Material) -> Result<u32, SceneError> {
        let Some(index) = material.index() else {
            if let Some(id) = self.default_material {
                return Ok(id);
            }
            let id = self.push_material(Material::default());
            self.default_material = Some(id);
            return Ok(id);
        };
        if let Some(Some(id)) = self.material_ids.get(index) {
            return Ok(*id);
        }
        let pbr = material.pbr_metallic_roughness();
        let base_color_texture = match pbr.base_color_texture() {
            Some(info) => {
                if info.texture_transform().is_some() {
                    self.warn(
                        "KHR_texture_transform is ignored (textures are sampled untransformed)"
                            .into(),
                    );
                }
                if info.tex_coord() != 0 {
                    self.warn(format!(
                        "texture coordinate set {} is not read; TEXCOORD_0 is used",
                        info.tex_coord()
                    ));
                }
                Some(self.texture_id(&info.texture().source())?)
            }
            None => None,
        };
        if material.emissive_texture().is_some() {
            self.warn("emissive textures are ignored (the emissive factor is used alone)".into());
        }
        let [r, g, b, _alpha] = pbr.base_color_factor();
        let strength = material.emissive_strength().unwrap_or(1.0);
        let name = material.name().map_or_else(|| format!("material{index}"), str::to_string);
        if pbr.metallic_roughness_texture().is_some() {
            self.warn(format!(
                "material '{name}': its metallic-roughness texture is ignored (the factors are used alone)"
            ));
        }
        let factors = Factors {
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            transmission: material.transmission().map_or(0.0, |t| t.transmission_factor()),
            ior: material.ior().unwrap_or(1.5),
            thickness: material.volume().map(|v| v.thickness_factor()),
        };
        let (surface, warnings) =
            surface(&factors).map_err(|e| self.error(format!("material '{name}': {e}")))?;
        for w in warnings {
            self.warn(format!("material '{name}': {w}"));
        }
        let converted = Material {
            name,
            base_color: Vec3::new(r, g, b),
            base_color_texture,
            emission: Vec3::from(material.emissive_factor()) * strength,
            surface,
        };
        let id = self.push_material(converted);
        if let Some(slot) = self.material_ids.get_mut(index) {
            *slot = Some(id);
        }
        Ok(id)
    }

    fn push_material(&mut self, material: Material) -> u32 {
        self.scene.materials.push(material);
        (self.scene.materials.len() - 1) as u32
    }

    /// The scene texture for a glTF image, decoded to linear RGB on first use.
    fn texture_id(&mut self, image: &gltf::Image) -> Result<u32, SceneError> {
        if let Some(Some(id)) = self.texture_ids.get(image.index()) {
            return Ok(*id);
        }
        let what = match image.source() {
            gltf::image::Source::Uri { uri, .. } => {
                let what = format!("image {} ({})", image.index(), short_uri(uri));
                check_uri(uri).map_err(|m| self.error(format!("{what}: {m}")))?;
                what
            }
            gltf::image::Source::View { .. } => format!("image {}", image.index()),
        };
        let data = gltf::image::Data::from_source(image.source(), Some(self.base), self.buffers)
            .map_err(|e| self.error(format!("cannot decode {what}: {e}")))?;
        let texture = linear_texture(&data).map_err(|m| self.error(format!("{what}: {m}")))?;
        self.scene.textures.push(texture);
        let id = (self.scene.textures.len() - 1) as u32;
        if let Some(slot) = self.texture_ids.get_mut(image.index()) {
            *slot = Some(id);
        }
        Ok(id)
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &Mat4) {
        use gltf::khr_lights_punctual::Kind;
        let position = world.transform_point3(Vec3::ZERO);
        let intensity = Vec3::from(light.color()) * light.intensity();
        match light.kind() {
            Kind::Point => self.scene.lights.push(PunctualLight::Point { position, intensity }),
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                // Spots shine along the node's -Z; scale must not bend or shrink the direction.
                let Some(direction) = world.transform_vector3(-Vec3::Z).try_normalize() else {
                    self.warn(format!(
                        "spot light {} has a degenerate orientation; skipped",
                        light.index()
                    ));
                    return;
                };
                let cos_outer = outer_cone_angle.cos();
                // glTF requires inner < outer; clamp so a sloppy file still gives a valid cone.
                let cos_inner = inner_cone_angle.cos().max(cos_outer);
                self.scene.lights.push(PunctualLight::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                });
            }
            Kind::Directional => {
                // Directional lights shine along the node's -Z too.
                let Some(direction) = world.transform_vector3(-Vec3::Z).try_normalize() else {
                    self.warn(format!(
                        "directional light {} has a degenerate orientation; skipped",
                        light.index()
                    ));
                    return;
                };
                self.scene
                    .lights
                    .push(PunctualLight::Directional { direction, irradiance: intensity });
            }
        }
    }

    /// Keeps the first perspective camera met in traversal order; true if this is it.
    fn read_camera(&mut self, camera: &gltf::Camera, world: &Mat4) -> bool {
        if self.camera.is_some() {
            return false;
        }
        match self.perspective_yfov(camera).map(|yfov| Camera::from_world(world, yfov)) {
            Some(Some(c)) => {
                self.camera = Some(c);
                true
            }
            Some(None) => {
                self.warn(format!(
                    "camera {} has a degenerate transform or field of view; ignored",
                    camera.index()
                ));
                false
            }
            None => false,
        }
    }

    fn perspective_yfov(&mut self, camera: &gltf::Camera) -> Option<f32> {
        // `projection()` unwraps the object named by `type`; the JSON validation does not
        // check that it is the one present.
        use gltf::json::{camera::Type, validation::Checked};
        let json = self.document.as_json().cameras.get(camera.index());
        let perspective = json
            .filter(|c| c.type_ == Checked::Valid(Type::Perspective))
            .and_then(|c| c.perspective.as_ref());
        if perspective.is_none() {
            self.warn(
                "orthographic cameras are not supported; looking for a perspective one".into(),
            );
        }
        perspective.map(|p| p.yfov)
    }

    /// The camera node's translation and rotation channels, from every animation of the file
    /// (a later channel of the same property replaces an earlier one, with a warning). Scale
    /// channels and cubic-spline keys are refused: the first would skew the view, the second
    /// is not implemented.
    fn read_camera_path(&mut self) -> Result<Option<CameraPath>, SceneError> {
        let Some((index, parent)) = self.camera_node else {
            return Ok(None);
        };
        let document = self.document;
        let buffers = self.buffers;
        let node = document.nodes().nth(index).expect("the camera node exists");
        let (t, r, scale) = node.transform().decomposed();
        let (mut translation, mut rotation) = (None, None);
        for animation in document.animations() {
            for (c, channel) in animation.channels().enumerate() {
                if channel.target().node().index() != index {
                    continue;
                }
                let at =
                    format!("animation {} channel {c} (camera node {index})", animation.index());
                use gltf::animation::{Interpolation, Property};
                let step = match channel.sampler().interpolation() {
                    Interpolation::Linear => false,
                    Interpolation::Step => true,
                    Interpolation::CubicSpline => {
                        return Err(self.error(format!(
                            "{at}: cubic-spline keyframes are not supported (use LINEAR or STEP)"
                        )))
                    }
                };
                let property = channel.target().property();
                if property == Property::Scale {
                    return Err(self.error(format!("{at}: an animated camera scale is not supported (only translation and rotation)")));
                }
                if property == Property::MorphTargetWeights {
                    continue;
                }
                check_accessor(&channel.sampler().input(), SCALAR_F32)
                    .map_err(|m| self.error(format!("{at}: key times: {m}")))?;
                let kinds = if property == Property::Rotation { ROTATION_KINDS } else { VEC3_F32 };
                check_accessor(&channel.sampler().output(), kinds)
                    .map_err(|m| self.error(format!("{at}: key values: {m}")))?;
                let reader = channel.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
                let times: Vec<f32> = reader
                    .read_inputs()
                    .ok_or_else(|| self.error(format!("{at}: key times are unreadable")))?
                    .collect();
                use gltf::animation::util::ReadOutputs;
                let bad = |m: String| self.error(format!("{at}: {m}"));
                let replaced = match reader.read_outputs() {
                    Some(ReadOutputs::Translations(v)) => translation
                        .replace(Track::new(times, v.map(Vec3::from).collect(), step).map_err(bad)?)
                        .is_some(),
                    Some(ReadOutputs::Rotations(v)) => rotation
                        .replace(
                            Track::new(times, v.into_f32().map(Quat::from_array).collect(), step)
                                .map_err(bad)?,
                        )
                        .is_some(),
                    _ => return Err(self.error(format!("{at}: key values are unreadable"))),
                };
                if replaced {
                    self.warn(format!("camera node {index} has more than one {property:?} channel; the last one is used"));
                }
            }
        }
        if translation.is_none() && rotation.is_none() {
            return Ok(None);
        }
        let path = CameraPath {
            parent,
            translation: translation.unwrap_or_else(|| Track::constant(Vec3::from(t))),
            rotation: rotation.unwrap_or_else(|| Track::constant(Quat::from_array(r))),
            scale: Vec3::from(scale),
            yfov: self.camera.map_or(0.0, |c| c.yfov),
        };
        // Every frame must be seeable: check the keys themselves.
        let (t0, t1) = path.span();
        if path.at(t0).is_none() || path.at(t1).is_none() {
            return Err(
                self.error(format!("camera node {index}: the animated transform is degenerate"))
            );
        }
        Ok(Some(path))
    }

    pub(super) fn finish(mut self) -> Result<Scene, SceneError> {
        if self.scene.indices.is_empty() {
            let why = if self.skipped.is_empty() {
                String::new()
            } else {
                format!(" (skipped: {})", self.skipped.join(", "))
            };
            return Err(self.error(format!("no triangles: the scene has nothing renderable{why}")));
        }
        for m in 0..self.scene.materials.len() {
            if !matches!(self.scene.materials[m].surface, Surface::Dielectric { .. }) {
                continue;
            }
            let open = self.scene.open_edges(m as u32);
            if let Some([p, q]) = open.first() {
                let name = self.scene.materials[m].name.clone();
                self.warn(format!(
                    "material '{name}' is solid glass (it has KHR_materials_volume) but its mesh is open: {} edges border one triangle or \
                     more than two, one from {p} to {q}; a ray may enter it and never leave. Close the mesh, or drop the volume to make it a thin pane",
                    open.len()
                ));
            }
        }
        self.scene.camera_path = self.read_camera_path()?;
        self.scene.camera = match self.camera {
            Some(camera) => camera,
            None => {
                let (min, max) = self.scene.bounds();
                Camera::framing(min, max)
            }
        };
        Ok(self.scene)
    }
}
