// The scene, declared once for every stage that traces rays or samples lights: the threaded BVH
// (bvh.wgsl), per-triangle shading data, materials and texels (surface.wgsl), and the light
// tables (lights.wgsl). Bindings 32 and up of group 0 belong to the scene, in the order of
// vplgi_gpu::scene::SCENE_BINDINGS (a test checks the two against each other); a stage's own
// bindings stay below 32, and each pipeline binds only the scene arrays it uses.

@group(0) @binding(32) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(33) var<storage, read> bvh_nodes_hi: array<BvhNode>;
@group(0) @binding(34) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(35) var<storage, read> bvh_tris_hi: array<BvhTri>;
@group(0) @binding(36) var<storage, read> scene_tris: array<SceneTri>;
@group(0) @binding(37) var<storage, read> scene_tris_1: array<SceneTri>;
@group(0) @binding(38) var<storage, read> scene_tris_2: array<SceneTri>;
@group(0) @binding(39) var<storage, read> scene_tris_3: array<SceneTri>;
@group(0) @binding(40) var<storage, read> materials: array<Material>;
@group(0) @binding(41) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(42) var<storage, read> texels: array<u32>;
@group(0) @binding(43) var<storage, read> texels_1: array<u32>;
@group(0) @binding(44) var<storage, read> texels_2: array<u32>;
@group(0) @binding(45) var<storage, read> texels_3: array<u32>;
@group(0) @binding(46) var<storage, read> light_counts: vec4<u32>;          // emitters, punctual lights, light groups
@group(0) @binding(47) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(48) var<storage, read> area_table: array<vec2<f32>>;  // emitters by power
@group(0) @binding(49) var<storage, read> all_table: array<vec2<f32>>;   // emitters, then punctual lights
@group(0) @binding(50) var<storage, read> punctual: array<Punctual>;
@group(0) @binding(51) var<storage, read> light_groups: array<LightGroup>;  // light_counts.z of them
@group(0) @binding(52) var<storage, read> bvh_frame: array<vec4<f32>, 2>;    // node corners: [0].xyz + q * [1].xyz
