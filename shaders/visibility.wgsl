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

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(3) var<storage, read> rows: array<Endpoint>;
@group(0) @binding(4) var<storage, read> cols: array<Endpoint>;
@group(0) @binding(5) var<storage, read_write> words: array<u32>;
@group(0) @binding(6) var<storage, read> bvh_nodes_hi: array<BvhNode>;
@group(0) @binding(7) var<storage, read> bvh_tris_hi: array<BvhTri>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let id = thread_index(gid, groups);
    if (id >= params.row_count * params.words_per_row) {
        return;
    }
    let r = params.first_row + id / params.words_per_row;
    let w = id % params.words_per_row;
    let a = rows[r];
    var bits = 0u;
    for (var b = 0u; b < 32u; b = b + 1u) {
        let c = w * 32u + b;
        if (c >= params.cols) {
            break;
        }
        let e = cols[c];
        let d = e.position.xyz - a.position.xyz;
        // visibility::facing
        if (dot(a.normal.xyz, d) > 0.0 && dot(e.normal.xyz, d) < 0.0) {
            if (visible(a.position.xyz, a.normal.xyz, e.position.xyz, e.normal.xyz, params.eps)) {
                bits = bits | (1u << b);
            }
        }
    }
    words[id] = bits;
}
