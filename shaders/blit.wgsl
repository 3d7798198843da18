// Copies an offscreen image into a rectangle of the egui frame (the viewport's paint
// callback). Draws one full-viewport triangle.
//
// `fs_main` converts no colour: the caller binds a view of the image whose encoding matches
// the window's (the sRGB view for an sRGB window, the raw-bytes view otherwise), so the copy
// costs one texel fetch per pixel — it runs on every frame, and on a software rasteriser a
// per-pixel `pow` is a measurable share of the frame. `fs_encode` is for a non-sRGB window
// where no raw-bytes view can be made (OpenGL): it encodes the decoded colour back to sRGB.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    var out: VertexOut;
    out.clip_position = vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
    out.uv = vec2<f32>(x, y);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSample(source, source_sampler, in.uv).rgb, 1.0);
}

@fragment
fn fs_encode(in: VertexOut) -> @location(0) vec4<f32> {
    let c = textureSample(source, source_sampler, in.uv).rgb;
    let encoded = select(1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055, c * 12.92, c <= vec3<f32>(0.0031308));
    return vec4<f32>(encoded, 1.0);
}
