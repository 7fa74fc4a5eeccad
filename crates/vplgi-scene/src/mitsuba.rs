//! Writing a scene for Mitsuba 3, the independent renderer `make validate` checks references
//! against: `scene.xml` plus one binary PLY mesh per material (`meshes/matN.ply`) and, for a
//! textured material, its albedo (base colour times texture) as a float image
//! (`textures/matN.pfm`).
//!
//! What is written, and why it renders the same light transport as vplgi:
//! * Materials are `diffuse` inside `twosided`: vplgi's Lambertian surfaces reflect on both
//!   sides (hits face their normals towards the ray), Mitsuba's `diffuse` alone only on the front.
//!   Other surfaces are written as the table of `vplgi_shared::bsdf` says (`conductor`,
//!   `roughconductor`, `blendbsdf` twosided with `material="none"`; `dielectric` and
//!   `thindielectric` as they are).
//! * Emission becomes an `area` emitter on the material's mesh. Both emit from the front side
//!   only, the side the winding's normal points to.
//! * Vertex normals are written, so both renderers shade with the interpolated normal.
//! * The camera is a pinhole with vplgi's vertical field of view; the film uses a box filter, as
//!   vplgi's jittered samples are box-filtered pixels (Mitsuba's default is a Gaussian).
//! * Point lights keep their radiant intensity. A spot light becomes Mitsuba's `spot` with the
//!   outer cone as `cutoff_angle` and the inner one as `beam_width`; its falloff between the cones
//!   differs (glTF's quadratic in the cosine against Mitsuba's linear in the angle), which
//!   [`MitsubaScene::warnings`] says.
//!
//! Width, height, samples per pixel and `max_depth` are XML defaults (`$width`, ...), so a run can
//! override them (`mitsuba -D spp=1024 scene.xml`, or `mi.load_file(path, spp=1024)`).

use crate::Surface;
use crate::{PunctualLight, Scene};
use glam::Vec3;
use std::fmt::Write as _;

/// A scene in Mitsuba 3's format: every file to write, by path relative to the output folder.
pub struct MitsubaScene {
    /// `scene.xml` first, then meshes and textures.
    pub files: Vec<(String, Vec<u8>)>,
    /// What does not translate exactly.
    pub warnings: Vec<String>,
}

/// The defaults written into `scene.xml`.
#[derive(Clone, Copy, Debug)]
pub struct RenderDefaults {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Mitsuba's path length limit: vplgi's `bounces` + 2 (camera segment, shading point to VPL,
    /// and the particle's segments from the light).
    pub max_depth: u32,
}

/// Shortest text that reads back as the same `f32`.
fn num(x: f32) -> String {
    format!("{x}")
}

fn vec3(v: Vec3) -> String {
    format!("{}, {}, {}", num(v.x), num(v.y), num(v.z))
}

fn rgb(v: Vec3) -> String {
    format!("{} {} {}", num(v.x), num(v.y), num(v.z))
}

/// Text safe inside an XML comment (which may not contain "--").
fn comment(s: &str) -> String {
    s.chars().map(|c| if c.is_alphanumeric() || " _.,:/()".contains(c) { c } else { '_' }).collect()
}

/// A binary little-endian PLY mesh of the triangles `tris` of `scene`: the vertices they use
/// (position, normal, texture coordinates) and the triangles re-indexed into them.
fn ply(scene: &Scene, tris: &[usize]) -> Vec<u8> {
    let mut remap = vec![u32::MAX; scene.positions.len()];
    let mut used = Vec::new();
    let mut faces = Vec::with_capacity(tris.len());
    for &t in tris {
        faces.push(scene.indices[t].map(|v| {
            if remap[v as usize] == u32::MAX {
                remap[v as usize] = used.len() as u32;
                used.push(v as usize);
            }
            remap[v as usize]
        }));
    }
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment vplgi export\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float u\nproperty float v\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        used.len(),
        faces.len()
    )
    .into_bytes();
    for &v in &used {
        let values = scene.positions[v]
            .to_array()
            .into_iter()
            .chain(scene.normals[v].to_array())
            .chain(scene.uvs[v].to_array());
        values.for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    }
    for f in faces {
        out.push(3);
        f.iter().for_each(|&i| out.extend_from_slice(&(i as i32).to_le_bytes()));
    }
    out
}

/// A PFM image (little-endian RGB floats, rows stored bottom to top) of texture `tex` times
/// `tint`: Mitsuba's bitmap reads it as linear values, with row 0 of the texture at v = 0 as in
/// glTF.
fn pfm(scene: &Scene, tex: u32, tint: Vec3) -> Vec<u8> {
    let t = &scene.textures[tex as usize];
    let mut out = format!("PF\n{} {}\n-1.0\n", t.width, t.height).into_bytes();
    for row in t.texels.chunks(t.width as usize).rev() {
        for texel in row {
            (*texel * tint).to_array().iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
    }
    out
}

/// Translates `scene` to Mitsuba 3.
pub fn export(scene: &Scene, defaults: RenderDefaults) -> MitsubaScene {
    let mut files = Vec::new();
    let mut warnings = Vec::new();
    let mut xml = String::new();
    let RenderDefaults { width, height, spp, max_depth } = defaults;
    let _ = writeln!(xml, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        xml,
        "<!-- {}: written by vplgi scene export (format mitsuba) -->",
        comment(&scene.name)
    );
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    for (name, value) in
        [("width", width), ("height", height), ("spp", spp), ("max_depth", max_depth)]
    {
        let _ = writeln!(xml, "  <default name=\"{name}\" value=\"{value}\"/>");
    }
    let _ = writeln!(xml, "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"$max_depth\"/>\n  </integrator>");
    let cam = scene.camera;
    let extent = scene.extent().max(1e-3);
    let _ = writeln!(
        xml,
        "  <sensor type=\"perspective\">\n    <float name=\"fov\" value=\"{}\"/>\n    <string name=\"fov_axis\" value=\"y\"/>\n    \
         <float name=\"near_clip\" value=\"{}\"/>\n    <float name=\"far_clip\" value=\"{}\"/>\n    \
         <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    \
         <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"$spp\"/>\n    </sampler>\n    \
         <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"$width\"/>\n      <integer name=\"height\" value=\"$height\"/>\n      \
         <string name=\"pixel_format\" value=\"rgb\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        num(cam.yfov.to_degrees()),
        num(extent * 1e-5),
        num(extent * 100.0),
        vec3(cam.position),
        vec3(cam.position + cam.forward),
        vec3(cam.up)
    );
    let mut by_material: Vec<Vec<usize>> = vec![Vec::new(); scene.materials.len()];
    for (t, &m) in scene.material_ids.iter().enumerate() {
        by_material[m as usize].push(t);
    }
    for (m, tris) in by_material.iter().enumerate().filter(|(_, tris)| !tris.is_empty()) {
        let mat = &scene.materials[m];
        let reflectance = match mat.base_color_texture {
            Some(tex) => {
                let path = format!("textures/mat{m}.pfm");
                files.push((path.clone(), pfm(scene, tex, mat.base_color)));
                format!("<texture type=\"bitmap\" name=\"reflectance\">\n          <string name=\"filename\" value=\"{path}\"/>\n        </texture>")
            }
            None => format!("<rgb name=\"reflectance\" value=\"{}\"/>", rgb(mat.base_color)),
        };
        let mesh = format!("meshes/mat{m}.ply");
        let _ = writeln!(
            xml,
            "  <!-- material {m}: {} -->\n  <shape type=\"ply\">\n    <string name=\"filename\" value=\"{mesh}\"/>\n    \
             {}",
            comment(&mat.name),
            bsdf_xml(mat.surface, &reflectance)
        );
        if mat.emission.max_element() > 0.0 {
            let _ = writeln!(xml, "    <emitter type=\"area\">\n      <rgb name=\"radiance\" value=\"{}\"/>\n    </emitter>", rgb(mat.emission));
        }
        let _ = writeln!(xml, "  </shape>");
        files.push((mesh, ply(scene, tris)));
    }
    for (i, light) in scene.lights.iter().enumerate() {
        match *light {
            PunctualLight::Point { position, intensity } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    <rgb name=\"intensity\" value=\"{}\"/>\n  </emitter>",
                    vec3(position),
                    rgb(intensity)
                );
            }
            PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                // Mitsuba's lookat needs an up vector that is not parallel to the axis.
                let up = if direction.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"spot\">\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    \
                     <rgb name=\"intensity\" value=\"{}\"/>\n    <float name=\"cutoff_angle\" value=\"{}\"/>\n    <float name=\"beam_width\" value=\"{}\"/>\n  </emitter>",
                    vec3(position),
                    vec3(position + direction),
                    vec3(up),
                    rgb(intensity),
                    num(cos_outer.clamp(-1.0, 1.0).acos().to_degrees()),
                    num(cos_inner.clamp(-1.0, 1.0).acos().to_degrees())
                );
                warnings.push(format!(
                    "light {i} is a spot light: Mitsuba's falloff between the inner and outer cones (linear in the angle) \
                     differs from glTF's (quadratic in the cosine), so images differ in its penumbra"
                ));
            }
            PunctualLight::Directional { direction, irradiance } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                    vec3(direction),
                    rgb(irradiance)
                );
            }
        }
    }
    let _ = writeln!(xml, "</scene>");
    files.insert(0, ("scene.xml".into(), xml.into_bytes()));
    MitsubaScene { files, warnings }
}

/// The Mitsuba 3 BSDF of `surface` whose colour is `reflectance` (an `rgb` or `texture` element
/// named `reflectance`), by the table of `vplgi_shared::bsdf`: conductors with
/// `material="none"` (no Fresnel term), glass not twosided (its inside differs from its outside).
fn bsdf_xml(surface: Surface, reflectance: &str) -> String {
    let specular = reflectance.replacen("name=\"reflectance\"", "name=\"specular_reflectance\"", 1);
    let rough = |alpha: f32| {
        format!(
            "<bsdf type=\"roughconductor\">\n        <string name=\"distribution\" value=\"ggx\"/>\n        \
             <float name=\"alpha\" value=\"{alpha:?}\"/>\n        <string name=\"material\" value=\"none\"/>\n        \
             {specular}\n      </bsdf>"
        )
    };
    let diffuse = format!("<bsdf type=\"diffuse\">\n        {reflectance}\n      </bsdf>");
    let twosided = |inner: String| format!("<bsdf type=\"twosided\">\n      {inner}\n    </bsdf>");
    let glass = |kind: &str, eta: f32| {
        format!(
            "<bsdf type=\"{kind}\">\n      <float name=\"int_ior\" value=\"{eta:?}\"/>\n      \
             <float name=\"ext_ior\" value=\"1.0\"/>\n    </bsdf>"
        )
    };
    match surface {
        Surface::Diffuse => twosided(diffuse),
        Surface::Mirror => twosided(format!(
            "<bsdf type=\"conductor\">\n        <string name=\"material\" value=\"none\"/>\n        {specular}\n      </bsdf>"
        )),
        Surface::RoughConductor { alpha } => twosided(rough(alpha)),
        Surface::Dielectric { eta } => glass("dielectric", eta),
        Surface::ThinDielectric { eta } => glass("thindielectric", eta),
        Surface::Blend { metallic, alpha } => twosided(format!(
            "<bsdf type=\"blendbsdf\">\n      <float name=\"weight\" value=\"{metallic:?}\"/>\n      {diffuse}\n      {}\n    </bsdf>",
            rough(alpha)
        )),
    }
}

#[cfg(test)]
mod tests {
    //! The export read back without Mitsuba: the XML through an XML parser, each PLY through a
    //! reader that follows its header (not the writer's layout), and the scene rebuilt from them
    //! compared with the original, bit for bit.
    use super::*;
    use crate::{cornell, Material, Texture};
    use glam::Vec2;
    use std::collections::HashMap;

    const DEFAULTS: RenderDefaults =
        RenderDefaults { width: 64, height: 48, spp: 16, max_depth: 5 };

    fn floats(s: &str) -> Vec<f32> {
        s.split([',', ' ']).filter(|t| !t.is_empty()).map(|t| t.parse().unwrap()).collect()
    }

    fn v3(s: &str) -> Vec3 {
        let f = floats(s);
        assert_eq!(f.len(), 3, "{s}");
        Vec3::new(f[0], f[1], f[2])
    }

    /// A PLY file's vertex records (by property name) and faces.
    struct Ply {
        vertices: Vec<HashMap<String, f32>>,
        faces: Vec<Vec<usize>>,
    }

    /// A PLY property: name, type, and for a list the type of its count.
    type Property = (String, String, Option<String>);

    fn read_ply(bytes: &[u8]) -> Ply {
        let end = bytes.windows(11).position(|w| w == b"end_header\n").expect("end_header") + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap();
        assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"), "{header}");
        // (element name, count, properties)
        let mut elements: Vec<(String, usize, Vec<Property>)> = Vec::new();
        for line in header.lines() {
            let w: Vec<&str> = line.split_whitespace().collect();
            match w.as_slice() {
                ["element", name, n] => {
                    elements.push((name.to_string(), n.parse().unwrap(), Vec::new()))
                }
                ["property", "list", count, item, name] => elements.last_mut().unwrap().2.push((
                    name.to_string(),
                    item.to_string(),
                    Some(count.to_string()),
                )),
                ["property", ty, name] => {
                    elements.last_mut().unwrap().2.push((name.to_string(), ty.to_string(), None))
                }
                _ => {}
            }
        }
        let mut at = end;
        let mut take = |ty: &str| -> f64 {
            let (size, v) = match ty {
                "float" => (4, f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64),
                "int" => (4, i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64),
                "uint" => (4, u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64),
                "uchar" => (1, bytes[at] as f64),
                other => panic!("type {other}"),
            };
            at += size;
            v
        };
        let (mut vertices, mut faces) = (Vec::new(), Vec::new());
        for (name, n, props) in &elements {
            for _ in 0..*n {
                let mut record = HashMap::new();
                for (pname, ty, list) in props {
                    match list {
                        Some(count_ty) => {
                            let k = take(count_ty) as usize;
                            faces.push((0..k).map(|_| take(ty) as usize).collect());
                        }
                        None => {
                            record.insert(pname.clone(), take(ty) as f32);
                        }
                    }
                }
                if name == "vertex" {
                    vertices.push(record);
                }
            }
        }
        assert_eq!(at, bytes.len(), "trailing bytes after the PLY's elements");
        Ply { vertices, faces }
    }

    /// A triangle as rendered: corner positions, normals and uvs, reflectance (a colour, or the
    /// albedo texture's file) and emission, as bit patterns so that it sorts and compares exactly.
    type Tri = (Vec<u32>, String, Vec<u32>);

    fn bits(vs: &[f32]) -> Vec<u32> {
        vs.iter().map(|x| x.to_bits()).collect()
    }

    fn scene_triangles(s: &Scene, texture_of: &dyn Fn(usize) -> String) -> Vec<Tri> {
        let mut out: Vec<Tri> = (0..s.triangle_count())
            .map(|t| {
                let corners: Vec<f32> = s.indices[t]
                    .iter()
                    .flat_map(|&v| {
                        let v = v as usize;
                        s.positions[v]
                            .to_array()
                            .into_iter()
                            .chain(s.normals[v].to_array())
                            .chain(s.uvs[v].to_array())
                    })
                    .collect();
                let m = &s.materials[s.material_ids[t] as usize];
                let refl = match m.base_color_texture {
                    Some(_) => texture_of(s.material_ids[t] as usize),
                    None => format!("{:?}", bits(&m.base_color.to_array())),
                };
                (bits(&corners), refl, bits(&m.emission.to_array()))
            })
            .collect();
        out.sort();
        out
    }

    fn read_back(files: &[(String, Vec<u8>)]) -> (roxmltree::Document<'_>, HashMap<&str, &[u8]>) {
        let map: HashMap<&str, &[u8]> =
            files.iter().map(|(n, b)| (n.as_str(), b.as_slice())).collect();
        let xml = std::str::from_utf8(map["scene.xml"]).unwrap();
        (roxmltree::Document::parse(xml).expect("scene.xml parses"), map)
    }

    fn named<'a>(node: roxmltree::Node<'a, 'a>, tag: &str, name: &str) -> roxmltree::Node<'a, 'a> {
        node.descendants()
            .find(|n| n.has_tag_name(tag) && n.attribute("name") == Some(name))
            .unwrap_or_else(|| panic!("no <{tag} name=\"{name}\">"))
    }

    /// Rebuilds the triangles from the XML's shapes and their PLY files.
    fn exported_triangles(doc: &roxmltree::Document, files: &HashMap<&str, &[u8]>) -> Vec<Tri> {
        let mut out = Vec::new();
        for shape in doc.root_element().children().filter(|n| n.has_tag_name("shape")) {
            assert_eq!(shape.attribute("type"), Some("ply"));
            let file = named(shape, "string", "filename").attribute("value").unwrap();
            let bsdf = shape.children().find(|n| n.has_tag_name("bsdf")).unwrap();
            assert_eq!(
                bsdf.attribute("type"),
                Some("twosided"),
                "vplgi's surfaces reflect on both sides"
            );
            let refl = match bsdf
                .descendants()
                .find(|n| n.attribute("name") == Some("reflectance"))
                .unwrap()
            {
                n if n.has_tag_name("rgb") => {
                    format!("{:?}", bits(&v3(n.attribute("value").unwrap()).to_array()))
                }
                n => named(n, "string", "filename").attribute("value").unwrap().to_string(),
            };
            let emission = shape
                .children()
                .find(|n| n.has_tag_name("emitter"))
                .map(|e| {
                    assert_eq!(e.attribute("type"), Some("area"));
                    v3(named(e, "rgb", "radiance").attribute("value").unwrap())
                })
                .unwrap_or(Vec3::ZERO);
            let ply = read_ply(files[file]);
            for f in &ply.faces {
                assert_eq!(f.len(), 3);
                let corners: Vec<f32> = f
                    .iter()
                    .flat_map(|&v| {
                        ["x", "y", "z", "nx", "ny", "nz", "u", "v"].map(|p| ply.vertices[v][p])
                    })
                    .collect();
                out.push((bits(&corners), refl.clone(), bits(&emission.to_array())));
            }
        }
        out.sort();
        out
    }

    #[test]
    fn the_cornell_box_reads_back_as_itself() {
        let scene = cornell::cornell_box();
        let exported = export(&scene, DEFAULTS);
        assert!(exported.warnings.is_empty());
        let (doc, files) = read_back(&exported.files);
        assert_eq!(exported_triangles(&doc, &files), scene_triangles(&scene, &|_| unreachable!()));
        // Every file the XML names was written, and nothing else.
        let named_files: Vec<&str> = doc
            .descendants()
            .filter(|n| n.attribute("name") == Some("filename"))
            .map(|n| n.attribute("value").unwrap())
            .collect();
        assert_eq!(named_files.len() + 1, exported.files.len());
        // The camera: the same ray through every pixel corner as vplgi's.
        let sensor = doc.descendants().find(|n| n.has_tag_name("sensor")).unwrap();
        assert_eq!(named(sensor, "string", "fov_axis").attribute("value"), Some("y"));
        let fov: f32 = named(sensor, "float", "fov").attribute("value").unwrap().parse().unwrap();
        assert!((fov.to_radians() - scene.camera.yfov).abs() < 1e-6);
        let lookat = sensor.descendants().find(|n| n.has_tag_name("lookat")).unwrap();
        let origin = v3(lookat.attribute("origin").unwrap());
        assert_eq!(origin, scene.camera.position);
        assert!(
            (v3(lookat.attribute("target").unwrap()) - origin - scene.camera.forward).length()
                < 1e-6
        );
        assert_eq!(v3(lookat.attribute("up").unwrap()), scene.camera.up);
        let rfilter = sensor.descendants().find(|n| n.has_tag_name("rfilter")).unwrap();
        assert_eq!(rfilter.attribute("type"), Some("box"));
        // Overridable defaults, and max_depth used by the path integrator.
        let default = |name: &str| {
            doc.descendants()
                .find(|n| n.has_tag_name("default") && n.attribute("name") == Some(name))
                .unwrap()
                .attribute("value")
                .unwrap()
        };
        assert_eq!(
            [default("width"), default("height"), default("spp"), default("max_depth")],
            ["64", "48", "16", "5"]
        );
        assert_eq!(
            named(doc.root_element(), "integer", "max_depth").attribute("value"),
            Some("$max_depth")
        );
    }

    /// Each surface is written as the Mitsuba BSDF of the table in `vplgi_shared::bsdf`, with its
    /// parameters: conductors without Fresnel (`material="none"`) and twosided, glass not.
    #[test]
    fn surfaces_are_written_as_mitsuba_bsdfs() {
        let mut scene = cornell::cornell_box();
        let surfaces = [
            (Surface::Mirror, "twosided/conductor"),
            (Surface::RoughConductor { alpha: 0.25 }, "twosided/roughconductor"),
            (Surface::Dielectric { eta: 1.33 }, "dielectric"),
            (Surface::ThinDielectric { eta: 1.5 }, "thindielectric"),
            (Surface::Blend { metallic: 0.3, alpha: 0.09 }, "twosided/blendbsdf"),
        ];
        for (m, (surface, _)) in scene.materials.iter_mut().zip(&surfaces) {
            m.surface = *surface;
        }
        let exported = export(&scene, DEFAULTS);
        let (doc, _) = read_back(&exported.files);
        let shapes: Vec<roxmltree::Node> =
            doc.root_element().children().filter(|n| n.has_tag_name("shape")).collect();
        for (shape, (surface, path)) in shapes.iter().zip(&surfaces) {
            let outer = shape.children().find(|n| n.has_tag_name("bsdf")).unwrap();
            let kinds: Vec<&str> = std::iter::successors(Some(outer), |n| {
                n.children().find(|c| c.has_tag_name("bsdf"))
            })
            .map(|n| n.attribute("type").unwrap())
            .take(2)
            .collect();
            assert_eq!(kinds.join("/"), path.to_string(), "{surface:?}");
            let float = |name: &str| -> Option<f32> {
                outer
                    .descendants()
                    .find(|n| n.has_tag_name("float") && n.attribute("name") == Some(name))
                    .map(|n| n.attribute("value").unwrap().parse().unwrap())
            };
            let none = outer.descendants().any(|n| n.attribute("value") == Some("none"));
            match *surface {
                Surface::RoughConductor { alpha } => {
                    assert_eq!((float("alpha"), none), (Some(alpha), true))
                }
                Surface::Mirror => assert!(none),
                Surface::Dielectric { eta } | Surface::ThinDielectric { eta } => {
                    assert_eq!((float("int_ior"), float("ext_ior")), (Some(eta), Some(1.0)))
                }
                Surface::Blend { metallic, alpha } => {
                    assert_eq!((float("weight"), float("alpha")), (Some(metallic), Some(alpha)))
                }
                Surface::Diffuse => unreachable!(),
            }
        }
    }

    #[test]
    fn punctual_lights_and_textures_read_back() {
        let mut scene = cornell::plane_with_point_light(1.0, 1.5, 0.5, 10.0);
        scene.lights.push(PunctualLight::Spot {
            position: Vec3::new(0.1, 2.0, -0.3),
            direction: Vec3::new(0.0, -1.0, 0.0),
            intensity: Vec3::new(3.0, 2.0, 1.0),
            cos_inner: 0.9,
            cos_outer: 0.8,
        });
        let sun = Vec3::new(0.3, -0.9, 0.1).normalize();
        scene.lights.push(PunctualLight::Directional {
            direction: sun,
            irradiance: Vec3::new(2.0, 1.5, 1.0),
        });
        // One textured material: a 3 x 2 texture whose texels all differ.
        let texels: Vec<Vec3> =
            (0..6).map(|i| Vec3::new(i as f32 * 0.1, 0.5, 1.0 - i as f32 * 0.1)).collect();
        scene.textures.push(Texture { width: 3, height: 2, texels: texels.clone() });
        scene.materials.push(Material {
            name: "tex".into(),
            base_color: Vec3::new(0.5, 1.0, 1.0),
            base_color_texture: Some(0),
            emission: Vec3::ZERO,
            ..Material::default()
        });
        let last = scene.material_ids.len() - 1;
        scene.material_ids[last] = scene.materials.len() as u32 - 1;
        scene.uvs = (0..scene.positions.len()).map(|i| Vec2::new(i as f32 * 0.25, 0.5)).collect();
        let exported = export(&scene, DEFAULTS);
        let (doc, files) = read_back(&exported.files);
        let tex_file = format!("textures/mat{}.pfm", scene.materials.len() - 1);
        assert_eq!(
            exported_triangles(&doc, &files),
            scene_triangles(&scene, &|_| tex_file.clone())
        );
        // The albedo image: base colour times texel, rows bottom to top.
        let pfm = files[tex_file.as_str()];
        let header = b"PF\n3 2\n-1.0\n";
        assert_eq!(&pfm[..header.len()], header);
        let data: Vec<f32> = pfm[header.len()..]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(data.len(), 18);
        for (i, texel) in texels.iter().enumerate() {
            let (x, y) = (i % 3, i / 3);
            let stored = 3 * ((1 - y) * 3 + x);
            assert_eq!(
                Vec3::from_slice(&data[stored..stored + 3]),
                *texel * Vec3::new(0.5, 1.0, 1.0),
                "texel ({x}, {y})"
            );
        }
        // The lights.
        let emitters: Vec<roxmltree::Node> =
            doc.root_element().children().filter(|n| n.has_tag_name("emitter")).collect();
        assert_eq!(emitters.len(), 3);
        assert_eq!(emitters[2].attribute("type"), Some("directional"));
        assert!(
            (v3(named(emitters[2], "vector", "direction").attribute("value").unwrap()) - sun)
                .length()
                < 1e-6
        );
        assert_eq!(
            v3(named(emitters[2], "rgb", "irradiance").attribute("value").unwrap()),
            Vec3::new(2.0, 1.5, 1.0)
        );
        assert_eq!(emitters[0].attribute("type"), Some("point"));
        assert_eq!(
            v3(named(emitters[0], "point", "position").attribute("value").unwrap()),
            Vec3::new(0.0, 1.5, 0.0)
        );
        assert_eq!(
            v3(named(emitters[0], "rgb", "intensity").attribute("value").unwrap()),
            Vec3::splat(10.0)
        );
        assert_eq!(emitters[1].attribute("type"), Some("spot"));
        let lookat = emitters[1].descendants().find(|n| n.has_tag_name("lookat")).unwrap();
        assert_eq!(v3(lookat.attribute("origin").unwrap()), Vec3::new(0.1, 2.0, -0.3));
        assert!(
            (v3(lookat.attribute("target").unwrap()) - Vec3::new(0.1, 1.0, -0.3)).length() < 1e-6
        );
        let angle = |name: &str| {
            named(emitters[1], "float", name)
                .attribute("value")
                .unwrap()
                .parse::<f32>()
                .unwrap()
                .to_radians()
                .cos()
        };
        assert!(
            (angle("cutoff_angle") - 0.8).abs() < 1e-6 && (angle("beam_width") - 0.9).abs() < 1e-6
        );
        assert_eq!(
            exported.warnings.len(),
            1,
            "the spot's falloff differs, and the export says so"
        );
    }
}
