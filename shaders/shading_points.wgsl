// Stage 2, shading_points: one primary ray per camera sample (vplgi-cpu/src/shading_points.rs).
// Sample i belongs to pixel i / spp; with spp = 1 it goes through the pixel centre, otherwise it
// is jittered with the stream (seed, STREAM_CAMERA, i).

struct Params {
    cam_pos: vec4<f32>,      // xyz
    cam_forward: vec4<f32>,  // xyz
    cam_up: vec4<f32>,       // xyz
    cam_right: vec4<f32>,    // xyz = normalize(cross(forward, up)), w = tan(yfov / 2)
    width: u32,
    height: u32,
    spp: u32,
    seed: u32,
    first: u32,              // first sample of this dispatch (chunking)
    count: u32,              // samples in this dispatch
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(3) var<storage, read> scene_tris: array<SceneTri>;
@group(0) @binding(4) var<storage, read> materials: array<Material>;
@group(0) @binding(5) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(6) var<storage, read> texels: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> out: array<ShadingPoint>;

fn texel(info: TextureInfo, i: i32, j: i32) -> vec3<f32> {
    // Repeat wrapping (rem_euclid).
    let w = i32(info.width);
    let h = i32(info.height);
    let x = ((i % w) + w) % w;
    let y = ((j % h) + h) % h;
    return texels[info.offset + u32(y * w + x)].xyz;
}

// vplgi_scene::Texture::sample: bilinear, repeat, (0, 0) at the top-left corner.
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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = gid.x + gid.y * groups.x * 64u;
    if (local >= params.count) {
        return;
    }
    let i = params.first + local;
    let pixel = i / params.spp;
    var sx = f32(pixel % params.width) + 0.5;
    var sy = f32(pixel / params.width) + 0.5;
    if (params.spp != 1u) {
        var rng = rng_new(params.seed, STREAM_CAMERA, i);
        sx = f32(pixel % params.width) + rng_next_f32(&rng);
        sy = f32(pixel / params.width) + rng_next_f32(&rng);
    }
    // vplgi_scene::Camera::ray_direction
    let aspect = f32(params.width) / f32(params.height);
    let tan_half = params.cam_right.w;
    let px = (2.0 * sx / f32(params.width) - 1.0) * tan_half * aspect;
    let py = (1.0 - 2.0 * sy / f32(params.height)) * tan_half;
    let dir = normalize(params.cam_forward.xyz + params.cam_right.xyz * px + params.cam_up.xyz * py);

    let inf = bitcast<f32>(0x7f800000u);
    let hit = bvh_trace(params.cam_pos.xyz, dir, 0.0, inf, false);
    var sp: ShadingPoint;
    sp.pixel = pixel;
    sp.triangle = MISS;
    if (hit.triangle != NO_HIT) {
        let tri = bvh_tris[hit.slot];
        let st = scene_tris[hit.triangle];
        let w0 = 1.0 - hit.u - hit.v;
        sp.position = tri.v0.xyz + tri.e1.xyz * hit.u + tri.e2.xyz * hit.v;
        let front = st.ng.xyz;
        let facing = dot(front, dir) < 0.0;
        var ng = front;
        if (!facing) {
            ng = -front;
        }
        let n = st.n0.xyz * w0 + st.n1.xyz * hit.u + st.n2.xyz * hit.v;
        var ns = ng;
        if (dot(n, n) > 0.0) {
            ns = normalize(n);
        }
        if (dot(ns, ng) < 0.0) {
            ns = -ns;
        }
        sp.normal = ns;
        sp.triangle = hit.triangle;
        let m = materials[bitcast<u32>(st.ng.w)];
        var albedo = m.base_color.xyz;
        let tex = bitcast<u32>(m.base_color.w);
        if (tex != MISS) {
            let uv = st.uv01.xy * w0 + st.uv01.zw * hit.u + st.uv2.xy * hit.v;
            albedo = albedo * sample_texture(tex, uv);
        }
        sp.albedo = albedo;
        if (facing) {
            sp.emitted = m.emission.xyz;
        }
    }
    out[local] = sp;
}
