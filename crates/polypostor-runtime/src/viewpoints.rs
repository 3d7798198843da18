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
    /// Directions over the whole sphere, below the horizon too.
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

/// [`nearest`] for many queries per frame (a crowd picks a view per character): a cube map
/// over the sphere (six faces of N×N cells, no trigonometry per query) lists, per cell, the
/// only views that can be nearest to a direction in that cell, so a query checks a few views
/// instead of all. Exact: a view `v` can beat the view `v*` nearest to the cell's centre `c`
/// somewhere in a cell of angular radius `r` only if `angle(v, c) <= angle(v*, c) + 2r`.
#[derive(Clone, Debug)]
pub struct ViewLookup {
    views: Vec<Vec3>,
    n: usize,
    /// Per cell, a range of `candidates`.
    cells: Vec<(u32, u32)>,
    candidates: Vec<u32>,
}

/// The direction through face `face` (0..6: +X, -X, +Y, -Y, +Z, -Z) at face coordinates
/// `(u, v)` in [-1, 1]², normalised.
fn cube_dir(face: usize, u: f32, v: f32) -> Vec3 {
    let d = match face {
        0 => Vec3::new(1.0, v, u),
        1 => Vec3::new(-1.0, v, u),
        2 => Vec3::new(u, 1.0, v),
        3 => Vec3::new(u, -1.0, v),
        4 => Vec3::new(u, v, 1.0),
        _ => Vec3::new(u, v, -1.0),
    };
    d.normalize()
}

impl ViewLookup {
    /// The lookup for `views` (normalised here; the indices it returns are positions in
    /// `views`). Building tests every view against every cell, so build it once per set of views.
    pub fn new(views: &[Vec3]) -> Self {
        let views: Vec<Vec3> = views.iter().map(|v| v.normalize_or_zero()).collect();
        // About fourteen cells per view (a few candidates each), at least a coarse grid.
        let n = ((views.len() as f32 * 56.0 / 6.0).sqrt().ceil() as usize).clamp(4, 256);
        let mut cells = Vec::with_capacity(6 * n * n);
        let mut candidates = Vec::new();
        let at = |k: f32| -1.0 + 2.0 * k / n as f32;
        for face in 0..6 {
            for j in 0..n {
                for i in 0..n {
                    let (u0, u1, v0, v1) = (at(i as f32), at(i as f32 + 1.0), at(j as f32), at(j as f32 + 1.0));
                    let c = cube_dir(face, 0.5 * (u0 + u1), 0.5 * (v0 + v1));
                    // Angular radius: the farthest corner (cells are convex on the sphere;
                    // edge midpoints too, for safety), with a margin.
                    let mut r = 0.0f32;
                    for (u, v) in [
                        (u0, v0),
                        (u0, v1),
                        (u1, v0),
                        (u1, v1),
                        (u0, 0.5 * (v0 + v1)),
                        (u1, 0.5 * (v0 + v1)),
                        (0.5 * (u0 + u1), v0),
                        (0.5 * (u0 + u1), v1),
                    ] {
                        r = r.max(angle(c, cube_dir(face, u, v)));
                    }
                    let r = r * 1.1 + 1e-4;
                    let best = views.iter().map(|&v| angle(v, c)).fold(f32::INFINITY, f32::min);
                    let start = candidates.len() as u32;
                    candidates.extend(
                        views
                            .iter()
                            .enumerate()
                            .filter(|(_, v)| angle(**v, c) <= best + 2.0 * r)
                            .map(|(i, _)| i as u32),
                    );
                    cells.push((start, candidates.len() as u32));
                }
            }
        }
        Self {
            views,
            n,
            cells,
            candidates,
        }
    }

    /// The index of the view nearest to `dir` (as [`nearest`]); `None` only without views.
    /// Written without data-dependent branches where it can (the crowd calls it for every
    /// visible character, with directions in no particular order).
    #[inline]
    pub fn nearest(&self, dir: Vec3) -> Option<usize> {
        if self.views.is_empty() {
            return None;
        }
        let c = dir.to_array();
        let a = [c[0].abs(), c[1].abs(), c[2].abs()];
        // The major axis (x on ties with y or z, then y), its sign, and the face coordinates
        // as in `cube_dir`.
        let x_major = a[0] >= a[1] && a[0] >= a[2];
        let axis = if x_major { 0 } else { 1 + (a[2] > a[1]) as usize };
        let m = a[axis];
        if !(m > 0.0) {
            return Some(0);
        }
        const UV: [(usize, usize); 3] = [(2, 1), (0, 2), (0, 1)];
        let (ui, vi) = UV[axis];
        let face = axis * 2 + (c[axis] < 0.0) as usize;
        let scale = 0.5 * self.n as f32 / m;
        let top = self.n - 1;
        let cell = |x: f32| ((x * scale + 0.5 * self.n as f32) as usize).min(top);
        let (lo, hi) = self.cells[(face * self.n + cell(c[vi])) * self.n + cell(c[ui])];
        let mut best = (f32::NEG_INFINITY, 0u32);
        for &k in &self.candidates[lo as usize..hi as usize] {
            let d = self.views[k as usize].dot(dir);
            best = if d > best.0 { (d, k) } else { best };
        }
        Some(best.1 as usize)
    }

    /// Direction of view `i` (unit length), if there is one.
    pub fn direction(&self, i: usize) -> Option<Vec3> {
        self.views.get(i).copied()
    }

    /// Mean number of views a query checks (for the benchmark's notes).
    pub fn mean_candidates(&self) -> f32 {
        self.candidates.len() as f32 / self.cells.len().max(1) as f32
    }
}

fn angle(a: Vec3, b: Vec3) -> f32 {
    a.dot(b).clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lookup_table_agrees_with_the_linear_search() {
        for (count, coverage) in [
            (137, Coverage::UpperHemisphere),
            (24, Coverage::UpperHemisphere),
            (300, Coverage::FullSphere),
            (1, Coverage::FullSphere),
        ] {
            let views = directions(count, coverage);
            let table = ViewLookup::new(&views);
            let mut rng = crate::crowd::rng::Rng::new(count as u64);
            for _ in 0..20_000 {
                let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                let (a, b) = (nearest(&views, d).unwrap(), table.nearest(d).unwrap());
                // Equal up to ties: the same dot product.
                let dn = d.normalize_or_zero();
                assert!(
                    (views[a].dot(dn) - views[b].dot(dn)).abs() < 1e-6,
                    "{count} views, {d}: {a} vs {b}"
                );
            }
            // The views themselves and the poles.
            for (i, v) in views.iter().enumerate() {
                assert_eq!(table.nearest(*v), Some(i));
            }
            for d in [Vec3::Y, -Vec3::Y, Vec3::X, -Vec3::Z] {
                let (a, b) = (nearest(&views, d).unwrap(), table.nearest(d).unwrap());
                assert!((views[a].dot(d) - views[b].dot(d)).abs() < 1e-6);
            }
            eprintln!("{count} views: {} candidates per cell", table.mean_candidates());
            assert!(table.mean_candidates() < 6.0, "{}", table.mean_candidates());
        }
        assert_eq!(ViewLookup::new(&[]).nearest(Vec3::X), None);
    }

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
