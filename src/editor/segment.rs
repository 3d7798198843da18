//! The Segment tab: paint body parts onto the character and author the caps that close the
//! cuts. The tools themselves live in the library (`polypostor::edit::paint`); this is their
//! user interface. Every stroke, fill, palette change and cap colour is one undo step.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec2;

use polypostor::Character;
use polypostor::animation::{Pose, skin_vertices};
use polypostor::bake::caps::{Cap, find_caps, part_character};
use polypostor::edit::paint::{self, Dab, Topology};
use polypostor::project::Project;

use super::document::Document;

/// What a click or drag in the viewport does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    /// Paint the triangles under a round brush.
    Brush,
    /// Flood the clicked triangle's connected region of its part.
    FillConnected,
    /// Take every triangle the clicked triangle's dominant joint dominates.
    FillJoint,
}

impl Tool {
    const ALL: [Tool; 3] = [Tool::Brush, Tool::FillConnected, Tool::FillJoint];

    fn label(self) -> &'static str {
        match self {
            Tool::Brush => "Brush (B)",
            Tool::FillConnected => "Fill connected (G)",
            Tool::FillJoint => "Fill by joint (J)",
        }
    }
}

/// A stroke in progress: the project before it, for one undo step at its end.
struct Stroke {
    before: Project,
    changed: usize,
}

/// Viewport display generations: far above the document generations.
static NEXT_DISPLAY: AtomicU64 = AtomicU64::new(1 << 40);

pub struct SegmentPanel {
    pub tool: Tool,
    pub radius_px: f32,
    pub mirror: bool,
    pub active: u16,
    /// Show only the active part with its caps (textured), as the bake cuts it.
    pub isolate: bool,
    /// The cap whose colour the next click on the texture picks.
    pub eyedropper: Option<String>,
    /// The cap whose colour picker is open and has made an undo step (with the undo depth
    /// after it): further changes while it stays open go into that step.
    picking: Option<(String, usize)>,
    joint: usize,
    remove_into: u16,
    /// The active part and part count `remove_into` was chosen for.
    remove_into_for: Option<(u16, usize)>,
    rename: Option<(u16, String)>,
    stroke: Option<Stroke>,
    topology: Option<(u64, Arc<Topology>)>,
    /// (document generation, revision, isolate, active) the display was built for.
    display_key: Option<(u64, u64, bool, u16)>,
    display: Option<(u64, Arc<Character>)>,
    caps: Option<((u64, u64), Arc<Vec<Cap>>)>,
    /// Pieces of parts lying apart from the rest of them, for (generation, revision).
    strays: Option<((u64, u64), Arc<Vec<paint::StrayPiece>>)>,
    texture: Option<(u64, egui::TextureHandle)>,
    /// The cursor over the viewport (for the brush outline).
    hover: Option<egui::Pos2>,
    /// Messages for the log (text, is an error).
    pub messages: Vec<String>,
    /// Warnings for the log (no dialog).
    pub notes: Vec<String>,
}

impl Default for SegmentPanel {
    fn default() -> Self {
        Self {
            tool: Tool::Brush,
            radius_px: 18.0,
            mirror: true,
            active: 0,
            isolate: false,
            eyedropper: None,
            picking: None,
            joint: 0,
            remove_into: 0,
            remove_into_for: None,
            rename: None,
            stroke: None,
            topology: None,
            display_key: None,
            display: None,
            caps: None,
            strays: None,
            texture: None,
            hover: None,
            messages: Vec::new(),
            notes: Vec::new(),
        }
    }
}

impl SegmentPanel {
    fn topology(&mut self, doc: &Document) -> Arc<Topology> {
        if self.topology.as_ref().is_none_or(|(g, _)| *g != doc.generation) {
            self.topology = Some((doc.generation, Arc::new(Topology::new(&doc.character))));
        }
        self.topology.as_ref().unwrap().1.clone()
    }

    /// The stray pieces of the current segmentation's parts (recomputed when it changes).
    fn strays(&mut self, doc: &Document) -> Arc<Vec<paint::StrayPiece>> {
        let key = (doc.generation, doc.revision);
        if self.strays.as_ref().is_none_or(|(k, _)| *k != key) {
            let topo = self.topology(doc);
            let found = paint::stray_pieces(&doc.character, &topo, &doc.segmentation);
            self.strays = Some((key, Arc::new(found)));
        }
        self.strays.as_ref().unwrap().1.clone()
    }

    /// The caps of the current segmentation (recomputed when it changes).
    pub fn caps(&mut self, doc: &Document) -> Arc<Vec<Cap>> {
        let key = (doc.generation, doc.revision);
        if self.caps.as_ref().is_none_or(|(k, _)| *k != key) {
            self.caps = Some((key, Arc::new(find_caps(&doc.character, &doc.segmentation))));
        }
        self.caps.as_ref().unwrap().1.clone()
    }

    /// What the viewport shows in this tab: the part-coloured mesh, or the active part with
    /// its caps. Returns its generation (changes whenever it is rebuilt) and the character.
    pub fn display(&mut self, doc: &Document) -> (u64, Arc<Character>) {
        self.active = self.active.min(doc.segmentation.parts.len().saturating_sub(1) as u16);
        let key = (doc.generation, doc.revision, self.isolate, self.active);
        if self.display_key != Some(key) || self.display.is_none() {
            let character = if self.isolate {
                let caps = self.caps(doc);
                part_character(
                    &doc.character,
                    &doc.segmentation,
                    self.active as usize,
                    &caps,
                    &doc.project.caps,
                )
            } else {
                let topo = self.topology(doc);
                paint::segmentation_display(&doc.character, &doc.segmentation, &topo)
            };
            let generation = NEXT_DISPLAY.fetch_add(1, Ordering::Relaxed);
            self.display = Some((generation, Arc::new(character)));
            self.display_key = Some(key);
        }
        self.display.clone().unwrap()
    }

    /// Keyboard shortcuts of the tab (when no text field has focus).
    pub fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::Key;
        ctx.input(|i| {
            if i.key_pressed(Key::B) && !i.modifiers.command {
                self.tool = Tool::Brush;
            }
            if i.key_pressed(Key::G) {
                self.tool = Tool::FillConnected;
            }
            if i.key_pressed(Key::J) {
                self.tool = Tool::FillJoint;
            }
            if i.key_pressed(Key::M) {
                self.mirror = !self.mirror;
            }
            if i.key_pressed(Key::OpenBracket) {
                self.radius_px = (self.radius_px / 1.25).max(2.0);
            }
            if i.key_pressed(Key::CloseBracket) {
                self.radius_px = (self.radius_px * 1.25).min(200.0);
            }
        });
    }

    /// The side panel: palette, tools, caps.
    pub fn controls(&mut self, ui: &mut egui::Ui, doc: &mut Document) {
        ui.heading("Segmentation");
        ui.label(
            egui::RichText::new("Paint body parts onto the mesh; the bake cuts the character along the seams.")
                .small()
                .weak(),
        );
        ui.separator();
        self.palette(ui, doc);
        ui.separator();
        self.tools(ui, doc);
        ui.separator();
        self.caps_ui(ui, doc);
    }

    fn palette(&mut self, ui: &mut egui::Ui, doc: &mut Document) {
        ui.strong("Parts");
        let sizes = doc.segmentation.part_sizes();
        let n = doc.segmentation.parts.len();
        let mut recolor: Option<(usize, [u8; 3])> = None;
        let mut rename: Option<(usize, String)> = None;
        egui::Grid::new("parts").num_columns(3).striped(true).show(ui, |ui| {
            for p in 0..n {
                let part = &doc.segmentation.parts[p];
                let mut color = part.color;
                if ui.color_edit_button_srgb(&mut color).changed() {
                    recolor = Some((p, color));
                }
                if p as u16 == self.active {
                    // A rename commits when the field loses focus; the text typed so far is
                    // kept between frames.
                    let mut buf = match &self.rename {
                        Some((q, b)) if *q == p as u16 => b.clone(),
                        _ => part.name.clone(),
                    };
                    let edit = ui.add(egui::TextEdit::singleline(&mut buf).desired_width(120.0));
                    self.rename = edit.has_focus().then(|| (p as u16, buf.clone()));
                    if edit.lost_focus() && buf.trim() != part.name && !buf.trim().is_empty() {
                        rename = Some((p, buf.trim().to_string()));
                    }
                } else if ui
                    .selectable_label(false, &part.name)
                    .on_hover_text("Make this the part that brushes and fills paint")
                    .clicked()
                {
                    self.active = p as u16;
                }
                ui.label(egui::RichText::new(format!("{} tris", sizes[p])).small().weak());
                ui.end_row();
            }
        });
        if let Some((p, color)) = recolor {
            doc.edit("Recolour part", |seg, _| {
                seg.parts[p].color = color;
                true
            });
        }
        if let Some((p, name)) = rename {
            doc.edit("Rename part", |seg, _| {
                seg.parts[p].name = name;
                true
            });
        }
        ui.horizontal(|ui| {
            let can_add = n < polypostor::limits::MAX_PARTS;
            let add = ui
                .add_enabled(can_add, egui::Button::new("➕ Add part"))
                .on_hover_text("Add a part with a fresh colour")
                .on_disabled_hover_text(paint::part_limit_message());
            if add.clicked() {
                match doc.add_part("") {
                    Ok((p, extended)) => {
                        self.active = p;
                        if extended > 0 {
                            self.notes.push(format!(
                                "the new part is drawn in front in {} (the Views tab moves it)",
                                polypostor::import::plural(extended, "hand-set drawing order")
                            ));
                        }
                    }
                    Err(e) => self.messages.push(e),
                }
            }
            let can_remove = n > 1;
            // By default the part the active one borders most (chosen again when another
            // part is made active; a choice in the list below stays until then).
            if self.remove_into_for != Some((self.active, n))
                || self.remove_into as usize >= n
                || self.remove_into == self.active
            {
                let topo = self.topology(doc);
                self.remove_into = paint::neighbour_part(&doc.segmentation, &topo, self.active)
                    .unwrap_or(if self.active == 0 { 1.min(n as u16 - 1) } else { 0 });
                self.remove_into_for = Some((self.active, n));
            }
            let into_name = doc
                .segmentation
                .parts
                .get(self.remove_into as usize)
                .map_or(String::new(), |p| p.name.clone());
            if ui
                .add_enabled(can_remove, egui::Button::new("🗑 Remove"))
                .on_hover_text(format!("Remove the active part; its triangles go to {into_name}"))
                .clicked()
            {
                let (p, into) = (self.active, self.remove_into);
                match doc.remove_part(p, into) {
                    Ok(0) => {}
                    Ok(pins) => self.notes.push(format!(
                        "{pins} pin(s) of the removed part and of {into_name} (whose outline changes) were dropped; Ctrl+Z brings them back"
                    )),
                    Err(e) => self.messages.push(e),
                }
                self.active = if into > p { into - 1 } else { into };
            }
            egui::ComboBox::from_id_salt("remove into")
                .selected_text(format!("into {into_name}"))
                .width(110.0)
                .show_ui(ui, |ui| {
                    for (i, part) in doc.segmentation.parts.iter().enumerate() {
                        if i as u16 != self.active {
                            ui.selectable_value(&mut self.remove_into, i as u16, &part.name);
                        }
                    }
                });
        });
        if doc.segmentation.parts.len() >= polypostor::limits::MAX_PARTS {
            ui.label(
                egui::RichText::new(format!("No more parts: {}", paint::part_limit_message()))
                    .small()
                    .color(ui.visuals().warn_fg_color),
            );
        }
        // A piece of a part far from the rest of it (a stray stroke): each view would join
        // the two with a thin bridge and the part fit badly, without a word.
        let strays = self.strays(doc);
        for piece in strays.iter().take(4) {
            let names: Vec<String> = doc
                .segmentation
                .parts
                .iter()
                .map(|q| shortened(&q.name, NAME_CHARS))
                .collect();
            let name = |p: u16| names.get(p as usize).cloned().unwrap_or_else(|| "?".into());
            ui.horizontal_wrapped(|ui| {
                ui.label(
                    egui::RichText::new(format!(
                        "⚠ {}: {} lie {} from the rest of it; every view joins them with a thin bridge",
                        name(piece.part),
                        polypostor::import::plural(piece.triangles.len(), "triangle"),
                        crate::editor::crowd::metres(piece.distance)
                    ))
                    .small()
                    .color(ui.visuals().warn_fg_color),
                );
                if let Some(to) = piece.touches
                    && ui
                        .small_button(format!("Give to {}", name(to)))
                        .on_hover_text("Paint these triangles with the part around them (undoable)")
                        .clicked()
                {
                    let tris = piece.triangles.clone();
                    doc.edit("Give stray triangles back", |seg, _| {
                        paint::paint(seg, &tris, to, None) > 0
                    });
                }
            });
        }
        if strays.len() > 4 {
            ui.label(
                egui::RichText::new(format!("… and {} more pieces apart from their parts", strays.len() - 4))
                    .small()
                    .color(ui.visuals().warn_fg_color),
            );
        }
    }

    fn tools(&mut self, ui: &mut egui::Ui, doc: &mut Document) {
        ui.strong("Tools");
        ui.horizontal_wrapped(|ui| {
            for t in Tool::ALL {
                ui.selectable_value(&mut self.tool, t, t.label());
            }
        });
        ui.add(
            egui::Slider::new(&mut self.radius_px, 2.0..=200.0)
                .logarithmic(true)
                .text("radius px  [ ]"),
        );
        ui.checkbox(&mut self.mirror, "X-mirror (M)")
            .on_hover_text("Paint and fill the mirrored triangles on the other side too");
        let topo = self.topology(doc);
        let c = doc.character.clone();
        let bone_name = |b: usize| {
            c.bones
                .get(b)
                .and_then(|bone| c.skeleton.nodes.get(bone.node))
                .map_or(format!("bone {b}"), |n| n.name.clone())
        };
        ui.horizontal(|ui| {
            egui::ComboBox::from_id_salt("joint")
                .selected_text(bone_name(self.joint))
                .width(150.0)
                .show_ui(ui, |ui| {
                    for b in 0..c.bones.len() {
                        let count = topo.bone_triangles.get(b).copied().unwrap_or(0);
                        if count > 0 {
                            ui.selectable_value(&mut self.joint, b, format!("{}  ({count})", bone_name(b)));
                        }
                    }
                });
            if ui
                .button("Fill joint")
                .on_hover_text("Give the triangles this joint dominates to the active part")
                .clicked()
            {
                let (bone, part, mirror) = (self.joint as u16, self.active, self.mirror);
                doc.edit("Fill by joint", |seg, _| {
                    paint::fill_bone(seg, &topo, bone, part, mirror) > 0
                });
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("Auto-segment")
                .on_hover_text("Start over from the automatic segmentation (undoable)")
                .clicked()
            {
                let c = doc.character.clone();
                doc.edit("Auto-segment", |seg, caps| {
                    let auto = polypostor::bake::segment::auto_segment(&c);
                    let changed = *seg != auto || !caps.colors.is_empty();
                    *seg = auto;
                    caps.colors.clear();
                    changed
                });
            }
            ui.checkbox(&mut self.isolate, "Show active part with caps");
        });
        ui.label(
            egui::RichText::new("Left drag paints · middle drag orbits · right drag pans · Ctrl+Z undoes a stroke")
                .small()
                .weak(),
        );
    }

    fn caps_ui(&mut self, ui: &mut egui::Ui, doc: &mut Document) {
        let caps = self.caps(doc);
        egui::CollapsingHeader::new(format!("Caps ({})", caps.len()))
            .default_open(true)
            .show(ui, |ui| {
                ui.label(
                    egui::RichText::new("Each cut leaves a hole; a cap closes it with one colour.")
                        .small()
                        .weak(),
                );
                let mut set: Option<(String, Option<[u8; 3]>)> = None;
                let mut from_picker = false;
                if !egui::Popup::is_any_open(ui.ctx()) {
                    self.picking = None;
                }
                egui::Grid::new("caps").num_columns(4).striped(true).show(ui, |ui| {
                    for cap in caps.iter() {
                        let part = doc.segmentation.parts.get(cap.part).map_or("?", |p| p.name.as_str());
                        let custom = doc.project.caps.colors.contains_key(&cap.id);
                        let mut color = cap.color(&doc.project.caps);
                        if ui
                            .color_edit_button_srgb(&mut color)
                            .on_hover_text("Cap colour")
                            .changed()
                        {
                            set = Some((cap.id.clone(), Some(color)));
                            from_picker = true;
                        }
                        // A long part name is cut (it pushed the cap's buttons off the panel).
                        let text = format!(
                            "{} · {} ({} edges)",
                            shortened(part, NAME_CHARS),
                            cap.id,
                            cap.loop_vertices.len()
                        );
                        if ui
                            .selectable_label(self.isolate && self.active as usize == cap.part, text)
                            .on_hover_text(format!("{part}: show this part with its caps"))
                            .clicked()
                        {
                            self.active = cap.part as u16;
                            self.isolate = true;
                        }
                        let armed = self.eyedropper.as_deref() == Some(cap.id.as_str());
                        let textured = !doc.character.textures.is_empty();
                        if ui
                            .add_enabled(textured, egui::Button::selectable(armed, "💧"))
                            .on_hover_text("Eyedropper: click the texture below to take its colour")
                            .on_disabled_hover_text("The character has no texture to take a colour from")
                            .clicked()
                        {
                            self.eyedropper = if armed { None } else { Some(cap.id.clone()) };
                        }
                        if ui
                            .add_enabled(custom, egui::Button::new("↺").small())
                            .on_hover_text("Back to the default (the mean colour along the cut)")
                            .clicked()
                        {
                            set = Some((cap.id.clone(), None));
                            from_picker = false;
                        }
                        ui.end_row();
                    }
                });
                if caps.is_empty() {
                    ui.label(if doc.segmentation.parts.len() > 1 {
                        "(no cuts: the parts are separate pieces of the mesh)"
                    } else {
                        "(no cuts: a single part)"
                    });
                }
                if doc.character.textures.is_empty() {
                    self.eyedropper = None;
                }
                if let Some(id) = self.eyedropper.clone()
                    && let Some(picked) = self.texture_picker(ui, doc)
                {
                    set = Some((id, Some(picked)));
                    from_picker = false;
                    self.eyedropper = None;
                }
                if let Some((id, color)) = set {
                    let change = |_: &mut _, overrides: &mut polypostor::bake::caps::CapOverrides| match color {
                        Some(c) => overrides.colors.insert(id.clone(), c) != Some(c),
                        None => overrides.colors.remove(&id).is_some(),
                    };
                    let same_session = from_picker
                        && self
                            .picking
                            .as_ref()
                            .is_some_and(|(p, depth)| *p == id && *depth == doc.history.undo_len());
                    if same_session {
                        doc.amend(change);
                    } else if doc.edit("Cap colour", change) {
                        self.picking = from_picker.then(|| (id.clone(), doc.history.undo_len()));
                    }
                }
            });
    }

    /// The character's first texture; returns the colour of a clicked texel.
    fn texture_picker(&mut self, ui: &mut egui::Ui, doc: &Document) -> Option<[u8; 3]> {
        let tex = doc.character.textures.first()?;
        if self.texture.as_ref().is_none_or(|(g, _)| *g != doc.generation) {
            let image = egui::ColorImage::from_rgba_unmultiplied([tex.width as usize, tex.height as usize], &tex.rgba8);
            let handle = ui
                .ctx()
                .load_texture("eyedropper texture", image, egui::TextureOptions::NEAREST);
            self.texture = Some((doc.generation, handle));
        }
        let (_, handle) = self.texture.as_ref()?;
        ui.label(egui::RichText::new("Click the texture to take a colour (Esc cancels)").strong());
        let w = ui.available_width().min(260.0);
        let h = w * tex.height as f32 / tex.width.max(1) as f32;
        let response = ui.add(egui::Image::new((handle.id(), egui::vec2(w, h))).sense(egui::Sense::click()));
        if ui.input(|i| i.key_pressed(egui::Key::Escape)) {
            self.eyedropper = None;
        }
        let pos = response.interact_pointer_pos().filter(|_| response.clicked())?;
        let u = ((pos.x - response.rect.left()) / response.rect.width()).clamp(0.0, 0.9999);
        let v = ((pos.y - response.rect.top()) / response.rect.height()).clamp(0.0, 0.9999);
        let (x, y) = ((u * tex.width as f32) as usize, (v * tex.height as f32) as usize);
        let i = 4 * (y * tex.width as usize + x);
        tex.rgba8.get(i..i + 3).map(|p| [p[0], p[1], p[2]])
    }

    /// Viewport input in this tab: left button paints or fills; returns true when it took the
    /// primary button (the camera must not orbit then).
    pub fn viewport_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        doc: &mut Document,
        clip_from_world: glam::Mat4,
        pose: &Pose,
    ) -> bool {
        self.hover = response.hover_pos();
        let rect = response.rect;
        let to_dab = |pos: egui::Pos2, radius: f32| Dab {
            clip_from_world,
            cursor_ndc: Vec2::new(
                (pos.x - rect.left()) / rect.width() * 2.0 - 1.0,
                1.0 - (pos.y - rect.top()) / rect.height() * 2.0,
            ),
            radius_px: radius,
            viewport_px: Vec2::new(rect.width(), rect.height()),
        };
        let primary_down = ui.input(|i| i.pointer.primary_down());
        let pressed = response.is_pointer_button_down_on() && primary_down;
        match self.tool {
            Tool::Brush => {
                if pressed && let Some(pos) = response.interact_pointer_pos() {
                    let stroke = self.stroke.get_or_insert_with(|| Stroke {
                        before: doc.project.clone(),
                        changed: 0,
                    });
                    let (positions, _) = skin_vertices(&doc.character, pose);
                    let tris = paint::dab_triangles(&positions, &doc.character.indices, &to_dab(pos, self.radius_px));
                    let topo = self.topology.as_ref().map(|(_, t)| t.clone());
                    let mirror = if self.mirror { topo.as_deref() } else { None };
                    let changed = paint::paint(&mut doc.segmentation, &tris, self.active, mirror);
                    if changed > 0 {
                        stroke.changed += changed;
                        doc.revision += 1;
                        doc.dirty = true;
                    }
                } else if let Some(stroke) = self.stroke.take()
                    && stroke.changed > 0
                {
                    doc.history.record("Paint stroke", stroke.before);
                    doc.store_segmentation();
                }
                pressed
            }
            Tool::FillConnected | Tool::FillJoint => {
                if response.clicked_by(egui::PointerButton::Primary)
                    && let Some(pos) = response.interact_pointer_pos()
                {
                    let (positions, _) = skin_vertices(&doc.character, pose);
                    let ray = paint::ray_through(clip_from_world, to_dab(pos, 1.0).cursor_ndc);
                    if let Some((t, _)) = paint::pick(&positions, &doc.character.indices, &ray) {
                        let topo = self.topology(doc);
                        let (part, mirror) = (self.active, self.mirror);
                        if self.tool == Tool::FillConnected {
                            doc.edit("Fill connected", |seg, _| {
                                paint::fill_connected(seg, &topo, t, part, mirror) > 0
                            });
                        } else {
                            let bone = topo.dominant_bone[t];
                            self.joint = bone as usize;
                            doc.edit("Fill by joint", |seg, _| {
                                paint::fill_bone(seg, &topo, bone, part, mirror) > 0
                            });
                        }
                    }
                }
                response.is_pointer_button_down_on() && primary_down
            }
        }
    }

    /// The brush outline and the active part over the viewport.
    pub fn overlay(&self, ui: &egui::Ui, rect: egui::Rect, doc: &Document) {
        let painter = ui.painter_at(rect);
        if self.tool == Tool::Brush
            && let Some(pos) = self.hover
        {
            painter.circle_stroke(pos, self.radius_px, egui::Stroke::new(1.5, egui::Color32::WHITE));
            painter.circle_stroke(pos, self.radius_px + 1.5, egui::Stroke::new(1.0, egui::Color32::BLACK));
        }
        if let Some(part) = doc.segmentation.parts.get(self.active as usize) {
            let [r, g, b] = part.color;
            // Cut to what fits beside the viewport's toolbar (a long name was drawn over it).
            let room = ((rect.width() - 330.0) / 8.0).clamp(8.0, 60.0) as usize;
            let text = format!(
                "painting: {}{}",
                shortened(&part.name, room),
                if self.mirror { "  ·  X-mirror" } else { "" }
            );
            let at = rect.right_top() + egui::vec2(-10.0, 14.0);
            painter.circle_filled(at + egui::vec2(-8.0, 0.0), 6.0, egui::Color32::from_rgb(r, g, b));
            painter.text(
                at + egui::vec2(-20.0, 0.0),
                egui::Align2::RIGHT_CENTER,
                text,
                egui::FontId::proportional(14.0),
                egui::Color32::from_gray(230),
            );
        }
    }
}

/// Characters of a part name shown where room is short (the caps list).
const NAME_CHARS: usize = 24;

/// `name` cut to `max` characters, the last of them an ellipsis.
fn shortened(name: &str, max: usize) -> String {
    if name.chars().count() <= max {
        name.to_owned()
    } else {
        let mut s: String = name.chars().take(max.saturating_sub(1)).collect();
        s.push('…');
        s
    }
}
