// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/sampling.wgsl common/lights.wgsl common/scene.wgsl common/bsdf.wgsl
// Stage 5, shade (vplgi-cpu/src/shade.rs): per pixel, the mean over its spp shading points of
// emitted + direct + indirect radiance, indirect by Eq. 6 with the clamped geometry term and
// the visibility of Eq. 8 / 9-10 (mode 1) or the point's own row (mode 0).
//
// Two entry points. `shade_lights` sums the VPL lights of every shading point, SHADE_POINTS points per
// invocation, over a range of lights per dispatch (running sums carried between dispatches);
// `shade_finish` adds emission and direct light per pixel. Splitting them is for lavapipe, which
// is where this kernel is measured: its storage-buffer loads are a loop over the 8 lanes with a
// bounds check per lane and component (about 75 instructions per vec4 per lane, where the light's
// arithmetic is about 6), even when every lane reads the same light. So a light is loaded once
// for SHADE_POINTS shading points, and the per-point state lives in arrays indexed only by loops of
// constant trip count (SHADE_POINTS, and ROWS fixed per pipeline), which are unrolled into registers;
// a dynamically indexed private array would stay in memory, read lane by lane. On a GPU the same
// shape amortises the light's loads over four points and keeps the state in registers.

struct Params {
    spp: u32,
    seed: u32,
    direct_samples: u32,
    f: u32,               // fuzzy row stride (mode 1)
    mode: u32,            // 0: own row (row_of[i] - first_row), 1: fuzzy clusters
    first_row: u32,
    words_per_row: u32,   // u32 words per visibility row
    first_pixel: u32,
    pixel_count: u32,
    g_max: f32,
    eps: f32,
    sp_first: u32,        // first sample held by the bound `sps` chunk
    light_first: u32,     // this dispatch's VPL lights: light_first .. light_end
    light_end: u32,
    direct: u32,          // shade_finish: 1 adds emission and direct light, 0 the VPLs' only
    sample_first: u32,    // shade_finish: this dispatch's samples of each pixel, first .. end
    sample_end: u32,
}

// Visibility rows per shading point: F in mode 1, 1 in mode 0; a pipeline per value, so that the
// loops over rows have a constant trip count.
override ROWS: u32 = 1u;
// Whether the lights may be exact disks or polygons (VplLight::exact): a pipeline of its own, so
// that point and Eq. 2 frames do not carry the exact form factors' code in their light loop (on
// lavapipe that alone made `shade` several times slower).
override EXACT_SHAPES: bool = false;
// Whether the scene has glossy surfaces, whose lobes (shade::lobe_terms) are evaluated light by
// light: a pipeline of its own, for the same reason.
override GLOSSY: bool = false;

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(7) var<storage, read> sps: array<ShadingPoint>;
@group(0) @binding(8) var<storage, read> row_of: array<u32>;
@group(0) @binding(9) var<storage, read> vis_words: array<u32>;
@group(0) @binding(10) var<storage, read> labels: array<u32>;
@group(0) @binding(11) var<storage, read> weights: array<f32>;
@group(0) @binding(12) var<storage, read> vpl_lights: array<VplLight>;
@group(0) @binding(13) var<storage, read_write> out: array<vec4<f32>>;
// Each shading point's sum over the lights of the ranges done so far (light order), by sample
// index from params.first_pixel * spp.
@group(0) @binding(14) var<storage, read_write> running: array<vec4<f32>>;
// The polygon lights' outlines (vplgi_types::LightOutline): POLYGON_SIDES vertices per light,
// each with the area in w, w = 0 after the last.
@group(0) @binding(15) var<storage, read> outlines: array<vec4<f32>>;
// Each material's BSDF in white (Surface::with_colour(1)), for the lobes a_p and a_c.
@group(0) @binding(16) var<storage, read> lobes: array<BsdfRecord>;

// shade::receiver: material m's white BSDF; one past the table is diffuse (an irradiance sample).
fn lobe_record(m: u32) -> BsdfRecord {
    if (m < arrayLength(&lobes)) {
        return lobes[m];
    }
    return diffuse_record();
}

fn diffuse_record() -> BsdfRecord {
    return BsdfRecord(vec3<f32>(1.0), BSDF_DIFFUSE, 0.0, 0.0, 0.0, 0u);
}

// shade::lobe_terms for one light: a glossy receiver's a_p under a point light's clamp (G
// recomputed as light_geometry_term does) or times a disk's G, then a glossy light's own a_c.
fn lobe_term(p: vec3<f32>, n: vec3<f32>, receiver: BsdfRecord, view: vec3<f32>, l: VplLight, light: BsdfRecord, incoming: vec3<f32>, g: f32, g_max: f32) -> f32 {
    let x = l.position.xyz;
    let nx = l.normal.xyz;
    let d = x - p;
    let d2 = dot(d, d);
    let inv_d = 1.0 / sqrt(d2);
    let dir = d * inv_d;
    var out = g;
    if (bsdf_is_glossy(receiver)) {
        let a = bsdf_lobe(receiver, n, view, dir);
        if (l.position.w == 0.0 && bitcast<u32>(l.normal.w) == 0u) {
            let cos_p = dot(n, d) * inv_d;
            let cos_x = -dot(nx, d) * inv_d;
            var raw = 0.0;
            if (d2 > 0.0 && cos_p > 0.0 && cos_x > 0.0) {
                raw = cos_p * cos_x / (d2 + 0.0);
            }
            out = min(a * raw, g_max);
        } else {
            out = out * a;
        }
    }
    if (bsdf_is_glossy(light)) {
        out = out * bsdf_lobe(light, nx, incoming, -dir);
    }
    return out;
}

// Distribution::sample: the first item whose CDF exceeds u (a lower bound on cdf > u).
fn sample_table_area(u: f32) -> u32 {
    var lo = 0u;
    var hi = arrayLength(&area_table);
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (area_table[mid].x <= u) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return min(lo, arrayLength(&area_table) - 1u);
}



// shade::sum_lights: Eq. 2 of Prutkin et al. for a disk (R² in position.w > 0, no clamp), the
// clamped point geometry term otherwise (d2 + 0 = d2 exactly); 0 where either side faces away.
fn light_geometry_term(p: vec3<f32>, np: vec3<f32>, l: VplLight, c: u32, g_max: f32) -> f32 {
    let d = l.position.xyz - p;
    let d2 = dot(d, d);
    let inv_d = 1.0 / sqrt(d2);
    let cos_p = dot(np, d) * inv_d;
    let cos_x = -dot(l.normal.xyz, d) * inv_d;
    let r2 = l.position.w;
    if (EXACT_SHAPES && bitcast<u32>(l.normal.w) == EXACT_DISK) {
        return exact_geometry_term(p, np, l.position.xyz, l.normal.xyz, r2);
    }
    if (EXACT_SHAPES && bitcast<u32>(l.normal.w) == EXACT_POLYGON) {
        return polygon_geometry_term(p, np, l.normal.xyz, c * POLYGON_SIDES);
    }
    let g = cos_p * cos_x / (d2 + r2);
    let capped = select(min(g, g_max), g, r2 > 0.0);
    return select(0.0, capped, d2 > 0.0 && cos_p > 0.0 && cos_x > 0.0);
}

// disk::exact_geometry_term: the exact form factor to the disk / R² (the arithmetic in the CPU
// twin's order; the derivation is there).
fn exact_geometry_term(p: vec3<f32>, n: vec3<f32>, centre: vec3<f32>, normal: vec3<f32>, radius2: f32) -> f32 {
    let rel = p - centre;
    let h = dot(normal, rel);
    if (!(h > 0.0) || !(radius2 > 0.0)) {
        return 0.0;
    }
    let rho_vec = rel - normal * h;
    let rel2 = dot(rel, rel);
    let n_z = dot(n, normal);
    let n_rho = dot(n, rho_vec);
    var m = length(n - normal * n_z);
    if (!(m > DISK_MIN_TILT)) {
        m = 0.0;
    }
    let r = sqrt(radius2);
    let n_rel = dot(n, rel);
    if (n_rel >= r * m) {
        return 0.0;
    }
    let q = rel2 - radius2;
    let a = rel2 + radius2;
    if (n_rel <= -r * m) {
        // All of the disk above the horizon.
        let s = sqrt(q * q + 4.0 * radius2 * h * h);
        var g_z = (s - q) / (2.0 * s * radius2);
        if (q > 0.0) {
            g_z = 2.0 * h * h / (s * (s + q));
        }
        let g_rho = 2.0 * h / (s * (a + s));
        return max(-g_z * n_z - g_rho * n_rho, 0.0);
    }
    // The horizon cuts the disk: the arc above it and the chord along it.
    // ρ̂ projected into the plane once more, and the axis within rounding of it (as the CPU's
    // disk::off_axis, where the reason is).
    let in_plane = rho_vec - normal * dot(normal, rho_vec);
    var rho = length(in_plane);
    var u = disk_perpendicular(normal);
    if (rho * rho > DISK_MIN_OFF_AXIS * DISK_MIN_OFF_AXIS * rel2) {
        u = in_plane / rho;
    } else {
        rho = 0.0;
    }
    let v = cross(normal, u);
    let n_u = dot(n, u);
    let n_v = dot(n, v);
    let b = 2.0 * r * rho;
    let s = sqrt(max((a - b) * (a + b), 0.0));
    let t = clamp(n_rel / (r * m), -1.0, 1.0);
    let w = sqrt(max(1.0 - t * t, 0.0));
    let cos1 = (n_u * t + n_v * w) / m;
    let sin1 = (n_v * t - n_u * w) / m;
    let cos2 = (n_u * t - n_v * w) / m;
    let sin2 = (n_v * t + n_u * w) / m;
    let span = 2.0 * acos(t);
    let ab = b / (a + s);
    let dd_over_b = disk_d_over_b(cos2, sin2, a, b, s, ab) - disk_d_over_b(cos1, sin1, a, b, s, ab);
    let i_one = (span + b * dd_over_b) / s;
    let i_cos = (a * dd_over_b + ab * span) / s;
    let base = a - b * cos1;
    let x = b * (cos1 - cos2) / base;
    let one_x = 1.0 + x;
    var ln1p_over_x = 1.0;
    if (one_x != 1.0) {
        ln1p_over_x = log(one_x) / (one_x - 1.0);
    }
    let i_sin = (cos1 - cos2) / base * ln1p_over_x;
    let arc = r * ((h * n_u - rho * n_z) * i_cos + h * n_v * i_sin + r * n_z * i_one);
    let end = centre + (u * cos2 + v * sin2) * r - p;
    let start = centre + (u * cos1 + v * sin1) * r - p;
    let chord = atan2(dot(n, cross(end, start)), dot(end, start));
    return min(max(-(arc + chord) / (2.0 * PI * radius2), 0.0), 1.0 / radius2);
}

// disk::exact_geometry_term's D(φ) / b.
fn disk_d_over_b(c: f32, sn: f32, a: f32, b: f32, s: f32, ab: f32) -> f32 {
    let y = sn * (1.0 - ab * c);
    let x = s + b * ab * c * c - b * c;
    if (b > 1e-6 * a) {
        return atan2(b * y, x) / b;
    }
    return y / x;
}

// polygon::geometry_term: the exact form factor to the polygon whose outline starts at
// outlines[base], / its area, each edge clipped to p's horizon as it is read and the chord
// added where the horizon cuts (the derivation is there).
fn polygon_geometry_term(p: vec3<f32>, n: vec3<f32>, normal: vec3<f32>, base: u32) -> f32 {
    let first = outlines[base];
    let area = first.w;
    if (!(dot(normal, p - first.xyz) > 0.0) || !(area > 0.0)) {
        return 0.0;
    }
    var sum = 0.0;
    var exit = vec3<f32>(0.0);
    var entry = vec3<f32>(0.0);
    var cut = 0u;
    var a = first.xyz;
    for (var i = 1u; i <= POLYGON_SIDES; i = i + 1u) {
        var b = first.xyz;
        var last = true;
        if (i < POLYGON_SIDES) {
            let v = outlines[base + i];
            if (v.w > 0.0) {
                b = v.xyz;
                last = false;
            }
        }
        let ra = a - p;
        let rb = b - p;
        let ha = dot(n, ra);
        let hb = dot(n, rb);
        if (ha >= 0.0 && hb >= 0.0) {
            sum = sum + polygon_edge(ra, rb, n);
        } else if (ha >= 0.0 || hb >= 0.0) {
            let x = ra + (rb - ra) * (ha / (ha - hb));
            if (ha >= 0.0) {
                sum = sum + polygon_edge(ra, x, n);
                exit = x;
                cut = cut | 1u;
            } else {
                sum = sum + polygon_edge(x, rb, n);
                entry = x;
                cut = cut | 2u;
            }
        }
        if (last) {
            break;
        }
        a = b;
    }
    if (cut == 3u) {
        sum = sum + polygon_edge(exit, entry, n);
    }
    return max(-0.5 * sum / area, 0.0);
}

// polygon::edge
fn polygon_edge(a: vec3<f32>, b: vec3<f32>, n: vec3<f32>) -> f32 {
    let c = cross(a, b);
    let len = length(c);
    if (len > 0.0) {
        return atan2(len, dot(a, b)) * dot(n, c) / len;
    }
    return 0.0;
}

// shade::direct
fn direct(sp: ShadingPoint, index: u32) -> vec3<f32> {
    let p = sp.position;
    let n = sp.normal;
    // A glossy receiver's lobe toward each light, as in shade_lights.
    let receiver = lobe_record(sp.material);
    let glossy = bsdf_is_glossy(receiver);
    var rng = rng_new(params.seed, STREAM_DIRECT, index);
    // One draw per statement: the CPU draws them in this order.
    let r0 = rng_next_u32(&rng);
    let r1 = rng_next_u32(&rng);
    let r2 = rng_next_u32(&rng);
    let scramble = vec3<u32>(r0, r1, r2);
    // LightSampler::group_choice: every group's importance at p, summed here and recomputed
    // (bit-identically) while walking, instead of kept in a per-lane array.
    let groups = light_counts.z;
    var total = 0.0;
    for (var g = 0u; g < groups; g = g + 1u) {
        total = total + group_importance(light_groups[g], p, n);
    }
    var area = vec3<f32>(0.0);
    for (var s = 0u; s < params.direct_samples; s = s + 1u) {
        if (!(total > 0.0)) {
            break;
        }
        // Stratified: sample s of a Sobol' set scrambled per shading point (shade::direct).
        let u = scrambled_sobol3(s, scramble);
        // LightSampler::sample_area_at: a group by importance, then an emitter of it by power.
        let goal = u.x * total;
        var acc = 0.0;
        var chosen = groups;
        var before = 0.0;
        var w = 0.0;
        for (var g = 0u; g < groups; g = g + 1u) {
            let wg = group_importance(light_groups[g], p, n);
            if (wg > 0.0) {
                chosen = g;
                before = acc;
                w = wg;
                if (goal < acc + wg) {
                    break;
                }
            }
            acc = acc + wg;
        }
        if (chosen == groups) {
            break;
        }
        let group = light_groups[chosen];
        let v = clamp((goal - before) / w, 0.0, 1.0 - 1.0 / 16777216.0);
        let first = group.range.x;
        let i = clamp(sample_table_area(group.power.z + v * group.power.y), first, first + group.range.y - 1u);
        let e = emitters[i];
        let b = uniform_triangle(u.y, u.z);
        let pos = e.v0.xyz + e.e1.xyz * b.x + e.e2.xyz * b.y;
        let pdf_area = (w / total) * (area_table[i].y / group.power.y) / e.v0.w;
        let d = pos - p;
        let d2 = dot(d, d);
        let cos_p = dot(n, d);
        let cos_l = -dot(e.normal.xyz, d);
        if (d2 <= 0.0 || cos_p <= 0.0 || cos_l <= 0.0) {
            continue;
        }
        if (visible(p, n, pos, e.normal.xyz, params.eps)) {
            var a = 1.0;
            if (glossy) {
                a = bsdf_lobe(receiver, n, sp.view, normalize(d));
            }
            area = area + e.radiance.xyz * (cos_p * cos_l / (d2 * d2) / pdf_area * a);
        }
    }
    var sum = area / f32(max(params.direct_samples, 1u));
    for (var k = 0u; k < light_counts.y; k = k + 1u) {
        let l = punctual[k];
        if (l.position.w == PUNCTUAL_DIRECTIONAL) {
            // Directional: E cos, along a ray to infinity.
            let cos_d = -dot(n, l.direction.xyz);
            if (cos_d > 0.0 && visible_toward(p, n, -l.direction.xyz, params.eps)) {
                var a = 1.0;
                if (glossy) {
                    a = bsdf_lobe(receiver, n, sp.view, normalize(-l.direction.xyz));
                }
                sum = sum + l.intensity.xyz * (cos_d * a);
            }
            continue;
        }
        let d = l.position.xyz - p;
        let d2 = dot(d, d);
        let cos_p = dot(n, d);
        if (d2 <= 0.0 || cos_p <= 0.0) {
            continue;
        }
        let falloff = punctual_falloff(l, -d / sqrt(d2));
        if (falloff > 0.0 && visible_from_surface(p, n, l.position.xyz, params.eps)) {
            var a = 1.0;
            if (glossy) {
                a = bsdf_lobe(receiver, n, sp.view, normalize(d));
            }
            sum = sum + l.intensity.xyz * (falloff * cos_p / (d2 * sqrt(d2)) * a);
        }
    }
    return sum * (sp.albedo / PI);
}

// shade::indirect over lights light_first .. light_end for SHADE_POINTS consecutive shading points,
// continuing their running sums (the CPU's one sequential sum per point, cut into ranges: see
// ShadeKernel::run). Each point's visibility rows (its own, or its F clusters' with weights; a
// missing cluster is a row of weight 0) are resolved once, and each row's 32-bit word is loaded
// once per block of 32 lights. A light that does not reach a point adds exactly +0 to its sum,
// as on the CPU, instead of branching per point; weights are summed in label order.
@compute @workgroup_size(64)
fn shade_lights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let first = thread_index(gid, groups) * SHADE_POINTS;
    let count = params.pixel_count * params.spp;
    if (first >= count) {
        return;
    }
    let first_sample = params.first_pixel * params.spp;
    let wpr = params.words_per_row;
    let g_max = params.g_max;
    let resumed = params.light_first > 0u;
    var pos: array<vec3<f32>, SHADE_POINTS>;
    var nrm: array<vec3<f32>, SHADE_POINTS>;
    var sum: array<vec3<f32>, SHADE_POINTS>;
    var view: array<vec3<f32>, SHADE_POINTS>;
    var receiver: array<BsdfRecord, SHADE_POINTS>;
    var row_base: array<u32, SHADE_POINTS * MAX_F>;
    var row_w: array<f32, SHADE_POINTS * MAX_F>;
    var words: array<u32, SHADE_POINTS * MAX_F>;
    for (var q = 0u; q < SHADE_POINTS; q = q + 1u) {
        let local = min(first + q, count - 1u);
        let i = first_sample + local;
        let sp = sps[i - params.sp_first];
        pos[q] = sp.position;
        nrm[q] = sp.normal;
        sum[q] = select(vec3<f32>(0.0), running[local].xyz, resumed);
        if (GLOSSY) {
            view[q] = sp.view;
            receiver[q] = lobe_record(sp.material);
        }
        // Points past the end or missing the scene are shaded like the last one and not stored.
        let row = row_of[i] - params.first_row;
        if (params.mode == SHADE_OWN_ROW) {
            row_base[q * MAX_F] = row * wpr;
            row_w[q * MAX_F] = 1.0;
        } else {
            // labels and weights are bound from hit params.first_row on (a window).
            for (var j = 0u; j < ROWS; j = j + 1u) {
                let k = labels[row * params.f + j];
                let ok = k != MISS;
                row_base[q * MAX_F + j] = select(0u, k * wpr, ok);
                row_w[q * MAX_F + j] = select(0.0, weights[row * params.f + j], ok);
            }
        }
    }
    let end = params.light_end;
    var c = params.light_first;
    while (c < end) {
        let block = c / 32u;
        for (var q = 0u; q < SHADE_POINTS; q = q + 1u) {
            for (var j = 0u; j < ROWS; j = j + 1u) {
                words[q * MAX_F + j] = vis_words[row_base[q * MAX_F + j] + block];
            }
        }
        let block_end = min(end, block * 32u + 32u);
        for (; c < block_end; c = c + 1u) {
            // Field by field: the lobe's vec4 is loaded only where it is used.
            let l = VplLight(vpl_lights[c].position, vpl_lights[c].normal, vpl_lights[c].flux, vec4<f32>(0.0));
            var light = diffuse_record();
            var incoming = vec3<f32>(0.0);
            if (GLOSSY) {
                let lobe = vpl_lights[c].incoming;
                incoming = lobe.xyz;
                light = lobe_record(bitcast<u32>(lobe.w));
            }
            let bit = c % 32u;
            for (var q = 0u; q < SHADE_POINTS; q = q + 1u) {
                var g = light_geometry_term(pos[q], nrm[q], l, c, g_max);
                if (GLOSSY) {
                    g = lobe_term(pos[q], nrm[q], receiver[q], view[q], l, light, incoming, g, g_max);
                }
                var v = 0.0;
                for (var j = 0u; j < ROWS; j = j + 1u) {
                    v = v + select(0.0, row_w[q * MAX_F + j], ((words[q * MAX_F + j] >> bit) & 1u) == 1u);
                }
                sum[q] = sum[q] + l.flux.xyz * (g / PI * v);
            }
        }
    }
    for (var q = 0u; q < SHADE_POINTS; q = q + 1u) {
        if (first + q < count) {
            running[first + q] = vec4<f32>(sum[q], 0.0);
        }
    }
}

// Per pixel: the mean over its samples of emitted + direct + the VPL lights' sum (in `running`,
// complete after the last range of shade_lights) times albedo / pi. A dispatch sums the samples
// sample_first .. sample_end onto the pixel's sum so far in `out` (shade::samples_per_dispatch:
// each sample traces shadow rays, and lavapipe ends an invocation's loops after 65,535
// iterations); the last divides, so the sum is the CPU's sequential one.
@compute @workgroup_size(64)
fn shade_finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.pixel_count) {
        return;
    }
    let px = params.first_pixel + local;
    var sum = vec3<f32>(0.0);
    if (params.sample_first > 0u) {
        sum = out[local].xyz;
    }
    for (var s = params.sample_first; s < params.sample_end; s = s + 1u) {
        let i = px * params.spp + s;
        let sp = sps[i - params.sp_first];
        if (sp.triangle != MISS) {
            let lights = running[local * params.spp + s].xyz;
            var own = vec3<f32>(0.0);
            if (params.direct != 0u) {
                own = sp.emitted + direct(sp, i);
            }
            sum = sum + (own + lights * (sp.albedo / PI));
        } else if (params.direct != 0u) {
            // A jittered miss carries the emission its pixel sees elsewhere (shading_points).
            sum = sum + sp.emitted;
        }
    }
    if (params.sample_end == params.spp) {
        sum = sum / f32(params.spp);
    }
    out[local] = vec4<f32>(sum, 0.0);
}
