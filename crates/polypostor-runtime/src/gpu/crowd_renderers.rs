//! The comparison representations at crowd scale, each drawn with per-instance data in GPU
//! buffers and one instanced draw (per material for meshes):
//!
//! - [`GpuMeshCrowd`]: GPU-skinned meshes (the clip's joints sampled ahead as quaternion +
//!   translation + scale, interpolated per vertex) and rigid meshes (pre-skinned frames,
//!   interpolated) — `shaders/crowd_mesh.wgsl`;
//! - [`GpuImpostors`]: classic animated impostors — `shaders/impostor.wgsl`;
//! - [`GpuNp3d`]: NP3D impostors — `shaders/np3d.wgsl`;
//! - [`CrowdRenderers`]: all of them with the Polypostor renderer, drawing each level's
//!   instances of a [`crate::crowd::Crowd`] in one pass.
//!
//! Every representation reads the same 32-byte [`Instance`] records and the same per-part
//! tint hash, so switching level does not change a character's colours.

use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use super::character_renderer::{depth_less, opaque_targets};
use super::gpu_data::{Attributes, PositionNormal};
use super::{CharacterRenderer, GpuCharacter, GpuError, GpuPolypostors, PolypostorStyle, RenderTarget, shaders};
use crate::animation::Pose;
use crate::character::Character;
use crate::crowd::Instance;
use crate::crowd::lod::Level;
use crate::reps::{FrameVertices, Representations};

/// Per-frame settings (the same layout in every crowd shader: `Frame`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct CrowdUniform {
    clip_from_world: [[f32; 4]; 4],
    light_dir: [f32; 4],
    counts: [f32; 4],
    params: [f32; 4],
    bases: [u32; 4],
}

fn crowd_uniform(clip_from_world: Mat4, style: &PolypostorStyle, counts: [f32; 4], bases: [u32; 4]) -> CrowdUniform {
    let l = style.light_dir.normalize_or(Vec3::Y);
    CrowdUniform {
        clip_from_world: clip_from_world.to_cols_array_2d(),
        light_dir: [l.x, l.y, l.z, 0.0],
        counts,
        params: [if style.lit { 1.0 } else { 0.0 }, style.ambient, style.tint, 0.0],
        bases,
    }
}

/// A view's camera for the image-based shaders (`View` in WGSL; the Polypostor renderer's
/// layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewGpu {
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    center: [f32; 4],
    uv_scale: [f32; 4],
}

fn views_gpu(reps: &Representations) -> Vec<ViewGpu> {
    reps.manifest
        .views
        .iter()
        .map(|v| {
            let c = &v.camera;
            let four = |a: [f32; 3], w: f32| [a[0], a[1], a[2], w];
            ViewGpu {
                right: four(c.right, 0.0),
                up: four(c.up, 0.0),
                forward: four(c.forward, 0.0),
                center: four(c.center, c.half_size),
                uv_scale: [1.0, 1.0, 0.0, 0.0],
            }
        })
        .collect()
}

/// Snorm8×4 packing of a unit normal (as WGSL's `pack4x8snorm`).
fn pack_normal(n: [f32; 3]) -> u32 {
    let b = |x: f32| ((x.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8 as u32;
    b(n[0]) | b(n[1]) << 8 | b(n[2]) << 16
}

/// Per frame per vertex: position bits and packed normal (`vec4<u32>` in WGSL).
fn packed_frames(v: &FrameVertices) -> Vec<[u32; 4]> {
    v.positions
        .iter()
        .zip(&v.normals)
        .map(|(p, n)| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits(), pack_normal(*n)])
        .collect()
}

fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    // Never bind an empty buffer.
    let pad = [0u8; 16];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if bytes.is_empty() { &pad } else { bytes },
        usage: wgpu::BufferUsages::STORAGE,
    })
}

pub(super) fn uniform_buffer(device: &wgpu::Device, label: &str) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: std::mem::size_of::<CrowdUniform>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

pub(super) enum Entry {
    Uniform,
    Storage,
    TextureArray,
    Sampler,
}

pub(super) fn layout(device: &wgpu::Device, label: &str, entries: &[Entry]) -> wgpu::BindGroupLayout {
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

pub(super) enum Resource<'a> {
    Buffer(&'a wgpu::Buffer),
    View(&'a wgpu::TextureView),
    Sampler(&'a wgpu::Sampler),
}

pub(super) fn bind(
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

pub(super) fn pipeline(
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
pub(super) fn clamp_sampler(device: &wgpu::Device, label: &str) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}

/// One layer per image (all the same size), uploaded. Returns the view and the bytes held.
fn texture_array(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    images: &[image::RgbaImage],
    format: wgpu::TextureFormat,
    blocks: &[crate::texture::CompressedImage],
) -> Result<(wgpu::TextureView, u64), GpuError> {
    let (w, h) = images.first().map_or((1, 1), |i| i.dimensions());
    // The BC7 blocks as they are where every layer has them and the device samples BC7.
    let bc = device.features().contains(wgpu::Features::TEXTURE_COMPRESSION_BC)
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
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w.max(1),
            height: h.max(1),
            depth_or_array_layers: array_layers(device, w.max(1), h.max(1), images.len() as u32),
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (layer, img) in images.iter().enumerate() {
        if img.dimensions() != (w, h) {
            return Err(GpuError::Unsupported(format!(
                "{label}: layer {layer} has another size"
            )));
        }
        let (data, bytes_per_row, rows) = if bc {
            let b = &blocks[layer];
            (
                &b.blocks[..],
                b.blocks_per_row() * crate::texture::BLOCK_BYTES as u32,
                h / 4,
            )
        } else {
            (&img.as_raw()[..], 4 * w, h)
        };
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
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bytes_per_row),
                rows_per_image: Some(rows),
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
    let texel_bytes = if bc { 1 } else { 4 };
    Ok((view, texel_bytes * w as u64 * h as u64 * images.len() as u64))
}

/// How many layers to give a 2D texture array of `w`×`h` that holds `count` images. The
/// OpenGL backend guesses a texture's kind from its shape when it is created (one layer: a
/// plain 2D texture; square with a multiple of six: a cube map) and then cannot view it as an
/// array; there the array gets one or two unused layers so that it is one.
pub(crate) fn array_layers(device: &wgpu::Device, w: u32, h: u32, count: u32) -> u32 {
    layers_for(device.adapter_info().backend, w, h, count)
}

fn layers_for(backend: wgpu::Backend, w: u32, h: u32, count: u32) -> u32 {
    let count = count.max(1);
    if backend != wgpu::Backend::Gl {
        return count;
    }
    let layers = count.max(2);
    if w == h && layers % 6 == 0 { layers + 1 } else { layers }
}

/// A growable storage buffer of instances.
struct InstanceBuffer {
    buffer: wgpu::Buffer,
    capacity: usize,
}

impl InstanceBuffer {
    fn new(device: &wgpu::Device, capacity: usize) -> Self {
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
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[Instance]) -> bool {
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

/// Joint samples per baked frame for the skinned mesh (its animation is sampled 4× finer than
/// the image-based representations, then interpolated).
pub const JOINT_SAMPLES_PER_FRAME: usize = 4;

/// The joints at `per_frame` evenly spaced times in each frame of `timeline` (from the
/// frame's time to the next frame's, within its clip): per sample, per bone, rotation (xyzw)
/// then translation xyz + uniform scale.
pub fn joint_samples(
    character: &Character,
    timeline: &crate::timeline::Timeline,
    per_frame: usize,
) -> Vec<[[f32; 4]; 2]> {
    let per_frame = per_frame.max(1);
    let frames = timeline.samples();
    let frames = if frames.is_empty() { vec![(None, 0.0)] } else { frames };
    let step = 1.0 / (timeline.fps.max(1e-3) * per_frame as f32);
    let mut out = Vec::with_capacity(frames.len() * per_frame * character.bones.len().max(1));
    for (clip, t0) in frames
        .iter()
        .flat_map(|&(c, t)| (0..per_frame).map(move |k| (c, t + k as f32 * step)))
    {
        let pose = Pose::sample_index(character, clip, t0);
        if character.bones.is_empty() {
            out.push([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]]);
        }
        for m in &pose.skin_from_bind {
            let (s, r, tr) = m.to_scale_rotation_translation();
            let scale = (s.x + s.y + s.z) / 3.0;
            out.push([r.to_array(), [tr.x, tr.y, tr.z, scale]]);
        }
    }
    out
}

/// The body part of each character vertex from per-triangle labels (a vertex takes the
/// label of the first triangle that uses it; 0 where none does).
pub fn vertex_parts(character: &Character, triangle_labels: &[u32]) -> Vec<u32> {
    let mut parts = vec![u32::MAX; character.vertices.len()];
    for (t, tri) in character.indices.chunks_exact(3).enumerate() {
        let label = triangle_labels.get(t).copied().unwrap_or(0);
        for &i in tri {
            if let Some(p) = parts.get_mut(i as usize).filter(|p| **p == u32::MAX) {
                *p = label;
            }
        }
    }
    parts.iter().map(|&p| if p == u32::MAX { 0 } else { p }).collect()
}

fn mesh_groups(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frames: [&wgpu::Buffer; 2],
    joints: &wgpu::Buffer,
    instances: [&wgpu::Buffer; 2],
    rigid: &wgpu::Buffer,
    parts: &wgpu::Buffer,
) -> [wgpu::BindGroup; 2] {
    [0, 1].map(|k| {
        bind(
            device,
            "crowd meshes",
            layout,
            &[
                Resource::Buffer(frames[k]),
                Resource::Buffer(joints),
                Resource::Buffer(instances[k]),
                Resource::Buffer(rigid),
                Resource::Buffer(parts),
            ],
        )
    })
}

/// Skinned and rigid meshes of one character.
pub struct GpuMeshCrowd {
    character: GpuCharacter,
    skinned: wgpu::RenderPipeline,
    rigid: Option<wgpu::RenderPipeline>,
    layout: wgpu::BindGroupLayout,
    frame_skinned: wgpu::Buffer,
    frame_rigid: wgpu::Buffer,
    joints: wgpu::Buffer,
    rigid_frames: wgpu::Buffer,
    parts: wgpu::Buffer,
    instances: [InstanceBuffer; 2],
    groups: [wgpu::BindGroup; 2],
    counts: [f32; 4],
    /// Bytes on the GPU of the skinned mesh (static mesh + textures + joint samples) and of
    /// the rigid mesh (static mesh + textures + frames).
    pub skinned_bytes: u64,
    /// Bytes on the GPU of the rigid mesh: the static mesh and textures plus the pre-skinned
    /// frames (16 bytes per vertex per frame; none when no rigid frames were given).
    pub rigid_bytes: u64,
}

impl GpuMeshCrowd {
    /// `frames` and `fps`: the baked animation the instances' frame numbers count
    /// (`rigid`, when given, has that many frames). `triangle_labels`: the body part of each
    /// triangle (for the per-part tint).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        character: &Character,
        timeline: &crate::timeline::Timeline,
        rigid: Option<&FrameVertices>,
        triangle_labels: &[u32],
    ) -> Result<Self, GpuError> {
        let frames = timeline.frames().max(1);
        if let Some(r) = rigid
            && (r.vertex_count != character.vertices.len() || r.frames() != frames.max(1))
        {
            return Err(GpuError::Unsupported(format!(
                "the rigid frames ({} vertices × {} frames) do not match the character ({} vertices, {} frames)",
                r.vertex_count,
                r.frames(),
                character.vertices.len(),
                frames
            )));
        }
        let renderer = CharacterRenderer::new(device);
        let gpu = GpuCharacter::new(&renderer, device, queue, character);
        let layout = layout(
            device,
            "crowd meshes",
            &[
                Entry::Uniform,
                Entry::Storage,
                Entry::Storage,
                Entry::Storage,
                Entry::Storage,
            ],
        );
        let stream0 = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<PositionNormal>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
        };
        let stream1 = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Attributes>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![2 => Float32x2, 3 => Float32x4, 4 => Uint16x4, 5 => Float32x4],
        };
        let layouts = [&layout, renderer.material_layout()];
        let skinned = pipeline(
            device,
            "crowd skinned",
            &layouts,
            shaders::CROWD_MESH,
            "vs_skinned",
            &[Some(stream0), Some(stream1.clone())],
        );
        let rigid_pipeline = rigid.map(|_| {
            pipeline(
                device,
                "crowd rigid",
                &layouts,
                shaders::CROWD_MESH,
                "vs_rigid",
                &[Some(stream1)],
            )
        });
        let samples = joint_samples(character, timeline, JOINT_SAMPLES_PER_FRAME);
        let joints = storage(device, "crowd joints", bytemuck::cast_slice(&samples));
        let rigid_data = rigid.map(packed_frames).unwrap_or_default();
        let rigid_frames = storage(device, "crowd rigid frames", bytemuck::cast_slice(&rigid_data));
        let parts_data = vertex_parts(character, triangle_labels);
        let parts = storage(device, "crowd vertex parts", bytemuck::cast_slice(&parts_data));
        let frame_skinned = uniform_buffer(device, "crowd skinned frame");
        let frame_rigid = uniform_buffer(device, "crowd rigid frame");
        let instances = [InstanceBuffer::new(device, 1024), InstanceBuffer::new(device, 1024)];
        let static_bytes = crate::reps::character_static_bytes(character).total + parts_data.len() as u64 * 4;
        let skinned_bytes =
            static_bytes + character.vertices.len() as u64 * 24 + std::mem::size_of_val(samples.as_slice()) as u64;
        let rigid_bytes = static_bytes + rigid_data.len() as u64 * 16;
        let groups = mesh_groups(
            device,
            &layout,
            [&frame_skinned, &frame_rigid],
            &joints,
            [&instances[0].buffer, &instances[1].buffer],
            &rigid_frames,
            &parts,
        );
        Ok(Self {
            character: gpu,
            skinned,
            rigid: rigid_pipeline,
            groups,
            layout,
            frame_skinned,
            frame_rigid,
            joints,
            rigid_frames,
            parts,
            instances,
            counts: [
                JOINT_SAMPLES_PER_FRAME as f32,
                frames.max(1) as f32,
                character.bones.len().max(1) as f32,
                character.vertices.len() as f32,
            ],
            skinned_bytes,
            rigid_bytes,
        })
    }

    /// True when rigid frames were given.
    pub fn has_rigid(&self) -> bool {
        self.rigid.is_some()
    }

    /// Uploads this frame's skinned and rigid instances.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        skinned: &[Instance],
        rigid: &[Instance],
    ) {
        let a = self.instances[0].upload(device, queue, skinned);
        let b = self.instances[1].upload(device, queue, rigid);
        if a || b {
            self.groups = mesh_groups(
                device,
                &self.layout,
                [&self.frame_skinned, &self.frame_rigid],
                &self.joints,
                [&self.instances[0].buffer, &self.instances[1].buffer],
                &self.rigid_frames,
                &self.parts,
            );
        }
        let u = crowd_uniform(clip_from_world, style, self.counts, [0; 4]);
        queue.write_buffer(&self.frame_skinned, 0, bytemuck::bytes_of(&u));
        queue.write_buffer(&self.frame_rigid, 0, bytemuck::bytes_of(&u));
    }

    /// Draws the prepared instances; returns the draw calls made.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, skinned: usize, rigid: usize) -> usize {
        let mut calls = 0;
        if skinned > 0 {
            pass.set_pipeline(&self.skinned);
            pass.set_bind_group(0, &self.groups[0], &[]);
            self.character.bind_geometry(pass);
            calls += self.character.draw_instanced(pass, skinned as u32);
        }
        if let (Some(p), true) = (&self.rigid, rigid > 0) {
            pass.set_pipeline(p);
            pass.set_bind_group(0, &self.groups[1], &[]);
            self.character.bind_attributes(pass);
            calls += self.character.draw_instanced(pass, rigid as u32);
        }
        calls
    }
}

/// An image-based crowd renderer: per-frame uniforms, the baked views, instances, then its
/// own storage buffers, texture arrays and a sampler, bound in that order (the impostor and
/// NP3D shaders declare them so); one instanced draw.
struct ImageCrowd {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    frame: wgpu::Buffer,
    views: wgpu::Buffer,
    instances: InstanceBuffer,
    buffers: Vec<wgpu::Buffer>,
    textures: Vec<wgpu::TextureView>,
    sampler: wgpu::Sampler,
    group: wgpu::BindGroup,
    counts: [f32; 4],
    bases: [u32; 4],
    view_count: u32,
    frames: u32,
    vertices_per_instance: u32,
    /// Bytes of the views buffer.
    views_bytes: u64,
}

impl ImageCrowd {
    #[allow(clippy::too_many_arguments)]
    fn new(
        device: &wgpu::Device,
        label: &str,
        shader: &str,
        reps: &Representations,
        buffers: Vec<wgpu::Buffer>,
        textures: Vec<wgpu::TextureView>,
        counts: [f32; 4],
        bases: [u32; 4],
        vertices_per_instance: u32,
    ) -> Self {
        let mut entries = vec![Entry::Uniform, Entry::Storage, Entry::Storage];
        entries.extend(buffers.iter().map(|_| Entry::Storage));
        entries.extend(textures.iter().map(|_| Entry::TextureArray));
        entries.push(Entry::Sampler);
        let layout = layout(device, label, &entries);
        let pipeline = pipeline(device, label, &[&layout], shader, "vs_main", &[]);
        let views_data = views_gpu(reps);
        let views = storage(device, label, bytemuck::cast_slice(&views_data));
        let sampler = clamp_sampler(device, label);
        let frame = uniform_buffer(device, label);
        let instances = InstanceBuffer::new(device, 1024);
        let group = Self::group(
            device,
            label,
            &layout,
            [&frame, &views, &instances.buffer],
            &buffers,
            &textures,
            &sampler,
        );
        Self {
            pipeline,
            layout,
            frame,
            views,
            instances,
            buffers,
            textures,
            sampler,
            group,
            counts,
            bases,
            view_count: reps.manifest.views.len() as u32,
            frames: reps.manifest.frames,
            vertices_per_instance,
            views_bytes: std::mem::size_of_val(views_data.as_slice()) as u64,
        }
    }

    fn group(
        device: &wgpu::Device,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        first: [&wgpu::Buffer; 3],
        buffers: &[wgpu::Buffer],
        textures: &[wgpu::TextureView],
        sampler: &wgpu::Sampler,
    ) -> wgpu::BindGroup {
        let mut r: Vec<Resource> = first.iter().map(|b| Resource::Buffer(b)).collect();
        r.extend(buffers.iter().map(Resource::Buffer));
        r.extend(textures.iter().map(Resource::View));
        r.push(Resource::Sampler(sampler));
        bind(device, label, layout, &r)
    }

    fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        instances: &[Instance],
    ) {
        // Views clamped and frames wrapped: no instance may index past the data.
        let safe: Vec<Instance> = instances
            .iter()
            .map(|i| Instance {
                view: i.view.min(self.view_count.saturating_sub(1)),
                frame: crate::crowd::wrap_frame_pair(i.frame, self.frames.max(1)),
                ..*i
            })
            .collect();
        if self.instances.upload(device, queue, &safe) {
            self.group = Self::group(
                device,
                "image crowd",
                &self.layout,
                [&self.frame, &self.views, &self.instances.buffer],
                &self.buffers,
                &self.textures,
                &self.sampler,
            );
        }
        let u = crowd_uniform(clip_from_world, style, self.counts, self.bases);
        queue.write_buffer(&self.frame, 0, bytemuck::bytes_of(&u));
    }

    /// One draw call of `count` instances.
    fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, count: usize) -> usize {
        if count == 0 {
            return 0;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.draw(0..self.vertices_per_instance, 0..count as u32);
        1
    }
}

/// Classic animated impostors: one quad per character.
pub struct GpuImpostors {
    base: ImageCrowd,
    /// Bytes on the GPU (sheets and views).
    pub gpu_bytes: u64,
    /// Per frame of the timeline, the tile drawn (sheets holding every other frame).
    frame_map: Option<Vec<u32>>,
    mapped: Vec<Instance>,
}

impl GpuImpostors {
    /// Impostors from `reps`' own full-resolution sheets. [`GpuError::Unsupported`] when `reps`
    /// holds none (not baked, or left out by [`crate::reps::load_representations_far`]) or the
    /// sheets exceed this GPU's texture limits.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, reps: &Representations) -> Result<Self, GpuError> {
        let data = reps.impostor.as_ref().ok_or_else(|| {
            GpuError::Unsupported("no impostors were baked (bake with --representation impostor)".into())
        })?;
        Self::from_sheets(device, queue, reps, data)
    }

    /// Impostors of `reps`' views drawn from `data` (its sheets, or a downsampled copy).
    pub fn from_sheets(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        reps: &Representations,
        data: &crate::reps::ImpostorData,
    ) -> Result<Self, GpuError> {
        Self::from_sheets_mapped(device, queue, reps, data, None)
    }

    /// [`GpuImpostors::from_sheets`] for sheets holding a subset of the frames
    /// ([`crate::reps::far_frames`]): `frame_map` gives, per frame of the timeline, the tile
    /// drawn for it.
    pub fn from_sheets_mapped(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        reps: &Representations,
        data: &crate::reps::ImpostorData,
        frame_map: Option<Vec<u32>>,
    ) -> Result<Self, GpuError> {
        if frame_map.as_ref().is_some_and(|m| m.is_empty()) {
            return Err(GpuError::Unsupported(
                "impostor frame map: empty (it maps every frame of the timeline to a tile)".into(),
            ));
        }
        let frames = match &frame_map {
            Some(m) => m.iter().copied().max().map_or(1, |x| x + 1),
            None => reps.manifest.frames,
        };
        let (color, cb) = texture_array(
            device,
            queue,
            "impostor colour sheets",
            &data.color,
            wgpu::TextureFormat::Rgba8UnormSrgb,
            &data.color_blocks,
        )?;
        let (normal, nb) = texture_array(
            device,
            queue,
            "impostor normal sheets",
            &data.normal,
            wgpu::TextureFormat::Rgba8Unorm,
            &[],
        )?;
        let base = ImageCrowd::new(
            device,
            "impostors",
            shaders::IMPOSTOR,
            reps,
            Vec::new(),
            vec![color, normal],
            [data.columns as f32, data.rows as f32, frames as f32, 0.0],
            [0; 4],
            6,
        );
        Ok(Self {
            gpu_bytes: cb + nb + base.views_bytes,
            base,
            frame_map,
            mapped: Vec::new(),
        })
    }

    /// Uploads this frame's instances (views clamped, frames wrapped; with a frame map, each
    /// frame replaced by the tile that holds it) and the uniforms of `clip_from_world` and `style`.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        instances: &[Instance],
    ) {
        match &self.frame_map {
            Some(map) => {
                let last = map.len().saturating_sub(1);
                let tile = |f: u32| map[(f as usize).min(last)];
                self.mapped.clear();
                self.mapped.extend(instances.iter().map(|i| {
                    let (a, b) = crate::crowd::frame_pair_parts(i.frame);
                    Instance {
                        frame: crate::crowd::frame_pair(tile(a), tile(b)),
                        ..*i
                    }
                }));
                self.base.prepare(device, queue, clip_from_world, style, &self.mapped);
            }
            None => self.base.prepare(device, queue, clip_from_world, style, instances),
        }
    }

    /// One draw call of `count` quads.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, count: usize) -> usize {
        self.base.draw(pass, count)
    }
}

/// NP3D impostors: the simplified mesh per frame with projected view images.
pub struct GpuNp3d {
    base: ImageCrowd,
    /// Bytes on the GPU (images, meshes, views).
    pub gpu_bytes: u64,
}

impl GpuNp3d {
    /// `vertex_parts`: the body part of each character vertex ([`vertex_parts`]).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        reps: &Representations,
        vertex_parts: &[u32],
    ) -> Result<Self, GpuError> {
        let data = reps.np3d.as_ref().ok_or_else(|| {
            GpuError::Unsupported("no NP3D impostors were baked (bake with --representation np3d)".into())
        })?;
        let packed = packed_frames(&data.frames);
        let vertices = storage(device, "np3d vertices", bytemuck::cast_slice(&packed));
        let mut topo: Vec<u32> = data.indices.iter().map(|&i| i as u32).collect();
        let part_base = topo.len() as u32;
        topo.extend(
            data.source
                .iter()
                .map(|&s| vertex_parts.get(s as usize).copied().unwrap_or(0)),
        );
        let topology = storage(device, "np3d topology", bytemuck::cast_slice(&topo));
        let (images, ib) = texture_array(
            device,
            queue,
            "np3d images",
            &data.images,
            wgpu::TextureFormat::Rgba8UnormSrgb,
            &[],
        )?;
        let base = ImageCrowd::new(
            device,
            "np3d",
            shaders::NP3D,
            reps,
            vec![vertices, topology],
            vec![images],
            [
                data.frames.vertex_count as f32,
                reps.manifest.frames as f32,
                reps.manifest.key_frame as f32,
                0.0,
            ],
            [part_base, 0, 0, 0],
            data.indices.len() as u32,
        );
        Ok(Self {
            gpu_bytes: ib + (packed.len() * 16 + topo.len() * 4) as u64 + base.views_bytes,
            base,
        })
    }

    /// Uploads this frame's instances (views clamped, frames wrapped) and the uniforms of
    /// `clip_from_world` and `style`.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        instances: &[Instance],
    ) {
        self.base.prepare(device, queue, clip_from_world, style, instances);
    }

    /// One draw call of `count` meshes.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, count: usize) -> usize {
        self.base.draw(pass, count)
    }
}

/// The ground under a crowd (`shaders/crowd_ground.wgsl`).
struct Ground {
    pipeline: wgpu::RenderPipeline,
    frame: wgpu::Buffer,
    group: wgpu::BindGroup,
}

impl Ground {
    fn new(device: &wgpu::Device) -> Self {
        let layout = layout(device, "crowd ground", &[Entry::Uniform]);
        let pipeline = pipeline(
            device,
            "crowd ground",
            &[&layout],
            shaders::CROWD_GROUND,
            "vs_main",
            &[],
        );
        let frame = uniform_buffer(device, "crowd ground");
        let group = bind(device, "crowd ground", &layout, &[Resource::Buffer(&frame)]);
        Self { pipeline, frame, group }
    }
}

/// Downsampling of the far impostors' sheets: the three-level mix draws impostors only below
/// a quarter of a screen pixel per baked texel (`LodDistances::impostor_below`), where a
/// quarter of the texels along each side still gives one texel a pixel. Their normal sheets
/// are downsampled twice as much (lighting is smoother than colour).
pub const FAR_IMPOSTOR_FACTOR: u32 = 4;

/// Every representation of one character, ready to draw a crowd's per-level instances.
pub struct CrowdRenderers {
    /// Skinned meshes (always) and rigid ones (when the representations hold rigid frames that
    /// match the character and the timeline).
    pub meshes: GpuMeshCrowd,
    /// The Polypostor pack on the GPU, when a pack was given.
    pub polypostor: Option<GpuPolypostors>,
    /// Impostors at the baked resolution (the impostor level on its own; loaded on request).
    pub impostor: Option<GpuImpostors>,
    /// Impostors at `1 / FAR_IMPOSTOR_FACTOR` of the baked resolution: what the three-level
    /// mix draws its far characters with.
    pub far_impostor: Option<GpuImpostors>,
    /// Draw the impostor level with [`CrowdRenderers::far_impostor`] (the mix) rather than
    /// the full-resolution sheets. Default value: false.
    pub use_far_impostors: bool,
    /// NP3D impostors, when the representations hold them.
    pub np3d: Option<GpuNp3d>,
    counts: [usize; Level::COUNT],
    ground: Ground,
    /// Half the side of the ground square drawn under the crowd (0: no ground).
    pub ground_half_extent: f32,
    /// Height of the ground plane (the character's lowest point). Default value: 0.
    pub ground_y: f32,
    /// Size of the characters against a 1.8 m person: the ground's margin and its grid lines
    /// (2 m and 10 m for a person, the nearest power of ten times that otherwise). Default
    /// value: 1.
    pub ground_scale: f32,
}

impl CrowdRenderers {
    /// Builds what the inputs allow: meshes always (skinned; rigid when `reps` has rigid
    /// frames), the Polypostor from `pack`, impostors (far ones always, from `reps`' baked far
    /// sheets or reduced from its full ones; full-resolution ones from `full_impostors`, the
    /// sheets of `reps`' views) and NP3D from `reps`. Frames and rate come from the pack, else
    /// from `reps`, else `fallback`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        character: &Character,
        timeline: &crate::timeline::Timeline,
        triangle_labels: &[u32],
        pack: Option<&crate::pack::LoadedPack>,
        reps: Option<&Representations>,
        fallback: crate::crowd::ClipTiming,
        full_impostors: Option<&crate::reps::ImpostorData>,
    ) -> Result<Self, GpuError> {
        let timing = pack
            .map(|p| crate::crowd::ClipTiming {
                frames: p.manifest.frames as usize,
                fps: p.manifest.fps,
            })
            .or_else(|| {
                reps.map(|r| crate::crowd::ClipTiming {
                    frames: r.manifest.frames as usize,
                    fps: r.manifest.fps,
                })
            })
            .unwrap_or(fallback);
        let rigid = reps
            .and_then(|r| r.rigid.as_ref())
            .filter(|r| r.frames() == timing.frames && r.vertex_count == character.vertices.len());
        if timeline.frames() != timing.frames.max(1) {
            return Err(GpuError::Unsupported(format!(
                "the clips give {} frames but the bake has {}",
                timeline.frames(),
                timing.frames
            )));
        }
        let meshes = GpuMeshCrowd::new(device, queue, character, timeline, rigid, triangle_labels)?;
        let parts = vertex_parts(character, triangle_labels);
        Ok(Self {
            meshes,
            polypostor: pack.map(|p| GpuPolypostors::new(device, queue, p)).transpose()?,
            impostor: reps
                .zip(full_impostors)
                .map(|(r, d)| GpuImpostors::from_sheets(device, queue, r, d))
                .transpose()?,
            far_impostor: match reps.and_then(|r| r.far_impostor.as_ref().map(|f| (r, f))) {
                // Baked (representations format 4).
                Some((r, far)) => Some(GpuImpostors::from_sheets_mapped(
                    device,
                    queue,
                    r,
                    far,
                    crate::reps::far_frame_map(&r.manifest),
                )?),
                // Representations made in memory: reduced here.
                None => reps
                    .and_then(|r| r.impostor.as_ref().map(|d| (r, d)))
                    .map(|(r, d)| {
                        // A long timeline (a whole-character pack): every other frame of each clip.
                        let (subset, map) = match crate::reps::far_frames(&r.manifest.clips, r.manifest.frames as usize)
                        {
                            Some((keep, map)) => (Some(d.frames_subset(&keep)), Some(map)),
                            None => (None, None),
                        };
                        GpuImpostors::from_sheets_mapped(
                            device,
                            queue,
                            r,
                            &subset
                                .as_ref()
                                .unwrap_or(d)
                                .downsampled_split(FAR_IMPOSTOR_FACTOR, 2 * FAR_IMPOSTOR_FACTOR),
                            map,
                        )
                    })
                    .transpose()?,
            },
            use_far_impostors: false,
            np3d: reps
                .filter(|r| r.np3d.is_some())
                .map(|r| GpuNp3d::new(device, queue, r, &parts))
                .transpose()?,
            counts: [0; Level::COUNT],
            ground: Ground::new(device),
            ground_half_extent: 0.0,
            ground_y: 0.0,
            ground_scale: 1.0,
        })
    }

    /// True when this level can be drawn.
    pub fn has(&self, level: Level) -> bool {
        match level {
            Level::Skinned => true,
            Level::Rigid => self.meshes.has_rigid(),
            Level::Polypostor => self.polypostor.is_some(),
            Level::Impostor => self.impostor.is_some() || self.far_impostor.is_some(),
            Level::Np3d => self.np3d.is_some(),
        }
    }

    /// The impostors the impostor level draws with: the far ones for the mix (or when the
    /// full-resolution ones are not loaded), else the full-resolution ones.
    fn impostors(&self) -> Option<&GpuImpostors> {
        if self.use_far_impostors || self.impostor.is_none() {
            self.far_impostor.as_ref().or(self.impostor.as_ref())
        } else {
            self.impostor.as_ref()
        }
    }

    /// Whether the full-resolution impostor sheets are on the GPU.
    pub fn has_full_impostors(&self) -> bool {
        self.impostor.is_some()
    }

    /// Bytes on the GPU per level (0 where it is not loaded).
    pub fn gpu_bytes(&self, level: Level) -> u64 {
        match level {
            Level::Skinned => self.meshes.skinned_bytes,
            Level::Rigid if self.meshes.has_rigid() => self.meshes.rigid_bytes,
            Level::Rigid => 0,
            Level::Polypostor => self.polypostor.as_ref().map_or(0, |p| p.gpu_bytes),
            Level::Impostor => self.impostors().map_or(0, |p| p.gpu_bytes),
            Level::Np3d => self.np3d.as_ref().map_or(0, |p| p.gpu_bytes),
        }
    }

    /// Uploads each level's instances (a level that is not loaded draws nothing).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        instances: &[Vec<Instance>; Level::COUNT],
    ) {
        let n = |l: Level| instances[l as usize].as_slice();
        self.meshes.prepare(
            device,
            queue,
            clip_from_world,
            style,
            n(Level::Skinned),
            n(Level::Rigid),
        );
        if let Some(p) = &mut self.polypostor {
            p.prepare(device, queue, clip_from_world, style, n(Level::Polypostor));
        }
        let far = self.use_far_impostors || self.impostor.is_none();
        let used = if far {
            self.far_impostor.as_mut().or(self.impostor.as_mut())
        } else {
            self.impostor.as_mut()
        };
        if let Some(p) = used {
            p.prepare(device, queue, clip_from_world, style, n(Level::Impostor));
        }
        if let Some(p) = &mut self.np3d {
            p.prepare(device, queue, clip_from_world, style, n(Level::Np3d));
        }
        for l in Level::ALL {
            self.counts[l as usize] = if self.has(l) { instances[l as usize].len() } else { 0 };
        }
        let u = crowd_uniform(
            clip_from_world,
            style,
            [
                self.ground_half_extent,
                self.ground_y,
                self.ground_scale.max(1e-6),
                10f32.powf(self.ground_scale.max(1e-6).log10().round()),
            ],
            [0; 4],
        );
        queue.write_buffer(&self.ground.frame, 0, bytemuck::bytes_of(&u));
    }

    /// Draws the ground (when [`CrowdRenderers::ground_half_extent`] is set) and what
    /// [`CrowdRenderers::prepare`] uploaded; returns the draw calls made for characters.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>) -> usize {
        let c = |l: Level| self.counts[l as usize];
        let mut calls = 0;
        if self.ground_half_extent > 0.0 {
            pass.set_pipeline(&self.ground.pipeline);
            pass.set_bind_group(0, &self.ground.group, &[]);
            pass.draw(0..6, 0..1);
        }
        calls += self.meshes.draw(pass, c(Level::Skinned), c(Level::Rigid));
        if let Some(p) = &self.polypostor {
            calls += p.draw(pass, c(Level::Polypostor));
        }
        if let Some(p) = self.impostors() {
            calls += p.draw(pass, c(Level::Impostor));
        }
        if let Some(p) = &self.np3d {
            calls += p.draw(pass, c(Level::Np3d));
        }
        calls
    }

    /// Prepares, draws into `target` (cleared to `clear`) and submits; returns the draw
    /// calls. For tests, benchmarks and the editor's offscreen preview.
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &RenderTarget,
        clip_from_world: Mat4,
        style: &PolypostorStyle,
        instances: &[Vec<Instance>; Level::COUNT],
        clear: wgpu::Color,
    ) -> usize {
        self.prepare(device, queue, clip_from_world, style, instances);
        let mut encoder = device.create_command_encoder(&Default::default());
        let calls = {
            let mut pass = target.begin_pass(&mut encoder, "crowd", clear);
            self.draw(&mut pass)
        };
        queue.submit([encoder.finish()]);
        calls
    }
}

#[cfg(test)]
mod tests {
    use super::layers_for;
    use wgpu::Backend::{Gl, Vulkan};

    #[test]
    fn texture_arrays_on_opengl_never_look_like_2d_or_cube_textures() {
        for count in 0..40 {
            for (w, h) in [(64, 64), (64, 32)] {
                assert_eq!(layers_for(Vulkan, w, h, count), count.max(1));
                let n = layers_for(Gl, w, h, count);
                assert!(n >= count.max(2), "{count} images in {n} layers");
                assert!(n <= count.max(2) + 1, "{count} images in {n} layers");
                // wgpu-hal's guess: one layer is 2D, a square multiple of six is a cube (array).
                assert!(!(w == h && n % 6 == 0), "{count} images: {n} square layers");
            }
        }
    }
}
