// Shared by every crowd shader (prepended to crowd_mesh, impostor, np3d and polypostor.wgsl
// by `src/gpu/shaders.rs`; WGSL has no includes). Keep the structs in sync with
// `crates/polypostor-runtime/src/gpu/crowd_renderers/`, `…/gpu/polypostor_renderer.rs` and `records::Instance`.

// Per-frame settings; `counts` and `bases` mean what each shader says.
struct Frame {
    clip_from_world: mat4x4<f32>,
    // xyz: unit direction towards the light (world).
    light_dir: vec4<f32>,
    counts: vec4<f32>,
    // x: shading (0 unlit, 1 lit), y: ambient, z: tint strength.
    params: vec4<f32>,
    bases: vec4<u32>,
};

// A baked view's orthographic camera.
struct View {
    right: vec4<f32>,
    up: vec4<f32>,
    // Towards the camera; w: the atlas page (Polypostor only).
    forward: vec4<f32>,
    // xyz: centre, w: half size.
    center: vec4<f32>,
    // Polypostor: xy atlas size / page size, zw the atlas's corner in the page.
    uv_scale: vec4<f32>,
};

// One character (32 bytes).
struct Instance {
    pos: vec2<f32>,
    // (sin h, cos h) of the heading h about +Y.
    facing: vec2<f32>,
    view: u32,
    // Bits 0..16: the frame drawn; bits 16..32: the frame it blends towards (`frame_pair`).
    frame: u32,
    blend: f32,
    variant: u32,
};

// The two frames an instance blends between: the one drawn (bits 0..16 of `Instance.frame`)
// and the next as its clip plays (bits 16..32; a clip's last frame is followed by its own
// first, not the next clip's), each wrapped below `frames`. Keep in sync with
// `crowd::frame_pair`.
fn frame_pair(packed: u32, frames: u32) -> vec2<u32> {
    let n = max(frames, 1u);
    return vec2<u32>((packed & 0xffffu) % n, (packed >> 16u) % n);
}

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

// Rotation about +Y by the heading h, given (sin h, cos h).
fn turn(p: vec3<f32>, f: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(f.y * p.x + f.x * p.z, p.y, -f.x * p.x + f.y * p.z);
}

// The colour modulation of body part `part` of an instance: the same in every
// representation, so a character keeps its colours when it changes level.
fn part_tint(variant: u32, part: u32, strength: f32) -> vec3<f32> {
    // Bits 0..24 seed the appearance; the rest is the cross-fade (`faded_out`).
    let h = hash((variant & 0xFFFFFFu) ^ (part * 0x9e3779b9u));
    let t = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    return mix(vec3<f32>(1.0), 0.6 + 0.8 * t, strength);
}

// The ordered-dither threshold (8×8 Bayer, 0..1) of a screen pixel: the Polypostor's key
// cross-fade and every level and view cross-fade compare against it. The matrix entry is the
// bits of x ^ y and y interleaved, lowest first, rather than a table: a dynamically indexed
// local array lives in slow per-thread memory on GPUs and is filled again by every pixel.
// Keep in sync with `bayer_8x8` and `BAYER_8X8` in `raster.rs` (a test compares them).
fn crossfade_threshold(p: vec2<f32>) -> f32 {
    let x = u32(p.x) & 7u;
    let y = u32(p.y) & 7u;
    let z = x ^ y;
    let m = ((z & 1u) << 5u) | ((y & 1u) << 4u) | ((z & 2u) << 2u) | ((y & 2u) << 1u) | ((z & 4u) >> 1u) | ((y & 4u) >> 2u);
    return (f32(m) + 0.5) / 64.0;
}

// Cross-fades between levels of detail and between baked views: bits 24..30 of
// `Instance.variant` hold q (0: drawn whole); the incoming copy is drawn where the pixel's
// threshold is below q / 128, the outgoing copy (bit 31 set) everywhere else, so the two
// cover exactly what one would. Keep in sync with `crowd::fade_keeps`.
fn faded_out(variant: u32, pixel: vec2<f32>) -> bool {
    let q = (variant >> 24u) & 0x7Fu;
    if (q == 0u) {
        return false;
    }
    let keep = crossfade_threshold(pixel) < f32(q) / 128.0;
    return keep == ((variant >> 31u) == 1u);
}

// The world light in a view's camera frame, for a character turned by `facing`.
fn light_in_view(light: vec3<f32>, facing: vec2<f32>, view: View) -> vec3<f32> {
    let l = turn(light, vec2<f32>(-facing.x, facing.y));
    return vec3<f32>(dot(l, view.right.xyz), dot(l, view.up.xyz), dot(l, view.forward.xyz));
}

struct FragmentOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
};

// Albedo × tint, lit by `n·l` with an ambient term (or unlit), and the normal target.
fn shade(albedo: vec3<f32>, tint: vec3<f32>, n: vec3<f32>, l: vec3<f32>, params: vec4<f32>) -> FragmentOut {
    let base = albedo * tint;
    let ambient = params.y;
    let lit = base * (ambient + (1.0 - ambient) * max(dot(n, normalize(l)), 0.0));
    var out: FragmentOut;
    out.color = vec4<f32>(mix(base, lit, params.x), 1.0);
    out.normal = vec4<f32>(n * 0.5 + vec3<f32>(0.5), 1.0);
    return out;
}
