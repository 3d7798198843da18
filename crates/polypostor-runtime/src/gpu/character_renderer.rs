//! Drawing a skinned character into colour, normal and depth targets.

use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use super::gpu_data::{Attributes, Bones, FrameUniforms, MAX_BONES, MaterialUniforms, PositionNormal};
use super::{Camera, DepthImage, GpuError, read_depth, read_rgba8, shaders};
use crate::animation::{Pose, skin_vertices};
use crate::character::{Character, Texture, TextureWrap};

/// Colour target: sRGB-encoded RGBA8 (linear values written, encoded by the hardware).
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// [`COLOR_FORMAT`] without the sRGB decode: the view format of `RenderTarget::color_bytes_view`.
pub const COLOR_BYTES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Normal target: view-space unit normal encoded as `n * 0.5 + 0.5`, alpha 1 on the character.
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Depth target: 32-bit float in wgpu's 0..1 range, cleared to 1 (far); nearer fragments win.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// How colour is shaded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Shading {
    /// Diffuse light from the upper left plus ambient and a soft rim.
    #[default]
    Lit,
    /// The base colour alone (what the bake matches).
    Unlit,
}

/// Where skinning happens.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkinningMode {
    /// In the vertex shader (the default; falls back to CPU above [`MAX_BONES`] bones).
    #[default]
    Gpu,
    /// On the CPU with [`skin_vertices`], uploaded each pose.
    Cpu,
}

/// Options of one draw.
#[derive(Clone, Copy, Debug)]
pub struct DrawOptions {
    /// Lit, or the base colour alone.
    pub shading: Shading,
    /// Linear RGBA clear colour of the colour target.
    pub clear_color: [f64; 4],
    /// Also draw the ground grid on the y = 0 plane (blended over the colour, depth-tested but
    /// not written, the normal target left as it is).
    pub grid: bool,
}

impl Default for DrawOptions {
    fn default() -> Self {
        Self {
            shading: Shading::Lit,
            clear_color: [0.0, 0.0, 0.0, 0.0],
            grid: false,
        }
    }
}

/// Colour, normal and depth textures of one size.
pub struct RenderTarget {
    /// Width in pixels (at least 1).
    pub width: u32,
    /// Height in pixels (at least 1).
    pub height: u32,
    /// Colour image, [`COLOR_FORMAT`] (sRGB-encoded RGBA8).
    pub color: wgpu::Texture,
    /// View of [`Self::color`] in its own sRGB format: the first colour attachment (linear
    /// values written, encoded by the hardware).
    pub color_view: wgpu::TextureView,
    /// The colour image read as its stored (sRGB-encoded) bytes, without decoding: what a
    /// non-sRGB window wants to show as is. Only in targets made by
    /// [`RenderTarget::with_bytes_view`].
    pub color_bytes_view: Option<wgpu::TextureView>,
    /// View-space normal image, [`NORMAL_FORMAT`] (`n * 0.5 + 0.5`; alpha 0 where nothing was
    /// drawn).
    pub normal: wgpu::Texture,
    /// View of [`Self::normal`]: the second colour attachment.
    pub normal_view: wgpu::TextureView,
    /// Depth image, [`DEPTH_FORMAT`] (1 = far).
    pub depth: wgpu::Texture,
    /// View of [`Self::depth`]: the depth attachment.
    pub depth_view: wgpu::TextureView,
}

impl RenderTarget {
    /// Colour, normal and depth textures of `width × height` pixels (each side at least 1), usable
    /// as attachments, copy sources and destinations and sampled textures; no
    /// [`Self::color_bytes_view`].
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        Self::make(device, width, height, false)
    }

    /// A target whose colour image can also be read as its stored bytes
    /// ([`Self::color_bytes_view`]). Needs the `VIEW_FORMATS` downlevel capability, which the
    /// OpenGL backend lacks (see [`view_formats_supported`]).
    pub fn with_bytes_view(device: &wgpu::Device, width: u32, height: u32) -> Self {
        Self::make(device, width, height, true)
    }

    fn make(device: &wgpu::Device, width: u32, height: u32, bytes_view: bool) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let make = |label, format: wgpu::TextureFormat| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                // The colour image can also be read as its stored bytes (see `color_bytes_view`).
                view_formats: if bytes_view && format == COLOR_FORMAT {
                    &[COLOR_BYTES_FORMAT]
                } else {
                    &[]
                },
            })
        };
        let color = make("target colour", COLOR_FORMAT);
        let normal = make("target normal", NORMAL_FORMAT);
        let depth = make("target depth", DEPTH_FORMAT);
        Self {
            width,
            height,
            color_view: color.create_view(&Default::default()),
            color_bytes_view: bytes_view.then(|| {
                color.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("target colour bytes"),
                    format: Some(COLOR_BYTES_FORMAT),
                    ..Default::default()
                })
            }),
            normal_view: normal.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
            normal,
            depth,
        }
    }

    /// A render pass over the three targets, cleared (colour to `clear`, normal to
    /// transparent, depth to far).
    pub fn begin_pass<'e>(
        &'e self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &'static str,
        clear: wgpu::Color,
    ) -> wgpu::RenderPass<'e> {
        self.pass(encoder, label, Some(clear))
    }

    /// A render pass over the three targets that keeps the colour and normal images and
    /// clears depth to far.
    pub fn begin_pass_over<'e>(
        &'e self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &'static str,
    ) -> wgpu::RenderPass<'e> {
        self.pass(encoder, label, None)
    }

    fn pass<'e>(
        &'e self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &'static str,
        clear: Option<wgpu::Color>,
    ) -> wgpu::RenderPass<'e> {
        let attachment = |view: &'e wgpu::TextureView, color: wgpu::Color| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: clear.map_or(wgpu::LoadOp::Load, |_| wgpu::LoadOp::Clear(color)),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[
                attachment(&self.color_view, clear.unwrap_or(wgpu::Color::TRANSPARENT)),
                attachment(&self.normal_view, wgpu::Color::TRANSPARENT),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Records copies of this target's colour and normal images into `dst` (same size).
    pub(crate) fn copy_images_to(&self, encoder: &mut wgpu::CommandEncoder, dst: &RenderTarget) {
        let size = wgpu::Extent3d {
            width: self.width.min(dst.width),
            height: self.height.min(dst.height),
            depth_or_array_layers: 1,
        };
        for (from, to) in [(&self.color, &dst.color), (&self.normal, &dst.normal)] {
            encoder.copy_texture_to_texture(from.as_image_copy(), to.as_image_copy(), size);
        }
    }

    /// Copies the colour image back to the CPU (waiting for the GPU): its sRGB-encoded RGBA8
    /// bytes, rows top to bottom.
    pub fn read_color(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<image::RgbaImage, GpuError> {
        read_rgba8(device, queue, &self.color)
    }
    /// Copies the normal image back to the CPU: the view-space normal as `n * 0.5 + 0.5` in RGBA8,
    /// rows top to bottom.
    pub fn read_normal(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<image::RgbaImage, GpuError> {
        read_rgba8(device, queue, &self.normal)
    }
    /// Copies the depth image back to the CPU (through a shader on OpenGL: see
    /// [`super::read_depth`]).
    pub fn read_depth(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<DepthImage, GpuError> {
        read_depth(device, queue, &self.depth)
    }
}

/// Whether `adapter` can view a texture in another format than its own (sRGB colour as its
/// raw bytes): not on OpenGL.
pub fn view_formats_supported(adapter: &wgpu::Adapter) -> bool {
    adapter
        .get_downlevel_capabilities()
        .flags
        .contains(wgpu::DownlevelFlags::VIEW_FORMATS)
}

/// A pipeline that draws one full-target triangle (`module`'s `vs_main`, three vertices, no
/// buffers) shaded by `fragment_entry` into one unblended `format` target: blits and
/// per-pixel conversions.
pub fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    fragment_entry: &str,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            buffers: &[],
            compilation_options: Default::default(),
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment_entry),
            targets: &[Some(format.into())],
            compilation_options: Default::default(),
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The colour and normal targets of a [`RenderTarget`], written without blending.
pub(crate) fn opaque_targets() -> [Option<wgpu::ColorTargetState>; 2] {
    [COLOR_FORMAT, NORMAL_FORMAT].map(|format| {
        Some(wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })
    })
}

/// Depth test and write against a [`RenderTarget`]'s depth (nearer wins).
pub(crate) fn depth_less() -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// The base colour textures' sampler: linear, mipmapped, with the material's wrap modes in u
/// and v (glTF's sampler `wrapS`, `wrapT`).
fn base_color_sampler(device: &wgpu::Device, wrap: [TextureWrap; 2]) -> wgpu::Sampler {
    let mode = |w: TextureWrap| match w {
        TextureWrap::Repeat => wgpu::AddressMode::Repeat,
        TextureWrap::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
        TextureWrap::ClampToEdge => wgpu::AddressMode::ClampToEdge,
    };
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("base colour"),
        address_mode_u: mode(wrap[0]),
        address_mode_v: mode(wrap[1]),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}

/// Pipelines and layouts shared by every character.
pub struct CharacterRenderer {
    frame_layout: wgpu::BindGroupLayout,
    material_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    grid_pipeline: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl CharacterRenderer {
    /// Builds the character and grid pipelines (drawing into a [`RenderTarget`]), their bind
    /// group layouts and the base-colour sampler (trilinear, repeating).
    pub fn new(device: &wgpu::Device) -> Self {
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT),
                uniform_entry(1, wgpu::ShaderStages::VERTEX),
            ],
        });
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("character"),
            bind_group_layouts: &[Some(&frame_layout), Some(&material_layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("character.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::CHARACTER.into()),
        });
        let targets = opaque_targets();
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("character"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                buffers: &[
                    Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<PositionNormal>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
                    }),
                    Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<Attributes>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![2 => Float32x2, 3 => Float32x4, 4 => Uint16x4, 5 => Float32x4],
                    }),
                ],
                compilation_options: Default::default(),
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
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
        });

        let grid_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("grid"),
            bind_group_layouts: &[Some(&frame_layout)],
            immediate_size: 0,
        });
        let grid_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("grid.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::GRID.into()),
        });
        let grid_targets = [
            Some(wgpu::ColorTargetState {
                format: COLOR_FORMAT,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: NORMAL_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::empty(),
            }),
        ];
        let grid_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("grid"),
            layout: Some(&grid_layout),
            vertex: wgpu::VertexState {
                module: &grid_module,
                entry_point: Some("vs_main"),
                buffers: &[],
                compilation_options: Default::default(),
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &grid_module,
                entry_point: Some("fs_main"),
                targets: &grid_targets,
                compilation_options: Default::default(),
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = base_color_sampler(device, [TextureWrap::Repeat; 2]);
        Self {
            frame_layout,
            material_layout,
            pipeline,
            grid_pipeline,
            sampler,
        }
    }

    pub(crate) fn material_layout(&self) -> &wgpu::BindGroupLayout {
        &self.material_layout
    }

    /// The skinned character pipeline (`character.wgsl`): group 0 the frame uniforms and bones,
    /// group 1 a material; vertex buffers [`PositionNormal`] at slot 0 and [`Attributes`] at slot 1.
    pub fn pipeline(&self) -> &wgpu::RenderPipeline {
        &self.pipeline
    }

    /// A group-0 bind group of a camera buffer and a bones buffer.
    pub fn frame_group(&self, device: &wgpu::Device, frame: &wgpu::Buffer, bones: &wgpu::Buffer) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &self.frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: bones.as_entire_binding(),
                },
            ],
        })
    }

    /// Records a draw of `character` into `target` (clearing it) on `encoder`. Call
    /// [`GpuCharacter::set_camera`] and [`GpuCharacter::set_pose`] first so the uniforms hold this
    /// camera and pose.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        character: &GpuCharacter,
        options: &DrawOptions,
    ) {
        let [r, g, b, a] = options.clear_color;
        let mut pass = target.begin_pass(encoder, "character", wgpu::Color { r, g, b, a });
        self.draw_character(&mut pass, character);
        if options.grid {
            pass.set_pipeline(&self.grid_pipeline);
            pass.set_bind_group(0, &character.frame_group, &[]);
            pass.draw(0..6, 0..1);
        }
    }

    /// Records the ground grid alone into `backdrop` (cleared to `options.clear_color`): the
    /// background [`Self::encode_over`] starts from. It depends only on the camera and the
    /// target size, so a viewport that plays an animation draws it once rather than every
    /// frame (the grid covers most of the view; on a software rasteriser it is most of the 3D
    /// view's cost).
    pub fn encode_backdrop(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        backdrop: &RenderTarget,
        character: &GpuCharacter,
        options: &DrawOptions,
    ) {
        let [r, g, b, a] = options.clear_color;
        let mut pass = backdrop.begin_pass(encoder, "backdrop", wgpu::Color { r, g, b, a });
        pass.set_pipeline(&self.grid_pipeline);
        pass.set_bind_group(0, &character.frame_group, &[]);
        pass.draw(0..6, 0..1);
    }

    /// Records a copy of `backdrop` (same size, drawn by [`Self::encode_backdrop`] with this
    /// camera) into `target`, and `character` over it. Unlike [`Self::encode`] with a grid,
    /// the grid lines do not show through the parts of the character below the ground.
    pub fn encode_over(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        backdrop: &RenderTarget,
        character: &GpuCharacter,
    ) {
        backdrop.copy_images_to(encoder, target);
        let mut pass = target.begin_pass_over(encoder, "character over backdrop");
        self.draw_character(&mut pass, character);
    }

    fn draw_character(&self, pass: &mut wgpu::RenderPass<'_>, character: &GpuCharacter) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &character.frame_group, &[]);
        pass.set_vertex_buffer(0, character.stream0.slice(..));
        pass.set_vertex_buffer(1, character.stream1.slice(..));
        pass.set_index_buffer(character.indices.slice(..), wgpu::IndexFormat::Uint32);
        for s in &character.submeshes {
            pass.set_bind_group(1, &character.materials[s.material].1, &[]);
            pass.draw_indexed(s.first_index..s.first_index + s.index_count, 0, 0..1);
        }
    }

    /// Sets the pose and camera, draws, and submits: a complete headless render.
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &RenderTarget,
        gpu: &mut GpuCharacter,
        character: &Character,
        pose: &Pose,
        mode: SkinningMode,
        camera: &Camera,
        options: &DrawOptions,
    ) {
        gpu.set_pose(queue, character, pose, mode);
        gpu.set_camera(
            queue,
            camera,
            target.width as f32 / target.height as f32,
            options.shading,
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("render") });
        self.encode(&mut encoder, target, gpu, options);
        queue.submit([encoder.finish()]);
    }
}

/// GPU resources of one character.
pub struct GpuCharacter {
    stream0: wgpu::Buffer,
    stream1: wgpu::Buffer,
    indices: wgpu::Buffer,
    frame_buffer: wgpu::Buffer,
    bones_buffer: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    materials: Vec<(wgpu::Buffer, wgpu::BindGroup)>,
    submeshes: Vec<crate::character::Submesh>,
    bind_pose: Vec<PositionNormal>,
    /// True when stream 0 holds CPU-skinned or morphed vertices rather than the bind pose.
    stream0_skinned: bool,
    bone_count: usize,
}

/// Mip chain of an sRGB RGBA8 texture by 2×2 box filtering (in sRGB space).
fn mip_chain(t: &Texture) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(t.width, t.height, t.rgba8.clone())];
    while let Some((w, h, data)) = levels.last().filter(|l| l.0 > 1 || l.1 > 1) {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut out = vec![0u8; (nw * nh * 4) as usize];
        for y in 0..nh {
            for x in 0..nw {
                for c in 0..4 {
                    let mut sum = 0u32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let sx = (x * 2 + dx).min(w - 1);
                        let sy = (y * 2 + dy).min(h - 1);
                        sum += data[((sy * w + sx) * 4 + c) as usize] as u32;
                    }
                    out[((y * nw + x) * 4 + c) as usize] = ((sum + 2) / 4) as u8;
                }
            }
        }
        levels.push((nw, nh, out));
    }
    levels
}

fn upload_texture(device: &wgpu::Device, queue: &wgpu::Queue, t: &Texture) -> wgpu::Texture {
    let levels = mip_chain(t);
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(&t.name),
        size: wgpu::Extent3d {
            width: t.width,
            height: t.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (level, (w, h, data)) in levels.iter().enumerate() {
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(*h),
            },
            wgpu::Extent3d {
                width: *w,
                height: *h,
                depth_or_array_layers: 1,
            },
        );
    }
    texture
}

/// Positions and normals in the vertex layout of stream 0.
fn position_normals(p: &[Vec3], n: &[Vec3]) -> Vec<PositionNormal> {
    p.iter()
        .zip(n)
        .map(|(p, n)| PositionNormal {
            position: p.to_array(),
            normal: n.to_array(),
        })
        .collect()
}

/// The ground grid's cell for something `size` world units across: the power of ten nearest
/// it (1 m for a person, 100 m for a character 100× too big, 10 µm for one 0.02 mm tall).
pub fn grid_cell(size: f32) -> f32 {
    if !(size.is_finite() && size > 0.0) {
        return 1.0;
    }
    10f32.powf(size.log10().round().clamp(-30.0, 30.0))
}

/// Uniforms of a camera for one draw.
pub fn frame_uniforms(camera: &Camera, aspect: f32, shading: Shading) -> FrameUniforms {
    let light = Vec3::new(-0.45, 0.65, 0.6).normalize();
    FrameUniforms {
        clip_from_world: camera.clip_from_world(aspect).to_cols_array_2d(),
        view_from_world: camera.view_from_world().to_cols_array_2d(),
        light_dir_view: [light.x, light.y, light.z, 0.0],
        params: match shading {
            Shading::Lit => [1.0, 0.35, 0.12, 0.0],
            Shading::Unlit => [0.0, 1.0, 0.0, 0.0],
        },
    }
}

/// Bone matrices of a pose in the uniform layout (identity past the pose's bones).
pub fn bones_uniforms(pose: &Pose) -> Bones {
    let mut bones = Bones {
        m: [Mat4::IDENTITY.to_cols_array_2d(); MAX_BONES],
    };
    for (dst, m) in bones.m.iter_mut().zip(&pose.skin_from_bind) {
        *dst = m.to_cols_array_2d();
    }
    bones
}

impl GpuCharacter {
    /// Binds the vertex and index buffers.
    pub fn bind_geometry<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>) {
        pass.set_vertex_buffer(0, self.stream0.slice(..));
        pass.set_vertex_buffer(1, self.stream1.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// Binds only the static attributes (UV, colour, joints, weights) at slot 0, and the
    /// indices: for pipelines that pull positions from elsewhere.
    pub(crate) fn bind_attributes<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>) {
        pass.set_vertex_buffer(0, self.stream1.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// Draws every submesh with its material, `instances` times (one draw call per
    /// submesh; geometry must be bound). Returns the draw calls made.
    pub(crate) fn draw_instanced<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, instances: u32) -> usize {
        let mut calls = 0;
        for s in &self.submeshes {
            if let Some((_, group)) = self.materials.get(s.material) {
                pass.set_bind_group(1, group, &[]);
                pass.draw_indexed(s.first_index..s.first_index + s.index_count, 0, 0..instances);
                calls += 1;
            }
        }
        calls
    }

    /// Draws index ranges with their materials (geometry must be bound).
    pub fn draw_ranges<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, ranges: &[crate::character::Submesh]) {
        for s in ranges {
            if let Some((_, group)) = self.materials.get(s.material) {
                pass.set_bind_group(1, group, &[]);
                pass.draw_indexed(s.first_index..s.first_index + s.index_count, 0, 0..1);
            }
        }
    }

    /// Uploads `c`: its bind-pose positions and normals (stream 0), static attributes (stream 1),
    /// 32-bit indices, each texture with its mip chain, and per material its factor and texture
    /// (white when it has none). The bones start as identity; call [`Self::set_pose`] and
    /// [`Self::set_camera`] before drawing.
    pub fn new(renderer: &CharacterRenderer, device: &wgpu::Device, queue: &wgpu::Queue, c: &Character) -> Self {
        let bind_pose: Vec<PositionNormal> = c
            .vertices
            .iter()
            .map(|v| PositionNormal {
                position: v.position.to_array(),
                normal: v.normal.to_array(),
            })
            .collect();
        let attrs: Vec<Attributes> = c
            .vertices
            .iter()
            .map(|v| Attributes {
                uv: v.uv,
                color: v.color,
                bones: v.bones,
                weights: v.weights,
            })
            .collect();
        let stream0 = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("positions+normals"),
            contents: bytemuck::cast_slice(&bind_pose),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        });
        let stream1 = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("attributes"),
            contents: bytemuck::cast_slice(&attrs),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("indices"),
            contents: bytemuck::cast_slice(&c.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let identity = Bones {
            m: [Mat4::IDENTITY.to_cols_array_2d(); MAX_BONES],
        };
        let bones_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bones"),
            contents: bytemuck::bytes_of(&identity),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let frame_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &renderer.frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: bones_buffer.as_entire_binding(),
                },
            ],
        });
        let white = upload_texture(device, queue, &Texture::white());
        let textures: Vec<wgpu::Texture> = c.textures.iter().map(|t| upload_texture(device, queue, t)).collect();
        // Samplers for materials whose texture does not repeat (the renderer's own repeats).
        let mut samplers: Vec<([TextureWrap; 2], wgpu::Sampler)> = Vec::new();
        for m in &c.materials {
            if m.wrap != [TextureWrap::Repeat; 2] && !samplers.iter().any(|(w, _)| *w == m.wrap) {
                samplers.push((m.wrap, base_color_sampler(device, m.wrap)));
            }
        }
        let materials = c
            .materials
            .iter()
            .map(|m| {
                let sampler = samplers
                    .iter()
                    .find(|(w, _)| *w == m.wrap)
                    .map_or(&renderer.sampler, |(_, s)| s);
                let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(&m.name),
                    contents: bytemuck::bytes_of(&MaterialUniforms {
                        base_color_factor: m.base_color_factor,
                        params: [m.alpha_cutoff, 0.0, 0.0, 0.0],
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                let tex = m.base_color_texture.and_then(|i| textures.get(i)).unwrap_or(&white);
                let view = tex.create_view(&Default::default());
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&m.name),
                    layout: &renderer.material_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buffer.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(&view),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: wgpu::BindingResource::Sampler(sampler),
                        },
                    ],
                });
                (buffer, group)
            })
            .collect();
        Self {
            stream0,
            stream1,
            indices,
            frame_buffer,
            bones_buffer,
            frame_group,
            materials,
            submeshes: c.submeshes.clone(),
            bind_pose,
            stream0_skinned: false,
            bone_count: c.bones.len(),
        }
    }

    /// A stream-0 vertex buffer of `character`'s bind-space vertices with `pose`'s morph
    /// weights applied, for drawing that pose with GPU skinning ([`Self::bind_stream0`]);
    /// `None` where the pose's morphs are at rest (the buffer [`Self::new`] made serves).
    pub fn morphed_stream(device: &wgpu::Device, character: &Character, pose: &Pose) -> Option<wgpu::Buffer> {
        let (p, n) = crate::animation::morphed_bind(character, pose)?;
        Some(device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("morphed positions+normals"),
            contents: bytemuck::cast_slice(&position_normals(&p, &n)),
            usage: wgpu::BufferUsages::VERTEX,
        }))
    }

    /// Binds `stream0` (from [`Self::morphed_stream`]), or this character's own positions
    /// and normals with `None`, at slot 0 (after [`Self::bind_geometry`]).
    pub fn bind_stream0<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, stream0: Option<&'a wgpu::Buffer>) {
        pass.set_vertex_buffer(0, stream0.unwrap_or(&self.stream0).slice(..));
    }

    /// True when this character has more bones than one GPU draw can skin.
    pub fn needs_cpu_skinning(&self) -> bool {
        self.bone_count > MAX_BONES
    }

    /// Uploads a pose: bone matrices for GPU skinning, or CPU-skinned vertices.
    pub fn set_pose(&mut self, queue: &wgpu::Queue, character: &Character, pose: &Pose, mode: SkinningMode) {
        let mode = if self.needs_cpu_skinning() {
            SkinningMode::Cpu
        } else {
            mode
        };
        let mut bones = Bones {
            m: [Mat4::IDENTITY.to_cols_array_2d(); MAX_BONES],
        };
        match mode {
            SkinningMode::Gpu => {
                for (dst, m) in bones.m.iter_mut().zip(&pose.skin_from_bind) {
                    *dst = m.to_cols_array_2d();
                }
                // Morph targets a clip moves change the bind-space vertices the shader skins.
                match crate::animation::morphed_bind(character, pose) {
                    Some((p, n)) => {
                        queue.write_buffer(&self.stream0, 0, bytemuck::cast_slice(&position_normals(&p, &n)));
                        self.stream0_skinned = true;
                    }
                    None if self.stream0_skinned => {
                        queue.write_buffer(&self.stream0, 0, bytemuck::cast_slice(&self.bind_pose));
                        self.stream0_skinned = false;
                    }
                    None => {}
                }
            }
            SkinningMode::Cpu => {
                let (p, n) = skin_vertices(character, pose);
                queue.write_buffer(&self.stream0, 0, bytemuck::cast_slice(&position_normals(&p, &n)));
                self.stream0_skinned = true;
            }
        }
        queue.write_buffer(&self.bones_buffer, 0, bytemuck::bytes_of(&bones));
    }

    /// Uploads the camera and shading for the next draw (the ground grid in metres).
    pub fn set_camera(&self, queue: &wgpu::Queue, camera: &Camera, aspect: f32, shading: Shading) {
        self.set_camera_with_grid(queue, camera, aspect, shading, 1.0);
    }

    /// [`Self::set_camera`] with the ground grid's cell `grid_cell` world units wide (lines
    /// every cell and every tenth of one; see [`grid_cell`]).
    pub fn set_camera_with_grid(
        &self,
        queue: &wgpu::Queue,
        camera: &Camera,
        aspect: f32,
        shading: Shading,
        grid_cell: f32,
    ) {
        let mut frame = frame_uniforms(camera, aspect, shading);
        frame.params[3] = if grid_cell.is_finite() && grid_cell > 0.0 {
            grid_cell
        } else {
            1.0
        };
        queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&frame));
    }
}
