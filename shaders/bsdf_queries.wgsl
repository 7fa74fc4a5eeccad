// include: common/types.wgsl common/sampling.wgsl common/bsdf.wgsl
// Diagnostic kernel: common/bsdf.wgsl's eval, pdf and sample on a list of queries, for the twin
// test against vplgi-shared/src/bsdf.rs (crates/vplgi-gpu/src/bsdf.rs runs it).

struct Params {
    count: u32,
    radiance: u32,
    pad0: u32,
    pad1: u32,
}

struct Query {
    bsdf: BsdfRecord,
    wi: vec3<f32>,
    pad0: u32,
    wo: vec3<f32>,
    pad1: u32,
    // (u1, u.x, u.y): the sample's uniform numbers
    u: vec3<f32>,
    pad2: u32,
}

struct Answer {
    eval: vec3<f32>,
    pdf: f32,
    wo: vec3<f32>,
    sample_pdf: f32,
    weight: vec3<f32>,
    // bit 0: a sample was made; bit 1: from a delta lobe
    flags: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> queries: array<Query>;
@group(0) @binding(2) var<storage, read_write> answers: array<Answer>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    let q = queries[i];
    let s = bsdf_sample(q.bsdf, q.wi, q.u.x, q.u.yz, params.radiance != 0u);
    answers[i] = Answer(
        bsdf_eval(q.bsdf, q.wi, q.wo),
        bsdf_pdf(q.bsdf, q.wi, q.wo),
        s.wo,
        s.pdf,
        s.weight,
        s.valid | (s.delta << 1u),
    );
}
