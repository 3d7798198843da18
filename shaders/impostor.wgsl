// Classic animated impostors: one quad per character in the plane of the nearest baked view
// (turned with the character), textured with that view's image of the current frame (no
// interpolation: the nearest frame) from a sheet of frames, shaded with its normal image.
// Frame.counts: x sheet columns, y sheet rows, z frames. Shared structs and functions:
// crowd_common.wgsl. Keep the structs in sync with
// `crates/polypostor-runtime/src/gpu/crowd_renderers/`.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
@group(0) @binding(3) var sheets: texture_2d_array<f32>;
@group(0) @binding(4) var normal_sheets: texture_2d_array<f32>;
// The body part of each texel (R8, part number / 255), read unfiltered.
@group(0) @binding(5) var part_sheets: texture_2d_array<f32>;
@group(0) @binding(6) var sheet_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
    @location(2) light_view: vec3<f32>,
    @location(3) @interpolate(flat) variant: u32,
};

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VertexOut {
    var out: VertexOut;
    let inst = instances[ii];
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    let xy = corners[vi % 6u];
    let view = views[inst.view];
    let model = view.center.xyz + (xy.x * view.right.xyz + xy.y * view.up.xyz) * view.center.w;
    let world = turn(model, inst.facing) + vec3<f32>(inst.pos.x, 0.0, inst.pos.y);
    out.clip_position = frame.clip_from_world * vec4<f32>(world, 1.0);
    let frames = max(u32(frame.counts.z), 1u);
    let columns = max(u32(frame.counts.x), 1u);
    // Impostors cannot interpolate: the nearest baked frame.
    let pair = frame_pair(inst.frame, frames);
    let f = select(pair.x, pair.y, inst.blend >= 0.5);
    let tile = vec2<f32>(f32(f % columns), f32(f / columns));
    out.uv = (tile + vec2<f32>(0.5 + 0.5 * xy.x, 0.5 - 0.5 * xy.y)) / frame.counts.xy;
    out.layer = inst.view;
    out.light_view = light_in_view(frame.light_dir.xyz, inst.facing, view);
    out.variant = inst.variant;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    if (faded_out(in.variant, in.clip_position.xy)) {
        discard;
    }
    let albedo = textureSample(sheets, sheet_sampler, in.uv, in.layer);
    if (albedo.a < 0.5) {
        discard;
    }
    let n = normalize(textureSample(normal_sheets, sheet_sampler, in.uv, in.layer).xyz * 2.0 - vec3<f32>(1.0));
    let size = vec2<f32>(textureDimensions(part_sheets));
    let texel = vec2<i32>(clamp(in.uv * size, vec2<f32>(0.0), size - vec2<f32>(1.0)));
    let part = u32(round(textureLoad(part_sheets, texel, i32(in.layer), 0).r * 255.0));
    return shade(albedo.rgb, part_tint(in.variant, part, frame.params.z), n, in.light_view, frame.params);
}
