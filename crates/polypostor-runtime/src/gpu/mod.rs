//! GPU rendering core, usable headless and inside the editor.
//!
//! - [`GpuContext`]: adapter selection (hardware first, then Vulkan lavapipe, then GL
//!   llvmpipe), naming the adapter it uses.
//! - [`Camera`]: orthographic and perspective cameras.
//! - [`CharacterRenderer`] / [`GpuCharacter`]: a skinned character drawn with GPU skinning
//!   (`shaders/character.wgsl`) into a [`RenderTarget`] of colour, view-space normal and depth,
//!   with readback to CPU images.
//! - [`shaders`]: every WGSL source of `shaders/`, embedded, for pipelines and validation.

mod camera;
pub mod character_renderer;
mod context;
mod crowd_renderers;
pub mod gpu_data;
pub mod inputs;
mod polypostor_renderer;
mod readback;
pub mod shaders;
mod upload;

pub use camera::{Camera, Projection};
pub use character_renderer::{
    COLOR_FORMAT, CharacterRenderer, DEPTH_FORMAT, DrawOptions, GpuCharacter, NORMAL_FORMAT, RenderTarget, Shading,
    SkinningMode, fullscreen_pipeline, grid_cell, view_formats_supported,
};
pub use context::{AdapterPreference, GpuContext, GpuError, OPTIONAL_FEATURES, optional_features, rank_adapter};
pub use crowd_renderers::{
    CrowdRenderers, FAR_IMPOSTOR_FACTOR, GpuImpostors, GpuMeshCrowd, GpuNp3d, JOINT_SAMPLES_PER_FRAME, joint_samples,
    vertex_parts,
};
pub use polypostor_renderer::{GpuPolypostors, PolypostorStyle};
pub use readback::{DepthImage, read_depth, read_depth_via_shader, read_rgba8};
