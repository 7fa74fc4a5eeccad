//! Writing a scene as binary glTF 2.0 (`.glb`), for the procedural scenes: one mesh with one
//! primitive per material (all sharing one vertex buffer of positions, normals and texture
//! coordinates, u32 indices), Lambertian materials with emission
//! (`KHR_materials_emissive_strength` above 1), `KHR_lights_punctual` lights and the camera.
//! Textures are not written (the generators make none): such a scene is refused.

use crate::{PunctualLight, Scene, Surface};
use glam::{Mat3, Quat, Vec3};
use serde_json::{json, Value};

/// The `.glb` bytes of `scene`.
pub fn glb(scene: &Scene) -> Result<Vec<u8>, String> {
    if !scene.textures.is_empty() {
        return Err(format!("{} has textures, which the glTF writer does not write", scene.name));
    }
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    // Vertex and index views name their target; animation keys have none.
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: Option<u32>| -> usize {
        bin.resize(bin.len().next_multiple_of(4), 0);
        let mut view = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        views.push(view);
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let floats =
        |v: &mut dyn Iterator<Item = f32>| -> Vec<u8> { v.flat_map(f32::to_le_bytes).collect() };
    let n = scene.positions.len();
    let (lo, hi) = scene
        .positions
        .iter()
        .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), &p| {
            (a.min(p), b.max(p))
        });
    let pos_view = push_view(
        &mut bin,
        &floats(&mut scene.positions.iter().flat_map(|p| p.to_array())),
        Some(34962),
    );
    accessors.push(json!({"bufferView": pos_view, "componentType": 5126, "count": n, "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}));
    let nrm_view = push_view(
        &mut bin,
        &floats(&mut scene.normals.iter().flat_map(|p| p.to_array())),
        Some(34962),
    );
    accessors
        .push(json!({"bufferView": nrm_view, "componentType": 5126, "count": n, "type": "VEC3"}));
    let uv_view =
        push_view(&mut bin, &floats(&mut scene.uvs.iter().flat_map(|p| p.to_array())), Some(34962));
    accessors
        .push(json!({"bufferView": uv_view, "componentType": 5126, "count": n, "type": "VEC2"}));
    let mut primitives = Vec::new();
    for m in 0..scene.materials.len() as u32 {
        let idx: Vec<u8> = scene
            .indices
            .iter()
            .zip(&scene.material_ids)
            .filter(|(_, &id)| id == m)
            .flat_map(|(t, _)| t.iter().flat_map(|i| i.to_le_bytes()))
            .collect();
        if idx.is_empty() {
            continue;
        }
        let view = push_view(&mut bin, &idx, Some(34963));
        accessors.push(json!({"bufferView": view, "componentType": 5125, "count": idx.len() / 4, "type": "SCALAR"}));
        primitives.push(json!({"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": accessors.len() - 1, "material": m}));
    }
    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| {
            let strength = m.emission.max_element();
            // The surface as glTF says it (the loader's table read backwards): metallic and
            // roughness (α = roughness²), and glass as full transmission with its index, solid
            // glass with a volume.
            let (metallic, roughness, glass) = match m.surface {
                Surface::Diffuse => (0.0, 1.0, None),
                Surface::Mirror => (1.0, 0.0, None),
                Surface::RoughConductor { alpha } => (1.0, alpha.sqrt(), None),
                Surface::Blend { metallic, alpha } => (metallic, alpha.sqrt(), None),
                Surface::Dielectric { eta } => (0.0, 0.0, Some((eta, true))),
                Surface::ThinDielectric { eta } => (0.0, 0.0, Some((eta, false))),
            };
            let mut v = json!({
                "name": m.name,
                "pbrMetallicRoughness": {"baseColorFactor": [m.base_color.x, m.base_color.y, m.base_color.z, 1.0], "metallicFactor": metallic, "roughnessFactor": roughness},
            });
            let mut extensions = serde_json::Map::new();
            if strength > 0.0 {
                let (factor, s) = if strength > 1.0 { (m.emission / strength, strength) } else { (m.emission, 1.0) };
                v["emissiveFactor"] = json!(factor.to_array());
                if s > 1.0 {
                    extensions.insert("KHR_materials_emissive_strength".into(), json!({"emissiveStrength": s}));
                }
            }
            if let Some((eta, solid)) = glass {
                extensions.insert("KHR_materials_transmission".into(), json!({"transmissionFactor": 1.0}));
                extensions.insert("KHR_materials_ior".into(), json!({"ior": eta}));
                if solid {
                    extensions.insert("KHR_materials_volume".into(), json!({"thicknessFactor": 1.0}));
                }
            }
            if !extensions.is_empty() {
                v["extensions"] = Value::Object(extensions);
            }
            v
        })
        .collect();
    // The camera node: glTF cameras look down their local -z with +y up.
    let c = scene.camera;
    let rotation = c.rotation();
    // Its animation, if any: one sampler per animated property, keys one accessor each.
    let mut animations = Vec::new();
    if let Some(path) = &scene.camera_path {
        if path.parent != glam::Mat4::IDENTITY || path.scale != Vec3::ONE {
            return Err(format!("{}: the glTF writer writes camera paths of an unparented, unscaled camera node only", scene.name));
        }
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        let mut track = |bin: &mut Vec<u8>,
                         times: &[f32],
                         values: Vec<f32>,
                         kind: &str,
                         step: bool,
                         property: &str| {
            let (lo, hi) = (times[0], times[times.len() - 1]);
            let view = push_view(bin, &floats(&mut times.iter().copied()), None);
            accessors.push(json!({"bufferView": view, "componentType": 5126, "count": times.len(), "type": "SCALAR", "min": [lo], "max": [hi]}));
            let view = push_view(bin, &floats(&mut values.into_iter()), None);
            accessors.push(json!({"bufferView": view, "componentType": 5126, "count": times.len(), "type": kind}));
            let interpolation = if step { "STEP" } else { "LINEAR" };
            samplers.push(json!({"input": accessors.len() - 2, "output": accessors.len() - 1, "interpolation": interpolation}));
            channels.push(
                json!({"sampler": samplers.len() - 1, "target": {"node": 1, "path": property}}),
            );
        };
        // A constant track is the node's own translation or rotation: no channel.
        let (t, r) = (&path.translation, &path.rotation);
        if t.span().is_some() {
            track(
                &mut bin,
                t.times(),
                t.values().iter().flat_map(|v| v.to_array()).collect(),
                "VEC3",
                t.is_step(),
                "translation",
            );
        }
        if r.span().is_some() {
            track(
                &mut bin,
                r.times(),
                r.values().iter().flat_map(|q| q.to_array()).collect(),
                "VEC4",
                r.is_step(),
                "rotation",
            );
        }
        animations.push(json!({"name": "camera path", "samplers": samplers, "channels": channels}));
    }
    let mut nodes = vec![
        json!({"name": scene.name, "mesh": 0}),
        json!({"name": "camera", "camera": 0, "translation": c.position.to_array(), "rotation": rotation.to_array()}),
    ];
    let mut lights = Vec::new();
    for l in &scene.lights {
        // Radiant intensity per channel = colour x intensity (the loader's reading).
        let (position, intensity, extra) = match l {
            PunctualLight::Point { position, intensity } => {
                (position, intensity, json!({"type": "point"}))
            }
            PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                let z = -direction.normalize();
                let x = if z.x.abs() < 0.9 { Vec3::X } else { Vec3::Y }.cross(z).normalize();
                let rot = Quat::from_mat3(&Mat3::from_cols(x, z.cross(x), z)).normalize();
                nodes.push(json!({"name": "spot", "rotation": rot.to_array(), "translation": position.to_array(), "extensions": {"KHR_lights_punctual": {"light": lights.len()}}}));
                let spot = json!({"type": "spot", "spot": {"innerConeAngle": cos_inner.clamp(-1.0, 1.0).acos(), "outerConeAngle": cos_outer.clamp(-1.0, 1.0).acos()}});
                lights.push(light_json(intensity, spot));
                continue;
            }
            PunctualLight::Directional { direction, irradiance } => {
                // The node's -Z is the direction the light travels in.
                let z = -direction.normalize();
                let x = if z.x.abs() < 0.9 { Vec3::X } else { Vec3::Y }.cross(z).normalize();
                let rot = Quat::from_mat3(&Mat3::from_cols(x, z.cross(x), z)).normalize();
                nodes.push(json!({"name": "sun", "rotation": rot.to_array(), "extensions": {"KHR_lights_punctual": {"light": lights.len()}}}));
                lights.push(light_json(irradiance, json!({"type": "directional"})));
                continue;
            }
        };
        nodes.push(json!({"name": "light", "translation": position.to_array(), "extensions": {"KHR_lights_punctual": {"light": lights.len()}}}));
        lights.push(light_json(intensity, extra));
    }
    let mut used = vec!["KHR_materials_emissive_strength"];
    let glass = scene.materials.iter().any(|m| m.surface.is_glass());
    for (ext, any) in [
        ("KHR_materials_transmission", glass),
        ("KHR_materials_ior", glass),
        (
            "KHR_materials_volume",
            scene.materials.iter().any(|m| matches!(m.surface, Surface::Dielectric { .. })),
        ),
    ] {
        if any {
            used.push(ext);
        }
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("vplgi ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [{"name": scene.name, "primitives": primitives}],
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": c.yfov, "znear": 0.01}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    if !animations.is_empty() {
        doc["animations"] = json!(animations);
    }
    if !lights.is_empty() {
        used.push("KHR_lights_punctual");
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": lights}});
    }
    doc["extensionsUsed"] = json!(used);
    let text = serde_json::to_vec(&doc).map_err(|e| e.to_string())?;
    Ok(crate::glb::container(&text, &bin))
}

fn light_json(intensity: &Vec3, mut light: Value) -> Value {
    let i = intensity.max_element().max(1e-30);
    light["color"] = json!((*intensity / i).to_array());
    light["intensity"] = json!(i);
    light
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written and loaded again, a generated scene has the same geometry (bit for bit),
    /// materials (emission to rounding), lights and camera.
    #[test]
    fn generated_scenes_survive_a_glb_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut scenes: Vec<Scene> = crate::generate::GENERATORS
            .iter()
            .map(|(name, _, _)| crate::generate::generate(name, 15_000).unwrap())
            .collect();
        scenes.push(crate::cornell::plane_with_point_light(1.0, 0.9, 0.6, 3.0));
        let mut sunlit = crate::cornell::plane_with_point_light(1.0, 0.9, 0.6, 3.0);
        sunlit.name = "sunlit".into();
        let sun = Vec3::new(-0.3, -0.8, 0.52).normalize();
        sunlit.lights.push(PunctualLight::Directional {
            direction: sun,
            irradiance: Vec3::new(3.0, 2.0, 1.0),
        });
        scenes.push(sunlit);
        for s in scenes {
            let path = dir.path().join(format!("{}.glb", s.name));
            std::fs::write(&path, glb(&s).unwrap()).unwrap();
            let back = Scene::load(&path).unwrap();
            assert_eq!(back.triangle_count(), s.triangle_count(), "{}", s.name);
            // Triangles come back grouped by material: compare as sets of corner positions.
            let tris = |x: &Scene| {
                let mut v: Vec<[u32; 9]> = (0..x.triangle_count())
                    .map(|t| {
                        let [a, b, c] = x.triangle(t);
                        let mut k = [0u32; 9];
                        for (i, p) in [a, b, c].iter().enumerate() {
                            for j in 0..3 {
                                k[3 * i + j] = p[j].to_bits();
                            }
                        }
                        k
                    })
                    .collect();
                v.sort_unstable();
                v
            };
            assert_eq!(tris(&back), tris(&s), "{}: geometry changed", s.name);
            assert_eq!(back.materials.len(), s.materials.len());
            for (a, b) in back.materials.iter().zip(&s.materials) {
                assert_eq!(a.base_color, b.base_color);
                assert!(
                    (a.emission - b.emission).abs().max_element()
                        <= 1e-5 * b.emission.max_element().max(1.0),
                    "{} vs {}",
                    a.emission,
                    b.emission
                );
            }
            assert_eq!(back.lights.len(), s.lights.len());
            for (a, b) in back.lights.iter().zip(&s.lights) {
                if let (
                    PunctualLight::Directional { direction: da, irradiance: ea },
                    PunctualLight::Directional { direction: db, irradiance: eb },
                ) = (a, b)
                {
                    assert!(
                        (*da - *db).length() < 1e-5 && (*ea - *eb).abs().max_element() < 1e-5,
                        "{}: sun {a:?} vs {b:?}",
                        s.name
                    );
                } else {
                    assert_eq!(
                        a.position().is_some(),
                        b.position().is_some(),
                        "{}: light kinds",
                        s.name
                    );
                }
            }
            assert!((back.camera.position - s.camera.position).length() < 1e-5);
            assert!(
                (back.camera.forward - s.camera.forward).length() < 1e-5,
                "{}: camera {:?} vs {:?}",
                s.name,
                back.camera,
                s.camera
            );
            assert!((back.camera.yfov - s.camera.yfov).abs() < 1e-6);
        }
    }

    /// A generated camera walk is written as an animation and read back as the same path: the
    /// cameras of 9 frames over its 5 keys agree, and the walk moves and turns.
    #[test]
    fn a_camera_walk_survives_a_glb_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = crate::generate::generate("conference", 2_000).unwrap();
        let walk = crate::generate::camera_walk(&s, 5).unwrap();
        s.camera_path = Some(walk.clone());
        let path = dir.path().join("walk.glb");
        std::fs::write(&path, glb(&s).unwrap()).unwrap();
        let back = Scene::load(&path).unwrap().camera_path.expect("a camera path");
        assert_eq!(back.span(), (0.0, 4.0));
        let (a, b) = (walk.frames(9).unwrap(), back.frames(9).unwrap());
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x.position - y.position).length() < 1e-5
                    && (x.forward - y.forward).length() < 1e-5,
                "{x:?} vs {y:?}"
            );
        }
        assert_eq!(a[0].position, s.camera.position, "the walk starts at the scene's camera");
        assert!((a[8].position - a[0].position).length() > 0.1 * s.extent(), "it walks");
        assert!(a[2].forward.dot(a[0].forward) < 0.995, "it turns");
        assert!(crate::generate::camera_walk(&s, 1).unwrap_err().contains("at least 2"));

        // Stepped tracks stay stepped: between keys the camera holds the earlier key's pose.
        let stepped = crate::CameraPath {
            translation: crate::Track::new(
                walk.translation.times().to_vec(),
                walk.translation.values().to_vec(),
                true,
            )
            .unwrap(),
            rotation: crate::Track::new(
                walk.rotation.times().to_vec(),
                walk.rotation.values().to_vec(),
                true,
            )
            .unwrap(),
            ..walk
        };
        s.camera_path = Some(stepped.clone());
        std::fs::write(&path, glb(&s).unwrap()).unwrap();
        let back = Scene::load(&path).unwrap().camera_path.expect("a camera path");
        assert!(back.translation.is_step() && back.rotation.is_step());
        let (held, read) = (stepped.at(0.5).unwrap(), back.at(0.5).unwrap());
        assert_eq!(held.position, stepped.at(0.0).unwrap().position);
        assert!(
            (walk.at(0.5).unwrap().position - held.position).length() > 1e-3,
            "read as linear, the walk has moved by then"
        );
        assert!(
            (read.position - held.position).length() < 1e-5
                && (read.forward - held.forward).length() < 1e-5,
            "{read:?} vs {held:?}"
        );
    }
}
