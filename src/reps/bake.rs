//! Baking the comparison representations from the same views, resolution and frame rate as
//! the Polypostor bake (the cameras come from the same [`view_cameras`] framing, so each
//! view's image lines up with the pack's view pixel for pixel).

use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use super::{
    FrameVertices, ImpostorData, ImpostorInfo, Np3dData, Np3dInfo, REPS_FORMAT, REPS_VERSION, RepSet, RepView,
    Representations, RepsManifest, RigidInfo,
};
use crate::animation::{Pose, skin_vertices};
use crate::bake::pipeline::{BakeError, Progress};
use crate::bake::renders::{frame_times, sample_frames, view_cameras};
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
    /// The texture key-frame (NP3D images).
    pub key_frame: usize,
    pub set: RepSet,
    pub np3d_triangles: usize,
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
    let duration = options
        .clip
        .and_then(|i| character.clips.get(i))
        .map_or(0.0, |c| c.duration_secs);
    let times = frame_times(duration, options.fps);
    let frames = times.len();
    if options.key_frame >= frames {
        return Err(BakeError::KeyFrame(options.key_frame, frames));
    }
    let (poses, points) = sample_frames(character, options.clip, &times);
    let dirs = directions(options.views.max(1), options.coverage);
    let cameras = view_cameras(&points, &dirs);
    let r = options.resolution;
    let set = options.set;

    // Whole-character renders: every frame of every view for impostors, the key frame for
    // NP3D.
    let mut impostor = None;
    let mut np3d_images = Vec::new();
    if set.impostor || set.np3d {
        let renderer = CharacterRenderer::new(&ctx.device);
        let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, character);
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
        let columns = (frames as f64).sqrt().ceil().max(1.0) as u32;
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
                let nrm = target.read_normal(&ctx.device, &ctx.queue)?;
                // Bleed colour into the background so filtering at the silhouette does not
                // pull in black.
                crate::pack::dilate(&mut c, 2);
                if f == options.key_frame {
                    np3d_images[v] = c.clone();
                }
                let (x, y) = ((f as u32 % columns) * r, (f as u32 / columns) * r);
                image::imageops::replace(&mut color[v], &c, x as i64, y as i64);
                image::imageops::replace(&mut normal[v], &nrm, x as i64, y as i64);
            }
        }
        if set.impostor {
            impostor = Some(ImpostorData {
                columns,
                rows,
                color,
                normal,
            });
        }
    }

    let np3d = if set.np3d {
        progress(Progress {
            stage: "np3d",
            done: 0,
            total: 1,
        });
        let indices = simplify(character, &points[options.key_frame], options.np3d_triangles);
        let (kept, local) = compact(&indices);
        Some(Np3dData {
            indices: local,
            source: kept.clone(),
            frames: frame_vertices(character, &poses, Some(&kept)),
            images: np3d_images,
        })
    } else {
        None
    };
    let rigid = set.rigid.then(|| frame_vertices(character, &poses, None));

    let columns = (cameras.len() as f64).sqrt().ceil().max(1.0) as u32;
    let manifest = RepsManifest {
        format: REPS_FORMAT.into(),
        version: REPS_VERSION,
        character: character.name.clone(),
        character_path: character_path.map(String::from),
        clip: clip_name.map(String::from),
        fps: options.fps,
        frames: frames as u32,
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
        np3d: np3d.as_ref().map(|n| Np3dInfo {
            vertex_count: n.frames.vertex_count as u32,
            index_count: n.indices.len() as u32,
            columns,
        }),
        rigid: rigid.as_ref().map(|r| RigidInfo {
            vertex_count: r.vertex_count as u32,
        }),
    };
    Ok(Representations {
        manifest,
        impostor,
        np3d,
        rigid,
    })
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
/// first, so seams do not stop the simplification; where the quadric simplifier cannot reach
/// the target within its error bound, the sloppy (clustering) one finishes the job.
pub fn simplify(character: &Character, positions: &[Vec3], triangles: usize) -> Vec<u32> {
    let n = positions.len().min(character.vertices.len());
    let (lo, hi) = crate::character::bounds(positions.iter().copied());
    let cell = ((hi - lo).max_element() * 1e-5).max(1e-9);
    let mut first: rustc_hash::FxHashMap<[i64; 3], u32> = Default::default();
    let weld: Vec<u32> = (0..n)
        .map(|i| {
            let q = (character.vertices[i].position / cell).round().as_i64vec3().to_array();
            *first.entry(q).or_insert(i as u32)
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
    let pos: Vec<[f32; 3]> = positions[..n].iter().map(|p| p.to_array()).collect();
    let target = (triangles * 3).min(welded.len());
    if welded.len() <= target {
        return welded;
    }
    let mut out = meshopt::simplify_decoder(&welded, &pos, target, 1.0, meshopt::SimplifyOptions::None, None);
    if out.len() > target + target / 10 {
        out = meshopt::simplify_sloppy_decoder(&welded, &pos, target, 1.0, None);
    }
    out
}

/// The vertices `indices` use (in first-use order) and the indices renumbered into them.
pub fn compact(indices: &[u32]) -> (Vec<u32>, Vec<u16>) {
    let mut map: rustc_hash::FxHashMap<u32, u16> = Default::default();
    let mut kept = Vec::new();
    let local = indices
        .iter()
        .map(|&i| {
            *map.entry(i).or_insert_with(|| {
                kept.push(i);
                (kept.len() - 1) as u16
            })
        })
        .collect();
    (kept, local)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let (kept, local) = compact(&idx);
        assert_eq!(local.len(), idx.len());
        for (a, b) in idx.iter().zip(&local) {
            assert_eq!(*a, kept[*b as usize]);
        }
    }
}
