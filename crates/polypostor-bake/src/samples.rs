//! Characters made by code for trying the tool on what is not the default humanoid.
//!
//! [`quadruped`]: a long-bodied four-legged animal (about 1.3 m tall at the head, 2.7 m from
//! nose to tail tip) whose joints are named as a Blender rig writes them (`b_` prefixes, `.L`
//! / `.R`), with a smoothly skinned mesh (tubes along the bones, weights blended at every
//! joint), a striped procedural texture and three clips: `Walk` (a four-beat walk, 1.2 s) and
//! `Trot` (diagonal pairs, 0.6 s) that move forward by **root motion** (the hips' translation
//! carries the body while the feet stay nearly planted, as motion-captured clips do), and
//! `Idle` (2 s, grazing and tail swishing, in place). `polypostor generate-default --quadruped`
//! writes it as `.glb`; `tools/unit_copy.py` makes centimetre copies of it.

use std::f32::consts::TAU;

use glam::{Mat4, Quat, Vec3};

use crate::character::{
    Bone, Channel, ChannelValues, Character, Clip, Interpolation, Material, Node, Skeleton, Submesh, Texture,
    Transform, Vertex,
};

/// Keys per second of the generated clips.
const KEYS_PER_SEC: f32 = 30.0;
/// Vertices around each ring of a tube.
const RING: usize = 12;
/// Side of the procedural texture.
const TEXTURE_SIDE: u32 = 256;

/// The skeleton: (name, parent, head position in metres, tube radius there).
struct Joints(Vec<(String, Option<usize>, Vec3, f32)>);

impl Joints {
    fn add(&mut self, name: &str, parent: Option<usize>, head: [f32; 3], radius: f32) -> usize {
        self.0.push((name.to_string(), parent, Vec3::from_array(head), radius));
        self.0.len() - 1
    }
    fn find(&self, name: &str) -> usize {
        self.0
            .iter()
            .position(|j| j.0 == name)
            .expect("a joint the generator made")
    }
}

fn skeleton() -> (Joints, Vec<Vec<usize>>) {
    let mut j = Joints(Vec::new());
    let hips = j.add("b_Hips", None, [0.0, 0.86, -0.6], 0.2);
    let spine = j.add("b_Spine", Some(hips), [0.0, 0.9, 0.0], 0.23);
    let chest = j.add("b_Chest", Some(spine), [0.0, 0.92, 0.55], 0.21);
    let neck = j.add("b_Neck", Some(chest), [0.0, 1.12, 0.82], 0.1);
    let head = j.add("b_Head", Some(neck), [0.0, 1.3, 0.98], 0.12);
    let nose = j.add("b_HeadEnd", Some(head), [0.0, 1.2, 1.32], 0.05);
    let mut chains = vec![vec![hips, spine, chest, neck, head, nose]];
    for (side, x) in [("L", 0.15f32), ("R", -0.15)] {
        for (end, parent, z, knee_dz) in [("Front", chest, 0.55f32, 0.03f32), ("Back", hips, -0.6, -0.08)] {
            let a = j.add(&format!("b_{end}Leg1.{side}"), Some(parent), [x, 0.74, z], 0.075);
            let b = j.add(&format!("b_{end}Leg2.{side}"), Some(a), [x, 0.44, z + knee_dz], 0.05);
            let c = j.add(&format!("b_{end}Leg3.{side}"), Some(b), [x, 0.1, z], 0.04);
            let f = j.add(&format!("b_{end}Foot.{side}"), Some(c), [x, 0.0, z + 0.07], 0.045);
            chains.push(vec![a, b, c, f]);
        }
    }
    let t1 = j.add("b_Tail01", Some(hips), [0.0, 0.92, -0.82], 0.06);
    let t2 = j.add("b_Tail02", Some(t1), [0.0, 0.84, -1.06], 0.045);
    let t3 = j.add("b_Tail03", Some(t2), [0.0, 0.72, -1.26], 0.03);
    let t4 = j.add("b_Tail04", Some(t3), [0.0, 0.6, -1.4], 0.012);
    chains.push(vec![t1, t2, t3, t4]);
    (j, chains)
}

/// Builds the quadruped (see the module's documentation).
pub fn quadruped() -> Character {
    let (joints, chains) = skeleton();
    let nodes: Vec<Node> = joints
        .0
        .iter()
        .map(|(name, parent, head, _)| Node {
            name: name.clone(),
            parent: *parent,
            rest: Transform {
                translation: *head - parent.map_or(Vec3::ZERO, |p| joints.0[p].2),
                ..Transform::IDENTITY
            },
            is_joint: true,
        })
        .collect();
    let bones: Vec<Bone> = joints
        .0
        .iter()
        .enumerate()
        .map(|(i, j)| Bone {
            node: i,
            inverse_bind: Mat4::from_translation(-j.2),
        })
        .collect();
    let (mut vertices, mut indices) = (Vec::new(), Vec::new());
    for chain in &chains {
        tube(&joints, chain, &mut vertices, &mut indices);
    }
    Character {
        name: "Quadruped".into(),
        submeshes: vec![Submesh {
            first_index: 0,
            index_count: indices.len() as u32,
            material: 0,
        }],
        vertices,
        indices,
        materials: vec![Material {
            name: "Fur".into(),
            base_color_factor: [1.0; 4],
            base_color_texture: Some(0),
            double_sided: false,
            alpha_cutoff: 0.0,
            wrap: Default::default(),
        }],
        textures: vec![fur_texture()],
        skeleton: Skeleton { nodes },
        bones,
        clips: vec![
            clip("Walk", 1.2, &joints, walk),
            clip("Trot", 0.6, &joints, trot),
            clip("Idle", 2.0, &joints, idle),
        ],
        warnings: Vec::new(),
        up_axis: Default::default(),
        morphs: Vec::new(),
    }
}

/// The quadruped as `.glb` bytes (deterministic).
pub fn quadruped_glb() -> Vec<u8> {
    crate::gltf_write::write_glb(&quadruped()).expect("the generated character is always writable")
}

/// A closed tube along `chain` (each joint the parent of the next): rings at every joint and
/// three between, each ring's vertices weighted to the bone of its segment and, near the
/// segment's start, half to the bone before it (the parent of the chain's first joint for the
/// first segment), so joints bend smoothly. Texture `u` goes round the tube, `v` along it.
fn tube(joints: &Joints, chain: &[usize], vertices: &mut Vec<Vertex>, indices: &mut Vec<u32>) {
    let first = vertices.len() as u32;
    let total: f32 = chain
        .windows(2)
        .map(|w| (joints.0[w[1]].2 - joints.0[w[0]].2).length())
        .sum();
    let body = chain[0] == 0;
    let mut along = 0.0f32;
    let mut rings = 0u32;
    let mut side_axis = Vec3::X;
    for (k, w) in chain.windows(2).enumerate() {
        let (a, b) = (&joints.0[w[0]], &joints.0[w[1]]);
        let prev_bone = if k == 0 { a.1 } else { Some(chain[k - 1]) };
        let dir = (b.2 - a.2).normalize();
        // A side axis kept from ring to ring (no twist along the tube), perpendicular to `dir`.
        side_axis = (side_axis - dir * side_axis.dot(dir)).normalize_or(Vec3::X);
        let up_axis = dir.cross(side_axis);
        let last = k + 2 == chain.len();
        let steps: &[f32] = if last {
            &[0.0, 0.25, 0.5, 0.75, 1.0]
        } else {
            &[0.0, 0.25, 0.5, 0.75]
        };
        for &t in steps {
            let centre = a.2.lerp(b.2, t);
            let radius = a.3 + (b.3 - a.3) * t;
            let prev_w = match prev_bone {
                Some(_) if t == 0.0 => 0.5,
                Some(_) if t == 0.25 => 0.15,
                _ => 0.0,
            };
            let v = (along + (b.2 - a.2).length() * t) / total;
            for i in 0..RING {
                let angle = TAU * i as f32 / RING as f32;
                // The body is a little taller than wide.
                let (sx, sy) = if body && k < 2 { (0.85, 1.05) } else { (1.0, 1.0) };
                let offset = side_axis * (angle.cos() * radius * sx) + up_axis * (angle.sin() * radius * sy);
                vertices.push(Vertex {
                    position: centre + offset,
                    normal: offset.normalize_or(dir),
                    uv: [i as f32 / RING as f32, if body { v * 0.5 } else { 0.5 + v * 0.5 }],
                    color: [1.0; 4],
                    bones: [w[0] as u16, prev_bone.unwrap_or(w[0]) as u16, 0, 0],
                    weights: [1.0 - prev_w, prev_w, 0.0, 0.0],
                });
            }
            rings += 1;
        }
        along += (b.2 - a.2).length();
    }
    for r in 0..rings - 1 {
        for i in 0..RING as u32 {
            let n = (i + 1) % RING as u32;
            let (a, b) = (first + r * RING as u32, first + (r + 1) * RING as u32);
            indices.extend([a + i, b + i, b + n, a + i, b + n, a + n]);
        }
    }
    // Caps: a centre vertex at each end, weighted as its ring.
    for (ring, outward) in [(0u32, -1.0f32), (rings - 1, 1.0)] {
        let base = first + ring * RING as u32;
        let ring_vertices = &vertices[base as usize..base as usize + RING];
        let centre = ring_vertices.iter().map(|v| v.position).sum::<Vec3>() / RING as f32;
        let dir = (ring_vertices[0].position - centre)
            .cross(ring_vertices[RING / 4].position - centre)
            .normalize_or(Vec3::Y);
        let cap = Vertex {
            position: centre,
            normal: dir * outward.signum(),
            ..ring_vertices[0]
        };
        let c = vertices.len() as u32;
        vertices.push(cap);
        for i in 0..RING as u32 {
            let n = (i + 1) % RING as u32;
            if outward < 0.0 {
                indices.extend([c, base + n, base + i]);
            } else {
                indices.extend([c, base + i, base + n]);
            }
        }
    }
}

/// Tan fur with dark stripes across the back and sides, a pale belly (`u` near a quarter turn
/// below: the tube's lower side), darker legs (the lower half of the texture).
fn fur_texture() -> Texture {
    let side = TEXTURE_SIDE;
    let mut rgba8 = Vec::with_capacity((side * side * 4) as usize);
    for y in 0..side {
        for x in 0..side {
            let (u, v) = ((x as f32 + 0.5) / side as f32, (y as f32 + 0.5) / side as f32);
            // sin(angle) < 0 is the tube's lower side for the body (up axis = dir × side).
            let lower = (TAU * u).sin() < -0.45;
            let legs = v >= 0.5;
            let stripe = ((v * 28.0 + 0.15 * (TAU * u * 2.0).sin()).fract() < 0.32) && !lower;
            let mut c: [f32; 3] = if legs { [0.45, 0.32, 0.2] } else { [0.78, 0.58, 0.34] };
            if lower {
                c = [0.93, 0.86, 0.72];
            }
            if stripe {
                c = c.map(|x| x * 0.35);
            }
            rgba8.extend(c.map(|x| (x * 255.0).round() as u8));
            rgba8.push(255);
        }
    }
    Texture {
        name: "fur".into(),
        width: side,
        height: side,
        rgba8,
    }
}

/// One sampled pose: a local rotation per joint and the hips' offset from rest.
struct Pose {
    rot: Vec<Quat>,
    hips: Vec3,
}

fn rx(d: f32) -> Quat {
    Quat::from_rotation_x(d.to_radians())
}
fn ry(d: f32) -> Quat {
    Quat::from_rotation_y(d.to_radians())
}

/// A gait: each leg's phase offset (fractions of the cycle: front left, front right, back
/// left, back right), the share of the cycle each foot is on the ground, swing amplitude and
/// knee lift in degrees, body bob in metres.
struct Gait {
    phases: [f32; 4],
    duty: f32,
    swing: f32,
    lift: f32,
    bob: f32,
}

/// Hip to ground, metres.
const LEG_LENGTH: f32 = 0.8;

impl Gait {
    /// How far the root travels in one cycle: a foot on the ground sweeps back from `swing`
    /// degrees in front of its hip to `swing` behind at an even angular rate while the body
    /// goes forward as far, so it stays (nearly) put.
    fn travel(&self) -> f32 {
        2.0 * LEG_LENGTH * self.swing.to_radians().sin() / self.duty
    }

    /// A leg at `p` (fraction of its own cycle, 0 = its foot coming down in front): its angle
    /// (positive = backwards) and how far its lower joints fold (lifting the foot in swing).
    fn leg(&self, p: f32) -> (f32, f32) {
        if p < self.duty {
            (-self.swing + 2.0 * self.swing * p / self.duty, 0.0)
        } else {
            let s = (p - self.duty) / (1.0 - self.duty);
            (
                self.swing * (std::f32::consts::PI * s).cos(),
                self.lift * (std::f32::consts::PI * s).sin(),
            )
        }
    }
}

fn gait(joints: &Joints, g: &Gait, phase: f32) -> Pose {
    let mut rot = vec![Quat::IDENTITY; joints.0.len()];
    let w = TAU * phase;
    for (i, (end, side)) in [("Front", "L"), ("Front", "R"), ("Back", "L"), ("Back", "R")]
        .iter()
        .enumerate()
    {
        // Positive X swings a hanging limb backwards.
        let (angle, fold) = g.leg((phase + g.phases[i]).rem_euclid(1.0));
        let sign = if *end == "Front" { 1.0 } else { -1.0 };
        rot[joints.find(&format!("b_{end}Leg1.{side}"))] = rx(angle - 0.3 * fold);
        rot[joints.find(&format!("b_{end}Leg2.{side}"))] = rx(sign * fold);
        rot[joints.find(&format!("b_{end}Leg3.{side}"))] = rx(-sign * 0.6 * fold);
    }
    rot[joints.find("b_Spine")] = ry(3.0 * w.sin());
    rot[joints.find("b_Chest")] = ry(-3.0 * w.sin());
    rot[joints.find("b_Neck")] = rx(4.0 * (2.0 * w).sin());
    rot[joints.find("b_Tail01")] = ry(12.0 * w.sin()) * rx(-10.0);
    rot[joints.find("b_Tail02")] = ry(10.0 * (w - 0.6).sin());
    rot[joints.find("b_Tail03")] = ry(8.0 * (w - 1.2).sin());
    Pose {
        rot,
        hips: Vec3::new(0.0, g.bob * (2.0 * w).cos() - g.bob, g.travel() * phase),
    }
}

fn walk(joints: &Joints, phase: f32) -> Pose {
    // Four beats: back left, front left, back right, front right.
    let g = Gait {
        phases: [0.25, 0.75, 0.0, 0.5],
        duty: 0.75,
        swing: 22.0,
        lift: 40.0,
        bob: 0.015,
    };
    gait(joints, &g, phase)
}

fn trot(joints: &Joints, phase: f32) -> Pose {
    // Diagonal pairs: front left with back right, front right with back left.
    let g = Gait {
        phases: [0.0, 0.5, 0.5, 0.0],
        duty: 0.5,
        swing: 28.0,
        lift: 60.0,
        bob: 0.03,
    };
    gait(joints, &g, phase)
}

fn idle(joints: &Joints, phase: f32) -> Pose {
    let w = TAU * phase;
    let mut rot = vec![Quat::IDENTITY; joints.0.len()];
    // The head goes down to graze and comes back up once per cycle; the tail swishes twice.
    let graze = 0.5 - 0.5 * w.cos();
    rot[joints.find("b_Neck")] = rx(45.0 * graze);
    rot[joints.find("b_Head")] = rx(20.0 * graze) * ry(6.0 * (2.0 * w).sin());
    rot[joints.find("b_Tail01")] = ry(20.0 * (2.0 * w).sin()) * rx(-8.0);
    rot[joints.find("b_Tail02")] = ry(15.0 * (2.0 * w - 0.7).sin());
    rot[joints.find("b_Tail03")] = ry(12.0 * (2.0 * w - 1.4).sin());
    Pose {
        rot,
        hips: Vec3::new(0.0, -0.01 * graze, 0.0),
    }
}

/// Samples `f` over one cycle as a looping clip: rotations repeat (the last key equals the
/// first) while the hips' translation keeps travelling, so a locomotion clip's root moves on.
fn clip(name: &str, duration: f32, joints: &Joints, f: fn(&Joints, f32) -> Pose) -> Clip {
    let keys = (duration * KEYS_PER_SEC).round() as usize;
    let times: Vec<f32> = (0..=keys).map(|k| k as f32 / KEYS_PER_SEC).collect();
    let poses: Vec<Pose> = (0..=keys).map(|k| f(joints, (k % keys) as f32 / keys as f32)).collect();
    let hips_rest = joints.0[0].2;
    let travel = f(joints, 1.0 - 1e-6).hips.z.max(0.0);
    let mut channels = vec![Channel {
        node: 0,
        interpolation: Interpolation::Linear,
        times: times.clone(),
        values: ChannelValues::Translation(
            poses
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    let z = if k == keys { travel } else { p.hips.z };
                    hips_rest + Vec3::new(p.hips.x, p.hips.y, z)
                })
                .collect(),
        ),
    }];
    for j in 0..joints.0.len() {
        let values: Vec<Quat> = poses.iter().map(|p| p.rot[j]).collect();
        if values.iter().all(|q| q.abs_diff_eq(Quat::IDENTITY, 1e-6)) {
            continue;
        }
        channels.push(Channel {
            node: j,
            interpolation: Interpolation::Linear,
            times: times.clone(),
            values: ChannelValues::Rotation(values),
        });
    }
    Clip {
        name: name.into(),
        duration_secs: times[keys],
        channels,
        in_place_velocity: Vec3::ZERO,
        morph_channels: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quadruped_round_trips_through_gltf_and_walks_forward() {
        let c = quadruped();
        let back = crate::import::import_slice(&quadruped_glb(), None, "quadruped.glb").expect("imports");
        assert_eq!(back.skeleton.joint_count(), c.skeleton.joint_count());
        assert_eq!(back.vertices.len(), c.vertices.len());
        assert_eq!(
            back.clips.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
            ["Walk", "Trot", "Idle"]
        );
        // Weights sum to one; every index is in range.
        assert!(
            c.vertices
                .iter()
                .all(|v| (v.weights.iter().sum::<f32>() - 1.0).abs() < 1e-6)
        );
        assert!(c.indices.iter().all(|&i| (i as usize) < c.vertices.len()));
        // Walk and Trot move forward by root motion at a speed measured from it; Idle stands.
        let speed = |name: &str| {
            let k = back.clips.iter().position(|c| c.name == name).unwrap();
            crate::timeline::ground_speed(&back, Some(k))
        };
        let (walk, trot, idle) = (speed("Walk"), speed("Trot"), speed("Idle"));
        assert!(walk > 0.4 && walk < 1.5, "walk {walk} m/s");
        // As authored (before the import plays it in place), nearly planted: the feet slide at
        // a small part of the root's speed.
        let (root, feet) = crate::timeline::ground_velocities(&c, Some(0));
        assert!(feet.length() < 0.35 * root.length(), "root {root} feet {feet}");
        assert!(trot > walk, "trot {trot} walk {walk}");
        assert!(idle < 0.05, "idle {idle}");
        // The import takes the root motion out (Walk and Trot play in place, at their speed),
        // so the walk's bounds over a loop are the animal's length, not that plus its travel.
        let v: Vec<f32> = back.clips.iter().map(|c| c.in_place_velocity.z).collect();
        assert!(
            (v[0] - walk).abs() < 0.1 * walk && (v[1] - trot).abs() < 0.1 * trot && v[2] == 0.0,
            "{v:?}"
        );
        let (lo, hi) = crate::animation::clip_bounds(&back, Some(0), 24);
        let (rest_lo, rest_hi) = crate::animation::clip_bounds(&back, None, 2);
        assert!(
            (hi.z - lo.z) < (rest_hi.z - rest_lo.z) + 0.2,
            "walk spans {lo}..{hi}, rest {rest_lo}..{rest_hi}"
        );
    }
}
