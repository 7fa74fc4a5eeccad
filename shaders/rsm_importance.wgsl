// include: common/types.wgsl
// The bidirectional importance map of the RSM clustering (vplgi-cpu/src/rsm_importance.rs;
// Prutkin et al. 2012, Alg. 1 lines 2-4; vplgi_shared::rsm_importance), two kernels:
//   importance_points: the G-buffer point of each listed camera sample (a zero normal where the
//                      sample missed, which adds nothing below);
//   importance:        each VPL's texel: its flux times the geometry terms toward those points,
//                      summed in the list's order (the CPU's order).

struct Params {
    n: u32,          // VPLs
    count: u32,      // listed samples
    d_min2: f32,     // the floor of d², (D_MIN_REL x the scene's diagonal)²
    pad: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(2) var<storage, read> samples: array<u32>;
@group(0) @binding(3) var<storage, read> offsets: array<u32>;      // hits before each sample
@group(0) @binding(4) var<storage, read> hit_points: array<Endpoint>;
@group(0) @binding(5) var<storage, read_write> points: array<Endpoint>;
@group(0) @binding(6) var<storage, read_write> importance: array<f32>; // per texel, zeroed

@compute @workgroup_size(64)
fn importance_points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    let s = samples[i];
    let h = offsets[s];
    if (offsets[s + 1u] > h) {
        points[i] = hit_points[h];
    } else {
        points[i] = Endpoint(vec4<f32>(0.0), vec4<f32>(0.0));
    }
}

// rsm_importance::term
fn term(v: Vpl, p: Endpoint) -> f32 {
    let d = p.position.xyz - v.position;
    let d2 = dot(d, d);
    if (d2 <= 0.0) {
        return 0.0;
    }
    let w = d / sqrt(d2);
    let cos_v = max(dot(v.normal, w), 0.0);
    let cos_p = max(-dot(p.normal.xyz, w), 0.0);
    return cos_v * cos_p / max(d2, max(params.d_min2, 1.17549435e-38));
}

@compute @workgroup_size(64)
fn importance_of_texels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let v = vpls[i];
    var g = 0.0;
    for (var j = 0u; j < params.count; j = j + 1u) {
        g = g + term(v, points[j]);
    }
    importance[v.path] = (v.flux.x + v.flux.y + v.flux.z) * g;
}
