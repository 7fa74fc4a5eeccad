// include: common/types.wgsl common/rng.wgsl common/sampling.wgsl common/bsdf.wgsl
// Stage caustics (vplgi-cpu/src/caustics.rs): per shading point, the caustic radiance from the
// k nearest photons of the caustic map, L = ρ / π Σ_{d_i < r} a_i Φ_i / (π r²), r the k-th
// nearest's distance (or max radius), photons whose normals are within 60° of the point's. The
// walk of the shared kd-tree (vplgi_shared::photon_tree) is the CPU's, node for node: nearer
// child first, pruned by box distance, a max-heap on (distance², index), stopped after the same
// CAUSTIC_VISITS. One thread per sample; the host averages each pixel's samples.

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

var<private> heap_d2: array<f32, MAX_CAUSTIC_K>;
var<private> heap_i: array<u32, MAX_CAUSTIC_K>;

// photon_tree::box_distance2
fn box_distance2(node: PhotonNode, p: vec3<f32>) -> f32 {
    if (node.count == 0u) {
        return bitcast<f32>(0x7f800000u);
    }
    let d = max(max(node.lo - p, p - node.hi), vec3<f32>(0.0));
    return d.x * d.x + d.y * d.y + d.z * d.z;
}

fn heap_less(ad: f32, ai: u32, bd: f32, bi: u32) -> bool {
    return ad < bd || (ad == bd && ai < bi);
}

fn heap_swap(a: u32, b: u32) {
    let d = heap_d2[a];
    let i = heap_i[a];
    heap_d2[a] = heap_d2[b];
    heap_i[a] = heap_i[b];
    heap_d2[b] = d;
    heap_i[b] = i;
}

// caustics::offer: the max-heap of the k smallest (distance², index), `len` entries so far.
fn offer(len: u32, k: u32, d2: f32, j: u32) -> u32 {
    if (len < k) {
        var i = len;
        heap_d2[i] = d2;
        heap_i[i] = j;
        while (i > 0u) {
            let parent = (i - 1u) / 2u;
            if (!heap_less(heap_d2[parent], heap_i[parent], heap_d2[i], heap_i[i])) {
                break;
            }
            heap_swap(parent, i);
            i = parent;
        }
        return len + 1u;
    }
    if (!heap_less(d2, j, heap_d2[0], heap_i[0])) {
        return len;
    }
    heap_d2[0] = d2;
    heap_i[0] = j;
    var i = 0u;
    loop {
        let l = 2u * i + 1u;
        let r = 2u * i + 2u;
        var largest = i;
        if (l < k && heap_less(heap_d2[largest], heap_i[largest], heap_d2[l], heap_i[l])) {
            largest = l;
        }
        if (r < k && heap_less(heap_d2[largest], heap_i[largest], heap_d2[r], heap_i[r])) {
            largest = r;
        }
        if (largest == i) {
            break;
        }
        heap_swap(i, largest);
        i = largest;
    }
    return len;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.count) {
        return;
    }
    let sp = points[s];
    if (sp.triangle == MISS || arrayLength(&photons) == 0u || params.k == 0u) {
        out[s] = vec4<f32>(0.0);
        return;
    }
    let p = sp.position;
    let n = sp.normal;
    let k = params.k;
    let len = arrayLength(&nodes);
    var stack: array<u32, PHOTON_STACK>;
    stack[0] = 0u;
    var top = 1u;
    var visits = 0u;
    var found = 0u;
    var truncated = 0.0;
    while (top > 0u) {
        if (visits >= CAUSTIC_VISITS) {
            truncated = 1.0;
            break;
        }
        top = top - 1u;
        let i = stack[top];
        visits = visits + 1u;
        let node = nodes[i];
        let bound = select(params.max_r2, heap_d2[0], found == k);
        if (box_distance2(node, p) > bound) {
            continue;
        }
        if (2u * i + 1u >= len) {
            for (var j = node.first; j < node.first + node.count; j = j + 1u) {
                visits = visits + 1u;
                let photon = photons[j];
                if (dot(photon.normal, n) <= CAUSTIC_NORMAL_COS) {
                    continue;
                }
                let d = photon.position - p;
                let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
                if (d2 < params.max_r2) {
                    found = offer(found, k, d2, j);
                }
            }
            continue;
        }
        let l = 2u * i + 1u;
        let r = 2u * i + 2u;
        let dl = box_distance2(nodes[l], p);
        let dr = box_distance2(nodes[r], p);
        var near = l;
        var far = r;
        if (dr < dl) {
            near = r;
            far = l;
        }
        stack[top] = far;
        stack[top + 1u] = near;
        top = top + 2u;
    }
    let r2 = select(params.max_r2, heap_d2[0], found == k);
    // shade::receiver: only rough metal weighs its photons by a lobe; any other surface (a
    // mirror a chain stopped at included) is shaded as diffuse.
    var receiver = BsdfRecord(vec3<f32>(1.0), BSDF_DIFFUSE, 0.0, 0.0, 0.0, 0u);
    if (sp.material < arrayLength(&lobes)) {
        receiver = lobes[sp.material];
    }
    let glossy = bsdf_is_glossy(receiver);
    var sum = vec3<f32>(0.0);
    for (var e = 0u; e < found; e = e + 1u) {
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
    out[s] = vec4<f32>(sum * sp.albedo / (PI * PI * r2), truncated);
}
