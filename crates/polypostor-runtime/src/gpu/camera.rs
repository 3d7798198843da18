//! Cameras: a look-at eye with a perspective or orthographic projection (wgpu's 0..1 depth).

use glam::camera::rh::proj::directx as proj;
use glam::camera::rh::view::look_at_mat4;
use glam::{Mat4, Vec3};

/// How a [`Camera`] maps view space to clip space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view in radians.
    Perspective {
        /// Full vertical angle of view, top edge to bottom edge, in radians.
        fov_y_rad: f32,
    },
    /// Half the visible height in world units (the width follows the aspect ratio).
    Orthographic {
        /// Half the height of the view volume in world units, from its centre line to its top edge.
        half_height: f32,
    },
}

/// A look-at camera: an eye, the point it looks at, an up hint and a projection
/// (right-handed, world units, wgpu's 0..1 depth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the camera, world space.
    pub eye: Vec3,
    /// The point looked at, world space (it projects to the centre of the image).
    pub target: Vec3,
    /// World-space direction that appears upwards on screen; need not be orthogonal to the view
    /// direction (+Z is used instead when it is parallel to it).
    pub up: Vec3,
    /// Perspective or orthographic projection.
    pub projection: Projection,
    /// Distance from the eye to the near clipping plane, world units (depth 0); above 0 for a
    /// perspective camera.
    pub near: f32,
    /// Distance from the eye to the far clipping plane, world units (depth 1); beyond `near`.
    pub far: f32,
}

impl Camera {
    /// A perspective camera orbiting `target`: `yaw` about +Y (0 looks from +Z), `pitch` up.
    pub fn orbit(target: Vec3, yaw_rad: f32, pitch_rad: f32, distance: f32, fov_y_rad: f32) -> Self {
        let dir = Vec3::new(
            pitch_rad.cos() * yaw_rad.sin(),
            pitch_rad.sin(),
            pitch_rad.cos() * yaw_rad.cos(),
        );
        // No absolute floor: a character a hundredth of a millimetre across is seen as one
        // of two metres is (relative near plane, far plane past a crowd's ground).
        let distance = distance.max(f32::MIN_POSITIVE);
        Self {
            eye: target + dir * distance,
            target,
            up: Vec3::Y,
            projection: Projection::Perspective { fov_y_rad },
            near: distance * 0.01,
            far: distance * 100.0 + 100.0,
        }
    }

    /// An orthographic camera looking along `-view_dir` (from `view_dir`) that frames the
    /// box `(min, max)` with a relative `margin`.
    pub fn ortho_framing(min: Vec3, max: Vec3, view_dir: Vec3, margin: f32) -> Self {
        let center = (min + max) * 0.5;
        let radius = ((max - min) * 0.5).length().max(f32::MIN_POSITIVE);
        let dir = view_dir.normalize_or(Vec3::Z);
        let up = if dir.cross(Vec3::Y).length_squared() < 1e-6 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        Self {
            eye: center + dir * radius * 2.0,
            target: center,
            up,
            projection: Projection::Orthographic {
                half_height: radius * (1.0 + margin),
            },
            near: radius * 0.5,
            far: radius * 3.5,
        }
    }

    /// View-space-from-world matrix (right-handed: the camera looks down -Z, +Y up on screen).
    /// When `up` is parallel to the view direction, +Z stands in for it; an eye on the target
    /// (or a non-finite one) looks down -Z rather than giving NaN.
    pub fn view_from_world(&self) -> Mat4 {
        // Tolerances relative to the scene's own numbers (a camera a hundredth of a
        // millimetre from its target is as good as one metres away).
        let d = self.eye - self.target;
        let magnitude = self.eye.length_squared().max(self.target.length_squared());
        let target = if d.length_squared() > magnitude * 1e-12 && d.length_squared() > 0.0 && d.is_finite() {
            self.target
        } else {
            self.eye - Vec3::Z
        };
        let d2 = (self.eye - target).length_squared();
        let up = if (self.eye - target).cross(self.up).length_squared() < 1e-10 * d2 {
            if (self.eye - target).cross(Vec3::Z).length_squared() < 1e-10 * d2 {
                Vec3::Y
            } else {
                Vec3::Z
            }
        } else {
            self.up
        };
        look_at_mat4(self.eye, target, up)
    }

    /// Clip-space-from-view projection with wgpu's 0..1 depth (near plane 0, far plane 1).
    /// `aspect`: width / height of the viewport (a non-finite or non-positive value counts as 1).
    pub fn clip_from_view(&self, aspect: f32) -> Mat4 {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        match self.projection {
            Projection::Perspective { fov_y_rad } => proj::perspective(fov_y_rad, aspect, self.near, self.far),
            Projection::Orthographic { half_height } => {
                let hw = half_height * aspect;
                proj::orthographic(-hw, hw, -half_height, half_height, self.near, self.far)
            }
        }
    }

    /// Clip-space-from-world matrix: [`Self::view_from_world`], then [`Self::clip_from_view`].
    pub fn clip_from_world(&self, aspect: f32) -> Mat4 {
        self.clip_from_view(aspect) * self.view_from_world()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_projects_to_centre_at_mid_depth_range() {
        for cam in [
            Camera::orbit(Vec3::new(1.0, 2.0, 3.0), 0.7, 0.3, 5.0, 0.8),
            Camera::ortho_framing(Vec3::splat(-1.0), Vec3::splat(1.0), Vec3::new(0.3, 0.5, 1.0), 0.05),
        ] {
            let p = cam.clip_from_world(1.5).project_point3(cam.target);
            assert!(p.x.abs() < 1e-5 && p.y.abs() < 1e-5, "{p:?}");
            assert!(p.z > 0.0 && p.z < 1.0, "{p:?}");
        }
    }

    #[test]
    fn an_eye_on_its_target_or_looking_along_up_gives_no_nan() {
        let mut cam = Camera::orbit(Vec3::new(1.0, 2.0, 3.0), 0.7, 0.3, 5.0, 0.8);
        cam.eye = cam.target;
        assert!(cam.view_from_world().is_finite());
        // Looking straight down +Z with +Z as up: both fallbacks at once.
        cam.target = cam.eye - Vec3::Z;
        cam.up = Vec3::Z;
        assert!(cam.view_from_world().is_finite());
        cam.up = Vec3::Y;
        assert!(cam.clip_from_world(1.0).is_finite());
    }

    #[test]
    fn ortho_framing_contains_the_box() {
        let (min, max) = (Vec3::new(-0.3, 0.0, -0.2), Vec3::new(0.4, 1.8, 0.3));
        for dir in [Vec3::Z, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y] {
            let cam = Camera::ortho_framing(min, max, dir, 0.0);
            let m = cam.clip_from_world(1.0);
            for i in 0..8 {
                let c = Vec3::new(
                    if i & 1 == 0 { min.x } else { max.x },
                    if i & 2 == 0 { min.y } else { max.y },
                    if i & 4 == 0 { min.z } else { max.z },
                );
                let p = m.project_point3(c);
                assert!(
                    p.x.abs() <= 1.0 + 1e-5 && p.y.abs() <= 1.0 + 1e-5 && (0.0..=1.0).contains(&p.z),
                    "{dir:?} {p:?}"
                );
            }
        }
    }
}
