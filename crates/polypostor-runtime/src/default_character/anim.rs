//! The default character's clips, sampled at 30 Hz with linear keys: Walk (1 s), Run
//! (0.7 s), Idle (2 s) and Wave (2 s). All loop: the last key equals the first.
//!
//! Sign conventions (joints have identity bind rotations, the character faces +Z):
//! a positive rotation about X swings a hanging limb backwards (towards −Z) and tilts the
//! spine forwards.

use std::f32::consts::TAU;

use glam::{Quat, Vec3};

use super::{JOINTS, joint, joint_head};
use crate::character::{Channel, ChannelValues, Clip, Interpolation};

const KEYS_PER_SEC: f32 = 30.0;

fn deg(x: f32) -> f32 {
    x.to_radians()
}

/// One sampled pose: a local rotation per joint and the hips' offset from rest.
struct Pose {
    rot: Vec<Quat>,
    hips_offset: Vec3,
}

impl Pose {
    fn new() -> Self {
        Self {
            rot: vec![Quat::IDENTITY; JOINTS.len()],
            hips_offset: Vec3::ZERO,
        }
    }
    fn set(&mut self, name: &str, q: Quat) {
        self.rot[joint(name) as usize] = q;
    }
}

fn rx(d: f32) -> Quat {
    Quat::from_rotation_x(deg(d))
}
fn ry(d: f32) -> Quat {
    Quat::from_rotation_y(deg(d))
}
fn rz(d: f32) -> Quat {
    Quat::from_rotation_z(deg(d))
}

/// Legs, arms and trunk of a gait cycle at phase angle `w` (radians).
struct Gait {
    thigh: f32,
    knee_base: f32,
    knee_swing: f32,
    arm: f32,
    elbow_base: f32,
    elbow_swing: f32,
    bob: f32,
    lean: f32,
    twist: f32,
}

fn gait(g: &Gait, w: f32) -> Pose {
    let mut p = Pose::new();
    p.hips_offset = Vec3::new(0.012 * w.sin(), g.bob * (2.0 * w).cos() - g.bob, 0.0);
    p.set("Hips", ry(g.twist * w.sin()) * rz(2.0 * w.sin()));
    p.set("Spine", rx(g.lean * 0.5) * ry(-g.twist * 0.6 * w.sin()));
    p.set("Chest", rx(g.lean * 0.5) * ry(-g.twist * 0.6 * w.sin()));
    p.set("Neck", rx(-g.lean * 0.4));
    p.set("Head", rx(-g.lean * 0.4) * ry(-g.twist * 0.2 * w.sin()));
    for (side, phase) in [("Left", 0.0f32), ("Right", std::f32::consts::PI)] {
        let wl = w + phase;
        // Thigh forward (negative) when sin > 0; the knee folds during the forward swing.
        let thigh = -g.thigh * wl.sin();
        let swing = wl.cos().max(0.0);
        let knee = g.knee_base + g.knee_swing * swing * swing;
        let foot = -(thigh + knee) * 0.6 + 8.0 * (-wl.cos()).max(0.0);
        p.set(&format!("{side}UpperLeg"), rx(thigh - g.lean * 0.5));
        p.set(&format!("{side}LowerLeg"), rx(knee));
        p.set(&format!("{side}Foot"), rx(foot));
        p.set(&format!("{side}Toes"), rx(-12.0 * (-wl.sin()).max(0.0) * swing));
        // Arms swing against the leg of their side.
        let s = if side == "Left" { 1.0 } else { -1.0 };
        p.set(&format!("{side}UpperArm"), rx(g.arm * wl.sin()) * rz(s * 4.0));
        p.set(
            &format!("{side}LowerArm"),
            rx(-(g.elbow_base + g.elbow_swing * (0.5 - 0.5 * wl.sin()))),
        );
        p.set(&format!("{side}Shoulder"), rx(2.0 * wl.sin()));
    }
    p
}

fn walk(phase: f32) -> Pose {
    let g = Gait {
        thigh: 26.0,
        knee_base: 6.0,
        knee_swing: 48.0,
        arm: 22.0,
        elbow_base: 10.0,
        elbow_swing: 16.0,
        bob: 0.018,
        lean: 3.0,
        twist: 6.0,
    };
    gait(&g, TAU * phase)
}

fn run(phase: f32) -> Pose {
    let g = Gait {
        thigh: 40.0,
        knee_base: 20.0,
        knee_swing: 85.0,
        arm: 38.0,
        elbow_base: 70.0,
        elbow_swing: 20.0,
        bob: 0.035,
        lean: 12.0,
        twist: 10.0,
    };
    gait(&g, TAU * phase)
}

fn idle(phase: f32) -> Pose {
    let w = TAU * phase;
    let mut p = Pose::new();
    p.hips_offset = Vec3::new(0.006 * w.sin(), -0.004 + 0.004 * (2.0 * w).cos(), 0.0);
    p.set("Hips", rz(1.5 * w.sin()));
    p.set("Spine", rx(1.5 * (2.0 * w).sin()) * rz(-1.0 * w.sin()));
    p.set("Chest", rx(2.0 * (2.0 * w).sin()));
    p.set("Head", rx(3.0 * (w + 0.7).sin()) * ry(8.0 * w.sin()));
    for (side, s) in [("Left", 1.0f32), ("Right", -1.0)] {
        p.set(&format!("{side}UpperArm"), rx(3.0 * (w + s).sin()) * rz(s * 3.0));
        p.set(&format!("{side}LowerArm"), rx(-8.0 - 3.0 * (2.0 * w).sin()));
        p.set(&format!("{side}UpperLeg"), rz(s * 1.5 * w.sin()));
    }
    p
}

fn wave(phase: f32) -> Pose {
    let w = TAU * phase;
    let mut p = idle(phase);
    // Right arm raised to the side, forearm up, waving twice per cycle.
    p.set("RightShoulder", rz(-12.0));
    p.set("RightUpperArm", rz(-75.0) * rx(-20.0));
    p.set("RightLowerArm", rz(-85.0 + 25.0 * (2.0 * w).sin()));
    p.set("RightHand", rz(10.0 * (2.0 * w).sin()));
    p.set("Head", rz(-6.0) * ry(-10.0));
    p
}

fn sample(name: &str, duration: f32, f: fn(f32) -> Pose) -> Clip {
    let keys = (duration * KEYS_PER_SEC).round() as usize;
    let times: Vec<f32> = (0..=keys).map(|k| k as f32 / KEYS_PER_SEC).collect();
    let poses: Vec<Pose> = (0..=keys).map(|k| f((k % keys) as f32 / keys as f32)).collect();
    let hips = joint("Hips") as usize;
    let mut channels = vec![Channel {
        node: hips,
        interpolation: Interpolation::Linear,
        times: times.clone(),
        values: ChannelValues::Translation(poses.iter().map(|p| joint_head(hips as u16) + p.hips_offset).collect()),
    }];
    for j in 0..JOINTS.len() {
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

pub fn clips() -> Vec<Clip> {
    vec![
        sample("Walk", 1.0, walk),
        sample("Run", 0.7, run),
        sample("Idle", 2.0, idle),
        sample("Wave", 2.0, wave),
    ]
}
