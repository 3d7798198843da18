//! Batched part renders for the bake: for one view, every part at every frame (a tile per
//! part and frame), read back as one colour, one normal and one depth image. Where every
//! tile fits one render target within the device's texture limit, one pass draws them in
//! the images' own layout; otherwise (long clips, high resolutions, many parts) the tiles go
//! through a smaller target in batches and are copied into place.

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

    /// The part the whole character shows at a pixel of a frame: of the parts covering it,
    /// the nearest the camera (the lowest number on a tie, as the first drawn wins a depth
    /// test); `None` where no part covers it.
    pub fn front_part(&self, frame: usize, x: u32, y: u32) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for p in 0..self.parts {
            if self.covered(p, frame, x, y) {
                let d = self.depth_at(p, frame, x, y);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, p));
                }
            }
        }
        best.map(|(_, p)| p)
    }
}

/// Most pixels of the bake's part-render target (colour, normal and depth: 12 bytes each).
pub const MAX_TARGET_PIXELS: u64 = 32 << 20;

/// GPU state of a part-render batch: the merged part meshes and one bone buffer per frame.
pub struct PartRenderer {
    gpu: GpuCharacter,
    part_ranges: Vec<Vec<Submesh>>,
    camera_buffer: wgpu::Buffer,
    frame_groups: Vec<wgpu::BindGroup>,
    /// Per frame, the morphed bind-space vertices where a clip moves morph targets.
    frame_streams: Vec<Option<wgpu::Buffer>>,
    resolution: u32,
    target: RenderTarget,
    /// Tiles per row and rows of the target; `None`: the images' own layout (part column,
    /// frame row) in one pass.
    grid: Option<(u32, u32)>,
}

/// The target grid for `tiles` tiles of `resolution²` within a texture side of `max_side`:
/// `None` if the images' own layout (`parts × frames` tiles) fits, else tiles per row and
/// rows of a smaller target drawn in batches.
pub fn tile_grid(parts: u32, frames: u32, resolution: u32, max_side: u32) -> Option<(u32, u32)> {
    let (parts, frames, r) = (parts.max(1), frames.max(1), resolution.max(1));
    let fits = |cols: u32, rows: u32| {
        u64::from(cols) * u64::from(r) <= u64::from(max_side)
            && u64::from(rows) * u64::from(r) <= u64::from(max_side)
            && u64::from(cols) * u64::from(rows) * u64::from(r) * u64::from(r) <= MAX_TARGET_PIXELS
    };
    if fits(parts, frames) {
        return None;
    }
    let tiles = u64::from(parts) * u64::from(frames);
    let cols = (max_side / r).max(1).min(tiles.min(u64::from(u32::MAX)) as u32);
    let by_pixels = (MAX_TARGET_PIXELS / (u64::from(cols) * u64::from(r) * u64::from(r))).max(1);
    let rows = u64::from((max_side / r).max(1))
        .min(by_pixels)
        .min(tiles.div_ceil(u64::from(cols))) as u32;
    Some((cols, rows.max(1)))
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
        let max_side = device.limits().max_texture_dimension_2d;
        Self::with_max_side(
            renderer,
            device,
            queue,
            merged,
            part_ranges,
            poses,
            resolution,
            max_side,
        )
    }

    /// [`PartRenderer::new`] as if the device's largest texture side were `max_side` (at
    /// most the real one): a smaller side makes it draw in batches (tests of that path).
    #[allow(clippy::too_many_arguments)]
    pub fn with_max_side(
        renderer: &CharacterRenderer,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        merged: &Character,
        part_ranges: Vec<Vec<Submesh>>,
        poses: &[Pose],
        resolution: u32,
        max_side: u32,
    ) -> Self {
        let max_side = max_side.min(device.limits().max_texture_dimension_2d);
        let gpu = GpuCharacter::new(renderer, device, queue, merged);
        let camera_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bake camera"),
            size: std::mem::size_of::<polypostor_runtime::gpu::gpu_data::FrameUniforms>() as u64,
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
        let frame_streams = poses
            .iter()
            .map(|pose| GpuCharacter::morphed_stream(device, merged, pose))
            .collect();
        let parts = part_ranges.len().max(1) as u32;
        let frames = poses.len().max(1) as u32;
        let grid = tile_grid(parts, frames, resolution, max_side);
        let (cols, rows) = grid.unwrap_or((parts, frames));
        let target = RenderTarget::new(device, cols * resolution, rows * resolution);
        Self {
            gpu,
            part_ranges,
            camera_buffer,
            frame_groups,
            frame_streams,
            resolution,
            target,
            grid,
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
        let parts = self.part_ranges.len();
        let frames = self.frame_groups.len();
        let Some((cols, rows)) = self.grid else {
            // One pass in the images' own layout.
            let tiles: Vec<(usize, usize)> = (0..frames).flat_map(|f| (0..parts).map(move |p| (p, f))).collect();
            self.draw_tiles(renderer, device, queue, &tiles, |p, f| (p as u32, f as u32));
            return Ok(PartImages {
                resolution: self.resolution,
                parts,
                frames,
                color: self.target.read_color(device, queue)?,
                normal: self.target.read_normal(device, queue)?,
                depth: self.target.read_depth(device, queue)?,
            });
        };
        let r = self.resolution;
        let (w, h) = (parts as u32 * r, frames as u32 * r);
        let mut out = PartImages {
            resolution: r,
            parts,
            frames,
            color: image::RgbaImage::new(w, h),
            normal: image::RgbaImage::new(w, h),
            depth: DepthImage {
                width: w,
                height: h,
                data: vec![1.0; w as usize * h as usize],
            },
        };
        let all: Vec<(usize, usize)> = (0..frames).flat_map(|f| (0..parts).map(move |p| (p, f))).collect();
        for batch in all.chunks((cols * rows) as usize) {
            let slot = |k: usize| ((k as u32) % cols, (k as u32) / cols);
            let index: std::collections::HashMap<(usize, usize), usize> =
                batch.iter().enumerate().map(|(k, &t)| (t, k)).collect();
            self.draw_tiles(renderer, device, queue, batch, |p, f| slot(index[&(p, f)]));
            let color = self.target.read_color(device, queue)?;
            let normal = self.target.read_normal(device, queue)?;
            let depth = self.target.read_depth(device, queue)?;
            for (k, &(p, f)) in batch.iter().enumerate() {
                let (sx, sy) = slot(k);
                let (sx, sy) = (sx * r, sy * r);
                let (dx, dy) = out.tile_origin(p, f);
                for (dst, src) in [(&mut out.color, &color), (&mut out.normal, &normal)] {
                    let tile = image::imageops::crop_imm(src, sx, sy, r, r).to_image();
                    image::imageops::replace(dst, &tile, i64::from(dx), i64::from(dy));
                }
                for y in 0..r {
                    let from = ((sy + y) * depth.width + sx) as usize;
                    let to = ((dy + y) * w + dx) as usize;
                    out.depth.data[to..to + r as usize].copy_from_slice(&depth.data[from..from + r as usize]);
                }
            }
        }
        Ok(out)
    }

    /// Draws part `p` at frame `f` for every `(p, f)` of `tiles` into the target tile
    /// `slot(p, f)` (column, row), in one pass.
    fn draw_tiles(
        &self,
        renderer: &CharacterRenderer,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        tiles: &[(usize, usize)],
        slot: impl Fn(usize, usize) -> (u32, u32),
    ) {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("bake view"),
        });
        {
            let mut pass = self
                .target
                .begin_pass(&mut encoder, "bake parts", wgpu::Color::TRANSPARENT);
            pass.set_pipeline(renderer.pipeline());
            self.gpu.bind_geometry(&mut pass);
            let r = self.resolution;
            let mut bound = None;
            for &(p, f) in tiles {
                if bound != Some(f) {
                    pass.set_bind_group(0, &self.frame_groups[f], &[]);
                    self.gpu.bind_stream0(&mut pass, self.frame_streams[f].as_ref());
                    bound = Some(f);
                }
                let (col, row) = slot(p, f);
                pass.set_viewport((col * r) as f32, (row * r) as f32, r as f32, r as f32, 0.0, 1.0);
                pass.set_scissor_rect(col * r, row * r, r, r);
                self.gpu.draw_ranges(&mut pass, &self.part_ranges[p]);
            }
        }
        queue.submit([encoder.finish()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_grids_stay_within_the_texture_limit() {
        assert_eq!(tile_grid(5, 10, 128, 16384), None);
        for (parts, frames, r, side) in [
            (5, 129, 128, 16384),
            (5, 10, 2048, 16384),
            (20, 10, 2048, 16384),
            (5, 21, 1024, 8192),
            (1, 10_000, 128, 16384),
            (20, 10_000, 16, 2048),
        ] {
            let (c, rows) = tile_grid(parts, frames, r, side).expect("too big for one pass");
            assert!(c * r <= side && rows * r <= side, "{parts}×{frames} at {r}: {c}×{rows}");
            assert!(u64::from(c * rows) * u64::from(r * r) <= MAX_TARGET_PIXELS);
            assert!(c >= 1 && rows >= 1);
        }
    }
}
