// include:
// Exclusive prefix sum of counts[0..n) into offsets[0..n], with offsets[n] = the total, by one
// workgroup per dispatch over the items [first, first + count): each thread sums a contiguous
// chunk, the 256 partial sums are scanned in workgroup memory (Hillis-Steele), then each thread
// writes the offsets of its chunk, starting from offsets[first], the total of the dispatches
// before (vplgi-gpu/src/scan.rs sizes the ranges against lavapipe's loop limiter). Integer sums:
// the result does not depend on scheduling. Used by trace_vpls (VPL compaction), cluster (grid
// cells, surviving clusters) and the frame (hit shading points).

struct Params {
    n: u32,
    first: u32,
    count: u32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read_write> offsets: array<u32>;

var<workgroup> partial: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_id) lid: vec3<u32>) {
    let t = lid.x;
    let last = params.first + params.count;
    // Read before any thread writes offsets (after the barriers below).
    let base = select(0u, offsets[params.first], params.first > 0u);
    let chunk = (params.count + 255u) / 256u;
    let begin = min(params.first + t * chunk, last);
    let end = min(begin + chunk, last);
    var s = 0u;
    for (var i = begin; i < end; i = i + 1u) {
        s = s + counts[i];
    }
    partial[t] = s;
    workgroupBarrier();
    for (var step = 1u; step < 256u; step = step * 2u) {
        var add = 0u;
        if (t >= step) {
            add = partial[t - step];
        }
        workgroupBarrier();
        partial[t] = partial[t] + add;
        workgroupBarrier();
    }
    var running = base + partial[t] - s;
    for (var i = begin; i < end; i = i + 1u) {
        offsets[i] = running;
        running = running + counts[i];
    }
    if (t == 255u) {
        offsets[last] = base + partial[255];
    }
}
