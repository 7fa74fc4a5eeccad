// What a ray sees where it hits a surface (vplgi-cpu CpuScene::trace). Reads the arrays of
// scene.wgsl: bvh_tris(_hi), the per-triangle shading data in four pages scene_tris,
// scene_tris_1 .. _3, materials, texture_infos and the texel words in four pages texels,
// texels_1 .. _3 (vplgi-gpu/src/scene.rs). Page sizes are overrides set from the device limit.

override SCENE_TRI_PAGE: u32 = 4294967295u;

fn scene_tri(i: u32) -> SceneTri {
    let k = i % SCENE_TRI_PAGE;
    switch i / SCENE_TRI_PAGE {
        case 0u: { return scene_tris[k]; }
        case 1u: { return scene_tris_1[k]; }
        case 2u: { return scene_tris_2[k]; }
        default: { return scene_tris_3[k]; }
    }
}

// Surface::with_colour(1): the BSDF of material m in white.
fn white_bsdf(m: u32) -> BsdfRecord {
    var b = materials[m].bsdf;
    b.reflectance = vec3<f32>(1.0);
    return b;
}

struct Surface {
    position: vec3<f32>,
    ng: vec3<f32>,        // geometric normal facing the ray's origin
    ns: vec3<f32>,        // shading normal in ng's hemisphere
    albedo: vec3<f32>,
    emitted: vec3<f32>,   // emission towards the ray's origin (front side only)
    bsdf: BsdfRecord,     // its reflectance is albedo
    material: u32,        // its material's index
    facing: bool,         // the ray hit the front side (where the geometric normal points)
}

override TEXEL_PAGE: u32 = 4294967295u;

fn texel_word(i: u32) -> u32 {
    let k = i % TEXEL_PAGE;
    switch i / TEXEL_PAGE {
        case 0u: { return texels[k]; }
        case 1u: { return texels_1[k]; }
        case 2u: { return texels_2[k]; }
        default: { return texels_3[k]; }
    }
}

// Words 0 .. 256 are the linear values of the 8-bit sRGB codes (vplgi_scene::srgb8_table), so
// 8-bit textures decode to exactly the CPU's texels.
fn srgb8(code: u32) -> f32 {
    return bitcast<f32>(texel_word(code & 255u));
}

fn texel(info: TextureInfo, i: i32, j: i32) -> vec3<f32> {
    // Repeat wrapping (rem_euclid).
    let w = i32(info.width);
    let h = i32(info.height);
    let x = ((i % w) + w) % w;
    let y = ((j % h) + h) % h;
    let t = u32(y * w + x);
    if (info.format == TEXELS_SRGB8) {
        let c = texel_word(info.offset + t);
        return vec3<f32>(srgb8(c), srgb8(c >> 8u), srgb8(c >> 16u));
    }
    let o = info.offset + 3u * t;
    return vec3<f32>(bitcast<f32>(texel_word(o)), bitcast<f32>(texel_word(o + 1u)), bitcast<f32>(texel_word(o + 2u)));
}

// vplgi_scene::Texture::sample: bilinear, repeat, (0, 0) at the top-left corner.
// false when no material of the scene has a texture: the lookup in surface_at folds away, where
// lavapipe would run it, masked, at every hit (vplgi_gpu::shader::RayPipeline).
override TEXTURED: bool = true;

fn sample_texture(t: u32, uv: vec2<f32>) -> vec3<f32> {
    let info = texture_infos[t];
    let x = uv.x * f32(info.width) - 0.5;
    let y = uv.y * f32(info.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let top = mix(texel(info, i, j), texel(info, i + 1, j), fx);
    let bottom = mix(texel(info, i, j + 1), texel(info, i + 1, j + 1), fx);
    return mix(top, bottom, fy);
}

fn surface_at(hit: Hit, dir: vec3<f32>) -> Surface {
    let tri = bvh_tri(hit.slot);
    let st = scene_tri(hit.triangle);
    let w0 = 1.0 - hit.u - hit.v;
    var s: Surface;
    s.position = tri.v0.xyz * w0 + tri.v1.xyz * hit.u + tri.v2.xyz * hit.v;   // as CpuScene::surface
    let front = st.ng.xyz;
    let facing = dot(front, dir) < 0.0;
    s.ng = front;
    if (!facing) {
        s.ng = -front;
    }
    let n = st.n0.xyz * w0 + st.n1.xyz * hit.u + st.n2.xyz * hit.v;
    s.ns = s.ng;
    if (dot(n, n) > 0.0) {
        s.ns = normalize(n);
    }
    if (dot(s.ns, s.ng) < 0.0) {
        s.ns = -s.ns;
    }
    s.material = bitcast<u32>(st.ng.w);
    let m = materials[s.material];
    s.albedo = m.base_color.xyz;
    let t = bitcast<u32>(m.base_color.w);
    if (TEXTURED && t != MISS) {
        let uv = st.uv01.xy * w0 + st.uv01.zw * hit.u + st.uv2.xy * hit.v;
        s.albedo = s.albedo * sample_texture(t, uv);
    }
    s.emitted = vec3<f32>(0.0);
    if (facing) {
        s.emitted = m.emission.xyz;
    }
    s.bsdf = m.bsdf;
    s.bsdf.reflectance = s.albedo;
    s.facing = facing;
    return s;
}
