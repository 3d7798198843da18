//! The default character's mesh: generalised cylinders ("tubes") along the bones, each with
//! its own rectangle of the texture atlas and smooth skin weights.

use std::collections::HashMap;

use glam::Vec3;

use super::texture::Region;
use super::{joint, joint_head};
use crate::character::Vertex;

/// One cross-section of a tube: an ellipse around `center` in the plane spanned by `side`
/// and `front`, with its skin weights.
struct Ring {
    center: Vec3,
    side: Vec3,
    front: Vec3,
    r_side: f32,
    r_front: f32,
    weights: Vec<(u16, f32)>,
}

#[derive(Default)]
struct MeshBuilder {
    vertices: Vec<Vertex>,
    indices: Vec<u32>,
}

fn pack_weights(w: &[(u16, f32)]) -> ([u16; 4], [f32; 4]) {
    let mut list: Vec<(u16, f32)> = Vec::new();
    for &(j, x) in w {
        if x <= 0.0 {
            continue;
        }
        match list.iter_mut().find(|e| e.0 == j) {
            Some(e) => e.1 += x,
            None => list.push((j, x)),
        }
    }
    list.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    list.truncate(4);
    let sum: f32 = list.iter().map(|e| e.1).sum();
    let mut bones = [0u16; 4];
    let mut weights = [0f32; 4];
    for (k, e) in list.iter().enumerate() {
        bones[k] = e.0;
        weights[k] = e.1 / sum;
    }
    (bones, weights)
}

impl MeshBuilder {
    fn vertex(&mut self, p: Vec3, uv: [f32; 2], w: &[(u16, f32)]) -> u32 {
        let (bones, weights) = pack_weights(w);
        self.vertices.push(Vertex {
            position: p,
            normal: Vec3::ZERO,
            uv,
            color: [1.0; 4],
            bones,
            weights,
        });
        self.vertices.len() as u32 - 1
    }

    /// Adds a triangle oriented so that its normal points away from `inside`.
    fn tri(&mut self, a: u32, b: u32, c: u32, inside: Vec3) {
        let [pa, pb, pc] = [a, b, c].map(|i| self.vertices[i as usize].position);
        let n = (pb - pa).cross(pc - pa);
        if n.length_squared() < 1e-14 {
            return;
        }
        let centroid = (pa + pb + pc) / 3.0;
        if n.dot(centroid - inside) >= 0.0 {
            self.indices.extend_from_slice(&[a, b, c]);
        } else {
            self.indices.extend_from_slice(&[a, c, b]);
        }
    }

    /// A tube through `rings` with `segments` around, mapped onto `region` (s around with
    /// the front at s = 0.5, t along from the first ring to the last), closed at the ends by
    /// fans to `start_pole` / `end_pole` when given.
    fn tube(
        &mut self,
        rings: &[Ring],
        segments: usize,
        region: Region,
        start_pole: Option<Vec3>,
        end_pole: Option<Vec3>,
    ) {
        let n = rings.len();
        let base = self.vertices.len() as u32;
        for (ri, r) in rings.iter().enumerate() {
            let t = ri as f32 / (n - 1) as f32;
            for j in 0..=segments {
                let s = j as f32 / segments as f32;
                let theta = std::f32::consts::TAU * s;
                let p = r.center - r.side * (theta.sin() * r.r_side) - r.front * (theta.cos() * r.r_front);
                self.vertex(p, region.uv(s, t), &r.weights);
            }
        }
        let row = (segments + 1) as u32;
        for ri in 0..n - 1 {
            let inside = (rings[ri].center + rings[ri + 1].center) * 0.5;
            for j in 0..segments as u32 {
                let a = base + ri as u32 * row + j;
                let b = a + 1;
                let c = a + row;
                let d = c + 1;
                self.tri(a, b, d, inside);
                self.tri(a, d, c, inside);
            }
        }
        let axis_dir = (rings[n - 1].center - rings[0].center).normalize_or(Vec3::Y);
        for (ring_index, pole, t, outward) in [(0, start_pole, 0.0f32, -axis_dir), (n - 1, end_pole, 1.0, axis_dir)] {
            let Some(pole) = pole else { continue };
            let r = &rings[ring_index];
            let pv = self.vertex(pole, region.uv(0.5, t), &r.weights);
            let inside = r.center - outward * 0.01;
            for j in 0..segments as u32 {
                let a = base + ring_index as u32 * row + j;
                self.tri(a, a + 1, pv, inside);
            }
        }
    }

    /// Smooth normals, averaged over vertices at the same position (UV seams).
    fn finish_normals(&mut self) {
        let key = |p: Vec3| {
            (
                (p.x * 1e5).round() as i64,
                (p.y * 1e5).round() as i64,
                (p.z * 1e5).round() as i64,
            )
        };
        let mut acc: HashMap<(i64, i64, i64), Vec3> = HashMap::new();
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| self.vertices[i as usize].position);
            let n = (b - a).cross(c - a);
            for p in [a, b, c] {
                *acc.entry(key(p)).or_insert(Vec3::ZERO) += n;
            }
        }
        for v in &mut self.vertices {
            v.normal = acc
                .get(&key(v.position))
                .copied()
                .unwrap_or(Vec3::Y)
                .normalize_or(Vec3::Y);
        }
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Weights blending from joint `a` to joint `b` as `x` goes from `e0` to `e1`.
fn blend(a: u16, b: u16, e0: f32, e1: f32, x: f32) -> Vec<(u16, f32)> {
    let k = smoothstep(e0, e1, x);
    vec![(a, 1.0 - k), (b, k)]
}

/// Piecewise-linear interpolation of a profile `[(x, value...)]`.
fn profile<const N: usize>(table: &[(f32, [f32; N])], x: f32) -> [f32; N] {
    if x <= table[0].0 {
        return table[0].1;
    }
    for w in table.windows(2) {
        if x <= w[1].0 {
            let k = (x - w[0].0) / (w[1].0 - w[0].0);
            let k = k * k * (3.0 - 2.0 * k); // smooth between keys
            let mut out = [0.0; N];
            for i in 0..N {
                out[i] = w[0].1[i] + (w[1].1[i] - w[0].1[i]) * k;
            }
            return out;
        }
    }
    table[table.len() - 1].1
}

/// A frame (side, front) perpendicular to `axis`, with `front` as close as possible to `hint`.
fn frame(axis: Vec3, hint: Vec3) -> (Vec3, Vec3) {
    let axis = axis.normalize();
    let front = (hint - axis * hint.dot(axis)).normalize();
    let side = front.cross(axis).normalize();
    // side points to the character's left (+X) for a vertical axis and front +Z.
    (-side, front)
}

pub fn build() -> (Vec<Vertex>, Vec<u32>) {
    let mut m = MeshBuilder::default();
    torso(&mut m);
    head_and_neck(&mut m);
    for side in [1.0f32, -1.0] {
        leg(&mut m, side);
        foot(&mut m, side);
        arm(&mut m, side);
        hand(&mut m, side);
    }
    m.finish_normals();
    (m.vertices, m.indices)
}

/// Hips → Spine → Chest by height.
fn torso_weights(y: f32) -> Vec<(u16, f32)> {
    let (hips, spine, chest) = (joint("Hips"), joint("Spine"), joint("Chest"));
    if y < 1.13 {
        blend(hips, spine, 0.98, 1.10, y)
    } else {
        blend(spine, chest, 1.14, 1.24, y)
    }
}

fn torso(m: &mut MeshBuilder) {
    let (ls, rs) = (joint("LeftShoulder"), joint("RightShoulder"));
    // y -> (half width, half depth, forward offset)
    let table: &[(f32, [f32; 3])] = &[
        (0.84, [0.06, 0.05, 0.0]),
        (0.88, [0.150, 0.098, 0.0]),
        (0.95, [0.168, 0.108, 0.0]),
        (1.02, [0.158, 0.100, 0.004]),
        (1.08, [0.142, 0.094, 0.006]),
        (1.16, [0.150, 0.100, 0.008]),
        (1.26, [0.170, 0.110, 0.012]),
        (1.34, [0.180, 0.106, 0.008]),
        (1.40, [0.172, 0.090, 0.0]),
        (1.445, [0.105, 0.070, 0.0]),
        (1.475, [0.056, 0.050, 0.0]),
    ];
    let n = 22;
    let rings: Vec<Ring> = (0..n)
        .map(|i| {
            let y = 0.84 + (1.475 - 0.84) * i as f32 / (n - 1) as f32;
            let [rx, rz, dz] = profile(table, y);
            let w = torso_weights(y);
            Ring {
                center: Vec3::new(0.0, y, dz),
                side: Vec3::X,
                front: Vec3::Z,
                r_side: rx,
                r_front: rz,
                weights: w,
            }
        })
        .collect();
    m.tube(
        &rings,
        24,
        Region::TORSO,
        Some(Vec3::new(0.0, 0.83, 0.0)),
        Some(Vec3::new(0.0, 1.48, 0.0)),
    );
    // The shoulder tops follow their shoulder joint.
    let start = m.vertices.len() - rings.len() * 25 - 2;
    for v in &mut m.vertices[start..] {
        let k = smoothstep(1.33, 1.42, v.position.y) * 0.35;
        if k > 0.0 {
            let x = v.position.x;
            let lk = smoothstep(-0.05, 0.12, x) * k;
            let rk = smoothstep(-0.05, 0.12, -x) * k;
            let mut w: Vec<(u16, f32)> = torso_weights(v.position.y)
                .iter()
                .map(|e| (e.0, e.1 * (1.0 - lk - rk)))
                .collect();
            w.push((ls, lk));
            w.push((rs, rk));
            let (b, ws) = pack_weights(&w);
            v.bones = b;
            v.weights = ws;
        }
    }
}

fn head_and_neck(m: &mut MeshBuilder) {
    let (chest, neck, head) = (joint("Chest"), joint("Neck"), joint("Head"));
    let neck_rings: Vec<Ring> = (0..6)
        .map(|i| {
            let y = 1.43 + 0.19 * i as f32 / 5.0;
            let w = if y < 1.5 {
                blend(chest, neck, 1.43, 1.5, y)
            } else {
                blend(neck, head, 1.56, 1.62, y)
            };
            Ring {
                center: Vec3::new(0.0, y, 0.0),
                side: Vec3::X,
                front: Vec3::Z,
                r_side: 0.058,
                r_front: 0.062,
                weights: w,
            }
        })
        .collect();
    m.tube(&neck_rings, 16, Region::NECK, None, None);

    // Head: an ellipsoid from chin to crown with a narrower jaw.
    let c = Vec3::new(0.0, 1.685, 0.012);
    let n = 18;
    let rings: Vec<Ring> = (1..n)
        .map(|i| {
            let a = std::f32::consts::PI * i as f32 / n as f32; // 0 bottom .. PI top
            let y = c.y - 0.125 * a.cos();
            let r = a.sin();
            let jaw = if a < 1.3 { 0.78 + 0.22 * (a / 1.3) } else { 1.0 };
            Ring {
                center: Vec3::new(0.0, y, c.z + 0.01 * r),
                side: Vec3::X,
                front: Vec3::Z,
                r_side: 0.097 * r * jaw,
                r_front: 0.112 * r,
                weights: vec![(head, 1.0)],
            }
        })
        .collect();
    m.tube(
        &rings,
        22,
        Region::HEAD,
        Some(Vec3::new(0.0, c.y - 0.123, c.z + 0.008)),
        Some(Vec3::new(0.0, c.y + 0.125, c.z)),
    );

    // Nose: a small cone.
    let tip = Vec3::new(0.0, 1.67, 0.142);
    let nose: Vec<Ring> = (0..3)
        .map(|i| {
            let k = i as f32 / 2.0;
            Ring {
                center: Vec3::new(0.0, 1.685 - 0.01 * k, 0.112 + 0.022 * k),
                side: Vec3::X,
                front: Vec3::Y,
                r_side: 0.016 * (1.0 - 0.5 * k),
                r_front: 0.022 * (1.0 - 0.6 * k),
                weights: vec![(head, 1.0)],
            }
        })
        .collect();
    m.tube(&nose, 8, Region::SKIN, None, Some(tip));

    // Ears.
    for s in [1.0f32, -1.0] {
        let cx = s * 0.097;
        let rings: Vec<Ring> = (1..6)
            .map(|i| {
                let a = std::f32::consts::PI * i as f32 / 6.0;
                Ring {
                    center: Vec3::new(cx + s * 0.012 * (1.0 - a.cos()), 1.685, 0.0),
                    side: Vec3::Z,
                    front: Vec3::Y,
                    r_side: 0.022 * a.sin(),
                    r_front: 0.034 * a.sin(),
                    weights: vec![(head, 1.0)],
                }
            })
            .collect();
        m.tube(
            &rings,
            10,
            Region::SKIN,
            Some(Vec3::new(cx, 1.685, 0.0)),
            Some(Vec3::new(cx + s * 0.026, 1.685, 0.0)),
        );
    }
}

fn side_name(side: f32, name: &str) -> u16 {
    joint(&format!("{}{name}", if side > 0.0 { "Left" } else { "Right" }))
}

fn leg(m: &mut MeshBuilder, side: f32) {
    let (upper, lower, hips) = (side_name(side, "UpperLeg"), side_name(side, "LowerLeg"), joint("Hips"));
    let top = joint_head(upper) + Vec3::new(0.0, 0.03, 0.0);
    let knee = joint_head(lower);
    let ankle = joint_head(side_name(side, "Foot")) + Vec3::new(0.0, 0.01, 0.01);
    // t along the leg -> (radius side, radius front, forward offset)
    let table: &[(f32, [f32; 3])] = &[
        (0.0, [0.085, 0.090, 0.0]),
        (0.22, [0.078, 0.080, 0.004]),
        (0.44, [0.058, 0.060, 0.0]),
        (0.50, [0.054, 0.058, 0.004]),
        (0.64, [0.056, 0.062, -0.008]),
        (0.85, [0.042, 0.044, -0.004]),
        (1.0, [0.036, 0.040, 0.0]),
    ];
    let n = 22;
    let knee_t = (top.y - knee.y) / (top.y - ankle.y);
    let rings: Vec<Ring> = (0..n)
        .map(|i| {
            let t = i as f32 / (n - 1) as f32;
            let [rs, rf, dz] = profile(table, t);
            let center = top.lerp(ankle, t) + Vec3::new(0.0, 0.0, dz);
            let mut w = blend(upper, lower, knee_t - 0.06, knee_t + 0.05, t);
            let hk = 1.0 - smoothstep(0.0, 0.12, t);
            if hk > 0.0 {
                for e in &mut w {
                    e.1 *= 1.0 - 0.5 * hk;
                }
                w.push((hips, 0.5 * hk));
            }
            let (s, f) = frame(ankle - top, Vec3::Z);
            Ring {
                center,
                side: s,
                front: f,
                r_side: rs,
                r_front: rf,
                weights: w,
            }
        })
        .collect();
    m.tube(
        &rings,
        16,
        Region::LEGS,
        Some(top + Vec3::new(0.0, 0.01, 0.0)),
        Some(ankle - Vec3::new(0.0, 0.01, 0.0)),
    );
}

fn foot(m: &mut MeshBuilder, side: f32) {
    let (foot, toes, lower) = (
        side_name(side, "Foot"),
        side_name(side, "Toes"),
        side_name(side, "LowerLeg"),
    );
    let x = joint_head(foot).x;
    // z along the foot -> (half width, half height, centre height)
    let table: &[(f32, [f32; 3])] = &[
        (-0.065, [0.030, 0.030, 0.045]),
        (-0.04, [0.044, 0.050, 0.060]),
        (0.00, [0.048, 0.058, 0.068]),
        (0.05, [0.050, 0.045, 0.052]),
        (0.10, [0.052, 0.034, 0.038]),
        (0.15, [0.046, 0.028, 0.030]),
        (0.175, [0.030, 0.020, 0.026]),
    ];
    let n = 12;
    let rings: Vec<Ring> = (0..n)
        .map(|i| {
            let z = -0.065 + (0.175 + 0.065) * i as f32 / (n - 1) as f32;
            let [rw, rh, cy] = profile(table, z);
            let mut w = blend(foot, toes, 0.07, 0.11, z);
            let lk = 1.0 - smoothstep(-0.03, 0.02, z);
            if lk > 0.0 && cy > 0.05 {
                for e in &mut w {
                    e.1 *= 1.0 - 0.3 * lk;
                }
                w.push((lower, 0.3 * lk));
            }
            Ring {
                center: Vec3::new(x, cy, z),
                side: Vec3::X,
                front: Vec3::Y,
                r_side: rw,
                r_front: rh,
                weights: w,
            }
        })
        .collect();
    m.tube(
        &rings,
        16,
        Region::FEET,
        Some(Vec3::new(x, 0.045, -0.072)),
        Some(Vec3::new(x, 0.026, 0.182)),
    );
}

fn arm(m: &mut MeshBuilder, side: f32) {
    let (shoulder, upper, lower) = (
        side_name(side, "Shoulder"),
        side_name(side, "UpperArm"),
        side_name(side, "LowerArm"),
    );
    let top = joint_head(upper) + Vec3::new(-side * 0.025, 0.015, 0.0);
    let elbow = joint_head(lower);
    let wrist = joint_head(side_name(side, "Hand"));
    let table: &[(f32, [f32; 2])] = &[
        (0.0, [0.056, 0.058]),
        (0.25, [0.050, 0.050]),
        (0.48, [0.040, 0.042]),
        (0.62, [0.042, 0.044]),
        (0.85, [0.034, 0.036]),
        (1.0, [0.029, 0.032]),
    ];
    let n = 16;
    let elbow_t = (top - elbow).length() / ((top - elbow).length() + (elbow - wrist).length());
    let rings: Vec<Ring> = (0..n)
        .map(|i| {
            let t = i as f32 / (n - 1) as f32;
            let [rs, rf] = profile(table, t);
            let center = if t < elbow_t {
                top.lerp(elbow, t / elbow_t)
            } else {
                elbow.lerp(wrist, (t - elbow_t) / (1.0 - elbow_t))
            };
            let axis = if t < elbow_t { elbow - top } else { wrist - elbow };
            let mut w = blend(upper, lower, elbow_t - 0.05, elbow_t + 0.05, t);
            let sk = 1.0 - smoothstep(0.0, 0.1, t);
            if sk > 0.0 {
                for e in &mut w {
                    e.1 *= 1.0 - 0.5 * sk;
                }
                w.push((shoulder, 0.5 * sk));
            }
            let (s, f) = frame(axis, Vec3::Z);
            Ring {
                center,
                side: s,
                front: f,
                r_side: rs,
                r_front: rf,
                weights: w,
            }
        })
        .collect();
    m.tube(&rings, 14, Region::ARMS, Some(top + Vec3::new(0.0, 0.02, 0.0)), None);
}

fn hand(m: &mut MeshBuilder, side: f32) {
    let (lower, hand) = (side_name(side, "LowerArm"), side_name(side, "Hand"));
    let wrist = joint_head(hand) + Vec3::new(0.0, 0.01, 0.0);
    let dir = (joint_head(hand) - joint_head(lower)).normalize();
    let tip = wrist + dir * 0.18;
    let n = 9;
    let rings: Vec<Ring> = (1..n)
        .map(|i| {
            let t = i as f32 / n as f32;
            let a = (t * std::f32::consts::PI).sin();
            let width = 0.046 * (0.55 + 0.45 * a) * if t > 0.8 { 0.8 } else { 1.0 };
            let thick = 0.021 * (0.6 + 0.4 * a);
            let w = blend(lower, hand, 0.0, 0.2, t);
            // Palm faces the thigh: width along Z, thickness along X.
            Ring {
                center: wrist.lerp(tip, t),
                side: Vec3::Z,
                front: Vec3::X * side,
                r_side: width,
                r_front: thick,
                weights: w,
            }
        })
        .collect();
    m.tube(&rings, 12, Region::HANDS, Some(wrist), Some(tip));
}
