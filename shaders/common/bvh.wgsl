// Stackless ray traversal of a threaded obvhs BVH2 (built on the CPU and threaded by
// vplgi-gpu/src/bvh.rs) for closest hit and any hit. Nodes are in depth-first preorder: an inner
// node's first child is the next node, and `skip` leads past the node's subtree, taken when the
// ray misses the box or after a leaf. A ray's traversal state is one node index: no stack array
// per invocation, and visibility.wgsl can chain its rays without waiting for other lanes.
// A scene without triangles is uploaded as one leaf without triangles. Reads the arrays of
// scene.wgsl:
//   bvh_nodes, bvh_nodes_hi: array<BvhNode>  vplgi_gpu::bvh::BvhNode, 16 bytes: the box
//                            quantized in bvh_frame (16 bits per corner coordinate), the link
//   bvh_tris, bvh_tris_hi:   array<BvhTri>   triangles reordered by the BVH's primitive_indices
//   bvh_frame                                corner = origin + q * step
// Each array is paged over two bindings so it may exceed one storage binding: element i lives
// in the first page if i < the page size (an override set from the device limit), else in `_hi`.

override BVH_NODE_PAGE: u32 = 4294967295u;
override BVH_TRI_PAGE: u32 = 4294967295u;
// false when the scene's BVH fits the first pages: the branches below fold away
// (vplgi_gpu::shader::RayPipeline).
override BVH_PAGED: bool = true;

fn bvh_node(i: u32) -> BvhNode {
    if (!BVH_PAGED || i < BVH_NODE_PAGE) {
        return bvh_nodes[i];
    }
    return bvh_nodes_hi[i - BVH_NODE_PAGE];
}

fn bvh_tri(i: u32) -> BvhTri {
    if (!BVH_PAGED || i < BVH_TRI_PAGE) {
        return bvh_tris[i];
    }
    return bvh_tris_hi[i - BVH_TRI_PAGE];
}

// Words 0-2: the box's corners quantized to 16 bits (min x, y, z, max x, y, z, low half first),
// rounded outwards so the box holds the node's exact box; word 3: the link. A leaf's link has
// BVH_LINK_LEAF set, BVH_LINK_LAST on the last node of the preorder, and its triangle slots
// (leaf_slots); an inner node's link is its skip link, or BVH_LINK_END.
alias BvhNode = vec4<u32>;

// A node decoded: its box, whether it is a leaf, its triangle slots if so, and where the
// traversal goes when the ray misses its box or has tested the leaf.
struct Node {
    lo: vec3<f32>,
    hi: vec3<f32>,
    is_leaf: bool,
    leaf: u32,
    skip: u32,
}

// The frame of the quantized boxes, read once per traversal (lavapipe reloads storage inside a
// loop on every iteration): origin in [0], step in [1].
fn decode_node(n: BvhNode, i: u32, origin: vec3<f32>, step: vec3<f32>) -> Node {
    let lo = origin + vec3<f32>(f32(n.x & 0xffffu), f32(n.x >> 16u), f32(n.y & 0xffffu)) * step;
    let hi = origin + vec3<f32>(f32(n.y >> 16u), f32(n.z & 0xffffu), f32(n.z >> 16u)) * step;
    let is_leaf = (n.w & BVH_LINK_LEAF) != 0u;
    let leaf_skip = select(i + 1u, BVH_END, (n.w & BVH_LINK_LAST) != 0u);
    let inner_skip = select(n.w, BVH_END, n.w == BVH_LINK_END);
    return Node(lo, hi, is_leaf, n.w & (BVH_LINK_LAST - 1u), select(inner_skip, leaf_skip, is_leaf));
}

struct BvhTri {
    v0: vec4<f32>,       // w = bitcast<f32>(index of the triangle in the scene)
    v1: vec4<f32>,
    v2: vec4<f32>,
}

struct Hit {
    t: f32,
    triangle: u32,       // 0xffffffffu: no hit
    u: f32,              // barycentric weight of vertex 1
    v: f32,              // barycentric weight of vertex 2
    slot: u32,           // index into bvh_tris of the hit triangle
}

const NO_HIT: u32 = 0xffffffffu;

// The slots [first, end) of a leaf's triangles in bvh_tris, from its `leaf` word.
fn leaf_slots(leaf: u32) -> vec2<u32> {
    let first = leaf >> LEAF_COUNT_BITS;
    return vec2<u32>(first, first + (leaf & ((1u << LEAF_COUNT_BITS) - 1u)));
}

// A ray's setup for the watertight triangle test of Woop, Benthin and Wald (JCGT 2013): the
// axis along which the direction is largest becomes z (k.z), x and y are chosen so that the
// winding is kept, and s shears the direction onto +z: s = (d[k.x] / d[k.z], d[k.y] / d[k.z],
// 1 / d[k.z]). The sheared z of a point is then its ray parameter t along this (unnormalised) d.
struct RayShear {
    k: vec3<u32>,
    s: vec3<f32>,
}

fn ray_shear(d: vec3<f32>) -> RayShear {
    let a = abs(d);
    var kz = 2u;
    if (a.x > a.y && a.x > a.z) {
        kz = 0u;
    } else if (a.y > a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if (d[kz] < 0.0) {
        let swap = kx;
        kx = ky;
        ky = swap;
    }
    return RayShear(vec3<u32>(kx, ky, kz), vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]));
}

// Watertight ray/triangle test; returns (t, u, v) with u, v the weights of v1 and v2, t = inf
// when missed or outside (tmin, tmax). The three edge functions are computed from the sheared
// vertices alone, so two triangles sharing an edge compute that edge's function from the same
// numbers with opposite signs: a ray through the edge cannot miss both (Möller–Trumbore, used
// before, computes each triangle's edges from its own v0 and let 18 of 726 segments aimed at a
// grid's shared edges through; tests/tests/visibility.rs). Edge values of exactly 0 count
// as inside, as in the paper; its double-precision fallback for them is not used (no f64 on
// lavapipe), so a ray through a shared vertex may hit both triangles, never neither.
// Watertightness needs the edge's vertices to be the same numbers. Meshes placed by their own
// transforms meet at vertices a few ulps apart, with a hairline crack between them that a pixel
// ray of a centred camera can run straight into. Embree's test accepts edge values down to one
// float epsilon of their sum, which widens every triangle by about an ulp of its size and
// closes such cracks, and also hits a ray that grazes a silhouette edge within that margin. So
// every edge is moved out by `crack` (crack_width) in the sheared plane, where an edge function
// divided by its edge's length is the ray's distance from the edge: |edge value| <= crack *
// |edge|_1 is within crack of it. All edges, not only those no other triangle shares bit for
// bit: shared ones would stay exact at silhouettes, where Embree's margin blocks segments
// grazing a block's edge that the GPU would pass.
fn intersect_tri(tri: BvhTri, o: vec3<f32>, ray: RayShear, tmin: f32, tmax: f32, crack: f32) -> vec3<f32> {
    let inf = bitcast<f32>(0x7f800000u);
    let k = ray.k;
    let a = tri.v0.xyz - o;
    let b = tri.v1.xyz - o;
    let c = tri.v2.xyz - o;
    let ax = a[k.x] - ray.s.x * a[k.z];
    let ay = a[k.y] - ray.s.y * a[k.z];
    let bx = b[k.x] - ray.s.x * b[k.z];
    let by = b[k.y] - ray.s.y * b[k.z];
    let cx = c[k.x] - ray.s.x * c[k.z];
    let cy = c[k.y] - ray.s.y * c[k.z];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let eu = crack * (abs(cx - bx) + abs(cy - by));
    let ev = crack * (abs(ax - cx) + abs(ay - cy));
    let ew = crack * (abs(bx - ax) + abs(by - ay));
    if ((u < -eu || v < -ev || w < -ew) && (u > eu || v > ev || w > ew)) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    let det = u + v + w;
    if (det == 0.0) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    let inv_det = 1.0 / det;
    let t = (u * a[k.z] + v * b[k.z] + w * c[k.z]) * ray.s.z * inv_det;
    if (!(t > tmin && t < tmax)) {
        return vec3<f32>(inf, 0.0, 0.0);
    }
    return vec3<f32>(t, v * inv_det, w * inv_det);
}

// The widest crack intersect_tri closes for rays from `o`: CRACK_ULPS float spacings of the
// largest coordinate the test computes with (the scene's, from bvh_frame, plus the origin's),
// which covers separately placed meshes meeting a few ulps apart and the rounding of the sheared
// vertices. Far below the f64 tie oracle's 64 ulps (vplgi_verify::segment), so a ray the GPU
// hits only within the crack of an edge is a tie there, never a disagreement. The node boxes keep
// at least this much room around their triangles (vplgi_gpu::bvh::quantize).
fn crack_width(o: vec3<f32>) -> f32 {
    let lo = abs(bvh_frame[0].xyz);
    let hi = abs(bvh_frame[0].xyz + 65535.0 * bvh_frame[1].xyz);
    let a = abs(o);
    return CRACK_ULPS * 1.1920929e-7 * (max(max(lo.x, lo.y), max(lo.z, max(hi.x, max(hi.y, hi.z)))) + max(a.x, max(a.y, a.z)));
}

// 1 + 2 gamma(3) (Ize, "Robust BVH Ray Traversal", JCGT 2013): the slab distances below are each
// off by a few roundings, so a ray crossing a flat box (a wall's leaf) right at its edge can come
// out just outside it and just outside its neighbour too, a crack between boxes that the
// watertight triangle test cannot close. Scaling `far` by this bound makes the test conservative.
const BOX_SLACK: f32 = 1.0000004;

// Whether the ray segment (tmin, tmax) touches the node's box (conservatively).
fn hits_box(node: Node, o: vec3<f32>, inv_d: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    let t0 = (node.lo - o) * inv_d;
    let t1 = (node.hi - o) * inv_d;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), tmin));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), tmax));
    return near <= far * BOX_SLACK;
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    // The guard of obvhs::ray::safe_inverse: a huge finite value instead of inf, so the slab
    // test never computes inf * 0 = NaN. Rust's signum(0.0) is 1, WGSL's sign(0.0) is 0: select.
    let eps = 1.1920929e-7;
    let s = select(vec3<f32>(1.0), vec3<f32>(-1.0), d < vec3<f32>(0.0));
    return select(1.0 / d, s / eps, abs(d) <= vec3<f32>(eps));
}

// Closest hit along o + t d, t in (tmin, tmax). With any_hit = true, returns the first hit found.
// lavapipe runs every branch of a loop body for all lanes of a SIMD group (visibility.wgsl), so
// the hot loop tests boxes only and a leaf's triangles are tested in a loop of their own, once
// the box loop has found the leaf: with a leaf loop nested in the box loop, every box cost a
// triangle test too. Leaves are still tested in preorder, so the closest hit (ties included:
// the first one found stays) is the same.
fn bvh_trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax_in: f32, any_hit: bool) -> Hit {
    var hit = Hit(tmax_in, NO_HIT, 0.0, 0.0, 0u);
    let inv_d = safe_inverse(d);
    let shear = ray_shear(d);
    let crack = crack_width(o);
    let origin = bvh_frame[0].xyz;
    let step = bvh_frame[1].xyz;
    var i = 0u;
    loop {
        var k = 0u;             // the leaf's triangle slots [k, end) to test
        var end = 0u;
        loop {
            if (i == BVH_END) {
                break;
            }
            let node = decode_node(bvh_node(i), i, origin, step);
            var next = node.skip;
            if (hits_box(node, o, inv_d, tmin, hit.t)) {
                if (!node.is_leaf) {
                    next = i + 1u;
                } else {
                    let slots = leaf_slots(node.leaf);
                    k = slots.x;
                    end = slots.y;
                    i = next;
                    break;
                }
            }
            i = next;
        }
        loop {
            if (k == end) {
                break;
            }
            let tri = bvh_tri(k);
            let r = intersect_tri(tri, o, shear, tmin, hit.t, crack);
            if (r.x < hit.t) {
                hit = Hit(r.x, bitcast<u32>(tri.v0.w), r.y, r.z, k);
                if (any_hit) {
                    return hit;
                }
            }
            k = k + 1u;
        }
        if (i == BVH_END) {
            break;
        }
    }
    return hit;
}

// CpuScene::visible: both ends pushed off their surfaces, the segment between them tested.
fn visible(p: vec3<f32>, np: vec3<f32>, q: vec3<f32>, nq: vec3<f32>, eps: f32) -> bool {
    let a = offset_toward(p, np, q, eps);
    let b = offset_toward(q, nq, p, eps);
    return bvh_trace(a, b - a, SEGMENT_TNEAR, SEGMENT_TFAR, true).triangle == NO_HIT;
}

// CpuScene::visible_toward: along unit direction `dir` to infinity (a directional light).
fn visible_toward(p: vec3<f32>, np: vec3<f32>, dir: vec3<f32>, eps: f32) -> bool {
    let a = offset_toward(p, np, p + dir, eps);
    let inf = bitcast<f32>(0x7f800000u);
    return bvh_trace(a, dir, 0.0, inf, true).triangle == NO_HIT;
}

// CpuScene::visible_from_surface: to a point light, stopping eps short of it.
fn visible_from_surface(p: vec3<f32>, np: vec3<f32>, light: vec3<f32>, eps: f32) -> bool {
    let a = offset_toward(p, np, light, eps);
    let d = light - a;
    let len = length(d);
    return len > eps && bvh_trace(a, d, SEGMENT_TNEAR, 1.0 - eps / len, true).triangle == NO_HIT;
}
