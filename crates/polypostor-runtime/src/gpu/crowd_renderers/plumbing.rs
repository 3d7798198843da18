//! The crowd renderers' shared plumbing: storage and uniform buffers, bind group layouts
//! and pipelines, texture arrays (BC blocks or RGBA), the growing instance buffer.

use super::*;

/// Snorm8×4 packing of a unit normal (as WGSL's `pack4x8snorm`).
pub(super) fn pack_normal(n: [f32; 3]) -> u32 {
    let b = |x: f32| ((x.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8 as u32;
    b(n[0]) | b(n[1]) << 8 | b(n[2]) << 16
}

/// Per frame per vertex: position bits and packed normal (`vec4<u32>` in WGSL).
pub(super) fn packed_frames(v: &FrameVertices) -> Vec<[u32; 4]> {
    v.positions
        .iter()
        .zip(&v.normals)
        .map(|(p, n)| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits(), pack_normal(*n)])
        .collect()
}

pub(super) fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    // Never bind an empty buffer.
    let pad = [0u8; 16];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if bytes.is_empty() { &pad } else { bytes },
        usage: wgpu::BufferUsages::STORAGE,
    })
}

pub(in crate::gpu) fn uniform_buffer(device: &wgpu::Device, label: &str) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: std::mem::size_of::<CrowdUniform>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

pub(in crate::gpu) enum Entry {
    Uniform,
    Storage,
    TextureArray,
    Sampler,
}

pub(in crate::gpu) fn layout(device: &wgpu::Device, label: &str, entries: &[Entry]) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = entries
        .iter()
        .enumerate()
        .map(|(i, e)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: match e {
                Entry::Uniform => wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                Entry::Storage => wgpu::ShaderStages::VERTEX,
                Entry::TextureArray | Entry::Sampler => wgpu::ShaderStages::FRAGMENT,
            },
            ty: match e {
                Entry::Uniform => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                Entry::Storage => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                Entry::TextureArray => wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                Entry::Sampler => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

pub(in crate::gpu) enum Resource<'a> {
    Buffer(&'a wgpu::Buffer),
    View(&'a wgpu::TextureView),
    Sampler(&'a wgpu::Sampler),
}

pub(in crate::gpu) fn bind(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[Resource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: match r {
                Resource::Buffer(b) => b.as_entire_binding(),
                Resource::View(v) => wgpu::BindingResource::TextureView(v),
                Resource::Sampler(s) => wgpu::BindingResource::Sampler(s),
            },
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

pub(in crate::gpu) fn pipeline(
    device: &wgpu::Device,
    label: &str,
    layouts: &[&wgpu::BindGroupLayout],
    source: &str,
    vertex_entry: &str,
    buffers: &[Option<wgpu::VertexBufferLayout>],
) -> wgpu::RenderPipeline {
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let targets = opaque_targets();
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vertex_entry),
            buffers,
            compilation_options: Default::default(),
        },
        primitive: wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(depth_less()),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            targets: &targets,
            compilation_options: Default::default(),
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A linear-filtered, clamped sampler.
pub(in crate::gpu) fn clamp_sampler(device: &wgpu::Device, label: &str) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}

/// One layer per image (all the same size), uploaded. Returns the view and the bytes held.
pub(super) fn texture_array(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    images: &[image::RgbaImage],
    format: wgpu::TextureFormat,
    blocks: &[crate::texture::CompressedImage],
) -> Result<(wgpu::TextureView, u64), GpuError> {
    let (w, h) = images.first().map_or((1, 1), |i| i.dimensions());
    // The BC7 blocks as they are where every layer has them and the device samples BC7.
    let bc = crate::gpu::upload::samples_bc(device)
        && !blocks.is_empty()
        && blocks.len() == images.len()
        && blocks.iter().all(|b| [b.width, b.height] == [w, h]);
    let format = match blocks.first() {
        Some(b) if bc => b.format.wgpu_format(),
        _ => format,
    };
    let limits = device.limits();
    if images.len() as u32 > limits.max_texture_array_layers || w.max(h) > limits.max_texture_dimension_2d {
        return Err(GpuError::Unsupported(format!(
            "{label}: {} layers of {w}×{h} exceed this GPU's texture limits ({} layers, {} pixels)",
            images.len(),
            limits.max_texture_array_layers,
            limits.max_texture_dimension_2d
        )));
    }
    let texture = crate::gpu::upload::array_texture(device, label, (w, h), images.len() as u32, format);
    for (layer, img) in images.iter().enumerate() {
        if img.dimensions() != (w, h) {
            return Err(GpuError::Unsupported(format!(
                "{label}: layer {layer} has another size"
            )));
        }
        let origin = wgpu::Origin3d {
            x: 0,
            y: 0,
            z: layer as u32,
        };
        crate::gpu::upload::write_image(queue, &texture, origin, img, blocks.get(layer), bc);
    }
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let texel_bytes = crate::gpu::upload::texel_bytes(bc);
    Ok((view, texel_bytes * w as u64 * h as u64 * images.len() as u64))
}

/// One R8 layer per image holding the image's alpha (the impostors' part numbers), for
/// `textureLoad`. Returns the view and the bytes held.
pub(super) fn part_array(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    images: &[image::RgbaImage],
) -> Result<(wgpu::TextureView, u64), GpuError> {
    let (w, h) = images.first().map_or((1, 1), |i| i.dimensions());
    let limits = device.limits();
    if images.len() as u32 > limits.max_texture_array_layers || w.max(h) > limits.max_texture_dimension_2d {
        return Err(GpuError::Unsupported(format!(
            "{label}: {} layers of {w}×{h} exceed this GPU's texture limits",
            images.len()
        )));
    }
    let format = wgpu::TextureFormat::R8Unorm;
    let texture = crate::gpu::upload::array_texture(device, label, (w, h), images.len() as u32, format);
    for (layer, img) in images.iter().enumerate() {
        if img.dimensions() != (w, h) {
            return Err(GpuError::Unsupported(format!(
                "{label}: layer {layer} has another size"
            )));
        }
        let alpha: Vec<u8> = img.pixels().map(|p| p[3]).collect();
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: layer as u32,
                },
                aspect: wgpu::TextureAspect::All,
            },
            &alpha,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w),
                rows_per_image: Some(h),
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
    }
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    Ok((view, w as u64 * h as u64 * images.len() as u64))
}

/// How many layers to give a 2D texture array of `w`×`h` that holds `count` images. The
/// OpenGL backend guesses a texture's kind from its shape when it is created (one layer: a
/// plain 2D texture; square with a multiple of six: a cube map) and then cannot view it as an
/// array; there the array gets one or two unused layers so that it is one.
pub(crate) fn array_layers(device: &wgpu::Device, w: u32, h: u32, count: u32) -> u32 {
    layers_for(device.adapter_info().backend, w, h, count)
}

pub(super) fn layers_for(backend: wgpu::Backend, w: u32, h: u32, count: u32) -> u32 {
    let count = count.max(1);
    if backend != wgpu::Backend::Gl {
        return count;
    }
    let layers = count.max(2);
    if w == h && layers % 6 == 0 { layers + 1 } else { layers }
}

/// A growable storage buffer of instances.
pub(super) struct InstanceBuffer {
    pub(super) buffer: wgpu::Buffer,
    pub(super) capacity: usize,
}

impl InstanceBuffer {
    pub(super) fn new(device: &wgpu::Device, capacity: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            buffer: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("crowd instances"),
                size: (capacity * std::mem::size_of::<Instance>()) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            capacity,
        }
    }

    /// Uploads `data`; true when the buffer had to grow (bind groups must be rebuilt).
    pub(super) fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[Instance]) -> bool {
        let grew = data.len() > self.capacity;
        if grew {
            *self = Self::new(device, data.len().next_power_of_two());
        }
        if !data.is_empty() {
            queue.write_buffer(&self.buffer, 0, bytemuck::cast_slice(data));
        }
        grew
    }
}
