//! The character model every stage works on: one merged, skinned triangle mesh with its
//! skeleton, animation clips, materials and textures.
//!
//! Conventions: Y up, metres, counter-clockwise front faces (as glTF). Vertex influences
//! index [`Character::bones`]; a bone is a skeleton node plus its inverse bind matrix, so
//! that the skinning matrix of a bone is `world_from_node * inverse_bind`.

use glam::{Mat4, Quat, Vec3};

/// One vertex of the merged character mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    /// Position in bind space (the space the inverse bind matrices expect).
    pub position: Vec3,
    /// Unit normal in bind space.
    pub normal: Vec3,
    /// Texture coordinate of the base-colour texture.
    pub uv: [f32; 2],
    /// Linear RGBA vertex colour (white when the file has none).
    pub color: [f32; 4],
    /// Indices into [`Character::bones`].
    pub bones: [u16; 4],
    /// Weights of `bones`, summing to one.
    pub weights: [f32; 4],
}

/// A local transform: translation, rotation, scale (applied scale first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Offset from the parent node's origin, in the parent's units (applied last).
    pub translation: Vec3,
    /// Rotation as a unit quaternion, applied after the scale.
    pub rotation: Quat,
    /// Per-axis scale factors, applied first (`Vec3::ONE`: none).
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// No translation, no rotation, unit scale.
    pub const IDENTITY: Self = Self {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// The parent-from-node matrix `T * R * S`.
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Splits an affine matrix into translation, rotation and scale. Shear cannot be represented
    /// and is lost; a mirroring matrix gets a negative x scale; a singular one can give
    /// non-finite parts.
    pub fn from_mat4(m: Mat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Self {
            translation,
            rotation,
            scale,
        }
    }
}

/// A node of the skeleton hierarchy. Nodes are stored parents first.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Name from the file (`node{i}` with the file's node index when it has none; `root` for the
    /// single node of a file without a skin). Not necessarily unique.
    pub name: String,
    /// Index of the parent node; always smaller than this node's index.
    pub parent: Option<usize>,
    /// Local transform at rest (used for every channel a clip does not animate).
    pub rest: Transform,
    /// True for joints of a skin in the source file (false for helper nodes such as the
    /// parents of the skeleton or the nodes that carry rigid props).
    pub is_joint: bool,
}

/// The node hierarchy of the character.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skeleton {
    /// Every node, parents before children (a node's parent has a smaller index).
    pub nodes: Vec<Node>,
}

impl Skeleton {
    /// Number of skin joints (what a user calls "joints").
    pub fn joint_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_joint).count()
    }

    /// Index of the node with this name, if any.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// World-from-node matrices of the rest pose.
    pub fn rest_world(&self) -> Vec<Mat4> {
        let locals: Vec<Transform> = self.nodes.iter().map(|n| n.rest).collect();
        self.world_from_locals(&locals)
    }

    /// World-from-node matrices for the given local transforms (one per node).
    pub fn world_from_locals(&self, locals: &[Transform]) -> Vec<Mat4> {
        let mut world = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let local = locals.get(i).copied().unwrap_or(node.rest).to_mat4();
            let m = match node.parent {
                Some(p) => world[p] * local,
                None => local,
            };
            world.push(m);
        }
        world
    }
}

/// A skinning bone: a node and the inverse bind matrix that brings bind-space vertices into
/// that node's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bone {
    /// Index into [`Skeleton::nodes`] of the node the bone follows.
    pub node: usize,
    /// Takes bind-space vertices into the node's space as it was at bind time (identity for
    /// meshes bound rigidly to their own node and for files without a skin).
    pub inverse_bind: Mat4,
}

/// How a sampler interpolates between keys (glTF's three modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Interpolation {
    /// Each key's value holds until the next key.
    Step,
    /// Linear between keys (spherical linear for rotations).
    Linear,
    /// Values are stored as (in-tangent, value, out-tangent) triples per key.
    CubicSpline,
}

/// The animated property of a channel.
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelValues {
    /// Translations, in the parent node's units.
    Translation(Vec<Vec3>),
    /// Rotations as unit quaternions (cubic-spline tangents are left unnormalised).
    Rotation(Vec<Quat>),
    /// Per-axis scales.
    Scale(Vec<Vec3>),
}

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Index into [`Skeleton::nodes`] of the animated node.
    pub node: usize,
    /// How values are interpolated between `times`.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// Per key one value (three for [`Interpolation::CubicSpline`]).
    pub values: ChannelValues,
}

/// An animation clip.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    /// Name from the file (`Animation {i}` with the file's animation index when it has none).
    pub name: String,
    /// End time of the last key of any channel, in seconds (the clip loops over `[0, duration)`).
    pub duration_secs: f32,
    /// The animated properties; a node without a channel keeps its rest transform. Empty for a
    /// clip all of whose channels were skipped (and for every clip of a static file without a
    /// skin: one whose animations move none of its meshes).
    pub channels: Vec<Channel>,
    /// Horizontal velocity `(x, 0, z)` in model units per second that sampling takes out, so
    /// the clip plays in place: a locomotion clip's root motion, found at import by
    /// [`crate::timeline::play_in_place`] (the crowd moves the character; its ground speed is
    /// kept). Zero for a clip played as authored.
    pub in_place_velocity: Vec3,
    /// The morph target weights the clip moves ([`Character::morphs`]); a target without a
    /// channel keeps its rest weight.
    pub morph_channels: Vec<MorphChannel>,
}

/// The weights of some of a character's morph targets over time (a glTF `weights` channel:
/// every target of one mesh node).
#[derive(Clone, Debug, PartialEq)]
pub struct MorphChannel {
    /// Indices into [`Character::morphs`] of the weights this channel holds, in order.
    pub targets: Vec<usize>,
    /// How values are interpolated between `times`.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// Per key (three per key for [`Interpolation::CubicSpline`]: in-tangent, value,
    /// out-tangent) one weight per target, `targets.len()` values a row.
    pub values: Vec<f32>,
}

/// A morph target (blend shape) some clip animates: how far each of some vertices moves
/// per unit of weight, in bind space. The vertices hold the shape at `rest_weight`; a pose
/// at weight `w` adds `(w - rest_weight)` times these offsets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTarget {
    /// Where it comes from (mesh and target index), for messages.
    pub name: String,
    /// The weight already in [`Character::vertices`] (the file's default weight).
    pub rest_weight: f32,
    /// The vertices it moves, increasing.
    pub vertices: Vec<u32>,
    /// Position offset of each of `vertices` per unit of weight.
    pub positions: Vec<Vec3>,
    /// Normal offset of each of `vertices` per unit of weight (added, then normalised).
    pub normals: Vec<Vec3>,
}

impl MorphTarget {
    /// The same target on another vertex list: new vertex `i` is the weighted sum
    /// `origins[i]` of old vertices (a copy: one old vertex at weight 1; a cap's centre:
    /// the mean of its ring). `None` where no new vertex moves.
    pub fn remapped(&self, origins: &[Vec<(u32, f32)>]) -> Option<Self> {
        let offset = |v: u32| {
            self.vertices
                .binary_search(&v)
                .ok()
                .map(|k| (self.positions[k], self.normals[k]))
        };
        let mut out = Self {
            name: self.name.clone(),
            rest_weight: self.rest_weight,
            ..Default::default()
        };
        for (i, list) in origins.iter().enumerate() {
            let (mut p, mut n, mut any) = (Vec3::ZERO, Vec3::ZERO, false);
            for &(v, w) in list {
                if let Some((dp, dn)) = offset(v) {
                    p += dp * w;
                    n += dn * w;
                    any = true;
                }
            }
            if any {
                out.vertices.push(i as u32);
                out.positions.push(p);
                out.normals.push(n);
            }
        }
        (!out.vertices.is_empty()).then_some(out)
    }
}

/// An RGBA8 texture, stored as sRGB-encoded bytes (as in the file).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// The image's name in the file, else its relative URI, else `image {i}` (the file's
    /// image index).
    pub name: String,
    /// Width in pixels (at most [`crate::import::MAX_TEXTURE_SIDE`] when imported).
    pub width: u32,
    /// Height in pixels (at most [`crate::import::MAX_TEXTURE_SIDE`] when imported).
    pub height: u32,
    /// `width * height * 4` bytes, rows top to bottom.
    pub rgba8: Vec<u8>,
}

impl Texture {
    /// A 1×1 white texture, used where a material has none.
    pub fn white() -> Self {
        Self {
            name: "white".into(),
            width: 1,
            height: 1,
            rgba8: vec![255; 4],
        }
    }
}

/// The part of a material the pipeline uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the file (`material {i}` when it has none; `default` for primitives without
    /// a material).
    pub name: String,
    /// Linear RGBA multiplier of the texture and vertex colour.
    pub base_color_factor: [f32; 4],
    /// Index into [`Character::textures`].
    pub base_color_texture: Option<usize>,
    /// Draw back faces too instead of culling them (glTF's `doubleSided`).
    pub double_sided: bool,
    /// Fragments whose base colour alpha (texture × factor × vertex colour) falls below this
    /// are not drawn: glTF's `MASK` with its `alphaCutoff`, and `BLEND` drawn as a cut-out at
    /// 0.5. `0.0` draws every fragment (`OPAQUE`, alpha ignored).
    pub alpha_cutoff: f32,
    /// How the base colour texture continues past 0..1 in u and in v (glTF's sampler
    /// `wrapS`, `wrapT`; repeat when the file names no sampler).
    pub wrap: [TextureWrap; 2],
}

/// How a texture coordinate outside 0..1 reads the texture (glTF's sampler wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureWrap {
    /// The texture tiles (glTF 10497, the default).
    #[default]
    Repeat,
    /// The texture tiles, every other copy mirrored (glTF 33648).
    MirroredRepeat,
    /// The edge texels continue (glTF 33071).
    ClampToEdge,
}

impl TextureWrap {
    /// From glTF's wrap mode number; `None` for any other number.
    pub fn from_gltf(code: u32) -> Option<Self> {
        match code {
            10497 => Some(Self::Repeat),
            33648 => Some(Self::MirroredRepeat),
            33071 => Some(Self::ClampToEdge),
            _ => None,
        }
    }

    /// glTF's number for this mode.
    pub fn gltf(self) -> u32 {
        match self {
            Self::Repeat => 10497,
            Self::MirroredRepeat => 33648,
            Self::ClampToEdge => 33071,
        }
    }

    /// The coordinate in 0..=1 that `x` reads under this mode (as a GPU sampler's address
    /// mode does for the texel centres it filters between).
    pub fn apply(self, x: f32) -> f32 {
        if !x.is_finite() {
            return 0.0;
        }
        match self {
            Self::Repeat => x.rem_euclid(1.0),
            Self::MirroredRepeat => {
                let t = x.rem_euclid(2.0);
                if t > 1.0 { 2.0 - t } else { t }
            }
            Self::ClampToEdge => x.clamp(0.0, 1.0),
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            double_sided: false,
            alpha_cutoff: 0.0,
            wrap: [TextureWrap::Repeat; 2],
        }
    }
}

/// A range of [`Character::indices`] drawn with one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Submesh {
    /// First index (a multiple of three).
    pub first_index: u32,
    /// Number of indices (a multiple of three).
    pub index_count: u32,
    /// Index into [`Character::materials`].
    pub material: usize,
}

/// A skinned, animated character: what an import produces and every later stage consumes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Character {
    /// Display name: the default scene's name when it says something, else the file name
    /// without its extension.
    pub name: String,
    /// Vertices of the merged mesh, in bind space.
    pub vertices: Vec<Vertex>,
    /// Triangle list, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Ranges of `indices` with their material, one per imported triangle primitive, in
    /// index order.
    pub submeshes: Vec<Submesh>,
    /// Materials the submeshes use: each file material once, plus [`Material::default`] for
    /// primitives without one.
    pub materials: Vec<Material>,
    /// Base-colour textures the materials refer to (only those that loaded: a material whose
    /// texture failed has none, and is drawn untextured).
    pub textures: Vec<Texture>,
    /// The node hierarchy: skin joints, nodes that carry rigid meshes, and their ancestors (one
    /// `root` node for a file without a skin).
    pub skeleton: Skeleton,
    /// Skinning bones, which [`Vertex::bones`] index: every skin's joints in skin order, then one
    /// per mesh node bound rigidly. At most 65,535.
    pub bones: Vec<Bone>,
    /// Every animation clip of the file, in file order.
    pub clips: Vec<Clip>,
    /// Problems the import worked around, for the user to read.
    pub warnings: Vec<String>,
    /// Which of the file's axes was read as up (the import's `ImportOptions::up`; the
    /// import turned the character so that it stands along +y). Packs record it so every
    /// re-import of the file agrees.
    pub up_axis: UpAxis,
    /// Morph targets that some clip's [`Clip::morph_channels`] animate (targets no clip moves
    /// are only applied at their default weights, into the vertices, at import).
    pub morphs: Vec<MorphTarget>,
}

impl Character {
    /// Number of triangles (`indices.len() / 3`).
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Which bones some vertex is weighted to (a weight above zero).
    pub fn used_bones(&self) -> Vec<bool> {
        let mut used = vec![false; self.bones.len()];
        for v in &self.vertices {
            for k in 0..4 {
                if v.weights[k] > 0.0
                    && let Some(u) = used.get_mut(v.bones[k] as usize)
                {
                    *u = true;
                }
            }
        }
        used
    }

    /// Bones some vertex is weighted to; the skinning a crowd of skinned meshes needs (IK
    /// targets, poles and controls the file lists among the skin's joints move nothing).
    pub fn used_bone_count(&self) -> usize {
        let used = self.used_bones().iter().filter(|&&u| u).count();
        if used == 0 { self.bones.len() } else { used }
    }

    /// This character with only the bones some vertex is weighted to, the vertices' bone
    /// numbers renumbered (a slot of weight zero on a dropped bone points at bone 0): every
    /// pose skins every vertex where it skinned it. `None` where every bone is used, or none.
    pub fn without_unused_bones(&self) -> Option<Character> {
        let used = self.used_bones();
        let kept = used.iter().filter(|&&u| u).count();
        if kept == used.len() || kept == 0 {
            return None;
        }
        let mut renumber = vec![0u16; used.len()];
        let mut next = 0u16;
        for (b, &u) in used.iter().enumerate() {
            if u {
                renumber[b] = next;
                next += 1;
            }
        }
        let mut out = self.clone();
        out.bones = self
            .bones
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(b, _)| b.clone())
            .collect();
        for v in &mut out.vertices {
            for k in 0..4 {
                v.bones[k] = if v.weights[k] > 0.0 {
                    renumber.get(v.bones[k] as usize).copied().unwrap_or(0)
                } else {
                    0
                };
            }
        }
        Some(out)
    }

    /// Per submesh, whether it can draw no fragment at all: its material cuts out below an
    /// alpha (`MASK`, or `BLEND` drawn as a cut-out) that its base colour never reaches: the
    /// factor's alpha times the texture's largest alpha times its vertices' largest colour
    /// alpha. Each texture is scanned once.
    pub fn submeshes_drawing_nothing(&self) -> Vec<bool> {
        let mut texture_alpha: Vec<Option<f32>> = vec![None; self.textures.len()];
        self.submeshes
            .iter()
            .map(|s| {
                let Some(m) = self.materials.get(s.material) else {
                    return false;
                };
                if !(m.alpha_cutoff > 0.0) {
                    return false;
                }
                let texture = match m.base_color_texture.filter(|&t| t < self.textures.len()) {
                    Some(t) => *texture_alpha[t].get_or_insert_with(|| {
                        let most = self.textures[t].rgba8.chunks_exact(4).map(|p| p[3]).max();
                        f32::from(most.unwrap_or(255)) / 255.0
                    }),
                    None => 1.0,
                };
                let first = (s.first_index as usize).min(self.indices.len());
                let end = (first + s.index_count as usize).min(self.indices.len());
                let vertex = self.indices[first..end].iter().fold(0.0f32, |a, &i| {
                    a.max(self.vertices.get(i as usize).map_or(1.0, |v| v.color[3]))
                });
                m.base_color_factor[3] * texture * vertex < m.alpha_cutoff
            })
            .collect()
    }

    /// Index of the clip with this name.
    pub fn find_clip(&self, name: &str) -> Option<usize> {
        self.clips.iter().position(|c| c.name == name)
    }

    /// This character's morph targets on another vertex list (see [`MorphTarget::remapped`]),
    /// keeping target indices (a target no new vertex uses stays, empty), so clips' morph
    /// channels still point at the right ones. Empty when this character has none.
    pub fn morphs_remapped(&self, origins: &[Vec<(u32, f32)>]) -> Vec<MorphTarget> {
        self.morphs
            .iter()
            .map(|m| {
                m.remapped(origins).unwrap_or_else(|| MorphTarget {
                    name: m.name.clone(),
                    rest_weight: m.rest_weight,
                    ..Default::default()
                })
            })
            .collect()
    }

    /// Axis-aligned bounds of the bind-space vertices, `(min, max)`.
    pub fn bind_bounds(&self) -> (Vec3, Vec3) {
        bounds(self.vertices.iter().map(|v| v.position))
    }

    /// Turns the whole character, every pose of every clip, by `radians` about the vertical
    /// (+y) axis through the origin; see [`Character::move_rigidly`].
    pub fn turn_about_vertical(&mut self, radians: f32) {
        self.move_rigidly(Quat::from_rotation_y(radians), Vec3::ZERO);
    }

    /// Moves the whole character, every pose of every clip, rigidly: each world position `p`
    /// becomes `R p + t`. Bind-space vertices and normals move with it, each inverse bind
    /// matrix gets `M⁻¹` on its right (joint-local coordinates stay), and the top-level
    /// nodes' rest transforms and animation channels get `M` on their left
    /// (`M · T(a) · Q · S = T(R a + t) · (R Q) · S`, so scales, even non-uniform, stay as
    /// they are). Clips' in-place velocities turn with `R`.
    pub fn move_rigidly(&mut self, r: Quat, t: Vec3) {
        // (T(t) R)⁻¹ = R⁻¹ T(−t).
        let inverse = Mat4::from_quat(r.inverse()) * Mat4::from_translation(-t);
        for v in &mut self.vertices {
            v.position = r * v.position + t;
            v.normal = r * v.normal;
        }
        for m in &mut self.morphs {
            m.positions
                .iter_mut()
                .chain(m.normals.iter_mut())
                .for_each(|d| *d = r * *d);
        }
        for b in &mut self.bones {
            b.inverse_bind *= inverse;
        }
        let roots: Vec<bool> = self.skeleton.nodes.iter().map(|n| n.parent.is_none()).collect();
        for (node, _) in self.skeleton.nodes.iter_mut().zip(&roots).filter(|(_, r)| **r) {
            node.rest.translation = r * node.rest.translation + t;
            node.rest.rotation = r * node.rest.rotation;
        }
        for clip in &mut self.clips {
            clip.in_place_velocity = r * clip.in_place_velocity;
            for ch in clip
                .channels
                .iter_mut()
                .filter(|c| roots.get(c.node).copied().unwrap_or(false))
            {
                // Cubic-spline tangents (each key's first and third value) are rates: they
                // turn but do not move.
                let cubic = ch.interpolation == Interpolation::CubicSpline;
                let is_value = |k: usize| !cubic || k % 3 == 1;
                match &mut ch.values {
                    ChannelValues::Translation(v) => v.iter_mut().enumerate().for_each(|(k, a)| {
                        *a = r * *a + if is_value(k) { t } else { Vec3::ZERO };
                    }),
                    ChannelValues::Rotation(v) => v.iter_mut().for_each(|q| *q = r * *q),
                    ChannelValues::Scale(_) => {}
                }
            }
        }
    }
}

/// Axis-aligned bounds of points, `(min, max)`; zero-size at the origin for no points.
pub fn bounds(points: impl IntoIterator<Item = Vec3>) -> (Vec3, Vec3) {
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for p in points {
        min = min.min(p);
        max = max.max(p);
    }
    if min.x > max.x {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (min, max)
    }
}

/// Which axis of the file points up. glTF says +y, and every file that follows it needs
/// nothing; a file exported from a Z-up tool without conversion lies on its back (or its
/// front), and the artist says so once: the project stores it, a bake records it in the
/// pack, and every later import of that file reads it the same way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum UpAxis {
    /// +y, glTF's own (the default).
    #[default]
    #[serde(rename = "+y", alias = "y")]
    PosY,
    /// -y: the file is upside down.
    #[serde(rename = "-y")]
    NegY,
    /// +z: a Z-up export left unconverted.
    #[serde(rename = "+z", alias = "z")]
    PosZ,
    /// -z.
    #[serde(rename = "-z")]
    NegZ,
    /// +x.
    #[serde(rename = "+x", alias = "x")]
    PosX,
    /// -x.
    #[serde(rename = "-x")]
    NegX,
}

impl UpAxis {
    /// Every axis, glTF's own first.
    pub const ALL: [UpAxis; 6] = [
        UpAxis::PosY,
        UpAxis::PosZ,
        UpAxis::NegZ,
        UpAxis::PosX,
        UpAxis::NegX,
        UpAxis::NegY,
    ];

    /// glTF's own, +y (for `skip_serializing_if`).
    pub fn is_default(&self) -> bool {
        *self == UpAxis::PosY
    }

    /// The axis as written in projects, manifests and on the command line (`+z`).
    pub fn name(self) -> &'static str {
        match self {
            UpAxis::PosY => "+y",
            UpAxis::NegY => "-y",
            UpAxis::PosZ => "+z",
            UpAxis::NegZ => "-z",
            UpAxis::PosX => "+x",
            UpAxis::NegX => "-x",
        }
    }

    /// Reads `+z`, `z`, `-x`, … (case-insensitive).
    pub fn parse(text: &str) -> Option<UpAxis> {
        let t = text.trim().to_ascii_lowercase();
        let t = t.strip_prefix('+').unwrap_or(&t);
        Some(match t {
            "y" => UpAxis::PosY,
            "-y" => UpAxis::NegY,
            "z" => UpAxis::PosZ,
            "-z" => UpAxis::NegZ,
            "x" => UpAxis::PosX,
            "-x" => UpAxis::NegX,
            _ => return None,
        })
    }

    /// The file's up direction.
    pub fn direction(self) -> Vec3 {
        match self {
            UpAxis::PosY => Vec3::Y,
            UpAxis::NegY => Vec3::NEG_Y,
            UpAxis::PosZ => Vec3::Z,
            UpAxis::NegZ => Vec3::NEG_Z,
            UpAxis::PosX => Vec3::X,
            UpAxis::NegX => Vec3::NEG_X,
        }
    }

    /// The turn that stands the file up: its up direction onto +y, about the horizontal
    /// axis at right angles to both (upside down: half a turn about x). Which way the
    /// character then faces is settled as for any file (walkers are turned to face +z).
    pub fn rotation(self) -> Quat {
        match self {
            UpAxis::NegY => Quat::from_rotation_x(std::f32::consts::PI),
            a => Quat::from_rotation_arc(a.direction(), Vec3::Y),
        }
    }
}

impl std::fmt::Display for UpAxis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Welded vertex ids: vertices at the same bind-space position (split only by their
/// attributes, as at UV seams) share one id.
pub fn weld(c: &Character) -> Vec<u32> {
    weld_points(c.vertices.iter().map(|v| v.position))
}

/// Welded ids of `points`: points at the same place (to a 100,000th of their extent) share one.
pub fn weld_points(points: impl Iterator<Item = Vec3> + Clone) -> Vec<u32> {
    let (min, max) = bounds(points.clone());
    let scale = 1e5 / (max - min).max_element().max(1e-6);
    let mut ids: std::collections::HashMap<(i64, i64, i64), u32> = std::collections::HashMap::new();
    points
        .map(|p| {
            let q = ((p - min) * scale).round();
            let key = (q.x as i64, q.y as i64, q.z as i64);
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        })
        .collect()
}

/// No triangle across an edge ([`triangle_neighbours`]).
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// For each triangle of `indices`, the triangles sharing its edges `k → k + 1`, vertices
/// compared by their `welded` ids ([`weld`]: UV seams joined): [`NO_NEIGHBOUR`] where an edge
/// is open; a non-manifold edge links its first two.
pub fn triangle_neighbours(indices: &[u32], welded: &[u32]) -> Vec<[u32; 3]> {
    let tris = indices.len() / 3;
    let w = |i: u32| welded.get(i as usize).copied().unwrap_or(i);
    // Edges (welded, ordered) -> the triangles on them.
    let mut edges: std::collections::HashMap<(u32, u32), [u32; 2]> =
        std::collections::HashMap::with_capacity(tris * 3 / 2);
    for t in 0..tris {
        for k in 0..3 {
            let (a, b) = (w(indices[3 * t + k]), w(indices[3 * t + (k + 1) % 3]));
            if a == b {
                continue;
            }
            let e = edges
                .entry((a.min(b), a.max(b)))
                .or_insert([NO_NEIGHBOUR, NO_NEIGHBOUR]);
            if e[0] == NO_NEIGHBOUR {
                e[0] = t as u32;
            } else if e[1] == NO_NEIGHBOUR && e[0] != t as u32 {
                e[1] = t as u32;
            }
        }
    }
    let mut neighbours = vec![[NO_NEIGHBOUR; 3]; tris];
    for (t, n) in neighbours.iter_mut().enumerate() {
        for (k, slot) in n.iter_mut().enumerate() {
            let (a, b) = (w(indices[3 * t + k]), w(indices[3 * t + (k + 1) % 3]));
            if let Some(e) = edges.get(&(a.min(b), a.max(b))) {
                let other = if e[0] == t as u32 { e[1] } else { e[0] };
                if other != t as u32 {
                    *slot = other;
                }
            }
        }
    }
    neighbours
}

#[cfg(test)]
mod bone_tests {
    use crate::animation::{Pose, skin_vertices};

    /// Bones no vertex is weighted to (IK targets, controls), one of them first so that every
    /// used bone is renumbered: dropped, the mesh skins exactly as before at every sampled
    /// time of every clip, and the skinned crowd's memory is the plain character's.
    #[test]
    fn unused_bones_are_dropped_and_the_skinning_stays() {
        let plain = crate::default_character::generate();
        assert!(plain.without_unused_bones().is_none(), "the default uses every bone");
        let mut rigged = plain.clone();
        let extra = |node: usize| super::Bone {
            node,
            inverse_bind: glam::Mat4::from_translation(glam::Vec3::new(0.3, 0.0, 0.1)),
        };
        rigged.bones.insert(0, extra(0));
        rigged.bones.push(extra(1));
        rigged.bones.push(extra(2));
        for v in &mut rigged.vertices {
            for k in 0..4 {
                if v.weights[k] > 0.0 {
                    v.bones[k] += 1;
                }
            }
        }
        assert_eq!(rigged.used_bone_count(), plain.bones.len());
        let pruned = rigged.without_unused_bones().expect("three unused bones");
        assert_eq!(pruned.bones.len(), plain.bones.len());
        for (ci, clip) in rigged.clips.iter().enumerate() {
            for k in 0..5 {
                let t = clip.duration_secs * k as f32 / 5.0;
                let (a, na) = skin_vertices(&rigged, &Pose::sample(&rigged, clip, t));
                let (b, nb) = skin_vertices(&pruned, &Pose::sample(&pruned, &pruned.clips[ci], t));
                let (c, _) = skin_vertices(&plain, &Pose::sample(&plain, &plain.clips[ci], t));
                assert_eq!(a, b, "{} at {t}", clip.name);
                assert_eq!(na, nb);
                assert_eq!(b, c);
            }
        }
        assert_eq!(
            crate::reps::skinned_bytes(&rigged, 40).geometry,
            crate::reps::skinned_bytes(&plain, 40).geometry
        );
    }
}
