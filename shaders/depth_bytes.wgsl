// Depth readback for backends that cannot copy a depth texture to a buffer (OpenGL): one
// full-target triangle writes each depth texel's f32 bits as the four bytes of an RGBA8
// (unorm) texel, low byte in red. Each byte b is written as b / 255, which unorm storage
// rounds back to exactly b, so the CPU reassembles the depth bit for bit.

// Bound as an unfilterable float texture rather than `texture_depth_2d`: GLSL has no texel
// fetch from depth textures.
@group(0) @binding(0) var depth: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let bits = bitcast<u32>(textureLoad(depth, vec2<i32>(p.xy), 0).r);
    let bytes = vec4<u32>(bits, bits >> 8u, bits >> 16u, bits >> 24u) & vec4<u32>(255u);
    return vec4<f32>(bytes) / 255.0;
}
