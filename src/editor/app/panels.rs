//! The window's panels: menu bar, status bar, timeline, side panel tabs, log, the 3D
//! viewport, and the keyboard shortcuts.

use super::*;

impl EditorApp {
    pub(super) fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let typing = ctx.egui_wants_keyboard_input();
        let (undo, redo) = if typing {
            (false, false)
        } else {
            ctx.input_mut(|i| {
                // Ctrl+Shift+Z first, or Ctrl+Z would take it.
                let redo = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z))
                    || i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Y));
                let undo = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Z));
                (undo, redo)
            })
        };
        if undo {
            self.send(Command::Undo);
        }
        if redo {
            self.send(Command::Redo);
        }
        let (open, new, save_as, save, quit, bake) = ctx.input_mut(|i| {
            let open = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::O));
            let new = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::N));
            // Ctrl+Shift+S first, or Ctrl+S would take it.
            let save_as = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::S));
            let save = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::S));
            let quit = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Q));
            let bake = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::B));
            (open, new, save_as, save, quit, bake)
        });
        if ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::E)))
            && !self.crowd.busy()
            && let Some(doc) = &self.doc
        {
            self.export.show(doc, self.playback.clip);
        }
        if bake && self.doc.is_some() {
            self.send(Command::BakeCrowd);
        }
        if open {
            self.ask_path(PathPurpose::Open);
        }
        if new {
            self.ask_path(PathPurpose::NewFromGltf);
        }
        if save_as && self.doc.is_some() {
            self.ask_path(PathPurpose::SaveAs);
        }
        if save {
            self.send(Command::Save);
        }
        if quit {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        let tab_key = std::mem::take(&mut self.tab_key);
        if typing || self.prompt.is_some() {
            return;
        }
        let (tab, p) = ctx.input(|i| (i.key_pressed(Key::Tab) || tab_key, i.key_pressed(Key::P)));
        if tab {
            self.send(Command::ShowCrowd(!self.crowd.open));
        }
        if p && self.crowd.open {
            self.crowd.paused = !self.crowd.paused;
        }
        if self.tab == SideTab::Segment && !self.crowd.open {
            self.segment.shortcuts(ctx);
        }
        let (space, left, right, home, f) = ctx.input(|i| {
            (
                i.key_pressed(Key::Space),
                i.key_pressed(Key::ArrowLeft),
                i.key_pressed(Key::ArrowRight),
                i.key_pressed(Key::Home),
                i.key_pressed(Key::F),
            )
        });
        if space {
            self.send(Command::TogglePlaying);
        }
        if left {
            self.send(Command::StepFrames(-1));
        }
        if right {
            self.send(Command::StepFrames(1));
        }
        if home {
            self.send(Command::Seek(0.0));
        }
        if f {
            self.send(Command::FrameCharacter);
        }
    }

    pub(super) fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui
                    .add(egui::Button::new("New from glTF…").shortcut_text("Ctrl+N"))
                    .clicked()
                {
                    self.ask_path(PathPurpose::NewFromGltf);
                }
                if ui.add(egui::Button::new("Open…").shortcut_text("Ctrl+O")).clicked() {
                    self.ask_path(PathPurpose::Open);
                }
                if ui.button("Open path…").clicked() {
                    self.prompt = Some(PathPrompt::new(PathPurpose::Open));
                }
                ui.menu_button("Open recent", |ui| {
                    if self.settings.recent.is_empty() {
                        ui.label("(none)");
                    }
                    for path in self.settings.recent.clone() {
                        if ui.button(path.display().to_string()).clicked() {
                            self.send(Command::Open(path));
                        }
                    }
                });
                ui.separator();
                let has_doc = self.doc.is_some();
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save").shortcut_text("Ctrl+S"))
                    .clicked()
                {
                    self.send(Command::Save);
                }
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save As…").shortcut_text("Ctrl+Shift+S"))
                    .clicked()
                {
                    self.ask_path(PathPurpose::SaveAs);
                }
                if ui.add_enabled(has_doc, egui::Button::new("Save As path…")).clicked() {
                    self.prompt = Some(PathPrompt::new(PathPurpose::SaveAs));
                }
                ui.separator();
                if ui
                    .add_enabled(
                        has_doc && !self.crowd.busy(),
                        egui::Button::new("Export…").shortcut_text("Ctrl+E"),
                    )
                    .clicked()
                    && let Some(doc) = &self.doc
                {
                    self.export.show(doc, self.playback.clip);
                }
                ui.separator();
                if ui.add(egui::Button::new("Quit").shortcut_text("Ctrl+Q")).clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Edit", |ui| {
                let (undo, redo) = self.doc.as_ref().map_or((None, None), |d| {
                    (
                        d.history.undo_label().map(str::to_owned),
                        d.history.redo_label().map(str::to_owned),
                    )
                });
                let text = |verb: &str, l: &Option<String>| match l {
                    Some(l) => format!("{verb} {l}"),
                    None => verb.to_owned(),
                };
                if ui
                    .add_enabled(
                        undo.is_some(),
                        egui::Button::new(text("Undo", &undo)).shortcut_text("Ctrl+Z"),
                    )
                    .clicked()
                {
                    self.send(Command::Undo);
                }
                if ui
                    .add_enabled(
                        redo.is_some(),
                        egui::Button::new(text("Redo", &redo)).shortcut_text("Ctrl+Shift+Z"),
                    )
                    .clicked()
                {
                    self.send(Command::Redo);
                }
            });
            ui.menu_button("View", |ui| {
                for mode in ViewMode::ALL {
                    ui.radio_value(&mut self.view_mode, mode, mode.label());
                }
                ui.separator();
                ui.checkbox(&mut self.grid, "Ground grid");
                ui.checkbox(&mut self.show_log, "Log panel");
                if ui
                    .add(egui::Button::new("Frame character").shortcut_text("F"))
                    .clicked()
                {
                    self.send(Command::FrameCharacter);
                }
            });
            ui.menu_button("Crowd", |ui| {
                let has_doc = self.doc.is_some();
                let busy = self.crowd.busy();
                if ui
                    .add_enabled(
                        has_doc && !busy,
                        egui::Button::new("Bake for crowd preview").shortcut_text("Ctrl+B"),
                    )
                    .on_hover_text(
                        "Polypostors, classic and NP3D impostors and rigid meshes, same views and resolution",
                    )
                    .clicked()
                {
                    self.send(Command::BakeCrowd);
                }
                if ui.add_enabled(!busy, egui::Button::new("Open baked folder…")).clicked() {
                    self.ask_path(PathPurpose::OpenCrowd);
                }
                if ui
                    .add_enabled(!busy, egui::Button::new("Open baked folder path…"))
                    .clicked()
                {
                    self.prompt = Some(PathPrompt::new(PathPurpose::OpenCrowd));
                }
                ui.separator();
                let mut open = self.crowd.open;
                if ui.checkbox(&mut open, "Show crowd preview (Tab)").changed() {
                    self.send(Command::ShowCrowd(open));
                }
            });
            ui.menu_button("Help", |ui| {
                if ui.button("Controls and about").clicked() {
                    self.show_about = true;
                }
            });
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                // Cut to the room the menus leave, never selectable: a long project name in a
                // narrow window was drawn over the menus and took their clicks.
                if let Some(doc) = &self.doc {
                    let title = doc.title();
                    ui.add(
                        egui::Label::new(egui::RichText::new(&title).strong())
                            .truncate()
                            .selectable(false),
                    )
                    .on_hover_text(title);
                }
            });
        });
    }

    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
        self.crowd.job_ui(ui);
        ui.horizontal(|ui| {
            if let Some(l) = &self.loading {
                ui.spinner();
                ui.label(format!(
                    "Loading {} … {:.1} s",
                    l.what,
                    l.started.elapsed().as_secs_f32()
                ));
                ui.separator();
            }
            let errors = self.log.iter().filter(|e| e.level == LogLevel::Error).count();
            let warnings = self.log.iter().filter(|e| e.level == LogLevel::Warning).count();
            if ui
                .selectable_label(self.show_log, format!("⚠ {warnings}  ⛔ {errors}"))
                .on_hover_text("Show the log")
                .clicked()
            {
                self.show_log = !self.show_log;
            }
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.label(format!(
                    "{:.0} FPS · {:.0} ms · cpu {:.0} ms",
                    self.timer.fps(),
                    1000.0 / self.timer.fps().max(0.1),
                    self.timer.cpu_secs * 1000.0
                ));
                ui.separator();
                ui.label(self.adapter.as_deref().unwrap_or("no GPU"));
                if let Some(t) = self.safety.written_at {
                    ui.separator();
                    ui.label(egui::RichText::new(format!("autosaved {} s ago", t.elapsed().as_secs())).weak())
                        .on_hover_text("Unsaved changes are autosaved every 30 s and offered back after a crash");
                }
            });
        });
    }

    pub(super) fn timeline(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &self.doc else {
            ui.label("No character loaded.");
            return;
        };
        let clips: Vec<String> = doc.character.clips.iter().map(|c| c.name.clone()).collect();
        let duration = doc.clip_duration(self.playback.clip);
        let mut commands = Vec::new();
        // Wraps onto a second row in a narrow window (the speed went off the edge at 700 px).
        ui.horizontal_wrapped(|ui| {
            let selected = self
                .playback
                .clip
                .and_then(|i| clips.get(i))
                .cloned()
                .unwrap_or_else(|| "(rest pose)".into());
            egui::ComboBox::from_label("Clip")
                .selected_text(selected)
                .show_ui(ui, |ui| {
                    if ui
                        .selectable_label(self.playback.clip.is_none(), "(rest pose)")
                        .clicked()
                    {
                        commands.push(Command::SelectClip(None));
                    }
                    for (i, name) in clips.iter().enumerate() {
                        if ui.selectable_label(self.playback.clip == Some(i), name).clicked() {
                            commands.push(Command::SelectClip(Some(i)));
                        }
                    }
                });
            ui.separator();
            let label = if self.playback.playing { "⏸ Pause" } else { "▶ Play" };
            if ui.button(label).on_hover_text("Space").clicked() {
                commands.push(Command::SetPlaying(!self.playback.playing));
            }
            if ui.button("⏮").on_hover_text("Previous frame (Left arrow)").clicked() {
                commands.push(Command::StepFrames(-1));
            }
            if ui.button("⏭").on_hover_text("Next frame (Right arrow)").clicked() {
                commands.push(Command::StepFrames(1));
            }
            let mut t = self.playback.time_secs;
            // Room for the readout and the speed after it on the same row: what is left of
            // this row (the available width of a wrapping row is the whole row's; the readout
            // broke over two lines even at 1440 px).
            let width = (ui.available_size_before_wrap().x - 420.0).max(120.0);
            ui.spacing_mut().slider_width = width;
            let slider = ui.add_enabled(
                duration > 0.0,
                egui::Slider::new(&mut t, 0.0..=duration.max(1e-3))
                    .show_value(false)
                    .text("Time"),
            );
            if slider.changed() {
                commands.push(Command::SetPlaying(false));
                commands.push(Command::Seek(t));
            }
            // Never broken over two lines: it moves to the next row whole where it must.
            ui.add(
                egui::Label::new(
                    egui::RichText::new(format!(
                        "{:6.3} / {:.3} s  frame {:>3}",
                        self.playback.time_secs,
                        duration,
                        (self.playback.time_secs * TIMELINE_FPS).round() as i32
                    ))
                    .monospace(),
                )
                .extend(),
            );
            let mut speed = self.playback.speed;
            egui::ComboBox::from_label("Speed")
                .selected_text(format!("{speed}×"))
                .width(60.0)
                .show_ui(ui, |ui| {
                    for s in [0.1f32, 0.25, 0.5, 1.0, 2.0] {
                        ui.selectable_value(&mut speed, s, format!("{s}×"));
                    }
                });
            if speed != self.playback.speed {
                commands.push(Command::SetSpeed(speed));
            }
        });
        self.commands.extend(commands);
    }

    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &self.doc else {
            ui.heading("No character");
            ui.label("Open a project, or drop a .glb/.gltf here.");
            return;
        };
        let c = doc.character.clone();
        let s = doc.summary.clone();
        ui.heading(&s.name);
        ui.label(
            egui::RichText::new(doc.character_path.display().to_string())
                .small()
                .weak(),
        );
        if let Some(f) = &doc.project_file {
            ui.label(egui::RichText::new(format!("project: {}", f.display())).small().weak());
        } else {
            ui.label(egui::RichText::new("project: not saved yet").small().weak());
        }
        ui.separator();
        egui::Grid::new("summary").num_columns(2).striped(true).show(ui, |ui| {
            for (k, v) in [
                ("Vertices", s.vertices.to_string()),
                ("Triangles", s.triangles.to_string()),
                ("Joints", s.joints.to_string()),
                ("Skeleton nodes", s.nodes.to_string()),
                ("Materials", s.materials.to_string()),
                ("Clips", s.clips.len().to_string()),
                ("Textures", s.textures.len().to_string()),
                ("Warnings", s.warnings.len().to_string()),
            ] {
                ui.label(k);
                ui.label(v);
                ui.end_row();
            }
            ui.label("Height");
            ui.label(crate::editor::crowd::metres(s.bounds_max[1] - s.bounds_min[1]));
            ui.end_row();
        });
        // Which of the file's axes is up: a character exported lying down is stood up.
        let up = doc.project.character.up;
        let mut chosen = up;
        let name = |a: polypostor::UpAxis| match a {
            polypostor::UpAxis::PosY => "+y (glTF)".to_owned(),
            a => a.name().to_owned(),
        };
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("Up axis")
                .selected_text(name(up))
                .show_ui(ui, |ui| {
                    for a in polypostor::UpAxis::ALL {
                        ui.selectable_value(&mut chosen, a, name(a));
                    }
                })
                .response
                .on_hover_text(
                    "Which of the file's axes points up. glTF's is +y; a character exported from a Z-up \
                     tool without conversion lies on its back or front: choose +z or -z to stand it up. \
                     Saved in the project and recorded in every pack baked from it (Ctrl+Z undoes it).",
                );
            if doc.character.up_axis != up {
                ui.spinner();
            }
        });
        let set_up = (chosen != up).then_some(chosen);
        ui.separator();
        let mut select = None;
        egui::CollapsingHeader::new("Clips").default_open(true).show(ui, |ui| {
            for (i, clip) in s.clips.iter().enumerate() {
                let text = format!("{}  ({:.2} s)", clip.name, clip.duration_secs);
                if ui.selectable_label(self.playback.clip == Some(i), text).clicked() {
                    select = Some(i);
                }
            }
            if s.clips.is_empty() {
                ui.label("(no clips)");
            }
        });
        egui::CollapsingHeader::new("Joints")
            .default_open(false)
            .show(ui, |ui| {
                egui::ScrollArea::vertical()
                    .max_height(220.0)
                    .id_salt("joints")
                    .show(ui, |ui| {
                        for (i, n) in c.skeleton.nodes.iter().enumerate() {
                            let mut depth = 0;
                            let mut at = n.parent;
                            while let Some(p) = at {
                                depth += 1;
                                at = c.skeleton.nodes.get(p).and_then(|x| x.parent);
                            }
                            let text = format!(
                                "{}{}{}",
                                "  ".repeat(depth),
                                n.name,
                                if n.is_joint { "" } else { "  (helper)" }
                            );
                            ui.label(egui::RichText::new(text).monospace().small())
                                .on_hover_text(format!("node {i}"));
                        }
                    });
            });
        egui::CollapsingHeader::new("Textures")
            .default_open(true)
            .show(ui, |ui| {
                for t in &s.textures {
                    ui.label(format!("{}  {}×{}", t.name, t.width, t.height));
                }
                if let Some(tex) = c.textures.first() {
                    let generation = doc.generation;
                    if self.texture_preview.as_ref().is_none_or(|(g, _, _)| *g != generation) {
                        let image = egui::ColorImage::from_rgba_unmultiplied(
                            [tex.width as usize, tex.height as usize],
                            &tex.rgba8,
                        );
                        let handle = ui
                            .ctx()
                            .load_texture("texture preview", image, egui::TextureOptions::LINEAR);
                        let see_through = tex.rgba8.chunks_exact(4).any(|p| p[3] < 255);
                        self.texture_preview = Some((generation, handle, see_through));
                    }
                    if let Some((_, handle, see_through)) = &self.texture_preview {
                        let w = ui.available_width().min(240.0);
                        let h = w * tex.height as f32 / tex.width.max(1) as f32;
                        let (rect, _) = ui.allocate_exact_size(egui::vec2(w, h), egui::Sense::hover());
                        if *see_through {
                            // Transparent texels over a checkerboard, as image editors show them.
                            let painter = ui.painter_at(rect);
                            let cell = 8.0;
                            painter.rect_filled(rect, 0.0, egui::Color32::from_gray(200));
                            for row in 0..(h / cell).ceil() as usize {
                                for col in (row % 2..(w / cell).ceil() as usize).step_by(2) {
                                    let min = rect.min + egui::vec2(col as f32 * cell, row as f32 * cell);
                                    let square = egui::Rect::from_min_size(min, egui::vec2(cell, cell));
                                    painter.rect_filled(square, 0.0, egui::Color32::from_gray(150));
                                }
                            }
                        }
                        egui::Image::new((handle.id(), egui::vec2(w, h))).paint_at(ui, rect);
                        if *see_through {
                            ui.label(egui::RichText::new("checks: transparent texels").small().weak());
                        }
                    }
                }
            });
        if let Some(i) = select {
            self.send(Command::SelectClip(Some(i)));
        }
        if let Some(a) = set_up {
            self.send(Command::SetUpAxis(a));
        }
    }

    pub(super) fn log_panel(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.strong("Log");
            if ui.small_button("Clear").clicked() {
                self.log.clear();
            }
        });
        egui::ScrollArea::vertical()
            .stick_to_bottom(true)
            .auto_shrink([false, false])
            .show(ui, |ui| {
                for e in &self.log {
                    let (icon, color) = match e.level {
                        LogLevel::Info => ("ℹ", ui.visuals().text_color()),
                        LogLevel::Warning => ("⚠", ui.visuals().warn_fg_color),
                        LogLevel::Error => ("⛔", ui.visuals().error_fg_color),
                    };
                    ui.label(egui::RichText::new(format!("{icon} {}", e.text)).color(color));
                }
            });
    }

    pub(super) fn viewport(&mut self, ui: &mut egui::Ui) {
        let mut rect = ui.available_rect_before_wrap();
        // Between the side panels as drawn (a panel wider than its share was overlapped).
        if let Some(x) = self.side_panels.0 {
            rect.min.x = rect.min.x.max(x);
        }
        if let Some(x) = self.side_panels.1 {
            rect.max.x = rect.max.x.min(x);
        }
        rect.max.x = rect.max.x.max(rect.min.x + 1.0);
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        self.viewport_rect = rect;
        let painting = self.tab == SideTab::Segment && self.doc.is_some();
        if painting {
            let doc = self.doc.as_mut().unwrap();
            let pose = Pose::sample_index(&doc.character, self.playback.clip, self.playback.time_secs);
            let m = self
                .camera
                .camera()
                .clip_from_world(rect.width() / rect.height().max(1.0));
            self.segment.viewport_input(ui, &response, doc, m, &pose);
        }
        self.camera.handle_input(ui, &response, !painting);
        if response.double_clicked() && !painting {
            self.send(Command::FrameCharacter);
        }
        let Some(doc) = &self.doc else {
            let text = if self.loading.is_some() {
                "Loading…"
            } else {
                "Drop a .glb/.gltf here, or use File > New from glTF"
            };
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        };
        if self.adapter.is_some() {
            let pose = Pose::sample_index(&doc.character, self.playback.clip, self.playback.time_secs);
            let ppp = ui.ctx().pixels_per_point();
            let (generation, character, mode) = if painting {
                let (g, c) = self.segment.display(doc);
                let mode = if self.segment.isolate {
                    self.view_mode
                } else {
                    ViewMode::Lit
                };
                (g, c, mode)
            } else {
                (doc.generation, doc.character.clone(), self.view_mode)
            };
            let callback = ViewportCallback {
                character,
                generation,
                pose: Arc::new(pose),
                camera: self.camera.camera(),
                size_px: [
                    (rect.width() * ppp).round() as u32,
                    (rect.height() * ppp).round() as u32,
                ],
                mode,
                grid: self.grid,
                grid_cell: polypostor::gpu::grid_cell(self.camera.scale),
            };
            ui.painter()
                .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
        }
        if painting {
            self.segment.overlay(ui, rect, doc);
        }
        // Overlay: view mode, grid, frame button; controls hint.
        let overlay = egui::Rect::from_min_size(rect.min + egui::vec2(8.0, 8.0), egui::vec2(rect.width() - 16.0, 28.0));
        let mut child = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(overlay)
                .layout(egui::Layout::left_to_right(egui::Align::Center)),
        );
        // Kept inside the viewport when it is narrow (it was drawn over the fit inspector).
        child.shrink_clip_rect(rect);
        egui::ComboBox::from_id_salt("view mode")
            .selected_text(self.view_mode.label())
            .width(80.0)
            .show_ui(&mut child, |ui| {
                for mode in ViewMode::ALL {
                    ui.selectable_value(&mut self.view_mode, mode, mode.label());
                }
            });
        child.checkbox(&mut self.grid, "Grid").on_hover_text(format!(
            "Ground grid: lines every {} and every tenth of that (a power of ten that suits the character's size)",
            crate::editor::crowd::metres(polypostor::gpu::grid_cell(self.camera.scale))
        ));
        if child.button("Frame (F)").clicked() {
            self.send(Command::FrameCharacter);
        }
        ui.painter_at(rect).text(
            rect.left_bottom() + egui::vec2(8.0, -8.0),
            egui::Align2::LEFT_BOTTOM,
            if painting {
                "Paint: left drag · Orbit: middle drag · Pan: right drag · Zoom: wheel · Radius: [ ]"
            } else {
                "Orbit: left/middle drag · Pan: shift+middle or right drag · Zoom: wheel · Space: play/pause"
            },
            egui::FontId::proportional(12.0),
            egui::Color32::from_gray(150),
        );
    }
}

/// A docked panel's frame without a fill: the window is cleared to the panel colour instead
/// ([`eframe::App::clear_color`]). On a software rasteriser shading the panels' background
/// quads cost about 20 ms a frame at 1440×900, as much as all the rest of the UI; a clear
/// costs next to nothing.
pub(super) fn panel_frame(style: &egui::Style) -> egui::Frame {
    egui::Frame::side_top_panel(style).fill(egui::Color32::TRANSPARENT)
}
