//! View-frustum culling: the six planes of a clip-from-world matrix (wgpu's 0..1 depth), and a
//! conservative sphere test.

use glam::{Mat4, Vec3, Vec4};

/// The six planes of a camera's view volume (left, right, bottom, top, near, far) in world
/// space, for culling bounding spheres.
#[derive(Clone, Copy, Debug)]
pub struct Frustum {
    /// Planes `n·p + d >= 0` inside, normals of unit length.
    planes: [Vec4; 6],
}

impl Frustum {
    /// The planes of a clip-from-world (view-projection) matrix with wgpu's 0..1 depth,
    /// normalised so that a plane's value at a point is its distance in world units.
    pub fn from_clip_from_world(m: &Mat4) -> Self {
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2].map(|p| {
            let n = p.truncate().length();
            if n > 0.0 { p / n } else { p }
        });
        Self { planes }
    }

    /// False only when the sphere lies wholly outside one plane (may keep a few spheres
    /// near the corners that are outside: conservative).
    pub fn sphere_visible(&self, centre: Vec3, radius: f32) -> bool {
        self.planes.iter().all(|p| p.truncate().dot(centre) + p.w >= -radius)
    }
}
