// Polypostor crowd: instances sorted by view, one indexed instanced draw per view in use.
// Each index names a part record (high 16 bits: view × parts + drawing slot) and a vertex of
// that part (low 16 bits); the vertex is pulled from the pack's 16-bit data at two frames
// and interpolated. Indexed draws let the GPU reuse each vertex across its triangles. Parts
// later in the view's order are moved slightly towards the camera, so the depth test draws
// them in front.
// Frame.counts: y parts per view, z frames, w depth offset per slot (world units). Shared
// structs and functions: crowd_common.wgsl. Keep the structs in sync with
// `src/gpu/polypostor_renderer.rs`.

struct Part {
    // First u32 of the part's block (each u32 holds one x, y pair of unorm16 values).
    vertex_word: u32,
    // Low 16 bits: vertices; high 16 bits: the body part (for the per-part tint).
    vertex_count: u32,
    // First u16 index, and how many.
    index_offset: u32,
    index_count: u32,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> parts: array<Part>;
// Vertex data (u32 words, each an x, y pair of unorm16 values).
@group(0) @binding(3) var<storage, read> geometry: array<u32>;
@group(0) @binding(4) var<storage, read> instances: array<Instance>;
@group(0) @binding(5) var atlas: texture_2d_array<f32>;
@group(0) @binding(6) var normals: texture_2d_array<f32>;
@group(0) @binding(7) var atlas_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
    @location(2) light_view: vec3<f32>,
    @location(3) tint: vec3<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VertexOut {
    var out: VertexOut;
    let inst = instances[ii];
    let per_view = u32(frame.counts.y);
    let frames = max(u32(frame.counts.z), 1u);
    let record = vi >> 16u;
    let slot = record % max(per_view, 1u);
    let part = parts[record];
    let vc = max(part.vertex_count & 0xffffu, 1u);
    let local = min(vi & 0xffffu, vc - 1u);
    let f0 = inst.frame % frames;
    let f1 = (f0 + 1u) % frames;
    let a = unpack2x16unorm(geometry[part.vertex_word + vc * (1u + f0) + local]) * 2.0 - 1.0;
    let b = unpack2x16unorm(geometry[part.vertex_word + vc * (1u + f1) + local]) * 2.0 - 1.0;
    let xy = mix(a, b, clamp(inst.blend, 0.0, 1.0));
    let view_index = record / max(per_view, 1u);
    let view = views[view_index];
    let model = view.center.xyz
        + (xy.x * view.right.xyz + xy.y * view.up.xyz) * view.center.w
        + view.forward.xyz * (f32(slot) * frame.counts.w);
    let world = turn(model, inst.facing) + vec3<f32>(inst.pos.x, 0.0, inst.pos.y);
    out.clip_position = frame.clip_from_world * vec4<f32>(world, 1.0);
    out.uv = unpack2x16unorm(geometry[part.vertex_word + local]) * view.uv_scale.xy + view.uv_scale.zw;
    out.layer = u32(view.forward.w);
    // The light in the view's camera frame (the normal atlas is in that frame).
    out.light_view = light_in_view(frame.light_dir.xyz, inst.facing, view);
    out.tint = part_tint(inst.variant, part.vertex_count >> 16u, frame.params.z);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    let albedo = textureSample(atlas, atlas_sampler, in.uv, in.layer);
    if (albedo.a < 0.5) {
        discard;
    }
    let n = normalize(textureSample(normals, atlas_sampler, in.uv, in.layer).xyz * 2.0 - vec3<f32>(1.0));
    return shade(albedo.rgb, in.tint, n, in.light_view, frame.params);
}
