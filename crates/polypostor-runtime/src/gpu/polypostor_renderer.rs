//! The Polypostor crowd renderer: every character drawn from a pack, instances sorted by view
//! and one indexed instanced draw per view in use (`shaders/polypostor.wgsl`). Per instance: position, facing, view, frame and blend, variant
//! ([`crate::records::Instance`]). The pack's geometry stays in its 16-bit form on the GPU; the
//! views' atlases are layers of one texture array.

use wgpu::util::DeviceExt;

use super::inputs::PolypostorInput;
use super::{GpuError, RenderTarget, shaders};
use crate::records::Instance;
use crate::texture::BcFormat;

/// Per-frame settings of the draw (keep in sync with `Frame` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameUniform {
    clip_from_world: [[f32; 4]; 4],
    light_dir: [f32; 4],
    counts: [f32; 4],
    params: [f32; 4],
    bases: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewGpu {
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    center: [f32; 4],
    uv_scale: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PartGpu {
    /// First u32 of the key's vertex block.
    vertex_word: u32,
    /// Low 16 bits vertices, high 16 bits the body part.
    vertex_count: u32,
    view: u32,
    /// Bits 0-7 drawing slot, 8-15 this record's key, 16-23 the part's keys.
    slot_key: u32,
    /// Low 16 bits the block's first frame, high 16 bits its frames.
    frames: u32,
    /// First u32 of the part's per-frame key table in the geometry buffer.
    key_table: u32,
    /// The block's position box ([`crate::quant::PositionBox`]): lower corner x, y as
    /// unorm16 values, then its size.
    box_lo: u32,
    box_size: u32,
}

/// How a frame of polypostors is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolypostorStyle {
    /// Lit with the normal atlas (false: the atlas colour as it is).
    pub lit: bool,
    /// Share of the colour kept where the surface faces away from the light, 0 to 1 (the rest
    /// follows `n·l`); unused when not `lit`. Default value: 0.35.
    pub ambient: f32,
    /// Per-part colour variation per instance, 0 (none) to 1.
    pub tint: f32,
    /// Unit direction towards the light, world space.
    pub light_dir: glam::Vec3,
}

impl Default for PolypostorStyle {
    fn default() -> Self {
        Self {
            lit: true,
            ambient: 0.35,
            tint: 0.5,
            light_dir: glam::Vec3::new(0.4, 0.8, 0.45).normalize(),
        }
    }
}

/// A pack on the GPU, ready to draw any number of instances.
pub struct GpuPolypostors {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    frame: wgpu::Buffer,
    views: wgpu::Buffer,
    parts: wgpu::Buffer,
    geometry: wgpu::Buffer,
    instances: wgpu::Buffer,
    instance_capacity: usize,
    atlas_view: wgpu::TextureView,
    normal_view: wgpu::TextureView,
    sampler: wgpu::Sampler,
    bind_group: wgpu::BindGroup,
    parts_per_view: u32,
    frames: u32,
    view_count: u32,
    index_buffer: wgpu::Buffer,
    /// Each view's range of `index_buffer`.
    view_ranges: Vec<std::ops::Range<u32>>,
    /// Each view's coarse ranges of `index_buffer`: the pack's coarse level (else every other
    /// polygon vertex), then every fourth vertex.
    coarse_ranges: [Vec<std::ops::Range<u32>>; 2],
    /// Instances per (view, level) bucket after [`GpuPolypostors::prepare`] sorted them.
    view_instances: Vec<std::ops::Range<u32>>,
    keyed: Vec<Instance>,
    /// Characters shorter than `coarse_below[0]` on screen (NDC units, the screen height
    /// being 2) get the pack's coarse level (the polygon simplified on to half its vertices;
    /// every other vertex for packs without one), shorter than `coarse_below[1]` the triangles
    /// over every fourth vertex. Default value: [0.25, 0.08] (about 90 and 29 pixels at 720p,
    /// under the 128² bake's size: measured on the default character's 40-vertex polygons,
    /// their coarse level's outline stays within a few tenths of a pixel there and the crowd
    /// of 10,000 draws 1.4× faster on llvmpipe); 0 turns a level off.
    pub coarse_below: [f32; 2],
    sorted: Vec<Instance>,
    /// Bytes of GPU memory this pack holds (buffers and textures, instances excluded).
    pub gpu_bytes: u64,
    /// Depth offset between consecutive parts (world units).
    pub depth_step: f32,
    /// Half the character's framing (the largest view's half size): its screen height test.
    half_height: f32,
}

impl GpuPolypostors {
    /// Uploads `pack`: per key block its UVs as 16-bit pairs and its positions as bytes inside
    /// the block's box ([`crate::quant`], what a format-7 pack stores), the parts'
    /// records and per-frame key tables, per view the full and two coarse index lists, and the
    /// views' colour and normal atlases shelf-packed into the layers of two texture arrays.
    /// [`GpuError::Unsupported`] when the pack has no views, more than 255 parts or 65536 part
    /// records, a vertex block past the vertex data, or atlases past this GPU's texture limits.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, input: &PolypostorInput) -> Result<Self, GpuError> {
        let m = input;
        let parts_per_view = m.part_count.max(1) as u32;
        let view_count = m.views.len() as u32;
        if view_count == 0 {
            return Err(GpuError::Unsupported("the pack has no views".into()));
        }
        let limits = device.limits();
        // Every view's atlas shelf-packed into shared pages (layers of one texture array).
        let sizes: Vec<[u32; 2]> = m.views.iter().map(|v| v.atlas_size).collect();
        let pages = atlas_pages(&sizes, limits.max_texture_dimension_2d.min(8192)).ok_or_else(|| {
            GpuError::Unsupported(format!(
                "a view atlas is larger than this GPU's {}-pixel texture limit",
                limits.max_texture_dimension_2d
            ))
        })?;
        if pages.count > limits.max_texture_array_layers {
            return Err(GpuError::Unsupported(format!(
                "the pack's atlases need {} pages; this GPU holds at most {} texture layers",
                pages.count, limits.max_texture_array_layers
            )));
        }
        // Geometry: per key block its UVs (an x, y pair of unorm16 in one u32 per vertex),
        // then per frame its positions as bytes inside the block's box (two vertices a u32,
        // each frame's run whole words); the per-frame key tables follow.
        let mut geometry: Vec<u32> = Vec::new();
        if parts_per_view > 255 {
            return Err(GpuError::Unsupported(format!(
                "the pack has {parts_per_view} parts; this renderer draws at most 255"
            )));
        }
        let frames = m.frames.max(1);
        // Per-frame key tables (4 frames a word), placed after the vertex data at the end.
        let mut tables: Vec<u32> = Vec::new();
        let mut views = Vec::with_capacity(m.views.len());
        let mut parts: Vec<PartGpu> = Vec::with_capacity(m.views.len() * parts_per_view as usize);
        // Per view, its parts' triangles in drawing order (every key image of a part in turn);
        // each index is the part record (high 16 bits) and the vertex in it (low 16 bits).
        let mut index_words: Vec<u32> = Vec::new();
        let mut view_ranges: Vec<std::ops::Range<u32>> = Vec::with_capacity(m.views.len());
        // The same with every other polygon vertex (about half the triangles), for characters
        // a few dozen pixels tall, and with every fourth for those about a dozen.
        let mut coarse_words: [Vec<u32>; 2] = Default::default();
        let mut coarse_ranges: [Vec<std::ops::Range<u32>>; 2] = Default::default();
        let page = pages.size as f32;
        for (vi, v) in m.views.iter().enumerate() {
            let c = &v.frame;
            let [ox, oy, layer] = pages.place[vi];
            let four = |a: [f32; 3], w: f32| [a[0], a[1], a[2], w];
            views.push(ViewGpu {
                right: four(c.right, 0.0),
                up: four(c.up, 0.0),
                forward: four(c.forward, layer as f32),
                center: four(c.center, c.half_size),
                uv_scale: [
                    v.atlas_size[0] as f32 / page,
                    v.atlas_size[1] as f32 / page,
                    ox as f32 / page,
                    oy as f32 / page,
                ],
            });
            let view_start = index_words.len() as u32;
            let coarse_start = coarse_words.each_ref().map(|w| w.len() as u32);
            for (s, &id) in v.order.iter().enumerate().take(parts_per_view as usize) {
                let Some(p) = v.parts.get(id as usize).and_then(|p| p.as_ref()) else {
                    continue;
                };
                // The part's key images: its first (every frame), then the extra ones.
                let blocks = &p.keys;
                let keys = if p.frame_keys.len() == frames as usize {
                    blocks.len().min(255)
                } else {
                    1
                };
                let key_table = tables.len() as u32;
                if keys > 1 {
                    tables.extend(
                        p.frame_keys
                            .chunks(4)
                            .map(|c| c.iter().enumerate().fold(0u32, |w, (i, &k)| w | (k as u32) << (8 * i))),
                    );
                }
                for (k, block) in blocks.iter().enumerate().take(keys) {
                    let (offset, count, block_frames) = (block.vertex_offset, block.vertex_count, block.frame_count);
                    let (index_offset, index_count, start) = (block.index_offset, block.index_count, block.frame_start);
                    let vc = count.clamp(1, 0xffff) as usize;
                    let Some((vertex_word, bx)) = push_block(&mut geometry, input.vertices, offset, vc, block_frames)
                    else {
                        return Err(GpuError::Unsupported(format!(
                            "view {vi} part {id} key {k}: its vertex block lies past the vertex data"
                        )));
                    };
                    let record = PartGpu {
                        vertex_word,
                        vertex_count: count.clamp(1, 0xffff) | (id.min(0xffff) << 16),
                        view: vi as u32,
                        slot_key: s as u32 | (k as u32) << 8 | (keys as u32) << 16,
                        frames: start.min(0xffff) | block_frames.clamp(1, 0xffff) << 16,
                        key_table,
                        box_lo: u32::from(bx.lo[0]) | u32::from(bx.lo[1]) << 16,
                        box_size: u32::from(bx.size[0]) | u32::from(bx.size[1]) << 16,
                    };
                    let id_record = parts.len() as u32;
                    parts.push(record);
                    if index_count == 0 || id_record > 0xffff {
                        continue;
                    }
                    let start = index_offset as usize;
                    let list = input.indices.get(start..start + index_count as usize).unwrap_or(&[]);
                    index_words.extend(list.iter().map(|&i| id_record << 16 | i as u32));
                    let base = offset as usize;
                    let uvs = input.vertices.get(base..base + 2 * vc).unwrap_or(&[]);
                    // The first coarse level is the pack's (the polygon simplified to half its
                    // vertices by the bake's rule) where it has one, else every other vertex;
                    // the second every fourth. A part too small to thin keeps the previous
                    // level's triangles.
                    let cstart = block.coarse_index_offset as usize;
                    let packed = input
                        .indices
                        .get(cstart..cstart + block.coarse_index_count as usize)
                        .filter(|c| !c.is_empty() && c.iter().all(|&i| usize::from(i) < vc));
                    let mut previous: Vec<u32> = list.iter().map(|&i| i as u32).collect();
                    // Thinning takes the outline's vertices only (a polygon's interior
                    // vertices follow its outline's in the block).
                    let outline = &uvs[..2 * crate::triangulate::outline_len(list, vc)];
                    for (level, words) in coarse_words.iter_mut().enumerate() {
                        let tris = match packed {
                            Some(c) if level == 0 => Some(c.iter().map(|&i| u32::from(i)).collect()),
                            _ => coarse_triangles(outline, 2 << level),
                        };
                        if let Some(tris) = tris {
                            previous = tris;
                        }
                        words.extend(previous.iter().map(|&i| id_record << 16 | i));
                    }
                }
            }
            view_ranges.push(view_start..index_words.len() as u32);
            for level in 0..2 {
                coarse_ranges[level].push(coarse_start[level]..coarse_words[level].len() as u32);
            }
        }
        let table_base = geometry.len() as u32;
        for p in &mut parts {
            p.key_table += table_base;
        }
        geometry.extend_from_slice(&tables);
        geometry.push(0);
        if parts.is_empty() {
            parts.push(bytemuck::Zeroable::zeroed());
        }
        // One index buffer: the full lists, then the coarse ones.
        for level in 0..2 {
            let shift = index_words.len() as u32;
            index_words.extend_from_slice(&coarse_words[level]);
            for r in &mut coarse_ranges[level] {
                *r = r.start + shift..r.end + shift;
            }
        }
        if parts.len() > 0x10000 {
            return Err(GpuError::Unsupported(format!(
                "the pack has {} part records (one per key image); this renderer addresses at most 65536",
                parts.len()
            )));
        }
        index_words.push(0);
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("polypostor indices"),
            contents: bytemuck::cast_slice(&index_words),
            usage: wgpu::BufferUsages::INDEX,
        });
        let storage = |label, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let views_buf = storage("polypostor views", bytemuck::cast_slice(&views));
        let parts_buf = storage("polypostor parts", bytemuck::cast_slice(&parts));
        let geometry_buf = storage("polypostor geometry", bytemuck::cast_slice(&geometry));
        let array =
            |label, w: u32, h: u32, format| super::upload::array_texture(device, label, (w, h), pages.count, format);
        let (pw, nw) = (pages.size, (pages.size / 2).max(1));
        // BC7 pages where the pack stores its atlases so and the device samples BC7; else
        // RGBA8 from the decoded atlases.
        let bc = super::upload::samples_bc(device)
            && input
                .views
                .iter()
                .all(|v| v.atlas_blocks.is_some() && v.normal_blocks.is_some());
        let (color_format, normal_format) = if bc {
            (BcFormat::Bc7Srgb.wgpu_format(), BcFormat::Bc7Unorm.wgpu_format())
        } else {
            (BcFormat::Bc7Srgb.rgba8_format(), BcFormat::Bc7Unorm.rgba8_format())
        };
        let atlas = array("polypostor atlases", pw, pw, color_format);
        let normals = array("polypostor normal atlases", nw, nw, normal_format);
        for (vi, view) in input.views.iter().enumerate() {
            let [ox, oy, layer] = pages.place[vi];
            let uploads = [
                (&atlas, view.atlas, view.atlas_blocks, 0),
                (&normals, view.normals, view.normal_blocks, 1),
            ];
            for (texture, img, blocks, shift) in uploads {
                if img.width() == 0 || img.height() == 0 {
                    continue;
                }
                let origin = wgpu::Origin3d {
                    x: ox >> shift,
                    y: oy >> shift,
                    z: layer,
                };
                super::upload::write_image(queue, texture, origin, img, blocks, bc);
            }
        }
        let texel_bytes = super::upload::texel_bytes(bc);
        let gpu_bytes = (views.len() * std::mem::size_of::<ViewGpu>()
            + parts.len() * std::mem::size_of::<PartGpu>()
            + geometry.len() * 4
            + index_words.len() * 4) as u64
            + texel_bytes * pages.count as u64 * (pw as u64 * pw as u64 + nw as u64 * nw as u64);
        use super::crowd_renderers::{Entry, clamp_sampler, layout as bind_layout, pipeline as crowd_pipeline};
        let frame = super::crowd_renderers::uniform_buffer(device, "polypostor frame");
        let layout = bind_layout(
            device,
            "polypostor",
            &[
                Entry::Uniform,
                Entry::Storage,
                Entry::Storage,
                Entry::Storage,
                Entry::Storage,
                Entry::TextureArray,
                Entry::TextureArray,
                Entry::Sampler,
            ],
        );
        let pipeline = crowd_pipeline(device, "polypostor", &[&layout], shaders::POLYPOSTOR, "vs_main", &[]);
        let sampler = clamp_sampler(device, "polypostor atlas");
        let atlas_view = atlas.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let normal_view = normals.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let instance_capacity = 1024;
        let instances = Self::instance_buffer(device, instance_capacity);
        let bind_group = Self::bind(
            device,
            &layout,
            [&frame, &views_buf, &parts_buf, &geometry_buf, &instances],
            &atlas_view,
            &normal_view,
            &sampler,
        );
        // A thousandth of the character's framing per part: far below what the eye sees,
        // far above depth precision at crowd distances.
        let depth_step = m.views.iter().map(|v| v.frame.half_size).fold(0.0f32, f32::max) * 2e-3;
        Ok(Self {
            pipeline,
            layout,
            frame,
            views: views_buf,
            parts: parts_buf,
            geometry: geometry_buf,
            instances,
            instance_capacity,
            atlas_view,
            normal_view,
            sampler,
            bind_group,
            parts_per_view,
            frames: m.frames.max(1),
            view_count,
            index_buffer,
            view_instances: vec![0..0; 2 * view_ranges.len()],
            view_ranges,
            coarse_ranges,
            keyed: Vec::new(),
            coarse_below: [0.25, 0.08],
            sorted: Vec::new(),
            gpu_bytes,
            depth_step,
            half_height: m.views.iter().map(|v| v.frame.half_size).fold(0.0f32, f32::max),
        })
    }

    fn instance_buffer(device: &wgpu::Device, capacity: usize) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("polypostor instances"),
            size: (capacity.max(1) * std::mem::size_of::<Instance>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        buffers: [&wgpu::Buffer; 5],
        atlas: &wgpu::TextureView,
        normals: &wgpu::TextureView,
        sampler: &wgpu::Sampler,
    ) -> wgpu::BindGroup {
        use super::crowd_renderers::Resource;
        let mut r: Vec<Resource> = buffers.iter().map(|b| Resource::Buffer(b)).collect();
        r.extend([
            Resource::View(atlas),
            Resource::View(normals),
            Resource::Sampler(sampler),
        ]);
        super::crowd_renderers::bind(device, "polypostor", layout, &r)
    }

    /// Views in the pack.
    pub fn view_count(&self) -> usize {
        self.view_count as usize
    }

    /// Uploads this frame's instances (views out of range are clamped by the caller's
    /// [`crate::crowd::Crowd::select`], which only produces pack views) and settings.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        clip_from_world: glam::Mat4,
        style: &PolypostorStyle,
        instances: &[Instance],
    ) {
        if instances.len() > self.instance_capacity {
            self.instance_capacity = instances.len().next_power_of_two();
            self.instances = Self::instance_buffer(device, self.instance_capacity);
            self.bind_group = Self::bind(
                device,
                &self.layout,
                [&self.frame, &self.views, &self.parts, &self.geometry, &self.instances],
                &self.atlas_view,
                &self.normal_view,
                &self.sampler,
            );
        }
        // Sorted by view so each view is one indexed draw; views clamped and frames wrapped
        // so no instance indexes past the pack.
        // Bucket (view, level): the view's index range, full or coarse, is one draw each.
        let height = 2.0 * self.half_height;
        self.keyed.clear();
        self.keyed.extend(instances.iter().map(|i| {
            let foot = clip_from_world * glam::Vec4::new(i.pos[0], 0.0, i.pos[1], 1.0);
            let head = clip_from_world * glam::Vec4::new(i.pos[0], height, i.pos[1], 1.0);
            let tall = if foot.w > 1e-4 && head.w > 1e-4 {
                (head.y / head.w - foot.y / foot.w).abs()
            } else {
                f32::INFINITY
            };
            let level = (tall < self.coarse_below[0]) as u32 + (tall < self.coarse_below[1]) as u32;
            Instance {
                view: i.view.min(self.view_count - 1) * LEVELS + level,
                ..*i
            }
        }));
        crate::records::sort_by_view(
            &self.keyed,
            self.view_count * LEVELS,
            self.frames,
            &mut self.sorted,
            &mut self.view_instances,
        );
        if !self.sorted.is_empty() {
            queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&self.sorted));
        }
        let l = style.light_dir.normalize_or(glam::Vec3::Y);
        let uniform = FrameUniform {
            clip_from_world: clip_from_world.to_cols_array_2d(),
            light_dir: [l.x, l.y, l.z, 0.0],
            counts: [0.0, self.parts_per_view as f32, self.frames as f32, self.depth_step],
            params: [if style.lit { 1.0 } else { 0.0 }, style.ambient, style.tint, 0.0],
            bases: [0; 4],
        };
        queue.write_buffer(&self.frame, 0, bytemuck::bytes_of(&uniform));
    }

    /// Draws the instances uploaded by [`GpuPolypostors::prepare`] (`count` of them): one
    /// indexed instanced draw per view in use. Returns the draw calls made.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, count: usize) -> usize {
        if count == 0 {
            return 0;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_index_buffer(self.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        let mut calls = 0;
        for (v, fine) in self.view_ranges.iter().enumerate() {
            let lists = [fine, &self.coarse_ranges[0][v], &self.coarse_ranges[1][v]];
            for (level, indices) in lists.into_iter().enumerate() {
                let instances = &self.view_instances[LEVELS as usize * v + level];
                if instances.is_empty() || indices.is_empty() || instances.end as usize > count {
                    continue;
                }
                pass.draw_indexed(indices.clone(), 0, instances.clone());
                calls += 1;
            }
        }
        calls
    }

    /// Renders instances into `target` (cleared first), for tests and offscreen benchmarks.
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &RenderTarget,
        clip_from_world: glam::Mat4,
        style: &PolypostorStyle,
        instances: &[Instance],
    ) -> Result<(), GpuError> {
        self.prepare(device, queue, clip_from_world, style, instances);
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = target.begin_pass(&mut encoder, "polypostors", wgpu::Color::TRANSPARENT);
            self.draw(&mut pass, instances.len());
        }
        queue.submit([encoder.finish()]);
        Ok(())
    }
}

/// Index levels per view: the full triangles and two coarser lists.
const LEVELS: u32 = 3;

/// Triangles over every `step`-th vertex of a part's polygon (`uvs`: its vertices in order, x,
/// y interleaved, as in the pack), as local vertex numbers; `None` when fewer than 4 vertices
/// would remain or the thinned polygon is not simple (the caller keeps finer triangles).
/// Appends the GPU form of one key block (`vc` vertices, `frames` frames, at value `offset` of
/// `vertices`: UVs, then positions frame by frame) to `geometry`: a u32 per UV, then each
/// frame's positions as bytes of the block's box, two vertices a u32. Returns the block's
/// first word and its box; `None` when the block (at least one frame) runs past `vertices`.
fn push_block(
    geometry: &mut Vec<u32>,
    vertices: &[f32],
    offset: u64,
    vc: usize,
    frames: u32,
) -> Option<(u32, crate::quant::PositionBox)> {
    // At least one frame, as the shader reads it (`frames` in the part record is clamped so).
    let frames = frames.max(1) as usize;
    let start = usize::try_from(offset).ok()?;
    let end = start.checked_add(2 * vc * (1 + frames))?;
    let block = vertices.get(start..end)?;
    let (uvs, positions) = block.split_at(2 * vc);
    let word = geometry.len() as u32;
    let unorm = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
    geometry.extend(uvs.chunks_exact(2).map(|c| unorm(c[0]) | unorm(c[1]) << 16));
    let bx = crate::quant::PositionBox::around(positions);
    let bytes = bx.quantise_all(positions);
    for frame in bytes.chunks_exact(2 * vc) {
        geometry.extend(frame.chunks(4).map(|c| {
            c.iter()
                .enumerate()
                .fold(0u32, |w, (i, &b)| w | u32::from(b) << (8 * i))
        }));
    }
    Some((word, bx))
}

fn coarse_triangles(uvs: &[f32], step: usize) -> Option<Vec<u32>> {
    let points: Vec<[f32; 2]> = uvs.chunks_exact(2).map(|q| [q[0], q[1]]).collect();
    let tris = crate::triangulate::thinned(&points, step)?;
    Some(tris.iter().flatten().map(|&i| i as u32).collect())
}

/// Where each view's atlas lies in the shared pages.
#[derive(Debug)]
struct AtlasPages {
    /// Side of every (square) page, a multiple of [`PAGE_ALIGN`].
    size: u32,
    count: u32,
    /// Per view: x, y (multiples of [`PAGE_ALIGN`], so the half-size normal atlas lands on
    /// whole 4 × 4 blocks) and page.
    place: Vec<[u32; 3]>,
}

/// Places and page sides are multiples of this: BC7 atlases are copied block by block, the
/// normal atlas at half size.
const PAGE_ALIGN: u32 = 8;

/// Shelf-packs rectangles of `sizes` into as few square pages as fit: one page just large
/// enough when everything fits under `max_side`, else pages of `max_side`. A gutter of at
/// least 2 texels keeps filtering from reading a neighbour. `None` when one rectangle is
/// larger than `max_side`.
fn atlas_pages(sizes: &[[u32; 2]], max_side: u32) -> Option<AtlasPages> {
    const GUTTER: u32 = 2;
    let max_side = max_side & !(PAGE_ALIGN - 1);
    if sizes
        .iter()
        .any(|s| s[0] + GUTTER > max_side || s[1] + GUTTER > max_side)
    {
        return None;
    }
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse((sizes[i][1], sizes[i][0])));
    let pack = |side: u32| -> AtlasPages {
        let mut place = vec![[0u32; 3]; sizes.len()];
        let (mut x, mut y, mut shelf, mut page) = (0u32, 0u32, 0u32, 0u32);
        for &i in &order {
            let [w, h] = [
                sizes[i][0].next_multiple_of(PAGE_ALIGN),
                sizes[i][1].next_multiple_of(PAGE_ALIGN),
            ];
            if x + w > side {
                x = 0;
                y += shelf;
                shelf = 0;
            }
            if y + h > side {
                page += 1;
                x = 0;
                y = 0;
                shelf = 0;
            }
            place[i] = [x, y, page];
            x += (w + GUTTER).next_multiple_of(PAGE_ALIGN);
            shelf = shelf.max((h + GUTTER).next_multiple_of(PAGE_ALIGN));
        }
        AtlasPages {
            size: side,
            count: page + 1,
            place,
        }
    };
    let area: u64 = sizes
        .iter()
        .map(|s| (s[0] + GUTTER + PAGE_ALIGN) as u64 * (s[1] + GUTTER + PAGE_ALIGN) as u64)
        .sum();
    let mut side = (((area as f64).sqrt() * 1.05) as u32).max(PAGE_ALIGN);
    while side < max_side {
        side = side.next_multiple_of(PAGE_ALIGN);
        let p = pack(side);
        if p.count == 1 {
            return Some(p);
        }
        side += side / 16 + PAGE_ALIGN;
    }
    Some(pack(max_side))
}

#[cfg(test)]
mod tests {
    use super::atlas_pages;

    #[test]
    fn a_block_is_uvs_then_whole_words_of_position_bytes_per_frame() {
        // 3 vertices, 2 frames: 3 UV words, then 2 words a frame (two vertices a word).
        let uv = [0.0, 0.0, 1.0, 0.0, 0.5, 1.0];
        let f0 = [0.2, 0.2, 0.4, 0.2, 0.3, 0.4];
        let f1 = [0.25, 0.2, 0.45, 0.2, 0.35, 0.4];
        let values: Vec<f32> = uv.iter().chain(&f0).chain(&f1).copied().collect();
        let mut geometry = vec![7u32];
        let (word, bx) = super::push_block(&mut geometry, &values, 0, 3, 2).unwrap();
        assert_eq!(word, 1);
        assert_eq!(geometry.len(), 1 + 3 + 2 * 2);
        assert_eq!(geometry[1], 0);
        assert_eq!(geometry[2], 0xffff);
        // Every byte decodes to within half a step of its value.
        let bytes: Vec<u8> = geometry[4..].iter().flat_map(|w| w.to_le_bytes()).collect();
        let decoded: Vec<f32> = [&bytes[0..6], &bytes[8..14]]
            .into_iter()
            .flat_map(|b| bx.values(b).collect::<Vec<_>>())
            .collect();
        let err = bx.max_error();
        for (i, (a, b)) in f0.iter().chain(&f1).zip(&decoded).enumerate() {
            assert!((a - b).abs() <= err[i % 2] + 2.0 / 65535.0, "{a} vs {b}");
        }
        // No frames counts as one (as the shader reads it); a block past the data is refused.
        assert!(super::push_block(&mut geometry, &values, 0, 3, 0).is_some());
        assert!(super::push_block(&mut geometry, &values, 6, 3, 2).is_none());
    }

    #[test]
    fn the_outline_is_the_leading_vertices_on_one_triangle_edge() {
        // A square of four outline vertices and one in the middle (vertex 4).
        let fan: Vec<u16> = vec![0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4];
        assert_eq!(crate::triangulate::outline_len(&fan, 5), 4);
        // The outline alone: every vertex.
        assert_eq!(crate::triangulate::outline_len(&[0, 1, 2, 0, 2, 3], 4), 4);
        // A vertex inside numbered before the outline's: not read, every vertex thinned.
        let first: Vec<u16> = vec![1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1, 0];
        assert_eq!(crate::triangulate::outline_len(&first, 5), 5);
    }

    #[test]
    fn coarse_triangles_use_every_other_or_fourth_vertex() {
        // A 20-vertex star-ish polygon (simple): the coarse version has 10 vertices, 8
        // triangles, only even vertex numbers.
        let uv: Vec<f32> = (0..20)
            .flat_map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 20.0;
                let r = if k % 2 == 0 { 0.4 } else { 0.3 };
                [0.5 + r * a.cos(), 0.5 + r * a.sin()]
            })
            .collect();
        let t = super::coarse_triangles(&uv, 2).unwrap();
        assert_eq!(t.len(), 8 * 3);
        assert!(t.iter().all(|&i| i % 2 == 0 && i < 20));
        assert!(super::coarse_triangles(&uv[..10], 2).is_none(), "too small to thin");
        // Every fourth: 5 vertices, 3 triangles, multiples of 4; 12 vertices are too few.
        let t = super::coarse_triangles(&uv, 4).unwrap();
        assert_eq!(t.len(), 3 * 3);
        assert!(t.iter().all(|&i| i % 4 == 0 && i < 20));
        assert!(super::coarse_triangles(&uv[..24], 4).is_none(), "too small to thin");
    }

    #[test]
    fn atlas_pages_never_overlap_and_stay_inside() {
        let sizes: Vec<[u32; 2]> = (0..137)
            .map(|i| [60 + (i * 37 % 90) * 2, 40 + (i * 53 % 70) * 2])
            .collect();
        for max in [8192, 1024, 512] {
            let p = atlas_pages(&sizes, max).unwrap();
            assert!(p.size <= max && p.size.is_multiple_of(super::PAGE_ALIGN));
            for (i, a) in p.place.iter().enumerate() {
                assert!(a[0].is_multiple_of(super::PAGE_ALIGN) && a[1].is_multiple_of(super::PAGE_ALIGN));
                assert!(a[0] + sizes[i][0] <= p.size && a[1] + sizes[i][1] <= p.size, "{a:?}");
                assert!(a[2] < p.count);
                for (j, b) in p.place.iter().enumerate().skip(i + 1) {
                    let apart = a[2] != b[2]
                        || a[0] + sizes[i][0] <= b[0]
                        || b[0] + sizes[j][0] <= a[0]
                        || a[1] + sizes[i][1] <= b[1]
                        || b[1] + sizes[j][1] <= a[1];
                    assert!(apart, "views {i} and {j} overlap");
                }
            }
            if max == 8192 {
                assert_eq!(p.count, 1);
                let used: u64 = sizes.iter().map(|s| s[0] as u64 * s[1] as u64).sum();
                assert!(
                    (p.size as u64).pow(2) < used * 2,
                    "one page, at most twice the atlases' area"
                );
            } else {
                assert!(p.count > 1);
            }
        }
        assert!(atlas_pages(&[[600, 10]], 512).is_none());
    }
}
