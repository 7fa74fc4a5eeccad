// include: common/types.wgsl common/rng.wgsl
// Diagnostic kernel: `draws` numbers of the stream (seed, stream, first_index + i) per thread,
// for the bit-identity test against vplgi_types::Rng.

struct Params {
    seed: u32,
    stream: u32,
    first_index: u32,
    count: u32,
    draws: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    var r = rng_new(params.seed, params.stream, params.first_index + i);
    for (var k = 0u; k < params.draws; k = k + 1u) {
        out[i * params.draws + k] = rng_next_u32(&r);
    }
}
