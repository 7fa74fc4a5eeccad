//! glTF 2.0 (`.gltf` with its buffers and images beside it, or `.glb`) to a flat world-space
//! [`Scene`].
//!
//! What is read: the default (else the first) scene's node tree with its transforms; triangle
//! list primitives; base colour factor and texture (sRGB decoded to linear); emissive factor times
//! `KHR_materials_emissive_strength`; `KHR_lights_punctual` point and spot lights; the first
//! perspective camera. Anything else that would change the picture is skipped with a warning
//! on stderr, printed once per kind and file.
//!
//! A broken file must give a [`SceneError`] naming it, never a crash. The `gltf` crate trusts
//! accessor and buffer-view ranges and types once its JSON validation passed, and asserts or
//! panics on inconsistent ones, so everything it would slice or unwrap is checked here first.

use crate::{srgb_to_linear, Camera, Material, PunctualLight, Scene, SceneError, Texture};
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::collections::HashSet;
use std::path::Path;

/// Extensions that may be listed in `extensionsRequired`. `KHR_texture_transform` is accepted
/// although its transform is ignored (with a warning): the textures still mostly look right.
const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"];

/// Accessors longer than this are rejected as implausible: an accessor without a buffer view
/// (sparse only) would otherwise let a tiny file request gigabytes of zeros.
const MAX_ACCESSOR_COUNT: usize = 1 << 28;

/// Loads a `.gltf` or `.glb` file into a world-space triangle soup.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    // The checks below cover every malformed input known to upset the `gltf` crate; this is
    // the last line of defence for what they miss, so that a bad file still cannot take the
    // whole renderer down.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| load_bytes(path, &bytes)));
    let scene = match result {
        Ok(scene) => scene?,
        Err(payload) => {
            let why = payload.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| payload.downcast_ref::<String>().cloned()).unwrap_or_default();
            return Err(invalid(path, format!("malformed glTF data ({why})")));
        }
    };
    scene.validate().map_err(|message| invalid(path, format!("inconsistent scene: {message}")))?;
    Ok(scene)
}

fn invalid(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Invalid { path: path.to_path_buf(), message: message.into() }
}

fn unsupported(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Unsupported { path: path.to_path_buf(), message: message.into() }
}

fn load_bytes(path: &Path, bytes: &[u8]) -> Result<Scene, SceneError> {
    // Parse without validation first so that an unknown required extension is reported as
    // such, rather than as the crate's terse "extensionsRequired[0]: unsupported".
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| invalid(path, format!("not a readable glTF file: {e}")))?;
    let unknown: Vec<&str> = document.extensions_required().filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e)).collect();
    if !unknown.is_empty() {
        return Err(unsupported(
            path,
            format!("the file requires the glTF extension(s) {} (supported: {})", unknown.join(", "), SUPPORTED_REQUIRED_EXTENSIONS.join(", ")),
        ));
    }
    let document = gltf::Document::from_json(document.into_json()).map_err(|e| invalid(path, format!("not a valid glTF 2.0 document: {e}")))?;

    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, &document, base, blob)?;
    check_views(&document, &buffers).map_err(|m| invalid(path, m))?;

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut loader = Loader {
        path,
        base,
        document: &document,
        buffers: &buffers,
        scene: Scene { name, ..Scene::default() },
        material_ids: vec![None; document.materials().len()],
        default_material: None,
        texture_ids: vec![None; document.images().len()],
        camera: None,
        skipped: Vec::new(),
        warned: HashSet::new(),
    };
    loader.traverse()?;
    loader.finish()
}

/// Reads every buffer, naming the failing one (a missing `.bin` beside the file is the usual
/// cause).
fn load_buffers(path: &Path, document: &gltf::Document, base: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let what = match buffer.source() {
            gltf::buffer::Source::Bin => {
                format!("buffer {} (the GLB binary chunk)", buffer.index())
            }
            gltf::buffer::Source::Uri(uri) => {
                format!("buffer {} ({})", buffer.index(), short_uri(uri))
            }
        };
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            check_uri(uri).map_err(|m| invalid(path, format!("{what}: {m}")))?;
        }
        let data =
            gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob).map_err(|e| invalid(path, format!("cannot load {what}: {e}")))?;
        if data.len() < buffer.length() {
            return Err(invalid(path, format!("{what} has {} bytes but declares {}", data.len(), buffer.length())));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Data URIs can be megabytes long: messages show their start only.
fn short_uri(uri: &str) -> String {
    if uri.starts_with("data:") {
        let head: String = uri.chars().take(40).collect();
        format!("{head}...")
    } else {
        uri.to_string()
    }
}

/// A relative URI must percent-decode to UTF-8: the `gltf` crate unwraps that decoding.
fn check_uri(uri: &str) -> Result<(), String> {
    if uri.contains(':') {
        return Ok(());
    }
    let hex = |b: u8| (b as char).to_digit(16);
    let bytes = uri.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        // Like the crate's decoder: "%" with two hex digits is a byte, anything else literal.
        let escaped = match bytes.get(i..i + 3) {
            Some([b'%', h, l]) => hex(*h).zip(hex(*l)).map(|(h, l)| (h * 16 + l) as u8),
            _ => None,
        };
        match escaped {
            Some(byte) => {
                decoded.push(byte);
                i += 3;
            }
            None => {
                decoded.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8(decoded).map(|_| ()).map_err(|_| "the URI's percent escapes do not decode to UTF-8".into())
}

/// Every buffer view must lie inside its buffer: the `gltf` crate slices without checking.
fn check_views(document: &gltf::Document, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    for view in document.views() {
        let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > len) {
            return Err(format!(
                "buffer view {} (bytes {}..+{}) lies outside buffer {} of {len} bytes",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index()
            ));
        }
    }
    Ok(())
}

/// Checks that reading `accessor` as elements of the allowed kinds cannot fail or panic inside
/// the `gltf` crate: the element kind matches, the count is sane, the stride covers an element
/// and the last element ends inside the buffer view (sparse parts likewise).
fn check_accessor(accessor: &gltf::Accessor, kinds: &[(Dimensions, DataType)]) -> Result<(), String> {
    let what = format!("accessor {}", accessor.index());
    let (dims, ty) = (accessor.dimensions(), accessor.data_type());
    if !kinds.contains(&(dims, ty)) {
        return Err(format!("{what} has an unsupported element type {dims:?} of {ty:?} for its use"));
    }
    let count = accessor.count();
    if count == 0 || count > MAX_ACCESSOR_COUNT {
        return Err(format!("{what} has an invalid element count {count}"));
    }
    let size = accessor.size();
    if let Some(view) = accessor.view() {
        check_range(&what, &view, accessor.offset(), count, size)?;
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!("{what} has an invalid sparse count {n}"));
        }
        let indices = sparse.indices();
        check_range(&what, &indices.view(), indices.offset(), n, indices.index_type().size())?;
        let values = sparse.values();
        check_range(&what, &values.view(), values.offset(), n, size)?;
    }
    Ok(())
}

fn check_range(what: &str, view: &gltf::buffer::View, offset: usize, count: usize, size: usize) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!("{what}: byte stride {stride} is smaller than its {size}-byte elements"));
    }
    let end = stride.checked_mul(count - 1).and_then(|n| n.checked_add(size)).and_then(|n| n.checked_add(offset));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!("{what}: {count} elements run past the end of buffer view {}", view.index()));
    }
    Ok(())
}

const VEC3_F32: &[(Dimensions, DataType)] = &[(Dimensions::Vec3, DataType::F32)];
const UV_KINDS: &[(Dimensions, DataType)] = &[(Dimensions::Vec2, DataType::F32), (Dimensions::Vec2, DataType::U8), (Dimensions::Vec2, DataType::U16)];
const INDEX_KINDS: &[(Dimensions, DataType)] = &[(Dimensions::Scalar, DataType::U8), (Dimensions::Scalar, DataType::U16), (Dimensions::Scalar, DataType::U32)];

/// Flattening state: the scene being built and what has been converted so far.
struct Loader<'a> {
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
    /// Descriptions of skipped primitives, for the "no triangles" message.
    skipped: Vec<String>,
    warned: HashSet<String>,
}

impl Loader<'_> {
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
    fn traverse(&mut self) -> Result<(), SceneError> {
        let document = self.document;
        let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                // No scene at all: take every node that is nobody's child.
                let children: HashSet<usize> = document.nodes().flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>()).collect();
                document.nodes().filter(|n| !children.contains(&n.index())).collect()
            }
        };
        let mut visited = vec![false; document.nodes().len()];
        let mut stack: Vec<(gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            // glTF node graphs must be trees; a node reached twice would mean a cycle (endless
            // recursion) or a shared child.
            if std::mem::replace(&mut visited[node.index()], true) {
                self.warn(format!("node {} is reached more than once (not a tree); later visits ignored", node.index()));
                continue;
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() {
                    self.warn("skinned meshes are drawn in their bind pose with the node transform".into());
                }
                self.add_mesh(&mesh, &world)?;
            }
            if let Some(light) = node.light() {
                self.add_light(&light, &world);
            }
            if let Some(camera) = node.camera() {
                self.read_camera(&camera, &world);
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
            self.warn(format!("mesh {} sits under a degenerate (zero-scale) transform; skipped", mesh.index()));
            return Ok(());
        }
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns counter-clockwise windings clockwise; swapping two
        // corners keeps the front (and so the emitting side) where the file meant it.
        let flip = det < 0.0;
        for primitive in mesh.primitives() {
            let mode = primitive.mode();
            if mode != Mode::Triangles {
                self.warn(format!("primitives of mode {mode:?} are not rendered (only triangle lists are)"));
                self.skipped.push(format!("mesh {} primitive {} ({mode:?})", mesh.index(), primitive.index()));
                continue;
            }
            let material = self.material_id(&primitive.material())?;
            self.add_primitive(&primitive, world, &normal_matrix, flip, material)
                .map_err(|m| self.error(format!("mesh {} primitive {}: {m}", mesh.index(), primitive.index())))?;
        }
        Ok(())
    }

    fn add_primitive(&mut self, primitive: &gltf::Primitive, world: &Mat4, normal_matrix: &Mat3, flip: bool, material: u32) -> Result<(), String> {
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));

        let position_accessor = primitive.get(&gltf::Semantic::Positions).ok_or("no POSITION attribute")?;
        check_accessor(&position_accessor, VEC3_F32).map_err(|m| format!("POSITION: {m}"))?;
        let positions: Vec<Vec3> = reader.read_positions().ok_or("POSITION data is unreadable")?.map(|p| world.transform_point3(Vec3::from(p))).collect();
        let n = positions.len();
        if n != position_accessor.count() {
            return Err(format!("POSITION has {n} readable elements, expected {}", position_accessor.count()));
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
                let uvs: Vec<Vec2> = reader.read_tex_coords(0).ok_or("TEXCOORD_0 data is unreadable")?.into_f32().map(Vec2::from).collect();
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
                let indices: Vec<u32> = reader.read_indices().ok_or("index data is unreadable")?.into_u32().collect();
                if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
                    return Err(format!("index {bad} is out of range for {n} vertices"));
                }
                indices
            }
            None => (0..n as u32).collect(),
        };
        let chunks = corners.chunks_exact(3);
        if !chunks.remainder().is_empty() {
            self.warn(format!("a triangle list has {} indices, not a multiple of 3; the rest is ignored", corners.len()));
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
                    self.warn("KHR_texture_transform is ignored (textures are sampled untransformed)".into());
                }
                if info.tex_coord() != 0 {
                    self.warn(format!("texture coordinate set {} is not read; TEXCOORD_0 is used", info.tex_coord()));
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
        let converted = Material {
            name: material.name().map_or_else(|| format!("material{index}"), str::to_string),
            base_color: Vec3::new(r, g, b),
            base_color_texture,
            emission: Vec3::from(material.emissive_factor()) * strength,
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
        let data =
            gltf::image::Data::from_source(image.source(), Some(self.base), self.buffers).map_err(|e| self.error(format!("cannot decode {what}: {e}")))?;
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
                    self.warn(format!("spot light {} has a degenerate orientation; skipped", light.index()));
                    return;
                };
                let cos_outer = outer_cone_angle.cos();
                // glTF requires inner < outer; clamp so a sloppy file still gives a valid cone.
                let cos_inner = inner_cone_angle.cos().max(cos_outer);
                self.scene.lights.push(PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer });
            }
            Kind::Directional => self.warn("directional lights are not supported; skipped".into()),
        }
    }

    /// Keeps the first perspective camera met in traversal order.
    fn read_camera(&mut self, camera: &gltf::Camera, world: &Mat4) {
        if self.camera.is_some() {
            return;
        }
        // `projection()` unwraps the object named by `type`; the JSON validation does not
        // check that it is the one present.
        use gltf::json::{camera::Type, validation::Checked};
        let json = self.document.as_json().cameras.get(camera.index());
        let perspective = json.filter(|c| c.type_ == Checked::Valid(Type::Perspective)).and_then(|c| c.perspective.as_ref());
        let Some(perspective) = perspective else {
            self.warn("orthographic cameras are not supported; looking for a perspective one".into());
            return;
        };
        let yfov = perspective.yfov;
        let forward = world.transform_vector3(-Vec3::Z).try_normalize();
        let up = world.transform_vector3(Vec3::Y);
        let frame = forward.and_then(|f| Some((f, (up - f * up.dot(f)).try_normalize()?)));
        match frame {
            Some((forward, up)) if yfov > 0.0 && yfov < std::f32::consts::PI => {
                let position = world.transform_point3(Vec3::ZERO);
                self.camera = Some(Camera { position, forward, up, yfov });
            }
            _ => self.warn(format!("camera {} has a degenerate transform or field of view; ignored", camera.index())),
        }
    }

    fn finish(mut self) -> Result<Scene, SceneError> {
        if self.scene.indices.is_empty() {
            let why = if self.skipped.is_empty() { String::new() } else { format!(" (skipped: {})", self.skipped.join(", ")) };
            return Err(self.error(format!("no triangles: the scene has nothing renderable{why}")));
        }
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

/// Decodes an image to linear RGB texels. 8- and 16-bit data is sRGB-encoded (glTF base colour
/// textures always are); float data can only come from formats that store linear values. Grey
/// images spread over all three channels; alpha is dropped.
fn linear_texture(data: &gltf::image::Data) -> Result<Texture, String> {
    use gltf::image::Format;
    let (channels, bytes_per_channel) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (data.width as usize, data.height as usize);
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    let pixel_bytes = channels * bytes_per_channel;
    if w.checked_mul(h).and_then(|n| n.checked_mul(pixel_bytes)) != Some(data.pixels.len()) {
        return Err(format!("{} bytes of pixels for a {w}x{h} {:?} image", data.pixels.len(), data.format));
    }
    // Decoding 8-bit data through a table is exact and avoids millions of powf calls.
    let table = crate::srgb8_table();
    let channel = |c: &[u8]| -> f32 {
        match bytes_per_channel {
            1 => table[c[0] as usize],
            // The image crate hands out 16- and 32-bit samples in native byte order.
            2 => srgb_to_linear(u16::from_ne_bytes([c[0], c[1]]) as f32 / 65535.0),
            _ => f32::from_ne_bytes([c[0], c[1], c[2], c[3]]),
        }
    };
    let texels = data
        .pixels
        .chunks_exact(pixel_bytes)
        .map(|p| {
            let grey = || Vec3::splat(channel(&p[..bytes_per_channel]));
            match channels {
                1 | 2 => grey(),
                _ => Vec3::new(
                    channel(&p[..bytes_per_channel]),
                    channel(&p[bytes_per_channel..2 * bytes_per_channel]),
                    channel(&p[2 * bytes_per_channel..3 * bytes_per_channel]),
                ),
            }
        })
        .collect();
    Ok(Texture { width: data.width, height: data.height, texels })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};
    use std::path::PathBuf;

    const FLOAT: u32 = 5126;
    const U8: u32 = 5121;
    const U16: u32 = 5123;
    const U32: u32 = 5125;

    /// A glTF document under construction, with its single binary buffer.
    struct Doc {
        json: Value,
        bin: Vec<u8>,
    }

    impl Doc {
        fn new() -> Doc {
            Doc { json: json!({ "asset": { "version": "2.0" } }), bin: Vec::new() }
        }

        /// Appends `value` to the top-level array `key`, returning its index.
        fn push(&mut self, key: &str, value: Value) -> usize {
            let array = self.json.as_object_mut().unwrap().entry(key).or_insert_with(|| json!([]));
            let array = array.as_array_mut().unwrap();
            array.push(value);
            array.len() - 1
        }

        fn view(&mut self, bytes: &[u8]) -> usize {
            self.bin.resize(self.bin.len().next_multiple_of(4), 0);
            let offset = self.bin.len();
            self.bin.extend_from_slice(bytes);
            self.push("bufferViews", json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() }))
        }

        fn accessor(&mut self, bytes: &[u8], component: u32, ty: &str, count: usize) -> usize {
            let view = self.view(bytes);
            self.push("accessors", json!({ "bufferView": view, "componentType": component, "type": ty, "count": count }))
        }

        fn positions(&mut self, p: &[[f32; 3]]) -> usize {
            let a = self.vec3(p);
            let bound = |f: fn(f32, f32) -> f32, init: f32| -> Vec<f32> { (0..3).map(|k| p.iter().map(|v| v[k]).fold(init, f)).collect() };
            self.json["accessors"][a]["min"] = json!(bound(f32::min, f32::INFINITY));
            self.json["accessors"][a]["max"] = json!(bound(f32::max, f32::NEG_INFINITY));
            a
        }

        fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
            self.accessor(&f32_bytes(v.as_flattened()), FLOAT, "VEC3", v.len())
        }

        fn vec2(&mut self, v: &[[f32; 2]]) -> usize {
            self.accessor(&f32_bytes(v.as_flattened()), FLOAT, "VEC2", v.len())
        }

        fn indices(&mut self, indices: &[u32], component: u32) -> usize {
            let bytes: Vec<u8> = match component {
                U8 => indices.iter().map(|&i| i as u8).collect(),
                U16 => indices.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect(),
                _ => indices.iter().flat_map(|&i| i.to_le_bytes()).collect(),
            };
            self.accessor(&bytes, component, "SCALAR", indices.len())
        }

        fn mesh(&mut self, primitives: Vec<Value>) -> usize {
            self.push("meshes", json!({ "primitives": primitives }))
        }

        fn node(&mut self, node: Value) -> usize {
            self.push("nodes", node)
        }

        fn scene(&mut self, roots: &[usize]) {
            self.json["scenes"] = json!([{ "nodes": roots }]);
            self.json["scene"] = json!(0);
        }

        fn use_extension(&mut self, name: &str) {
            self.push("extensionsUsed", json!(name));
        }

        /// The JSON with the buffer declared (`uri` absent: the GLB binary chunk).
        fn finished(&self, uri: Option<String>) -> Value {
            let mut json = self.json.clone();
            if !self.bin.is_empty() {
                let mut buffer = json!({ "byteLength": self.bin.len() });
                if let Some(uri) = uri {
                    buffer["uri"] = json!(uri);
                }
                json["buffers"] = json!([buffer]);
            }
            json
        }

        /// A `.gltf` with the buffer embedded as a base64 data URI.
        fn write_embedded(&self, dir: &Path, name: &str) -> PathBuf {
            let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
            write(dir, &format!("{name}.gltf"), self.finished(Some(uri)).to_string().as_bytes())
        }

        /// A `.gltf` with the buffer in a `.bin` file beside it.
        fn write_with_bin(&self, dir: &Path, name: &str) -> PathBuf {
            write(dir, &format!("{name}.bin"), &self.bin);
            write(dir, &format!("{name}.gltf"), self.finished(Some(format!("{name}.bin"))).to_string().as_bytes())
        }

        fn write_glb(&self, dir: &Path, name: &str) -> PathBuf {
            write(dir, &format!("{name}.glb"), &glb(self.finished(None).to_string().as_bytes(), &self.bin))
        }
    }

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn f32_bytes(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn base64(data: &[u8]) -> String {
        const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for chunk in data.chunks(3) {
            let byte = |i: usize| chunk.get(i).copied().unwrap_or(0) as u32;
            let n = byte(0) << 16 | byte(1) << 8 | byte(2);
            for i in 0..4 {
                if i <= chunk.len() {
                    out.push(ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char);
                } else {
                    out.push('=');
                }
            }
        }
        out
    }

    /// Binary glTF: a 12-byte header, then the JSON chunk and the BIN chunk (when not empty),
    /// each padded to 4 bytes.
    fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
        let padded = |data: &[u8], fill: u8| {
            let mut v = data.to_vec();
            v.resize(v.len().next_multiple_of(4), fill);
            v
        };
        let (json, bin) = (padded(json, b' '), padded(bin, 0));
        let mut chunks = Vec::new();
        for (kind, data) in [(0x4E4F_534Au32, &json), (0x004E_4942, &bin)] {
            if !data.is_empty() {
                chunks.extend((data.len() as u32).to_le_bytes());
                chunks.extend(kind.to_le_bytes());
                chunks.extend_from_slice(data);
            }
        }
        let mut out = b"glTF".to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend((12 + chunks.len() as u32).to_le_bytes());
        out.extend(chunks);
        out
    }

    fn png_rgb(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
        let image = image::RgbImage::from_raw(width, height, rgb.to_vec()).unwrap();
        let mut bytes = Vec::new();
        image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
        bytes
    }

    fn load_ok(path: &Path) -> Scene {
        let scene = load(path).unwrap_or_else(|e| panic!("loading failed: {e}"));
        assert_eq!(scene.validate(), Ok(()));
        scene
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    /// The unit square in the z = 0 plane, counter-clockwise seen from +z.
    const QUAD: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    const QUAD_INDICES: [u32; 6] = [0, 1, 2, 0, 2, 3];

    /// A primitive over `positions` with +z normals, indexed when `indices` is given.
    fn primitive(doc: &mut Doc, positions: &[[f32; 3]], indices: Option<(&[u32], u32)>) -> Value {
        let p = doc.positions(positions);
        let n = doc.vec3(&vec![[0.0, 0.0, 1.0]; positions.len()]);
        let mut prim = json!({ "attributes": { "POSITION": p, "NORMAL": n } });
        if let Some((indices, component)) = indices {
            prim["indices"] = json!(doc.indices(indices, component));
        }
        prim
    }

    /// One node holding one mesh of the +z quad: the base of most tests.
    fn quad_doc() -> Doc {
        let mut doc = Doc::new();
        let prim = primitive(&mut doc, &QUAD, Some((&QUAD_INDICES, U16)));
        let mesh = doc.mesh(vec![prim]);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        doc
    }

    #[test]
    fn reads_u8_u16_and_u32_indices() {
        let mut doc = Doc::new();
        let shifted = |dz: f32| QUAD.map(|[x, y, z]| [x, y, z + dz]);
        let prims = vec![
            primitive(&mut doc, &shifted(0.0), Some((&QUAD_INDICES, U16))),
            primitive(&mut doc, &shifted(1.0), Some((&QUAD_INDICES, U8))),
            primitive(&mut doc, &shifted(2.0), Some((&[0, 2, 3], U32))),
        ];
        let mesh = doc.mesh(prims);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_embedded(dir.path(), "indexed"));
        assert_eq!(s.name, "indexed");
        assert_eq!(s.triangle_count(), 5);
        assert_eq!(s.positions.len(), 12);
        assert_eq!(s.triangle(0), [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)]);
        assert_eq!(s.triangle(3), [Vec3::Z, Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]);
        assert_eq!(s.triangle(4), [Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 1.0, 2.0), Vec3::new(0.0, 1.0, 2.0)]);
        for t in 0..5 {
            assert_eq!(s.geometric_normal(t), Vec3::Z);
            assert_eq!(s.shading_normal(t, 0.3, 0.3), Vec3::Z);
        }
        // No material: one default material shared by all primitives.
        assert_eq!(s.materials, vec![Material::default()]);
        assert!(s.material_ids.iter().all(|&m| m == 0));
        assert!(s.uvs.iter().all(|&uv| uv == Vec2::ZERO));
    }

    #[test]
    fn gltf_with_bin_and_glb_give_the_same_scene() {
        let doc = quad_doc();
        let dir = tempfile::tempdir().unwrap();
        let a = load_ok(&doc.write_embedded(dir.path(), "a"));
        let b = load_ok(&doc.write_with_bin(dir.path(), "b"));
        let c = load_ok(&doc.write_glb(dir.path(), "c"));
        for s in [&b, &c] {
            assert_eq!((&s.positions, &s.normals, &s.indices), (&a.positions, &a.normals, &a.indices));
        }
        assert_eq!((a.name.as_str(), b.name.as_str(), c.name.as_str()), ("a", "b", "c"));
    }

    #[test]
    fn reads_non_indexed_triangles() {
        let mut doc = Doc::new();
        let soup: Vec<[f32; 3]> = QUAD_INDICES.iter().map(|&i| QUAD[i as usize]).collect();
        let prim = primitive(&mut doc, &soup, None);
        let mesh = doc.mesh(vec![prim]);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_glb(dir.path(), "soup"));
        assert_eq!(s.indices, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(s.triangle(1), [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
    }

    #[test]
    fn missing_normals_become_flat_normals_following_the_winding() {
        let mut doc = Doc::new();
        let p = doc.positions(&QUAD);
        // The second triangle is wound clockwise seen from +z: its front faces -z.
        let i = doc.indices(&[0, 1, 2, 0, 3, 2], U16);
        let mesh = doc.mesh(vec![json!({ "attributes": { "POSITION": p }, "indices": i })]);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_embedded(dir.path(), "flat"));
        // Vertices are duplicated so that each triangle carries its own normal.
        assert_eq!(s.positions.len(), 6);
        assert_eq!(s.indices, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(s.normals[..3], [Vec3::Z; 3]);
        assert_eq!(s.normals[3..], [-Vec3::Z; 3]);
        assert_eq!((s.geometric_normal(0), s.geometric_normal(1)), (Vec3::Z, -Vec3::Z));
    }

    #[test]
    fn node_transforms_compose_down_the_hierarchy() {
        let mut doc = Doc::new();
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let prim = primitive(&mut doc, &tri, None);
        let mesh = doc.mesh(vec![prim]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        // Child: a quarter turn about z, then up by 1. Parent: scale 2, then right by 1.
        let child = doc.node(json!({ "mesh": mesh, "translation": [0.0, 1.0, 0.0], "rotation": [0.0, 0.0, h, h] }));
        let parent = doc.node(json!({ "children": [child], "translation": [1.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0] }));
        doc.scene(&[parent]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_embedded(dir.path(), "hierarchy"));
        let [a, b, c] = s.triangle(0);
        assert!(close(a, Vec3::new(1.0, 2.0, 0.0)), "{a}");
        assert!(close(b, Vec3::new(1.0, 4.0, 0.0)), "{b}");
        assert!(close(c, Vec3::new(-1.0, 2.0, 0.0)), "{c}");
        assert!(s.normals.iter().all(|&n| close(n, Vec3::Z)));
    }

    #[test]
    fn non_uniform_scale_keeps_normals_perpendicular() {
        let mut doc = Doc::new();
        // A slanted triangle with its true normal, stretched along y.
        let p = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]);
        let n = Vec3::new(0.0, -1.0, 1.0).normalize().to_array();
        let n = doc.vec3(&[n; 3]);
        let mesh = doc.mesh(vec![json!({ "attributes": { "POSITION": p, "NORMAL": n } })]);
        let node = doc.node(json!({ "mesh": mesh, "scale": [1.0, 3.0, 1.0] }));
        doc.scene(&[node]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_glb(dir.path(), "stretched"));
        let expected = Vec3::new(0.0, -1.0, 3.0).normalize();
        assert!(close(s.geometric_normal(0), expected));
        assert!(close(s.shading_normal(0, 0.2, 0.2), expected));
    }

    #[test]
    fn mirroring_keeps_fronts_consistent() {
        let mut doc = Doc::new();
        // One triangle facing +z and one facing +x, both with matching normals.
        let p = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let n = doc.vec3(&[[0.0, 0.0, 1.0]; 3]);
        let facing_z = json!({ "attributes": { "POSITION": p, "NORMAL": n } });
        let p = doc.positions(&[[0.5, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, 0.0, 1.0]]);
        let n = doc.vec3(&[[1.0, 0.0, 0.0]; 3]);
        let facing_x = json!({ "attributes": { "POSITION": p, "NORMAL": n } });
        // The same triangles without normals, so flat normals come from the flipped winding.
        let p = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let flat_z = json!({ "attributes": { "POSITION": p } });
        let mesh = doc.mesh(vec![facing_z, facing_x, flat_z]);
        let mirrored = doc.node(json!({ "mesh": mesh, "scale": [-1.0, 1.0, 1.0] }));
        // Two mirrors make a rotation: no flip at all.
        let inner = doc.node(json!({ "mesh": mesh, "scale": [1.0, -1.0, 1.0] }));
        let outer = doc.node(json!({ "children": [inner], "scale": [-1.0, 1.0, 1.0] }));
        doc.scene(&[mirrored, outer]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_embedded(dir.path(), "mirror"));
        assert_eq!(s.triangle_count(), 6);
        let expected = [Vec3::Z, -Vec3::X, Vec3::Z, Vec3::Z, -Vec3::X, Vec3::Z];
        for (t, &e) in expected.iter().enumerate() {
            assert!(close(s.geometric_normal(t), e), "triangle {t}: {}", s.geometric_normal(t));
            assert!(close(s.shading_normal(t, 0.3, 0.3), e), "triangle {t}: {}", s.shading_normal(t, 0.3, 0.3));
        }
        // The mirrored +x triangle now sits at x = -0.5.
        assert!(s.triangle(1).iter().all(|p| (p.x + 0.5).abs() < 1e-6));
    }

    #[test]
    fn emissive_strength_multiplies_the_emissive_factor() {
        let mut doc = quad_doc();
        doc.use_extension("KHR_materials_emissive_strength");
        let strong = doc.push(
            "materials",
            json!({
                "name": "lamp",
                "emissiveFactor": [1.0, 0.5, 0.25],
                "pbrMetallicRoughness": { "baseColorFactor": [0.2, 0.3, 0.4, 0.5] },
                "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": 4.0 } }
            }),
        );
        let plain = doc.push("materials", json!({ "emissiveFactor": [0.5, 0.5, 0.5] }));
        let first = doc.json["meshes"][0]["primitives"][0].clone();
        let mut second = first.clone();
        let mut third = first.clone();
        doc.json["meshes"][0]["primitives"][0]["material"] = json!(strong);
        second["material"] = json!(plain);
        third["material"] = json!(strong);
        doc.json["meshes"][0]["primitives"].as_array_mut().unwrap().extend([second, third]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_glb(dir.path(), "emissive"));
        assert_eq!(s.triangle_count(), 6);
        // Materials are converted once each, in order of first use.
        assert_eq!(s.materials.len(), 2);
        assert_eq!(s.material_ids, vec![0, 0, 1, 1, 0, 0]);
        let lamp = &s.materials[0];
        assert_eq!((lamp.name.as_str(), lamp.emission), ("lamp", Vec3::new(4.0, 2.0, 1.0)));
        assert_eq!(lamp.base_color, Vec3::new(0.2, 0.3, 0.4));
        assert_eq!(s.materials[1].emission, Vec3::splat(0.5));
        assert_eq!(s.materials[1].base_color, Vec3::ONE);
        assert_eq!(s.emission(0), Vec3::new(4.0, 2.0, 1.0));
    }

    #[test]
    fn point_and_spot_lights_follow_their_nodes() {
        let mut doc = quad_doc();
        doc.use_extension("KHR_lights_punctual");
        doc.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
            { "type": "point", "color": [1.0, 0.5, 0.5], "intensity": 10.0 },
            { "type": "spot", "intensity": 2.0, "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } },
            { "type": "directional", "intensity": 3.0 }
        ] } });
        let light = |i: usize| json!({ "KHR_lights_punctual": { "light": i } });
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let point = doc.node(json!({ "extensions": light(0), "translation": [1.0, 2.0, 3.0] }));
        // A quarter turn about -x points the spot's -z axis straight down.
        let spot = doc.node(json!({ "extensions": light(1), "translation": [0.0, 2.0, 0.0], "rotation": [-h, 0.0, 0.0, h] }));
        let sun = doc.node(json!({ "extensions": light(2) }));
        let parent = doc.node(json!({ "children": [point, spot, sun], "translation": [0.0, 1.0, 0.0] }));
        doc.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(parent));
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_embedded(dir.path(), "lights"));
        // The directional light is skipped.
        assert_eq!(s.lights.len(), 2);
        match &s.lights[0] {
            PunctualLight::Point { position, intensity } => {
                assert!(close(*position, Vec3::new(1.0, 3.0, 3.0)));
                assert_eq!(*intensity, Vec3::new(10.0, 5.0, 5.0));
            }
            other => panic!("expected a point light, got {other:?}"),
        }
        match &s.lights[1] {
            PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                assert!(close(*position, Vec3::new(0.0, 3.0, 0.0)));
                assert!(close(*direction, -Vec3::Y), "{direction}");
                assert_eq!(*intensity, Vec3::splat(2.0));
                assert_eq!((*cos_inner, *cos_outer), (0.2f32.cos(), 0.5f32.cos()));
            }
            other => panic!("expected a spot light, got {other:?}"),
        }
    }

    #[test]
    fn reads_the_first_perspective_camera_in_world_space() {
        let mut doc = quad_doc();
        doc.push("cameras", json!({ "type": "orthographic", "orthographic": { "xmag": 1.0, "ymag": 1.0, "zfar": 10.0, "znear": 0.1 } }));
        doc.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }));
        doc.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 1.2, "znear": 0.1 } }));
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let ortho = doc.node(json!({ "camera": 0 }));
        // A quarter turn about +y: the camera's -z looks along -x.
        let camera = doc.node(json!({ "camera": 1, "translation": [0.0, 0.0, 5.0], "rotation": [0.0, h, 0.0, h] }));
        let parent = doc.node(json!({ "children": [ortho, camera], "translation": [0.0, 1.0, 0.0] }));
        let later = doc.node(json!({ "camera": 2 }));
        doc.json["scenes"][0]["nodes"].as_array_mut().unwrap().extend([json!(parent), json!(later)]);
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&doc.write_glb(dir.path(), "camera"));
        let c = s.camera;
        assert!(close(c.position, Vec3::new(0.0, 1.0, 5.0)), "{}", c.position);
        assert!(close(c.forward, -Vec3::X), "{}", c.forward);
        assert!(close(c.up, Vec3::Y), "{}", c.up);
        assert_eq!(c.yfov, 0.8);
    }

    #[test]
    fn without_a_camera_the_scene_is_framed() {
        let dir = tempfile::tempdir().unwrap();
        let s = load_ok(&quad_doc().write_embedded(dir.path(), "nocam"));
        assert_eq!(s.camera, Camera::framing(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
    }

    /// A 2x2 texture (red, mid green / dark blue, white) on the quad, with a base colour factor.
    fn textured_doc(image: Value) -> Doc {
        let mut doc = Doc::new();
        let p = doc.positions(&QUAD);
        let uv = doc.vec2(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let i = doc.indices(&QUAD_INDICES, U8);
        let mesh = doc.mesh(vec![json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "indices": i, "material": 0 })]);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        doc.push("images", image);
        doc.push("textures", json!({ "source": 0 }));
        doc.push("materials", json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "baseColorFactor": [0.5, 1.0, 1.0, 1.0] } }));
        doc
    }

    const TEXELS: [u8; 12] = [255, 0, 0, 0, 128, 0, 0, 0, 64, 255, 255, 255];

    fn check_texture(s: &Scene) {
        let (green, blue) = (srgb_to_linear(128.0 / 255.0), srgb_to_linear(64.0 / 255.0));
        assert!((green - 0.215_860_5).abs() < 1e-6, "{green}");
        assert_eq!(s.textures.len(), 1);
        let t = &s.textures[0];
        assert_eq!((t.width, t.height), (2, 2));
        assert_eq!(t.texels, vec![Vec3::X, Vec3::new(0.0, green, 0.0), Vec3::new(0.0, 0.0, blue), Vec3::ONE]);
        // Texel centres of the top row, (0.25, 0.25) and (0.75, 0.25), through triangle 0's
        // uvs (0,0), (1,0), (1,1): the factor multiplies the decoded texel.
        assert!(close(s.albedo(0, 0.0, 0.25), Vec3::new(0.5, 0.0, 0.0)));
        assert!(close(s.albedo(0, 0.5, 0.25), Vec3::new(0.0, green, 0.0)));
    }

    #[test]
    fn texture_beside_the_gltf_is_decoded_to_linear() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "tex.png", &png_rgb(2, 2, &TEXELS));
        let doc = textured_doc(json!({ "uri": "tex.png" }));
        check_texture(&load_ok(&doc.write_with_bin(dir.path(), "textured")));
    }

    #[test]
    fn texture_embedded_in_a_glb_is_decoded_to_linear() {
        let mut doc = textured_doc(json!(null));
        let view = doc.view(&png_rgb(2, 2, &TEXELS));
        doc.json["images"][0] = json!({ "bufferView": view, "mimeType": "image/png" });
        let dir = tempfile::tempdir().unwrap();
        check_texture(&load_ok(&doc.write_glb(dir.path(), "textured")));
    }

    #[test]
    fn texture_transform_is_tolerated() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "tex.png", &png_rgb(2, 2, &TEXELS));
        let mut doc = textured_doc(json!({ "uri": "tex.png" }));
        doc.use_extension("KHR_texture_transform");
        doc.json["extensionsRequired"] = json!(["KHR_texture_transform"]);
        doc.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = json!({ "KHR_texture_transform": { "scale": [2.0, 2.0] } });
        check_texture(&load_ok(&doc.write_embedded(dir.path(), "transformed")));
    }

    #[test]
    fn decodes_every_pixel_format() {
        use gltf::image::{Data, Format};
        let data = |format, pixels: Vec<u8>| Data { format, width: 1, height: 1, pixels };
        let half = srgb_to_linear(128.0 / 255.0);
        let cases = [
            (data(Format::R8, vec![128]), Vec3::splat(half)),
            (data(Format::R8G8, vec![255, 7]), Vec3::ONE),
            (data(Format::R8G8B8A8, vec![0, 255, 128, 0]), Vec3::new(0.0, 1.0, half)),
            (data(Format::R16, 65535u16.to_ne_bytes().to_vec()), Vec3::ONE),
            (data(Format::R16G16B16, [0u16, 65535, 0].iter().flat_map(|v| v.to_ne_bytes()).collect()), Vec3::Y),
            (data(Format::R32G32B32FLOAT, [0.25f32, 2.0, 0.0].iter().flat_map(|v| v.to_ne_bytes()).collect()), Vec3::new(0.25, 2.0, 0.0)),
        ];
        for (d, expected) in cases {
            let t = linear_texture(&d).unwrap();
            assert!(close(t.texels[0], expected), "{:?}: {}", d.format, t.texels[0]);
        }
        assert!(linear_texture(&data(Format::R8G8B8, vec![1, 2])).is_err());
        assert!(linear_texture(&Data { format: Format::R8, width: 0, height: 0, pixels: vec![] }).is_err());
        // The EOTF is continuous at its knee and exact at both ends.
        assert!((srgb_to_linear(0.04045) - 0.04045 / 12.92).abs() < 1e-6);
        assert_eq!((srgb_to_linear(0.0), srgb_to_linear(1.0)), (0.0, 1.0));
    }

    #[test]
    fn skips_non_triangle_primitives() {
        let mut doc = quad_doc();
        let lines = doc.json["meshes"][0]["primitives"][0].clone();
        let mut lines = lines;
        lines["mode"] = json!(1);
        doc.json["meshes"][0]["primitives"].as_array_mut().unwrap().push(lines);
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(load_ok(&doc.write_embedded(dir.path(), "mixed")).triangle_count(), 2);
    }

    /// Writes the quad document, buffer embedded, after `edit` changed its JSON.
    fn edited(dir: &Path, name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
        let doc = quad_doc();
        let mut json = doc.finished(Some(format!("data:application/octet-stream;base64,{}", base64(&doc.bin))));
        edit(&mut json);
        write(dir, &format!("{name}.gltf"), json.to_string().as_bytes())
    }

    #[test]
    fn broken_files_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let valid = std::fs::read(edited(d, "valid", |_| ())).unwrap();
        let glb_bytes = std::fs::read(quad_doc().write_glb(d, "good")).unwrap();
        let mut no_bin = quad_doc();
        let glb_without_bin = glb(no_bin.finished(None).to_string().as_bytes(), &[]);
        no_bin.bin.clear();
        let mut points = quad_doc();
        points.json["meshes"][0]["primitives"][0]["mode"] = json!(0);

        let cases: Vec<(PathBuf, &str)> = vec![
            (write(d, "garbage.gltf", &[0xde, 0xad, 0xbe, 0xef, 0x00, 0xff]), "not a readable glTF"),
            (write(d, "empty.glb", &[]), "not a readable glTF"),
            (write(d, "truncated.gltf", &valid[..valid.len() / 2]), "not a readable glTF"),
            (write(d, "truncated.glb", &glb_bytes[..glb_bytes.len() - 20]), "not a readable glTF"),
            (write(d, "nobin.glb", &glb_without_bin), "cannot load buffer 0"),
            (write(d, "nothing.gltf", br#"{"asset":{"version":"2.0"}}"#), "no triangles"),
            (points.write_embedded(d, "points"), "no triangles"),
            (edited(d, "badbuffer", |j| j["bufferViews"][0]["buffer"] = json!(7)), "not a valid glTF 2.0"),
            (edited(d, "badaccessor", |j| j["meshes"][0]["primitives"][0]["indices"] = json!(99)), "not a valid glTF 2.0"),
            (edited(d, "viewpastend", |j| j["bufferViews"][1]["byteLength"] = json!(4096)), "lies outside buffer 0"),
            (edited(d, "accessorpastend", |j| j["accessors"][0]["count"] = json!(400)), "run past the end"),
            (edited(d, "zerocount", |j| j["accessors"][2]["count"] = json!(0)), "invalid element count"),
            (edited(d, "smallstride", |j| j["bufferViews"][0]["byteStride"] = json!(4)), "smaller than"),
            (edited(d, "floatindices", |j| j["accessors"][2]["componentType"] = json!(FLOAT)), "unsupported element type"),
            (edited(d, "u8normals", |j| j["accessors"][1]["componentType"] = json!(U8)), "NORMAL"),
            (edited(d, "missingbin", |j| j["buffers"][0]["uri"] = json!("nowhere.bin")), "nowhere.bin"),
            (edited(d, "badbase64", |j| j["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@")), "cannot load buffer 0"),
            (edited(d, "shortbuffer", |j| j["buffers"][0]["byteLength"] = json!(100_000)), "declares 100000"),
            (edited(d, "percent", |j| j["buffers"][0]["uri"] = json!("%FF%FE.bin")), "percent escapes"),
            (edited(d, "required", |j| j["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])), "KHR_draco_mesh_compression"),
            (
                edited(d, "spotless", |j| {
                    j["extensions"] = json!({ "KHR_lights_punctual": { "lights": [{ "type": "spot" }] } });
                    j["nodes"][0]["extensions"] = json!({ "KHR_lights_punctual": { "light": 0 } });
                }),
                "not a valid glTF 2.0",
            ),
            (
                edited(d, "badimage", |j| {
                    j["images"] = json!([{ "uri": "data:image/png;base64,AAAA" }]);
                    j["textures"] = json!([{ "source": 0 }]);
                    j["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
                    j["meshes"][0]["primitives"][0]["material"] = json!(0);
                }),
                "cannot decode image 0",
            ),
            (
                edited(d, "imagepercent", |j| {
                    j["images"] = json!([{ "uri": "%C3%28.png" }]);
                    j["textures"] = json!([{ "source": 0 }]);
                    j["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
                    j["meshes"][0]["primitives"][0]["material"] = json!(0);
                }),
                "percent escapes",
            ),
        ];
        // Keep the index-out-of-range case apart: it needs different index data.
        let mut doc = Doc::new();
        let prim = primitive(&mut doc, &QUAD, Some((&[0, 1, 9], U16)));
        let mesh = doc.mesh(vec![prim]);
        let node = doc.node(json!({ "mesh": mesh }));
        doc.scene(&[node]);
        let out_of_range = doc.write_glb(d, "outofrange");

        for (path, expected) in cases.iter().map(|(p, e)| (p.clone(), *e)).chain([(out_of_range, "out of range")]) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let message = match load(&path) {
                Ok(_) => panic!("{name} loaded"),
                Err(e) => e.to_string(),
            };
            assert!(message.contains(&name), "{name}: message does not name the file: {message}");
            assert!(message.contains(expected), "{name}: expected '{expected}' in: {message}");
        }

        match load(&d.join("missing.gltf")) {
            Err(e @ SceneError::Io { .. }) => assert!(e.to_string().contains("missing.gltf")),
            other => panic!("expected an I/O error, got {other:?}"),
        }
        match load(&d.join("required.gltf")) {
            Err(SceneError::Unsupported { message, .. }) => assert!(message.contains("requires")),
            other => panic!("expected an unsupported-extension error, got {other:?}"),
        }
    }

    #[test]
    fn tolerates_odd_but_harmless_input() {
        let dir = tempfile::tempdir().unwrap();
        // A camera whose type names the projection it lacks, a node reached twice and a
        // zero-scale node: warnings, not errors.
        let path = edited(dir.path(), "odd", |j| {
            j["cameras"] = json!([{ "type": "perspective", "orthographic": { "xmag": 1.0, "ymag": 1.0, "zfar": 10.0, "znear": 0.1 } }]);
            j["nodes"].as_array_mut().unwrap().push(json!({ "camera": 0, "children": [0] }));
            j["nodes"].as_array_mut().unwrap().push(json!({ "mesh": 0, "scale": [0.0, 1.0, 1.0] }));
            j["scenes"][0]["nodes"] = json!([0, 1, 2]);
        });
        let s = load_ok(&path);
        assert_eq!(s.triangle_count(), 2);
        assert_eq!(s.camera, Camera::framing(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
    }
}
