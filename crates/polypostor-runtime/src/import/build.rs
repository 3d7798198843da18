//! Building a [`Character`] from a parsed glTF: the rig (skeleton, bones, what each mesh
//! node is bound to), the geometry of every triangle primitive, then the clips.

use std::collections::HashMap;

use glam::{Mat4, Vec3};
use gltf::json;
use json::validation::Checked;

use super::{
    Binding, Builder, ImportError, accessor, compute_normals, node_local, normal_matrix, scene_name, size_warning,
    triangulate,
};
use crate::character::{Bone, Character, Material, Node, Skeleton, Submesh, Texture, Transform, Vertex};

/// The rig: the skeleton's nodes, the bones vertices bind to, and each mesh node's binding.
#[derive(Default)]
struct Rig {
    skeleton: Skeleton,
    bones: Vec<Bone>,
    bindings: HashMap<usize, Binding>,
    /// File node index -> skeleton node index (empty for static files).
    node_map: HashMap<usize, usize>,
    /// Per bone, whether its skinning transform at rest mirrors (negative determinant: a
    /// skeleton under a node scaled by -1), which turns its triangles' winding around.
    mirrored: Vec<bool>,
    /// What the rig had to repair (said as import warnings).
    notes: Vec<String>,
}

/// The geometry gathered so far, with the materials and textures it uses.
#[derive(Default)]
struct Geometry {
    vertices: Vec<Vertex>,
    indices: Vec<u32>,
    submeshes: Vec<Submesh>,
    materials: Vec<Material>,
    material_map: HashMap<Option<usize>, usize>,
    textures: Vec<Texture>,
    texture_map: HashMap<usize, Option<usize>>,
    /// Morph targets some clip animates, and per file node whose weights a clip moves, the
    /// indices of its mesh's targets among them.
    morphs: Vec<crate::character::MorphTarget>,
    morph_nodes: HashMap<usize, Vec<usize>>,
}

/// The scene's node hierarchy: each node's parent and rest-pose local transform.
struct Hierarchy {
    parent: Vec<Option<usize>>,
    locals: Vec<Transform>,
    /// Rest world matrices, filled as they are asked for.
    world_rest: Vec<Option<Mat4>>,
}

impl Hierarchy {
    /// The rest world matrix of node `i` (iterative: the chain up to a known ancestor).
    fn world(&mut self, i: usize) -> Mat4 {
        let (parent, locals, memo) = (&self.parent, &self.locals, &mut self.world_rest);
        let mut chain = vec![i];
        let mut at = i;
        while memo[at].is_none() {
            match parent[at] {
                Some(p) if memo[p].is_none() => {
                    chain.push(p);
                    at = p;
                }
                _ => break,
            }
        }
        for &n in chain.iter().rev() {
            if memo[n].is_none() {
                let base = parent[n].and_then(|p| memo[p]).unwrap_or(Mat4::IDENTITY);
                memo[n] = Some(base * locals[n].to_mat4());
            }
        }
        memo[i].unwrap_or(Mat4::IDENTITY)
    }
}

impl Builder<'_> {
    /// The character: rig, geometry, clips, and the size check.
    pub(super) fn build(mut self, name: &str) -> Result<Character, ImportError> {
        let root = self.root;
        let parent = self.parents()?;
        let scene = self.scene_nodes(&parent)?;
        let mesh_nodes: Vec<usize> = scene
            .iter()
            .copied()
            .filter(|&i| root.nodes[i].mesh.is_some())
            .collect();
        // A file with meshes but no nodes at all: the meshes as they are, static.
        let instances: Vec<(Option<usize>, usize)> = if root.nodes.is_empty() {
            (0..root.meshes.len()).map(|m| (None, m)).collect()
        } else {
            mesh_nodes
                .iter()
                .map(|&n| (Some(n), root.nodes[n].mesh.map_or(usize::MAX, |x| x.value())))
                .collect()
        };
        if instances.is_empty() {
            return Err(ImportError::NoGeometry);
        }
        let any_skin = mesh_nodes.iter().any(|&i| root.nodes[i].skin.is_some());
        let mut hierarchy = Hierarchy {
            locals: root.nodes.iter().map(node_local).collect(),
            world_rest: vec![None; root.nodes.len()],
            parent,
        };
        // Without a skin, a file whose animations move its mesh nodes (a prop: a door, a
        // windmill, a wheel) is rigged like the skinned files' rigid meshes: each mesh node a
        // bone that follows its node. Otherwise it is static.
        let rigged = any_skin || animates_meshes(root, &mesh_nodes, &hierarchy.parent);
        let mut rig = if rigged {
            self.skinned_rig(&mesh_nodes, &hierarchy)?
        } else {
            static_rig(&mesh_nodes)
        };
        for note in std::mem::take(&mut rig.notes) {
            self.warn(note);
        }
        let rest = rig.skeleton.rest_world();
        rig.mirrored = rig
            .bones
            .iter()
            .map(|b| {
                rest.get(b.node)
                    .is_some_and(|w| (*w * b.inverse_bind).determinant() < 0.0)
            })
            .collect();
        let mut g = Geometry::default();
        let animated_weights = self.animated_weight_nodes();
        for &(node, mesh_index) in &instances {
            let mesh = root.meshes.get(mesh_index).ok_or_else(|| {
                ImportError::Invalid(format!(
                    "node {} refers to missing mesh {mesh_index}",
                    node.unwrap_or(usize::MAX)
                ))
            })?;
            let mesh_name = mesh.name.clone().unwrap_or_else(|| format!("mesh {mesh_index}"));
            let static_world = match (rigged, node) {
                (true, _) => None,
                (false, Some(n)) => Some(hierarchy.world(n)),
                (false, None) => Some(Mat4::IDENTITY),
            };
            // The shape the morph targets give at rest: the node's weights, else the mesh's
            // (glTF's default weights); their animation is not played (said at the clips).
            let morph_weights: &[f32] = node
                .and_then(|n| root.nodes.get(n))
                .and_then(|n| n.weights.as_deref())
                .or(mesh.weights.as_deref())
                .unwrap_or(&[]);
            // Targets a clip animates keep their offsets (the clip moves them from the rest
            // weights baked in here); one set per node the clips name.
            let morph_slots: Vec<usize> = match node {
                Some(n) if animated_weights.contains(&n) && !g.morph_nodes.contains_key(&n) => {
                    let count = mesh
                        .primitives
                        .iter()
                        .map(|p| p.targets.as_ref().map_or(0, |t| t.len()))
                        .max()
                        .unwrap_or(0);
                    let slots: Vec<usize> = (0..count).map(|ti| g.morphs.len() + ti).collect();
                    g.morphs.extend((0..count).map(|ti| crate::character::MorphTarget {
                        name: format!("mesh '{mesh_name}' target {ti}"),
                        rest_weight: morph_weights.get(ti).copied().filter(|w| w.is_finite()).unwrap_or(0.0),
                        ..Default::default()
                    }));
                    g.morph_nodes.insert(n, slots.clone());
                    slots
                }
                _ => Vec::new(),
            };
            for (pi, prim) in mesh.primitives.iter().enumerate() {
                let place = Placement {
                    node,
                    static_world,
                    morph_weights,
                    morph_slots: &morph_slots,
                };
                self.primitive(&mesh_name, pi, prim, place, &rig, &mut g)?;
            }
        }
        if g.indices.is_empty() {
            return Err(ImportError::NoGeometry);
        }
        let clips = self.clips(&rig.node_map, rigged, &g.morph_nodes)?;
        let name = scene_name(root).unwrap_or_else(|| name.to_string());
        let mut character = Character {
            name,
            vertices: g.vertices,
            indices: g.indices,
            submeshes: g.submeshes,
            materials: g.materials,
            textures: g.textures,
            skeleton: rig.skeleton,
            bones: rig.bones,
            clips,
            warnings: collapse_warnings(self.warnings),
            up_axis: Default::default(),
            morphs: g.morphs,
        };
        // Measured skinned in the rest pose (a skinned mesh's own node transform does not
        // apply; its joints' do).
        if let Some(w) = size_warning(crate::animation::clip_bounds(&character, None, 2)) {
            if !character.warnings.contains(&w) {
                character.warnings.push(w);
            }
        }
        Ok(character)
    }

    /// The rig of a skinned file: the scene's skins and their joints, the nodes they need
    /// (and their ancestors, parents first), one bone per joint slot, and one bone per mesh
    /// node without a skin (it follows its node rigidly).
    fn skinned_rig(&self, mesh_nodes: &[usize], h: &Hierarchy) -> Result<Rig, ImportError> {
        let root = self.root;
        let (parent, locals) = (&h.parent, &h.locals);
        let mut skeleton = Skeleton::default();
        let mut bones: Vec<Bone> = Vec::new();
        let mut bindings: HashMap<usize, Binding> = HashMap::new();
        // Skins used by the scene's meshes, and their joints.
        let mut skins: Vec<usize> = mesh_nodes
            .iter()
            .filter_map(|&i| root.nodes[i].skin.map(|s| s.value()))
            .collect();
        skins.sort_unstable();
        skins.dedup();
        let mut joint_nodes: Vec<usize> = Vec::new();
        for &s in &skins {
            let skin = root
                .skins
                .get(s)
                .ok_or_else(|| ImportError::Invalid(format!("skin {s} does not exist")))?;
            if skin.joints.is_empty() {
                return Err(ImportError::Invalid(format!("skin {s} has no joints")));
            }
            for j in &skin.joints {
                if j.value() >= root.nodes.len() {
                    return Err(ImportError::Invalid(format!(
                        "skin {s} refers to missing joint node {}",
                        j.value()
                    )));
                }
                joint_nodes.push(j.value());
            }
        }
        // Needed nodes: joints, rigid mesh carriers, and all their ancestors.
        let mut needed = vec![false; root.nodes.len()];
        let rigid: Vec<usize> = mesh_nodes
            .iter()
            .copied()
            .filter(|&i| root.nodes[i].skin.is_none())
            .collect();
        mark_with_ancestors(joint_nodes.iter().chain(&rigid).copied(), parent, &mut needed);
        // Parents first, otherwise in file order (a file that already lists parents
        // first keeps its order). The hierarchy is a forest, so each pass emits at least
        // one node.
        let mut order: Vec<usize> = Vec::new();
        let mut emitted = vec![false; root.nodes.len()];
        let mut pending: Vec<usize> = (0..root.nodes.len()).filter(|&i| needed[i]).collect();
        while !pending.is_empty() {
            pending.retain(|&i| {
                let ready = parent[i].is_none_or(|p| emitted[p]);
                if ready {
                    emitted[i] = true;
                    order.push(i);
                }
                !ready
            });
        }
        let mut new_index: HashMap<usize, usize> = HashMap::new();
        let mut is_joint = vec![false; root.nodes.len()];
        for &j in &joint_nodes {
            is_joint[j] = true;
        }
        for &i in &order {
            let n = &root.nodes[i];
            new_index.insert(i, skeleton.nodes.len());
            skeleton.nodes.push(Node {
                name: n.name.clone().unwrap_or_else(|| format!("node{i}")),
                parent: parent[i].map(|p| new_index[&p]),
                rest: locals[i],
                is_joint: is_joint[i],
            });
        }
        let mut same_bone: HashMap<(usize, [u32; 16]), usize> = HashMap::new();
        let mut notes = Vec::new();
        for &s in &skins {
            let skin = &root.skins[s];
            let ibms: Vec<Mat4> = match skin.inverse_bind_matrices {
                Some(a) => {
                    let v = accessor::read_f32(root, self.buffers, a.value())?;
                    if v.components != 16 || v.count() < skin.joints.len() {
                        return Err(ImportError::Invalid(format!(
                            "skin {s}: inverseBindMatrices must hold {} MAT4 values",
                            skin.joints.len()
                        )));
                    }
                    (0..skin.joints.len())
                        .map(|k| {
                            let m = Mat4::from_cols_slice(&v.data[k * 16..k * 16 + 16]);
                            let det = m.determinant();
                            if m.is_finite() && det.is_finite() && det.abs() > 1e-30 {
                                return m;
                            }
                            // Not a transform (NaN or infinite numbers, or flat: all zeros):
                            // the joint's rest pose stands in for its bind pose, as exporters
                            // write it for a mesh bound in the rest pose.
                            let j = skin.joints[k].value();
                            let rest = rest_world(j, parent, locals);
                            let inverse = rest.inverse();
                            let name = root.nodes[j].name.clone().unwrap_or_else(|| format!("node {j}"));
                            notes.push(format!(
                                "skin {s}: joint '{name}' has an inverse bind matrix that is {}: the inverse of its rest pose is used instead",
                                if m.is_finite() { "not invertible" } else { "not finite" }
                            ));
                            if inverse.is_finite() { inverse } else { Mat4::IDENTITY }
                        })
                        .collect()
                }
                None => vec![Mat4::IDENTITY; skin.joints.len()],
            };
            // Skins that name the same joint with the same inverse bind (clothing or a head
            // exported on a skin of its own) share one bone: the skinned crowd samples each
            // bone, and copies would double its joint data.
            let mut slots = Vec::with_capacity(skin.joints.len());
            for (k, j) in skin.joints.iter().enumerate() {
                let bone = Bone {
                    node: new_index[&j.value()],
                    inverse_bind: ibms[k],
                };
                let key = (bone.node, bone.inverse_bind.to_cols_array().map(f32::to_bits));
                let slot = *same_bone.entry(key).or_insert_with(|| {
                    bones.push(bone);
                    bones.len() - 1
                });
                slots.push(slot as u16);
            }
            for &m in mesh_nodes {
                if root.nodes[m].skin.map(|x| x.value()) == Some(s) {
                    bindings.insert(m, Binding::Skin(slots.clone()));
                }
            }
        }
        for &m in &rigid {
            bindings.insert(m, Binding::Rigid(bones.len() as u16));
            bones.push(Bone {
                node: new_index[&m],
                inverse_bind: Mat4::IDENTITY,
            });
        }
        let node_map = new_index;
        if bones.len() > u16::MAX as usize {
            return Err(ImportError::Unsupported(format!(
                "{} bones (at most 65535)",
                bones.len()
            )));
        }
        Ok(Rig {
            skeleton,
            bones,
            bindings,
            node_map,
            mirrored: Vec::new(),
            notes,
        })
    }

    /// One primitive of a mesh: its attributes checked against each other, its triangles,
    /// its vertices bound to the rig (static files: placed by the node's rest transform),
    /// its material; appended to `g`. Primitives that are not triangles are skipped (said).
    fn primitive(
        &mut self,
        mesh_name: &str,
        pi: usize,
        prim: &json::mesh::Primitive,
        place: Placement,
        rig: &Rig,
        g: &mut Geometry,
    ) -> Result<(), ImportError> {
        let Placement {
            node,
            static_world,
            morph_weights,
            morph_slots,
        } = place;
        let root = self.root;
        let what = format!("mesh '{mesh_name}' primitive {pi}");
        let mode = match prim.mode {
            Checked::Valid(mode) => mode,
            Checked::Invalid => {
                return Err(ImportError::Invalid(format!("{what}: invalid mode")));
            }
        };
        use json::mesh::{Mode, Semantic};
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            self.warn(format!(
                "{what}: {mode:?} primitives are not triangles and were skipped"
            ));
            return Ok(());
        }
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
        let Some(pos_acc) = attr(Semantic::Positions) else {
            self.warn(format!("{what}: no POSITION attribute; skipped"));
            return Ok(());
        };
        let mut positions = accessor::read_f32(root, self.buffers, pos_acc)?;
        if positions.components != 3 {
            return Err(ImportError::Invalid(format!("{what}: POSITION must be VEC3")));
        }
        let n = positions.count();
        if positions.data.iter().any(|x| !x.is_finite()) {
            return Err(ImportError::Invalid(format!(
                "{what}: POSITION holds non-finite values"
            )));
        }
        let read_attr =
            |s: Semantic, comps: &[usize], this: &Self| -> Result<Option<accessor::Values<f32>>, ImportError> {
                let Some(a) = attr(s.clone()) else {
                    return Ok(None);
                };
                let v = accessor::read_f32(root, this.buffers, a)?;
                if !comps.contains(&v.components) {
                    return Err(ImportError::Invalid(format!(
                        "{what}: {s:?} has {} components",
                        v.components
                    )));
                }
                if v.count() != n {
                    return Err(ImportError::Invalid(format!(
                        "{what}: {s:?} has {} elements, POSITION has {n}",
                        v.count()
                    )));
                }
                Ok(Some(v))
            };
        let mut normals = read_attr(Semantic::Normals, &[3], self)?;
        self.apply_morph_targets(&what, prim, morph_weights, &mut positions, &mut normals)?;
        // The coordinates the base colour texture is sampled with: its own set (texCoord,
        // or the transform's override) placed by KHR_texture_transform.
        let (uv_set, uv_place) = base_color_uvs(root, prim);
        let uvs = read_attr(Semantic::TexCoords(uv_set), &[2], self)?;
        let colors = read_attr(Semantic::Colors(0), &[3, 4], self)?;
        let weights = read_attr(Semantic::Weights(0), &[4], self)?;
        let read_joints = |set: u32, this: &Self| -> Result<Option<accessor::Values<u32>>, ImportError> {
            let Some(a) = attr(Semantic::Joints(set)) else {
                return Ok(None);
            };
            let v = accessor::read_u32(root, this.buffers, a)?;
            if v.components != 4 || v.count() != n {
                return Err(ImportError::Invalid(format!(
                    "{what}: JOINTS_{set} must be VEC4 with {n} elements"
                )));
            }
            Ok(Some(v))
        };
        let joints = read_joints(0, self)?;
        // A second set of influences (eight per vertex): each vertex keeps its four
        // strongest joints of the eight (weights renormalised below). A third set and
        // beyond are said and left out.
        let second = match (read_joints(1, self)?, read_attr(Semantic::Weights(1), &[4], self)?) {
            (Some(j), Some(w)) => Some((j, w)),
            (None, None) => None,
            _ => {
                return Err(ImportError::Invalid(format!(
                    "{what}: JOINTS_1 and WEIGHTS_1 must come together"
                )));
            }
        };
        if attr(Semantic::Joints(2)).is_some() {
            self.warn(format!(
                "{what}: more than 8 influences per vertex; JOINTS_2/WEIGHTS_2 and beyond left out"
            ));
        }
        let mut dropped_weight = 0.0f32;

        // Triangle list.
        let raw: Vec<u32> = match prim.indices {
            Some(a) => {
                let v = accessor::read_u32(root, self.buffers, a.value())?;
                if v.components != 1 {
                    return Err(ImportError::Invalid(format!("{what}: indices must be SCALAR")));
                }
                v.data
            }
            None => (0..n as u32).collect(),
        };
        if let Some(&bad) = raw.iter().find(|&&i| i as usize >= n) {
            return Err(ImportError::Invalid(format!(
                "{what}: index {bad} is out of range ({n} vertices)"
            )));
        }
        let mut tris = triangulate(mode, &raw);
        if tris.is_empty() {
            self.warn(format!("{what}: no triangles"));
            return Ok(());
        }
        // Only the vertices its triangles use, in the file's order: primitives that share one
        // vertex buffer (each drawing a range of it) would otherwise bring every vertex once
        // per primitive, and unused copies weigh in every measure taken over the vertices.
        let keep = used_vertices(&mut tris, n);

        let binding = match node {
            Some(n) => rig.bindings.get(&n),
            None => Some(&Binding::Rigid(0)),
        };
        let base = g.vertices.len() as u32;
        let mut bad_weights = false;
        for &i in &keep {
            let mut position = Vec3::from_array(positions.get::<3>(i));
            let mut normal = normals.as_ref().map_or(Vec3::ZERO, |v| Vec3::from_array(v.get::<3>(i)));
            if !normal.is_finite() {
                normal = Vec3::ZERO;
            }
            let uv = uvs.as_ref().map_or([0.0; 2], |v| uv_place(v.get::<2>(i)));
            let uv = if uv.iter().all(|x| x.is_finite()) { uv } else { [0.0; 2] };
            let color = match &colors {
                Some(c) if c.components == 3 => {
                    let [r, g, b] = c.get::<3>(i);
                    [r, g, b, 1.0]
                }
                Some(c) => c.get::<4>(i),
                None => [1.0; 4],
            };
            let (vb, vw) = match binding {
                Some(Binding::Skin(slots)) => match (&joints, &weights) {
                    (Some(j), Some(w)) => {
                        let (js, mut ws) = match &second {
                            Some((j1, w1)) => {
                                let (js, ws, dropped) =
                                    strongest_four(j.get::<4>(i), w.get::<4>(i), j1.get::<4>(i), w1.get::<4>(i));
                                dropped_weight = dropped_weight.max(dropped);
                                (js, ws)
                            }
                            None => (j.get::<4>(i), w.get::<4>(i)),
                        };
                        let mut b = [0u16; 4];
                        for k in 0..4 {
                            if !ws[k].is_finite() || ws[k] < 0.0 {
                                ws[k] = 0.0;
                            }
                            match slots.get(js[k] as usize) {
                                Some(&bone) => b[k] = bone,
                                None if ws[k] == 0.0 => b[k] = slots[0],
                                None => {
                                    return Err(ImportError::Invalid(format!(
                                        "{what}: vertex {i} uses joint {} but the skin has {}",
                                        js[k],
                                        slots.len()
                                    )));
                                }
                            }
                        }
                        let sum: f32 = ws.iter().sum();
                        if sum > 0.0 {
                            (b, ws.map(|x| x / sum))
                        } else {
                            bad_weights = true;
                            (b, [1.0, 0.0, 0.0, 0.0])
                        }
                    }
                    _ => {
                        self.warn(format!(
                            "{what}: skinned without JOINTS_0/WEIGHTS_0; bound to the first joint"
                        ));
                        ([slots[0], 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
                    }
                },
                Some(Binding::Rigid(b)) => ([*b, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
                None => ([0; 4], [1.0, 0.0, 0.0, 0.0]),
            };
            if let Some(w) = static_world {
                position = w.transform_point3(position);
                // Normals by the inverse transpose: a node scaled unevenly (a prop
                // squashed flat) would otherwise tilt them.
                normal = normal_matrix(w) * normal;
            }
            g.vertices.push(Vertex {
                position,
                normal: normal.normalize_or_zero(),
                uv,
                color,
                bones: vb,
                weights: vw,
            });
        }
        if !morph_slots.is_empty() {
            self.keep_morph_offsets(&what, prim, &keep, base, static_world, morph_slots, g)?;
        }
        if bad_weights {
            self.warn(format!("{what}: vertices with zero weights bound to their first joint"));
        }
        if dropped_weight > 0.0 {
            self.warn(format!(
                "{what}: vertices with more than 4 influences keep their 4 strongest (at most {:.0} % of a vertex's weight left out)",
                dropped_weight * 100.0
            ));
        }
        // Mirrored transforms flip the winding: a static node's (its vertices are placed
        // mirrored here, so before any normals are computed from the winding), or the skinning
        // transform of a triangle's main bone (vertices stay in bind space, where the file's
        // winding is the outside; turned after the normals).
        let flip_static = static_world.is_some_and(|w| w.determinant() < 0.0);
        let first_index = g.indices.len() as u32;
        for t in tris.chunks_exact(3) {
            if flip_static {
                g.indices.extend_from_slice(&[base + t[0], base + t[2], base + t[1]]);
            } else {
                g.indices.extend_from_slice(&[base + t[0], base + t[1], base + t[2]]);
            }
        }
        if normals.is_none() {
            compute_normals(
                &mut g.vertices[base as usize..],
                &g.indices[first_index as usize..],
                base,
            );
        }
        if static_world.is_none() && rig.mirrored.iter().any(|&m| m) {
            let main_bone = |v: &Vertex| {
                let k = (0..4)
                    .max_by(|&a, &b| v.weights[a].total_cmp(&v.weights[b]))
                    .unwrap_or(0);
                v.bones[k] as usize
            };
            for t in g.indices[first_index as usize..].chunks_exact_mut(3) {
                if rig
                    .mirrored
                    .get(main_bone(&g.vertices[t[0] as usize]))
                    .copied()
                    .unwrap_or(false)
                {
                    t.swap(1, 2);
                }
            }
        }
        let mat_index = prim.material.map(|x| x.value());
        let material = match g.material_map.get(&mat_index) {
            Some(&k) => k,
            None => {
                let mat = self.material(mat_index, &mut g.textures, &mut g.texture_map)?;
                g.materials.push(mat);
                g.material_map.insert(mat_index, g.materials.len() - 1);
                g.materials.len() - 1
            }
        };
        if uvs.is_none() && g.materials[material].base_color_texture.is_some() {
            self.warn(format!(
                "{what}: its material has a texture but the primitive has no TEXCOORD_{uv_set}; drawn in the texture's first texel"
            ));
        }
        g.submeshes.push(Submesh {
            first_index,
            index_count: g.indices.len() as u32 - first_index,
            material,
        });
        Ok(())
    }
}

impl Builder<'_> {
    /// A primitive's morph target offsets for the targets a clip animates (`slots[ti]`:
    /// where target `ti` goes in `g.morphs`): the kept vertices `keep` (now `base..`), placed
    /// like the vertices (a static node's transform), zero offsets left out.
    #[allow(clippy::too_many_arguments)]
    fn keep_morph_offsets(
        &mut self,
        what: &str,
        prim: &json::mesh::Primitive,
        keep: &[usize],
        base: u32,
        static_world: Option<Mat4>,
        slots: &[usize],
        g: &mut Geometry,
    ) -> Result<(), ImportError> {
        let Some(targets) = prim.targets.as_deref() else {
            return Ok(());
        };
        // The primitive's vertex count (its POSITION accessor was read and checked already).
        let n = prim
            .attributes
            .get(&Checked::Valid(json::mesh::Semantic::Positions))
            .and_then(|a| self.root.accessors.get(a.value()))
            .map_or(0, |a| a.count.0 as usize);
        for (ti, target) in targets.iter().enumerate() {
            let Some(&slot) = slots.get(ti) else { continue };
            let dp = self.morph_offsets(what, ti, "POSITION", target.positions, n)?;
            let dn = self.morph_offsets(what, ti, "NORMAL", target.normals, n)?;
            let m = &mut g.morphs[slot];
            for (k, &i) in keep.iter().enumerate() {
                let mut p = dp.as_ref().map_or(Vec3::ZERO, |d| Vec3::from_array(d.get::<3>(i)));
                let mut q = dn.as_ref().map_or(Vec3::ZERO, |d| Vec3::from_array(d.get::<3>(i)));
                if p == Vec3::ZERO && q == Vec3::ZERO {
                    continue;
                }
                if let Some(w) = static_world {
                    p = w.transform_vector3(p);
                    q = normal_matrix(w) * q;
                }
                m.vertices.push(base + k as u32);
                m.positions.push(p);
                m.normals.push(q);
            }
        }
        Ok(())
    }

    /// Morph target `ti`'s `name` offsets (`None` where the target has none), checked to be
    /// `n` finite VEC3 values: one per vertex of the primitive.
    fn morph_offsets(
        &self,
        what: &str,
        ti: usize,
        name: &str,
        a: Option<json::Index<json::Accessor>>,
        n: usize,
    ) -> Result<Option<accessor::Values<f32>>, ImportError> {
        let Some(a) = a else {
            return Ok(None);
        };
        let v = accessor::read_f32(self.root, self.buffers, a.value())?;
        if v.components != 3 || v.count() != n || v.data.iter().any(|x| !x.is_finite()) {
            return Err(ImportError::Invalid(format!(
                "{what}: morph target {ti} {name} must be {n} finite VEC3 values, one per vertex"
            )));
        }
        Ok(Some(v))
    }

    /// Adds a primitive's morph targets at `weights` to its positions and normals (the
    /// shape the file shows at rest; glTF: `base + Σ wᵢ·targetᵢ`). Targets beyond the
    /// weights given are at weight 0; a target's accessor is checked like any attribute.
    fn apply_morph_targets(
        &mut self,
        what: &str,
        prim: &json::mesh::Primitive,
        weights: &[f32],
        positions: &mut accessor::Values<f32>,
        normals: &mut Option<accessor::Values<f32>>,
    ) -> Result<(), ImportError> {
        let Some(targets) = prim.targets.as_deref() else {
            return Ok(());
        };
        if !weights.is_empty() && weights.len() != targets.len() {
            self.warn(format!(
                "{what}: {} morph targets but {} default weights; the missing ones are 0",
                targets.len(),
                weights.len()
            ));
        }
        let n = positions.count();
        let mut applied = 0;
        for (ti, target) in targets.iter().enumerate() {
            let w = weights.get(ti).copied().unwrap_or(0.0);
            if w == 0.0 {
                continue;
            }
            if !w.is_finite() {
                return Err(ImportError::Invalid(format!(
                    "{what}: morph target {ti} has a non-finite weight"
                )));
            }
            if let Some(d) = self.morph_offsets(what, ti, "POSITION", target.positions, n)? {
                for (p, d) in positions.data.iter_mut().zip(&d.data) {
                    *p += w * d;
                }
            }
            if let (Some(d), Some(nv)) = (
                self.morph_offsets(what, ti, "NORMAL", target.normals, n)?,
                normals.as_mut(),
            ) {
                for (p, d) in nv.data.iter_mut().zip(&d.data) {
                    *p += w * d;
                }
            }
            applied += 1;
        }
        if applied > 0 {
            self.warn(format!(
                "{what}: {applied} morph target(s) applied at their default weights"
            ));
        }
        Ok(())
    }
}

/// The texture coordinate set a primitive's base colour texture reads and the placement
/// KHR_texture_transform gives it (`uv' = T·R·S·uv`: scale, then rotate by `rotation`
/// radians counter-clockwise in texture space, then offset), identity without it.
fn base_color_uvs(root: &json::Root, prim: &json::mesh::Primitive) -> (u32, impl Fn([f32; 2]) -> [f32; 2]) {
    let info = prim
        .material
        .and_then(|m| root.materials.get(m.value()))
        .and_then(|m| m.pbr_metallic_roughness.base_color_texture.as_ref());
    let xf = info
        .and_then(|i| i.extensions.as_ref())
        .and_then(|e| e.texture_transform.as_ref());
    let set = xf.and_then(|t| t.tex_coord).or(info.map(|i| i.tex_coord)).unwrap_or(0);
    let finite = |v: f32, or: f32| if v.is_finite() { v } else { or };
    let (offset, rotation, scale) = xf.map_or(([0.0; 2], 0.0, [1.0; 2]), |t| {
        (
            t.offset.0.map(|v| finite(v, 0.0)),
            finite(t.rotation.0, 0.0),
            t.scale.0.map(|v| finite(v, 1.0)),
        )
    });
    let (sin, cos) = rotation.sin_cos();
    let place = move |[u, v]: [f32; 2]| {
        let (su, sv) = (u * scale[0], v * scale[1]);
        [cos * su + sin * sv + offset[0], -sin * su + cos * sv + offset[1]]
    };
    (set, place)
}

/// The vertices (of `n`) that `tris` use, in order, with `tris` renumbered to index that list.
fn used_vertices(tris: &mut [u32], n: usize) -> Vec<usize> {
    let mut new_index = vec![u32::MAX; n];
    for &t in tris.iter() {
        new_index[t as usize] = 0;
    }
    let mut keep = Vec::with_capacity(n);
    for (i, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = keep.len() as u32;
            keep.push(i);
        }
    }
    for t in tris.iter_mut() {
        *t = new_index[*t as usize];
    }
    keep
}

/// Where a primitive's vertices go: its node, the node's world transform for static files,
/// the morph target weights that shape it at rest.
#[derive(Clone, Copy)]
struct Placement<'a> {
    node: Option<usize>,
    static_world: Option<Mat4>,
    morph_weights: &'a [f32],
    /// Where each morph target a clip animates goes in the character's morphs (empty: none).
    morph_slots: &'a [usize],
}

/// The four strongest of a vertex's eight influences (two sets of four; a joint named twice
/// counts once with its weights summed) and the share of the total weight left out.
/// Negative and non-finite weights count as zero.
fn strongest_four(j0: [u32; 4], w0: [f32; 4], j1: [u32; 4], w1: [f32; 4]) -> ([u32; 4], [f32; 4], f32) {
    let clean = |w: f32| if w.is_finite() && w > 0.0 { w } else { 0.0 };
    let mut all: Vec<(u32, f32)> = Vec::with_capacity(8);
    for (j, w) in j0.into_iter().zip(w0).chain(j1.into_iter().zip(w1)) {
        let w = clean(w);
        if w == 0.0 {
            continue;
        }
        match all.iter_mut().find(|(k, _)| *k == j) {
            Some((_, sum)) => *sum += w,
            None => all.push((j, w)),
        }
    }
    // Heaviest first; equal weights keep the order they came in.
    all.sort_by(|a, b| b.1.total_cmp(&a.1));
    let total: f32 = all.iter().map(|x| x.1).sum();
    let mut js = [j0[0]; 4];
    let mut ws = [0.0; 4];
    for (k, &(j, w)) in all.iter().take(4).enumerate() {
        js[k] = j;
        ws[k] = w;
    }
    let kept: f32 = ws.iter().sum();
    let dropped = if total > 0.0 { 1.0 - kept / total } else { 0.0 };
    (js, ws, dropped)
}

/// Marks `starts` and all their ancestors in `marks` (stopping at a node already marked).
fn mark_with_ancestors(starts: impl IntoIterator<Item = usize>, parent: &[Option<usize>], marks: &mut [bool]) {
    for start in starts {
        let mut at = Some(start);
        while let Some(i) = at {
            if marks[i] {
                break;
            }
            marks[i] = true;
            at = parent[i];
        }
    }
}

/// Whether an animation channel (translation, rotation or scale) targets a mesh node or one
/// of its ancestors.
fn animates_meshes(root: &json::Root, mesh_nodes: &[usize], parent: &[Option<usize>]) -> bool {
    let mut moves = vec![false; root.nodes.len()];
    mark_with_ancestors(mesh_nodes.iter().copied(), parent, &mut moves);
    root.animations.iter().flat_map(|a| &a.channels).any(|ch| {
        matches!(
            ch.target.path,
            Checked::Valid(
                json::animation::Property::Translation
                    | json::animation::Property::Rotation
                    | json::animation::Property::Scale
            )
        ) && moves.get(ch.target.node.value()).copied().unwrap_or(false)
    })
}

/// Rest world matrix of file node `i`: its local transforms chained up its parents (the
/// hierarchy has no cycles by now; the chain is bounded by the node count all the same).
fn rest_world(i: usize, parent: &[Option<usize>], locals: &[Transform]) -> Mat4 {
    let mut m = Mat4::IDENTITY;
    let mut at = Some(i);
    for _ in 0..=parent.len() {
        let Some(n) = at else { break };
        m = locals[n].to_mat4() * m;
        at = parent[n];
    }
    m
}

/// The rig of a file without skins: one root joint every mesh follows rigidly (the
/// geometry is placed by its nodes' rest transforms).
fn static_rig(mesh_nodes: &[usize]) -> Rig {
    let mut rig = Rig::default();
    rig.skeleton.nodes.push(Node {
        name: "root".into(),
        parent: None,
        rest: Transform::IDENTITY,
        is_joint: true,
    });
    rig.bones.push(Bone {
        node: 0,
        inverse_bind: Mat4::IDENTITY,
    });
    for &m in mesh_nodes {
        rig.bindings.insert(m, Binding::Rigid(0));
    }
    rig
}

/// Warnings alike but for their numbers (one per channel of a damaged clip: a file gave 57)
/// are said once when there are more than three, the first of them with how many more there
/// are; fewer are kept as they are.
fn collapse_warnings(warnings: Vec<String>) -> Vec<String> {
    const KEEP: usize = 3;
    // Each run of digits (and decimal points within it) becomes one '#'.
    let shape = |w: &str| -> String {
        let mut out = String::with_capacity(w.len());
        for c in w.chars() {
            if c.is_ascii_digit() || (c == '.' && out.ends_with('#')) {
                if !out.ends_with('#') {
                    out.push('#');
                }
            } else {
                out.push(c);
            }
        }
        out
    };
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for w in warnings {
        let s = shape(&w);
        match groups.iter_mut().find(|(k, _)| *k == s) {
            Some((_, list)) => list.push(w),
            None => groups.push((s, vec![w])),
        }
    }
    groups
        .into_iter()
        .flat_map(|(_, list)| {
            if list.len() > KEEP {
                vec![format!("{} (and {} more like it)", list[0], list.len() - 1)]
            } else {
                list
            }
        })
        .collect()
}

#[cfg(test)]
mod warning_tests {
    #[test]
    fn many_warnings_alike_are_said_once_and_a_few_as_they_are() {
        let mut w: Vec<String> = (0..57)
            .map(|c| format!("animation 'A' channel {c}: output has 48 values"))
            .collect();
        w.push("mesh 'm': no normals".into());
        w.push("clip 'x' 1".into());
        w.push("clip 'y' 2".into());
        let got = super::collapse_warnings(w);
        assert_eq!(
            got,
            [
                "animation 'A' channel 0: output has 48 values (and 56 more like it)",
                "mesh 'm': no normals",
                "clip 'x' 1",
                "clip 'y' 2"
            ]
        );
    }
}

#[cfg(test)]
mod influence_tests {
    use super::strongest_four;

    /// Against brute force: every way of keeping four of the merged joints, the kept weight
    /// is the largest possible and the share left out is what the others held.
    #[test]
    fn the_strongest_four_of_eight_influences() {
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        for _ in 0..2000 {
            let j0 = [0; 4].map(|_: i32| next() % 6);
            let j1 = [0; 4].map(|_: i32| next() % 6);
            let w = |n: u32| if n % 5 == 0 { 0.0 } else { (n % 1000) as f32 / 1000.0 };
            let w0 = [0; 4].map(|_: i32| w(next()));
            let w1 = [0; 4].map(|_: i32| w(next()));
            let mut merged = [0.0f32; 6];
            for (j, x) in j0.iter().zip(&w0).chain(j1.iter().zip(&w1)) {
                merged[*j as usize] += x;
            }
            let total: f32 = merged.iter().sum();
            let mut sorted = merged;
            sorted.sort_by(|a, b| b.total_cmp(a));
            let best: f32 = sorted[..4].iter().sum();
            let (js, ws, dropped) = strongest_four(j0, w0, j1, w1);
            let kept: f32 = ws.iter().sum();
            assert!((kept - best).abs() < 1e-5, "{kept} {best}");
            for (j, x) in js.iter().zip(&ws) {
                if *x > 0.0 {
                    assert!((merged[*j as usize] - x).abs() < 1e-6);
                }
            }
            let distinct: Vec<_> = js.iter().zip(&ws).filter(|(_, x)| **x > 0.0).map(|(j, _)| *j).collect();
            let mut d = distinct.clone();
            d.sort();
            d.dedup();
            assert_eq!(d.len(), distinct.len(), "a joint kept twice: {js:?}");
            if total > 0.0 {
                assert!((dropped - (1.0 - best / total)).abs() < 1e-5);
            }
        }
        // Negative and non-finite weights count as nothing.
        let (_, ws, dropped) = strongest_four([1, 2, 3, 4], [0.5, -1.0, f32::NAN, 0.5], [5, 0, 0, 0], [0.0; 4]);
        assert_eq!(ws, [0.5, 0.5, 0.0, 0.0]);
        assert_eq!(dropped, 0.0);
    }
}
