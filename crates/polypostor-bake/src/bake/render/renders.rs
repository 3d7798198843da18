//! Part renders: per view, per part, per frame, a colour and a normal image at a fixed
//! resolution, with one orthographic framing per view that fits the character over the
//! whole clip and is shared by all parts; plus depth, for the visibility order.

use glam::Vec3;

use crate::animation::{Pose, skin_vertices};
use crate::bake::caps::{Cap, CapOverrides, part_character};
use crate::bake::segment::Segmentation;
use crate::character::{Character, MorphTarget, Submesh};
use crate::gpu::{Camera, Projection};

/// The clip is sampled at this rate by default (the paper's 10 Hz).
pub const DEFAULT_FPS: f32 = 10.0;
/// Part image size by default (the paper's 128²).
pub const DEFAULT_RESOLUTION: u32 = 128;
/// Empty border around the framed character, relative to its half size.
pub const FRAMING_MARGIN: f32 = 0.04;

pub use crate::timeline::frame_times;

/// Every part (with its caps) in one character; `ranges[p]` are part `p`'s index ranges.
pub fn merge_parts(
    c: &Character,
    seg: &Segmentation,
    caps: &[Cap],
    overrides: &CapOverrides,
) -> (Character, Vec<Vec<Submesh>>) {
    let mut merged = Character {
        name: c.name.clone(),
        skeleton: c.skeleton.clone(),
        bones: c.bones.clone(),
        clips: c.clips.clone(),
        textures: c.textures.clone(),
        ..Default::default()
    };
    let mut ranges = Vec::new();
    for part in 0..seg.parts.len() {
        let p = part_character(c, seg, part, caps, overrides);
        let vbase = merged.vertices.len() as u32;
        let mbase = merged.materials.len();
        if merged.morphs.len() < p.morphs.len() {
            merged.morphs = p
                .morphs
                .iter()
                .map(|m| MorphTarget {
                    name: m.name.clone(),
                    rest_weight: m.rest_weight,
                    ..Default::default()
                })
                .collect();
        }
        for (to, from) in merged.morphs.iter_mut().zip(&p.morphs) {
            to.vertices.extend(from.vertices.iter().map(|v| v + vbase));
            to.positions.extend_from_slice(&from.positions);
            to.normals.extend_from_slice(&from.normals);
        }
        merged.vertices.extend(p.vertices.iter().copied());
        merged.materials.extend(p.materials.iter().cloned());
        let mut list = Vec::new();
        for s in &p.submeshes {
            let first = merged.indices.len() as u32;
            let idx = &p.indices[s.first_index as usize..(s.first_index + s.index_count) as usize];
            merged.indices.extend(idx.iter().map(|i| i + vbase));
            let sub = Submesh {
                first_index: first,
                index_count: s.index_count,
                material: mbase + s.material,
            };
            merged.submeshes.push(sub.clone());
            list.push(sub);
        }
        ranges.push(list);
    }
    (merged, ranges)
}

/// One orthographic camera per view direction, each framing every given point set (the
/// skinned vertices of every frame) in a square image, with no twist.
pub fn view_cameras(frames: &[Vec<Vec3>], views: &[Vec3]) -> Vec<Camera> {
    let all: Vec<Vec3> = frames.iter().flatten().copied().collect();
    let (min, max) = crate::character::bounds(all.iter().copied());
    let centre = (min + max) * 0.5;
    // Floors relative to the character (or none): a character a hundredth of a millimetre
    // across is framed as one of two metres is (an absolute floor framed it 10× too wide).
    let radius = ((max - min) * 0.5).length().max(f32::MIN_POSITIVE);
    views
        .iter()
        .map(|&d| {
            let d = d.normalize_or(Vec3::Z);
            let mut cam = Camera {
                eye: centre + d * radius * 3.0,
                target: centre,
                up: Vec3::Y,
                projection: Projection::Orthographic { half_height: radius },
                near: radius,
                far: radius * 5.0,
            };
            // Fit the projected points: shift the camera sideways to their centre.
            let view = cam.view_from_world();
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for p in &all {
                let q = view.transform_point3(*p);
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let inv = view.inverse();
            let mid_view = Vec3::new((lo.x + hi.x) * 0.5, (lo.y + hi.y) * 0.5, 0.0);
            let shift = inv.transform_vector3(mid_view);
            let half = ((hi.x - lo.x).max(hi.y - lo.y) * 0.5).max(radius * 1e-4) * (1.0 + FRAMING_MARGIN);
            cam.eye += shift;
            cam.target += shift;
            cam.projection = Projection::Orthographic { half_height: half };
            // View-space z is negative in front of the camera.
            cam.near = (-hi.z - radius * 0.05).max(radius * 1e-3);
            cam.far = -lo.z + radius * 0.05;
            cam
        })
        .collect()
}

/// Poses and skinned positions of the merged character at the frame times.
pub fn sample_frames(c: &Character, clip: Option<usize>, times: &[f32]) -> (Vec<Pose>, Vec<Vec<Vec3>>) {
    let poses: Vec<Pose> = times.iter().map(|&t| Pose::sample_index(c, clip, t)).collect();
    let points = poses.iter().map(|p| skin_vertices(c, p).0).collect();
    (poses, points)
}

/// Poses and skinned positions at each `(clip, time)` sample of a timeline
/// ([`crate::timeline::Timeline::samples`]).
pub fn sample_timeline(c: &Character, samples: &[(Option<usize>, f32)]) -> (Vec<Pose>, Vec<Vec<Vec3>>) {
    let poses: Vec<Pose> = samples
        .iter()
        .map(|&(clip, t)| Pose::sample_index(c, clip, t))
        .collect();
    let points = poses.iter().map(|p| skin_vertices(c, p).0).collect();
    (poses, points)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The framing scales with the character, whatever its size: points scaled by k give
    /// cameras whose extent, near and far planes are k times the originals' (an absolute
    /// floor framed a character 0.02 mm across in an image ten times too wide).
    #[test]
    fn view_cameras_scale_with_the_character() {
        let points: Vec<Vec3> = (0..50)
            .map(|i| {
                let t = i as f32 * 0.37;
                Vec3::new(0.3 * t.sin(), 0.9 + 0.9 * (t * 0.7).cos(), 0.2 * (t * 1.3).sin())
            })
            .collect();
        let views = [Vec3::Z, Vec3::new(1.0, 0.5, 0.0), Vec3::Y, Vec3::new(-0.3, -0.2, 0.9)];
        let plain = view_cameras(&[points.clone()], &views);
        for k in [1e-5f32, 1e-3, 1e3, 1e5] {
            let scaled: Vec<Vec3> = points.iter().map(|p| *p * k).collect();
            for (a, b) in plain.iter().zip(view_cameras(&[scaled], &views)) {
                let (Projection::Orthographic { half_height: ha }, Projection::Orthographic { half_height: hb }) =
                    (a.projection, b.projection)
                else {
                    panic!("orthographic cameras");
                };
                let close = |x: f32, y: f32| (y / (x * k) - 1.0).abs() < 1e-3;
                assert!(close(ha, hb), "scale {k}: half height {hb} against {ha}");
                assert!(
                    close(a.near, b.near) && close(a.far, b.far),
                    "scale {k}: {b:?} against {a:?}"
                );
                assert!((b.eye - a.eye * k).length() < 1e-3 * k * a.eye.length());
            }
        }
    }

    #[test]
    fn frame_times_cover_the_loop_once() {
        assert_eq!(frame_times(1.0, 10.0).len(), 10);
        assert_eq!(frame_times(0.7, 10.0).len(), 7);
        // 7.5 frames' worth: 8 frames spread evenly round the loop (the wrap from the last to
        // the first as long as every other step), not 0.1 apart with a 0.05 s wrap.
        let t = frame_times(0.75, 10.0);
        assert_eq!(t.len(), 8);
        for (k, &x) in t.iter().enumerate() {
            assert!((x - k as f32 * 0.75 / 8.0).abs() < 1e-6, "{t:?}");
        }
        assert!((0.75 - t[7] - (t[1] - t[0])).abs() < 1e-6);
        // A whole number of frames keeps the steps of 1 / fps exactly.
        assert_eq!(frame_times(0.3, 10.0), vec![0.0, 0.1, 0.2]);
        assert_eq!(frame_times(0.0, 10.0), vec![0.0]);
    }

    #[test]
    fn view_cameras_contain_every_frame_for_every_view() {
        let c = crate::default_character::generate();
        let times = frame_times(1.0, 10.0);
        let (_, points) = sample_frames(&c, Some(0), &times);
        let views = crate::bake::viewpoints::directions(30, crate::bake::viewpoints::Coverage::UpperHemisphere);
        for (cam, d) in view_cameras(&points, &views).iter().zip(&views) {
            let m = cam.clip_from_world(1.0);
            let mut max_xy = 0.0f32;
            for p in points.iter().flatten() {
                let q = m.project_point3(*p);
                assert!(
                    q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && (0.0..=1.0).contains(&q.z),
                    "{d:?}: {q:?}"
                );
                max_xy = max_xy.max(q.x.abs().max(q.y.abs()));
            }
            // Tight: the character fills the frame up to the margin on one axis.
            assert!(max_xy > 0.9, "{d:?}: loose framing {max_xy}");
            // No twist: world up projects upwards on screen (except looking straight down).
            if d.y < 0.95 {
                let a = m.project_point3(cam.target);
                let b = m.project_point3(cam.target + Vec3::Y * 0.1);
                assert!(b.y > a.y);
            }
        }
    }
}
