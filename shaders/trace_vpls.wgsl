// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/surface.wgsl common/sampling.wgsl common/bsdf.wgsl common/specular.wgsl common/lights.wgsl common/scene.wgsl
// Stage 1, trace_vpls (vplgi-cpu/src/trace_vpls.rs), in three kernels:
//   trace:   one thread per light particle; its VPLs go to `bounces` fixed slots, with a count;
//   (scan.wgsl turns the counts into exclusive offsets and the batch total);
//   compact: copies the VPLs of the batch behind those already kept, up to the requested
//            count, and records how many particles were used when the count is reached.
// Particle i uses only point i of the frame's scrambled Sobol' set (its emission) and the stream
// (seed, STREAM_LIGHT_PATH, i) (its bounces), so batching does not matter. Mirrors and glass hold
// no VPL: the particle reflects or refracts there, at most specular_depth times in a row. At
// rough metal it leaves a VPL and goes on along its BSDF's sample. With params.deposit the same
// paths leave photons instead (the power that arrived): caustic photons only where the last
// vertex was a mirror or glass, the global map's at every surface.
// Fluxes are divided by the particle count by `normalize` once it is known.

struct Params {
    seed: u32,
    bounces: u32,
    first: u32,        // first particle of this batch
    count: u32,        // particles in this batch
    wanted: u32,       // VPLs requested in total
    kept: u32,         // VPLs kept before this batch
    eps: f32,
    specular_depth: u32,  // mirrors and glass passed between two VPLs
    deposit: u32,         // 0: VPLs; 1: caustic photons (Deposit::CausticPhotons); 2: photons (Deposit::Photons)
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(11) var<storage, read_write> slots: array<Vpl>;
@group(0) @binding(12) var<storage, read_write> counts: array<u32>;
@group(0) @binding(13) var<storage, read_write> offsets: array<u32>;
// [1] = particles used once the wanted count is reached (else 0); [0] unused.
@group(0) @binding(14) var<storage, read_write> totals: array<u32>;
@group(0) @binding(15) var<storage, read_write> vpls: array<Vpl>;

// Distribution::sample on the all-light table (particles): first item whose CDF exceeds u.
fn sample_table_all(u: f32) -> u32 {
    var lo = 0u;
    var hi = arrayLength(&all_table);
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (all_table[mid].x <= u) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return min(lo, arrayLength(&all_table) - 1u);
}


@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let index = params.first + local;
    var n = 0u;
    var rng = rng_new(params.seed, STREAM_LIGHT_PATH, index);
    // trace_vpls::emission_scramble, then point `index` of the frame's shifted Sobol' set:
    // direction in dimensions 1-2, light choice and point in 3-5 (trace_vpls::trace_particle).
    var shift_rng = rng_new(params.seed, STREAM_SCRAMBLE, 0u);
    var scramble = array<u32, 5>(0u, 0u, 0u, 0u, 0u);
    for (var d = 0u; d < 5u; d = d + 1u) {
        scramble[d] = rng_next_u32(&shift_rng);
    }
    let s = scrambled_sobol5(index, scramble);
    let u0 = s[2];
    let u1 = s[3];
    let u2 = s[4];
    let u3 = s[0];
    let u4 = s[1];
    if (light_counts.x + light_counts.y > 0u) {
        // LightSampler::emit
        let i = sample_table_all(u0);
        let pmf = all_table[i].y;
        var origin: vec3<f32>;
        var dir: vec3<f32>;
        var power: vec3<f32>;
        var surface_normal = vec3<f32>(0.0);
        if (i < light_counts.x) {
            let e = emitters[i];
            let b = uniform_triangle(u1, u2);
            origin = e.v0.xyz + e.e1.xyz * b.x + e.e2.xyz * b.y;
            power = e.radiance.xyz * (PI * e.v0.w) / pmf;
            dir = cosine_hemisphere(e.normal.xyz, u3, u4);
            surface_normal = e.normal.xyz;
        } else {
            let l = punctual[i - light_counts.x];
            origin = l.position.xyz;
            if (l.position.w == PUNCTUAL_POINT) {
                dir = uniform_sphere(u3, u4);
                power = l.intensity.xyz * (4.0 * PI) / pmf;
            } else if (l.position.w == PUNCTUAL_DIRECTIONAL) {
                // Directional: SunFrame's disk, E pi R^2.
                let radius = l.direction.w;
                origin = sun_origin(l.position.xyz, l.direction.xyz, radius, u3, u4);
                dir = l.direction.xyz;
                power = l.intensity.xyz * (PI * radius * radius) / pmf;
            } else {
                let cos_outer = l.intensity.w;
                dir = uniform_cone(l.direction.xyz, cos_outer, u3, u4);
                let inv_pdf = 2.0 * PI * (1.0 - cos_outer);
                // The falloff of the sampled cosine, not of the direction built from it: a narrow
                // ramp between the cones multiplies the direction's rounding by up to 1,000.
                power = l.intensity.xyz * (punctual_falloff_cos(l, uniform_cone_cos(cos_outer, u3)) * inv_pdf / pmf);
            }
        }
        origin = origin + surface_normal * params.eps;
        let inf = bitcast<f32>(0x7f800000u);
        var specular = 0u;   // in a row
        var passed = 0u;     // in all
        var bounce = 1u;
        while (bounce <= params.bounces) {
            let hit = bvh_trace(origin, dir, 0.0, inf, false);
            if (hit.triangle == NO_HIT) {
                break;
            }
            let s = surface_at(hit, dir);
            if (specular < params.specular_depth && bsdf_is_specular(s.bsdf)) {
                // Power: no η² on refraction (radiance = false).
                let b = scatter_specular(s, dir, rng_next_f32(&rng), false);
                if (b.valid == 0u) {
                    break;
                }
                power = power * b.weight;
                specular = specular + 1u;
                passed = passed + 1u;
                dir = b.wo;
                origin = offset_toward(s.position, s.ng, s.position + dir, params.eps);
                continue;
            }
            let after_specular = specular > 0u;
            specular = 0u;
            let flux = power * s.albedo;
            if (params.deposit != 1u || after_specular) {
                // A photon keeps the power that arrived.
                let deposit = select(flux, power, params.deposit != 0u);
                slots[local * params.bounces + n] = Vpl(s.position, index, s.ns, bounce, deposit, passed, -dir, s.material);
                n = n + 1u;
            }
            if (bounce == params.bounces) {
                break;
            }
            if (bsdf_is_glossy(s.bsdf)) {
                // The BSDF's own sample, then Russian roulette on its weight.
                let u1 = rng_next_f32(&rng);
                let ux = rng_next_f32(&rng);
                let uy = rng_next_f32(&rng);
                let b = scatter(s, dir, u1, vec2<f32>(ux, uy), false);
                if (b.valid == 0u) {
                    break;
                }
                let survive = min(max(max(b.weight.x, b.weight.y), b.weight.z), MAX_SURVIVAL);
                if (survive <= 0.0 || rng_next_f32(&rng) >= survive) {
                    break;
                }
                power = power * (b.weight / survive);
                dir = b.wo;
            } else {
                let survive = min(max(max(s.albedo.x, s.albedo.y), s.albedo.z), MAX_SURVIVAL);
                if (survive <= 0.0 || rng_next_f32(&rng) >= survive) {
                    break;
                }
                power = flux / survive;
                let u5 = rng_next_f32(&rng);
                let u6 = rng_next_f32(&rng);
                dir = cosine_hemisphere(s.ns, u5, u6);
            }
            if (dot(dir, s.ng) <= 0.0) {
                break;
            }
            origin = s.position + s.ng * params.eps;
            bounce = bounce + 1u;
        }
    }
    counts[local] = n;
}

@compute @workgroup_size(64)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let room = params.wanted - params.kept;
    let start = offsets[local];
    let n = counts[local];
    for (var b = 0u; b < n; b = b + 1u) {
        if (start + b < room) {
            vpls[params.kept + start + b] = slots[local * params.bounces + b];
        }
    }
    // The particle holding the wanted-th VPL closes the set: the particles used are those up to
    // and including it (its path may be cut short).
    if (start < room && start + n >= room) {
        totals[1] = params.first + local + 1u;
    }
    // The batch's VPLs, for the host's one read per batch (with totals[1]).
    if (local == params.count - 1u) {
        totals[2] = start + n;
    }
}

@compute @workgroup_size(64)
fn normalize_flux(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.kept) {
        return;
    }
    // Particles used: recorded by compact, or (params.count) the whole budget when the scene let
    // too much light escape to reach the wanted count.
    let used = select(params.count, totals[1], totals[1] != 0u);
    let inv = 1.0 / f32(max(used, 1u));
    vpls[i].flux = vpls[i].flux * inv;
}
