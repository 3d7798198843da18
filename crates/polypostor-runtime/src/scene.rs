//! A crowd ready to run and draw: the character, its baked representations on the GPU, the
//! agents and the per-frame loop (simulate, select, upload, draw). The editor's crowd
//! preview and `polypostor bench crowd` both drive this.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;

use crate::character::Character;
use crate::crowd::lod::{Level, LodPolicy};
use crate::crowd::{CharacterSize, ClipTiming, Crowd, CrowdCamera, CrowdParams, FrameStats, Species};
use crate::gpu::{Camera, CrowdRenderers, GpuError, PolypostorStyle, RenderTarget};
use crate::pack::LoadedPack;
use crate::reps::Representations;
use crate::viewpoints::ViewLookup;

/// Everything a crowd is drawn from.
pub struct CrowdAssets {
    /// The character baked, imported from `character_path` (its clips checked against the
    /// bake's).
    pub character: Character,
    /// The file the character was imported from: the one given, else the one the
    /// representations name.
    pub character_path: PathBuf,
    /// The first clip baked (`None`: the rest pose).
    pub clip: Option<usize>,
    /// Every clip baked, one after another (with the ground speeds measured at bake).
    pub timeline: crate::timeline::Timeline,
    /// Body part of each triangle (per-part tint of the meshes).
    pub labels: Vec<u32>,
    /// The Polypostor pack in `dir` (`manifest.json`), when there is one.
    pub pack: Option<LoadedPack>,
    /// The other representations in `dir` (impostors, NP3D, rigid frames), without the
    /// full-resolution impostor sheets where far ones were baked ([`CrowdAssets::full_impostors`]).
    /// At least one of `pack` and `reps` is present.
    pub reps: Option<Representations>,
    /// The character's size in metres: height and length from the clip it walks in (else the
    /// first), the culling sphere over every clip the crowd plays.
    pub size: CharacterSize,
    /// The folder loaded.
    pub dir: PathBuf,
    /// The full-resolution impostor sheets, read from `dir` when first asked for
    /// ([`CrowdAssets::full_impostors`]): the mix draws from the far ones.
    full_impostors: std::sync::OnceLock<Result<Option<crate::reps::ImpostorData>, String>>,
}

impl CrowdAssets {
    /// Loads the pack and/or representations in `dir` and the character they were baked
    /// from (`character`, else the path the representations name). `labels`: the body part
    /// of each triangle (None: the automatic segmentation).
    pub fn load(dir: &Path, character: Option<&Path>, labels: Option<Vec<u32>>) -> Result<Self, String> {
        // Present at all (a link to a device is present, and refused by the loader).
        let has = |name: &str| std::fs::symlink_metadata(dir.join(name)).is_ok();
        if !has("manifest.json") && !has(crate::reps::REPS_FILE) {
            return Err(format!(
                "{} holds neither a pack (manifest.json) nor representations ({})",
                dir.display(),
                crate::reps::REPS_FILE
            ));
        }
        let pack = if has("manifest.json") {
            Some(crate::pack::load_pack(dir).map_err(|e| format!("{}: {e}", dir.display()))?)
        } else {
            None
        };
        let reps = if has(crate::reps::REPS_FILE) {
            Some(crate::reps::load_representations_far(dir).map_err(|e| format!("{}: {e}", dir.display()))?)
        } else {
            None
        };
        let path = match character {
            Some(p) => p.to_owned(),
            None => reps
                .as_ref()
                .and_then(|r| r.manifest.character_path.clone())
                .or_else(|| pack.as_ref().and_then(|p| p.manifest.character_path.clone()))
                .map(PathBuf::from)
                .ok_or_else(|| {
                    "the pack does not say which character it was baked from: give the character (--character)"
                        .to_string()
                })?,
        };
        if let (Some(p), Some(r)) = (&pack, &reps) {
            check_agreement(&p.manifest, &r.manifest).map_err(|e| {
                format!(
                    "{}: manifest.json and {} disagree: {e} (they must come from one bake; re-bake)",
                    dir.display(),
                    crate::reps::REPS_FILE
                )
            })?;
        }
        // Read as the bake read it (a file whose artist said another axis is up).
        let up = reps
            .as_ref()
            .map(|r| r.manifest.character_up)
            .or_else(|| pack.as_ref().map(|p| p.manifest.character_up))
            .unwrap_or_default();
        let c = crate::import::import_path_with(&path, crate::import::ImportOptions { up }).map_err(|e| {
            let moved = character.is_none() && matches!(e, crate::import::ImportError::Io { .. });
            format!(
                "{}: {e}{}",
                path.display(),
                if moved {
                    " (where the pack says its character was: give --character FILE where it is now)"
                } else {
                    ""
                }
            )
        })?;
        let (spans, fps) = pack
            .as_ref()
            .map(|p| (p.manifest.clips.clone(), p.manifest.fps))
            .or_else(|| reps.as_ref().map(|r| (r.manifest.clips.clone(), r.manifest.fps)))
            .unwrap_or_else(|| {
                (
                    crate::timeline::Timeline::single(crate::timeline::REST_POSE, 1, 10.0).spans,
                    10.0,
                )
            });
        // The character must be the one baked: every clip by name, with its frame count at
        // the baked rate.
        let not_baked = |what: String| {
            format!(
                "{}: {what}: the character is not the one baked (give it with --character) or the folder is damaged",
                dir.display()
            )
        };
        let mut clips = Vec::with_capacity(spans.len());
        for s in &spans {
            if s.name == crate::timeline::REST_POSE {
                clips.push(None);
            } else {
                clips.push(Some(c.find_clip(&s.name).ok_or_else(|| {
                    not_baked(format!(
                        "{} has no clip named '{}' (a clip of the bake)",
                        path.display(),
                        s.name
                    ))
                })?));
            }
        }
        let timeline = match crate::timeline::Timeline::new(&c, &clips, fps) {
            Ok(t) => t,
            Err(e) => return Err(not_baked(format!("{}: {e}", path.display()))),
        };
        for (got, want) in timeline.spans.iter().zip(&spans) {
            if got.frames != want.frames {
                return Err(not_baked(format!(
                    "the bake has {} frames of clip '{}' at {fps} fps, but {} gives {}",
                    want.frames,
                    want.name,
                    path.display(),
                    got.frames
                )));
            }
        }
        // And at the size baked: the bake's cameras frame the character it saw (half their
        // side is about its radius); a copy at other units (a centimetre file with the metre
        // pack) would be drawn at the wrong size and compared with the wrong images.
        if let Some(p) = &pack {
            let framed = p
                .manifest
                .views
                .iter()
                .map(|v| v.camera.half_size)
                .fold(0.0f32, f32::max);
            let radius = CharacterSize::measure_clips(&c, &clips).radius;
            let ratio = framed / radius;
            if framed > 0.0 && radius > 0.0 && ratio.is_finite() && !(0.2..=5.0).contains(&ratio) {
                return Err(not_baked(format!(
                    "{} is {:.3e} units across, but the bake framed a character about {:.3e} across ({:.3}× this one)",
                    path.display(),
                    2.0 * radius,
                    2.0 * framed,
                    ratio
                )));
            }
        }
        // The table as baked (with its measured ground speeds).
        let timeline = crate::timeline::Timeline { spans, ..timeline };
        let clip = clips.first().copied().flatten();
        if let Some(n) = reps.as_ref().and_then(|r| r.np3d.as_ref())
            && let Some(bad) = n.source.iter().find(|&&s| s as usize >= c.vertices.len())
        {
            return Err(format!(
                "{}: np3d.bin names vertex {bad}, but {} has {} vertices",
                dir.display(),
                path.display(),
                c.vertices.len()
            ));
        }
        let labels = labels.unwrap_or_else(|| {
            crate::segment::auto_segment(&c)
                .labels
                .iter()
                .map(|&l| l as u32)
                .collect()
        });
        // The character's size from the clip it walks in (else the first): a fall or a jump
        // would make it look longer or taller than it is, and the crowd would spread out. The
        // culling sphere holds every clip the crowd plays (those that loop).
        let gaits = crate::crowd::Gaits::new(&timeline.spans, fps);
        let sizing = gaits.walk.and_then(|w| timeline.clips.get(w).copied()).unwrap_or(clip);
        let mut size = CharacterSize::measure(&c, sizing);
        let played: Vec<Option<usize>> = timeline
            .clips
            .iter()
            .zip(&timeline.spans)
            .filter(|(_, s)| s.looping)
            .map(|(c, _)| *c)
            .collect();
        if played.len() > 1 {
            let all = CharacterSize::measure_clips(&c, &played);
            size.centre = all.centre;
            size.radius = all.radius;
            size.ground_y = size.ground_y.min(all.ground_y);
        }
        Ok(Self {
            character: c,
            character_path: path,
            clip,
            timeline,
            labels,
            pack,
            reps,
            size,
            dir: dir.to_owned(),
            full_impostors: Default::default(),
        })
    }

    /// Whether [`CrowdAssets::full_impostors`] answers at once (read, failed, or nothing to
    /// read).
    pub fn full_impostors_ready(&self) -> bool {
        self.reps
            .as_ref()
            .is_none_or(|r| r.impostor.is_some() || r.manifest.impostor.is_none())
            || self.full_impostors.get().is_some()
    }

    /// The full-resolution impostor sheets (`None` when none were baked), read from the folder
    /// the first time (seconds for a big bake: hundreds of megabytes); the error names what is
    /// wrong when the folder changed since it was opened.
    pub fn full_impostors(&self) -> Result<Option<&crate::reps::ImpostorData>, String> {
        let Some(reps) = &self.reps else { return Ok(None) };
        if let Some(i) = &reps.impostor {
            return Ok(Some(i));
        }
        self.full_impostors
            .get_or_init(|| {
                crate::reps::load_full_impostors(&self.dir, &reps.manifest)
                    .map_err(|e| format!("{}: {e}", self.dir.display()))
            })
            .as_ref()
            .map(Option::as_ref)
            .map_err(Clone::clone)
    }
}

/// Where a pack and the representations beside it disagree (they must share views, frames,
/// frame rate, resolution and clip).
fn check_agreement(p: &crate::pack::Manifest, r: &crate::reps::RepsManifest) -> Result<(), String> {
    if p.frames != r.frames {
        return Err(format!("{} frames against {}", p.frames, r.frames));
    }
    if p.fps != r.fps {
        return Err(format!("{} fps against {}", p.fps, r.fps));
    }
    if p.resolution != r.resolution {
        return Err(format!("resolution {} against {}", p.resolution, r.resolution));
    }
    if p.clip != r.clip {
        return Err(format!("clip {:?} against {:?}", p.clip, r.clip));
    }
    if p.character_up != r.character_up {
        return Err(format!("up axis {} against {}", p.character_up, r.character_up));
    }
    if p.clips.len() != r.clips.len()
        || p.clips
            .iter()
            .zip(&r.clips)
            .any(|(a, b)| a.name != b.name || a.frames != b.frames)
    {
        return Err("the clip tables differ".into());
    }
    if p.views.len() != r.views.len() {
        return Err(format!("{} views against {}", p.views.len(), r.views.len()));
    }
    for (v, (a, b)) in p.views.iter().zip(&r.views).enumerate() {
        if (Vec3::from(a.direction) - Vec3::from(b.direction)).length() > 1e-4 {
            return Err(format!("view {v} looks from another direction"));
        }
    }
    Ok(())
}

impl CrowdAssets {
    /// The baked animation: frames and rate (pack first, then representations).
    pub fn timing(&self) -> ClipTiming {
        if let Some(p) = &self.pack {
            return ClipTiming {
                frames: p.manifest.frames as usize,
                fps: p.manifest.fps,
            };
        }
        if let Some(r) = &self.reps {
            return ClipTiming {
                frames: r.manifest.frames as usize,
                fps: r.manifest.fps,
            };
        }
        ClipTiming { frames: 1, fps: 10.0 }
    }

    /// The baked view directions.
    pub fn view_directions(&self) -> Vec<Vec3> {
        if let Some(p) = &self.pack {
            return p.manifest.views.iter().map(|v| Vec3::from(v.direction)).collect();
        }
        self.reps
            .as_ref()
            .map(|r| r.manifest.views.iter().map(|v| Vec3::from(v.direction)).collect())
            .unwrap_or_default()
    }

    /// World length the baked images span (twice the largest view's orthographic half
    /// size), when there are baked images.
    pub fn framing(&self) -> Option<f32> {
        let half = match (&self.pack, &self.reps) {
            (Some(p), _) => p
                .manifest
                .views
                .iter()
                .map(|v| v.camera.half_size)
                .fold(0.0f32, f32::max),
            (None, Some(r)) => r
                .manifest
                .views
                .iter()
                .map(|v| v.camera.half_size)
                .fold(0.0f32, f32::max),
            _ => 0.0,
        };
        (half > 0.0).then_some(2.0 * half)
    }

    /// A crowd of `count` of this character at its real size ([`CrowdParams::for_character`]).
    pub fn crowd_params(&self, count: usize) -> CrowdParams {
        CrowdParams::for_character(count, self.size, self.framing())
    }

    /// This character as another kind in someone else's crowd ([`Crowd::mix`]).
    pub fn species(&self) -> Species {
        Species {
            texels: self.resolution() as f32,
            ..Species::new(
                self.size,
                self.framing(),
                &self.timeline.spans,
                &self.view_directions(),
                self.timing(),
            )
        }
    }

    /// Texels of the baked images along the character's height (the LOD switch unit).
    pub fn resolution(&self) -> u32 {
        self.pack
            .as_ref()
            .map(|p| p.manifest.resolution)
            .or_else(|| self.reps.as_ref().map(|r| r.manifest.resolution))
            .unwrap_or(128)
    }
}

/// What one frame of a crowd scene cost and drew.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneStats {
    /// The crowd's simulation and selection times and visible characters, with the records
    /// drawn per level counted after the fall-back to loaded levels and the thinning.
    pub frame: FrameStats,
    /// Instance upload and command recording (CPU).
    pub upload_secs: f64,
    /// Draw calls recorded for the characters of every kind (the ground not counted).
    pub draw_calls: usize,
    /// Character records not drawn this frame ([`CrowdScene::draw_budget`]).
    pub skipped: usize,
}

/// A crowd with its renderers.
pub struct CrowdScene {
    /// The agents: simulation, culling and the per-level instance records of each kind.
    pub crowd: Crowd,
    /// The renderers of the crowd's own character (kind 0).
    pub renderers: CrowdRenderers,
    /// The renderers of each character mixed in ([`CrowdScene::mixed`]): kind `k` is
    /// `guests[k - 1]`.
    pub guests: Vec<CrowdRenderers>,
    /// The characters mixed in and every kind's share (kept for [`CrowdScene::respawn`]).
    mix: Option<(Vec<Species>, Vec<f32>)>,
    /// The crowd's params before they were spaced for the mix (its own character's spacing).
    unspaced: CrowdParams,
    /// Nearest-view lookup over the baked view directions of the crowd's own character.
    pub views: ViewLookup,
    /// Frames and rate of the crowd's own baked animation (what its instances' frame numbers
    /// count).
    pub timing: ClipTiming,
    /// The baked clips the agents play ([`Crowd::set_clips`]).
    pub clips: Vec<crate::timeline::ClipSpan>,
    /// Lighting and per-part tint of every level and kind. Default value:
    /// `PolypostorStyle::default()`.
    pub style: PolypostorStyle,
    /// Draw the ground under the crowd.
    pub ground: bool,
    /// Most character records drawn a frame; the others are skipped, evenly spread over
    /// every level (`usize::MAX`: all). [`CrowdScene::adapt_budget`] sets it from the frame
    /// rate so that a crowd too heavy for the machine thins out instead of freezing the
    /// window. Default value: `usize::MAX`.
    pub draw_budget: usize,
    /// Fast frames in a row (a thinned crowd grows back only after [`FAST_STREAK`]).
    fast_streak: u32,
}

/// Fast frames in a row after which a thinned crowd grows back by a quarter (one quick
/// frame between slow ones is not enough).
pub const FAST_STREAK: u32 = 10;

/// Frame interval (seconds) above which [`CrowdScene::adapt_budget`] thins the drawn
/// characters (to at most half, in proportion to how slow the frame was).
pub const SLOW_FRAME_SECS: f32 = 0.15;
/// Frame interval (seconds) below which it lets a thinned crowd grow back by a quarter.
pub const FAST_FRAME_SECS: f32 = 0.1;
/// The fewest characters a thinned crowd draws.
pub const MIN_DRAWN: usize = 50;

/// [`CrowdScene::adapt_budget`]'s rule: the budget after a frame `interval_secs` long that
/// had `records` character records to draw.
pub fn next_budget(budget: usize, interval_secs: f32, records: usize) -> usize {
    if interval_secs > SLOW_FRAME_SECS && records > MIN_DRAWN {
        // Aim at about 100 ms a frame: the share to keep, at most a half.
        let keep = (0.1 / interval_secs as f64).clamp(0.05, 0.5);
        ((budget.min(records) as f64 * keep) as usize).max(MIN_DRAWN)
    } else if interval_secs < FAST_FRAME_SECS && budget != usize::MAX {
        let grown = budget + budget / 4 + 1;
        if grown >= 2 * records { usize::MAX } else { grown }
    } else {
        budget
    }
}

/// Keeps at most `budget` of `lists`' records in all, chosen by `key` (a per-character seed):
/// the records whose key is among the `budget` smallest, strictly below the first key left
/// out, so every record of one character — both copies of a cross-fade, of a level switch or a
/// clip change — is kept or dropped with the others (split, a fading character showed as a
/// see-through ghost), and the same characters stay drawn from frame to frame whatever order
/// the lists come in (dropping every k-th record changed who vanished each frame). With keys
/// drawn at random per character, each list keeps about the same share. Returns how many were
/// dropped.
pub fn thin_out<T>(lists: &mut [Vec<T>], budget: usize, key: impl Fn(&T) -> u32) -> usize {
    let total: usize = lists.iter().map(Vec::len).sum();
    if total <= budget {
        return 0;
    }
    let mut keys: Vec<u32> = lists.iter().flatten().map(&key).collect();
    let (_, &mut cut, _) = keys.select_nth_unstable(budget);
    let mut dropped = 0;
    for list in lists.iter_mut() {
        let before = list.len();
        list.retain(|r| key(r) < cut);
        dropped += before - list.len();
    }
    dropped
}

impl CrowdScene {
    /// A crowd with every representation loaded (full-resolution impostors included).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        assets: &CrowdAssets,
        params: CrowdParams,
    ) -> Result<Self, GpuError> {
        Self::with_impostors(device, queue, assets, params, true)
    }

    /// [`CrowdScene::new`], with the full-resolution impostor sheets only when
    /// `full_impostors` (the mix draws far characters from quarter-resolution sheets, always
    /// loaded; the impostor level on its own needs the full ones).
    pub fn with_impostors(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        assets: &CrowdAssets,
        params: CrowdParams,
        full_impostors: bool,
    ) -> Result<Self, GpuError> {
        let timing = assets.timing();
        let renderers = renderers_of(device, queue, assets, full_impostors)?;
        let unspaced = params.clone();
        let mut crowd = Crowd::new(params);
        crowd.set_clips(&assets.timeline.spans, timing.fps);
        Ok(Self {
            crowd,
            unspaced,
            clips: assets.timeline.spans.clone(),
            renderers,
            guests: Vec::new(),
            mix: None,
            views: ViewLookup::new(&assets.view_directions()),
            timing,
            style: PolypostorStyle::default(),
            ground: true,
            draw_budget: usize::MAX,
            fast_streak: 0,
        })
    }

    /// A crowd of several characters: `count` agents of `assets[0]`, `assets[1]`, … dealt
    /// out in proportion to `shares` (one per character; only the ratios count), each at its
    /// real size, playing its own clips, drawn by its own renderers; each keeping its own
    /// spacing on a ground sized for the shares ([`CrowdParams::spaced_for_shares`]).
    /// Errors: no character, more than [`crate::crowd::MAX_SPECIES`], shares that do not match or
    /// are all zero, or a character that cannot be drawn.
    pub fn mixed(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        assets: &[&CrowdAssets],
        shares: &[f32],
        count: usize,
        full_impostors: bool,
    ) -> Result<Self, GpuError> {
        let Some((first, others)) = assets.split_first() else {
            return Err(GpuError::Unsupported("a crowd needs at least one character".into()));
        };
        let species: Vec<Species> = others.iter().map(|a| a.species()).collect();
        let unspaced = first.crowd_params(count);
        let params = spaced(unspaced.clone(), &species, shares);
        let mut scene = Self::with_impostors(device, queue, first, params, full_impostors)?;
        scene.unspaced = unspaced;
        for a in others {
            let mut r = renderers_of(device, queue, a, full_impostors)?;
            r.ground_half_extent = 0.0;
            scene.guests.push(r);
        }
        scene
            .crowd
            .mix(species.clone(), shares)
            .map_err(GpuError::Unsupported)?;
        scene.mix = Some((species, shares.to_vec()));
        Ok(scene)
    }

    /// A new crowd of `params` (same renderers, same characters and shares; spacing widened
    /// for the largest character mixed in).
    pub fn respawn(&mut self, params: CrowdParams) {
        let paused = self.crowd.paused();
        let parallel = self.crowd.parallel();
        self.unspaced = params.clone();
        let params = match &self.mix {
            Some((species, shares)) => spaced(params, species, shares),
            None => params,
        };
        self.crowd = Crowd::new(params);
        self.crowd.set_parallel(parallel);
        self.crowd.set_clips(&self.clips, self.timing.fps);
        if let Some((species, shares)) = &self.mix {
            // Checked when the mix was made.
            let _ = self.crowd.mix(species.clone(), shares);
        }
        self.crowd.set_paused(paused);
    }

    /// New shares of the characters mixed in ([`CrowdScene::mixed`]; one per character):
    /// agents are dealt out again where they stand, each starting afresh; where the new
    /// shares ask for a ground more than a tenth larger or smaller
    /// ([`CrowdParams::respaced_for_shares`]: a mix tipping towards its big characters), a
    /// new crowd is laid out on it instead. A crowd of one character takes only `[x]`.
    pub fn set_shares(&mut self, shares: &[f32]) -> Result<(), String> {
        let species = match &self.mix {
            Some((_, old)) if old.as_slice() == shares => return Ok(()),
            Some((species, _)) => species.clone(),
            None if shares.len() == 1 => return Ok(()),
            None => return Err(format!("{} shares for one character", shares.len())),
        };
        self.crowd.mix(species.clone(), shares)?;
        let sizes: Vec<CharacterSize> = species.iter().map(|s| s.size).collect();
        let relay = self
            .crowd
            .params
            .respaced_for_shares(&self.unspaced, &sizes, shares)
            .is_some();
        self.mix = Some((species, shares.to_vec()));
        if relay {
            // Everything the caller set on the crowd's params is kept; only the spacing
            // starts again from the character's own.
            let mut params = self.crowd.params.clone();
            params.density = self.unspaced.density;
            params.min_distance = self.unspaced.min_distance;
            self.respawn(params);
        }
        Ok(())
    }

    /// The shares the characters were dealt out in (one, 1, for a crowd of one character).
    pub fn shares(&self) -> Vec<f32> {
        self.mix.as_ref().map_or_else(|| vec![1.0], |(_, s)| s.clone())
    }

    /// Bytes on the GPU for `level`, over every character of the crowd.
    pub fn gpu_bytes(&self, level: Level) -> u64 {
        std::iter::once(&self.renderers)
            .chain(&self.guests)
            .map(|r| r.gpu_bytes(level))
            .sum()
    }

    /// Each kind of character's renderers (the crowd's own first).
    fn all_renderers(&mut self) -> impl Iterator<Item = &mut CrowdRenderers> {
        std::iter::once(&mut self.renderers).chain(self.guests.iter_mut())
    }

    /// Simulates `dt`, selects for `camera` (a `width × height` viewport) and draws into
    /// `target`, cleared to `clear`; levels that are not loaded fall back to the nearest one
    /// that is (so a preview without impostors still shows everyone).
    #[allow(clippy::too_many_arguments)]
    pub fn frame(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &RenderTarget,
        camera: &Camera,
        policy: &LodPolicy,
        dt: f32,
        clear: wgpu::Color,
    ) -> SceneStats {
        let aspect = target.width as f32 / target.height.max(1) as f32;
        let clip_from_world = camera.clip_from_world(aspect);
        let fov = match camera.projection {
            crate::gpu::Projection::Perspective { fov_y_rad } => fov_y_rad,
            crate::gpu::Projection::Orthographic { .. } => 50f32.to_radians(),
        };
        let view = CrowdCamera {
            eye: camera.eye,
            clip_from_world,
            focal_px: target.height as f32 / (2.0 * (fov / 2.0).tan()),
        };
        let mut frame = self.crowd.frame(dt, &view, policy, &self.views, self.timing);
        // The mix draws its far characters from the quarter-resolution impostors.
        let far = matches!(policy, LodPolicy::Mixed(_));
        for r in self.all_renderers() {
            r.use_far_impostors = far;
        }
        let t = Instant::now();
        // The ground is drawn once, under the crowd's own character.
        self.renderers.ground_half_extent = if self.ground { self.crowd.half_extent } else { 0.0 };
        self.renderers.ground_y = self.crowd.params.size.ground_y;
        self.renderers.ground_scale = self.crowd.params.scale();
        self.fall_back();
        let skipped = thin_out(self.crowd.instances.as_flattened_mut(), self.draw_budget, |r| {
            r.variant & crate::crowd::VARIANT_SEED_MASK
        });
        frame.per_level = [0; Level::COUNT];
        for lists in &self.crowd.instances {
            for (n, list) in frame.per_level.iter_mut().zip(lists) {
                *n += list.len();
            }
        }
        // Every character's instances uploaded, then drawn in one pass.
        let renderers = std::iter::once(&mut self.renderers).chain(self.guests.iter_mut());
        for (r, lists) in renderers.zip(&self.crowd.instances) {
            r.prepare(device, queue, clip_from_world, &self.style, lists);
        }
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut draw_calls = 0;
        {
            let mut pass = target.begin_pass(&mut encoder, "crowd", clear);
            for r in std::iter::once(&self.renderers).chain(&self.guests) {
                draw_calls += r.draw(&mut pass);
            }
        }
        queue.submit([encoder.finish()]);
        SceneStats {
            frame,
            upload_secs: t.elapsed().as_secs_f64(),
            draw_calls,
            skipped,
        }
    }

    /// Adapts [`CrowdScene::draw_budget`] to the last frame interval: over
    /// [`SLOW_FRAME_SECS`] it keeps at most half of what was drawn, less the slower the frame
    /// (not below [`MIN_DRAWN`]); after [`FAST_STREAK`] frames in a row under
    /// [`FAST_FRAME_SECS`] a thinned crowd grows back by a quarter, and draws everyone again
    /// once the budget covers twice the `records` drawn and skipped last frame.
    pub fn adapt_budget(&mut self, interval_secs: f32, records: usize) {
        if interval_secs < FAST_FRAME_SECS {
            self.fast_streak += 1;
            if self.fast_streak < FAST_STREAK {
                return;
            }
        }
        self.fast_streak = 0;
        self.draw_budget = next_budget(self.draw_budget, interval_secs, records);
    }

    /// Moves instances of levels that are not loaded to a loaded one (impostor → polypostor
    /// → skinned; rigid → skinned; NP3D → polypostor → skinned).
    fn fall_back(&mut self) {
        let renderers = std::iter::once(&self.renderers).chain(&self.guests);
        for (r, lists) in renderers.zip(self.crowd.instances.iter_mut()) {
            for level in [Level::Impostor, Level::Np3d, Level::Polypostor, Level::Rigid] {
                if r.has(level) || lists[level as usize].is_empty() {
                    continue;
                }
                let to = match level {
                    Level::Impostor | Level::Np3d if r.has(Level::Polypostor) => Level::Polypostor,
                    _ => Level::Skinned,
                };
                let moved = std::mem::take(&mut lists[level as usize]);
                lists[to as usize].extend(moved);
            }
        }
    }
}

/// Every representation of `assets` on the GPU (the full-resolution impostor sheets, read
/// from the folder when not yet, only when `full_impostors`).
fn renderers_of(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    assets: &CrowdAssets,
    full_impostors: bool,
) -> Result<CrowdRenderers, GpuError> {
    let full = if full_impostors {
        assets.full_impostors().map_err(GpuError::Unsupported)?
    } else {
        None
    };
    let inputs = crowd_inputs(assets.pack.as_ref(), assets.reps.as_ref(), assets.timing(), full);
    CrowdRenderers::new(
        device,
        queue,
        &assets.character,
        &assets.timeline,
        &assets.labels,
        &inputs,
    )
}

/// What the crowd renderers draw of a baked folder: the Polypostor from `pack`; rigid
/// meshes, far impostors (`reps`' baked far sheets, or reduced here from its full ones for
/// representations made in memory), NP3D and the views from `reps`; full-resolution
/// impostors from `full_impostors` (the sheets of `reps`' views). Frames and rate come from
/// the pack, else from `reps`, else `fallback`.
pub fn crowd_inputs<'a>(
    pack: Option<&'a crate::pack::LoadedPack>,
    reps: Option<&'a crate::reps::Representations>,
    fallback: ClipTiming,
    full_impostors: Option<&'a crate::reps::ImpostorData>,
) -> crate::gpu::inputs::CrowdInputs<'a> {
    use std::borrow::Cow;
    let timing = pack
        .map(|p| ClipTiming {
            frames: p.manifest.frames as usize,
            fps: p.manifest.fps,
        })
        .or_else(|| {
            reps.map(|r| ClipTiming {
                frames: r.manifest.frames as usize,
                fps: r.manifest.fps,
            })
        })
        .unwrap_or(fallback);
    let far_impostor = reps.and_then(|r| match &r.far_impostor {
        // Baked (representations format 4 on).
        Some(far) => Some((Cow::Borrowed(far), crate::reps::far_frame_map(&r.manifest))),
        // Representations made in memory: reduced here; for a long timeline (a
        // whole-character pack) every other frame of each clip.
        None => r.impostor.as_ref().map(|d| {
            let (subset, map) = match crate::reps::far_frames(&r.manifest.clips, r.manifest.frames as usize) {
                Some((keep, map)) => (Some(d.frames_subset(&keep)), Some(map)),
                None => (None, None),
            };
            let f = crate::gpu::FAR_IMPOSTOR_FACTOR;
            let reduced = subset.as_ref().unwrap_or(d).downsampled_split(f, 2 * f);
            (Cow::Owned(reduced), map)
        }),
    });
    crate::gpu::inputs::CrowdInputs {
        timing,
        polypostor: pack.map(|p| p.gpu_input()),
        views: reps.map(|r| r.view_frames()).unwrap_or_default(),
        key_frame: reps.map_or(0, |r| r.manifest.key_frame),
        rigid: reps.and_then(|r| r.rigid.as_ref()),
        impostor: reps.and(full_impostors),
        far_impostor,
        np3d: reps.and_then(|r| r.np3d.as_ref()),
    }
}

/// `params` spaced for a mix with `species` in `shares` ([`CrowdParams::spaced_for_shares`]:
/// the grid's cell for the largest, the ground for the shares).
fn spaced(mut params: CrowdParams, species: &[Species], shares: &[f32]) -> CrowdParams {
    let sizes: Vec<_> = species.iter().map(|s| s.size).collect();
    params.spaced_for_shares(&sizes, shares);
    params
}

/// The camera of `bench crowd`: at the edge of the crowd, looking across it from 10 m up
/// (for the reference person; scaled with the character).
pub fn bench_camera(crowd: &Crowd) -> Camera {
    let s = crowd.params.scale();
    let ground = crowd.params.size.ground_y;
    let eye = Vec3::new(0.0, ground + 10.0 * s, -crowd.half_extent - 5.0 * s);
    Camera {
        eye,
        target: Vec3::new(0.0, ground, 0.0),
        up: Vec3::Y,
        projection: crate::gpu::Projection::Perspective {
            fov_y_rad: 50f32.to_radians(),
        },
        near: 0.1 * s,
        far: 4.0 * crowd.half_extent + 100.0 * s,
    }
}

/// The temporal-stability measure of a crowd's levels of detail: the largest frame-to-frame
/// change of the image of one still character (paused, so its animation does not move) while
/// the camera orbits it through several baked views and backs away through the
/// Polypostor → impostor switch, relative to the skinned mesh filmed the same way. A change is
/// the sum over pixels of the absolute colour difference (0..1 per channel, averaged over
/// RGB) between consecutive frames, divided by the pixels the character covers. A pop shows as
/// one large change; a mesh moving smoothly under a moving camera gives the reference.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Stability {
    /// Largest change of the mix (skinned / Polypostor / impostor) along the path.
    pub mix_max: f64,
    /// Largest change of the skinned mesh alone along the same path.
    pub skinned_max: f64,
    /// Their ratio (the measure; 1 is as stable as the mesh).
    pub ratio: f64,
    /// Frames along the path, and how many of the mix's had a character in two levels or two
    /// views at once (fading).
    pub frames: usize,
    /// Frames of the mix in which the character was drawn in two levels or two views at once
    /// (cross-fading); at most `frames`.
    pub fading_frames: usize,
}

/// [`Stability`] of `assets` with cross-fades of `fade_secs` (0: cuts), filmed at 60 frames a
/// second for `frames` frames into a `size`² target.
pub fn temporal_stability(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    assets: &CrowdAssets,
    fade_secs: f32,
    frames: usize,
    size: u32,
) -> Result<Stability, GpuError> {
    let params = CrowdParams {
        fade_secs,
        ..assets.crowd_params(1)
    };
    let mut scene = CrowdScene::with_impostors(device, queue, assets, params, false)?;
    scene.ground = false;
    scene.crowd.set_paused(true);
    scene.crowd.agents.pos[0] = glam::Vec2::ZERO;
    scene.crowd.agents.facing[0] = glam::Vec2::new(0.0, 1.0);
    let target = RenderTarget::new(device, size, size);
    let texels = assets.resolution() as f32;
    let fov = 20f32.to_radians();
    let focal = size as f32 / (2.0 * (fov / 2.0).tan());
    let framing = scene.crowd.params.height;
    let centre = Vec3::new(0.0, scene.crowd.params.size.centre.y, 0.0);
    // From 0.45 to 0.15 screen pixels per baked texel (through the 0.25 switch), orbiting
    // 40° round the character 25° above the ground.
    let distance = |ratio: f32| framing * focal / (ratio * texels);
    let frames = frames.max(2);
    let camera_at = |k: usize| {
        let u = k as f32 / (frames - 1) as f32;
        let d = distance(0.45 + (0.15 - 0.45) * u);
        let yaw = 40f32.to_radians() * u;
        let pitch = 25f32.to_radians();
        Camera {
            eye: centre + d * Vec3::new(pitch.cos() * yaw.sin(), pitch.sin(), pitch.cos() * yaw.cos()),
            target: centre,
            up: Vec3::Y,
            projection: crate::gpu::Projection::Perspective { fov_y_rad: fov },
            near: 0.01 * d,
            far: 4.0 * d,
        }
    };
    let film = |policy: LodPolicy, scene: &mut CrowdScene| -> Result<(f64, usize), GpuError> {
        let mut previous: Option<image::RgbaImage> = None;
        let mut worst = 0.0f64;
        let mut fading = 0;
        // One frame to settle the levels before the path starts (no fade from the spawn).
        scene.crowd.select(
            &CrowdCamera {
                eye: camera_at(0).eye,
                clip_from_world: camera_at(0).clip_from_world(1.0),
                focal_px: focal,
            },
            &policy,
            &scene.views,
            scene.timing,
        );
        for k in 0..frames {
            let s = scene.frame(
                device,
                queue,
                &target,
                &camera_at(k),
                &policy,
                1.0 / 60.0,
                wgpu::Color::TRANSPARENT,
            );
            if s.frame.per_level.iter().sum::<usize>() > s.frame.visible {
                fading += 1;
            }
            let img = target.read_color(device, queue)?;
            if let Some(p) = &previous {
                let mut sum = 0.0f64;
                let mut covered = 0usize;
                for (a, b) in img.pixels().zip(p.pixels()) {
                    if a[3] > 0 || b[3] > 0 {
                        covered += 1;
                    }
                    let da = |c: usize| (a[c] as f64 * a[3] as f64 - b[c] as f64 * b[3] as f64).abs() / (255.0 * 255.0);
                    sum += (da(0) + da(1) + da(2)) / 3.0;
                }
                worst = worst.max(sum / covered.max(1) as f64);
            }
            previous = Some(img);
        }
        Ok((worst, fading))
    };
    let (mix_max, fading_frames) = film(
        LodPolicy::Mixed(crate::crowd::lod::LodDistances {
            texels,
            ..Default::default()
        }),
        &mut scene,
    )?;
    let (skinned_max, _) = film(LodPolicy::Only(Level::Skinned), &mut scene)?;
    Ok(Stability {
        mix_max,
        skinned_max,
        ratio: mix_max / skinned_max.max(1e-12),
        frames,
        fading_frames,
    })
}
