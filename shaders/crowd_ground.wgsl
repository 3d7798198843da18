// The crowd's ground: one quad over the square the agents walk on (`frame.counts.x`: half its
// side) at height `frame.counts.y` (the characters' lowest point), opaque, with anti-aliased
// lines every 2 and 10 units that fade with distance so the far ground does not shimmer. The
// unit is `frame.counts.w` metres (a power of ten: 1 for people, 0.01 for a mouse) and the
// margin beyond the walking area scales with the characters (`frame.counts.z`, 1 for a
// 1.8 m person). Frame, FragmentOut: crowd_common.wgsl.

@group(0) @binding(0) var<uniform> frame: Frame;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) world_xz: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, 1.0),
        vec2<f32>(-1.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    );
    // A little beyond the walking area.
    let xz = corners[i % 6u] * (frame.counts.x + 2.0 * frame.counts.z);
    var out: VertexOut;
    out.clip_position = frame.clip_from_world * vec4<f32>(xz.x, frame.counts.y, xz.y, 1.0);
    out.world_xz = xz;
    return out;
}

fn lines(coord: vec2<f32>, spacing: f32) -> f32 {
    let c = coord / spacing;
    let w = fwidth(c);
    let g = abs(fract(c - 0.5) - 0.5) / max(w, vec2<f32>(1e-4));
    // Fade out where the lines get denser than a few pixels.
    let fade = clamp(1.5 - 4.0 * max(w.x, w.y), 0.0, 1.0);
    return (1.0 - min(min(g.x, g.y), 1.0)) * fade;
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    let base = vec3<f32>(0.16, 0.17, 0.18);
    let unit = max(frame.counts.w, 1e-6);
    let line = max(lines(in.world_xz, 2.0 * unit) * 0.5, lines(in.world_xz, 10.0 * unit));
    var out: FragmentOut;
    out.color = vec4<f32>(mix(base, vec3<f32>(0.3, 0.32, 0.34), line), 1.0);
    // No character here: the normal target stays empty (coverage is read from its alpha).
    out.normal = vec4<f32>(0.0);
    return out;
}
