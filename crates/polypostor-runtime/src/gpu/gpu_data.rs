//! `#[repr(C)]` structs shared with the shaders. Keep each in sync with the WGSL named.

use bytemuck::{Pod, Zeroable};

/// Bones per draw (`MAX_BONES` in `character.wgsl`).
pub const MAX_BONES: usize = 256;

/// `FrameUniforms` in `character.wgsl` and `grid.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    /// Clip-space-from-world matrix (view, then projection with wgpu's 0..1 depth), column-major.
    pub clip_from_world: [[f32; 4]; 4],
    /// View-space-from-world matrix of the camera (right-handed, looking down -Z), column-major:
    /// turns normals into view space for the normal target.
    pub view_from_world: [[f32; 4]; 4],
    /// xyz: unit direction towards the light, in view space; w unused (0).
    pub light_dir_view: [f32; 4],
    /// x: shading (0 unlit, 1 lit), y: ambient, z: rim strength.
    pub params: [f32; 4],
}

/// `Bones` in `character.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct Bones {
    /// Per bone, its skinning matrix from bind space to world space
    /// (`world_from_node[bone.node] * inverse_bind`, [`crate::animation::Pose::skin_from_bind`]),
    /// column-major; identity past the pose's bones.
    pub m: [[[f32; 4]; 4]; MAX_BONES],
}

/// `MaterialUniforms` in `character.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MaterialUniforms {
    /// Linear RGBA multiplier of the base-colour texture and the vertex colour.
    pub base_color_factor: [f32; 4],
    /// x: alpha cut-off ([`crate::character::Material::alpha_cutoff`]; 0 draws every
    /// fragment); y, z, w unused.
    pub params: [f32; 4],
}

/// Vertex stream 0 (rewritten each frame when skinning on the CPU).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PositionNormal {
    /// Position in bind space (GPU skinning), or already skinned into world space (CPU skinning).
    pub position: [f32; 3],
    /// Unit normal, in the same space as `position`.
    pub normal: [f32; 3],
}

/// Vertex stream 1 (static).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Attributes {
    /// Texture coordinate of the base-colour texture.
    pub uv: [f32; 2],
    /// Linear RGBA vertex colour (white when the file has none).
    pub color: [f32; 4],
    /// Indices of the four bones that move this vertex, into [`Bones::m`] (read as `Uint16x4`;
    /// the shader clamps them below [`MAX_BONES`]).
    pub bones: [u16; 4],
    /// Weights of `bones`, summing to one.
    pub weights: [f32; 4],
}

/// Static bytes of a character mesh on the GPU: its base-colour textures (RGBA8 with mips,
/// ×4/3) and its vertex attributes (UV, colour, joints, weights: 40 bytes a vertex) with u32
/// indices, as `(texture, geometry)`.
pub fn mesh_static_bytes(c: &crate::Character) -> (u64, u64) {
    let texture: u64 = c
        .textures
        .iter()
        .map(|t| t.width as u64 * t.height as u64 * 4 * 4 / 3)
        .sum();
    (texture, c.vertices.len() as u64 * 40 + c.indices.len() as u64 * 4)
}
