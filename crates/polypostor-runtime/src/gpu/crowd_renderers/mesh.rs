//! Skinned and rigid meshes at crowd scale ([`GpuMeshCrowd`]).

use super::*;

/// Joint samples per baked frame for the skinned mesh (its animation is sampled 4× finer than
/// the image-based representations, then interpolated).
pub const JOINT_SAMPLES_PER_FRAME: usize = 4;

/// One joint sample: the first three rows of its skinning matrix (`skin_from_bind`), so any
/// affine transform is drawn as the real mesh draws it — mirrored rigs (a root scaled −1),
/// non-uniform scales (squash and stretch) and joints scaled to nothing (a hidden weapon)
/// included; a rotation and a uniform scale could not hold those.
pub type JointSample = [[f32; 4]; 3];

/// The joints at `per_frame` evenly spaced times in each frame of `timeline` (from the
/// frame's time to the next frame's, within its clip): per sample, per bone, the rows of its
/// skinning matrix (`JointSample`).
pub fn joint_samples(
    character: &Character,
    timeline: &crate::timeline::Timeline,
    per_frame: usize,
) -> Vec<JointSample> {
    let times = sample_times(timeline, per_frame);
    let mut out = Vec::with_capacity(times.len() * character.bones.len().max(1));
    for (clip, t0) in times {
        let pose = Pose::sample_index(character, clip, t0);
        if character.bones.is_empty() {
            out.push(rows(glam::Mat4::IDENTITY));
        }
        out.extend(pose.skin_from_bind.iter().map(|m| rows(*m)));
    }
    out
}

/// The clip and time of each of `per_frame` evenly spaced samples in each frame of
/// `timeline` (from the frame's time to the next frame's, within its clip).
fn sample_times(timeline: &crate::timeline::Timeline, per_frame: usize) -> Vec<(Option<usize>, f32)> {
    let per_frame = per_frame.max(1);
    // Per frame: its clip, its time, the step between its samples (its clip's frame spacing
    // over `per_frame`) and the latest time its samples may reach (a clip that does not loop
    // holds its last frame; sampling past its end would wrap to its start).
    let mut frames: Vec<(Option<usize>, f32, f32, f32)> = Vec::with_capacity(timeline.frames());
    for (s, &c) in timeline.spans.iter().zip(&timeline.clips) {
        let step = s.step(timeline.fps);
        let last = if s.looping {
            f32::INFINITY
        } else {
            s.clip_secs(s.frames.saturating_sub(1) as f32, timeline.fps)
        };
        frames.extend((0..s.frames).map(|k| (c, s.clip_secs(k as f32, timeline.fps), step / per_frame as f32, last)));
    }
    if frames.is_empty() {
        frames.push((None, 0.0, 0.0, 0.0));
    }
    frames
        .iter()
        .flat_map(|&(c, t, step, last)| (0..per_frame).map(move |k| (c, (t + k as f32 * step).min(last))))
        .collect()
}

/// At every joint sample of `timeline` ([`JOINT_SAMPLES_PER_FRAME`] a frame, as
/// [`joint_samples`]), per vertex, how far the clips' animated morph targets move the vertex
/// in bind space: the position offset (f32 bits) and half the normal's change (snorm8, in
/// `w`), as `vec4<u32>` (read by `vs_skinned` in `crowd_mesh.wgsl`). Empty for a character
/// without animated morphs (the shader then skins the vertices as they are).
pub fn morph_frames(character: &Character, timeline: &crate::timeline::Timeline) -> Vec<[u32; 4]> {
    if character.morphs.is_empty() {
        return Vec::new();
    }
    let times = sample_times(timeline, JOINT_SAMPLES_PER_FRAME);
    let mut out = Vec::with_capacity(times.len() * character.vertices.len());
    for (clip, t) in times {
        let pose = Pose::sample_index(character, clip, t);
        match crate::animation::morphed_bind(character, &pose) {
            Some((p, n)) => out.extend(character.vertices.iter().zip(p.iter().zip(&n)).map(|(v, (p, n))| {
                let d = *p - v.position;
                let dn = ((*n - v.normal) * 0.5).to_array();
                [d.x.to_bits(), d.y.to_bits(), d.z.to_bits(), pack_normal(dn)]
            })),
            None => out.extend(std::iter::repeat_n([0u32; 4], character.vertices.len())),
        }
    }
    out
}

/// The first three rows of an affine matrix.
fn rows(m: glam::Mat4) -> JointSample {
    let t = m.transpose();
    [t.x_axis.to_array(), t.y_axis.to_array(), t.z_axis.to_array()]
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

pub(super) fn mesh_groups(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frames: [&wgpu::Buffer; 2],
    joints: &wgpu::Buffer,
    instances: [&wgpu::Buffer; 2],
    rigid: &wgpu::Buffer,
    parts: &wgpu::Buffer,
    morph: &wgpu::Buffer,
) -> [wgpu::BindGroup; 2] {
    // Binding 3: the skinned level's morph frames, the rigid level's pre-skinned frames
    // (four storage buffers a stage is all some GPUs allow).
    let per_level = [morph, rigid];
    [0, 1].map(|k| {
        bind(
            device,
            "crowd meshes",
            layout,
            &[
                Resource::Buffer(frames[k]),
                Resource::Buffer(joints),
                Resource::Buffer(instances[k]),
                Resource::Buffer(per_level[k]),
                Resource::Buffer(parts),
            ],
        )
    })
}

/// Skinned and rigid meshes of one character.
pub struct GpuMeshCrowd {
    pub(super) character: GpuCharacter,
    pub(super) skinned: wgpu::RenderPipeline,
    pub(super) rigid: Option<wgpu::RenderPipeline>,
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) frame_skinned: wgpu::Buffer,
    pub(super) frame_rigid: wgpu::Buffer,
    pub(super) joints: wgpu::Buffer,
    pub(super) rigid_frames: wgpu::Buffer,
    pub(super) parts: wgpu::Buffer,
    /// [`morph_frames`] (a 16-byte placeholder without animated morphs).
    pub(super) morph: wgpu::Buffer,
    pub(super) instances: [InstanceBuffer; 2],
    pub(super) groups: [wgpu::BindGroup; 2],
    pub(super) counts: [f32; 4],
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
        // Only the bones that move a vertex: a rig's IK targets, poles and controls would
        // add a joint transform per sample each and draw nothing (293 unused joints made the
        // crowd's animation 23 times larger).
        let pruned = character.without_unused_bones();
        let character = pruned.as_ref().unwrap_or(character);
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
        // Sized before anything is made: more than one binding holds (a long timeline of a
        // dense mesh) leaves the skinned crowd in the rest shape (the bake and the reference
        // renders still play the morphs).
        let morph_bytes = (timeline.frames().max(1) as u64)
            .saturating_mul(JOINT_SAMPLES_PER_FRAME as u64)
            .saturating_mul(character.vertices.len() as u64)
            .saturating_mul(16);
        let morph_data = if character.morphs.is_empty() {
            Vec::new()
        } else if morph_bytes > u64::from(device.limits().max_storage_buffer_binding_size) {
            log::warn!(
                "the animated morph targets' {} frames × {} vertices exceed the GPU's storage binding limit; the skinned crowd draws the rest shape",
                timeline.frames(),
                character.vertices.len()
            );
            Vec::new()
        } else {
            morph_frames(character, timeline)
        };
        let morph = storage(device, "crowd morph frames", bytemuck::cast_slice(&morph_data));
        let parts_data = vertex_parts(character, triangle_labels);
        let parts = storage(device, "crowd vertex parts", bytemuck::cast_slice(&parts_data));
        let frame_skinned = uniform_buffer(device, "crowd skinned frame");
        let frame_rigid = uniform_buffer(device, "crowd rigid frame");
        let instances = [InstanceBuffer::new(device, 1024), InstanceBuffer::new(device, 1024)];
        let (texture, geometry) = crate::gpu::gpu_data::mesh_static_bytes(character);
        let static_bytes = texture + geometry + parts_data.len() as u64 * 4;
        let skinned_bytes = static_bytes
            + character.vertices.len() as u64 * 24
            + std::mem::size_of_val(samples.as_slice()) as u64
            + std::mem::size_of_val(morph_data.as_slice()) as u64;
        let rigid_bytes = static_bytes + rigid_data.len() as u64 * 16;
        let groups = mesh_groups(
            device,
            &layout,
            [&frame_skinned, &frame_rigid],
            &joints,
            [&instances[0].buffer, &instances[1].buffer],
            &rigid_frames,
            &parts,
            &morph,
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
            morph,
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
                &self.morph,
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

#[cfg(test)]
mod tests {
    use super::joint_samples;
    use crate::animation::Pose;

    #[test]
    fn joint_samples_follow_each_clip_and_hold_the_end_of_one_that_does_not_loop() {
        let c = crate::default_character::generate();
        let (walk, run) = (c.find_clip("Walk").unwrap(), c.find_clip("Run").unwrap());
        let mut t = crate::timeline::Timeline::new(&c, &[Some(walk), Some(run)], 10.0).unwrap();
        // The Run played once and held (as a clip that does not come back to its first pose).
        t.spans[1].looping = false;
        t.spans[1].secs_per_frame = 0.7 * 0.9999 / (t.spans[1].frames - 1) as f32;
        let per = 4;
        let s = joint_samples(&c, &t, per);
        let bones = c.bones.len();
        let at = |frame: usize, k: usize| &s[(frame * per + k) * bones..(frame * per + k + 1) * bones];
        let expect =
            |clip: usize, secs: f32| -> Vec<glam::Mat4> { Pose::sample(&c, &c.clips[clip], secs).skin_from_bind };
        // The rows read back as the matrix: its points land where the matrix puts them.
        let close = |got: &[super::JointSample], want: &[glam::Mat4]| {
            got.iter().zip(want).all(|(g, w)| {
                [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z, glam::Vec3::ONE]
                    .iter()
                    .all(|p| {
                        let q = w.transform_point3(*p);
                        (0..3).all(|r| {
                            let row = g[r];
                            (row[0] * p.x + row[1] * p.y + row[2] * p.z + row[3] - q[r]).abs() < 1e-5
                        })
                    })
            })
        };
        assert_eq!(s.len(), t.frames() * per * bones);
        // The Walk's samples a quarter frame apart, the Run's at its own spacing.
        assert!(close(at(3, 2), &expect(walk, 0.35)));
        let step = t.spans[1].secs_per_frame;
        assert!(close(at(10 + 2, 1), &expect(run, step * 2.25)));
        // The Run's last frame holds: every sample of it is its end pose, none wrapped to
        // the start.
        let last = 10 + t.spans[1].frames as usize - 1;
        let end = expect(run, step * (t.spans[1].frames - 1) as f32);
        for k in 0..per {
            assert!(close(at(last, k), &end), "sample {k} of the last frame");
        }
    }
}
