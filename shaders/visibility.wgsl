// include: common/types.wgsl common/bvh.wgsl common/scene.wgsl
// Stage 4, visibility (vplgi-cpu/src/visibility.rs): one thread per row and 32-bit word of the
// bit matrix, i.e. 32 shadow rays, and VISIBILITY_ROW_LANES consecutive threads take the same
// word of as many consecutive rows. The rows are shading-point clusters seeded at evenly spaced
// pixels, so neighbouring rows are neighbouring surfaces: their lanes trace toward the same
// VPLs along similar paths, face the same ones and finish together, where the lanes of one row
// would trace toward unrelated VPLs and wait for the slowest (lavapipe's SIMD groups are 8
// lanes). Pairs facing away from each other get 0 without a ray; both ray ends are pushed off
// their surfaces and the segment between them is tested (any hit).
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
    let lanes = id / VISIBILITY_ROW_LANES;
    let w = lanes % params.words_per_row;
    let local_row = (lanes / params.words_per_row) * VISIBILITY_ROW_LANES + id % VISIBILITY_ROW_LANES;
    if (local_row >= params.row_count) {
        return;
    }
    let r = params.first_row + local_row;
    let a = rows[r];
    // The word's columns; words past the last column (the CPU's u64 padding) stay 0.
    let last = select(0u, min(32u, params.cols - w * 32u), w * 32u < params.cols);
    // The pairs that face each other (visibility::facing) first, in one loop every lane runs in
    // step; the others get 0 without a ray. Picking the next facing pair from this mask later
    // costs one column load, where testing columns one by one inside the traversal loop (as
    // before) ran that inner loop, with its loads, whenever any lane of the SIMD group started a
    // segment: 8-14 % of the conference room's visibility time on lavapipe (two runs each).
    var facing = 0u;
    for (var c = 0u; c < last; c = c + 1u) {
        let e = cols[w * 32u + c];
        let ae = e.position.xyz - a.position.xyz;
        let bound = FACING_COS * length(ae);
        if (dot(a.normal.xyz, ae) > bound && dot(e.normal.xyz, ae) < -bound) {
            facing = facing | (1u << c);
        }
    }
    // Each segment is CpuScene::shadow_segment: both ends pushed off their surfaces, any hit in
    // (SEGMENT_TNEAR, SEGMENT_TFAR). A facing pair's ends lie on the positive side of each
    // other's surface, so offset_toward pushes each along its own normal (side +1, the same
    // floats): the origin is the row's alone.
    let o = a.position.xyz + a.normal.xyz * params.eps;
    // lavapipe (Mesa 22.3) runs every branch of a loop body for all 8 lanes of a SIMD group,
    // masked: a branch no lane takes costs as much as one every lane takes. So the rare work is kept
    // out of the hot loop: the inner loop only tests boxes, and starting a segment and testing a
    // leaf's triangles happen once per round of the outer loop. A lane that meets a leaf keeps it
    // pending and goes on testing boxes until it meets a second one, so it does not idle while
    // the other lanes of its group finish their boxes. The bits are those of one loop: any hit
    // does not depend on the order in which leaves are tested.
    var bits = 0u;
    var b = 0u;                 // the column bit of the segment in flight
    var node = BVH_END;         // the segment's next node; BVH_END: none left
    var tri = 0u;               // its pending leaf's triangles still to test: slots [tri, tri_end)
    var tri_end = 0u;
    var d = vec3<f32>(0.0);
    var inv_d = vec3<f32>(0.0);
    let origin = bvh_frame[0].xyz;
    let step = bvh_frame[1].xyz;
    let crack = crack_width(o);
    loop {
        if (node == BVH_END && tri == tri_end) {
            if (facing == 0u) {
                break;
            }
            b = firstTrailingBit(facing);
            facing = facing & (facing - 1u);
            let e = cols[w * 32u + b];
            d = (e.position.xyz + e.normal.xyz * params.eps) - o;
            inv_d = safe_inverse(d);
            node = 0u;
            // Visible until a triangle blocks it.
            bits = bits | (1u << b);
        }
        loop {
            if (node == BVH_END) {
                break;
            }
            let n = decode_node(bvh_node(node), node, origin, step);
            var next = n.skip;
            if (hits_box(n, o, inv_d, SEGMENT_TNEAR, SEGMENT_TFAR)) {
                if (!n.is_leaf) {
                    next = node + 1u;
                } else if (tri < tri_end) {
                    // A second leaf: the pending one is tested first, this box again after it.
                    break;
                } else {
                    let slots = leaf_slots(n.leaf);
                    tri = slots.x;
                    tri_end = slots.y;
                }
            }
            node = next;
        }
        if (tri < tri_end) {
            let shear = ray_shear(d);
            loop {
                if (tri == tri_end) {
                    break;
                }
                if (intersect_tri(bvh_tri(tri), o, shear, SEGMENT_TNEAR, SEGMENT_TFAR, crack).x < SEGMENT_TFAR) {
                    // Blocked: the bit is cleared and the segment ends.
                    bits = bits & ~(1u << b);
                    tri_end = tri;
                    node = BVH_END;
                } else {
                    tri = tri + 1u;
                }
            }
        }
    }
    words[local_row * params.words_per_row + w] = bits;
}
