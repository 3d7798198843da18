//! Uploading one image into a texture: its BC blocks as they are where the device samples
//! block-compressed textures and the image has them, else its RGBA8 pixels (decoded from the
//! blocks at load time). The one rule every renderer follows.

use crate::texture::{BLOCK_BYTES, CompressedImage};

/// Whether `device` samples BC textures (asked for when the adapter has them: see
/// [`super::OPTIONAL_FEATURES`]).
pub(crate) fn samples_bc(device: &wgpu::Device) -> bool {
    device.features().contains(wgpu::Features::TEXTURE_COMPRESSION_BC)
}

/// Bytes the GPU holds per texel: one for BC7 blocks, four for RGBA8.
pub(crate) fn texel_bytes(bc: bool) -> u64 {
    if bc { 1 } else { 4 }
}

/// Writes `img` (or its `blocks` when `bc`) into `texture` at `origin` (texels; whole
/// 4 × 4 blocks for BC).
pub(crate) fn write_image(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    origin: wgpu::Origin3d,
    img: &image::RgbaImage,
    blocks: Option<&CompressedImage>,
    bc: bool,
) {
    let (data, layout): (&[u8], _) = match blocks.filter(|_| bc) {
        Some(b) => (
            &b.blocks,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(b.blocks_per_row() * BLOCK_BYTES as u32),
                rows_per_image: Some(b.height / 4),
            },
        ),
        None => (
            img.as_raw(),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * img.width()),
                rows_per_image: Some(img.height()),
            },
        ),
    };
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin,
            aspect: wgpu::TextureAspect::All,
        },
        data,
        layout,
        wgpu::Extent3d {
            width: img.width(),
            height: img.height(),
            depth_or_array_layers: 1,
        },
    );
}

/// A sampled 2D texture array of `count` images of `w`×`h` (never smaller than 1×1; the
/// layer count as [`super::crowd_renderers::array_layers`] gives it, so every backend views
/// it as an array), written by [`write_image`].
pub(crate) fn array_texture(
    device: &wgpu::Device,
    label: &str,
    (w, h): (u32, u32),
    count: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    let (w, h) = (w.max(1), h.max(1));
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: super::crowd_renderers::array_layers(device, w, h, count),
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}
