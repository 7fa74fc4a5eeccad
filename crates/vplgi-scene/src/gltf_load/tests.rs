use super::texture::linear_texture;
use super::*;
use crate::glb::container as glb;
use crate::{srgb_to_linear, Camera, Material, PunctualLight, Scene};
use glam::{Vec2, Vec3};
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
        self.push(
            "bufferViews",
            json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() }),
        )
    }

    fn accessor(&mut self, bytes: &[u8], component: u32, ty: &str, count: usize) -> usize {
        let view = self.view(bytes);
        self.push(
            "accessors",
            json!({ "bufferView": view, "componentType": component, "type": ty, "count": count }),
        )
    }

    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let a = self.vec3(p);
        let bound = |f: fn(f32, f32) -> f32, init: f32| -> Vec<f32> {
            (0..3).map(|k| p.iter().map(|v| v[k]).fold(init, f)).collect()
        };
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
        write(
            dir,
            &format!("{name}.gltf"),
            self.finished(Some(format!("{name}.bin"))).to_string().as_bytes(),
        )
    }

    fn write_glb(&self, dir: &Path, name: &str) -> PathBuf {
        write(
            dir,
            &format!("{name}.glb"),
            &glb(self.finished(None).to_string().as_bytes(), &self.bin),
        )
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
    assert_eq!(
        s.triangle(4),
        [Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 1.0, 2.0), Vec3::new(0.0, 1.0, 2.0)]
    );
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
    let child = doc.node(
        json!({ "mesh": mesh, "translation": [0.0, 1.0, 0.0], "rotation": [0.0, 0.0, h, h] }),
    );
    let parent = doc.node(
        json!({ "children": [child], "translation": [1.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0] }),
    );
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
        assert!(
            close(s.shading_normal(t, 0.3, 0.3), e),
            "triangle {t}: {}",
            s.shading_normal(t, 0.3, 0.3)
        );
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
fn point_spot_and_directional_lights_follow_their_nodes() {
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
    // The same quarter turn points the sun straight down.
    let sun = doc.node(json!({ "extensions": light(2), "rotation": [-h, 0.0, 0.0, h] }));
    let parent =
        doc.node(json!({ "children": [point, spot, sun], "translation": [0.0, 1.0, 0.0] }));
    doc.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(parent));
    let dir = tempfile::tempdir().unwrap();
    let s = load_ok(&doc.write_embedded(dir.path(), "lights"));
    assert_eq!(s.lights.len(), 3);
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
    // Directional: glTF intensity (lux) read as irradiance, travelling along the node's -z.
    match &s.lights[2] {
        PunctualLight::Directional { direction, irradiance } => {
            assert!(close(*direction, -Vec3::Y), "{direction}");
            assert_eq!(*irradiance, Vec3::splat(3.0));
        }
        other => panic!("expected a directional light, got {other:?}"),
    }
}

#[test]
fn a_directional_light_needs_geometry_to_bound() {
    // A file without triangles is refused before this (nothing renderable); a scene built in
    // code is checked by validate: the sun's light starts on the scene's bounding sphere.
    let mut s = Scene::default();
    s.lights.push(PunctualLight::Directional { direction: -Vec3::Y, irradiance: Vec3::ONE });
    let e = s.validate().unwrap_err();
    assert!(e.contains("directional light 0") && e.contains("without geometry"), "{e}");
    s.lights[0] =
        PunctualLight::Directional { direction: Vec3::new(0.0, -2.0, 0.0), irradiance: Vec3::ONE };
    assert!(s.validate().unwrap_err().contains("no direction"));
}

#[test]
fn reads_the_first_perspective_camera_in_world_space() {
    let mut doc = quad_doc();
    doc.push("cameras", json!({ "type": "orthographic", "orthographic": { "xmag": 1.0, "ymag": 1.0, "zfar": 10.0, "znear": 0.1 } }));
    doc.push(
        "cameras",
        json!({ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }),
    );
    doc.push(
        "cameras",
        json!({ "type": "perspective", "perspective": { "yfov": 1.2, "znear": 0.1 } }),
    );
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let ortho = doc.node(json!({ "camera": 0 }));
    // A quarter turn about +y: the camera's -z looks along -x.
    let camera = doc
        .node(json!({ "camera": 1, "translation": [0.0, 0.0, 5.0], "rotation": [0.0, h, 0.0, h] }));
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

/// The quad with a camera node (under a parent lifted by 1 in y) whose translation goes from
/// z = 5 to z = 3 over seconds 1 to 3 and whose rotation turns a quarter about +y over 0 to 2.
fn animated_camera_doc(interpolation: &str) -> Doc {
    let mut doc = quad_doc();
    doc.push(
        "cameras",
        json!({ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }),
    );
    let camera = doc.node(json!({ "camera": 0, "translation": [0.0, 0.0, 5.0] }));
    let parent = doc.node(json!({ "children": [camera], "translation": [0.0, 1.0, 0.0] }));
    doc.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(parent));
    let t_times = doc.accessor(&f32_bytes(&[1.0, 3.0]), FLOAT, "SCALAR", 2);
    doc.json["accessors"][t_times]["min"] = json!([1.0]);
    doc.json["accessors"][t_times]["max"] = json!([3.0]);
    let t_values = doc.vec3(&[[0.0, 0.0, 5.0], [0.0, 0.0, 3.0]]);
    let r_times = doc.accessor(&f32_bytes(&[0.0, 2.0]), FLOAT, "SCALAR", 2);
    doc.json["accessors"][r_times]["min"] = json!([0.0]);
    doc.json["accessors"][r_times]["max"] = json!([2.0]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let r_values =
        doc.accessor(&f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h]), FLOAT, "VEC4", 2);
    doc.push(
        "animations",
        json!({
            "samplers": [
                { "input": t_times, "output": t_values, "interpolation": interpolation },
                { "input": r_times, "output": r_values, "interpolation": interpolation },
            ],
            "channels": [
                { "sampler": 0, "target": { "node": camera, "path": "translation" } },
                { "sampler": 1, "target": { "node": camera, "path": "rotation" } },
            ],
        }),
    );
    doc
}

/// A camera node's translation and rotation channels become the scene's camera path: sampled
/// over the union of the channels' spans (0 to 3 s), translation held before its first key,
/// rotation slerped, the parent's transform applied.
#[test]
fn reads_the_camera_animation() {
    let dir = tempfile::tempdir().unwrap();
    let s = load_ok(&animated_camera_doc("LINEAR").write_glb(dir.path(), "walk"));
    let path = s.camera_path.expect("the camera path");
    assert_eq!(path.span(), (0.0, 3.0));
    let cams = path.frames(4).unwrap();
    let z: Vec<f32> = cams.iter().map(|c| c.position.z).collect();
    assert_eq!(z, vec![5.0, 5.0, 4.0, 3.0]);
    assert!(cams.iter().all(|c| c.position.y == 1.0 && c.yfov == 0.8));
    // Halfway through the quarter turn (t = 1): an eighth turn, looking between -z and -x.
    let eighth = Vec3::new(-1.0, 0.0, -1.0).normalize();
    assert!(
        close(cams[0].forward, -Vec3::Z)
            && close(cams[1].forward, eighth)
            && close(cams[2].forward, -Vec3::X),
        "{cams:?}"
    );
    let stepped =
        load_ok(&animated_camera_doc("STEP").write_glb(dir.path(), "steps")).camera_path.unwrap();
    assert!(
        close(stepped.frames(4).unwrap()[1].forward, -Vec3::Z),
        "STEP holds the first key until the second"
    );
    assert!(load_ok(&quad_doc().write_glb(dir.path(), "still")).camera_path.is_none());
}

/// Animations a camera path cannot follow are refused, naming the channel and the problem.
#[test]
fn bad_camera_animations_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, edit: &dyn Fn(&mut Doc)| {
        let mut doc = animated_camera_doc("LINEAR");
        edit(&mut doc);
        doc.write_glb(dir.path(), name)
    };
    let cases: Vec<(PathBuf, &str)> = vec![
        (
            write("mismatched", &|d| {
                let three = d.vec3(&[[0.0; 3]; 3]);
                d.json["animations"][0]["samplers"][0]["output"] = json!(three);
            }),
            "2 key times but 3 values",
        ),
        (
            write("cubic", &|d| {
                d.json["animations"][0]["samplers"][0]["interpolation"] = json!("CUBICSPLINE")
            }),
            "cubic-spline",
        ),
        (
            write("scaled", &|d| {
                d.json["animations"][0]["channels"][0]["target"]["path"] = json!("scale")
            }),
            "animated camera scale",
        ),
        (
            write("backwards", &|d| {
                let times = d.accessor(&f32_bytes(&[3.0, 1.0]), FLOAT, "SCALAR", 2);
                d.json["animations"][0]["samplers"][0]["input"] = json!(times);
            }),
            "not increasing",
        ),
    ];
    for (path, expected) in cases {
        let err = load(&path).map(|_| ()).expect_err(expected).to_string();
        assert!(
            err.contains(expected)
                && err.contains(&path.display().to_string())
                && err.contains("animation 0 channel"),
            "{err}"
        );
    }
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
    let mesh = doc.mesh(vec![
        json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "indices": i, "material": 0 }),
    ]);
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
    assert_eq!(
        t.texels,
        vec![Vec3::X, Vec3::new(0.0, green, 0.0), Vec3::new(0.0, 0.0, blue), Vec3::ONE]
    );
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
    doc.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
        json!({ "KHR_texture_transform": { "scale": [2.0, 2.0] } });
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
        (
            data(
                Format::R16G16B16,
                [0u16, 65535, 0].iter().flat_map(|v| v.to_ne_bytes()).collect(),
            ),
            Vec3::Y,
        ),
        (
            data(
                Format::R32G32B32FLOAT,
                [0.25f32, 2.0, 0.0].iter().flat_map(|v| v.to_ne_bytes()).collect(),
            ),
            Vec3::new(0.25, 2.0, 0.0),
        ),
    ];
    for (d, expected) in cases {
        let t = linear_texture(&d).unwrap();
        assert!(close(t.texels[0], expected), "{:?}: {}", d.format, t.texels[0]);
    }
    assert!(linear_texture(&data(Format::R8G8B8, vec![1, 2])).is_err());
    assert!(
        linear_texture(&Data { format: Format::R8, width: 0, height: 0, pixels: vec![] }).is_err()
    );
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
    let mut json =
        doc.finished(Some(format!("data:application/octet-stream;base64,{}", base64(&doc.bin))));
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
        (
            edited(d, "badbuffer", |j| j["bufferViews"][0]["buffer"] = json!(7)),
            "not a valid glTF 2.0",
        ),
        (
            edited(d, "badaccessor", |j| j["meshes"][0]["primitives"][0]["indices"] = json!(99)),
            "not a valid glTF 2.0",
        ),
        (
            edited(d, "hugeposition", |j| {
                j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(1u64 << 31)
            }),
            "POSITION names accessor 2147483648",
        ),
        (
            edited(d, "viewpastend", |j| j["bufferViews"][1]["byteLength"] = json!(4096)),
            "lies outside buffer 0",
        ),
        (
            edited(d, "accessorpastend", |j| j["accessors"][0]["count"] = json!(400)),
            "run past the end",
        ),
        (
            edited(d, "zerocount", |j| j["accessors"][2]["count"] = json!(0)),
            "invalid element count",
        ),
        (
            edited(d, "smallstride", |j| j["bufferViews"][0]["byteStride"] = json!(4)),
            "smaller than",
        ),
        (
            edited(d, "floatindices", |j| j["accessors"][2]["componentType"] = json!(FLOAT)),
            "unsupported element type",
        ),
        (edited(d, "u8normals", |j| j["accessors"][1]["componentType"] = json!(U8)), "NORMAL"),
        (edited(d, "missingbin", |j| j["buffers"][0]["uri"] = json!("nowhere.bin")), "nowhere.bin"),
        (
            edited(d, "badbase64", |j| {
                j["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@")
            }),
            "cannot load buffer 0",
        ),
        (
            edited(d, "shortbuffer", |j| j["buffers"][0]["byteLength"] = json!(100_000)),
            "declares 100000",
        ),
        (edited(d, "percent", |j| j["buffers"][0]["uri"] = json!("%FF%FE.bin")), "percent escapes"),
        (
            edited(d, "required", |j| {
                j["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])
            }),
            "KHR_draco_mesh_compression",
        ),
        (
            edited(d, "spotless", |j| {
                j["extensions"] =
                    json!({ "KHR_lights_punctual": { "lights": [{ "type": "spot" }] } });
                j["nodes"][0]["extensions"] = json!({ "KHR_lights_punctual": { "light": 0 } });
            }),
            "not a valid glTF 2.0",
        ),
        (
            edited(d, "badimage", |j| {
                j["images"] = json!([{ "uri": "data:image/png;base64,AAAA" }]);
                j["textures"] = json!([{ "source": 0 }]);
                j["materials"] =
                    json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
                j["meshes"][0]["primitives"][0]["material"] = json!(0);
            }),
            "cannot decode image 0",
        ),
        (
            edited(d, "imagepercent", |j| {
                j["images"] = json!([{ "uri": "%C3%28.png" }]);
                j["textures"] = json!([{ "source": 0 }]);
                j["materials"] =
                    json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
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

    for (path, expected) in
        cases.iter().map(|(p, e)| (p.clone(), *e)).chain([(out_of_range, "out of range")])
    {
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

/// glTF's metallic-roughness and transmission become the surfaces of the BSDF table: a mirror,
/// solid glass with its index, a thin pane, a rough metal; a material without a
/// `pbrMetallicRoughness` block is a rough metal (glTF's defaults are metallic 1, roughness 1).
/// An invalid factor is an error naming the file and the material. A surface is part of the
/// scene's hash (the committed references' hashes, all diffuse, are checked by the regression
/// tests).
#[test]
fn materials_become_surfaces() {
    use crate::Surface;
    let mut doc = quad_doc();
    for e in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"] {
        doc.use_extension(e);
    }
    let pbr = |metallic: f32, roughness: f32| json!({ "baseColorFactor": [0.9, 0.8, 0.7, 1.0], "metallicFactor": metallic, "roughnessFactor": roughness });
    let materials = [
        json!({ "name": "mirror", "pbrMetallicRoughness": pbr(1.0, 0.0) }),
        json!({ "name": "glass", "pbrMetallicRoughness": pbr(0.0, 0.0), "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_ior": { "ior": 1.33 },
            "KHR_materials_volume": { "thicknessFactor": 0.5 } } }),
        json!({ "name": "pane", "pbrMetallicRoughness": pbr(0.0, 0.0), "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 } } }),
        json!({ "name": "steel", "pbrMetallicRoughness": pbr(1.0, 0.5) }),
        json!({ "name": "plain" }),
        json!({ "name": "paint", "pbrMetallicRoughness": pbr(0.0, 0.9) }),
    ];
    let first = doc.json["meshes"][0]["primitives"][0].clone();
    let mut prims = Vec::new();
    for m in materials {
        let mut p = first.clone();
        p["material"] = json!(doc.push("materials", m));
        prims.push(p);
    }
    doc.json["meshes"][0]["primitives"] = json!(prims);
    let dir = tempfile::tempdir().unwrap();
    let s = load_ok(&doc.write_glb(dir.path(), "surfaces"));
    let surfaces: Vec<Surface> = s.materials.iter().map(|m| m.surface).collect();
    assert_eq!(
        surfaces,
        [
            Surface::Mirror,
            Surface::Dielectric { eta: 1.33 },
            Surface::ThinDielectric { eta: 1.5 },
            Surface::RoughConductor { alpha: 0.25 },
            Surface::RoughConductor { alpha: 1.0 },
            Surface::Diffuse,
        ]
    );
    let mut diffuse = s.clone();
    diffuse.materials.iter_mut().for_each(|m| m.surface = Surface::Diffuse);
    assert_ne!(s.content_hash(), diffuse.content_hash());

    doc.json["materials"][1]["extensions"]["KHR_materials_ior"]["ior"] = json!(-1.0);
    let err = load(&doc.write_glb(dir.path(), "bad-ior")).unwrap_err().to_string();
    assert!(
        err.contains("bad-ior.glb")
            && err.contains("'glass'")
            && err.contains("index of refraction"),
        "{err}"
    );
    doc.json["materials"][1]["extensions"]["KHR_materials_ior"]["ior"] = json!(1.5);
    doc.json["materials"][3]["pbrMetallicRoughness"]["roughnessFactor"] = json!(1.5);
    let err = load(&doc.write_glb(dir.path(), "bad-roughness")).unwrap_err().to_string();
    assert!(err.contains("'steel'") && err.contains("roughnessFactor 1.5"), "{err}");
}
