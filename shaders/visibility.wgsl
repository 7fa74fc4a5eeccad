// Stage 4, visibility (vplgi-cpu/src/visibility.rs): one thread per row and 32-bit word of the
// bit matrix, i.e. 32 shadow rays. Pairs facing away from each other get 0 without a ray; both
// ray ends are pushed off their surfaces and the segment between them is tested (any hit).
// Words are little-endian halves of the CPU's u64 words, so the bytes are identical.

struct Params {
    rows: u32,
    cols: u32,
    words_per_row: u32,   // u32 words per row (twice the CPU's u64 words)
    first_row: u32,       // first row of this dispatch in the bound window of `rows`
    row_count: u32,       // rows in this dispatch
    eps: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(3) var<storage, read> rows: array<Endpoint>;
@group(0) @binding(4) var<storage, read> cols: array<Endpoint>;
@group(0) @binding(5) var<storage, read_write> words: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let id = thread_index(gid, groups);
    if (id >= params.row_count * params.words_per_row) {
        return;
    }
    let r = params.first_row + id / params.words_per_row;
    let w = id % params.words_per_row;
    let a = rows[r];
    // The word's columns; words past the last column (the CPU's u64 padding) stay 0.
    let last = select(0u, min(32u, params.cols - w * 32u), w * 32u < params.cols);
    // The 32 segments are chained in one loop whose state is (b, node): when one segment's
    // traversal ends, the next starts in the same iteration count, so a SIMD lane that finished
    // does not idle until the slowest lane of its group finishes the same segment (bvh.wgsl).
    // Each segment is CpuScene::visible: both ends pushed off their surfaces, any hit in
    // (SEGMENT_TNEAR, SEGMENT_TFAR).
    var bits = 0u;
    var b = 0u;                 // the column bit in flight, or the next to start
    var node = BVH_END;         // BVH_END: no segment in flight
    var o = vec3<f32>(0.0);
    var inv_d = vec3<f32>(0.0);
    var shear = RayShear(vec3<u32>(0u), vec3<f32>(0.0));
    let origin = bvh_frame[0].xyz;
    let step = bvh_frame[1].xyz;
    loop {
        if (node == BVH_END) {
            // Start the next pair that faces (visibility::facing); the others get 0 without a ray.
            loop {
                if (b >= last) {
                    break;
                }
                let e = cols[w * 32u + b];
                let ae = e.position.xyz - a.position.xyz;
                let bound = FACING_COS * length(ae);
                if (dot(a.normal.xyz, ae) > bound && dot(e.normal.xyz, ae) < -bound) {
                    o = offset_toward(a.position.xyz, a.normal.xyz, e.position.xyz, params.eps);
                    let d = offset_toward(e.position.xyz, e.normal.xyz, a.position.xyz, params.eps) - o;
                    inv_d = safe_inverse(d);
                    shear = ray_shear(d);
                    node = 0u;
                    break;
                }
                b = b + 1u;
            }
            if (node == BVH_END) {
                break;
            }
        }
        let n = decode_node(bvh_node(node), node, origin, step);
        var next = n.skip;
        var blocked = false;
        if (hits_box(n, o, inv_d, SEGMENT_TNEAR, SEGMENT_TFAR)) {
            if (!n.is_leaf) {
                next = node + 1u;
            } else if (leaf_blocks(n.leaf, o, shear, SEGMENT_TNEAR, SEGMENT_TFAR)) {
                blocked = true;
                next = BVH_END;
            }
        }
        if (next == BVH_END) {
            bits = bits | select(1u << b, 0u, blocked);
            b = b + 1u;
        }
        node = next;
    }
    words[id] = bits;
}
