//! Segmentation painting: which triangles a brush dab covers, fill by connectivity and by
//! joint influence, the X-mirror, and the part palette (add, remove, rename, recolour).
//!
//! Every tool changes a [`Segmentation`]'s labels in place and returns how many triangles
//! changed; the caller records the state before a stroke for undo.

use std::collections::HashMap;

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

use crate::animation::{Pose, skin_vertices};
use crate::bake::caps::CapOverrides;
use crate::bake::segment::{Part, Segmentation};
use crate::character::Character;

/// No neighbour / no mirror.
pub const NONE: u32 = crate::character::NO_NEIGHBOUR;

/// Per-character data the tools need, computed once per character.
#[derive(Clone, Debug)]
pub struct Topology {
    /// For each triangle, the triangles sharing an edge with it (UV seams welded), up to
    /// three ([`NONE`] where the edge is open); a non-manifold edge links its first two.
    pub neighbours: Vec<[u32; 3]>,
    /// For each triangle, the bone with the largest summed weight over its corners.
    pub dominant_bone: Vec<u16>,
    /// For each triangle, the triangle across the character's left-right mirror plane
    /// ([`NONE`] when none lies close enough).
    pub mirror: Vec<u32>,
    /// Number of triangles each bone dominates.
    pub bone_triangles: Vec<usize>,
}

impl Topology {
    pub fn new(c: &Character) -> Self {
        let tris = c.indices.len() / 3;
        let neighbours = crate::character::triangle_neighbours(&c.indices, &crate::character::weld(c));

        let mut dominant_bone = Vec::with_capacity(tris);
        let mut bone_triangles = vec![0usize; c.bones.len().max(1)];
        for tri in c.indices.chunks_exact(3) {
            let mut sums: [(u16, f32); 12] = [(0, 0.0); 12];
            let mut n = 0;
            for &i in tri {
                let Some(v) = c.vertices.get(i as usize) else { continue };
                for (b, wt) in v.bones.iter().zip(v.weights) {
                    match sums[..n].iter_mut().find(|s| s.0 == *b) {
                        Some(s) => s.1 += wt,
                        None => {
                            sums[n] = (*b, wt);
                            n += 1;
                        }
                    }
                }
            }
            let best = sums[..n]
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
                .map_or(0, |s| s.0);
            let best = if (best as usize) < bone_triangles.len() {
                best
            } else {
                0
            };
            bone_triangles[best as usize] += 1;
            dominant_bone.push(best);
        }

        let mirror = mirror_triangles(c);
        Self {
            neighbours,
            dominant_bone,
            mirror,
            bone_triangles,
        }
    }
}

/// Centroids of every triangle in the rest pose (the model space the viewport shows).
fn rest_centroids(c: &Character) -> Vec<Vec3> {
    crate::bake::segment::triangle_centroids(c, &skin_vertices(c, &Pose::rest(c)).0)
}

/// For each triangle, the triangle whose rest-pose centroid is nearest to its centroid
/// mirrored across the plane x = (middle of the bounds), if within 2 % of the character's
/// size.
fn mirror_triangles(c: &Character) -> Vec<u32> {
    let centroids = rest_centroids(c);
    if centroids.is_empty() {
        return Vec::new();
    }
    let (lo, hi) = centroids
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), &p| {
            (a.min(p), b.max(p))
        });
    let mid = 0.5 * (lo.x + hi.x);
    let tol = 0.02 * (hi - lo).max_element().max(1e-6);
    let cell = |p: Vec3| ((p - lo) / tol).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
    for (t, &p) in centroids.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(t as u32);
    }
    centroids
        .iter()
        .map(|&p| {
            let m = Vec3::new(2.0 * mid - p.x, p.y, p.z);
            let k = cell(m);
            let mut best = (tol * tol, NONE);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(list) = grid.get(&(k + glam::IVec3::new(dx, dy, dz))) else {
                            continue;
                        };
                        for &o in list {
                            let d = centroids[o as usize].distance_squared(m);
                            if d <= best.0 {
                                best = (d, o);
                            }
                        }
                    }
                }
            }
            best.1
        })
        .collect()
}

/// Sets `triangles` (and their mirrors when `mirror` is given) to `part`; returns how many
/// labels changed.
pub fn paint(seg: &mut Segmentation, triangles: &[usize], part: u16, mirror: Option<&Topology>) -> usize {
    if part as usize >= seg.parts.len() {
        return 0;
    }
    let mut changed = 0;
    let mut set = |t: usize, labels: &mut Vec<u16>| {
        if let Some(l) = labels.get_mut(t)
            && *l != part
        {
            *l = part;
            changed += 1;
        }
    };
    for &t in triangles {
        set(t, &mut seg.labels);
        if let Some(m) = mirror.and_then(|topo| topo.mirror.get(t)).filter(|&&m| m != NONE) {
            set(*m as usize, &mut seg.labels);
        }
    }
    changed
}

/// Flood fill: every triangle connected to `start` through triangles of `start`'s part
/// becomes `part`; with `mirror`, the same from the triangle mirroring `start` (the other
/// arm, whatever its part). Returns how many changed.
pub fn fill_connected(seg: &mut Segmentation, topo: &Topology, start: usize, part: u16, mirror: bool) -> usize {
    let mut changed = fill_from(seg, topo, start, part);
    if mirror && let Some(&m) = topo.mirror.get(start).filter(|&&m| m != NONE) {
        changed += fill_from(seg, topo, m as usize, part);
    }
    changed
}

fn fill_from(seg: &mut Segmentation, topo: &Topology, start: usize, part: u16) -> usize {
    let Some(&from) = seg.labels.get(start) else { return 0 };
    if from == part || part as usize >= seg.parts.len() {
        return 0;
    }
    let mut stack = vec![start];
    seg.labels[start] = part;
    let mut changed = 1;
    while let Some(t) = stack.pop() {
        for &n in topo.neighbours.get(t).into_iter().flatten() {
            if n != NONE && seg.labels.get(n as usize) == Some(&from) {
                seg.labels[n as usize] = part;
                changed += 1;
                stack.push(n as usize);
            }
        }
    }
    changed
}

/// Every triangle `bone` dominates becomes `part` (with `mirror`, and their mirrors).
/// Returns how many changed.
pub fn fill_bone(seg: &mut Segmentation, topo: &Topology, bone: u16, part: u16, mirror: bool) -> usize {
    let list: Vec<usize> = topo
        .dominant_bone
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == bone)
        .map(|(t, _)| t)
        .collect();
    paint(seg, &list, part, mirror.then_some(topo))
}

/// A ray from the camera through a point of the screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// The ray through `ndc` (x right, y up, -1..1) of a camera whose matrix is `clip_from_world`.
pub fn ray_through(clip_from_world: Mat4, ndc: Vec2) -> Ray {
    let inv = clip_from_world.inverse();
    let at = |z: f32| {
        let p = inv * glam::Vec4::new(ndc.x, ndc.y, z, 1.0);
        p.xyz() / p.w
    };
    let (near, far) = (at(0.0), at(1.0));
    Ray {
        origin: near,
        dir: (far - near).normalize_or(Vec3::NEG_Z),
    }
}

/// The nearest triangle the ray hits (either side) and the distance along the ray.
pub fn pick(positions: &[Vec3], indices: &[u32], ray: &Ray) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        let g = |i: u32| positions.get(i as usize).copied();
        let (Some(a), Some(b), Some(c)) = (g(tri[0]), g(tri[1]), g(tri[2])) else {
            continue;
        };
        // Möller–Trumbore.
        let (e1, e2) = (b - a, c - a);
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = ray.origin - a;
        let u = s.dot(p) / det;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(e1);
        let v = ray.dir.dot(q) / det;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        let d = e2.dot(q) / det;
        if d > 0.0 && best.is_none_or(|(_, bd)| d < bd) {
            best = Some((t, d));
        }
    }
    best
}

/// A brush dab: the cursor and radius on screen, and the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dab {
    pub clip_from_world: Mat4,
    /// The cursor in normalised device coordinates (x right, y up, -1..1).
    pub cursor_ndc: Vec2,
    /// The brush radius in pixels.
    pub radius_px: f32,
    /// The viewport size in pixels.
    pub viewport_px: Vec2,
}

/// The triangles a dab covers on the posed mesh: the surface point under the cursor is
/// found by a ray cast, then every triangle facing the camera whose centroid lies within the
/// brush radius of it (the screen radius measured at the hit's depth) is taken. Nothing
/// when the cursor misses the character.
pub fn dab_triangles(positions: &[Vec3], indices: &[u32], dab: &Dab) -> Vec<usize> {
    let ray = ray_through(dab.clip_from_world, dab.cursor_ndc);
    let Some((_, d)) = pick(positions, indices, &ray) else {
        return Vec::new();
    };
    let hit = ray.origin + ray.dir * d;
    // World radius: unproject a point `radius_px` to the right of the cursor at the hit's depth.
    let clip = dab.clip_from_world * hit.extend(1.0);
    let ndc = clip.xyz() / clip.w;
    let dx = 2.0 * dab.radius_px.max(0.5) / dab.viewport_px.x.max(1.0);
    let side = dab.clip_from_world.inverse() * glam::Vec4::new(ndc.x + dx, ndc.y, ndc.z, 1.0);
    let radius = (side.xyz() / side.w).distance(hit);
    let inv = dab.clip_from_world.inverse();
    let mut out = Vec::new();
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        let g = |i: u32| positions.get(i as usize).copied().unwrap_or(Vec3::ZERO);
        let (a, b, c) = (g(tri[0]), g(tri[1]), g(tri[2]));
        let centroid = (a + b + c) / 3.0;
        if centroid.distance_squared(hit) > radius * radius {
            continue;
        }
        // Facing the camera: the normal points back along the ray through the centroid.
        let cc = dab.clip_from_world * centroid.extend(1.0);
        let near = inv * glam::Vec4::new(cc.x / cc.w, cc.y / cc.w, 0.0, 1.0);
        let to_camera = near.xyz() / near.w - centroid;
        if (b - a).cross(c - a).dot(to_camera) > 0.0 {
            out.push(t);
        }
    }
    out
}

/// A copy of the character for painting: every triangle its own three vertices, coloured
/// with its part's colour (linear), untextured; triangles along a seam (an edge to another
/// part) are darkened so the cut lines read at a glance.
pub fn segmentation_display(c: &Character, seg: &Segmentation, topo: &Topology) -> Character {
    let lin = |x: u8| {
        let x = x as f32 / 255.0;
        if x <= 0.04045 {
            x / 12.92
        } else {
            ((x + 0.055) / 1.055).powf(2.4)
        }
    };
    let mut out = crate::reps::bake::part_id_character(c, &[]);
    for (t, tri) in out.vertices.chunks_exact_mut(3).enumerate() {
        let label = seg.labels.get(t).copied().unwrap_or(0);
        let [r, g, b] = seg.parts.get(label as usize).map_or([128; 3], |p| p.color);
        let seam = topo.neighbours.get(t).is_some_and(|ns| {
            ns.iter()
                .any(|&n| n != NONE && seg.labels.get(n as usize).is_some_and(|&l| l != label))
        });
        let k = if seam { 0.35 } else { 1.0 };
        for v in tri {
            v.color = [lin(r) * k, lin(g) * k, lin(b) * k, 1.0];
        }
    }
    out.name = format!("{} (segmentation)", c.name);
    out
}

/// Adds a part with a fresh colour; returns its index, or why not: a segmentation has at most
/// [`crate::limits::MAX_PARTS`] parts (the bake's exact visibility order).
pub fn add_part(seg: &mut Segmentation, name: &str) -> Result<u16, String> {
    if seg.parts.len() >= crate::limits::MAX_PARTS {
        return Err(part_limit_message());
    }
    let used: Vec<[u8; 3]> = seg.parts.iter().map(|p| p.color).collect();
    let color = (0..=crate::limits::MAX_PARTS)
        .map(crate::bake::segment::part_color)
        .find(|c| !used.contains(c))
        .unwrap_or(crate::bake::segment::part_color(seg.parts.len()));
    let name = if name.trim().is_empty() {
        format!("Part {}", seg.parts.len() + 1)
    } else {
        name.trim().to_string()
    };
    seg.parts.push(Part { name, color });
    Ok((seg.parts.len() - 1) as u16)
}

/// Why no part can be added past [`crate::limits::MAX_PARTS`].
pub fn part_limit_message() -> String {
    format!(
        "a segmentation has at most {} parts: the bake orders parts exactly over every subset of them",
        crate::limits::MAX_PARTS
    )
}

/// The part whose triangles share the most edges with part `p`'s (ties: the lower index):
/// where a removed part's triangles go by default (a hand into its forearm, not into
/// whichever part comes first). A part touching no other: the largest other part. `None`
/// for a segmentation of one part.
pub fn neighbour_part(seg: &Segmentation, topo: &Topology, p: u16) -> Option<u16> {
    let n = seg.parts.len();
    if n < 2 || p as usize >= n {
        return None;
    }
    let mut shared = vec![0usize; n];
    let mut size = vec![0usize; n];
    for (t, &l) in seg.labels.iter().enumerate() {
        if let Some(s) = size.get_mut(l as usize) {
            *s += 1;
        }
        if l != p {
            continue;
        }
        for &m in topo.neighbours.get(t).into_iter().flatten().filter(|&&m| m != NONE) {
            if let Some(&o) = seg.labels.get(m as usize)
                && o != p
                && let Some(c) = shared.get_mut(o as usize)
            {
                *c += 1;
            }
        }
    }
    let best = |score: &[usize]| {
        (0..n)
            .filter(|&i| i != p as usize)
            .max_by(|&a, &b| score[a].cmp(&score[b]).then(b.cmp(&a)))
            .map(|i| i as u16)
    };
    if shared.iter().any(|&c| c > 0) {
        best(&shared)
    } else {
        best(&size)
    }
}

/// A piece of a part lying apart from the rest of it (a stray brush stroke on the other arm):
/// every view traces it with the rest of the part and joins the two with a thin bridge, and
/// the part fits badly, without a word.
#[derive(Clone, Debug, PartialEq)]
pub struct StrayPiece {
    pub part: u16,
    /// Its triangles (connected through triangles of the part).
    pub triangles: Vec<usize>,
    /// How far it lies from the rest of the part: the least distance between their
    /// triangles' rest-pose centroids, in heights of the character.
    pub gap: f32,
    /// The same in scene units.
    pub distance: f32,
    /// The part its triangles share the most edges with, where a stroke took them from.
    pub touches: Option<u16>,
}

/// A stray piece holds at most this share of its part's triangles…
pub const STRAY_SHARE: f32 = 0.1;
/// …and lies at least this far from the rest of the part, in heights (eyes, teeth and
/// buttons modelled as pieces of their own lie within a hundredth of the head or coat).
pub const STRAY_GAP: f32 = 0.05;
/// Pieces larger than this many triangles are not looked at (not a stroke; keeps the search
/// bounded on dense meshes).
const STRAY_MOST: usize = 2000;

/// The pieces of each part that lie apart from the rest of it ([`StrayPiece`]) and were cut
/// out of another part's surface (a piece of mesh of its own, such as an eye, is not one),
/// largest gap first.
pub fn stray_pieces(c: &Character, topo: &Topology, seg: &Segmentation) -> Vec<StrayPiece> {
    use crate::bake::segment::{label_pieces, piece_gap};
    let pieces = label_pieces(&topo.neighbours, &seg.labels);
    let mut per_part: Vec<Vec<usize>> = vec![Vec::new(); seg.parts.len()];
    for (i, (p, _)) in pieces.iter().enumerate() {
        if let Some(v) = per_part.get_mut(*p as usize) {
            v.push(i);
        }
    }
    // The rest pose's centroids and height, once some piece needs them (skinning a dense
    // mesh is most of the cost).
    let geometry = std::cell::OnceCell::new();
    let geometry = || {
        geometry.get_or_init(|| {
            let centroids = rest_centroids(c);
            let (lo, hi) = centroids
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.y), hi.max(p.y))
                });
            (centroids, (hi - lo).max(1e-6))
        })
    };
    let mut out = Vec::new();
    for (p, list) in per_part.iter().enumerate().filter(|(_, l)| l.len() >= 2) {
        let total: usize = list.iter().map(|&i| pieces[i].1.len()).sum();
        let largest = list.iter().map(|&i| pieces[i].1.len()).max().unwrap_or(0);
        for &i in list {
            let tris = &pieces[i].1;
            if tris.len() == largest || tris.len() > STRAY_MOST || tris.len() as f32 > STRAY_SHARE * total as f32 {
                continue;
            }
            // Where it came from: the part across most of its open edges. A piece of mesh of
            // its own (an eye, a button, an antenna's ball) touches none: it is modelled so; a
            // stroke cuts its triangles out of another part's surface.
            let mut across = vec![0usize; seg.parts.len()];
            for &t in tris {
                for &m in &topo.neighbours[t as usize] {
                    if let Some(&l) = seg.labels.get(m as usize).filter(|_| m != NONE)
                        && l as usize != p
                        && let Some(a) = across.get_mut(l as usize)
                    {
                        *a += 1;
                    }
                }
            }
            let Some(touches) = (0..across.len())
                .filter(|&q| across[q] > 0)
                .max_by(|&a, &b| across[a].cmp(&across[b]).then(b.cmp(&a)))
            else {
                continue;
            };
            let (centroids, height) = geometry();
            let distance = piece_gap(centroids, &pieces, i, STRAY_GAP * height);
            let gap = distance / height;
            if !(gap >= STRAY_GAP) {
                continue;
            }
            out.push(StrayPiece {
                part: p as u16,
                triangles: tris.iter().map(|&t| t as usize).collect(),
                gap,
                distance,
                touches: Some(touches as u16),
            });
        }
    }
    out.sort_by(|a, b| b.gap.total_cmp(&a.gap));
    out
}

/// Removes part `p`, giving its triangles to `into` (an index before the removal); later
/// parts move down one, and the cap colours chosen for them follow. Fails for the last part
/// or when `into` is `p` or missing.
pub fn remove_part(seg: &mut Segmentation, caps: &mut CapOverrides, p: u16, into: u16) -> Result<(), String> {
    let n = seg.parts.len();
    if n <= 1 {
        return Err("a segmentation needs at least one part".into());
    }
    if p as usize >= n || into as usize >= n || p == into {
        return Err(format!("cannot move part {p}'s triangles into part {into}"));
    }
    let into_after = if into > p { into - 1 } else { into };
    for l in &mut seg.labels {
        *l = match (*l).cmp(&p) {
            std::cmp::Ordering::Equal => into_after,
            std::cmp::Ordering::Greater => *l - 1,
            std::cmp::Ordering::Less => *l,
        };
    }
    seg.parts.remove(p as usize);
    // Cap ids are "{part}:{loop}": drop the removed part's, renumber the later ones'.
    let old = std::mem::take(&mut caps.colors);
    for (id, color) in old {
        let Some((part, rest)) = id.split_once(':') else {
            continue;
        };
        let Ok(part) = part.parse::<u16>() else { continue };
        match part.cmp(&p) {
            std::cmp::Ordering::Less => {
                caps.colors.insert(id, color);
            }
            std::cmp::Ordering::Greater => {
                caps.colors.insert(format!("{}:{rest}", part - 1), color);
            }
            std::cmp::Ordering::Equal => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::segment::auto_segment;

    fn character() -> Character {
        crate::default_character::generate()
    }

    /// A stroke of the Torso part on the left leg's foot is a stray piece of the Torso,
    /// touching the left leg; the automatic parts have none; a piece next to its part (a
    /// stroke on the hip, where the leg meets the torso) is not stray.
    #[test]
    fn a_stroke_far_from_its_part_is_a_stray_piece() {
        let c = character();
        let topo = Topology::new(&c);
        let seg = auto_segment(&c);
        assert!(stray_pieces(&c, &topo, &seg).is_empty());
        let leg = seg.parts.iter().position(|p| p.name == "Left Leg").unwrap() as u16;
        let centroids = rest_centroids(&c);
        // The lowest triangle of the leg and its neighbours of the leg.
        let foot = (0..seg.labels.len())
            .filter(|&t| seg.labels[t] == leg)
            .min_by(|&a, &b| centroids[a].y.total_cmp(&centroids[b].y))
            .unwrap();
        let mut stroke = vec![foot];
        stroke.extend(
            topo.neighbours[foot]
                .iter()
                .filter(|&&m| m != NONE)
                .map(|&m| m as usize)
                .filter(|&m| seg.labels[m] == leg),
        );
        let mut painted = seg.clone();
        paint(&mut painted, &stroke, 0, None);
        let stray = stray_pieces(&c, &topo, &painted);
        assert_eq!(stray.len(), 1, "{stray:?}");
        assert_eq!(stray[0].part, 0);
        assert_eq!(stray[0].touches, Some(leg));
        let mut got = stray[0].triangles.clone();
        got.sort_unstable();
        stroke.sort_unstable();
        assert_eq!(got, stroke);
        assert!(stray[0].gap > 0.3, "{}", stray[0].gap);
        // Giving it back to the leg leaves none.
        paint(&mut painted, &stroke, leg, None);
        assert!(stray_pieces(&c, &topo, &painted).is_empty());
        // A stroke of the torso's part where the leg meets it joins the torso: not stray.
        let hip = (0..seg.labels.len())
            .filter(|&t| seg.labels[t] == leg)
            .max_by(|&a, &b| centroids[a].y.total_cmp(&centroids[b].y))
            .unwrap();
        let mut near = seg.clone();
        paint(&mut near, &[hip], 0, None);
        assert!(stray_pieces(&c, &topo, &near).is_empty());
    }

    /// The automatic parts of the generated quadruped leave no piece far from its part (its
    /// torso kept a ring of 12 triangles on the tail, 0.16 of its height from the body, until
    /// [`crate::bake::segment::tidy_islands_with`] gave such pieces away).
    #[test]
    fn the_quadrupeds_automatic_parts_have_no_stray_piece() {
        let c = crate::samples::quadruped();
        let seg = auto_segment(&c);
        let topo = Topology::new(&c);
        assert_eq!(stray_pieces(&c, &topo, &seg), Vec::new());
        let tail = seg.parts.iter().find(|p| p.name == "Tail").map(|p| p.name.clone());
        assert!(tail.is_some(), "{:?}", seg.parts);
    }

    #[test]
    fn neighbours_are_symmetric_and_share_an_edge() {
        let c = character();
        let topo = Topology::new(&c);
        let welded = crate::bake::caps::weld(&c);
        for (t, ns) in topo.neighbours.iter().enumerate() {
            for &n in ns.iter().filter(|&&n| n != NONE) {
                assert!(topo.neighbours[n as usize].contains(&(t as u32)), "{t} <-> {n}");
                let set = |x: usize| -> Vec<u32> { (0..3).map(|k| welded[c.indices[3 * x + k] as usize]).collect() };
                let (a, b) = (set(t), set(n as usize));
                assert!(a.iter().filter(|v| b.contains(v)).count() >= 2);
            }
        }
    }

    #[test]
    fn fill_connected_matches_a_brute_force_closure() {
        let c = character();
        let topo = Topology::new(&c);
        let seg0 = auto_segment(&c);
        for start in [0usize, 777, 3000] {
            let mut seg = seg0.clone();
            let from = seg.labels[start];
            let to = (from + 1) % seg.parts.len() as u16;
            let changed = fill_connected(&mut seg, &topo, start, to, false);
            // Brute force: grow a set until no triangle of `from` touches it.
            let mut inside = vec![false; seg0.labels.len()];
            inside[start] = true;
            loop {
                let mut grew = false;
                for t in 0..inside.len() {
                    if !inside[t]
                        && seg0.labels[t] == from
                        && topo.neighbours[t].iter().any(|&n| n != NONE && inside[n as usize])
                    {
                        inside[t] = true;
                        grew = true;
                    }
                }
                if !grew {
                    break;
                }
            }
            let expected = inside.iter().filter(|&&x| x).count();
            assert_eq!(changed, expected);
            for t in 0..inside.len() {
                let want = if inside[t] { to } else { seg0.labels[t] };
                assert_eq!(seg.labels[t], want, "triangle {t}");
            }
        }
        // Mirrored: the fill from a triangle, then from its mirror (another part): the same
        // as the two fills one after the other.
        let start = (0..seg0.labels.len())
            .find(|&t| {
                let m = topo.mirror[t];
                m != NONE && seg0.labels[m as usize] != seg0.labels[t]
            })
            .expect("a triangle mirrored into another part");
        let m = topo.mirror[start] as usize;
        let to = (0..seg0.parts.len() as u16)
            .find(|&p| p != seg0.labels[start] && p != seg0.labels[m])
            .unwrap();
        let mut both = seg0.clone();
        let changed = fill_connected(&mut both, &topo, start, to, true);
        let mut apart = seg0.clone();
        let one = fill_connected(&mut apart, &topo, start, to, false);
        let two = fill_connected(&mut apart, &topo, m, to, false);
        assert!(one > 0 && two > 0);
        assert_eq!(changed, one + two);
        assert_eq!(both.labels, apart.labels);
        assert_eq!(both.labels[m], to);
    }

    #[test]
    fn the_mirror_of_a_symmetric_character_maps_sides_onto_each_other() {
        let c = character();
        let topo = Topology::new(&c);
        let found = topo.mirror.iter().filter(|&&m| m != NONE).count();
        assert!(
            found as f64 > 0.9 * topo.mirror.len() as f64,
            "{found} of {}",
            topo.mirror.len()
        );
        // Mirroring twice comes back close (the same triangle or one next to it).
        let centroids = rest_centroids(&c);
        for (t, &m) in topo.mirror.iter().enumerate() {
            if m == NONE {
                continue;
            }
            let back = topo.mirror[m as usize];
            if back != NONE {
                assert!(centroids[back as usize].distance(centroids[t]) < 0.05, "triangle {t}");
            }
        }
        // A left-arm triangle's mirror lies on the other side.
        let seg = auto_segment(&c);
        let left = seg.parts.iter().position(|p| p.name == "Left Arm").unwrap() as u16;
        let right = seg.parts.iter().position(|p| p.name == "Right Arm").unwrap() as u16;
        let t = seg.labels.iter().position(|&l| l == left).unwrap();
        let m = topo.mirror[t];
        assert_ne!(m, NONE);
        assert_eq!(seg.labels[m as usize], right);
    }

    #[test]
    fn joint_fill_takes_exactly_the_dominated_triangles() {
        let c = character();
        let topo = Topology::new(&c);
        let mut seg = auto_segment(&c);
        let bone = (0..c.bones.len()).max_by_key(|&b| topo.bone_triangles[b]).unwrap() as u16;
        let part = add_part(&mut seg, "Picked").unwrap();
        let changed = fill_bone(&mut seg, &topo, bone, part, false);
        assert_eq!(changed, topo.bone_triangles[bone as usize]);
        for (t, &l) in seg.labels.iter().enumerate() {
            assert_eq!(l == part, topo.dominant_bone[t] == bone);
        }
    }

    #[test]
    fn pick_and_dab_agree_with_brute_force_and_move_with_the_scene() {
        let c = character();
        let (pos, _) = skin_vertices(&c, &Pose::rest(&c));
        let cam = crate::gpu::Camera::orbit(Vec3::new(0.0, 1.2, 0.0), 0.3, 0.1, 3.0, 0.7);
        let m = cam.clip_from_world(1.0);
        let dab = Dab {
            clip_from_world: m,
            cursor_ndc: Vec2::new(0.0, 0.0),
            radius_px: 20.0,
            viewport_px: Vec2::new(800.0, 800.0),
        };
        let tris = dab_triangles(&pos, &c.indices, &dab);
        assert!(
            !tris.is_empty() && tris.len() < c.triangle_count() / 4,
            "{}",
            tris.len()
        );
        // The picked triangle projects under the cursor.
        let ray = ray_through(m, dab.cursor_ndc);
        let (t, d) = pick(&pos, &c.indices, &ray).unwrap();
        let hit = ray.origin + ray.dir * d;
        let clip = m * hit.extend(1.0);
        assert!((clip.xy() / clip.w).length() < 1e-3);
        // Independent answer: intersect the ray with each triangle's plane and test the point
        // with signed areas; the nearest such hit is the picked one.
        let mut nearest = (f32::MAX, usize::MAX);
        for (u, tri) in c.indices.chunks_exact(3).enumerate() {
            let (a, b, cc) = (pos[tri[0] as usize], pos[tri[1] as usize], pos[tri[2] as usize]);
            let n = (b - a).cross(cc - a);
            let denom = n.dot(ray.dir);
            if denom.abs() < 1e-12 {
                continue;
            }
            let along = n.dot(a - ray.origin) / denom;
            let x = ray.origin + ray.dir * along;
            let inside = [(a, b), (b, cc), (cc, a)]
                .iter()
                .all(|(p, q)| (*q - *p).cross(x - *p).dot(n) >= -1e-9);
            if along > 0.0 && inside && along < nearest.0 {
                nearest = (along, u);
            }
        }
        assert_eq!(nearest.1, t);
        assert!((nearest.0 - d).abs() < 1e-4);
        // Translating and rotating the whole scene (mesh and camera) picks the same triangles.
        let xf = Mat4::from_rotation_translation(glam::Quat::from_rotation_y(1.1), Vec3::new(3.0, -1.0, 2.0));
        let moved: Vec<Vec3> = pos.iter().map(|&p| xf.transform_point3(p)).collect();
        let dab2 = Dab {
            clip_from_world: m * xf.inverse(),
            ..dab
        };
        assert_eq!(dab_triangles(&moved, &c.indices, &dab2), tris);
        // A dab in the empty corner covers nothing.
        let miss = Dab {
            cursor_ndc: Vec2::new(0.95, 0.95),
            ..dab
        };
        assert!(dab_triangles(&pos, &c.indices, &miss).is_empty());
    }

    /// The default target of a removal, against counting every pair of triangles that share
    /// two welded corners: on the default character each part's is the part it borders most.
    #[test]
    fn a_removed_part_goes_by_default_to_the_part_it_borders_most() {
        let c = character();
        let topo = Topology::new(&c);
        let seg = auto_segment(&c);
        let welded = crate::bake::caps::weld(&c);
        let tris = seg.labels.len();
        let mut touching = 0;
        let corners: Vec<[u32; 3]> = (0..tris)
            .map(|t| std::array::from_fn(|k| welded[c.indices[3 * t + k] as usize]))
            .collect();
        for p in 0..seg.parts.len() as u16 {
            let mut count = vec![0usize; seg.parts.len()];
            for a in (0..tris).filter(|&a| seg.labels[a] == p) {
                let ca = corners[a];
                for b in (0..tris).filter(|&b| seg.labels[b] != p) {
                    if corners[b].iter().filter(|v| ca.contains(v)).count() >= 2 {
                        count[seg.labels[b] as usize] += 1;
                    }
                }
            }
            let got = neighbour_part(&seg, &topo, p).unwrap();
            assert_ne!(got, p);
            let top = *count.iter().max().unwrap();
            if top > 0 {
                assert_eq!(count[got as usize], top, "part {p}: {count:?}, chose {got}");
                touching += 1;
            } else {
                let size = |i: usize| seg.labels.iter().filter(|&&l| l as usize == i).count();
                let others = (0..seg.parts.len()).filter(|&i| i != p as usize);
                assert_eq!(size(got as usize), others.map(size).max().unwrap(), "part {p}");
            }
        }
        assert!(touching >= seg.parts.len() / 2, "{touching} parts touch another");
        // A part touching no other goes into the largest other part; one part: none.
        let mut lone = seg.clone();
        let p = add_part(&mut lone, "lone").unwrap();
        let largest = (0..seg.parts.len())
            .max_by_key(|&i| {
                (
                    seg.labels.iter().filter(|&&l| l as usize == i).count(),
                    std::cmp::Reverse(i),
                )
            })
            .unwrap();
        assert_eq!(neighbour_part(&lone, &topo, p), Some(largest as u16));
        let one = Segmentation {
            parts: vec![seg.parts[0].clone()],
            labels: vec![0; tris],
        };
        assert_eq!(neighbour_part(&one, &topo, 0), None);
    }

    #[test]
    fn removing_a_part_relabels_and_renumbers_cap_colours() {
        let c = character();
        let mut seg = auto_segment(&c);
        let n = seg.parts.len();
        let before = seg.clone();
        let mut caps = CapOverrides::default();
        caps.colors.insert("1:0".into(), [1, 2, 3]);
        caps.colors.insert("2:0".into(), [4, 5, 6]);
        caps.colors.insert("0:1".into(), [7, 8, 9]);
        remove_part(&mut seg, &mut caps, 1, 0).unwrap();
        assert_eq!(seg.parts.len(), n - 1);
        for (t, &l) in before.labels.iter().enumerate() {
            let want = match l {
                0 | 1 => 0,
                x => x - 1,
            };
            assert_eq!(seg.labels[t], want);
        }
        assert_eq!(caps.colors.get("1:0"), Some(&[4, 5, 6]));
        assert_eq!(caps.colors.get("0:1"), Some(&[7, 8, 9]));
        assert_eq!(caps.colors.len(), 2);
        assert!(remove_part(&mut seg, &mut caps, 0, 0).is_err());
        let mut one = Segmentation {
            parts: vec![before.parts[0].clone()],
            labels: vec![0; 3],
        };
        assert!(remove_part(&mut one, &mut caps, 0, 0).is_err());
        // A new part gets a colour no other part has.
        let p = add_part(&mut seg, "  ").unwrap();
        assert_eq!(seg.parts[p as usize].name, format!("Part {}", p + 1));
        let colors: Vec<_> = seg.parts.iter().map(|p| p.color).collect();
        assert!(!colors[..p as usize].contains(&colors[p as usize]));
    }

    #[test]
    fn the_display_colours_each_triangle_with_its_part_and_darkens_seams() {
        let c = character();
        let topo = Topology::new(&c);
        let seg = auto_segment(&c);
        let d = segmentation_display(&c, &seg, &topo);
        assert_eq!(d.vertices.len(), c.indices.len());
        assert!(d.textures.is_empty());
        let mut seams = 0;
        for (t, tri) in d.vertices.chunks_exact(3).enumerate() {
            let part = &seg.parts[seg.labels[t] as usize];
            let brightest = part.color.iter().copied().max().unwrap() as f32 / 255.0;
            let shown = tri[0].color[0].max(tri[0].color[1]).max(tri[0].color[2]);
            assert!(tri.iter().all(|v| v.color == tri[0].color));
            // The colour's hue is the part's: the channel order matches.
            let order = |x: [f32; 3]| {
                let mut i = [0usize, 1, 2];
                i.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
                i
            };
            let pc = part.color.map(|x| x as f32);
            if pc[0] != pc[1] && pc[1] != pc[2] && pc[0] != pc[2] {
                assert_eq!(order([tri[0].color[0], tri[0].color[1], tri[0].color[2]]), order(pc));
            }
            if shown < 0.5 * brightest.powf(2.2) {
                seams += 1;
            }
            // Positions are the mesh's.
            assert_eq!(tri[0].position, c.vertices[c.indices[3 * t] as usize].position);
        }
        assert!(seams > 0 && seams < c.triangle_count() / 4, "{seams} seam triangles");
    }

    #[test]
    fn painting_with_the_mirror_sets_both_sides() {
        let c = character();
        let topo = Topology::new(&c);
        let mut seg = auto_segment(&c);
        let part = add_part(&mut seg, "Sleeves").unwrap();
        let t = (0..seg.labels.len())
            .find(|&t| topo.mirror[t] != NONE && topo.mirror[t] as usize != t)
            .unwrap();
        let changed = paint(&mut seg, &[t], part, Some(&topo));
        assert_eq!(changed, 2);
        assert_eq!(seg.labels[t], part);
        assert_eq!(seg.labels[topo.mirror[t] as usize], part);
        assert_eq!(
            paint(&mut seg, &[t], part, Some(&topo)),
            0,
            "painting again changes nothing"
        );
        assert_eq!(paint(&mut seg, &[t], 99, None), 0, "no such part");
    }
}
