//! Baking the comparison representations from the same views, resolution and frame rate as
//! the Polypostor bake (the cameras come from the same [`view_cameras`] framing, so each
//! view's image lines up with the pack's view pixel for pixel).

use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use super::{
    FrameVertices, ImpostorData, ImpostorInfo, Np3dData, Np3dInfo, REPS_FORMAT, REPS_VERSION, RepSet, RepView,
    Representations, RepsManifest, RigidInfo, far_factor, far_impostor_sheets,
};
use crate::animation::{Pose, skin_vertices};
use crate::bake::pipeline::{BakeError, Progress};
use crate::bake::renders::{sample_timeline, view_cameras};
use crate::bake::viewpoints::{Coverage, directions};
use crate::character::Character;
use crate::gpu::{CharacterRenderer, DrawOptions, GpuCharacter, GpuContext, RenderTarget, Shading, SkinningMode};
use crate::pack::PackCamera;

/// Triangles of the NP3D meshes (the NP3D paper's figure).
pub const NP3D_TRIANGLES: usize = 400;

/// What to bake, with the pack's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RepsOptions {
    pub views: usize,
    pub coverage: Coverage,
    pub resolution: u32,
    pub fps: f32,
    pub clip: Option<usize>,
    /// Further clips after `clip`, as [`crate::bake::pipeline::BakeOptions::extra_clips`].
    pub extra_clips: Vec<usize>,
    /// The texture key-frame (NP3D images).
    pub key_frame: usize,
    pub set: RepSet,
    pub np3d_triangles: usize,
    /// The body part of each triangle (impostors store it per texel for the per-part tint;
    /// empty: every texel is part 0).
    pub part_labels: Vec<u32>,
}

/// Whole-character images of every view, composited from the Polypostor bake's part renders
/// (each pixel from the part nearest the camera there), so that `--representation all` renders
/// each view once: the impostor sheets (colour; normal with the texel's body part in alpha)
/// and the NP3D key-frame images, as [`bake_representations`] would render them. The parts'
/// caps sit inside the body, behind the surface next to them, so they do not show.
pub struct SharedRenders {
    frames: usize,
    resolution: u32,
    /// Keep every frame (impostors), or only the key frame's image (NP3D).
    every_frame: bool,
    views: Vec<Option<SharedView>>,
}

struct SharedView {
    camera: crate::gpu::Camera,
    key_frame: usize,
    color: image::RgbaImage,
    normal: image::RgbaImage,
    key_image: image::RgbaImage,
}

impl SharedRenders {
    /// Collects `views` views of `frames` frames at `resolution`² for the representations of
    /// `set` (none needed: nothing is kept).
    pub fn new(views: usize, frames: usize, resolution: u32, set: RepSet) -> Self {
        Self {
            frames,
            resolution,
            every_frame: set.impostor,
            views: if set.impostor || set.np3d {
                (0..views).map(|_| None).collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Composites one view's part renders (ignored when it does not match the collector).
    pub fn add(&mut self, view: &crate::bake::pipeline::ViewRenders) {
        let images = view.images;
        let r = self.resolution;
        if view.view >= self.views.len() || images.frames != self.frames || images.resolution != r {
            return;
        }
        let columns = sheet_columns(self.frames);
        let rows = (self.frames as u32).div_ceil(columns);
        let (mut color, mut normal) = if self.every_frame {
            (
                image::RgbaImage::new(columns * r, rows * r),
                image::RgbaImage::new(columns * r, rows * r),
            )
        } else {
            (image::RgbaImage::new(0, 0), image::RgbaImage::new(0, 0))
        };
        let mut key_image = image::RgbaImage::new(r, r);
        for f in 0..self.frames {
            if !self.every_frame && f != view.key_frame {
                continue;
            }
            let (mut c, nrm) = composite(images, f);
            crate::pack::dilate(&mut c, 2);
            if f == view.key_frame {
                key_image = c.clone();
                crate::pack::fill_background(&mut key_image);
            }
            if self.every_frame {
                let (x, y) = ((f as u32 % columns) * r, (f as u32 / columns) * r);
                image::imageops::replace(&mut color, &c, x as i64, y as i64);
                image::imageops::replace(&mut normal, &nrm, x as i64, y as i64);
            }
        }
        self.views[view.view] = Some(SharedView {
            camera: view.camera,
            key_frame: view.key_frame,
            color,
            normal,
            key_image,
        });
    }

    /// Whether every view is in, at key frame `key`.
    fn complete(&self, views: usize, frames: usize, resolution: u32, key: usize) -> bool {
        self.views.len() == views
            && self.frames == frames
            && self.resolution == resolution
            && self
                .views
                .iter()
                .all(|v| v.as_ref().is_some_and(|v| v.key_frame == key))
    }
}

/// The whole character at frame `f` from its parts' renders: colour (alpha 255 where
/// covered) and normal (alpha: the body part, 0 where nothing is), each pixel from
/// [`crate::gpu::PartImages::front_part`].
pub fn composite(images: &crate::gpu::PartImages, f: usize) -> (image::RgbaImage, image::RgbaImage) {
    let r = images.resolution;
    let mut color = image::RgbaImage::new(r, r);
    let mut normal = image::RgbaImage::new(r, r);
    for y in 0..r {
        for x in 0..r {
            if let Some(p) = images.front_part(f, x, y) {
                let (ox, oy) = images.tile_origin(p, f);
                color.put_pixel(x, y, *images.color.get_pixel(ox + x, oy + y));
                let mut n = *images.normal.get_pixel(ox + x, oy + y);
                n[3] = p.min(255) as u8;
                normal.put_pixel(x, y, n);
            }
        }
    }
    (color, normal)
}

/// Bakes the impostor, NP3D and rigid representations selected in `options.set`.
pub fn bake_representations(
    ctx: &GpuContext,
    character: &Character,
    character_path: Option<&str>,
    clip_name: Option<&str>,
    options: &RepsOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<Representations, BakeError> {
    bake_representations_sharing(
        ctx,
        character,
        character_path,
        clip_name,
        options,
        None,
        progress,
        cancel,
    )
}

/// [`bake_representations`], taking the impostor and NP3D images from `shared` (the
/// Polypostor bake's part renders of the same views) when it holds every view at the
/// options' key frame; otherwise rendering them.
#[allow(clippy::too_many_arguments)]
pub fn bake_representations_sharing(
    ctx: &GpuContext,
    character: &Character,
    character_path: Option<&str>,
    clip_name: Option<&str>,
    options: &RepsOptions,
    shared: Option<SharedRenders>,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<Representations, BakeError> {
    let clips: Vec<Option<usize>> = std::iter::once(options.clip)
        .chain(options.extra_clips.iter().map(|&c| Some(c)))
        .collect();
    let timeline = crate::timeline::Timeline::measured(character, &clips, options.fps)?;
    let samples = timeline.samples();
    let frames = samples.len();
    if options.key_frame >= frames {
        return Err(BakeError::KeyFrame(options.key_frame, frames));
    }
    let (poses, points) = sample_timeline(character, &samples);
    let dirs = directions(options.views.max(1), options.coverage);
    let shared = shared.filter(|s| s.complete(dirs.len(), frames, options.resolution, options.key_frame));
    let cameras = match &shared {
        Some(s) => s.views.iter().flatten().map(|v| v.camera).collect(),
        None => view_cameras(&points, &dirs),
    };
    let r = options.resolution;
    let set = options.set;
    // The NP3D mesh first: if it cannot be made, say so before the renders.
    let np3d_mesh = if set.np3d {
        progress(Progress {
            stage: "np3d",
            done: 0,
            total: 1,
        });
        let indices = simplify(character, &points[options.key_frame], options.np3d_triangles);
        if indices.len() < 3 {
            return Err(BakeError::Limit(crate::limits::LimitError(
                "the character's mesh does not simplify to any NP3D triangle (is it degenerate at the key frame?)"
                    .into(),
            )));
        }
        let (kept, local) = compact(&indices).ok_or_else(|| {
            BakeError::Limit(crate::limits::LimitError(format!(
                "the NP3D mesh keeps more than {} vertices (16-bit indices)",
                u16::MAX
            )))
        })?;
        Some((kept, local))
    } else {
        None
    };

    // Whole-character renders: every frame of every view for impostors, the key frame for
    // NP3D.
    let mut impostor = None;
    let mut np3d_images = Vec::new();
    if let Some(shared) = shared.filter(|_| set.impostor || set.np3d) {
        let columns = sheet_columns(frames);
        let rows = (frames as u32).div_ceil(columns);
        let (mut color, mut normal) = (Vec::new(), Vec::new());
        for v in shared.views.into_iter().flatten() {
            np3d_images.push(v.key_image);
            color.push(v.color);
            normal.push(v.normal);
        }
        if set.impostor {
            impostor = Some(ImpostorData {
                color_blocks: Vec::new(),
                normal_blocks: Vec::new(),
                columns,
                rows,
                color,
                normal,
            });
        }
    } else if set.impostor || set.np3d {
        let renderer = CharacterRenderer::new(&ctx.device);
        let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, character);
        let id_character = part_id_character(character, &options.part_labels);
        let mut id_gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &id_character);
        let target = RenderTarget::new(&ctx.device, r, r);
        let draw = DrawOptions {
            shading: Shading::Unlit,
            clear_color: [0.0; 4],
            grid: false,
        };
        let render_frames: Vec<usize> = if set.impostor {
            (0..frames).collect()
        } else {
            vec![options.key_frame]
        };
        let columns = sheet_columns(frames);
        let rows = (frames as u32).div_ceil(columns);
        let mut color = vec![image::RgbaImage::new(columns * r, rows * r); cameras.len()];
        let mut normal = color.clone();
        np3d_images = vec![image::RgbaImage::new(r, r); cameras.len()];
        for (n, &f) in render_frames.iter().enumerate() {
            if cancel.load(Ordering::Relaxed) {
                return Err(BakeError::Cancelled);
            }
            progress(Progress {
                stage: "impostors",
                done: n,
                total: render_frames.len(),
            });
            for (v, cam) in cameras.iter().enumerate() {
                renderer.render(
                    &ctx.device,
                    &ctx.queue,
                    &target,
                    &mut gpu,
                    character,
                    &poses[f],
                    SkinningMode::Gpu,
                    cam,
                    &draw,
                );
                let mut c = target.read_color(&ctx.device, &ctx.queue)?;
                let mut nrm = target.read_normal(&ctx.device, &ctx.queue)?;
                if set.impostor {
                    // The body part of every texel, in the normal image's alpha.
                    renderer.render(
                        &ctx.device,
                        &ctx.queue,
                        &target,
                        &mut id_gpu,
                        &id_character,
                        &poses[f],
                        SkinningMode::Gpu,
                        cam,
                        &draw,
                    );
                    let ids = target.read_color(&ctx.device, &ctx.queue)?;
                    for (n, id) in nrm.pixels_mut().zip(ids.pixels()) {
                        n[3] = if id[3] > 127 { decode_part_id(id) } else { 0 };
                    }
                }
                // Bleed colour into the background so filtering at the silhouette does not
                // pull in black.
                crate::pack::dilate(&mut c, 2);
                if f == options.key_frame {
                    np3d_images[v] = c.clone();
                    crate::pack::fill_background(&mut np3d_images[v]);
                }
                let (x, y) = ((f as u32 % columns) * r, (f as u32 / columns) * r);
                image::imageops::replace(&mut color[v], &c, x as i64, y as i64);
                image::imageops::replace(&mut normal[v], &nrm, x as i64, y as i64);
            }
        }
        if set.impostor {
            impostor = Some(ImpostorData {
                color_blocks: Vec::new(),
                normal_blocks: Vec::new(),
                columns,
                rows,
                color,
                normal,
            });
        }
    }

    let np3d = np3d_mesh.map(|(kept, local)| Np3dData {
        indices: local,
        frames: frame_vertices(character, &poses, Some(&kept)),
        source: kept,
        images: np3d_images,
        image_blocks: Vec::new(),
    });
    let rigid = set.rigid.then(|| frame_vertices(character, &poses, None));

    // The mix's far impostors, at the resolution its default switch distance asks for.
    let factor = far_factor(crate::crowd::lod::LodDistances::default().impostor_below, r);
    let far = impostor
        .as_ref()
        .map(|i| far_impostor_sheets(i, &timeline.spans, frames, r, factor));
    let columns = (cameras.len() as f64).sqrt().ceil().max(1.0) as u32;
    let manifest = RepsManifest {
        format: REPS_FORMAT.into(),
        version: REPS_VERSION,
        character: character.name.clone(),
        character_path: character_path.map(String::from),
        character_up: character.up_axis,
        clip: clip_name.map(String::from),
        fps: options.fps,
        frames: frames as u32,
        clips: timeline.spans.clone(),
        key_frame: options.key_frame as u32,
        resolution: r,
        views: dirs
            .iter()
            .zip(&cameras)
            .map(|(d, c)| RepView {
                direction: d.to_array(),
                camera: PackCamera::from_camera(c),
            })
            .collect(),
        impostor: impostor.as_ref().map(|i| ImpostorInfo {
            columns: i.columns,
            rows: i.rows,
        }),
        far_impostor: far.as_ref().map(|(info, _)| info.clone()),
        np3d: np3d.as_ref().map(|n| Np3dInfo {
            vertex_count: n.frames.vertex_count as u32,
            index_count: n.indices.len() as u32,
            columns,
        }),
        rigid: rigid.as_ref().map(|r| RigidInfo {
            vertex_count: r.vertex_count as u32,
        }),
        checksums: Default::default(),
    };
    Ok(Representations {
        manifest,
        impostor,
        far_impostor: far.map(|(_, data)| data),
        np3d,
        rigid,
    })
}

pub use super::sheet_columns;

/// A copy of the character whose unlit colour is the body part of each triangle (red: part
/// mod 16, green: part / 16, each in fifteenths, linear), with every triangle's vertices its
/// own so no colour blends across a part border.
pub fn part_id_character(c: &Character, labels: &[u32]) -> Character {
    let mut out = c.clone();
    out.vertices = Vec::with_capacity(c.indices.len());
    for (t, tri) in c.indices.chunks_exact(3).enumerate() {
        let k = labels.get(t).copied().unwrap_or(0).min(255);
        let color = [(k % 16) as f32 / 15.0, (k / 16) as f32 / 15.0, 0.0, 1.0];
        for &i in tri {
            let mut v = c.vertices.get(i as usize).copied().unwrap_or(c.vertices[0]);
            v.color = color;
            out.vertices.push(v);
        }
    }
    out.indices = (0..out.vertices.len() as u32).collect();
    // Every corner is a vertex of its own now: the morph targets move the corners of the
    // vertices they moved (with the old numbering they moved other triangles' corners: a
    // morphing character drew as scattered shards).
    if !c.morphs.is_empty() {
        let origins: Vec<Vec<(u32, f32)>> = c
            .indices
            .chunks_exact(3)
            .flatten()
            .map(|&i| vec![(if (i as usize) < c.vertices.len() { i } else { 0 }, 1.0)])
            .collect();
        out.morphs = c.morphs_remapped(&origins);
    }
    out.textures.clear();
    out.materials = vec![crate::character::Material {
        name: "part id".into(),
        base_color_factor: [1.0; 4],
        base_color_texture: None,
        double_sided: true,
        alpha_cutoff: 0.0,
        wrap: Default::default(),
    }];
    out.submeshes = vec![crate::character::Submesh {
        first_index: 0,
        index_count: out.indices.len() as u32,
        material: 0,
    }];
    out
}

/// The part number of a texel of a [`part_id_character`] render (sRGB-encoded bytes).
pub fn decode_part_id(p: &image::Rgba<u8>) -> u8 {
    let linear = |b: u8| {
        let x = b as f32 / 255.0;
        if x <= 0.04045 {
            x / 12.92
        } else {
            ((x + 0.055) / 1.055).powf(2.4)
        }
    };
    let lo = (linear(p[0]) * 15.0).round() as u32;
    let hi = (linear(p[1]) * 15.0).round() as u32;
    (hi * 16 + lo).min(255) as u8
}

/// Skinned positions and normals at every pose, of every vertex or of `only` these.
fn frame_vertices(character: &Character, poses: &[Pose], only: Option<&[u32]>) -> FrameVertices {
    let mut out = FrameVertices {
        vertex_count: only.map_or(character.vertices.len(), <[u32]>::len),
        ..Default::default()
    };
    for pose in poses {
        let (p, n) = skin_vertices(character, pose);
        match only {
            Some(list) => {
                for &i in list {
                    out.positions.push(p[i as usize].to_array());
                    out.normals.push(n[i as usize].to_array());
                }
            }
            None => {
                out.positions.extend(p.iter().map(|v| v.to_array()));
                out.normals.extend(n.iter().map(|v| v.to_array()));
            }
        }
    }
    out
}

/// The mesh simplified to about `triangles` triangles at the pose `positions` (indices into
/// the character's vertices). Vertices split only by their attributes (UV seams) are welded
/// first (where they coincide at that pose, to a millionth of its size whatever the units),
/// so seams do not stop the simplification. Four simplifications are tried (below) and,
/// of those within 10 % of the target, the one whose outline from seven sides agrees best
/// with the welded mesh's is kept ([`OutlineProbe`]); if none reaches the target, the
/// smallest; if every one is empty, the welded mesh whole.
pub fn simplify(character: &Character, positions: &[Vec3], triangles: usize) -> Vec<u32> {
    let n = positions.len().min(character.vertices.len());
    let (lo, hi) = crate::character::bounds(positions.iter().copied());
    // Welding: a vertex joins the first one within `cell` of it, looked for in its grid cell
    // and the 26 around it — rounding to a grid alone split a pair a rounding error apart
    // whenever the two straddled a cell boundary, so the same character placed elsewhere
    // (a different rounding of its skinned positions) welded and simplified differently.
    let cell = ((hi - lo).max_element() * 1e-5).max(f32::MIN_POSITIVE);
    let mut grid: rustc_hash::FxHashMap<[i64; 3], Vec<u32>> = Default::default();
    let weld: Vec<u32> = (0..n)
        .map(|i| {
            let p = positions[i];
            let q = ((p - lo) / cell).floor().as_i64vec3();
            let near = (0..27).map(|k| q + glam::I64Vec3::new(k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1));
            let found = near.filter_map(|key| grid.get(&key.to_array())).find_map(|list| {
                list.iter()
                    .copied()
                    .find(|&j| positions[j as usize].distance(p) <= cell)
            });
            found.unwrap_or_else(|| {
                grid.entry(q.to_array()).or_default().push(i as u32);
                i as u32
            })
        })
        .collect();
    let welded: Vec<u32> = character
        .indices
        .chunks_exact(3)
        .filter(|t| t.iter().all(|&i| (i as usize) < n))
        .map(|t| [weld[t[0] as usize], weld[t[1] as usize], weld[t[2] as usize]])
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .flatten()
        .collect();
    // Centred, so the simplifier sees the same numbers wherever the character stands.
    let centre = (lo + hi) * 0.5;
    let pos: Vec<[f32; 3]> = positions[..n].iter().map(|p| (*p - centre).to_array()).collect();
    let target = (triangles * 3).min(welded.len());
    if welded.len() <= target {
        return welded;
    }
    let limit = target + target / 10;
    let within = |c: &Vec<u32>| !c.is_empty() && c.len() <= limit;
    // Candidates, the one whose outline is truest from every side kept:
    // - the quadric simplifier on the welded mesh as it stands (the welded-away duplicates
    //   stay in the vertex list, unused; the simplifier takes them for attribute seams and
    //   holds their vertices still, which keeps some features and leaves many-piece
    //   characters far above the target);
    // - the same on the used vertices only, free to move every vertex;
    // - the budget shared out over the connected pieces by area, each simplified alone (thin
    //   props and limbs modelled apart keep their share instead of collapsing);
    // - the clustering simplifier over the whole mesh.
    let mut candidates: Vec<Vec<u32>> = Vec::new();
    let as_is = meshopt::simplify_decoder(&welded, &pos, target, 1.0, meshopt::SimplifyOptions::None, None);
    let compacted: Vec<u32> = {
        let (kept, local) = compact_u32(&welded);
        let local_pos: Vec<[f32; 3]> = kept.iter().map(|&v| pos[v as usize]).collect();
        meshopt::simplify_decoder(&local, &local_pos, target, 1.0, meshopt::SimplifyOptions::None, None)
            .iter()
            .map(|&l| kept[l as usize])
            .collect()
    };
    // Pieces that stop above their share push the sum over: ask for less until it fits.
    let pieces = connected_pieces(&welded, pos.len());
    let pieces_kept = (triangles.min(target / 3) / 2 / PIECE_MIN_TRIANGLES).max(1);
    let mut by_pieces = simplify_by_pieces(&pieces, &pos, target, pieces_kept);
    let mut ask = target;
    for _ in 0..4 {
        if by_pieces.len() <= limit || ask <= 3 {
            break;
        }
        ask = (ask as f64 * target as f64 / by_pieces.len() as f64) as usize / 3 * 3;
        by_pieces = simplify_by_pieces(&pieces, &pos, ask.max(3), pieces_kept);
    }
    log::debug!(
        "NP3D mesh candidates: {} / {} / {} triangles ({} asked)",
        as_is.len() / 3,
        compacted.len() / 3,
        by_pieces.len() / 3,
        triangles
    );
    let sloppy = meshopt::simplify_sloppy_decoder(&welded, &pos, target, 1.0, None);
    let all = [as_is, compacted, by_pieces, sloppy];
    for c in all.iter().filter(|c| within(c)) {
        if !candidates.contains(c) {
            candidates.push(c.clone());
        }
    }
    let out = match candidates.len() {
        // None reaches the target: the smallest there is.
        0 => all
            .into_iter()
            .filter(|c| !c.is_empty())
            .min_by_key(Vec::len)
            .unwrap_or_default(),
        1 => candidates.pop().unwrap_or_default(),
        _ => {
            let truth = OutlineProbe::new(&pos, &welded);
            candidates
                .into_iter()
                .map(|c| (truth.agreement(&pos, &c), c))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, c)| c)
                .unwrap_or_default()
        }
    };
    if out.is_empty() { welded } else { out }
}

/// The outline of a mesh seen from seven sides (front, back, both sides, above and two
/// raised three-quarter views; orthographic, all framed by the mesh's bounding sphere) as
/// coverage masks, for comparing simplifications of it by silhouette agreement (IoU).
struct OutlineProbe {
    centre: Vec3,
    radius: f32,
    masks: Vec<Vec<bool>>,
}

impl OutlineProbe {
    const SIZE: usize = 96;

    fn directions() -> [(Vec3, Vec3); 7] {
        let raised = |yaw: f32| {
            let d = Vec3::new(yaw.sin() * 0.866, 0.5, yaw.cos() * 0.866);
            (d, Vec3::Y)
        };
        [
            (Vec3::Z, Vec3::Y),
            (-Vec3::Z, Vec3::Y),
            (Vec3::X, Vec3::Y),
            (-Vec3::X, Vec3::Y),
            (Vec3::Y, Vec3::Z),
            raised(0.8),
            raised(-2.3),
        ]
    }

    fn new(pos: &[[f32; 3]], indices: &[u32]) -> Self {
        let (lo, hi) = crate::character::bounds(indices.iter().map(|&i| Vec3::from(pos[i as usize])));
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(f32::MIN_POSITIVE);
        let mut probe = OutlineProbe {
            centre,
            radius,
            masks: Vec::new(),
        };
        probe.masks = probe.draw(pos, indices);
        probe
    }

    /// One coverage mask per direction: a pixel is covered when its centre lies in a
    /// projected triangle (either winding).
    fn draw(&self, pos: &[[f32; 3]], indices: &[u32]) -> Vec<Vec<bool>> {
        let n = Self::SIZE;
        Self::directions()
            .iter()
            .map(|&(d, up)| {
                let right = up.cross(d).normalize();
                let up = d.cross(right).normalize();
                let to_px = |p: Vec3| {
                    let q = p - self.centre;
                    let s = n as f32 * 0.5 / self.radius;
                    glam::Vec2::new(q.dot(right) * s + n as f32 * 0.5, q.dot(up) * s + n as f32 * 0.5)
                };
                let mut mask = vec![false; n * n];
                for t in indices.chunks_exact(3) {
                    let [a, b, c] = [0, 1, 2].map(|k| to_px(Vec3::from(pos[t[k] as usize])));
                    let area = (b - a).perp_dot(c - a);
                    if area == 0.0 {
                        continue;
                    }
                    let lo = a.min(b).min(c).floor().max(glam::Vec2::ZERO);
                    let hi = a.max(b).max(c).ceil().min(glam::Vec2::splat(n as f32));
                    for y in lo.y as usize..hi.y as usize {
                        for x in lo.x as usize..hi.x as usize {
                            let p = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                            let w = [
                                (c - b).perp_dot(p - b),
                                (a - c).perp_dot(p - c),
                                (b - a).perp_dot(p - a),
                            ];
                            if w.iter().all(|&w| w * area >= 0.0) {
                                mask[y * n + x] = true;
                            }
                        }
                    }
                }
                mask
            })
            .collect()
    }

    /// The mean over the directions of the IoU of `indices`' outline with the probe's.
    fn agreement(&self, pos: &[[f32; 3]], indices: &[u32]) -> f64 {
        let masks = self.draw(pos, indices);
        let ious = self.masks.iter().zip(&masks).map(|(a, b)| {
            let both = a.iter().zip(b).filter(|(a, b)| **a && **b).count();
            let either = a.iter().zip(b).filter(|(a, b)| **a || **b).count();
            if either == 0 { 1.0 } else { both as f64 / either as f64 }
        });
        ious.sum::<f64>() / self.masks.len() as f64
    }
}

/// The triangles every kept piece is given before the rest is shared by area (a triangular
/// prism without its ends).
const PIECE_MIN_TRIANGLES: usize = 6;

/// A welded mesh's connected `pieces` ([`connected_pieces`]) simplified to about `target`
/// indices: the `most` largest pieces (the caller allows as many as half the budget gives
/// [`PIECE_MIN_TRIANGLES`] each) get that many plus a share of the rest in proportion to
/// their area (the smaller pieces are left out), and each kept piece is simplified alone
/// (quadric, then clustering where the quadric one cannot reach the share).
fn simplify_by_pieces(pieces: &[Vec<u32>], pos: &[[f32; 3]], target: usize, most: usize) -> Vec<u32> {
    let area = |tris: &[u32]| -> f64 {
        tris.chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(pos[t[k] as usize]));
                0.5 * f64::from((b - a).cross(c - a).length())
            })
            .sum()
    };
    let areas: Vec<f64> = pieces.iter().map(|p| area(p)).collect();
    let triangles = (target / 3).max(PIECE_MIN_TRIANGLES);
    // The largest pieces, as many as can each have the minimum out of half the budget; the
    // other half shared in proportion to area.
    let mut kept: Vec<usize> = (0..pieces.len()).filter(|&i| areas[i] > 0.0).collect();
    kept.sort_by(|&a, &b| areas[b].total_cmp(&areas[a]).then(a.cmp(&b)));
    kept.truncate(most.max(1));
    let total: f64 = kept.iter().map(|&i| areas[i]).sum();
    let spare = triangles.saturating_sub(kept.len() * PIECE_MIN_TRIANGLES) as f64;
    let mut out = Vec::new();
    for &i in &kept {
        let piece = &pieces[i];
        let share = (PIECE_MIN_TRIANGLES + (areas[i] / total * spare).floor() as usize) * 3;
        if piece.len() <= share {
            out.extend_from_slice(piece);
            continue;
        }
        // The piece alone, so that the simplifiers' error and grid are scaled to it (over
        // the whole character's box the clustering one collapsed a thin arm to nothing).
        let (kept_vertices, local) = compact_u32(piece);
        let local_pos: Vec<[f32; 3]> = kept_vertices.iter().map(|&v| pos[v as usize]).collect();
        let quadric = meshopt::simplify_decoder(&local, &local_pos, share, 1.0, meshopt::SimplifyOptions::None, None);
        let mut s = quadric.clone();
        if s.len() > share + share / 2 || s.is_empty() {
            // Clustering, asking for more where it leaves next to nothing.
            let mut ask = share;
            loop {
                let sloppy = meshopt::simplify_sloppy_decoder(&local, &local_pos, ask, 1.0, None);
                if sloppy.len() >= 12 && sloppy.len() < quadric.len() {
                    s = sloppy;
                    break;
                }
                if sloppy.len() >= quadric.len() || ask >= local.len() {
                    break;
                }
                ask *= 2;
            }
        }
        let s: Vec<u32> = s.iter().map(|&l| kept_vertices[l as usize]).collect();
        out.extend_from_slice(&s);
    }
    out
}

/// The vertices `indices` use (in first-use order) and the indices renumbered into them.
fn compact_u32(indices: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let mut map: rustc_hash::FxHashMap<u32, u32> = Default::default();
    let mut kept = Vec::new();
    let local = indices
        .iter()
        .map(|&i| {
            *map.entry(i).or_insert_with(|| {
                kept.push(i);
                kept.len() as u32 - 1
            })
        })
        .collect();
    (kept, local)
}

/// The triangles of `indices` grouped by the connected piece they belong to (pieces sharing
/// a vertex are one), each piece's triangles in their original order, pieces in the order of
/// their first triangle.
fn connected_pieces(indices: &[u32], vertices: usize) -> Vec<Vec<u32>> {
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
    let mut parent: Vec<u32> = (0..vertices as u32).collect();
    for t in indices.chunks_exact(3) {
        let a = root(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = root(&mut parent, v);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let mut piece_of: rustc_hash::FxHashMap<u32, usize> = Default::default();
    let mut pieces: Vec<Vec<u32>> = Vec::new();
    for t in indices.chunks_exact(3) {
        let r = root(&mut parent, t[0]);
        let next = pieces.len();
        let k = *piece_of.entry(r).or_insert(next);
        if k == next {
            pieces.push(Vec::new());
        }
        pieces[k].extend_from_slice(t);
    }
    pieces
}

/// The vertices `indices` use (in first-use order) and the indices renumbered into them;
/// `None` if they use more than 65,535 vertices (what the 16-bit format holds).
pub fn compact(indices: &[u32]) -> Option<(Vec<u32>, Vec<u16>)> {
    let (kept, local) = compact_u32(indices);
    (kept.len() <= usize::from(u16::MAX)).then(|| (kept, local.into_iter().map(|l| l as u16).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_ids_survive_the_srgb_target() {
        for k in 0..=255u32 {
            // What the GPU writes for the linear colour of part k.
            let enc = |v: f32| {
                let s = if v <= 0.0031308 {
                    v * 12.92
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0).round() as u8
            };
            let p = image::Rgba([enc((k % 16) as f32 / 15.0), enc((k / 16) as f32 / 15.0), 0, 255]);
            assert_eq!(decode_part_id(&p) as u32, k);
        }
        let c = crate::default_character::generate();
        let labels: Vec<u32> = (0..c.triangle_count() as u32).map(|t| t % 5).collect();
        let id = part_id_character(&c, &labels);
        assert_eq!(id.vertices.len(), c.indices.len());
        assert_eq!(id.triangle_count(), c.triangle_count());
    }

    /// A morphing character's part-id copy (one vertex per corner) puts every corner where the
    /// character itself puts it at a pose with the targets weighed in: the targets follow the
    /// corners (with the old vertex numbers they moved other triangles' corners, and the
    /// segmentation view of a morphing bird drew scattered shards).
    #[test]
    fn part_id_character_morphs_like_the_character() {
        let mut c = crate::default_character::generate();
        let moved: Vec<u32> = (0..c.vertices.len() as u32).filter(|v| v % 3 == 0).collect();
        c.morphs = vec![crate::character::MorphTarget {
            name: "bulge".into(),
            rest_weight: 0.0,
            positions: moved
                .iter()
                .map(|&v| Vec3::new(0.01 * (v % 7) as f32, 0.02, -0.03))
                .collect(),
            normals: vec![Vec3::ZERO; moved.len()],
            vertices: moved,
        }];
        let id = part_id_character(&c, &[]);
        let mut pose = Pose::rest(&c);
        pose.morph_weights = vec![0.8];
        let mut id_pose = Pose::rest(&id);
        id_pose.morph_weights = vec![0.8];
        let (posed, _) = crate::animation::skin_vertices(&c, &pose);
        let (id_posed, _) = crate::animation::skin_vertices(&id, &id_pose);
        let mut moved_corners = 0;
        for (corner, &v) in c.indices.iter().enumerate() {
            assert!(id_posed[corner].distance(posed[v as usize]) < 1e-5, "corner {corner}");
            moved_corners += usize::from(v % 3 == 0);
        }
        assert!(moved_corners > 0);
    }

    #[test]
    fn sheets_are_near_square_with_few_empty_tiles() {
        assert_eq!(sheet_columns(10), 5);
        assert_eq!(sheet_columns(1), 1);
        assert_eq!(sheet_columns(16), 4);
        for n in 1..200usize {
            let c = sheet_columns(n) as usize;
            let rows = n.div_ceil(c);
            assert!(c * rows >= n && c * rows - n < c, "{n}: {c} columns");
            assert!(c >= rows, "{n}: wider than tall");
        }
    }

    /// The same mesh in other units (a node scaled in the file scales the skinned positions,
    /// not the bind pose) simplifies the same way: welding follows the posed positions.
    #[test]
    fn simplification_does_not_depend_on_units() {
        let c = crate::default_character::generate();
        let pos: Vec<Vec3> = c.vertices.iter().map(|v| v.position).collect();
        let base = simplify(&c, &pos, 400).len() / 3;
        for scale in [1e-3f32, 100.0, 1000.0, 1e5] {
            let scaled: Vec<Vec3> = pos.iter().map(|p| *p * scale + Vec3::splat(3.0 * scale)).collect();
            let n = simplify(&c, &scaled, 400).len() / 3;
            assert!(
                n.abs_diff(base) <= base / 10,
                "scale {scale}: {n} triangles, {base} at scale 1"
            );
        }
        // Too many vertices for 16-bit indices is said, not wrapped.
        let many: Vec<u32> = (0..70_000u32).collect();
        assert!(compact(&many).is_none());
        assert_eq!(compact(&[5, 9, 5]).unwrap(), (vec![5, 9], vec![0, 1, 0]));
    }

    /// A closed tube from `a` to `b` (radius `r`, `sides` around, `rings` along, capped),
    /// with its texture seam split as exports do (the first column of vertices repeated with
    /// other texture coordinates, so welding leaves unused duplicates behind).
    fn tube(c: &mut Character, a: Vec3, b: Vec3, r: f32, sides: u32, rings: u32) {
        let axis = (b - a).normalize();
        let side = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
        let u = axis.cross(side).normalize();
        let v = axis.cross(u);
        let first = c.vertices.len() as u32;
        let vertex = |p: Vec3, n: Vec3, uv: [f32; 2]| crate::character::Vertex {
            position: p,
            normal: n,
            uv,
            color: [1.0; 4],
            bones: [0; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
        };
        for i in 0..=rings {
            let t = i as f32 / rings as f32;
            for j in 0..=sides {
                let ang = std::f32::consts::TAU * (j % sides) as f32 / sides as f32;
                let n = u * ang.cos() + v * ang.sin();
                c.vertices
                    .push(vertex(a.lerp(b, t) + n * r, n, [j as f32 / sides as f32, t]));
            }
        }
        let at = |i: u32, j: u32| first + i * (sides + 1) + j;
        for i in 0..rings {
            for j in 0..sides {
                c.indices.extend([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
                c.indices.extend([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
            }
        }
        for (i, centre, n) in [(0, a, -axis), (rings, b, axis)] {
            let mid = c.vertices.len() as u32;
            c.vertices.push(vertex(centre, n, [0.5, 0.5]));
            for j in 0..sides {
                c.indices.extend([mid, at(i, j + 1), at(i, j)]);
            }
        }
    }

    /// A figure modelled in many separate pieces (torso, head, limbs of six segments each, a
    /// spear, a shield, forty small studs), as robot and game characters come: 400 triangles
    /// of it keep both legs, both arms and the spear, and its outline. Before, the
    /// simplifier, holding still every vertex with an unused welded duplicate, stopped
    /// thousands of triangles above the target, and the clustering fallback over the whole
    /// figure dropped the spear.
    #[test]
    fn a_figure_of_many_pieces_keeps_its_limbs() {
        let mut c = Character::default();
        tube(
            &mut c,
            Vec3::new(0.0, 0.95, 0.0),
            Vec3::new(0.0, 1.5, 0.0),
            0.16,
            24,
            12,
        );
        tube(
            &mut c,
            Vec3::new(0.0, 1.55, 0.0),
            Vec3::new(0.0, 1.78, 0.0),
            0.1,
            24,
            12,
        );
        // Limbs of short segments (robot-like), each its own piece.
        let limb = |c: &mut Character, from: Vec3, to: Vec3, r: f32| {
            for k in 0..6 {
                let (a, b) = (from.lerp(to, k as f32 / 6.0), from.lerp(to, (k as f32 + 0.9) / 6.0));
                tube(c, a, b, r, 24, 4);
            }
        };
        for side in [-1.0f32, 1.0] {
            limb(
                &mut c,
                Vec3::new(0.1 * side, 0.92, 0.0),
                Vec3::new(0.1 * side, 0.05, 0.0),
                0.05,
            );
            limb(
                &mut c,
                Vec3::new(0.2 * side, 1.45, 0.0),
                Vec3::new(0.75 * side, 1.45, 0.0),
                0.035,
            );
        }
        // A spear and a shield, as game characters carry.
        tube(
            &mut c,
            Vec3::new(0.85, 0.1, 0.0),
            Vec3::new(0.85, 2.0, 0.0),
            0.012,
            24,
            24,
        );
        tube(
            &mut c,
            Vec3::new(-0.85, 1.2, 0.0),
            Vec3::new(-0.85, 1.2, 0.03),
            0.25,
            24,
            2,
        );
        for k in 0..40 {
            let ang = k as f32 * 0.9;
            let p = Vec3::new(ang.cos() * 0.16, 1.0 + 0.012 * k as f32, ang.sin() * 0.16);
            tube(
                &mut c,
                p,
                p + Vec3::new(ang.cos(), 0.0, ang.sin()) * 0.03,
                0.015,
                24,
                12,
            );
        }
        let pos: Vec<Vec3> = c.vertices.iter().map(|v| v.position).collect();
        assert!(c.triangle_count() > 20_000);
        for scale in [1.0f32, 100.0] {
            let scaled: Vec<Vec3> = pos.iter().map(|p| *p * scale).collect();
            let idx = simplify(&c, &scaled, 400);
            let tris = idx.len() / 3;
            assert!((200..=440).contains(&tris), "scale {scale}: {tris} triangles");
            // Every limb's far end is still there: a kept vertex near each ankle and wrist.
            for end in [
                [-0.1f32, 0.05],
                [0.1, 0.05],
                [-0.75, 1.45],
                [0.75, 1.45],
                [0.85, 1.95],
                [0.85, 0.15],
            ] {
                let near = idx.iter().any(|&i| {
                    let p = pos[i as usize];
                    (p.x - end[0]).abs() < 0.08 && (p.y - end[1]).abs() < 0.08
                });
                assert!(near, "scale {scale}: nothing left near {end:?}");
            }
            let flat: Vec<[f32; 3]> = scaled.iter().map(|p| p.to_array()).collect();
            let truth = OutlineProbe::new(&flat, &c.indices);
            let agreement = truth.agreement(&flat, &idx);
            assert!(agreement > 0.8, "scale {scale}: outline agreement {agreement}");
        }
    }

    /// The outline probe against counted answers: a mesh agrees with itself, a square seen
    /// face-on covers the pixels its area says, and half of a mesh agrees by about half.
    #[test]
    fn outline_probe_counts_what_it_covers() {
        // A unit square in the xy plane and a second one beside it, at x 1..2.
        let pos: Vec<[f32; 3]> = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
        ];
        let both = [0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2];
        let probe = OutlineProbe::new(&pos, &both);
        assert_eq!(probe.agreement(&pos, &both), 1.0);
        // Face-on (the first direction, along z): the 2 x 1 rectangle inside a circle of
        // radius sqrt(5)/2 drawn 96 pixels across covers 2 / 5 * 96² pixels, give or take
        // an edge row of pixels.
        let covered = probe.masks[0].iter().filter(|&&m| m).count() as f32;
        let expected = 2.0 / 5.0 * 96.0 * 96.0;
        assert!(
            (covered - expected).abs() < 2.0 * 96.0,
            "{covered} pixels, {expected} expected"
        );
        // One square of the two: half the area face-on and from above... and along the
        // plane (side views) the rectangle has no area in either, which counts as agreement.
        let one = probe.agreement(&pos, &both[..6]);
        assert!(one > 0.5 && one < 0.9, "{one}");
    }

    #[test]
    fn simplified_mesh_is_near_the_target_and_stays_on_the_surface() {
        let c = crate::default_character::generate();
        let pos: Vec<Vec3> = c.vertices.iter().map(|v| v.position).collect();
        let idx = simplify(&c, &pos, 400);
        let tris = idx.len() / 3;
        assert!((300..=440).contains(&tris), "{tris} triangles");
        assert!(idx.iter().all(|&i| (i as usize) < c.vertices.len()));
        // Every kept vertex is an original vertex: the bounds shrink at most a little.
        let (lo, hi) = crate::character::bounds(pos.iter().copied());
        let (klo, khi) = crate::character::bounds(idx.iter().map(|&i| pos[i as usize]));
        assert!((hi - lo).y * 0.9 < (khi - klo).y, "height kept");
        let (kept, local) = compact(&idx).unwrap();
        assert_eq!(local.len(), idx.len());
        for (a, b) in idx.iter().zip(&local) {
            assert_eq!(*a, kept[*b as usize]);
        }
    }
}
