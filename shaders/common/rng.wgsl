// The counter-based RNG of vplgi-types/src/rng.rs, transcribed operation for operation:
// PCG hash (Jarzynski & Olano 2020), key = pcg(index + pcg(stream + pcg(seed))),
// draw n = pcg(key ^ pcg(n)). WGSL u32 arithmetic wraps like Rust's wrapping_* ops.

fn pcg_hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

struct Rng {
    key: u32,
    counter: u32,
}

fn rng_new(seed: u32, stream: u32, index: u32) -> Rng {
    return Rng(pcg_hash(index + pcg_hash(stream + pcg_hash(seed))), 0u);
}

fn rng_next_u32(r: ptr<function, Rng>) -> u32 {
    let v = pcg_hash((*r).key ^ pcg_hash((*r).counter));
    (*r).counter = (*r).counter + 1u;
    return v;
}

// Uniform in [0, 1): the top 24 bits, exactly representable.
fn rng_next_f32(r: ptr<function, Rng>) -> f32 {
    return f32(rng_next_u32(r) >> 8u) * (1.0 / 16777216.0);
}
