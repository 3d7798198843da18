//! Batched part renders for the bake: for one view, every part at every frame in one render
//! pass (a tile per part and frame), read back as one colour, one normal and one depth image.

use wgpu::util::DeviceExt;

use super::character_renderer::{bones_uniforms, frame_uniforms};
use super::{Camera, CharacterRenderer, DepthImage, GpuCharacter, GpuError, RenderTarget, Shading};
use crate::animation::Pose;
use crate::character::{Character, Submesh};

/// One view's renders: tiles of `resolution²` pixels, part `p` at column `p`, frame `f` at
/// row `f`.
pub struct PartImages {
    pub resolution: u32,
    pub parts: usize,
    pub frames: usize,
    pub color: image::RgbaImage,
    pub normal: image::RgbaImage,
    pub depth: DepthImage,
}

impl PartImages {
    /// Top-left pixel of a tile.
    pub fn tile_origin(&self, part: usize, frame: usize) -> (u32, u32) {
        (part as u32 * self.resolution, frame as u32 * self.resolution)
    }

    /// A tile of an RGBA image as its own image.
    pub fn tile(&self, img: &image::RgbaImage, part: usize, frame: usize) -> image::RgbaImage {
        let (x, y) = self.tile_origin(part, frame);
        image::imageops::crop_imm(img, x, y, self.resolution, self.resolution).to_image()
    }

    /// Depth of one pixel of a tile (1.0 where the part does not cover it).
    pub fn depth_at(&self, part: usize, frame: usize, x: u32, y: u32) -> f32 {
        let (ox, oy) = self.tile_origin(part, frame);
        self.depth.data[((oy + y) * self.depth.width + ox + x) as usize]
    }

    /// Coverage of a tile pixel (the normal image's alpha).
    pub fn covered(&self, part: usize, frame: usize, x: u32, y: u32) -> bool {
        let (ox, oy) = self.tile_origin(part, frame);
        self.normal.get_pixel(ox + x, oy + y)[3] > 127
    }
}

/// GPU state of a part-render batch: the merged part meshes and one bone buffer per frame.
pub struct PartRenderer {
    gpu: GpuCharacter,
    part_ranges: Vec<Vec<Submesh>>,
    camera_buffer: wgpu::Buffer,
    frame_groups: Vec<wgpu::BindGroup>,
    resolution: u32,
    target: RenderTarget,
}

impl PartRenderer {
    /// `merged` holds every part's triangles; `part_ranges[p]` are part `p`'s index ranges;
    /// `poses` are the frames.
    pub fn new(
        renderer: &CharacterRenderer,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        merged: &Character,
        part_ranges: Vec<Vec<Submesh>>,
        poses: &[Pose],
        resolution: u32,
    ) -> Self {
        let gpu = GpuCharacter::new(renderer, device, queue, merged);
        let camera_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bake camera"),
            size: std::mem::size_of::<super::gpu_data::FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_groups = poses
            .iter()
            .map(|pose| {
                let bones = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("bake bones"),
                    contents: bytemuck::bytes_of(&bones_uniforms(pose)),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                renderer.frame_group(device, &camera_buffer, &bones)
            })
            .collect();
        let parts = part_ranges.len().max(1) as u32;
        let target = RenderTarget::new(device, parts * resolution, poses.len().max(1) as u32 * resolution);
        Self {
            gpu,
            part_ranges,
            camera_buffer,
            frame_groups,
            resolution,
            target,
        }
    }

    /// Renders every part at every frame through `camera` (unlit base colour) and reads the
    /// images back.
    pub fn render_view(
        &self,
        renderer: &CharacterRenderer,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        camera: &Camera,
    ) -> Result<PartImages, GpuError> {
        queue.write_buffer(
            &self.camera_buffer,
            0,
            bytemuck::bytes_of(&frame_uniforms(camera, 1.0, Shading::Unlit)),
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("bake view"),
        });
        {
            let mut pass = self
                .target
                .begin_pass(&mut encoder, "bake parts", wgpu::Color::TRANSPARENT);
            pass.set_pipeline(renderer.pipeline());
            self.gpu.bind_geometry(&mut pass);
            let r = self.resolution as f32;
            for (f, group) in self.frame_groups.iter().enumerate() {
                pass.set_bind_group(0, group, &[]);
                for (p, ranges) in self.part_ranges.iter().enumerate() {
                    pass.set_viewport(p as f32 * r, f as f32 * r, r, r, 0.0, 1.0);
                    pass.set_scissor_rect(
                        p as u32 * self.resolution,
                        f as u32 * self.resolution,
                        self.resolution,
                        self.resolution,
                    );
                    self.gpu.draw_ranges(&mut pass, ranges);
                }
            }
        }
        queue.submit([encoder.finish()]);
        Ok(PartImages {
            resolution: self.resolution,
            parts: self.part_ranges.len(),
            frames: self.frame_groups.len(),
            color: self.target.read_color(device, queue)?,
            normal: self.target.read_normal(device, queue)?,
            depth: self.target.read_depth(device, queue)?,
        })
    }
}
