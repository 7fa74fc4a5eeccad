// The clustering's arithmetic, shared by the clustering passes (cluster_*.wgsl) and the
// adaptive seeding (seeding.wgsl), each in the CPU's order of operations: the squared distance and
// dot product (vplgi-cpu/src/cluster.rs), Eq. 2 of Wang et al. (vplgi_types::clustering::
// ward_error) and the fixed-point format of sums of positions and normals (FixedPoint).

fn dist2(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let dx = a.x - b.x;
    let dy = a.y - b.y;
    let dz = a.z - b.z;
    var s = dx * dx;
    s = s + dy * dy;
    s = s + dz * dz;
    return s;
}

fn cosine(n: vec3<f32>, m: vec3<f32>) -> f32 {
    var d = n.x * m.x;
    d = d + n.y * m.y;
    d = d + n.z * m.z;
    return d;
}

// Eq. 2 of Wang et al. 2009: alpha |x - c| + sqrt(2 - 2 n.m) from the squared distance and the
// normals' dot product.
fn ward_error(alpha: f32, d2: f32, cos: f32) -> f32 {
    return alpha * sqrt(d2) + sqrt(max(2.0 - 2.0 * cos, 0.0));
}

// FixedPoint::quantize: a position as 24-bit fractions of the box (fix_min, fix_ext) per axis.
fn fix_position(p: vec3<f32>, fix_min: vec3<f32>, fix_ext: vec3<f32>) -> vec3<u32> {
    return vec3<u32>(round(clamp((p - fix_min) / fix_ext * FIX_ONE, vec3<f32>(0.0), vec3<f32>(FIX_ONE))));
}

// FixedPoint::quantize: a normal as round(n 2^24) + 2^24 per axis.
fn fix_normal(n: vec3<f32>) -> vec3<u32> {
    return vec3<u32>(round(clamp(clamp(n, vec3<f32>(-1.0), vec3<f32>(1.0)) * FIX_ONE + FIX_ONE, vec3<f32>(0.0), vec3<f32>(2.0 * FIX_ONE))));
}

// u64_mean: sum / count in f32 from the two halves (lo, hi) of a 64-bit sum.
fn mean64(lo: u32, hi: u32, count: u32) -> f32 {
    return (f32(hi) * 4294967296.0 + f32(lo)) / f32(count);
}

// FixedPoint::mean, the position: the box point of the mean fractions m.
fn fix_mean_position(m: vec3<f32>, fix_min: vec3<f32>, fix_ext: vec3<f32>) -> vec3<f32> {
    return fix_min + m / FIX_ONE * fix_ext;
}

// FixedPoint::mean, the normal, with glam's try_normalize: zero where the normals cancel (1 /
// length not finite and positive).
fn fix_mean_normal(m: vec3<f32>) -> vec3<f32> {
    let nrm = (m - vec3<f32>(FIX_ONE)) / FIX_ONE;
    let rcp = 1.0 / sqrt(dot(nrm, nrm));
    if (rcp < bitcast<f32>(0x7f800000u) && rcp > 0.0) {
        return nrm * rcp;
    }
    return vec3<f32>(0.0);
}
