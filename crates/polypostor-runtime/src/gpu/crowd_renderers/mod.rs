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
use super::inputs::{CrowdInputs, FrameVertices, ImpostorData, Np3dData, ViewFrame};
use super::{CharacterRenderer, GpuCharacter, GpuError, GpuPolypostors, PolypostorStyle, RenderTarget, shaders};
use crate::animation::Pose;
use crate::character::Character;
use crate::records::Instance;
use crate::records::Level;

mod images;
mod mesh;
mod plumbing;

pub use images::{GpuImpostors, GpuNp3d};
pub use mesh::{GpuMeshCrowd, JOINT_SAMPLES_PER_FRAME, joint_samples, vertex_parts};
use plumbing::*;
pub(in crate::gpu) use plumbing::{
    Entry, Resource, array_layers, bind, clamp_sampler, layout, pipeline, uniform_buffer,
};

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
    /// Builds what `inputs` hold: meshes always (skinned; rigid where given, for this
    /// character and timeline), the Polypostor, impostors (full-resolution and far) and NP3D
    /// where given ([`crate::scene::crowd_inputs`] makes them from a baked folder).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        character: &Character,
        timeline: &crate::timeline::Timeline,
        triangle_labels: &[u32],
        inputs: &CrowdInputs,
    ) -> Result<Self, GpuError> {
        let timing = inputs.timing;
        let rigid = inputs
            .rigid
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
        let views = (&inputs.views[..], timing.frames as u32);
        Ok(Self {
            meshes,
            polypostor: inputs
                .polypostor
                .as_ref()
                .map(|p| GpuPolypostors::new(device, queue, p))
                .transpose()?,
            impostor: inputs
                .impostor
                .map(|d| GpuImpostors::new(device, queue, views, d, None))
                .transpose()?,
            far_impostor: inputs
                .far_impostor
                .as_ref()
                .map(|(d, map)| GpuImpostors::new(device, queue, views, d, map.clone()))
                .transpose()?,
            use_far_impostors: false,
            np3d: inputs
                .np3d
                .map(|d| GpuNp3d::new(device, queue, (views.0, views.1, inputs.key_frame), d, &parts))
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
                self.ground_scale.max(f32::MIN_POSITIVE),
                crate::gpu::grid_cell(self.ground_scale),
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
