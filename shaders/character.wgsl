// Skinned character: GPU linear blend skinning, base colour x vertex colour x material factor,
// written to a colour target and a view-space normal target.
// Keep the structs in sync with `src/gpu/gpu_data.rs`.

const MAX_BONES: u32 = 256u;

struct FrameUniforms {
    clip_from_world: mat4x4<f32>,
    view_from_world: mat4x4<f32>,
    // xyz: unit direction towards the light, in view space.
    light_dir_view: vec4<f32>,
    // x: shading (0 = unlit albedo, 1 = lit), y: ambient term, z: rim strength.
    params: vec4<f32>,
};

struct Bones {
    // world_from_bind per bone.
    m: array<mat4x4<f32>, MAX_BONES>,
};

struct MaterialUniforms {
    base_color_factor: vec4<f32>,
    // x: alpha cut-off (0 draws every fragment).
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var<uniform> bones: Bones;
@group(1) @binding(0) var<uniform> material: MaterialUniforms;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
    @location(4) bone_ids: vec4<u32>,
    @location(5) weights: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) normal_view: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) color: vec4<f32>,
};

fn bone(i: u32) -> mat4x4<f32> {
    return bones.m[min(i, MAX_BONES - 1u)];
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    let skin = bone(v.bone_ids.x) * v.weights.x
        + bone(v.bone_ids.y) * v.weights.y
        + bone(v.bone_ids.z) * v.weights.z
        + bone(v.bone_ids.w) * v.weights.w;
    let world = skin * vec4<f32>(v.position, 1.0);
    // Through the inverse transpose (as the cofactor matrix, signed by the determinant): an
    // unevenly scaled joint keeps normals at right angles to the surface
    // (`animation::normal_transform` on the CPU).
    let c0 = skin[0].xyz;
    let c1 = skin[1].xyz;
    let c2 = skin[2].xyz;
    let cofactor = mat3x3<f32>(cross(c1, c2), cross(c2, c0), cross(c0, c1));
    let normal_world = cofactor * v.normal * select(1.0, -1.0, dot(c0, cross(c1, c2)) < 0.0);
    var out: VertexOut;
    out.clip_position = frame.clip_from_world * world;
    out.normal_view = (frame.view_from_world * vec4<f32>(normal_world, 0.0)).xyz;
    out.uv = v.uv;
    out.color = v.color;
    return out;
}

struct FragmentOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
};

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> FragmentOut {
    var n = normalize(in.normal_view);
    if (!front) {
        n = -n;
    }
    let albedo = textureSample(base_texture, base_sampler, in.uv) * material.base_color_factor * in.color;
    if (albedo.a < material.params.x) {
        discard;
    }
    let l = normalize(frame.light_dir_view.xyz);
    let ambient = frame.params.y;
    let diffuse = max(dot(n, l), 0.0);
    // Rim light from behind the silhouette (view space: the camera looks down -z).
    let rim = pow(1.0 - clamp(n.z, 0.0, 1.0), 3.0) * frame.params.z;
    let lit = albedo.rgb * (ambient + (1.0 - ambient) * diffuse) + vec3<f32>(rim);
    var out: FragmentOut;
    out.color = vec4<f32>(mix(albedo.rgb, lit, frame.params.x), 1.0);
    out.normal = vec4<f32>(n * 0.5 + vec3<f32>(0.5), 1.0);
    return out;
}
