// The warps of vplgi-types/src/sampling.rs, same operation order.

// Duff et al. 2017 orthonormal basis; `sign` is an exact copysign(1, n.z) (-0.0 gives -1 as in
// Rust), built from the sign bit.
fn orthonormal_basis(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let sign = bitcast<f32>((bitcast<u32>(n.z) & 0x80000000u) | 0x3f800000u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return array<vec3<f32>, 2>(t, bt);
}

fn cosine_hemisphere(n: vec3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    let tb = orthonormal_basis(n);
    let z = sqrt(max(1.0 - u1, 0.0));
    return normalize(tb[0] * (r * cos(phi)) + tb[1] * (r * sin(phi)) + n * z);
}

fn uniform_sphere(u1: f32, u2: f32) -> vec3<f32> {
    let z = 1.0 - 2.0 * u1;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u2;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// sampling::uniform_cone_cos
fn uniform_cone_cos(cos_max: f32, u1: f32) -> f32 {
    return 1.0 - u1 * (1.0 - cos_max);
}

fn uniform_cone(axis: vec3<f32>, cos_max: f32, u1: f32, u2: f32) -> vec3<f32> {
    let cos_t = uniform_cone_cos(cos_max, u1);
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    let phi = 2.0 * PI * u2;
    let tb = orthonormal_basis(axis);
    return normalize(tb[0] * (sin_t * cos(phi)) + tb[1] * (sin_t * sin(phi)) + axis * cos_t);
}

// sampling::sobol3: point j of the first three dimensions of Sobol's sequence as 32-bit binary
// fractions (direction numbers from x, x + 1 and x^2 + x + 1; integer operations only, so the
// bits equal the CPU's).
fn sobol3(j: u32) -> vec3<u32> {
    var x = vec3<u32>(0u);
    var m2 = 1u;
    var m3 = 1u;
    var m3_prev = 0u;
    var k = 1u;
    while (k <= 32u && (j >> (k - 1u)) != 0u) {
        if (k >= 2u) {
            m2 = m2 ^ (m2 << 1u);
            var next = 3u;
            if (k != 2u) {
                next = (m3 << 1u) ^ (m3_prev << 2u) ^ m3_prev;
            }
            m3_prev = m3;
            m3 = next;
        }
        if (((j >> (k - 1u)) & 1u) == 1u) {
            let shift = 32u - k;
            x = x ^ vec3<u32>(1u << shift, m2 << shift, m3 << shift);
        }
        k = k + 1u;
    }
    return x;
}

// sampling::scrambled_sobol3: sample j of a Sobol' set digitally shifted by `scramble`.
fn scrambled_sobol3(j: u32, scramble: vec3<u32>) -> vec3<f32> {
    return vec3<f32>((sobol3(j) ^ scramble) >> vec3<u32>(8u)) * (1.0 / 16777216.0);
}
