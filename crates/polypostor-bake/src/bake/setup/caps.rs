//! Caps: cutting the mesh into parts opens holes along the cuts; every boundary loop of a
//! part gets a triangulated cap (a fan around the loop's centroid, skinned like the loop) so
//! that fitting errors never show a hole. A cap's colour defaults to the mean of the texels
//! along its loop and can be overridden in the project.

use std::collections::{BTreeMap, HashMap};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::bake::segment::Segmentation;
use crate::character::{Character, Material, Submesh, Vertex};

/// One cap of one part.
#[derive(Clone, Debug, PartialEq)]
pub struct Cap {
    /// Stable identifier `"{part}:{index}"` (loops sorted by their smallest welded vertex).
    pub id: String,
    pub part: usize,
    /// Character vertex indices around the loop, in the part's boundary direction.
    pub loop_vertices: Vec<u32>,
    /// Default colour: the mean of the texels along the loop (sRGB bytes).
    pub default_color: [u8; 3],
}

/// A per-cap colour chosen by the artist.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CapOverrides {
    pub colors: BTreeMap<String, [u8; 3]>,
}

pub use crate::character::weld;

fn srgb_to_linear(x: f32) -> f32 {
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

fn linear_to_srgb(x: f32) -> f32 {
    if x <= 0.0031308 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The base colour (linear RGB) of a vertex as the renderer shows it, sampled nearest.
fn vertex_color(c: &Character, material: usize, v: &Vertex) -> Vec3 {
    let m = &c.materials[material.min(c.materials.len().saturating_sub(1))];
    let mut rgb = Vec3::new(m.base_color_factor[0], m.base_color_factor[1], m.base_color_factor[2])
        * Vec3::new(v.color[0], v.color[1], v.color[2]);
    if let Some(t) = m.base_color_texture.and_then(|i| c.textures.get(i)) {
        let u = m.wrap[0].apply(v.uv[0]);
        let w = m.wrap[1].apply(v.uv[1]);
        let x = ((u * t.width as f32) as u32).min(t.width - 1);
        let y = ((w * t.height as f32) as u32).min(t.height - 1);
        let i = ((y * t.width + x) * 4) as usize;
        let texel = Vec3::new(t.rgba8[i] as f32, t.rgba8[i + 1] as f32, t.rgba8[i + 2] as f32) / 255.0;
        rgb *= Vec3::new(
            srgb_to_linear(texel.x),
            srgb_to_linear(texel.y),
            srgb_to_linear(texel.z),
        );
    }
    rgb
}

/// Material of every triangle.
fn triangle_materials(c: &Character) -> Vec<usize> {
    let mut m = vec![0usize; c.triangle_count()];
    for s in &c.submeshes {
        for t in (s.first_index / 3)..((s.first_index + s.index_count) / 3) {
            if let Some(x) = m.get_mut(t as usize) {
                *x = s.material;
            }
        }
    }
    m
}

/// Finds every cut loop of every part.
pub fn find_caps(c: &Character, seg: &Segmentation) -> Vec<Cap> {
    let welded = weld(c);
    let tri_material = triangle_materials(c);
    let tris: Vec<[u32; 3]> = c.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    // Undirected welded edge -> number of triangles in the whole mesh.
    let mut mesh_count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (welded[t[k] as usize], welded[t[(k + 1) % 3] as usize]);
            *mesh_count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    // The colour of a welded vertex: from any of its corners (the first seen).
    let mut caps = Vec::new();
    for part in 0..seg.parts.len() {
        // Directed welded edges of this part, with a representative vertex and material.
        let mut directed: HashMap<(u32, u32), (u32, usize)> = HashMap::new();
        let mut part_count: HashMap<(u32, u32), u32> = HashMap::new();
        for (t, tri) in tris.iter().enumerate() {
            if seg.labels.get(t).copied().unwrap_or(0) as usize != part {
                continue;
            }
            for k in 0..3 {
                let (va, vb) = (tri[k], tri[(k + 1) % 3]);
                let (a, b) = (welded[va as usize], welded[vb as usize]);
                if a == b {
                    continue;
                }
                directed.insert((a, b), (va, tri_material[t]));
                *part_count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        // Cut edges: on the part's border but inside the whole mesh.
        let mut next: BTreeMap<u32, Vec<(u32, u32, usize)>> = BTreeMap::new();
        for (&(a, b), &(va, mat)) in &directed {
            let key = (a.min(b), a.max(b));
            if part_count[&key] == 1 && mesh_count[&key] >= 2 {
                // The cap runs against the part's boundary direction.
                next.entry(b).or_default().push((a, va, mat));
            }
        }
        for list in next.values_mut() {
            list.sort();
        }
        let mut loops: Vec<(Vec<u32>, Vec<(u32, usize)>)> = Vec::new();
        while let Some((&start, _)) = next.iter().find(|(_, l)| !l.is_empty()) {
            let mut welded_loop = vec![start];
            let mut corners = Vec::new();
            let mut at = start;
            loop {
                let Some(list) = next.get_mut(&at) else { break };
                let Some((to, va, mat)) = list.pop() else { break };
                corners.push((va, mat));
                if to == start {
                    break;
                }
                welded_loop.push(to);
                at = to;
                if welded_loop.len() > directed.len() {
                    break;
                }
            }
            if corners.len() >= 3 {
                loops.push((welded_loop, corners));
            }
        }
        loops.sort_by_key(|l| *l.0.iter().min().unwrap_or(&0));
        for (i, (_, corners)) in loops.into_iter().enumerate() {
            let mean = corners
                .iter()
                .map(|&(v, mat)| vertex_color(c, mat, &c.vertices[v as usize]))
                .sum::<Vec3>()
                / corners.len() as f32;
            let srgb = |x: f32| (linear_to_srgb(x.clamp(0.0, 1.0)) * 255.0).round() as u8;
            caps.push(Cap {
                id: format!("{part}:{i}"),
                part,
                loop_vertices: corners.iter().map(|c| c.0).collect(),
                default_color: [srgb(mean.x), srgb(mean.y), srgb(mean.z)],
            });
        }
    }
    caps
}

impl Cap {
    /// The colour to use: the override if any, else the default.
    pub fn color(&self, overrides: &CapOverrides) -> [u8; 3] {
        overrides.colors.get(&self.id).copied().unwrap_or(self.default_color)
    }
}

/// The triangles of one part plus its caps, as a character of its own (same skeleton,
/// bones and clips). Caps use an extra untextured material and carry their colour as
/// vertex colour.
pub fn part_character(
    c: &Character,
    seg: &Segmentation,
    part: usize,
    caps: &[Cap],
    overrides: &CapOverrides,
) -> Character {
    let tri_material = triangle_materials(c);
    let mut out = Character {
        name: format!("{} — {}", c.name, seg.parts.get(part).map_or("?", |p| p.name.as_str())),
        skeleton: c.skeleton.clone(),
        bones: c.bones.clone(),
        clips: c.clips.clone(),
        materials: c.materials.clone(),
        textures: c.textures.clone(),
        ..Default::default()
    };
    let mut remap: HashMap<u32, u32> = HashMap::new();
    let mut by_material: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    // Which of `c`'s vertices each new one is made of (for animated morph targets).
    let mut origins: Vec<Vec<(u32, f32)>> = Vec::new();
    for (t, tri) in c.indices.chunks_exact(3).enumerate() {
        if seg.labels.get(t).copied().unwrap_or(0) as usize != part {
            continue;
        }
        let list = by_material.entry(tri_material[t]).or_default();
        for &v in tri {
            let n = *remap.entry(v).or_insert_with(|| {
                out.vertices.push(c.vertices[v as usize]);
                origins.push(vec![(v, 1.0)]);
                out.vertices.len() as u32 - 1
            });
            list.push(n);
        }
    }
    let first_cap_vertex = out.vertices.len() as u32;
    for (material, list) in by_material {
        out.submeshes.push(Submesh {
            first_index: out.indices.len() as u32,
            index_count: list.len() as u32,
            material,
        });
        out.indices.extend(list);
    }
    let part_caps: Vec<&Cap> = caps.iter().filter(|k| k.part == part).collect();
    if !part_caps.is_empty() {
        let cap_material = out.materials.len();
        out.materials.push(Material {
            name: "cap".into(),
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            double_sided: true,
            alpha_cutoff: 0.0,
            wrap: Default::default(),
        });
        let first_index = out.indices.len() as u32;
        for cap in part_caps {
            let [r, g, b] = cap.color(overrides);
            let lin = |x: u8| srgb_to_linear(x as f32 / 255.0);
            let color = [lin(r), lin(g), lin(b), 1.0];
            let ring: Vec<Vertex> = cap.loop_vertices.iter().map(|&v| c.vertices[v as usize]).collect();
            let centre = ring.iter().map(|v| v.position).sum::<Vec3>() / ring.len() as f32;
            // Skin the centre like the loop: summed weights, best four.
            let mut weights: HashMap<u16, f32> = HashMap::new();
            for v in &ring {
                for k in 0..4 {
                    *weights.entry(v.bones[k]).or_default() += v.weights[k];
                }
            }
            let mut w: Vec<(u16, f32)> = weights.into_iter().filter(|e| e.1 > 0.0).collect();
            w.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            w.truncate(4);
            let sum: f32 = w.iter().map(|e| e.1).sum::<f32>().max(1e-12);
            let mut bones = [0u16; 4];
            let mut wts = [0f32; 4];
            for (k, e) in w.iter().enumerate() {
                bones[k] = e.0;
                wts[k] = e.1 / sum;
            }
            // The cap's normal: Newell's method over the loop (in its winding).
            let mut normal = Vec3::ZERO;
            for i in 0..ring.len() {
                let (a, b) = (ring[i].position, ring[(i + 1) % ring.len()].position);
                normal += Vec3::new(
                    (a.y - b.y) * (a.z + b.z),
                    (a.z - b.z) * (a.x + b.x),
                    (a.x - b.x) * (a.y + b.y),
                );
            }
            let normal = normal.normalize_or(Vec3::Y);
            let base = out.vertices.len() as u32;
            let mk = |p: Vec3| Vertex {
                position: p,
                normal,
                uv: [0.0; 2],
                color,
                bones,
                weights: wts,
            };
            out.vertices.push(mk(centre));
            let share = 1.0 / cap.loop_vertices.len().max(1) as f32;
            origins.push(cap.loop_vertices.iter().map(|&v| (v, share)).collect());
            for (i, v) in ring.iter().enumerate() {
                let mut x = mk(v.position);
                x.bones = v.bones;
                x.weights = v.weights;
                out.vertices.push(x);
                origins.push(vec![(cap.loop_vertices[i], 1.0)]);
                let (a, b) = (base + 1 + i as u32, base + 1 + ((i + 1) % ring.len()) as u32);
                out.indices.extend_from_slice(&[base, a, b]);
            }
        }
        out.submeshes.push(Submesh {
            first_index,
            index_count: out.indices.len() as u32 - first_index,
            material: cap_material,
        });
    }
    if !c.morphs.is_empty() {
        // Caps move with their loop's morphs; their flat normal stays.
        out.morphs = c.morphs_remapped(&origins);
        for m in &mut out.morphs {
            for (v, n) in m.vertices.iter().zip(m.normals.iter_mut()) {
                if *v >= first_cap_vertex {
                    *n = Vec3::ZERO;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::segment::auto_segment;

    /// Undirected welded edges used by exactly one triangle (holes in the surface).
    fn open_edges(c: &Character) -> usize {
        let w = weld(c);
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for t in c.indices.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (w[t[k] as usize], w[t[(k + 1) % 3] as usize]);
                if a != b {
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
        }
        count.values().filter(|&&n| n == 1).count()
    }

    #[test]
    fn caps_close_every_cut_of_the_default_character() {
        let c = crate::default_character::generate();
        let seg = auto_segment(&c);
        let caps = find_caps(&c, &seg);
        let whole_open = open_edges(&c);
        assert!(caps.len() >= 4, "{} caps", caps.len());
        for part in 0..seg.parts.len() {
            let p = part_character(&c, &seg, part, &caps, &CapOverrides::default());
            let without: Character = part_character(&c, &seg, part, &[], &CapOverrides::default());
            let before = open_edges(&without);
            let after = open_edges(&p);
            assert!(before > 0, "part {part} has no cut");
            assert!(
                after <= whole_open,
                "part {part}: {after} open edges remain after capping ({before} before)"
            );
        }
    }

    #[test]
    fn cap_colour_is_the_mean_of_the_loop_and_can_be_overridden() {
        let c = crate::default_character::generate();
        let seg = auto_segment(&c);
        let caps = find_caps(&c, &seg);
        let cap = &caps[0];
        // An independent mean in sRGB space is close (the default averages in linear space).
        assert!(cap.default_color.iter().all(|&x| x > 0));
        let mut o = CapOverrides::default();
        o.colors.insert(cap.id.clone(), [255, 0, 255]);
        assert_eq!(cap.color(&o), [255, 0, 255]);
        let p = part_character(&c, &seg, cap.part, &caps, &o);
        assert!(
            p.vertices
                .iter()
                .any(|v| v.color[0] == 1.0 && v.color[1] == 0.0 && v.color[2] == 1.0)
        );
    }
}
