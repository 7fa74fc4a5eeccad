// include: common/types.wgsl common/rng.wgsl common/sampling.wgsl common/bsdf.wgsl common/photons.wgsl
// Stage caustics (vplgi-cpu/src/caustics.rs): per shading point, the caustic radiance from the
// k nearest photons of the caustic map, L = ρ / π Σ_{d_i < r} a_i Φ_i / (π r²), r the k-th
// nearest's distance (or max radius), photons whose normals are within 60° of the point's. The
// walk of the shared kd-tree (vplgi_shared::photon_tree) is the CPU's, node for node: nearer
// child first, pruned by box distance, a max-heap on (distance², index), stopped after the same
// CAUSTIC_VISITS (common/photons.wgsl). One thread per sample; the host averages each pixel's
// samples.

struct Params {
    count: u32,       // samples
    k: u32,
    max_bounce: u32,
    max_r2: f32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> photons: array<Vpl>;
@group(0) @binding(2) var<storage, read> nodes: array<PhotonNode>;
@group(0) @binding(3) var<storage, read> points: array<ShadingPoint>;
// Each material's BSDF in white, for a rough-metal receiver's lobe.
@group(0) @binding(4) var<storage, read> lobes: array<BsdfRecord>;
// rgb: radiance; w: 1 where the walk stopped at the visit budget.
@group(0) @binding(5) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.count) {
        return;
    }
    let sp = points[s];
    if (sp.triangle == MISS) {
        out[s] = vec4<f32>(0.0);
        return;
    }
    let p = sp.position;
    let n = sp.normal;
    let k = params.k;
    let found = nearest(p, n, k, params.max_r2);
    let r2 = nearest_r2(found, k, params.max_r2);
    // shade::receiver: only rough metal weighs its photons by a lobe; any other surface (a
    // mirror a chain stopped at included) is shaded as diffuse.
    var receiver = BsdfRecord(vec3<f32>(1.0), BSDF_DIFFUSE, 0.0, 0.0, 0.0, 0u);
    if (sp.material < arrayLength(&lobes)) {
        receiver = lobes[sp.material];
    }
    let glossy = bsdf_is_glossy(receiver);
    var sum = vec3<f32>(0.0);
    for (var e = 0u; e < found.found; e = e + 1u) {
        let photon = photons[heap_i[e]];
        if (heap_d2[e] >= r2 || photon.bounce > params.max_bounce) {
            continue;
        }
        var a = 1.0;
        if (glossy) {
            a = bsdf_lobe(receiver, n, sp.view, photon.incoming);
        }
        sum = sum + photon.flux * a;
    }
    out[s] = vec4<f32>(sum * sp.albedo / (PI * PI * r2), select(0.0, 1.0, found.truncated));
}
