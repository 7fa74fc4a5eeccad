// include: common/types.wgsl
// Glue between the stages of the chained GPU frame (crates/vplgi-gpu/src/backend.rs), the twin
// of the bookkeeping in crates/vplgi-cpu/src/backend.rs: which shading points hit something and
// their rows, clustering inputs, lights for shading, visibility columns.

struct Params {
    n: u32,          // items of the dispatch: samples of the chunk, VPLs, lights
    k: u32,          // cluster_lights: clusters
    first: u32,      // first sample of the bound `sps` chunk (sp_flags, sp_compact); first VPL of
                     // a cluster_lights range (a range: see GpuBackend::vpl_lights)
    end: u32,        // cluster_lights: the range's end
    hit_first: u32,  // sp_compact: first hit of the bound `endpoints` window
    hit_count: u32,  // sp_compact: hits in that window
    phase: u32,      // cluster_lights: 0 the sums, 1 the disk's spread or the polygon's support
    max_bounce: u32, // vpl_lights: VPLs deposited at more surfaces carry no flux
    shape: u32,      // cluster_lights: LIGHT_SHAPE_* of the lights
    pad1: u32,
    pad2: u32,
    pad3: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> sps: array<ShadingPoint>;
@group(0) @binding(2) var<storage, read_write> flags: array<u32>;
@group(0) @binding(3) var<storage, read> offsets: array<u32>;
@group(0) @binding(4) var<storage, read_write> row_of: array<u32>;
@group(0) @binding(5) var<storage, read_write> endpoints: array<Endpoint>;
@group(0) @binding(6) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(8) var<storage, read> reps: array<u32>;
@group(0) @binding(9) var<storage, read_write> lights: array<VplLight>;
// cluster_lights' running sums per cluster: (flux, weight), (weighted position, spread), and
// the polygon's support in directions 0-3 and 4-7.
@group(0) @binding(10) var<storage, read_write> light_sums: array<vec4<f32>>;
// cluster_lights_finish: the polygon lights' outlines (vplgi_types::LightOutline).
@group(0) @binding(11) var<storage, read_write> outlines: array<vec4<f32>>;

// 1 for a shading point that hit a surface (sps holds a chunk of samples from params.first).
@compute @workgroup_size(64)
fn sp_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    flags[params.first + i] = select(0u, 1u, sps[i].triangle != MISS);
}

// Hits, numbered by the scan of the flags: their row and their Endpoint (clustering input), for
// the hits inside the bound window of `endpoints` (the host runs every chunk x window pair).
@compute @workgroup_size(64)
fn sp_compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let sp = sps[i];
    let g = params.first + i;
    if (sp.triangle == MISS) {
        row_of[g] = MISS;
        return;
    }
    let r = offsets[g];
    row_of[g] = r;
    if (r >= params.hit_first && r - params.hit_first < params.hit_count) {
        endpoints[r - params.hit_first] = Endpoint(vec4<f32>(sp.position, 0.0), vec4<f32>(sp.normal, 0.0));
    }
}

// VPLs as clustering points.
@compute @workgroup_size(64)
fn vpl_endpoints(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let v = vpls[i];
    endpoints[i] = Endpoint(vec4<f32>(v.position, 0.0), vec4<f32>(v.normal, 0.0));
}

// One light per VPL; VPLs deposited at more than params.max_bounce surfaces carry no flux (the
// lights of a bias-compensation level).
@compute @workgroup_size(64)
fn vpl_lights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let v = vpls[i];
    let flux = select(v.flux, vec3<f32>(0.0), v.bounce > params.max_bounce);
    lights[i] = VplLight(vec4<f32>(v.position, 0.0), vec4<f32>(v.normal, 0.0), vec4<f32>(flux, 0.0), vec4<f32>(v.incoming, bitcast<f32>(v.material)));
}

// Which of the VPLs base .. base + 31 (below `end`) belong to cluster k, as bits. The loops over
// a cluster's members test 32 labels in step, then visit the set bits in ascending order (the
// same order as one VPL after the other): lavapipe runs a loop's body for all lanes whenever one
// lane needs it, so a label test and a member's loads in one loop would load every VPL's record
// for every cluster.
fn members_in_block(k: u32, base: u32, end: u32) -> u32 {
    var found = 0u;
    for (var j = 0u; j < 32u; j = j + 1u) {
        let i = min(base + j, end - 1u);
        found = found | select(0u, 1u << j, base + j < end && labels[i] == k);
    }
    return found;
}

// One light per VPL cluster: its representative, carrying the members' flux summed in VPL
// order (the CPU's order, so the sums agree bit for bit). O(K N) label tests, 32 at a time, and a
// member's record loaded only for its own cluster (members_in_block); deterministic. The
// VPLs are read in ranges, each dispatch continuing the running sums of the one before (the
// same sequential sums, cut: lavapipe stops an invocation's loops after 65,535 iterations).
// Disk lights (vplgi_shared::disk::radius2) also sum, in the same order, the members' flux
// weights and weighted positions, then (pass 1) their weighted squared distances in the plane of
// the representative's normal from the weighted centre: R² is twice their mean. Polygon lights
// (vplgi_shared::polygon::support) take instead, in pass 1, the members' largest offsets from the
// representative in the 8 directions of its plane.
@compute @workgroup_size(64)
fn cluster_lights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    var a = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    if (params.first > 0u) {
        a = light_sums[4u * k];
        b = light_sums[4u * k + 1u];
    }
    if (params.phase == 0u) {
        var flux = a.xyz;
        var weight = a.w;
        var moment = b.xyz;
        for (var base = params.first; base < params.end; base = base + 32u) {
            var found = members_in_block(k, base, params.end);
            while (found != 0u) {
                let v = vpls[base + firstTrailingBit(found)];
                found = found & (found - 1u);
                flux = flux + v.flux;
                let w = member_weight(v.flux);
                weight = weight + w;
                moment = moment + v.position * w;
            }
        }
        a = vec4<f32>(flux, weight);
        b = vec4<f32>(moment, 0.0);
    } else {
        // The sums are complete: pass 0 has read every VPL.
        let all = light_sums[4u * k];
        let sums = light_sums[4u * k + 1u];
        a = all;
        if (params.shape == LIGHT_SHAPE_POLYGON) {
            polygon_support(k);
            b = sums;
        } else if (all.w > 0.0) {
            let centre = sums.xyz / all.w;
            let n = vpls[reps[k]].normal;
            var spread = 0.0;
            if (params.first > 0u) {
                spread = sums.w;
            }
            for (var base = params.first; base < params.end; base = base + 32u) {
                var found = members_in_block(k, base, params.end);
                while (found != 0u) {
                    let v = vpls[base + firstTrailingBit(found)];
                    found = found & (found - 1u);
                    spread = spread + member_weight(v.flux) * in_plane2(v.position - centre, n);
                }
            }
            b = vec4<f32>(sums.xyz, spread);
        } else {
            b = sums;
        }
    }
    light_sums[4u * k] = a;
    light_sums[4u * k + 1u] = b;
}

// polygon::support of cluster k's members around its representative, continuing the maxima of
// the ranges before (light_sums[4k + 2], [4k + 3]).
fn polygon_support(k: u32) {
    let r = vpls[reps[k]];
    let u = polygon_directions(r.normal);
    var lo = vec4<f32>(0.0);
    var hi = vec4<f32>(0.0);
    if (params.first > 0u) {
        lo = light_sums[4u * k + 2u];
        hi = light_sums[4u * k + 3u];
    }
    for (var base = params.first; base < params.end; base = base + 32u) {
        var found = members_in_block(k, base, params.end);
        while (found != 0u) {
            let v = vpls[base + firstTrailingBit(found)];
            found = found & (found - 1u);
            if (member_weight(v.flux) > 0.0) {
                let d = v.position - r.position;
                lo = max(lo, vec4<f32>(dot(u[0], d), dot(u[1], d), dot(u[2], d), dot(u[3], d)));
                hi = max(hi, vec4<f32>(dot(u[4], d), dot(u[5], d), dot(u[6], d), dot(u[7], d)));
            }
        }
    }
    light_sums[4u * k + 2u] = lo;
    light_sums[4u * k + 3u] = hi;
}

// polygon::directions
fn polygon_directions(normal: vec3<f32>) -> array<vec3<f32>, 8> {
    let t = disk_perpendicular(normal);
    let b = cross(normal, t);
    let h = 0.70710677;
    return array<vec3<f32>, 8>(t, (t + b) * h, b, (b - t) * h, -t, -(t + b) * h, -b, (t - b) * h);
}

// polygon::Outline::clipped: the part of the outline `v` (`count` vertices) with dot(q, d) <= s,
// a vertex within eps of the line counting as on it.
fn outline_clipped(v: array<vec2<f32>, 8>, count: u32, d: vec2<f32>, s: f32, eps: f32, out_count: ptr<function, u32>) -> array<vec2<f32>, 8> {
    var out: array<vec2<f32>, 8>;
    var n = 0u;
    for (var i = 0u; i < count; i = i + 1u) {
        let a = v[i];
        let b = v[(i + 1u) % count];
        let da = dot(d, a) - s;
        let db = dot(d, b) - s;
        let a_in = da <= eps;
        let b_in = db <= eps;
        if (a_in && n < 8u) {
            out[n] = a;
            n = n + 1u;
        }
        if (a_in != b_in && min(da, db) < -eps && n < 8u) {
            out[n] = a + (b - a) * (da / (da - db));
            n = n + 1u;
        }
    }
    *out_count = n;
    return out;
}

// polygon::Outline::new and ::area, placed in space as the light's LightOutline. Returns the area.
fn polygon_outline(k: u32, centre: vec3<f32>, normal: vec3<f32>) -> f32 {
    let lo = light_sums[4u * k + 2u];
    let hi = light_sums[4u * k + 3u];
    var v: array<vec2<f32>, 8>;
    v[0] = vec2<f32>(lo.x, -hi.z);
    v[1] = vec2<f32>(lo.x, lo.z);
    v[2] = vec2<f32>(-hi.x, lo.z);
    v[3] = vec2<f32>(-hi.x, -hi.z);
    var count = 4u;
    let largest = max(max(max(lo.x, lo.y), max(lo.z, lo.w)), max(max(hi.x, hi.y), max(hi.z, hi.w)));
    let eps = POLYGON_CUT_TOLERANCE * largest;
    let h = 0.70710677;
    v = outline_clipped(v, count, vec2<f32>(h, h), lo.y, eps, &count);
    v = outline_clipped(v, count, vec2<f32>(-h, h), lo.w, eps, &count);
    v = outline_clipped(v, count, vec2<f32>(-h, -h), hi.y, eps, &count);
    v = outline_clipped(v, count, vec2<f32>(h, -h), hi.w, eps, &count);
    var twice = 0.0;
    for (var i = 0u; i < count; i = i + 1u) {
        let a = v[i];
        let b = v[(i + 1u) % count];
        twice = twice + (a.x * b.y - a.y * b.x);
    }
    let area = max(0.5 * twice, 0.0);
    let t = disk_perpendicular(normal);
    let b = cross(normal, t);
    for (var i = 0u; i < POLYGON_SIDES; i = i + 1u) {
        var out = vec4<f32>(0.0);
        if (i < count && area > 0.0) {
            out = vec4<f32>(centre + t * v[i].x + b * v[i].y, area);
        }
        outlines[k * POLYGON_SIDES + i] = out;
    }
    return area;
}

// The lights from the complete sums.
@compute @workgroup_size(64)
fn cluster_lights_finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let a = light_sums[4u * k];
    let b = light_sums[4u * k + 1u];
    let r = vpls[reps[k]];
    var radius2 = 0.0;
    // VplLight::exact, in the normal's w.
    var exact = 0u;
    if (params.shape == LIGHT_SHAPE_POLYGON) {
        let area = polygon_outline(k, r.position, r.normal);
        if (area > 0.0) {
            radius2 = area / PI;
            exact = EXACT_POLYGON;
        }
    } else {
        if (params.shape != LIGHT_SHAPE_POINT && a.w > 0.0) {
            radius2 = 2.0 * b.w / a.w;
        }
        exact = select(0u, EXACT_DISK, params.shape == LIGHT_SHAPE_DISK_EXACT && radius2 > 0.0);
    }
    lights[k] = VplLight(vec4<f32>(r.position, radius2), vec4<f32>(r.normal, bitcast<f32>(exact)), vec4<f32>(a.xyz, 0.0), vec4<f32>(r.incoming, bitcast<f32>(r.material)));
}

// disk::member_weight
fn member_weight(flux: vec3<f32>) -> f32 {
    return flux.x + flux.y + flux.z;
}

// disk::in_plane2
fn in_plane2(d: vec3<f32>, n: vec3<f32>) -> f32 {
    let along = dot(n, d);
    return max(dot(d, d) - along * along, 0.0);
}

// Visibility columns: the lights' positions and normals.
@compute @workgroup_size(64)
fn light_endpoints(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    endpoints[i] = Endpoint(lights[i].position, lights[i].normal);
}
