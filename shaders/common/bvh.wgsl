// Ray traversal of an obvhs BVH2 (built on the CPU by vplgi-gpu/src/bvh.rs) for closest hit
// and any hit. A scene without triangles is uploaded as one leaf with an empty box. Expects these
// bindings in the including shader:
//   bvh_nodes, bvh_nodes_hi: array<BvhNode>  obvhs::bvh2::node::Bvh2Node, 48 bytes
//   bvh_tris, bvh_tris_hi:   array<BvhTri>   triangles reordered by the BVH's primitive_indices
// Each array is paged over two bindings so it may exceed one storage binding: element i lives
// in the first page if i < the page size (an override set from the device limit), else in `_hi`.
// lavapipe has no ray queries, so traversal is an explicit stack loop.

override BVH_NODE_PAGE: u32 = 4294967295u;
override BVH_TRI_PAGE: u32 = 4294967295u;

fn bvh_node(i: u32) -> BvhNode {
    if (i < BVH_NODE_PAGE) {
        return bvh_nodes[i];
    }
    return bvh_nodes_hi[i - BVH_NODE_PAGE];
}

fn bvh_tri(i: u32) -> BvhTri {
    if (i < BVH_TRI_PAGE) {
        return bvh_tris[i];
    }
    return bvh_tris_hi[i - BVH_TRI_PAGE];
}

struct BvhNode {
    min: vec4<f32>,      // xyz = box minimum (glam Vec3A: 16 bytes)
    max: vec4<f32>,      // xyz = box maximum
    prim_count: u32,     // 0 for an inner node
    first_index: u32,    // first child (inner) or first primitive slot (leaf)
    meta1: u32,
    meta2: u32,
}

struct BvhTri {
    v0: vec4<f32>,       // w = bitcast<f32>(index of the triangle in the scene)
    e1: vec4<f32>,       // v1 - v0
    e2: vec4<f32>,       // v2 - v0
}

struct Hit {
    t: f32,
    triangle: u32,       // 0xffffffffu: no hit
    u: f32,              // barycentric weight of vertex 1
    v: f32,              // barycentric weight of vertex 2
    slot: u32,           // index into bvh_tris of the hit triangle
}

const NO_HIT: u32 = 0xffffffffu;
const BVH_STACK: u32 = 64u;

// Möller–Trumbore; returns (t, u, v), t = inf when missed or outside (tmin, tmax).
fn intersect_tri(tri: BvhTri, o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> vec3<f32> {
    let inf = bitcast<f32>(0x7f800000u);
    let p = cross(d, tri.e2.xyz);
    let det = dot(tri.e1.xyz, p);
    if (abs(det) < 1e-30) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    let inv_det = 1.0 / det;
    let s = o - tri.v0.xyz;
    let u = dot(s, p) * inv_det;
    if (u < 0.0 || u > 1.0) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    let q = cross(s, tri.e1.xyz);
    let v = dot(d, q) * inv_det;
    if (v < 0.0 || u + v > 1.0) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    let t = dot(tri.e2.xyz, q) * inv_det;
    if (t <= tmin || t >= tmax) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    return vec3<f32>(t, u, v);
}

// Entry distance into the box, or inf when the ray segment misses it.
fn intersect_box(node: BvhNode, o: vec3<f32>, inv_d: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let inf = bitcast<f32>(0x7f800000u);
    let t0 = (node.min.xyz - o) * inv_d;
    let t1 = (node.max.xyz - o) * inv_d;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), tmin));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), tmax));
    if (near <= far) {
        return near;
    }
    return inf;
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    // The guard of obvhs::ray::safe_inverse: a huge finite value instead of inf, so the slab
    // test never computes inf * 0 = NaN. Rust's signum(0.0) is 1, WGSL's sign(0.0) is 0: select.
    let eps = 1.1920929e-7;
    let s = select(vec3<f32>(1.0), vec3<f32>(-1.0), d < vec3<f32>(0.0));
    return select(1.0 / d, s / eps, abs(d) <= vec3<f32>(eps));
}

// Closest hit along o + t d, t in (tmin, tmax). With any_hit = true, returns the first hit found.
fn bvh_trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax_in: f32, any_hit: bool) -> Hit {
    var hit = Hit(tmax_in, NO_HIT, 0.0, 0.0, 0u);
    let inv_d = safe_inverse(d);
    var stack: array<u32, BVH_STACK>;
    var sp = 0u;
    var node_index = 0u;
    let inf = bitcast<f32>(0x7f800000u);
    if (intersect_box(bvh_node(0u), o, inv_d, tmin, hit.t) == inf) {
        return hit;
    }
    loop {
        let node = bvh_node(node_index);
        if (node.prim_count > 0u) {
            for (var i = node.first_index; i < node.first_index + node.prim_count; i = i + 1u) {
                let tri = bvh_tri(i);
                let r = intersect_tri(tri, o, d, tmin, hit.t);
                if (r.x < hit.t) {
                    hit = Hit(r.x, bitcast<u32>(tri.v0.w), r.y, r.z, i);
                    if (any_hit) {
                        return hit;
                    }
                }
            }
        } else {
            let a = node.first_index;
            let ta = intersect_box(bvh_node(a), o, inv_d, tmin, hit.t);
            let tb = intersect_box(bvh_node(a + 1u), o, inv_d, tmin, hit.t);
            if (ta != inf || tb != inf) {
                // Visit the nearer child first; push the other if it is hit too.
                var near_child = a;
                var far_child = a + 1u;
                var far_t = tb;
                if (tb < ta) {
                    near_child = a + 1u;
                    far_child = a;
                    far_t = ta;
                }
                if (far_t != inf && sp < BVH_STACK) {
                    stack[sp] = far_child;
                    sp = sp + 1u;
                }
                node_index = near_child;
                continue;
            }
        }
        if (sp == 0u) {
            break;
        }
        sp = sp - 1u;
        node_index = stack[sp];
    }
    return hit;
}

// vplgi_cpu::SEGMENT_TNEAR: shadow segments ignore touches at their very start.
const SEGMENT_TNEAR: f32 = 1e-5;

// CpuScene::visible: both ends pushed off their surfaces, the segment between them tested.
fn visible(p: vec3<f32>, np: vec3<f32>, q: vec3<f32>, nq: vec3<f32>, eps: f32) -> bool {
    let a = offset_toward(p, np, q, eps);
    let b = offset_toward(q, nq, p, eps);
    return bvh_trace(a, b - a, SEGMENT_TNEAR, 1.0, true).triangle == NO_HIT;
}

// CpuScene::visible_from_surface: to a point light, stopping eps short of it.
fn visible_from_surface(p: vec3<f32>, np: vec3<f32>, light: vec3<f32>, eps: f32) -> bool {
    let a = offset_toward(p, np, light, eps);
    let d = light - a;
    let len = length(d);
    return len > eps && bvh_trace(a, d, SEGMENT_TNEAR, 1.0 - eps / len, true).triangle == NO_HIT;
}
