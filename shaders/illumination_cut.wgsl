// include: common/types.wgsl common/photons.wgsl
// Stage illumination_cut (vplgi-cpu/src/illumination_cut.rs): per photon-tree node, its
// representative (the member nearest a point just off its box's centre, ties to the lower
// index), radius
// r_p (largest box side, floored at min_radius) and Eq. 3's Ẽ_p = Σ max(0, ω_i·n_p) Φ_i / r_p²;
// and the density estimate E = Σ Φ / (π r²) at given points (the cut nodes' representatives), r
// at least min_radius.
//
// node_estimates runs two passes, each over the members of every node in ranges [first, end) of
// its member list, one dispatch per range (a root's members are the whole map, beyond
// lavapipe's 65,535 loop iterations): phase 0 finds the representative, phase 1 sums Ẽ. Running
// values carry over in `sums`, and a node's range that reaches its last member finishes that
// phase. Sums run in member order, as the CPU's.

struct Params {
    count: u32,       // nodes, or points for `densities`
    first: u32,       // member range of this dispatch
    end: u32,
    phase: u32,       // 0 representative, 1 estimate
    min_radius: f32,
    k: u32,
    max_r2: f32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> photons: array<Vpl>;
@group(0) @binding(2) var<storage, read> nodes: array<PhotonNode>;
// Running values per node: phase 0 (best d², best index bits); phase 1 Σ.
@group(0) @binding(3) var<storage, read_write> sums: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> estimates: array<CutNode>;
@group(0) @binding(5) var<storage, read> points: array<Endpoint>;
// rgb: irradiance; w: 1 where the search stopped at the visit budget.
@group(0) @binding(6) var<storage, read_write> density: array<vec4<f32>>;

@compute @workgroup_size(64)
fn node_estimates(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.count) {
        return;
    }
    let node = nodes[i];
    if (params.first >= node.count && !(node.count == 0u && params.first == 0u)) {
        return;
    }
    let j0 = node.first + params.first;
    let j1 = node.first + min(node.count, params.end);
    let last = node.count <= params.end;
    let fresh = params.first == 0u;
    if (params.phase == 0u) {
        // illumination_cut::centre_fraction: just off the centre.
        let c = node.lo + (node.hi - node.lo) * (vec3<f32>(0.5) + vec3<f32>(1.0, 2.0, 3.0) * CUT_CENTRE_SKEW);
        var best_d2 = bitcast<f32>(0x7f800000u);
        var best = node.first;
        if (!fresh) {
            best_d2 = sums[i].x;
            best = bitcast<u32>(sums[i].y);
        }
        for (var j = j0; j < j1; j = j + 1u) {
            let d = photons[j].position - c;
            let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
            if (d2 < best_d2) {
                best_d2 = d2;
                best = j;
            }
        }
        sums[i] = vec4<f32>(best_d2, bitcast<f32>(best), 0.0, 0.0);
        if (last) {
            var e: CutNode;
            e.radius = params.min_radius;
            if (node.count > 0u) {
                let rep = photons[best];
                e.position = rep.position;
                e.normal = rep.normal;
                let side = node.hi - node.lo;
                e.radius = max(max(side.x, max(side.y, side.z)), params.min_radius);
            }
            estimates[i] = e;
        }
        return;
    }
    let n = estimates[i].normal;
    var s = select(sums[i], vec4<f32>(0.0), fresh);
    for (var j = j0; j < j1; j = j + 1u) {
        let m = photons[j];
        s = vec4<f32>(s.xyz + max(dot(m.incoming, n), 0.0) * m.flux, 0.0);
    }
    sums[i] = s;
    if (last) {
        let r = estimates[i].radius;
        estimates[i].irradiance = s.xyz / (r * r);
    }
}

@compute @workgroup_size(64)
fn densities(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.count) {
        return;
    }
    let e = points[s];
    let found = nearest(e.position.xyz, e.normal.xyz, params.k, params.max_r2);
    let r2 = max(nearest_r2(found, params.k, params.max_r2), params.min_radius * params.min_radius);
    var sum = vec3<f32>(0.0);
    for (var q = 0u; q < found.found; q = q + 1u) {
        // density: a photon at the point itself (the representative) is left out.
        if (heap_d2[q] < r2 && heap_d2[q] > 0.0) {
            sum = sum + photons[heap_i[q]].flux;
        }
    }
    density[s] = vec4<f32>(sum / (PI * r2), select(0.0, 1.0, found.truncated));
}
