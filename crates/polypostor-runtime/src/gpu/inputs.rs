//! What the renderers draw from: plain, GPU-ready data with no file format in it. The run
//! time's loaders turn what they read into these (`LoadedPack::gpu_input`,
//! `Representations::view_frames`, `scene::crowd_inputs`); an engine with data of its own can
//! fill them directly.
//!
//! - [`ViewFrame`]: where a baked view's images lie in the world.
//! - [`PolypostorInput`]: a Polypostor pack's geometry, per-view part tables and atlases.
//! - [`ImpostorData`], [`Np3dData`], [`FrameVertices`]: the other representations' data.
//! - [`CrowdInputs`]: everything one character's crowd renderers draw.

use std::borrow::Cow;

use crate::texture::CompressedImage;

/// A baked view's orthographic frame: the world point at the middle of its images, the
/// world directions of their +x and +y axes and of the camera, and half the frame's side in
/// world units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewFrame {
    /// World point at the middle of the view's images.
    pub center: [f32; 3],
    /// Unit world direction of the images' +x axis.
    pub right: [f32; 3],
    /// Unit world direction of the images' +y axis.
    pub up: [f32; 3],
    /// Unit world direction towards the camera.
    pub forward: [f32; 3],
    /// Half the side of the view frame in world units (±1 on the images).
    pub half_size: f32,
}

/// One key image's block of a part: its polygon's vertices and triangles, and the frames it
/// serves.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KeyBlock {
    /// First value of the block in [`PolypostorInput::vertices`].
    pub vertex_offset: u64,
    /// Vertices of the polygon (the block holds their atlas UVs, then their view-plane
    /// positions at every frame the key serves).
    pub vertex_count: u32,
    /// First index of the key's triangles in [`PolypostorInput::indices`].
    pub index_offset: u64,
    /// Indices of the key's triangles (three per triangle, local to the block).
    pub index_count: u32,
    /// First index of the key's coarse triangles (the polygon simplified to about half its
    /// vertices, for characters small on screen) in [`PolypostorInput::indices`].
    pub coarse_index_offset: u64,
    /// Indices of the coarse triangles; 0: none (the renderer thins the polygon itself).
    pub coarse_index_count: u32,
    /// First frame the block holds positions for.
    pub frame_start: u32,
    /// Frames the block holds positions for.
    pub frame_count: u32,
}

/// A part as one view draws it: its key images' blocks (the first serves every frame) and,
/// with several keys, which key draws each frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolypostorPart<'a> {
    /// The first key's block, then the extra keys'.
    pub keys: Vec<KeyBlock>,
    /// Per frame, the key (index into `keys`) that draws it; empty with one key.
    pub frame_keys: &'a [u8],
}

/// One view of a Polypostor pack.
#[derive(Clone, Debug)]
pub struct PolypostorView<'a> {
    /// Where the view's images lie.
    pub frame: ViewFrame,
    /// Colour atlas size in texels; the normal atlas is half of it each way.
    pub atlas_size: [u32; 2],
    /// Parts in drawing order, back to front (indices into `parts`).
    pub order: &'a [u32],
    /// Per part; `None` where the part is not drawn in this view.
    pub parts: Vec<Option<PolypostorPart<'a>>>,
    /// The colour atlas (sRGB, coverage in alpha), and its BC7 blocks where there are.
    pub atlas: &'a image::RgbaImage,
    /// The colour atlas's BC7 blocks, uploaded as they are where the device samples BC7.
    pub atlas_blocks: Option<&'a CompressedImage>,
    /// The normal atlas (linear).
    pub normals: &'a image::RgbaImage,
    /// The normal atlas's BC7 blocks.
    pub normal_blocks: Option<&'a CompressedImage>,
}

/// A Polypostor pack as the renderer draws it.
#[derive(Clone, Debug)]
pub struct PolypostorInput<'a> {
    /// Parts of the character (every view's `parts` has this many entries).
    pub part_count: usize,
    /// Frames of the timeline.
    pub frames: u32,
    /// Vertex values in [0, 1] (stored as u16 on the GPU).
    pub vertices: &'a [f32],
    /// Triangle indices, local to each key's block.
    pub indices: &'a [u16],
    /// The views.
    pub views: Vec<PolypostorView<'a>>,
}

/// Per-frame vertex data of a mesh (frame-major: frame `f`, vertex `v` at `f·count + v`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameVertices {
    /// Vertices of the mesh in each frame.
    pub vertex_count: usize,
    /// Every vertex's skinned position at every frame, in the character's space (as the
    /// bake posed it).
    pub positions: Vec<[f32; 3]>,
    /// Every vertex's skinned normal at every frame, laid out as `positions`.
    pub normals: Vec<[f32; 3]>,
}

/// Classic impostor sheets, one colour and one normal image per view.
#[derive(Clone, Debug)]
pub struct ImpostorData {
    /// Tiles per row of each sheet.
    pub columns: u32,
    /// Rows of tiles of each sheet.
    pub rows: u32,
    /// One colour sheet per view (RGBA8, coverage in alpha), in the manifest's view order.
    pub color: Vec<image::RgbaImage>,
    /// One normal sheet per view: the normal in RGB (each component `(n + 1) × 127.5`) and
    /// the texel's body part number in alpha.
    pub normal: Vec<image::RgbaImage>,
    /// The colour sheets' BC7 blocks, one per view, when the folder stores them so
    /// (`.ktx2`; empty otherwise): what a renderer uploads where the adapter samples BC7.
    pub color_blocks: Vec<crate::texture::CompressedImage>,
    /// The normal sheets' BC7 blocks (normals only, stored opaque), one per view, when the
    /// folder stores them so; the part numbers then come from lossless `impostor_part_NNN.png`
    /// files and sit in [`ImpostorData::normal`]'s alpha as always.
    pub normal_blocks: Vec<crate::texture::CompressedImage>,
}

/// The simplified mesh at every frame and the per-view key-frame images.
#[derive(Clone, Debug)]
pub struct Np3dData {
    /// The simplified mesh's triangles, three u16 vertex numbers each (below
    /// `frames.vertex_count`).
    pub indices: Vec<u16>,
    /// The character vertex each simplified vertex is.
    pub source: Vec<u32>,
    /// The simplified mesh's positions and normals at every frame.
    pub frames: FrameVertices,
    /// One `resolution²` colour image per view (the key frame).
    pub images: Vec<image::RgbaImage>,
    /// The images' BC7 blocks, one per view, when the folder stores them so
    /// (`np3d_color.ktx2`; empty otherwise).
    pub image_blocks: Vec<CompressedImage>,
}

/// Every representation one character's crowd renderers draw ([`super::CrowdRenderers::new`]):
/// meshes always, the others where given.
#[derive(Clone, Debug)]
pub struct CrowdInputs<'a> {
    /// The timeline's frames and rate the instances index into.
    pub timing: crate::records::ClipTiming,
    /// The Polypostor pack.
    pub polypostor: Option<PolypostorInput<'a>>,
    /// The image-based representations' views (impostors, NP3D).
    pub views: Vec<ViewFrame>,
    /// The frame NP3D's images were taken at.
    pub key_frame: u32,
    /// Rigid meshes: the character pre-skinned at every frame.
    pub rigid: Option<&'a FrameVertices>,
    /// Full-resolution impostor sheets (the impostor level on its own).
    pub impostor: Option<&'a ImpostorData>,
    /// The sheets the mix draws its far characters with, and per frame of the timeline the
    /// tile that holds it (`None`: every frame has its tile).
    pub far_impostor: Option<(Cow<'a, ImpostorData>, Option<Vec<u32>>)>,
    /// NP3D impostors.
    pub np3d: Option<&'a Np3dData>,
}

impl CrowdInputs<'_> {
    /// Meshes only, at `timing`.
    pub fn meshes(timing: crate::records::ClipTiming) -> Self {
        Self {
            timing,
            polypostor: None,
            views: Vec::new(),
            key_frame: 0,
            rigid: None,
            impostor: None,
            far_impostor: None,
            np3d: None,
        }
    }
}
