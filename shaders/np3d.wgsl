// NP3D impostors: the simplified mesh of the current frame (interpolated with the next: the
// meshes share one topology), textured by projecting the nearest view's key-frame image
// onto it through that view's orthographic camera, at the vertices' key-frame positions.
// Shaded with the mesh normals.
// Frame.counts: x vertices, y frames, z key frame; bases.x: first word of the per-vertex
// parts in `topology`. Shared structs and functions: crowd_common.wgsl. Keep the structs in
// sync with `crates/polypostor-runtime/src/gpu/crowd_renderers/`.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
// Per frame, per vertex: position xyz (f32 bits) and the normal packed as snorm8x4 in w.
@group(0) @binding(3) var<storage, read> vertices: array<vec4<u32>>;
// Triangle indices (one per word), then each vertex's body part from `frame.bases.x` on.
@group(0) @binding(4) var<storage, read> topology: array<u32>;
@group(0) @binding(5) var images: texture_2d_array<f32>;
@group(0) @binding(6) var image_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
    @location(2) normal: vec3<f32>,
    @location(3) tint: vec3<f32>,
    // The instance's variant: its level/view cross-fade bits (`faded_out`).
    @location(4) @interpolate(flat) variant: u32,
};

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VertexOut {
    var out: VertexOut;
    let inst = instances[ii];
    let count = u32(frame.counts.x);
    let frames = max(u32(frame.counts.y), 1u);
    let local = min(topology[vi], count - 1u);
    let pair = frame_pair(inst.frame, frames);
    let f0 = pair.x;
    let f1 = pair.y;
    let a = vertices[f0 * count + local];
    let b = vertices[f1 * count + local];
    let blend = clamp(inst.blend, 0.0, 1.0);
    let model = mix(bitcast<vec3<f32>>(a.xyz), bitcast<vec3<f32>>(b.xyz), blend);
    let n = mix(unpack4x8snorm(a.w).xyz, unpack4x8snorm(b.w).xyz, blend);
    let key = bitcast<vec3<f32>>(vertices[u32(frame.counts.z) * count + local].xyz);
    let view = views[inst.view];
    let q = (key - view.center.xyz) / view.center.w;
    out.uv = vec2<f32>(0.5 + 0.5 * dot(q, view.right.xyz), 0.5 - 0.5 * dot(q, view.up.xyz));
    out.layer = inst.view;
    let world = turn(model, inst.facing) + vec3<f32>(inst.pos.x, 0.0, inst.pos.y);
    out.clip_position = frame.clip_from_world * vec4<f32>(world, 1.0);
    out.normal = turn(n, inst.facing);
    out.tint = part_tint(inst.variant, topology[frame.bases.x + local], frame.params.z);
    out.variant = inst.variant;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    if (faded_out(in.variant, in.clip_position.xy)) {
        discard;
    }
    let albedo = textureSample(images, image_sampler, in.uv, in.layer);
    return shade(albedo.rgb, in.tint, normalize(in.normal), frame.light_dir.xyz, frame.params);
}
