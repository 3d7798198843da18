//! Viewpoints: unit directions from the character's centre towards the camera, spread
//! uniformly over the upper hemisphere (the paper's 137 by default) or the whole sphere.
//!
//! Points follow a Fibonacci spiral (equal-area bands, golden-angle longitude), which is
//! deterministic and close to uniform for any count. The camera looks at the centre with no
//! twist (world up stays up on screen).

use glam::Vec3;

/// The paper's number of views.
pub const DEFAULT_VIEW_COUNT: usize = 137;

/// Which part of the sphere the views cover.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Coverage {
    /// Directions with y ≥ 0 (cameras at or above the horizon).
    UpperHemisphere,
    FullSphere,
}

/// `count` unit directions. For the hemisphere, the first lies near the horizon and the
/// last near the zenith.
pub fn directions(count: usize, coverage: Coverage) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .map(|i| {
            let k = (i as f32 + 0.5) / count as f32;
            // Equal-area bands: y uniform in [0,1] (hemisphere) or [-1,1] (sphere).
            let y = match coverage {
                Coverage::UpperHemisphere => k,
                Coverage::FullSphere => 2.0 * k - 1.0,
            };
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.sin(), y, r * phi.cos())
        })
        .collect()
}

/// Index of the direction closest to `dir` (largest dot product). Hemisphere views also
/// serve cameras below the horizon by their mirror above it.
pub fn nearest(views: &[Vec3], dir: Vec3) -> Option<usize> {
    let d = dir.normalize_or_zero();
    views
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.dot(d).total_cmp(&b.1.dot(d)))
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hemisphere_points_are_unit_above_horizon_and_deterministic() {
        let v = directions(DEFAULT_VIEW_COUNT, Coverage::UpperHemisphere);
        assert_eq!(v.len(), 137);
        assert!(v.iter().all(|d| (d.length() - 1.0).abs() < 1e-5 && d.y >= 0.0));
        assert_eq!(v, directions(137, Coverage::UpperHemisphere));
    }

    #[test]
    fn points_are_spread_evenly() {
        // Nearest-neighbour angles stay within a narrow band (no clumps, no holes).
        for coverage in [Coverage::UpperHemisphere, Coverage::FullSphere] {
            let v = directions(200, coverage);
            let nn: Vec<f32> = v
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    v.iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, b)| a.angle_between(*b))
                        .fold(f32::MAX, f32::min)
                })
                .collect();
            let (lo, hi) = (
                nn.iter().cloned().fold(f32::MAX, f32::min),
                nn.iter().cloned().fold(0.0, f32::max),
            );
            assert!(
                hi / lo < 2.5,
                "{coverage:?}: nearest-neighbour angles from {lo} to {hi}"
            );
        }
    }

    #[test]
    fn nearest_matches_brute_force_and_is_exact_on_views() {
        let v = directions(137, Coverage::UpperHemisphere);
        for (i, d) in v.iter().enumerate() {
            assert_eq!(nearest(&v, *d), Some(i));
        }
        let mut s = 12345u32;
        for _ in 0..500 {
            let mut r = || {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                (s >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0
            };
            let q = Vec3::new(r(), r().abs(), r());
            let best = v.iter().map(|d| d.angle_between(q)).fold(f32::MAX, f32::min);
            let got = v[nearest(&v, q).unwrap()].angle_between(q);
            assert!((got - best).abs() < 1e-6);
        }
    }
}
