// Ground grid on the y = 0 plane: anti-aliased lines every cell and every tenth of one,
// fading with distance, red X axis and blue Z axis. Drawn as one large quad. The cell is
// `frame.params.w` world units (a power of ten that suits the character's size; 0: 1 m), so
// a character in any unit stands on a grid of its own scale.
// Keep `FrameUniforms` in sync with `character.wgsl` and `src/gpu/gpu_data.rs`.

struct FrameUniforms {
    clip_from_world: mat4x4<f32>,
    view_from_world: mat4x4<f32>,
    light_dir_view: vec4<f32>,
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) world_xz: vec2<f32>,
};

const EXTENT: f32 = 50.0;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    // Two triangles: (0,1,2), (2,1,3) over the corners of the square.
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, 1.0),
        vec2<f32>(-1.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    );
    let xz = corners[i] * EXTENT * grid_cell();
    var out: VertexOut;
    out.clip_position = frame.clip_from_world * vec4<f32>(xz.x, 0.0, xz.y, 1.0);
    out.world_xz = xz;
    return out;
}

fn grid_cell() -> f32 {
    return select(1.0, frame.params.w, frame.params.w > 0.0);
}

fn line_mask(coord: vec2<f32>, spacing: f32) -> f32 {
    let c = coord / spacing;
    let w = fwidth(c);
    let g = abs(fract(c - 0.5) - 0.5) / max(w, vec2<f32>(1e-4));
    return 1.0 - min(min(g.x, g.y), 1.0);
}

struct FragmentOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
};

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    // In cells: the same picture whatever the unit.
    let xz = in.world_xz / grid_cell();
    let major = line_mask(xz, 1.0);
    let minor = line_mask(xz, 0.1) * 0.35;
    let d = length(xz);
    let fade = clamp(1.0 - d / 20.0, 0.0, 1.0);
    var color = vec3<f32>(0.55, 0.56, 0.58);
    let w = fwidth(xz);
    let on_x = 1.0 - min(abs(xz.y) / max(w.y, 1e-4), 1.0);
    let on_z = 1.0 - min(abs(xz.x) / max(w.x, 1e-4), 1.0);
    var alpha = max(major, minor) * fade * 0.6;
    if (on_x > 0.0) { color = mix(color, vec3<f32>(0.85, 0.25, 0.25), on_x); alpha = max(alpha, on_x * fade); }
    if (on_z > 0.0) { color = mix(color, vec3<f32>(0.25, 0.45, 0.9), on_z); alpha = max(alpha, on_z * fade); }
    if (alpha < 0.01) {
        discard;
    }
    var out: FragmentOut;
    out.color = vec4<f32>(color, alpha);
    out.normal = vec4<f32>(0.5, 1.0, 0.5, 0.0);
    return out;
}
