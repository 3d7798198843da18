//! Copying render targets back to the CPU.

use super::GpuError;

/// A depth image (wgpu's 0..1 range, 1 = far).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` depth values, row by row from the top, each in 0..1 (1 = far,
    /// what a [`super::RenderTarget`] clears depth to).
    pub data: Vec<f32>,
}

/// Most bytes one read-back buffer holds: a large image is copied back in bands of rows
/// (the device's buffer limit, often 256 MiB, is an 8192² RGBA image).
const READBACK_BAND_BYTES: u64 = 64 << 20;

fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    aspect: wgpu::TextureAspect,
    bytes_per_px: u32,
) -> Result<Vec<u8>, GpuError> {
    read_texture_in_bands(device, queue, texture, aspect, bytes_per_px, READBACK_BAND_BYTES)
}

fn read_texture_in_bands(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    aspect: wgpu::TextureAspect,
    bytes_per_px: u32,
    band_bytes: u64,
) -> Result<Vec<u8>, GpuError> {
    let (w, h) = (texture.width(), texture.height());
    let unpadded = u64::from(w) * u64::from(bytes_per_px);
    let align = u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let padded = unpadded.div_ceil(align) * align;
    let most = band_bytes.min(device.limits().max_buffer_size).max(padded);
    // Depth can only be copied whole (WebGPU): one band.
    let band = if aspect == wgpu::TextureAspect::DepthOnly {
        u64::from(h)
    } else {
        (most / padded).clamp(1, u64::from(h.max(1)))
    };
    if padded * band > device.limits().max_buffer_size {
        return Err(GpuError::Readback(format!(
            "a {w}×{h} image is more than this device can copy back at once ({} bytes at most)",
            device.limits().max_buffer_size
        )));
    }
    let mut out = Vec::with_capacity((unpadded * u64::from(h)) as usize);
    let mut y0 = 0u32;
    while y0 < h {
        let rows = (band as u32).min(h - y0);
        read_band(device, queue, texture, aspect, y0, rows, padded, unpadded, &mut out)?;
        y0 += rows;
    }
    Ok(out)
}

/// Copies rows `y0 .. y0 + rows` of `texture` back, appending them (unpadded) to `out`.
#[allow(clippy::too_many_arguments)]
fn read_band(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    aspect: wgpu::TextureAspect,
    y0: u32,
    rows: u32,
    padded: u64,
    unpadded: u64,
    out: &mut Vec<u8>,
) -> Result<(), GpuError> {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded * u64::from(rows),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("readback"),
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: 0, y: y0, z: 0 },
            aspect,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded as u32),
                rows_per_image: None,
            },
        },
        wgpu::Extent3d {
            width: texture.width(),
            height: rows,
            depth_or_array_layers: 1,
        },
    );
    let index = queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| drop(tx.send(r)));
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: Some(std::time::Duration::from_secs(60)),
        })
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let mapped = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Readback(format!("{e:?}")))?;
    for row in mapped.chunks_exact(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    drop(mapped);
    buffer.unmap();
    Ok(())
}

/// Reads an RGBA8 texture (any 4-byte 8-bit format) into an image, rows top to bottom.
pub fn read_rgba8(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<image::RgbaImage, GpuError> {
    let bytes = read_texture(device, queue, texture, wgpu::TextureAspect::All, 4)?;
    image::RgbaImage::from_raw(texture.width(), texture.height(), bytes)
        .ok_or_else(|| GpuError::Readback("size mismatch".into()))
}

/// Reads a `Depth32Float` texture (with `TEXTURE_BINDING` usage where the backend is OpenGL,
/// which cannot copy depth to a buffer: there [`read_depth_via_shader`] reads it).
pub fn read_depth(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) -> Result<DepthImage, GpuError> {
    if device.adapter_info().backend == wgpu::Backend::Gl {
        return read_depth_via_shader(device, queue, texture);
    }
    let bytes = read_texture(device, queue, texture, wgpu::TextureAspect::DepthOnly, 4)?;
    Ok(depth_image(texture, &bytes))
}

/// Reads a `Depth32Float` texture (with `TEXTURE_BINDING` usage) on any backend, bit for bit:
/// `depth_bytes.wgsl` writes each value's bits into an RGBA8 image, which is copied back.
pub fn read_depth_via_shader(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<DepthImage, GpuError> {
    let bytes = depth_bytes_via_shader(device, queue, texture)?;
    Ok(depth_image(texture, &bytes))
}

fn depth_image(texture: &wgpu::Texture, bytes: &[u8]) -> DepthImage {
    let data = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    DepthImage {
        width: texture.width(),
        height: texture.height(),
        data,
    }
}

/// The raw little-endian bytes of a depth texture, drawn by `depth_bytes.wgsl` into an RGBA8
/// image (one texel per depth value) and read back from that.
fn depth_bytes_via_shader(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<Vec<u8>, GpuError> {
    const BYTES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("depth_bytes.wgsl"),
        source: wgpu::ShaderSource::Wgsl(super::shaders::DEPTH_BYTES.into()),
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("depth bytes"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("depth bytes"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = super::fullscreen_pipeline(
        device,
        "depth bytes",
        &pipeline_layout,
        &module,
        "fs_main",
        BYTES_FORMAT,
    );
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        aspect: wgpu::TextureAspect::DepthOnly,
        ..Default::default()
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("depth bytes"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&view),
        }],
    });
    let bytes = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("depth bytes"),
        size: texture.size(),
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: BYTES_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("depth bytes"),
    });
    {
        let target = bytes.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("depth bytes"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }
    queue.submit([encoder.finish()]);
    read_texture(device, queue, &bytes, wgpu::TextureAspect::All, 4)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An image read back in bands of a few rows (as an image over the device's buffer limit
    /// is: `render --size 9000` panicked on one 400 MB buffer) gives every texel, in order.
    #[test]
    fn a_texture_read_in_bands_is_the_texture() {
        let ctx = crate::gpu::GpuContext::new(&crate::gpu::AdapterPreference::SoftwareFirst)
            .expect("a wgpu adapter (install mesa-vulkan-drivers)");
        let (w, h) = (37u32, 50u32);
        let texels: Vec<u8> = (0..w * h * 4)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("banded"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        ctx.queue.write_texture(
            texture.as_image_copy(),
            &texels,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 4),
                rows_per_image: None,
            },
            texture.size(),
        );
        // One padded row is 256 bytes: bands of 1, 3 and 7 rows (the last one short), and all.
        for band in [1u64, 3, 7, 1000] {
            let got = read_texture_in_bands(
                &ctx.device,
                &ctx.queue,
                &texture,
                wgpu::TextureAspect::All,
                4,
                256 * band,
            )
            .unwrap();
            assert_eq!(got, texels, "bands of {band} rows");
        }
    }
}
