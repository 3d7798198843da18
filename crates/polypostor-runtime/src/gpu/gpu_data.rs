//! `#[repr(C)]` structs shared with the shaders. Keep each in sync with the WGSL named.

use bytemuck::{Pod, Zeroable};

/// Bones per draw (`MAX_BONES` in `character.wgsl`).
pub const MAX_BONES: usize = 256;

/// `FrameUniforms` in `character.wgsl` and `grid.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub clip_from_world: [[f32; 4]; 4],
    pub view_from_world: [[f32; 4]; 4],
    pub light_dir_view: [f32; 4],
    /// x: shading (0 unlit, 1 lit), y: ambient, z: rim strength.
    pub params: [f32; 4],
}

/// `Bones` in `character.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct Bones {
    pub m: [[[f32; 4]; 4]; MAX_BONES],
}

/// `MaterialUniforms` in `character.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MaterialUniforms {
    pub base_color_factor: [f32; 4],
}

/// Vertex stream 0 (rewritten each frame when skinning on the CPU).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PositionNormal {
    pub position: [f32; 3],
    pub normal: [f32; 3],
}

/// Vertex stream 1 (static).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Attributes {
    pub uv: [f32; 2],
    pub color: [f32; 4],
    pub bones: [u16; 4],
    pub weights: [f32; 4],
}
