//! The export dialog (File > Export…, Ctrl+E): which representations, how many views, the
//! resolution, frame rate and texture compression, with a memory estimate before anything
//! is written. Exporting bakes in the background (progress and cancel in the status bar)
//! and opens the crowd preview on the new folder.

use std::path::{Path, PathBuf};

use polypostor::bake::overrides::OverrideBasis;
use polypostor::bake::pipeline::{PngCompression, TextureEncoding};
use polypostor::reps::RepSet;
use polypostor::reps::compare::estimate;

use super::document::{Document, ExportRequest};

pub struct ExportDialog {
    pub open: bool,
    pub folder: String,
    pub set: RepSet,
    pub views: usize,
    pub resolution: u32,
    pub fps: f32,
    pub png: PngCompression,
    /// BC7 (KTX2) or PNG textures.
    pub textures: TextureEncoding,
    /// Vertices of each part's polygon (3 to the fitted 40).
    pub polygon_vertices: usize,
    /// Per clip of the character, whether it goes into the pack (several: one
    /// whole-character pack sharing its key images).
    pub clips: Vec<bool>,
    /// Why the folder typed cannot receive the export (checked when the text changes).
    folder_check: Option<(String, Option<String>)>,
    /// The project (its file, else its character) the folder was chosen for: another
    /// project's export folder is not offered (Export would have replaced its pack).
    folder_for: Option<PathBuf>,
}

impl Default for ExportDialog {
    fn default() -> Self {
        Self {
            open: false,
            folder: String::new(),
            set: RepSet::ALL,
            views: polypostor::bake::viewpoints::DEFAULT_VIEW_COUNT,
            resolution: polypostor::bake::renders::DEFAULT_RESOLUTION,
            fps: polypostor::bake::renders::DEFAULT_FPS,
            png: PngCompression::default(),
            textures: TextureEncoding::default(),
            polygon_vertices: polypostor::bake::part_fit::DEFAULT_POLYGON_VERTICES,
            clips: Vec::new(),
            folder_check: None,
            folder_for: None,
        }
    }
}

fn mb(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

impl ExportDialog {
    /// Opens the dialog with a default folder beside the project, and the project's clip set
    /// (or the clip being viewed) ticked.
    pub fn show(&mut self, doc: &Document, viewed: Option<usize>) {
        let names: Vec<&str> = doc.character.clips.iter().map(|c| c.name.as_str()).collect();
        self.clips = if doc.project.clips.is_empty() {
            (0..names.len()).map(|i| Some(i) == viewed).collect()
        } else {
            names.iter().map(|n| doc.project.clips.iter().any(|c| c == n)).collect()
        };
        // The project's bake settings.
        let b = &doc.project.bake;
        (self.views, self.resolution, self.fps) = (b.views, b.resolution, b.fps);
        (self.png, self.textures) = (b.png, b.textures);
        self.polygon_vertices = b.polygon_vertices;
        self.set = b.representation_set();
        let this = doc.project_file.clone().unwrap_or_else(|| doc.character_path.clone());
        if self.folder.is_empty() || self.folder_for.as_ref() != Some(&this) {
            self.folder_for = Some(this);
            // Beside the project; a never-saved one's in the temporary folder, named after
            // its character (two unsaved projects would otherwise share one folder).
            self.folder = match doc.project_file.as_ref().and_then(|f| f.parent()) {
                Some(dir) => dir.join("export.pack"),
                None => {
                    let stem = doc.character_path.file_stem().map(|s| s.to_string_lossy().into_owned());
                    std::env::temp_dir().join(format!("{}-export.pack", stem.as_deref().unwrap_or("character")))
                }
            }
            .display()
            .to_string();
        }
        self.open = true;
    }

    /// The dialog; returns a request when the user presses Export.
    pub fn ui(&mut self, ctx: &egui::Context, doc: &Document, clip: Option<usize>) -> Option<ExportRequest> {
        if !self.open {
            return None;
        }
        let mut request = None;
        let mut close = false;
        if self.clips.len() != doc.character.clips.len() {
            self.clips = (0..doc.character.clips.len()).map(|i| Some(i) == clip).collect();
        }
        let chosen: Vec<Option<usize>> = if doc.character.clips.is_empty() {
            vec![None]
        } else {
            (0..self.clips.len()).filter(|&i| self.clips[i]).map(Some).collect()
        };
        let frames = polypostor::timeline::Timeline::new(&doc.character, &chosen, self.fps)
            .map(|t| t.frames())
            .unwrap_or(0);
        super::modal(ctx, "export dialog").show(ctx, |ui| {
            ui.set_width(520.0);
            ui.heading("Export crowd assets");
            ui.add_space(4.0);
            egui::Grid::new("export settings").num_columns(2).show(ui, |ui| {
                ui.label("Folder");
                ui.add(egui::TextEdit::singleline(&mut self.folder).desired_width(360.0));
                ui.end_row();
                ui.label("Representations");
                ui.horizontal(|ui| {
                    ui.checkbox(&mut self.set.polypostor, "Polypostor");
                    ui.checkbox(&mut self.set.impostor, "Impostor");
                    ui.checkbox(&mut self.set.np3d, "NP3D");
                    ui.checkbox(&mut self.set.rigid, "Rigid");
                });
                ui.end_row();
                ui.label("Clips");
                ui.vertical(|ui| {
                    ui.horizontal_wrapped(|ui| {
                        for (on, c) in self.clips.iter_mut().zip(&doc.character.clips) {
                            ui.checkbox(on, &c.name);
                        }
                    });
                    if self.clips.len() > 1 {
                        ui.horizontal(|ui| {
                            if ui.small_button("all").clicked() {
                                self.clips.iter_mut().for_each(|c| *c = true);
                            }
                            if ui.small_button("only the viewed one").clicked() {
                                for (i, c) in self.clips.iter_mut().enumerate() {
                                    *c = Some(i) == clip;
                                }
                            }
                        });
                    }
                    if self.clips.iter().filter(|&&c| c).count() > 1 {
                        ui.label(
                            egui::RichText::new("one whole-character pack: every clip shares the key images")
                                .small()
                                .weak(),
                        );
                    }
                });
                ui.end_row();
                ui.label("Views");
                ui.horizontal(|ui| {
                    ui.add(egui::Slider::new(&mut self.views, 1..=400).logarithmic(true));
                    for n in [24, 60, 137] {
                        if ui.small_button(n.to_string()).clicked() {
                            self.views = n;
                        }
                    }
                });
                ui.end_row();
                ui.label("Resolution");
                egui::ComboBox::from_id_salt("export resolution")
                    .selected_text(format!("{0}×{0}", self.resolution))
                    .show_ui(ui, |ui| {
                        for r in [64, 96, 128, 192, 256] {
                            ui.selectable_value(&mut self.resolution, r, format!("{r}×{r}"));
                        }
                    });
                ui.end_row();
                ui.label("Frame rate");
                ui.add(egui::Slider::new(&mut self.fps, 2.0..=30.0).suffix(" fps").step_by(1.0));
                ui.end_row();
                ui.label("Textures");
                let label = |t: TextureEncoding, p: PngCompression| match t {
                    TextureEncoding::Bc7 => "BC7 in KTX2 (GPU-compressed)",
                    TextureEncoding::Png => p.label(),
                };
                egui::ComboBox::from_id_salt("export png")
                    .selected_text(label(self.textures, self.png))
                    .show_ui(ui, |ui| {
                        let mut pick = (self.textures, self.png);
                        ui.selectable_value(&mut pick, (TextureEncoding::Bc7, self.png), label(TextureEncoding::Bc7, self.png));
                        for p in PngCompression::ALL {
                            ui.selectable_value(&mut pick, (TextureEncoding::Png, p), p.label());
                        }
                        (self.textures, self.png) = pick;
                    })
                    .response
                    .on_hover_text(
                        "BC7: what a GPU samples, a quarter of the memory, slightly lossy; PNG: lossless at every \
                         level (slower writing gives smaller files)",
                    );
                ui.end_row();
                ui.label("Polygon vertices");
                let most = polypostor::bake::part_fit::PartFitOptions::default().key_vertices;
                ui.add(egui::Slider::new(&mut self.polygon_vertices, 3..=most))
                    .on_hover_text(
                        "Vertices of each part's polygon: fewer make a smaller pack and less work for the crowd, \
                         with coarser warps (the paper used 20; the crowd draws half of them for small characters)",
                    );
                ui.end_row();
            });
            ui.separator();
            // Memory before writing.
            let texture_bytes: u64 = doc
                .character
                .textures
                .iter()
                .map(|t| t.width as u64 * t.height as u64 * 4)
                .sum();
            let e = estimate(
                self.views,
                self.resolution,
                frames,
                doc.segmentation.parts.len(),
                doc.character.vertices.len(),
                texture_bytes,
            )
            .with_polygon_vertices(
                self.polygon_vertices + polypostor::reps::compare::kept_interior(doc.project.bake.interior_vertices),
                self.views,
                frames,
                doc.segmentation.parts.len(),
            )
            .with_keys(
                &doc.project.bake.options().keys,
                self.views,
                frames,
                chosen.len(),
                self.resolution,
            )
            .with_textures(self.textures);
            let how = match self.textures {
                TextureEncoding::Bc7 => "textures as BC7 blocks",
                TextureEncoding::Png => "uncompressed",
            };
            ui.label(egui::RichText::new(format!("Estimated memory ({frames} frames, {how})")).strong());
            let mut total = 0;
            egui::Grid::new("export estimate").num_columns(2).striped(true).show(ui, |ui| {
                for (on, name, bytes) in [
                    (self.set.polypostor, "Polypostor", e.polypostor),
                    (self.set.impostor, "Classic impostor", e.impostor),
                    (self.set.np3d, "NP3D impostor", e.np3d),
                    (self.set.rigid, "Rigid mesh", e.rigid),
                ] {
                    // Every row always (unticked ones greyed): a table growing and shrinking
                    // as boxes were ticked re-centred the dialog under the pointer.
                    if on {
                        ui.label(name);
                        ui.label(mb(bytes));
                        total += bytes;
                    } else {
                        ui.label(egui::RichText::new(name).weak());
                        ui.label(egui::RichText::new("not exported").weak());
                    }
                    ui.end_row();
                }
                ui.strong("Total");
                ui.strong(mb(total));
                ui.end_row();
            });
            // (A line always, for the same reason.)
            ui.label(
                egui::RichText::new(if e.polypostor > 0 {
                    format!(
                        "Polypostors: {:.0}× less memory than classic impostors",
                        e.impostor as f64 / e.polypostor as f64
                    )
                } else {
                    String::new()
                })
                .weak(),
            );
            let basis = OverrideBasis {
                views: self.views,
                full_sphere: false,
                frames,
            };
            let ov = &doc.project.overrides;
            if !ov.is_empty() && ov.basis != basis {
                ui.label(
                    egui::RichText::new(format!(
                        "The project's corrections were made for {} views and {} frames; they do not apply to this export.",
                        ov.basis.views, ov.basis.frames
                    ))
                    .color(ui.visuals().warn_fg_color),
                );
            }
            // The folder may not hold anything this tool did not write (checked as typed).
            let folder = self.folder.trim().to_string();
            if self.folder_check.as_ref().is_none_or(|(f, _)| *f != folder) {
                let problem = (!folder.is_empty())
                    .then(|| polypostor::safe_fs::check_bake_output(Path::new(&folder), &[&doc.character_path]).err())
                    .flatten();
                self.folder_check = Some((folder.clone(), problem));
            }
            let folder_problem = self.folder_check.as_ref().and_then(|(_, p)| p.clone());
            if let Some(p) = &folder_problem {
                ui.label(egui::RichText::new(format!("⚠ {p}")).color(ui.visuals().warn_fg_color));
            }
            let no_clip = !doc.character.clips.is_empty() && !self.clips.iter().any(|&c| c);
            let nothing = !(self.set.polypostor || self.set.any_other()) || no_clip;
            ui.add_space(6.0);
            ui.horizontal(|ui| {
                let ok = !nothing && !folder.is_empty() && folder_problem.is_none();
                if ui.add_enabled(ok, egui::Button::new("Export")).clicked() {
                    request = Some(ExportRequest {
                        folder: PathBuf::from(self.folder.trim()),
                        set: self.set,
                        views: self.views,
                        resolution: self.resolution,
                        fps: self.fps,
                        png: self.png,
                        textures: self.textures,
                        polygon_vertices: self.polygon_vertices,
                        clips: self
                            .clips
                            .iter()
                            .zip(&doc.character.clips)
                            .filter(|(on, _)| **on)
                            .map(|(_, c)| c.name.clone())
                            .collect(),
                    });
                    close = true;
                }
                if ui.button("Cancel").clicked() || ui.input(|i| i.key_pressed(egui::Key::Escape)) {
                    close = true;
                }
                if no_clip {
                    ui.label(egui::RichText::new("choose at least one clip").weak());
                } else if nothing {
                    ui.label(egui::RichText::new("choose at least one representation").weak());
                }
            });
        });
        if close {
            self.open = false;
        }
        request
    }
}
