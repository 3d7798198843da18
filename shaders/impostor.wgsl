// Classic animated impostors: one quad per character in the plane of the nearest baked view
// (turned with the character), textured with that view's image of the current frame (no
// interpolation: the nearest frame) from a sheet of frames, shaded with its normal image.
// Keep the structs in sync with `src/gpu/crowd_renderers.rs`.

struct Frame {
    clip_from_world: mat4x4<f32>,
    light_dir: vec4<f32>,
    // x: sheet columns, y: sheet rows, z: frames.
    counts: vec4<f32>,
    // x: shading (0 unlit, 1 lit), y: ambient, z: tint strength.
    params: vec4<f32>,
    bases: vec4<u32>,
};

struct View {
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // xyz: centre, w: half size.
    center: vec4<f32>,
    uv_scale: vec4<f32>,
};

struct Instance {
    pos: vec2<f32>,
    facing: vec2<f32>,
    view: u32,
    frame: u32,
    blend: f32,
    variant: u32,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
@group(0) @binding(3) var sheets: texture_2d_array<f32>;
@group(0) @binding(4) var normal_sheets: texture_2d_array<f32>;
@group(0) @binding(5) var sheet_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
    @location(2) light_view: vec3<f32>,
    @location(3) tint: vec3<f32>,
};

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn turn(p: vec3<f32>, f: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(f.y * p.x + f.x * p.z, p.y, -f.x * p.x + f.y * p.z);
}

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
    let f = (inst.frame + u32(inst.blend >= 0.5)) % frames;
    let tile = vec2<f32>(f32(f % columns), f32(f / columns));
    out.uv = (tile + vec2<f32>(0.5 + 0.5 * xy.x, 0.5 - 0.5 * xy.y)) / frame.counts.xy;
    out.layer = inst.view;
    let l = turn(frame.light_dir.xyz, vec2<f32>(-inst.facing.x, inst.facing.y));
    out.light_view = vec3<f32>(dot(l, view.right.xyz), dot(l, view.up.xyz), dot(l, view.forward.xyz));
    let h = hash(inst.variant);
    let t = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    out.tint = mix(vec3<f32>(1.0), 0.6 + 0.8 * t, frame.params.z);
    return out;
}

struct FragmentOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
};

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    let albedo = textureSample(sheets, sheet_sampler, in.uv, in.layer);
    if (albedo.a < 0.5) {
        discard;
    }
    let n = normalize(textureSample(normal_sheets, sheet_sampler, in.uv, in.layer).xyz * 2.0 - vec3<f32>(1.0));
    let ambient = frame.params.y;
    let diffuse = max(dot(n, normalize(in.light_view)), 0.0);
    let base = albedo.rgb * in.tint;
    let lit = base * (ambient + (1.0 - ambient) * diffuse);
    var out: FragmentOut;
    out.color = vec4<f32>(mix(base, lit, frame.params.x), 1.0);
    out.normal = vec4<f32>(n * 0.5 + vec3<f32>(0.5), 1.0);
    return out;
}
