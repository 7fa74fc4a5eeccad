// The k-nearest-photon search of vplgi-cpu/src/caustics.rs (`nearest`), read by `caustics`
// and `illumination_cut`: a depth-first walk of the shared kd-tree (vplgi_shared::photon_tree),
// nearer child first, pruned by box distance, keeping a max-heap on (distance², index) in
// heap_d2 / heap_i, stopped after CAUSTIC_VISITS. The stage file declares `photons:
// array<Vpl>` and `nodes: array<PhotonNode>`.

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

// The k nearest photons to p whose normals are within 60° of n, closer than max_r2: how many
// are in the heap, and whether the walk stopped at the visit budget.
struct Nearest {
    found: u32,
    truncated: bool,
}

fn nearest(p: vec3<f32>, n: vec3<f32>, k: u32, max_r2: f32) -> Nearest {
    if (arrayLength(&photons) == 0u || k == 0u) {
        return Nearest(0u, false);
    }
    let len = arrayLength(&nodes);
    var stack: array<u32, PHOTON_STACK>;
    stack[0] = 0u;
    var top = 1u;
    var visits = 0u;
    var found = 0u;
    var truncated = false;
    while (top > 0u) {
        if (visits >= CAUSTIC_VISITS) {
            truncated = true;
            break;
        }
        top = top - 1u;
        let i = stack[top];
        visits = visits + 1u;
        let node = nodes[i];
        let bound = select(max_r2, heap_d2[0], found == k);
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
                if (d2 < max_r2) {
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
    return Nearest(found, truncated);
}

// The estimate's radius²: the k-th nearest's distance², or max_r2 where fewer were found.
fn nearest_r2(found: Nearest, k: u32, max_r2: f32) -> f32 {
    return select(max_r2, heap_d2[0], found.found == k);
}
