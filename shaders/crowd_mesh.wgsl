// Crowd meshes: every skinned or rigid character of a crowd in one instanced draw per
// material. Skinned: the clip's joints are sampled ahead (the rows of each joint's skinning
// matrix per sample) and interpolated per vertex between the two samples around the
// instance's time, then blended by the vertex's four weights. Rigid: the mesh pre-skinned at
// every frame, interpolated between two frames.
// Frame.counts: x joint samples per frame, y frames, z joints, w vertices. Shared structs and
// functions: crowd_common.wgsl. Keep the structs in sync with `crates/polypostor-runtime/src/gpu/crowd_renderers/`.

struct Joint {
    // The first three rows of the joint's skinning matrix (any affine map: mirrors,
    // non-uniform and zero scales included).
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
};

fn apply_joint(j: Joint, p: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(dot(j.r0, p), dot(j.r1, p), dot(j.r2, p));
}

struct Material {
    base_color_factor: vec4<f32>,
    // x: alpha cut-off (0 draws every fragment).
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> joints: array<Joint>;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
// Rigid: per frame, per vertex: position xyz (f32 bits) and the normal packed as snorm8x4
// in w. Skinned, where clips animate morph targets (the skinned level's bind group holds
// them here): per joint sample, per vertex, the bind-space position offset (f32 bits) and half
// the normal's change (snorm8x4 in w); shorter than samples × vertices (a placeholder) otherwise.
@group(0) @binding(3) var<storage, read> rigid: array<vec4<u32>>;
// Body part of each vertex (for the per-part tint).
@group(0) @binding(4) var<storage, read> vertex_parts: array<u32>;
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) color: vec4<f32>,
    @location(3) tint: vec3<f32>,
    // The instance's variant: its level cross-fade bits (`faded_out`).
    @location(4) @interpolate(flat) variant: u32,
};

fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

fn place(inst: Instance, model: vec3<f32>, normal: vec3<f32>, vi: u32, uv: vec2<f32>, color: vec4<f32>) -> VertexOut {
    var out: VertexOut;
    let world = turn(model, inst.facing) + vec3<f32>(inst.pos.x, 0.0, inst.pos.y);
    out.clip_position = frame.clip_from_world * vec4<f32>(world, 1.0);
    out.normal = turn(normal, inst.facing);
    out.uv = uv;
    out.color = color;
    out.tint = part_tint(inst.variant, vertex_parts[vi], frame.params.z);
    out.variant = inst.variant;
    return out;
}

struct SkinnedIn {
    @builtin(vertex_index) vi: u32,
    @builtin(instance_index) ii: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
    @location(4) bone_ids: vec4<u32>,
    @location(5) weights: vec4<f32>,
};

@vertex
fn vs_skinned(v: SkinnedIn) -> VertexOut {
    let inst = instances[v.ii];
    let per_frame = max(frame.counts.x, 1.0);
    let frames = max(u32(frame.counts.y), 1u);
    let bones = max(u32(frame.counts.z), 1u);
    let samples = frames * u32(per_frame);
    let pair = frame_pair(inst.frame, frames);
    // The samples of frame f0 run from f0 · per_frame; past its last one comes the first of
    // f1 (the next frame as the clip plays).
    let t = clamp(inst.blend, 0.0, 1.0) * per_frame;
    let sub = min(u32(floor(t)), u32(per_frame) - 1u);
    let s0 = min(pair.x * u32(per_frame) + sub, samples - 1u);
    let s1 = select(s0 + 1u, pair.y * u32(per_frame), sub + 1u >= u32(per_frame));
    let a = clamp(t - f32(sub), 0.0, 1.0);
    // The blended skinning matrix's rows.
    var r0 = vec4<f32>(0.0);
    var r1 = vec4<f32>(0.0);
    var r2 = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let w = v.weights[k];
        if (w > 0.0) {
            let b = min(v.bone_ids[k], bones - 1u);
            let j0 = joints[s0 * bones + b];
            let j1 = joints[s1 * bones + b];
            // Samples a quarter frame apart: blending the two matrices (as linear blend
            // skinning blends bones) turns by a few degrees at most, where it shrinks by
            // under 0.1 %.
            r0 += w * mix(j0.r0, j1.r0, a);
            r1 += w * mix(j0.r1, j1.r1, a);
            r2 += w * mix(j0.r2, j1.r2, a);
        }
    }
    // Morph targets move the bind-space vertex first, sampled as the joints are.
    var position = v.position;
    var normal = v.normal;
    let count = u32(frame.counts.w);
    if (count > 0u && arrayLength(&rigid) >= samples * count) {
        let m0 = rigid[s0 * count + v.vi];
        let m1 = rigid[s1 * count + v.vi];
        position += mix(bitcast<vec3<f32>>(m0.xyz), bitcast<vec3<f32>>(m1.xyz), a);
        normal += 2.0 * mix(unpack4x8snorm(m0.w).xyz, unpack4x8snorm(m1.w).xyz, a);
    }
    let p = apply_joint(Joint(r0, r1, r2), vec4<f32>(position, 1.0));
    // The normal through the inverse transpose of the matrix's 3×3 part, whose rows a, b, c
    // give it as rows b×c, c×a, a×b (signed by the determinant): an unevenly scaled joint keeps
    // normals at right angles to the surface (`animation::normal_transform` on the CPU).
    let ra = r0.xyz;
    let rb = r1.xyz;
    let rc = r2.xyz;
    let sign = select(1.0, -1.0, dot(ra, cross(rb, rc)) < 0.0);
    let n = sign * vec3<f32>(dot(cross(rb, rc), normal), dot(cross(rc, ra), normal), dot(cross(ra, rb), normal));
    // Scaled joints (a centimetre rig, a joint scaled to nothing) scale the normal too.
    let len = length(n);
    return place(inst, p, select(vec3<f32>(0.0, 1.0, 0.0), n / len, len > 1e-20), v.vi, v.uv, v.color);
}

struct RigidIn {
    @builtin(vertex_index) vi: u32,
    @builtin(instance_index) ii: u32,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
};

@vertex
fn vs_rigid(v: RigidIn) -> VertexOut {
    let inst = instances[v.ii];
    let frames = max(u32(frame.counts.y), 1u);
    let count = u32(frame.counts.w);
    let pair = frame_pair(inst.frame, frames);
    let f0 = pair.x;
    let f1 = pair.y;
    let a = rigid[f0 * count + v.vi];
    let b = rigid[f1 * count + v.vi];
    let blend = clamp(inst.blend, 0.0, 1.0);
    let na = unpack4x8snorm(a.w).xyz;
    let nb = unpack4x8snorm(b.w).xyz;
    let p = mix(bitcast<vec3<f32>>(a.xyz), bitcast<vec3<f32>>(b.xyz), blend);
    return place(inst, p, mix(na, nb, blend), v.vi, v.uv, v.color);
}

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    if (faded_out(in.variant, in.clip_position.xy)) {
        discard;
    }
    let albedo = textureSample(base_texture, base_sampler, in.uv) * material.base_color_factor * in.color;
    if (albedo.a < material.params.x) {
        discard;
    }
    return shade(albedo.rgb, in.tint, normalize(in.normal), frame.light_dir.xyz, frame.params);
}
