//! Image-based representations at crowd scale: classic impostors ([`GpuImpostors`]) and
//! NP3D impostors ([`GpuNp3d`]), both drawn from per-view images.

use super::*;

/// A view's camera for the image-based shaders (`View` in WGSL; the Polypostor renderer's
/// layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct ViewGpu {
    pub(super) right: [f32; 4],
    pub(super) up: [f32; 4],
    pub(super) forward: [f32; 4],
    pub(super) center: [f32; 4],
    pub(super) uv_scale: [f32; 4],
}

pub(super) fn views_gpu(views: &[ViewFrame]) -> Vec<ViewGpu> {
    views
        .iter()
        .map(|c| {
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

/// An image-based crowd renderer: per-frame uniforms, the baked views, instances, then its
/// own storage buffers, texture arrays and a sampler, bound in that order (the impostor and
/// NP3D shaders declare them so); one instanced draw.
pub(super) struct ImageCrowd {
    pub(super) pipeline: wgpu::RenderPipeline,
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) frame: wgpu::Buffer,
    pub(super) views: wgpu::Buffer,
    pub(super) instances: InstanceBuffer,
    pub(super) buffers: Vec<wgpu::Buffer>,
    pub(super) textures: Vec<wgpu::TextureView>,
    pub(super) sampler: wgpu::Sampler,
    pub(super) group: wgpu::BindGroup,
    pub(super) counts: [f32; 4],
    pub(super) bases: [u32; 4],
    pub(super) view_count: u32,
    pub(super) frames: u32,
    pub(super) vertices_per_instance: u32,
    /// Bytes of the views buffer.
    pub(super) views_bytes: u64,
}

impl ImageCrowd {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        device: &wgpu::Device,
        label: &str,
        shader: &str,
        (views, frames): (&[ViewFrame], u32),
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
        let view_count = views.len() as u32;
        let views_data = views_gpu(views);
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
            view_count,
            frames,
            vertices_per_instance,
            views_bytes: std::mem::size_of_val(views_data.as_slice()) as u64,
        }
    }

    pub(super) fn group(
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

    pub(super) fn prepare(
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
                frame: crate::records::wrap_frame_pair(i.frame, self.frames.max(1)),
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
    pub(super) fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, count: usize) -> usize {
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
    pub(super) base: ImageCrowd,
    /// Bytes on the GPU (sheets and views).
    pub gpu_bytes: u64,
    /// Per frame of the timeline, the tile drawn (sheets holding every other frame).
    pub(super) frame_map: Option<Vec<u32>>,
    pub(super) mapped: Vec<Instance>,
}

impl GpuImpostors {
    /// Impostors of the views `views` (at `frames` frames of the timeline) drawn from `data`
    /// (full-resolution sheets, or reduced ones). With `frame_map`, the sheets hold a subset of
    /// the frames ([`crate::reps::far_frames`]): it gives, per frame of the timeline, the tile
    /// drawn for it. [`GpuError::Unsupported`] when the map is empty or the sheets exceed this
    /// GPU's texture limits.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (views, frames): (&[ViewFrame], u32),
        data: &ImpostorData,
        frame_map: Option<Vec<u32>>,
    ) -> Result<Self, GpuError> {
        if frame_map.as_ref().is_some_and(|m| m.is_empty()) {
            return Err(GpuError::Unsupported(
                "impostor frame map: empty (it maps every frame of the timeline to a tile)".into(),
            ));
        }
        let tiles = match &frame_map {
            Some(m) => m.iter().copied().max().map_or(1, |x| x + 1),
            None => frames,
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
            &data.normal_blocks,
        )?;
        // The body part of each texel, exact and unfiltered, beside the normals (BC7 normals
        // cannot keep it).
        let (parts, pb) = part_array(device, queue, "impostor part sheets", &data.normal)?;
        let base = ImageCrowd::new(
            device,
            "impostors",
            shaders::IMPOSTOR,
            (views, tiles),
            Vec::new(),
            vec![color, normal, parts],
            [data.columns as f32, data.rows as f32, tiles as f32, 0.0],
            [0; 4],
            6,
        );
        Ok(Self {
            gpu_bytes: cb + nb + pb + base.views_bytes,
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
                    let (a, b) = crate::records::frame_pair_parts(i.frame);
                    Instance {
                        frame: crate::records::frame_pair(tile(a), tile(b)),
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
    pub(super) base: ImageCrowd,
    /// Bytes on the GPU (images, meshes, views).
    pub gpu_bytes: u64,
}

impl GpuNp3d {
    /// NP3D impostors of the views `views` (at `frames` frames, images taken at
    /// `key_frame`) from `data`; `vertex_parts`: the body part of each character vertex
    /// ([`vertex_parts`]).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (views, frames, key_frame): (&[ViewFrame], u32, u32),
        data: &Np3dData,
        vertex_parts: &[u32],
    ) -> Result<Self, GpuError> {
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
            &data.image_blocks,
        )?;
        let base = ImageCrowd::new(
            device,
            "np3d",
            shaders::NP3D,
            (views, frames),
            vec![vertices, topology],
            vec![images],
            [data.frames.vertex_count as f32, frames as f32, key_frame as f32, 0.0],
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
