//! Pose sampling and CPU skinning.
//!
//! [`Pose::sample`] evaluates a clip at any time (looping) into per-node local transforms,
//! then world matrices and per-bone skinning matrices. [`skin_vertices`] applies them on the
//! CPU; `shaders/character.wgsl` does exactly the same on the GPU.

use glam::{Mat4, Quat, Vec3};

use crate::character::{Channel, ChannelValues, Character, Clip, Interpolation, Transform};

/// A sampled pose: local and world transforms of every node and the skinning matrix of
/// every bone.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Local transform of every skeleton node, indexed like `Skeleton::nodes`: the clip's
    /// sampled values, and the node's rest transform for whatever the clip does not animate.
    pub locals: Vec<Transform>,
    /// Matrix taking each node's space into the character's model space (the space above the
    /// skeleton's roots, where skinned vertices land), indexed like `Skeleton::nodes`.
    pub world_from_node: Vec<Mat4>,
    /// `world_from_node[bone.node] * bone.inverse_bind`, one per bone.
    pub skin_from_bind: Vec<Mat4>,
    /// Weight of every morph target, indexed like [`Character::morphs`] (their rest weights
    /// where the clip does not move them; empty for a character without animated morphs).
    pub morph_weights: Vec<f32>,
}

impl Pose {
    /// The rest pose (no clip).
    pub fn rest(character: &Character) -> Self {
        let locals: Vec<Transform> = character.skeleton.nodes.iter().map(|n| n.rest).collect();
        Self::from_locals(character, locals)
    }

    /// The pose of `clip` at `time_secs`, wrapped into the clip's duration (clips loop).
    pub fn sample(character: &Character, clip: &Clip, time_secs: f32) -> Self {
        let t = wrap_time(time_secs, clip.duration_secs);
        let mut locals: Vec<Transform> = character.skeleton.nodes.iter().map(|n| n.rest).collect();
        for ch in &clip.channels {
            if let Some(local) = locals.get_mut(ch.node) {
                apply_channel(ch, t, local);
            }
        }
        let mut pose = Self::from_locals(character, locals);
        for ch in &clip.morph_channels {
            apply_morph_channel(ch, t, &mut pose.morph_weights);
        }
        let shift = -clip.in_place_velocity * t;
        if shift != Vec3::ZERO && shift.is_finite() {
            // Root motion taken out: the whole character goes back by what it travelled.
            let back = Mat4::from_translation(shift);
            for m in pose.world_from_node.iter_mut().chain(pose.skin_from_bind.iter_mut()) {
                *m = back * *m;
            }
        }
        pose
    }

    /// Pose of clip `clip_index`, or the rest pose when there is no such clip.
    pub fn sample_index(character: &Character, clip_index: Option<usize>, time_secs: f32) -> Self {
        match clip_index.and_then(|i| character.clips.get(i)) {
            Some(clip) => Self::sample(character, clip, time_secs),
            None => Self::rest(character),
        }
    }

    fn from_locals(character: &Character, locals: Vec<Transform>) -> Self {
        let world_from_node = character.skeleton.world_from_locals(&locals);
        let skin_from_bind = character
            .bones
            .iter()
            .map(|b| world_from_node.get(b.node).copied().unwrap_or(Mat4::IDENTITY) * b.inverse_bind)
            .collect();
        Self {
            locals,
            world_from_node,
            skin_from_bind,
            morph_weights: character.morphs.iter().map(|m| m.rest_weight).collect(),
        }
    }

    /// Whether some morph target is away from its rest weight (the bind-space vertices
    /// differ from [`Character::vertices`]).
    pub fn morphs_move(&self, character: &Character) -> bool {
        self.morph_weights
            .iter()
            .zip(&character.morphs)
            .any(|(w, m)| *w != m.rest_weight && !m.vertices.is_empty())
    }
}

/// Bind-space positions and normals (normalised) of every vertex with the pose's morph
/// weights applied; `None` where every target is at its rest weight (the vertices as they
/// are).
pub fn morphed_bind(character: &Character, pose: &Pose) -> Option<(Vec<Vec3>, Vec<Vec3>)> {
    if !pose.morphs_move(character) {
        return None;
    }
    let mut positions: Vec<Vec3> = character.vertices.iter().map(|v| v.position).collect();
    let mut normals: Vec<Vec3> = character.vertices.iter().map(|v| v.normal).collect();
    for (m, &w) in character.morphs.iter().zip(&pose.morph_weights) {
        let k = w - m.rest_weight;
        if k == 0.0 {
            continue;
        }
        for ((&v, dp), dn) in m.vertices.iter().zip(&m.positions).zip(&m.normals) {
            if let (Some(p), Some(n)) = (positions.get_mut(v as usize), normals.get_mut(v as usize)) {
                *p += *dp * k;
                *n += *dn * k;
            }
        }
    }
    normals.iter_mut().for_each(|n| *n = n.normalize_or_zero());
    Some((positions, normals))
}

/// Samples a morph weights channel at `t` into `weights` (indexed like
/// [`Character::morphs`]).
fn apply_morph_channel(ch: &crate::character::MorphChannel, t: f32, weights: &mut [f32]) {
    let n = ch.targets.len();
    let per_key = if ch.interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if ch.times.is_empty() || n == 0 || ch.values.len() != ch.times.len() * per_key * n {
        return;
    }
    let (i0, i1, u, dt) = locate(&ch.times, t);
    let row = |k: usize, j: usize| ch.values[k * n + j];
    for (j, &target) in ch.targets.iter().enumerate() {
        let w = match ch.interpolation {
            Interpolation::Step => row(i0, j),
            Interpolation::Linear => row(i0, j) + (row(i1, j) - row(i0, j)) * u,
            Interpolation::CubicSpline => {
                let p0 = row(i0 * 3 + 1, j);
                if i0 == i1 {
                    p0
                } else {
                    hermite(p0, row(i0 * 3 + 2, j) * dt, row(i1 * 3 + 1, j), row(i1 * 3, j) * dt, u)
                }
            }
        };
        if let Some(slot) = weights.get_mut(target)
            && w.is_finite()
        {
            *slot = w;
        }
    }
}

/// `time` wrapped into `[0, duration)`; `0` for an empty clip.
pub fn wrap_time(time: f32, duration: f32) -> f32 {
    if duration > 0.0 && time.is_finite() {
        time.rem_euclid(duration)
    } else {
        0.0
    }
}

/// The blended skinning matrix of one vertex.
#[inline]
pub fn vertex_matrix(skin_from_bind: &[Mat4], bones: [u16; 4], weights: [f32; 4]) -> Mat4 {
    let mut m = Mat4::ZERO;
    for k in 0..4 {
        let w = weights[k];
        if w != 0.0 {
            let b = skin_from_bind.get(bones[k] as usize).copied().unwrap_or(Mat4::IDENTITY);
            m += b * w;
        }
    }
    m
}

/// Skinned positions and normals of every vertex for `pose` (linear blend skinning).
pub fn skin_vertices(character: &Character, pose: &Pose) -> (Vec<Vec3>, Vec<Vec3>) {
    let morphed = morphed_bind(character, pose);
    let mut positions = Vec::with_capacity(character.vertices.len());
    let mut normals = Vec::with_capacity(character.vertices.len());
    for (i, v) in character.vertices.iter().enumerate() {
        let (p, n) = match &morphed {
            Some((p, n)) => (p[i], n[i]),
            None => (v.position, v.normal),
        };
        let m = vertex_matrix(&pose.skin_from_bind, v.bones, v.weights);
        positions.push(m.transform_point3(p));
        normals.push(normal_transform(&m, n).normalize_or_zero());
    }
    (positions, normals)
}

/// A normal carried by the blended skinning matrix `m`: through the inverse transpose of its
/// 3×3 part, so that a joint scaled unevenly (a squash-and-stretch rig, a limb flattened)
/// leaves normals at right angles to the surface it bends; as the cofactor matrix times the
/// sign of the determinant (the same direction, and defined where a joint is scaled to
/// nothing along one axis). Rotations and even scales carry normals as the matrix itself does;
/// `shaders/character.wgsl` and `shaders/crowd_mesh.wgsl` do the same.
pub fn normal_transform(m: &Mat4, n: Vec3) -> Vec3 {
    let (c0, c1, c2) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let det = c0.dot(c1.cross(c2));
    let v = c1.cross(c2) * n.x + c2.cross(c0) * n.y + c0.cross(c1) * n.z;
    if det < 0.0 { -v } else { v }
}

/// Bounds of the skinned mesh over a whole clip, sampled `samples` times (at least 2).
pub fn clip_bounds(character: &Character, clip_index: Option<usize>, samples: usize) -> (Vec3, Vec3) {
    let duration = clip_index
        .and_then(|i| character.clips.get(i))
        .map_or(0.0, |c| c.duration_secs);
    let samples = samples.max(2);
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for s in 0..samples {
        let t = duration * s as f32 / samples as f32;
        let pose = Pose::sample_index(character, clip_index, t);
        let (p, _) = skin_vertices(character, &pose);
        let (lo, hi) = crate::character::bounds(p);
        min = min.min(lo);
        max = max.max(hi);
    }
    if min.x > max.x {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (min, max)
    }
}

fn apply_channel(ch: &Channel, t: f32, local: &mut Transform) {
    if ch.times.is_empty() {
        return;
    }
    let (i0, i1, u, dt) = locate(&ch.times, t);
    match &ch.values {
        ChannelValues::Translation(v) => {
            if let Some(x) = interp_vec3(ch.interpolation, v, i0, i1, u, dt) {
                local.translation = x;
            }
        }
        ChannelValues::Scale(v) => {
            if let Some(x) = interp_vec3(ch.interpolation, v, i0, i1, u, dt) {
                local.scale = x;
            }
        }
        ChannelValues::Rotation(v) => {
            if let Some(q) = interp_quat(ch.interpolation, v, i0, i1, u, dt) {
                local.rotation = q;
            }
        }
    }
}

/// The keys around `t`: `(i0, i1, u, dt)` with `u` in `[0,1]` the position between them and
/// `dt` their time difference. Before the first key and after the last the value is held.
fn locate(times: &[f32], t: f32) -> (usize, usize, f32, f32) {
    let last = times.len() - 1;
    if t <= times[0] {
        return (0, 0, 0.0, 0.0);
    }
    if t >= times[last] {
        return (last, last, 0.0, 0.0);
    }
    // First key strictly greater than t.
    let i1 = times.partition_point(|&k| k <= t).clamp(1, last);
    let i0 = i1 - 1;
    let dt = times[i1] - times[i0];
    let u = if dt > 0.0 {
        ((t - times[i0]) / dt).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (i0, i1, u, dt)
}

fn hermite<T>(p0: T, m0: T, p1: T, m1: T, u: f32) -> T
where
    T: std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    let u2 = u * u;
    let u3 = u2 * u;
    p0 * (2.0 * u3 - 3.0 * u2 + 1.0) + m0 * (u3 - 2.0 * u2 + u) + p1 * (-2.0 * u3 + 3.0 * u2) + m1 * (u3 - u2)
}

fn interp_vec3(mode: Interpolation, v: &[Vec3], i0: usize, i1: usize, u: f32, dt: f32) -> Option<Vec3> {
    match mode {
        Interpolation::Step => v.get(i0).copied(),
        Interpolation::Linear => Some(v.get(i0)?.lerp(*v.get(i1)?, u)),
        Interpolation::CubicSpline => {
            let p0 = *v.get(i0 * 3 + 1)?;
            if i0 == i1 {
                return Some(p0);
            }
            let m0 = *v.get(i0 * 3 + 2)? * dt;
            let p1 = *v.get(i1 * 3 + 1)?;
            let m1 = *v.get(i1 * 3)? * dt;
            Some(hermite(p0, m0, p1, m1, u))
        }
    }
}

fn interp_quat(mode: Interpolation, v: &[Quat], i0: usize, i1: usize, u: f32, dt: f32) -> Option<Quat> {
    let q = match mode {
        Interpolation::Step => *v.get(i0)?,
        Interpolation::Linear => {
            let a = *v.get(i0)?;
            let b = *v.get(i1)?;
            a.slerp(b, u)
        }
        Interpolation::CubicSpline => {
            let p0 = *v.get(i0 * 3 + 1)?;
            if i0 == i1 {
                p0
            } else {
                let m0 = *v.get(i0 * 3 + 2)? * dt;
                let p1 = *v.get(i1 * 3 + 1)?;
                let m1 = *v.get(i1 * 3)? * dt;
                hermite(p0, m0, p1, m1, u)
            }
        }
    };
    let n = q.normalize();
    if n.is_finite() { Some(n) } else { None }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::character::{Bone, Node, Skeleton, Vertex};

    /// Normals under an unevenly scaled joint stay at right angles to the surface. Independent
    /// answer: the plane through the vertex spanned by two tangents, carried by the matrix as
    /// points are; its normal is their cross product.
    #[test]
    fn normals_stay_at_right_angles_to_an_unevenly_scaled_surface() {
        let cases = [
            Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0)),
            Mat4::from_scale_rotation_translation(
                Vec3::new(0.3, 1.7, 0.9),
                Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.4),
                Vec3::new(1.0, -2.0, 0.5),
            ),
            // Mirrored and squashed.
            Mat4::from_scale(Vec3::new(-1.0, 0.5, 1.5)),
            // Sheared (two joints blended).
            Mat4::from_cols_array(&[
                1.0, 0.0, 0.0, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            ]),
        ];
        for m in cases {
            for n in [Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.2, -0.5, 0.8), Vec3::Z] {
                let n = n.normalize();
                let t1 = n.any_orthonormal_vector();
                let t2 = n.cross(t1);
                let (a, b) = (m.transform_vector3(t1), m.transform_vector3(t2));
                let expected = a.cross(b).normalize();
                // Facing the same side of the surface as before: det < 0 flips the tangent frame.
                let expected = if m.determinant() < 0.0 { -expected } else { expected };
                let got = normal_transform(&m, n).normalize();
                assert!((got - expected).length() < 1e-5, "{m:?} {n}: {got} against {expected}");
                assert!(got.dot(a).abs() < 1e-5 && got.dot(b).abs() < 1e-5);
            }
        }
        // Even scales and rotations carry normals as the matrix does.
        let r = Mat4::from_scale_rotation_translation(Vec3::splat(0.01), Quat::from_rotation_z(1.1), Vec3::X);
        let n = Vec3::new(0.3, 0.4, 0.5).normalize();
        assert!((normal_transform(&r, n).normalize() - r.transform_vector3(n).normalize()).length() < 1e-5);
        // Flattened to nothing along x: the normal is the flattened surface's, not zero.
        let flat = Mat4::from_scale(Vec3::new(0.0, 1.0, 1.0));
        assert!((normal_transform(&flat, Vec3::new(1.0, 1.0, 0.0)).normalize() - Vec3::X).length() < 1e-6);
    }

    /// A morph target moves its vertices by (weight − rest weight) × offsets, before the
    /// skinning; at the rest weight nothing changes (and no bind-space copy is made); the
    /// channel's two targets take their weights from their own columns; a remap onto copies
    /// and means of vertices carries the offsets along. Independent answer: the offsets added
    /// by hand.
    #[test]
    fn morph_targets_move_their_vertices_by_their_weights() {
        use crate::character::{MorphChannel, MorphTarget};
        let mut c = two_bone_character(Channel {
            node: 1,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: ChannelValues::Translation(vec![Vec3::Y, Vec3::Y]),
        });
        let v0 = c.vertices[0];
        c.vertices = (0..4)
            .map(|i| Vertex {
                position: v0.position + Vec3::X * i as f32,
                ..v0
            })
            .collect();
        c.morphs = vec![
            MorphTarget {
                name: "a".into(),
                rest_weight: 0.25,
                vertices: vec![0],
                positions: vec![Vec3::X],
                normals: vec![Vec3::ZERO],
            },
            MorphTarget {
                name: "b".into(),
                rest_weight: 0.0,
                vertices: vec![0, 1],
                positions: vec![Vec3::Z, Vec3::Z * 2.0],
                normals: vec![Vec3::ZERO; 2],
            },
        ];
        c.clips[0].morph_channels = vec![MorphChannel {
            targets: vec![0, 1],
            interpolation: Interpolation::Linear,
            // Rows: (a, b) at 0 s and at 1 s.
            times: vec![0.0, 1.0],
            values: vec![0.25, 0.0, 1.25, 1.0],
        }];
        let rest = Pose::rest(&c);
        assert_eq!(rest.morph_weights, vec![0.25, 0.0]);
        assert!(morphed_bind(&c, &rest).is_none());
        let at0 = Pose::sample(&c, &c.clips[0], 0.0);
        assert!(morphed_bind(&c, &at0).is_none(), "the weights start at rest");
        let half = Pose::sample(&c, &c.clips[0], 0.5);
        assert!((half.morph_weights[0] - 0.75).abs() < 1e-6 && (half.morph_weights[1] - 0.5).abs() < 1e-6);
        let (p, _) = morphed_bind(&c, &half).expect("moved");
        let v = &c.vertices;
        assert!((p[0] - (v[0].position + Vec3::X * 0.5 + Vec3::Z * 0.5)).length() < 1e-6);
        assert!((p[1] - (v[1].position + Vec3::Z)).length() < 1e-6);
        for i in 2..v.len() {
            assert_eq!(p[i], v[i].position);
        }
        // Skinned: the morphed bind positions through the same matrices.
        let (skinned, _) = skin_vertices(&c, &half);
        for (i, vx) in v.iter().enumerate() {
            let m = vertex_matrix(&half.skin_from_bind, vx.bones, vx.weights);
            assert!((skinned[i] - m.transform_point3(p[i])).length() < 1e-5);
        }
        // Vertex 1 copied twice and the mean of vertices 0 and 1.
        let origins = vec![vec![(1, 1.0)], vec![(3, 1.0)], vec![(0, 0.5), (1, 0.5)], vec![(1, 1.0)]];
        let r = c.morphs_remapped(&origins);
        assert_eq!(r[0].vertices, vec![2]);
        assert!((r[0].positions[0] - Vec3::X * 0.5).length() < 1e-6);
        assert_eq!(r[1].vertices, vec![0, 2, 3]);
        assert!((r[1].positions[1] - Vec3::Z * 1.5).length() < 1e-6);
        assert_eq!(r[1].positions[0], Vec3::Z * 2.0);
    }

    fn two_bone_character(channel: Channel) -> Character {
        Character {
            skeleton: Skeleton {
                nodes: vec![
                    Node {
                        name: "root".into(),
                        parent: None,
                        rest: Transform::IDENTITY,
                        is_joint: true,
                    },
                    Node {
                        name: "child".into(),
                        parent: Some(0),
                        rest: Transform {
                            translation: Vec3::Y,
                            ..Transform::IDENTITY
                        },
                        is_joint: true,
                    },
                ],
            },
            bones: vec![
                Bone {
                    node: 0,
                    inverse_bind: Mat4::IDENTITY,
                },
                Bone {
                    node: 1,
                    inverse_bind: Mat4::from_translation(-Vec3::Y),
                },
            ],
            vertices: vec![Vertex {
                position: Vec3::new(0.0, 2.0, 0.0),
                normal: Vec3::X,
                uv: [0.0; 2],
                color: [1.0; 4],
                bones: [1, 0, 0, 0],
                weights: [1.0, 0.0, 0.0, 0.0],
            }],
            clips: vec![Clip {
                name: "c".into(),
                duration_secs: 1.0,
                channels: vec![channel],
                in_place_velocity: Vec3::ZERO,
                morph_channels: Vec::new(),
            }],
            ..Default::default()
        }
    }

    #[test]
    fn linear_rotation_skins_vertex_around_child_joint() {
        let q = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let c = two_bone_character(Channel {
            node: 1,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: ChannelValues::Rotation(vec![Quat::IDENTITY, q]),
        });
        // At t = 0.5 the child is rotated by 45° about Z around (0,1,0).
        let pose = Pose::sample(&c, &c.clips[0], 0.5);
        let (p, n) = skin_vertices(&c, &pose);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert!((p[0] - Vec3::new(-s, 1.0 + s, 0.0)).length() < 1e-5, "{:?}", p[0]);
        assert!((n[0] - Vec3::new(s, s, 0.0)).length() < 1e-5, "{:?}", n[0]);
    }

    #[test]
    fn step_holds_previous_key_and_time_wraps() {
        let c = two_bone_character(Channel {
            node: 0,
            interpolation: Interpolation::Step,
            times: vec![0.0, 0.5],
            values: ChannelValues::Translation(vec![Vec3::ZERO, Vec3::X]),
        });
        let at = |t: f32| Pose::sample(&c, &c.clips[0], t).locals[0].translation;
        assert_eq!(at(0.49), Vec3::ZERO);
        assert_eq!(at(0.5), Vec3::X);
        assert_eq!(at(0.99), Vec3::X);
        // 1.25 wraps to 0.25.
        assert_eq!(at(1.25), Vec3::ZERO);
        assert_eq!(at(-0.25), Vec3::X);
    }

    #[test]
    fn cubic_spline_passes_through_keys_and_follows_tangents() {
        // Values v(t) = t^3 sampled at 0 and 1 with exact tangents: 0 and 3.
        let c = two_bone_character(Channel {
            node: 0,
            interpolation: Interpolation::CubicSpline,
            times: vec![0.0, 1.0],
            values: ChannelValues::Translation(vec![
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::X * 3.0,
                Vec3::X,
                Vec3::ZERO,
            ]),
        });
        let mut clip = c.clips[0].clone();
        clip.duration_secs = 2.0; // do not wrap at 1
        for t in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            let x = Pose::sample(&c, &clip, t).locals[0].translation.x;
            assert!((x - t * t * t).abs() < 1e-5, "t={t}: {x}");
        }
    }
}
