//! The 3D viewport: an orbit camera driven by the mouse, and an egui_wgpu paint callback
//! that renders the posed character offscreen with the library's renderer (in `prepare`)
//! and blits the image into the egui frame (in `paint`).

use std::sync::Arc;

use eframe::egui_wgpu;
use egui_wgpu::wgpu;
use glam::Vec3;
use polypostor::Character;
use polypostor::animation::Pose;
use polypostor::gpu::{
    Camera, CharacterRenderer, DrawOptions, GpuCharacter, RenderTarget, Shading, SkinningMode, shaders,
};

/// What the viewport shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMode {
    Lit,
    Albedo,
    Normals,
}

impl ViewMode {
    pub const ALL: [ViewMode; 3] = [ViewMode::Lit, ViewMode::Albedo, ViewMode::Normals];
    pub fn label(self) -> &'static str {
        match self {
            ViewMode::Lit => "Lit",
            ViewMode::Albedo => "Albedo",
            ViewMode::Normals => "Normals",
        }
    }
}

/// A Blender-style orbit camera: middle-drag (or left-drag) orbits, shift+middle-drag (or
/// right-drag) pans, the wheel zooms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    pub yaw_rad: f32,
    pub pitch_rad: f32,
    pub distance: f32,
    pub fov_y_rad: f32,
    /// The size of what is looked at (world units; 1 for a person): zoom stays within
    /// 0.001–100,000 of it, so a character a hundredth of a millimetre or kilometres across
    /// zooms as a person does.
    pub scale: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self {
            target: Vec3::new(0.0, 0.9, 0.0),
            yaw_rad: 0.5,
            pitch_rad: 0.15,
            distance: 3.5,
            fov_y_rad: 40f32.to_radians(),
            scale: 1.0,
        }
    }
}

impl OrbitCamera {
    /// Frames a bounding box, keeping the current direction.
    pub fn frame(&mut self, min: Vec3, max: Vec3) {
        self.target = (min + max) * 0.5;
        let radius = ((max - min) * 0.5).length().max(f32::MIN_POSITIVE);
        self.distance = radius / (self.fov_y_rad * 0.5).sin() * 1.1;
        self.scale = radius;
    }

    pub fn camera(&self) -> Camera {
        Camera::orbit(self.target, self.yaw_rad, self.pitch_rad, self.distance, self.fov_y_rad)
    }

    pub fn orbit(&mut self, delta_px: egui::Vec2) {
        self.yaw_rad -= delta_px.x * 0.008;
        self.pitch_rad = (self.pitch_rad + delta_px.y * 0.008).clamp(-1.55, 1.55);
    }

    pub fn pan(&mut self, delta_px: egui::Vec2, viewport_height_px: f32) {
        let cam = self.camera();
        let forward = (cam.target - cam.eye).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let world_per_px = 2.0 * self.distance * (self.fov_y_rad * 0.5).tan() / viewport_height_px.max(1.0);
        self.target += (-right * delta_px.x + up * delta_px.y) * world_per_px;
    }

    pub fn zoom(&mut self, wheel: f32) {
        let s = if self.scale.is_finite() && self.scale > 0.0 {
            self.scale
        } else {
            1.0
        };
        self.distance = (self.distance * (-wheel * 0.0015).exp()).clamp(1e-3 * s, 1e5 * s);
    }

    /// Applies the pointer input of the viewport's response; `primary_orbits` false leaves
    /// the left button to a tool.
    pub fn handle_input(&mut self, ui: &egui::Ui, response: &egui::Response, primary_orbits: bool) {
        let shift = ui.input(|i| i.modifiers.shift);
        let delta = response.drag_delta();
        if response.dragged_by(egui::PointerButton::Middle) {
            if shift {
                self.pan(delta, response.rect.height())
            } else {
                self.orbit(delta)
            }
        } else if primary_orbits && response.dragged_by(egui::PointerButton::Primary) {
            self.orbit(delta);
        } else if response.dragged_by(egui::PointerButton::Secondary) {
            self.pan(delta, response.rect.height());
        }
        if response.hovered() {
            let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if scroll != 0.0 {
                self.zoom(scroll);
            }
            if zoom != 1.0 {
                self.distance = (self.distance / zoom).clamp(0.05, 3000.0);
            }
        }
    }
}

/// GPU state of the viewport, kept in egui_wgpu's callback resources.
pub struct ViewportResources {
    renderer: CharacterRenderer,
    character: Option<(u64, GpuCharacter)>,
    target: Option<RenderTarget>,
    /// Shows an image as it is.
    blit_pipeline: wgpu::RenderPipeline,
    /// Shows a colour image sRGB-encoded, when the window is not sRGB and the targets have no
    /// raw-bytes view.
    encode_pipeline: Option<wgpu::RenderPipeline>,
    /// Whether colour targets are made with a raw-bytes view (a non-sRGB window that can).
    bytes_view: bool,
    blit_layout: wgpu::BindGroupLayout,
    blit_sampler: wgpu::Sampler,
    blit_groups: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    /// What the target holds now: a frame asking for the same image only blits it again
    /// (paused playback, a bake running, the mouse over a panel), which on a software
    /// rasteriser is most of the frame's cost saved.
    drawn: Option<Drawn>,
    /// The ground grid alone, and the camera it was drawn for: while only the pose changes
    /// (playback) each frame copies it and draws the character over it.
    backdrop: Option<(RenderTarget, Option<Camera>)>,
}

/// The inputs of the image in the viewport's target.
#[derive(PartialEq)]
struct Drawn {
    generation: u64,
    pose: Arc<Pose>,
    camera: Camera,
    size_px: [u32; 2],
    mode: ViewMode,
    grid: bool,
}

impl ViewportResources {
    /// Registers the viewport's resources with eframe's wgpu renderer. Returns the adapter
    /// description.
    pub fn install(render_state: &egui_wgpu::RenderState) -> String {
        let device = &render_state.device;
        let renderer = CharacterRenderer::new(device);
        let blit_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blit"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blit"),
            bind_group_layouts: &[Some(&blit_layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::BLIT.into()),
        });
        let pipeline = |entry_point: &'static str| {
            polypostor::gpu::fullscreen_pipeline(
                device,
                entry_point,
                &layout,
                &module,
                entry_point,
                render_state.target_format,
            )
        };
        let blit_pipeline = pipeline("fs_main");
        // A non-sRGB window shows the sRGB colour image through its raw-bytes view; where no
        // such view can be made (OpenGL), the blit encodes instead.
        let target_is_srgb = render_state.target_format.is_srgb();
        let bytes_view = !target_is_srgb && polypostor::gpu::view_formats_supported(&render_state.adapter);
        let encode_pipeline = (!target_is_srgb && !bytes_view).then(|| pipeline("fs_encode"));
        let blit_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("blit"),
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Nearest,
            ..Default::default()
        });
        let info = render_state.adapter.get_info();
        let adapter = format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type);
        render_state
            .renderer
            .write()
            .callback_resources
            .insert(ViewportResources {
                renderer,
                character: None,
                target: None,
                blit_pipeline,
                encode_pipeline,
                bytes_view,
                blit_layout,
                blit_sampler,
                blit_groups: None,
                drawn: None,
                backdrop: None,
            });
        adapter
    }
}

impl ViewportResources {
    /// A blit bind group showing `view` as it is.
    fn blit_group_of(&self, device: &wgpu::Device, view: &wgpu::TextureView) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blit"),
            layout: &self.blit_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.blit_sampler),
                },
            ],
        })
    }

    /// A render target for the viewport or the crowd preview: with a raw-bytes view of its
    /// colour when the blit wants one.
    pub fn new_target(&self, device: &wgpu::Device, width: u32, height: u32) -> RenderTarget {
        if self.bytes_view {
            RenderTarget::with_bytes_view(device, width, height)
        } else {
            RenderTarget::new(device, width, height)
        }
    }

    /// A blit bind group for a render target's colour image (made by [`Self::new_target`]):
    /// the view whose encoding matches the window's, so the blit copies texels without
    /// converting them where it can.
    pub fn blit_group(&self, device: &wgpu::Device, target: &RenderTarget) -> wgpu::BindGroup {
        let view = match &target.color_bytes_view {
            Some(bytes) if self.bytes_view => bytes,
            _ => &target.color_view,
        };
        self.blit_group_of(device, view)
    }

    /// Draws a full-viewport blit of `group`: a colour image's group from
    /// [`Self::blit_group`] when `color`, else an image shown as it is (the normals).
    pub fn blit(&self, pass: &mut wgpu::RenderPass<'static>, group: &wgpu::BindGroup, color: bool) {
        let pipeline = match &self.encode_pipeline {
            Some(encode) if color => encode,
            _ => &self.blit_pipeline,
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// One frame's draw request.
pub struct ViewportCallback {
    pub character: Arc<Character>,
    /// Changes whenever a different character is loaded.
    pub generation: u64,
    pub pose: Arc<Pose>,
    pub camera: Camera,
    pub size_px: [u32; 2],
    pub mode: ViewMode,
    pub grid: bool,
    /// The grid's cell in world units ([`polypostor::gpu::grid_cell`]).
    pub grid_cell: f32,
}

impl egui_wgpu::CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<ViewportResources>() else {
            return Vec::new();
        };
        if res.character.as_ref().map(|c| c.0) != Some(self.generation) {
            res.character = Some((
                self.generation,
                GpuCharacter::new(&res.renderer, device, queue, &self.character),
            ));
        }
        let [w, h] = [self.size_px[0].max(1), self.size_px[1].max(1)];
        if res.target.as_ref().is_none_or(|t| t.width != w || t.height != h) {
            let target = res.new_target(device, w, h);
            res.blit_groups = Some((
                res.blit_group(device, &target),
                res.blit_group_of(device, &target.normal_view),
            ));
            res.target = Some(target);
            res.drawn = None;
            res.backdrop = None;
        }
        let drawn = Drawn {
            generation: self.generation,
            pose: self.pose.clone(),
            camera: self.camera,
            size_px: [w, h],
            mode: self.mode,
            grid: self.grid,
        };
        if res.drawn.as_ref() == Some(&drawn) {
            return Vec::new();
        }
        res.drawn = Some(drawn);
        if self.grid && res.backdrop.is_none() {
            res.backdrop = Some((RenderTarget::new(device, w, h), None));
        }
        let (Some((_, gpu)), Some(target)) = (res.character.as_mut(), res.target.as_ref()) else {
            return Vec::new();
        };
        let shading = if self.mode == ViewMode::Albedo {
            Shading::Unlit
        } else {
            Shading::Lit
        };
        gpu.set_pose(queue, &self.character, &self.pose, SkinningMode::Gpu);
        gpu.set_camera_with_grid(queue, &self.camera, w as f32 / h as f32, shading, self.grid_cell);
        let options = DrawOptions {
            shading,
            clear_color: [0.045, 0.05, 0.06, 1.0],
            grid: self.grid,
        };
        match res.backdrop.as_mut().filter(|_| self.grid) {
            Some((backdrop, drawn_for)) => {
                if *drawn_for != Some(self.camera) {
                    res.renderer.encode_backdrop(encoder, backdrop, gpu, &options);
                    *drawn_for = Some(self.camera);
                }
                res.renderer.encode_over(encoder, target, backdrop, gpu);
            }
            None => res.renderer.encode(encoder, target, gpu, &options),
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else {
            return;
        };
        let Some((color, normal)) = &res.blit_groups else {
            return;
        };
        if res.target.is_none() {
            return;
        }
        let normals = self.mode == ViewMode::Normals;
        res.blit(pass, if normals { normal } else { color }, !normals);
    }
}

#[cfg(test)]
mod zoom_tests {
    use super::*;

    /// Zooming reaches as close and as far relative to a framed character of any size: a
    /// character 0.02 mm across can be looked at from its own scale, one of 100 km from far
    /// enough to see it whole (the zoom had absolute limits of 1 mm and 100 km).
    #[test]
    fn zoom_limits_follow_the_framed_size() {
        let mut seen = Vec::new();
        for k in [1e-5f32, 1.0, 1e5] {
            let mut cam = OrbitCamera::default();
            cam.frame(Vec3::splat(-0.9 * k), Vec3::splat(0.9 * k));
            let framed = cam.distance;
            for _ in 0..200 {
                cam.zoom(500.0);
            }
            let nearest = cam.distance / framed;
            for _ in 0..400 {
                cam.zoom(-500.0);
            }
            let farthest = cam.distance / framed;
            assert!(
                nearest < 0.01 && farthest > 1000.0,
                "scale {k}: {nearest} .. {farthest}"
            );
            seen.push((nearest, farthest));
        }
        for w in seen.windows(2) {
            assert!(
                (w[0].0 / w[1].0 - 1.0).abs() < 1e-3 && (w[0].1 / w[1].1 - 1.0).abs() < 1e-3,
                "{seen:?}"
            );
        }
    }
}
