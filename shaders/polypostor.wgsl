// Polypostor crowd: instances sorted by view, one indexed instanced draw per view in use.
// Each index names a part record (high 16 bits) and a vertex of that part (low 16 bits); the
// vertex is pulled from the pack's data (8-bit positions in a per-block box, 16-bit UVs) at
// two frames and interpolated. Indexed draws
// let the GPU reuse each vertex across its triangles. Parts later in the view's order are
// moved slightly towards the camera, so the depth test draws them in front.
//
// Several key images: a part with k keys has k records, one per key image, each with its own
// polygon. Per frame the pack says which key draws the part (a table of u8 in `geometry`).
// Over an interval whose two frames use different keys, both records are drawn and the
// pixels are split between them by an ordered-dither threshold that moves with the blend:
// a cross-fade without transparency (no sorting, the depth test still works), no pop.
// Frame.counts: z frames, w depth offset per slot (world units). Shared structs and
// functions: crowd_common.wgsl. Keep the structs in sync with
// `src/gpu/polypostor_renderer.rs`.

struct Part {
    // First u32 of the key's block: UVs (each u32 one x, y pair of unorm16 values), then
    // `frame_count` frames of positions (each u32 two vertices' x, y bytes inside the box;
    // a frame's run is (vertices + 1) / 2 words).
    vertex_word: u32,
    // Low 16 bits: vertices; high 16 bits: the body part (for the per-part tint).
    vertex_count: u32,
    // The view.
    view: u32,
    // Bits 0-7: drawing slot; 8-15: this record's key; 16-23: the part's keys.
    slot_key: u32,
    // Low 16 bits: first frame of the block; high 16 bits: frames in it.
    frames: u32,
    // First u32 of the part's per-frame key table in `geometry` (4 frames a word; keys > 1).
    key_table: u32,
    // The block's position box: lower corner x, y (unorm16 pair), then its size (the same).
    box_lo: u32,
    box_size: u32,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> parts: array<Part>;
// Vertex data (per block UV words, then position bytes), then the key tables.
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
    // x: 0 draw every pixel, 1 the pixels whose threshold is at least the blend (the
    // interval's first key), 2 those below it (its second key); y: the blend.
    @location(4) @interpolate(flat) fade: vec2<f32>,
    // The instance's variant: its level/view cross-fade bits (`faded_out`).
    @location(5) @interpolate(flat) variant: u32,
};

// The key drawing frame `f` of a part whose table starts at word `table`.
fn key_of(table: u32, f: u32) -> u32 {
    return (geometry[table + f / 4u] >> (8u * (f % 4u))) & 0xffu;
}


// Vertex `local` of a block of `vc` vertices at its frame `g`, (x + 1) / 2, (y + 1) / 2 of the
// view plane: its byte pair inside the block's box.
fn block_position(part: Part, vc: u32, g: u32, local: u32) -> vec2<f32> {
    let word = geometry[part.vertex_word + vc + ((vc + 1u) / 2u) * g + local / 2u];
    let q = unpack4x8unorm(word);
    let pair = select(q.xy, q.zw, (local & 1u) == 1u);
    return unpack2x16unorm(part.box_lo) + pair * unpack2x16unorm(part.box_size);
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VertexOut {
    var out: VertexOut;
    let inst = instances[ii];
    let frames = max(u32(frame.counts.z), 1u);
    let part = parts[vi >> 16u];
    let slot = part.slot_key & 0xffu;
    let key = (part.slot_key >> 8u) & 0xffu;
    let keys = max((part.slot_key >> 16u) & 0xffu, 1u);
    let vc = max(part.vertex_count & 0xffffu, 1u);
    let local = min(vi & 0xffffu, vc - 1u);
    let pair = frame_pair(inst.frame, frames);
    let f0 = pair.x;
    let f1 = pair.y;
    let blend = clamp(inst.blend, 0.0, 1.0);
    var mode = 0.0;
    if (keys > 1u) {
        let k0 = key_of(part.key_table, f0);
        let k1 = key_of(part.key_table, f1);
        if (k0 != key && k1 != key) {
            // This key draws neither end of the interval: no triangle.
            out.clip_position = vec4<f32>(0.0, 0.0, 2.0, 0.0);
            return out;
        }
        if (k0 != k1) {
            mode = select(2.0, 1.0, k0 == key);
        }
    }
    // The block's frames, from its first one round the loop.
    let start = part.frames & 0xffffu;
    let count = max(part.frames >> 16u, 1u);
    let g0 = min((f0 + frames - start % frames) % frames, count - 1u);
    let g1 = min((f1 + frames - start % frames) % frames, count - 1u);
    let a = block_position(part, vc, g0, local);
    let b = block_position(part, vc, g1, local);
    let xy = mix(a, b, blend) * 2.0 - 1.0;
    let view = views[part.view];
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
    out.variant = inst.variant;
    out.fade = vec2<f32>(mode, blend);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    if (faded_out(in.variant, in.clip_position.xy)) {
        discard;
    }
    if (in.fade.x > 0.5) {
        let later = crossfade_threshold(in.clip_position.xy) < in.fade.y;
        if (later != (in.fade.x > 1.5)) {
            discard;
        }
    }
    let albedo = textureSample(atlas, atlas_sampler, in.uv, in.layer);
    if (albedo.a < 0.5) {
        discard;
    }
    let n = normalize(textureSample(normals, atlas_sampler, in.uv, in.layer).xyz * 2.0 - vec3<f32>(1.0));
    return shade(albedo.rgb, in.tint, n, in.light_view, frame.params);
}
