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

// sampling::sobol5: point j of the first five dimensions of Sobol's sequence as 32-bit binary
// fractions (direction numbers from x, x + 1, x^2 + x + 1, x^3 + x + 1 and x^3 + x^2 + 1;
// integer operations only, so the bits equal the CPU's).
fn sobol5(j: u32) -> array<u32, 5> {
    var x = array<u32, 5>(0u, 0u, 0u, 0u, 0u);
    var m2 = 1u;
    // m_{k-1}, m_{k-2}, m_{k-3} of dimensions 3, 4 and 5.
    var h3 = vec3<u32>(0u);
    var h4 = vec3<u32>(0u);
    var h5 = vec3<u32>(0u);
    var k = 1u;
    while (k <= 32u && (j >> (k - 1u)) != 0u) {
        if (k >= 2u) {
            m2 = m2 ^ (m2 << 1u);
        }
        var m3 = (h3.x << 1u) ^ (h3.y << 2u) ^ h3.y;
        var m4 = (h4.y << 2u) ^ (h4.z << 3u) ^ h4.z;
        var m5 = (h5.x << 1u) ^ (h5.z << 3u) ^ h5.z;
        if (k == 1u) {
            m3 = 1u;
            m4 = 1u;
            m5 = 1u;
        } else if (k == 2u) {
            m3 = 3u;
            m4 = 3u;
            m5 = 1u;
        } else if (k == 3u) {
            m4 = 1u;
            m5 = 1u;
        }
        h3 = vec3<u32>(m3, h3.x, h3.y);
        h4 = vec3<u32>(m4, h4.x, h4.y);
        h5 = vec3<u32>(m5, h5.x, h5.y);
        if (((j >> (k - 1u)) & 1u) == 1u) {
            let shift = 32u - k;
            x[0] = x[0] ^ (1u << shift);
            x[1] = x[1] ^ (m2 << shift);
            x[2] = x[2] ^ (m3 << shift);
            x[3] = x[3] ^ (m4 << shift);
            x[4] = x[4] ^ (m5 << shift);
        }
        k = k + 1u;
    }
    return x;
}

// sampling::sobol3: the first three dimensions of sobol5.
fn sobol3(j: u32) -> vec3<u32> {
    let s = sobol5(j);
    return vec3<u32>(s[0], s[1], s[2]);
}

// sampling::scrambled_sobol5: sample j of a Sobol' set digitally shifted by `scramble`.
fn scrambled_sobol5(j: u32, scramble: array<u32, 5>) -> array<f32, 5> {
    let s = sobol5(j);
    var u = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
    for (var d = 0u; d < 5u; d = d + 1u) {
        u[d] = f32((s[d] ^ scramble[d]) >> 8u) * (1.0 / 16777216.0);
    }
    return u;
}

// sampling::scrambled_sobol3: sample j of a Sobol' set digitally shifted by `scramble`.
fn scrambled_sobol3(j: u32, scramble: vec3<u32>) -> vec3<f32> {
    return vec3<f32>((sobol3(j) ^ scramble) >> vec3<u32>(8u)) * (1.0 / 16777216.0);
}
