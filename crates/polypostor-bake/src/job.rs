//! The bake of a character into one folder — the one entry that the command line
//! (`polypostor bake`), the editor's Ctrl+B and its export dialog all call.
//!
//! A bake starts from its inputs ([`BakeInput::resolve`]: a project or a glTF file), the
//! clips it holds ([`ClipChoice::resolve`]: the same rule everywhere), the segmentation
//! ([`segmentation_for`]) and where it goes ([`check_output`], [`default_out`]); [`run`]
//! then checks the plan, bakes the Polypostor and every other representation of the set
//! (each view rendered once for all of them), and writes the folder atomically with its
//! `report.json`.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::bake::pipeline::{BakeError, Progress};
use crate::bake::segment::Segmentation;
use crate::character::Character;
use crate::gpu::GpuContext;
use crate::project::Project;
use crate::reps::RepSet;

/// What a bake's input names: the project (when one is given or the input is one), its
/// file, and the character's path.
#[derive(Clone, Debug)]
pub struct BakeInput {
    pub project: Option<Project>,
    pub project_file: Option<PathBuf>,
    pub character_path: PathBuf,
    /// Which of the character file's axes points up: the project's
    /// ([`crate::project::CharacterRef::up`]), or `--up`.
    pub up: crate::import::UpAxis,
}

impl BakeInput {
    /// `input` is a glTF/GLB file (with `project` optionally supplying the project's
    /// segmentation, caps, corrections and settings) or a project (file or folder).
    pub fn resolve(input: &Path, project: Option<&Path>) -> Result<Self, String> {
        // By name, or by the GLB magic for a binary glTF named otherwise (a .vrm avatar).
        let is_gltf = input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"))
            || starts_as_glb(input);
        if !is_gltf && project.is_some() {
            return Err(format!(
                "'{}' is a project and --project names another: give the character file with --project, or the project alone",
                input.display()
            ));
        }
        if is_gltf {
            let (project, project_file) = match project {
                Some(p) => {
                    let (p, f) = Project::load(p).map_err(|e| e.to_string())?;
                    (Some(p), Some(f))
                }
                None => (None, None),
            };
            Ok(Self {
                up: project.as_ref().map(|p| p.character.up).unwrap_or_default(),
                project,
                project_file,
                character_path: input.to_owned(),
            })
        } else {
            let (p, file) = Project::load(input).map_err(|e| e.to_string())?;
            let character_path = p.character_path(&file);
            Ok(Self {
                up: p.character.up,
                project: Some(p),
                project_file: Some(file),
                character_path,
            })
        }
    }

    /// The project's bake settings, or the defaults without a project.
    pub fn settings(&self) -> crate::bake::settings::BakeSettings {
        self.project.as_ref().map(|p| p.bake.clone()).unwrap_or_default()
    }

    /// The project's segmentation when it fits `c`, else the automatic one.
    pub fn segmentation(&self, c: &Character) -> (Segmentation, Option<String>) {
        segmentation_for(self.project.as_ref(), c)
    }

    /// The project's cap overrides and per-view corrections (none without a project).
    pub fn caps_and_overrides(&self) -> (crate::bake::caps::CapOverrides, crate::bake::overrides::BakeOverrides) {
        match &self.project {
            Some(p) => (p.caps.clone(), p.overrides.clone()),
            None => Default::default(),
        }
    }
}

/// The project's segmentation when it fits the character, else the automatic one, with a
/// warning saying why the project's was not used.
pub fn segmentation_for(project: Option<&Project>, c: &Character) -> (Segmentation, Option<String>) {
    match project.and_then(|p| p.segmentation.as_ref()) {
        Some(s) => match s.to_segmentation(c.triangle_count()) {
            Ok(seg) => {
                // A painted part with a piece far from the rest of it fits badly in every
                // view (joined by a thin bridge): said, never silently.
                let stray = stray_note(c, &seg);
                let note = match (s.renamed_note(&seg), stray) {
                    (Some(a), Some(b)) => Some(format!("{a}\n{b}")),
                    (a, b) => a.or(b),
                };
                (seg, note)
            }
            Err(e) => (
                crate::bake::segment::auto_segment(c),
                Some(format!(
                    "the project's segmentation does not fit this character ({e}); using the automatic one"
                )),
            ),
        },
        None => (crate::bake::segment::auto_segment(c), None),
    }
}

/// What [`crate::edit::paint::stray_pieces`] finds in `seg`, as one warning (`None`: nothing).
pub fn stray_note(c: &Character, seg: &Segmentation) -> Option<String> {
    let topo = crate::edit::paint::Topology::new(c);
    let strays = crate::edit::paint::stray_pieces(c, &topo, seg);
    if strays.is_empty() {
        return None;
    }
    let name = |p: u16| seg.parts.get(p as usize).map_or("?", |q| q.name.as_str());
    let list: Vec<String> = strays
        .iter()
        .take(3)
        .map(|s| {
            format!(
                "'{}' has {} {} from the rest of it{}",
                name(s.part),
                crate::import::plural(s.triangles.len(), "triangle"),
                crate::crowd::metres(s.distance),
                s.touches.map_or(String::new(), |t| format!(" (amid '{}')", name(t)))
            )
        })
        .collect();
    Some(format!(
        "{}{}: every view joins such a piece to its part with a thin bridge and fits it badly; paint it with the part around it (the editor's Segment tab offers it)",
        list.join("; "),
        if strays.len() > 3 {
            format!(" and {} more pieces", strays.len() - 3)
        } else {
            String::new()
        }
    ))
}

/// The clips one bake holds: the first, and the further clips of a whole-character pack.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ClipChoice {
    /// `None`: the character has no clip (its rest pose is baked).
    pub first: Option<usize>,
    pub extra: Vec<usize>,
}

/// What a bake was asked for, from the most to the least specific.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClipRequest<'a> {
    /// A comma-separated list of clip names (the command line's `--clips`).
    pub list: Option<&'a str>,
    /// One clip by name (`--clip`); the project's clip set is then left aside.
    pub clip: Option<&'a str>,
    /// The project's clip set (a whole-character pack when it has several).
    pub project_clips: &'a [String],
    /// The clip being viewed (the editor's playback, the project's saved view).
    pub viewed: Option<usize>,
}

impl ClipChoice {
    /// The one rule of every bake: an explicit list, else one named clip, else the
    /// project's clip set, else the clip being viewed, else `Walk`, else the first clip.
    /// Names that do not exist are errors naming the clips there are; the project's own
    /// set skips names the character lost (said by the project's checks elsewhere).
    pub fn resolve(c: &Character, req: ClipRequest) -> Result<Self, String> {
        let find = |n: &str| c.find_clip(n).ok_or_else(|| crate::timeline::no_clip_named(n, c));
        let from_list = |names: &[String]| -> Result<Self, String> {
            let idx = names.iter().map(|n| find(n)).collect::<Result<Vec<_>, _>>()?;
            Ok(Self {
                first: idx.first().copied(),
                extra: idx.into_iter().skip(1).collect(),
            })
        };
        if let Some(list) = req.list {
            let names = crate::timeline::parse_clip_list(list, c).map_err(|e| format!("--clips: {e}"))?;
            return from_list(&names);
        }
        if let Some(n) = req.clip {
            return Ok(Self {
                first: Some(find(n)?),
                extra: Vec::new(),
            });
        }
        let known: Vec<String> = req
            .project_clips
            .iter()
            .filter(|n| c.find_clip(n).is_some())
            .cloned()
            .collect();
        if !known.is_empty() {
            return from_list(&known);
        }
        Ok(Self {
            first: req
                .viewed
                .filter(|&i| i < c.clips.len())
                .or_else(|| c.find_clip("Walk"))
                .or((!c.clips.is_empty()).then_some(0)),
            extra: Vec::new(),
        })
    }

    /// The first clip's name.
    pub fn name<'c>(&self, c: &'c Character) -> Option<&'c str> {
        self.first.and_then(|i| c.clips.get(i)).map(|k| k.name.as_str())
    }

    /// Whether this is a whole-character pack of several clips.
    pub fn is_several(&self) -> bool {
        !self.extra.is_empty()
    }
}

/// What to tell the user when a project's clip set names clips `c` does not have: which,
/// and what is baked instead (`None` when every name is there).
pub fn lost_clips_warning(c: &Character, project_clips: &[String], baked: &ClipChoice) -> Option<String> {
    let lost: Vec<&str> = project_clips
        .iter()
        .filter(|n| c.find_clip(n).is_none())
        .map(String::as_str)
        .collect();
    if lost.is_empty() {
        return None;
    }
    let baked: Vec<&str> = baked
        .first
        .into_iter()
        .chain(baked.extra.iter().copied())
        .filter_map(|i| c.clips.get(i).map(|k| k.name.as_str()))
        .collect();
    Some(format!(
        "the project's clip set names {} that the character does not have; baking {}",
        lost.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", "),
        if baked.is_empty() {
            "its rest pose".to_string()
        } else {
            baked.join(", ")
        }
    ))
}

/// Whether `path` is a regular file starting with the GLB magic `glTF`.
fn starts_as_glb(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 4];
    std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file())
        && std::fs::File::open(path)
            .and_then(|mut f| f.read_exact(&mut magic))
            .is_ok()
        && &magic == b"glTF"
}

/// Where a bake goes when no folder is named: `<stem>-<clip>.pack` (`-rest` without a clip,
/// `-clips` for several), in the working folder.
pub fn default_out(character_path: &Path, clips: &ClipChoice, c: &Character) -> PathBuf {
    let stem = character_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "character".into());
    if clips.is_several() {
        PathBuf::from(format!("{stem}-clips.pack"))
    } else {
        PathBuf::from(format!(
            "{stem}-{}.pack",
            name_for_file(clips.name(c).unwrap_or("rest"))
        ))
    }
}

/// A clip's name as part of a file name: letters, digits, `-`, `_`, `.` and spaces kept,
/// anything else (path separators, control characters, `:*?"<>|`) made `_`, leading dots
/// and spaces dropped, at most 64 characters. The name comes from the glTF: a clip named
/// `../../x` must not choose where a bake writes.
pub fn name_for_file(name: &str) -> String {
    let kept: String = name
        .chars()
        .map(|ch| {
            if ch.is_alphanumeric() || matches!(ch, '-' | '_' | '.' | ' ') {
                ch
            } else {
                '_'
            }
        })
        .take(64)
        .collect();
    let kept = kept.trim_start_matches(['.', ' ']).trim_end();
    if kept.is_empty() { "clip".into() } else { kept.into() }
}

/// Checks, before any work, that a bake may write `out`: never over what this tool did not
/// write, never over the character or the project file, and (when `project_file` is given:
/// the command line's rule for a named `--out`) never into the project's own folder but for
/// its [`crate::project::PROJECT_PACK`], where the editor bakes it and reads it back.
pub fn check_output(out: &Path, character_path: &Path, project_file: Option<&Path>) -> Result<(), String> {
    let mut protected: Vec<&Path> = vec![character_path];
    if let Some(f) = project_file {
        protected.push(f);
        if let Some(dir) = f.parent().filter(|d| !d.as_os_str().is_empty()) {
            let (dir_real, out_real) = (crate::safe_fs::resolved(dir), crate::safe_fs::resolved(out));
            if out_real.starts_with(&dir_real) && out_real != dir_real.join(crate::project::PROJECT_PACK) {
                return Err(format!(
                    "'{}' {} the project folder '{}'; write packs beside the project, not into it (its {} is the one folder inside it a bake may write: the editor's)",
                    out.display(),
                    if out_real == dir_real { "is" } else { "lies inside" },
                    dir.display(),
                    crate::project::PROJECT_PACK
                ));
            }
        }
    }
    crate::safe_fs::check_bake_output(out, &protected)?;
    crate::safe_fs::check_can_write_beside(out)
}

/// A hook that adds files to a bake folder before it moves into place.
pub type ExtraFiles<'a> = dyn Fn(&std::path::Path, Option<&crate::bake::pipeline::Bake>) -> Result<(), String> + 'a;

/// Where a whole bake goes and what it holds.
pub struct BakeJob<'a> {
    pub character: &'a Character,
    /// Written into `representations.json` (meshes draw from it).
    pub character_path: &'a std::path::Path,
    pub segmentation: &'a crate::bake::segment::Segmentation,
    pub caps: &'a crate::bake::caps::CapOverrides,
    pub options: &'a crate::bake::pipeline::BakeOptions,
    pub set: RepSet,
    pub out: &'a std::path::Path,
    /// The last bake into `out`: only what changed since is baked again
    /// ([`crate::bake::pipeline::rebake`]).
    pub previous: Option<&'a crate::bake::pipeline::Bake>,
    /// Copy the other representations from the folder already at `out` instead of baking
    /// them again (when `previous` applies: same character, segmentation and settings).
    pub reuse_representations: bool,
}

/// What [`run`] wrote.
pub struct BakeOutcome {
    pub bake: Option<crate::bake::pipeline::Bake>,
    pub stats: Option<crate::pack::PackStats>,
    /// What an incremental bake re-did (`None`: a plain bake).
    pub reuse: Option<crate::bake::pipeline::Reuse>,
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{0}")]
    Bake(#[from] BakeError),
    #[error("writing {path}: {message}")]
    Write { path: String, message: String },
    #[error("{0}")]
    Output(String),
}

/// Bakes every representation of `job.set` and writes them into one folder (the Polypostor
/// pack with its `report.json`, and `representations.json` with its files), replacing
/// `job.out` only once everything is written and reads back. `extra(folder, bake)` may add
/// files (debug images) before the folder moves into place.
pub fn run(
    ctx: &GpuContext,
    job: &BakeJob,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
    extra: &ExtraFiles,
) -> Result<BakeOutcome, JobError> {
    use crate::bake::pipeline::KeyFrame;
    let started = std::time::Instant::now();
    let profile = crate::bake::profile::snapshot();
    let o = job.options;
    let clip_name = o.clip.and_then(|i| job.character.clips.get(i)).map(|k| k.name.as_str());
    // Everything that can be known before the work: the settings, the output folder.
    crate::bake::plan::check(
        job.character,
        job.segmentation,
        o,
        job.set,
        ctx.device.limits().max_texture_dimension_2d,
    )
    .map_err(BakeError::from)?;
    crate::safe_fs::check_bake_output(job.out, &[job.character_path]).map_err(JobError::Output)?;
    crate::safe_fs::check_can_write_beside(job.out).map_err(JobError::Output)?;
    let mut reuse = None;
    // The other representations' whole-character images, composited from the Polypostor's
    // part renders as the bake makes them (each view is rendered once).
    let frames = crate::timeline::Timeline::new(job.character, &o.clip_list(), o.fps)
        .map_err(BakeError::from)?
        .frames();
    let mut shared = (job.set.polypostor && (job.set.impostor || job.set.np3d))
        .then(|| crate::reps::bake::SharedRenders::new(o.views.max(1), frames, o.resolution, job.set));
    let mut on_view = |v: &crate::bake::pipeline::ViewRenders| {
        if let Some(s) = shared.as_mut() {
            crate::bake::profile::in_root("other representations", || s.add(v));
        }
    };
    let bake = if job.set.polypostor {
        Some(match job.previous {
            Some(prev) => {
                let (b, r) = crate::bake::pipeline::rebake_sharing(
                    ctx,
                    prev,
                    job.character,
                    job.segmentation,
                    job.caps,
                    o,
                    progress,
                    cancel,
                    &mut on_view,
                )?;
                reuse = Some(r);
                b
            }
            None => crate::bake::pipeline::bake_sharing(
                ctx,
                job.character,
                job.segmentation,
                job.caps,
                o,
                progress,
                cancel,
                &mut on_view,
            )?,
        })
    } else {
        None
    };
    // The other representations depend on the character, segmentation and settings only:
    // after an incremental bake they are copied from the folder they are already in.
    let copy_from = (job.reuse_representations
        && reuse.is_some_and(|r| !r.full)
        && job.set.any_other()
        && crate::reps::load_representations(job.out).is_ok())
    .then(|| job.out.to_owned());
    let reps = if job.set.any_other() && copy_from.is_none() {
        let key = match (&bake, o.key_frame) {
            (Some(b), _) => b.key_frame,
            (None, KeyFrame::Frame(k)) => k,
            (None, KeyFrame::Auto) => 0,
        };
        let reps_options = crate::reps::bake::RepsOptions {
            views: o.views,
            coverage: o.coverage,
            resolution: o.resolution,
            fps: o.fps,
            clip: o.clip,
            extra_clips: o.extra_clips.clone(),
            key_frame: key,
            set: job.set,
            np3d_triangles: crate::reps::bake::NP3D_TRIANGLES,
            part_labels: job.segmentation.labels.iter().map(|&l| l as u32).collect(),
        };
        let path = std::fs::canonicalize(job.character_path).unwrap_or_else(|_| job.character_path.to_owned());
        Some(crate::bake::profile::in_root("other representations", || {
            crate::reps::bake::bake_representations_sharing(
                ctx,
                job.character,
                Some(&path.display().to_string()),
                clip_name,
                &reps_options,
                shared.take(),
                progress,
                cancel,
            )
        })?)
    } else {
        None
    };
    let write_reps = |dir: &std::path::Path| -> Result<(), String> {
        if let Some(from) = &copy_from {
            // Every file of the old folder the new one does not have yet (the pack's own
            // files were just written under the same names).
            for entry in std::fs::read_dir(from).map_err(|e| e.to_string())? {
                let entry = entry.map_err(|e| e.to_string())?;
                let target = dir.join(entry.file_name());
                if entry.file_type().map_err(|e| e.to_string())?.is_file() && !target.exists() {
                    std::fs::copy(entry.path(), &target).map_err(|e| e.to_string())?;
                }
            }
            crate::reps::load_representations(dir)
                .map_err(|e| format!("the copied representations do not load back: {e}"))?;
        }
        if let Some(r) = &reps {
            // The sheets as BC7 with the pack's textures (colour sRGB, normals linear with
            // their part numbers beside them), else PNG.
            let bc7 = |img: &image::RgbaImage, format| crate::pack::bc::encode_ktx2(img, format);
            let encode: Option<crate::reps::SheetEncoder> = match job.options.textures {
                crate::bake::pipeline::TextureEncoding::Bc7 => Some(&bc7),
                crate::bake::pipeline::TextureEncoding::Png => None,
            };
            crate::bake::profile::in_root("write", || crate::reps::write_representations_with(r, dir, encode))?;
            crate::reps::load_representations(dir)
                .map_err(|e| format!("the written representations do not load back: {e}"))?;
        }
        Ok(())
    };
    let write_error = |message: String| JobError::Write {
        path: job.out.display().to_string(),
        message,
    };
    let Some(mut b) = bake else {
        crate::pack::write_folder_atomic(job.out, &|dir| {
            write_reps(dir)?;
            extra(dir, None)
        })
        .map_err(write_error)?;
        return Ok(BakeOutcome {
            bake: None,
            stats: None,
            reuse: None,
        });
    };
    // The pack names the file it was baked from, so `compare` and the crowd find it.
    let source = std::fs::canonicalize(job.character_path).unwrap_or_else(|_| job.character_path.to_owned());
    b.character_path = Some(source.display().to_string());
    let write_started = std::time::Instant::now();
    let stats = crate::pack::write_pack_with(&b, &job.character.name, clip_name, job.out, &|dir, stats| {
        // Read the pack back through the validating loader before it replaces anything.
        crate::pack::load_pack(dir).map_err(|e| format!("the written pack does not load back: {e}"))?;
        write_reps(dir)?;
        let mut report = crate::bake::report::build_report(
            &b,
            &job.character.name,
            clip_name,
            stats,
            started.elapsed().as_secs_f64(),
        );
        report
            .stage_seconds
            .insert("write".into(), write_started.elapsed().as_secs_f64());
        report.cpu_seconds = profile.since();
        report.cpu_counts = profile.counts_since();
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        std::fs::write(dir.join("report.json"), text).map_err(|e| e.to_string())?;
        extra(dir, Some(&b))
    })
    .map_err(write_error)?;
    Ok(BakeOutcome {
        bake: Some(b),
        stats: Some(stats),
        reuse,
    })
}

/// What one bake is asked for beyond its input (the command line's flags; the defaults
/// bake the project's settings into `<stem>-<clip>.pack`).
#[derive(Clone, Debug, Default)]
pub struct Request<'a> {
    /// The input's settings with any overrides applied ([`BakeInput::settings`]).
    pub settings: crate::bake::settings::BakeSettings,
    pub key_frame: crate::bake::pipeline::KeyFrame,
    /// A comma-separated clip list, or one clip ([`ClipRequest`]).
    pub clips: Option<&'a str>,
    pub clip: Option<&'a str>,
    /// Where the folder goes (`None`: [`default_out`]).
    pub out: Option<PathBuf>,
    /// Keep every frame's images for debug pictures.
    pub keep_frame_images: bool,
}

/// A bake with everything resolved and checked that can be without a GPU: the character
/// imported, its clips, segmentation, caps, corrections, options and output folder.
pub struct Prepared {
    pub input: BakeInput,
    pub character: Character,
    pub clips: ClipChoice,
    pub segmentation: Segmentation,
    pub caps: crate::bake::caps::CapOverrides,
    pub options: crate::bake::pipeline::BakeOptions,
    pub set: RepSet,
    pub out: PathBuf,
    /// What the user should hear before the bake (import warnings, a segmentation that did
    /// not fit).
    pub warnings: Vec<String>,
}

impl Prepared {
    /// Validates the settings and the output folder before reading the character, then
    /// imports it and resolves its clips and segmentation. Errors name the flag or input
    /// at fault.
    pub fn new(input: BakeInput, req: Request) -> Result<Self, String> {
        req.settings.validate().map_err(|e| e.to_string())?;
        let set = req.settings.representation_set();
        let check = |out: &Path| {
            check_output(out, &input.character_path, input.project_file.as_deref()).map_err(|e| format!("--out {e}"))
        };
        if let Some(out) = &req.out {
            check(out)?;
        }
        let character = crate::import_path_with(&input.character_path, crate::ImportOptions { up: input.up })
            .map_err(|e| format!("{}: {e}", input.character_path.display()))?;
        let mut warnings = character.warnings.clone();
        let project_clips = input.project.as_ref().map(|p| p.clips.as_slice()).unwrap_or_default();
        let viewed = input
            .project
            .as_ref()
            .and_then(|p| p.view.clip.as_deref())
            .and_then(|n| character.find_clip(n));
        let clips = ClipChoice::resolve(
            &character,
            ClipRequest {
                list: req.clips,
                clip: req.clip,
                project_clips,
                viewed,
            },
        )?;
        // The project's clip set is used when nothing more specific was asked for; names the
        // character no longer has are skipped, and said.
        if req.clips.is_none() && req.clip.is_none() {
            warnings.extend(lost_clips_warning(&character, project_clips, &clips));
            // The clip the project was viewing decides when its clip set does not: a name
            // the character does not have is said, with what is baked instead.
            let set_decides = project_clips.iter().any(|n| character.find_clip(n).is_some());
            if let Some(name) = input.project.as_ref().and_then(|p| p.view.clip.as_deref())
                && viewed.is_none()
                && !set_decides
            {
                warnings.push(format!(
                    "the project's clip '{name}' is not among the character's clips; baking {}",
                    clips.name(&character).unwrap_or("its rest pose")
                ));
            }
        }
        let (segmentation, seg_warning) = input.segmentation(&character);
        warnings.extend(seg_warning);
        warnings.extend(input.project_file.as_deref().and_then(Project::unknown_keys_warning));
        // A part painted over entirely keeps its name but draws nothing: said once here, not
        // as "not visible" in every view.
        let mut counts = vec![0usize; segmentation.parts.len()];
        for &l in &segmentation.labels {
            if let Some(c) = counts.get_mut(l as usize) {
                *c += 1;
            }
        }
        let empty: Vec<&str> = segmentation
            .parts
            .iter()
            .zip(&counts)
            .filter(|(_, c)| **c == 0)
            .map(|(p, _)| p.name.as_str())
            .collect();
        if !empty.is_empty() {
            warnings.push(format!(
                "part(s) {} hold no triangles and draw nothing (paint some triangles into them, or remove them)",
                empty.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")
            ));
        }
        // Allowed, but a polygon of a few vertices cannot follow a limb: 3 gave 5.6 dB.
        let n = req.settings.polygon_vertices;
        if n < FEW_POLYGON_VERTICES {
            warnings.push(format!(
                "polygons of {n} vertices follow only the coarsest outline of each part; expect low fidelity (default {})",
                crate::bake::settings::BakeSettings::default().polygon_vertices
            ));
        }
        let (caps, overrides) = input.caps_and_overrides();
        let options = crate::bake::pipeline::BakeOptions {
            clip: clips.first,
            extra_clips: clips.extra.clone(),
            key_frame: req.key_frame,
            overrides,
            keep_frame_images: req.keep_frame_images,
            ..req.settings.options()
        };
        let out = match req.out {
            // `sub/../d.pack` with no `sub`: `d.pack` (no empty `sub` made, and every later
            // read of the folder finds it).
            Some(o) => crate::safe_fs::without_missing_dotdot(&o),
            None => {
                let o = default_out(&input.character_path, &clips, &character);
                check(&o)?;
                o
            }
        };
        Ok(Self {
            input,
            character,
            clips,
            segmentation,
            caps,
            options,
            set,
            out,
            warnings,
        })
    }

    /// The job [`run`] bakes.
    pub fn job(&self) -> BakeJob<'_> {
        BakeJob {
            character: &self.character,
            character_path: &self.input.character_path,
            segmentation: &self.segmentation,
            caps: &self.caps,
            options: &self.options,
            set: self.set,
            out: &self.out,
            previous: None,
            reuse_representations: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(c: &Character, k: &ClipChoice) -> Vec<String> {
        k.first
            .into_iter()
            .chain(k.extra.iter().copied())
            .map(|i| c.clips[i].name.clone())
            .collect()
    }

    /// A project's painted part with a piece far from the rest of it is said before the
    /// bake, naming the part and where the piece lies; the automatic parts say nothing.
    #[test]
    fn a_stray_piece_of_a_painted_part_is_said() {
        let c = crate::default_character::generate();
        let seg = crate::bake::segment::auto_segment(&c);
        assert_eq!(stray_note(&c, &seg), None);
        let leg = seg.parts.iter().position(|p| p.name == "Right Leg").unwrap() as u16;
        let (pos, _) = crate::animation::skin_vertices(&c, &crate::animation::Pose::rest(&c));
        let low = |t: usize| (0..3).map(|k| pos[c.indices[3 * t + k] as usize].y).sum::<f32>();
        let foot = (0..seg.labels.len())
            .filter(|&t| seg.labels[t] == leg)
            .min_by(|&a, &b| low(a).total_cmp(&low(b)))
            .unwrap();
        let mut painted = seg.clone();
        painted.labels[foot] = 0;
        let note = stray_note(&c, &painted).expect("said");
        assert!(
            note.starts_with("'Torso' has 1 triangle ") && note.contains("(amid 'Right Leg')"),
            "{note}"
        );
    }

    #[test]
    fn one_clip_rule_from_the_most_to_the_least_specific() {
        let c = crate::default_character::generate();
        let project = vec!["Run".to_string(), "Idle".to_string()];
        let resolve = |req: ClipRequest| ClipChoice::resolve(&c, req).map(|k| names(&c, &k));
        // An explicit list wins over everything, in its order.
        let req = ClipRequest {
            list: Some("Wave, Walk"),
            clip: Some("Run"),
            project_clips: &project,
            viewed: Some(2),
        };
        assert_eq!(resolve(req).unwrap(), ["Wave", "Walk"]);
        // One named clip leaves the project's set aside.
        let req = ClipRequest {
            clip: Some("Wave"),
            project_clips: &project,
            ..Default::default()
        };
        assert_eq!(resolve(req).unwrap(), ["Wave"]);
        // The project's set, names the character lost skipped.
        let lost = vec!["Jump".to_string(), "Idle".to_string(), "Run".to_string()];
        let req = ClipRequest {
            project_clips: &lost,
            viewed: Some(3),
            ..Default::default()
        };
        assert_eq!(resolve(req).unwrap(), ["Idle", "Run"]);
        let k = ClipChoice::resolve(&c, req).unwrap();
        let w = lost_clips_warning(&c, &lost, &k).expect("a lost clip is said");
        assert!(w.contains("'Jump'") && w.contains("baking Idle, Run"), "{w}");
        assert_eq!(lost_clips_warning(&c, &project, &k), None, "every name is there");
        // Then the viewed clip, then Walk, then the first.
        let viewed = ClipRequest {
            viewed: Some(3),
            ..Default::default()
        };
        assert_eq!(resolve(viewed).unwrap(), ["Wave"]);
        let out_of_range = ClipRequest {
            viewed: Some(99),
            ..Default::default()
        };
        assert_eq!(resolve(out_of_range).unwrap(), ["Walk"]);
        let mut no_walk = c.clone();
        no_walk.clips.retain(|k| k.name != "Walk");
        let k = ClipChoice::resolve(&no_walk, ClipRequest::default()).unwrap();
        assert_eq!(names(&no_walk, &k), ["Run"]);
        // No clip at all: the rest pose.
        let mut still = c.clone();
        still.clips.clear();
        let k = ClipChoice::resolve(&still, ClipRequest::default()).unwrap();
        assert_eq!(k, ClipChoice::default());
        assert_eq!(
            default_out(Path::new("a/b/hero.glb"), &k, &still),
            PathBuf::from("hero-rest.pack")
        );
        // Names that do not exist are errors naming the clips there are.
        let e = resolve(ClipRequest {
            clip: Some("Jump"),
            ..Default::default()
        })
        .unwrap_err();
        assert!(
            e.contains("no clip named 'Jump'") && e.contains("Walk, Run, Idle, Wave"),
            "{e}"
        );
        let e = resolve(ClipRequest {
            list: Some("Walk,Jump"),
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.starts_with("--clips") && e.contains("Jump"), "{e}");
        // Default folders: the clip's name, or `-clips` for several.
        let several = ClipChoice::resolve(
            &c,
            ClipRequest {
                list: Some("all"),
                ..Default::default()
            },
        )
        .unwrap();
        assert!(several.is_several());
        assert_eq!(
            default_out(Path::new("hero.glb"), &several, &c),
            PathBuf::from("hero-clips.pack")
        );
    }

    /// A clip's name taken into the default folder name never leaves the working folder nor
    /// makes a name with separators or control characters.
    #[test]
    fn clip_names_make_plain_folder_names() {
        for (name, want) in [
            ("Walk", "Walk"),
            ("Run fast", "Run fast"),
            ("../../../../ESCAPED", "_.._.._.._ESCAPED"),
            ("anim/sub/clip", "anim_sub_clip"),
            ("a\\b:c*?\"<>|", "a_b_c______"),
            ("line\nbreak\t", "line_break_"),
            ("..", "clip"),
            ("", "clip"),
            ("  .hidden", "hidden"),
            ("Ходьба", "Ходьба"),
        ] {
            let got = name_for_file(name);
            assert_eq!(got, want, "{name:?}");
            let p = Path::new(&got);
            assert_eq!(p.components().count(), 1, "{got:?}");
            assert!(matches!(p.components().next(), Some(std::path::Component::Normal(_))));
        }
        assert_eq!(name_for_file(&"x".repeat(300)).len(), 64);
        let mut c = crate::default_character::generate();
        c.clips[0].name = "../../../../ESCAPED".into();
        let k = ClipChoice::resolve(
            &c,
            ClipRequest {
                clip: Some("../../../../ESCAPED"),
                ..Default::default()
            },
        )
        .unwrap();
        let out = default_out(Path::new("x/hero.glb"), &k, &c);
        assert_eq!(out, PathBuf::from("hero-_.._.._.._ESCAPED.pack"));
        assert_eq!(out.components().count(), 1);
    }

    #[test]
    fn outputs_never_land_on_inputs_or_inside_the_project() {
        let dir = crate::safe_fs::TempDir::new("polypostor-job-test").unwrap();
        let project_dir = dir.path().join("proj");
        std::fs::create_dir_all(&project_dir).unwrap();
        let project_file = project_dir.join("project.json");
        std::fs::write(&project_file, "{}").unwrap();
        let character = dir.path().join("hero.glb");
        std::fs::write(&character, b"glTF").unwrap();
        // Beside the project: fine; inside it, on it, or on the character: refused.
        assert!(check_output(&dir.path().join("hero.pack"), &character, Some(&project_file)).is_ok());
        let inside = check_output(&project_dir.join("hero.pack"), &character, Some(&project_file)).unwrap_err();
        assert!(inside.contains("lies inside the project folder"), "{inside}");
        let on = check_output(&project_dir, &character, Some(&project_file)).unwrap_err();
        assert!(on.contains("is the project folder"), "{on}");
        // Except the project's own pack, where the editor bakes it and reads it back; still
        // never over a folder of the user's own of that name.
        let own = project_dir.join(crate::project::PROJECT_PACK);
        assert!(check_output(&own, &character, Some(&project_file)).is_ok());
        std::fs::create_dir_all(&own).unwrap();
        std::fs::write(own.join("notes.txt"), b"mine").unwrap();
        assert!(check_output(&own, &character, Some(&project_file)).is_err());
        assert!(own.join("notes.txt").exists());
        std::fs::remove_dir_all(&own).unwrap();
        assert!(check_output(&character, &character, None).is_err());
        // A folder of the user's own is never written over.
        let theirs = dir.path().join("photos");
        std::fs::create_dir_all(&theirs).unwrap();
        std::fs::write(theirs.join("cat.jpg"), b"x").unwrap();
        assert!(check_output(&theirs, &character, None).is_err());
        assert!(theirs.join("cat.jpg").exists());
    }

    #[test]
    fn inputs_resolve_to_the_project_or_the_gltf_and_bad_ones_are_named() {
        // The workspace root (this crate sits in crates/polypostor-bake).
        let root = &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let project = root.join(crate::project::DEFAULT_PROJECT_DIR);
        let from_project = BakeInput::resolve(&project, None).unwrap();
        assert!(from_project.project.is_some());
        assert!(
            from_project
                .character_path
                .ends_with(crate::default_character::DEFAULT_CHARACTER_PATH)
        );
        let gltf = root.join(crate::default_character::DEFAULT_CHARACTER_PATH);
        let alone = BakeInput::resolve(&gltf, None).unwrap();
        assert!(alone.project.is_none() && alone.project_file.is_none());
        assert_eq!(alone.settings(), crate::bake::settings::BakeSettings::default());
        let with = BakeInput::resolve(&gltf, Some(&project)).unwrap();
        assert!(with.project.is_some() && with.character_path == gltf);
        assert!(BakeInput::resolve(&root.join("no-such-project"), None).is_err());
        // A project with --project naming another is refused; a GLB named otherwise (a VRM
        // avatar) is a character.
        assert!(BakeInput::resolve(&project, Some(&project)).is_err());
        let dir = crate::safe_fs::TempDir::new("polypostor-job-vrm").unwrap();
        let vrm = dir.path().join("avatar.vrm");
        std::fs::copy(&gltf, &vrm).unwrap();
        assert_eq!(BakeInput::resolve(&vrm, None).unwrap().character_path, vrm);
        assert_eq!(
            crate::bake::pipeline::KeyFrame::parse("auto"),
            Ok(crate::bake::pipeline::KeyFrame::Auto)
        );
        assert_eq!(
            crate::bake::pipeline::KeyFrame::parse("7"),
            Ok(crate::bake::pipeline::KeyFrame::Frame(7))
        );
        assert!(
            crate::bake::pipeline::KeyFrame::parse("-1")
                .unwrap_err()
                .contains("--key-frame")
        );
    }
}

/// Fewest polygon vertices a bake takes without a warning (`--polygon-vertices`).
pub const FEW_POLYGON_VERTICES: usize = 12;
