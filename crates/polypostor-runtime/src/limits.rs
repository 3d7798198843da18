//! Every documented limit in one place. Inputs beyond them are refused up front with an
//! error that names the limit (see the README's "Limits and safety"), never discovered by a
//! panic or an allocation failure minutes into the work. Also the names that mark a folder as
//! one this tool wrote (the formats' manifest names), which the safe file layer checks.

/// Most viewpoints a bake takes (`--views`); the representation loader accepts no more.
pub const MAX_VIEWS: usize = 4096;
/// Part image resolution range of a bake (`--resolution`), pixels per side.
pub const MIN_RESOLUTION: u32 = 16;
/// Largest part image resolution of a bake (`--resolution`), pixels per side.
pub const MAX_RESOLUTION: u32 = 2048;
/// Clip sampling rate range of a bake (`--fps`), frames per second.
pub const MIN_FPS: f32 = 0.01;
/// Highest clip sampling rate of a bake (`--fps`), frames per second.
pub const MAX_FPS: f32 = 240.0;
/// Most frames of one baked clip (clip duration × frame rate); packs and representation
/// folders with more are refused as damaged.
pub const MAX_FRAMES: usize = 10_000;
/// Most body parts a segmentation may have (the exact visibility order is a dynamic
/// programme over subsets of parts: `2^parts` table entries).
pub const MAX_PARTS: usize = 20;
/// Estimated peak memory a bake may need (images of the views in flight, key-frame images of
/// every view, impostor sheets). A bake estimated above it is refused before it starts, with
/// the settings that would fit.
pub const BAKE_MEMORY_BUDGET: u64 = 8 << 30;
/// Most pixels of all decoded textures of one pack or representation folder (RGBA8: four
/// bytes each), checked from the manifests before anything is decoded.
pub const MAX_LOADED_TEXTURE_BYTES: u64 = 3 << 30;
/// Largest texture side of an imported glTF image.
pub const MAX_IMPORT_TEXTURE_SIDE: u32 = 8192;
/// Most bytes of all decoded textures of one imported character (RGBA8).
pub const MAX_IMPORT_TEXTURE_BYTES: u64 = 1 << 30;
/// Most nodes of an imported glTF scene graph.
pub const MAX_NODES: usize = 1 << 20;
/// Largest image side the command line renders (`render --size`, `bench crowd --width`);
/// the adapter's own texture limit applies too, whichever is smaller.
pub const MAX_RENDER_SIDE: u32 = 16384;
/// Largest render target in pixels (colour, normal and depth: 12 bytes each), so
/// `render --size` and `bench crowd` stay near 1 GiB.
pub const MAX_RENDER_PIXELS: u64 = 96 << 20;

/// A limit that an input exceeds.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct LimitError(pub String);

/// Frames of a clip of `duration_secs` sampled at `fps` (at least one), or the limit it
/// exceeds. The count matches [`crate::timeline::frame_times`].
pub fn frame_count(duration_secs: f32, fps: f32) -> Result<usize, LimitError> {
    if !(duration_secs.is_finite() && fps.is_finite()) {
        return Err(LimitError(format!(
            "a clip of {duration_secs} s at {fps} frames per second cannot be sampled"
        )));
    }
    if !(duration_secs > 0.0) || !(fps > 0.0) {
        return Ok(1);
    }
    let n = ((duration_secs * fps) - 1e-4).ceil().max(1.0);
    if !(n <= MAX_FRAMES as f32) {
        return Err(LimitError(format!(
            "a clip of {duration_secs} s at {fps} frames per second has {n:.0} frames, more than the limit of {MAX_FRAMES}"
        )));
    }
    Ok(n as usize)
}

/// Largest texture side of a device, with [`MAX_RENDER_SIDE`] on top.
pub fn render_side_limit(device: &wgpu::Device) -> u32 {
    device.limits().max_texture_dimension_2d.min(MAX_RENDER_SIDE)
}

/// Checks an image size the command line is asked to render on `device`.
pub fn check_render_size(device: &wgpu::Device, width: u32, height: u32, what: &str) -> Result<(), LimitError> {
    let side = render_side_limit(device);
    if width == 0 || height == 0 {
        return Err(LimitError(format!(
            "{what}: an image of {width}×{height} pixels is empty"
        )));
    }
    if width > side || height > side {
        return Err(LimitError(format!(
            "{what}: {width}×{height} pixels exceeds the largest image side of {side} (this GPU's texture limit)"
        )));
    }
    if u64::from(width) * u64::from(height) > MAX_RENDER_PIXELS {
        return Err(LimitError(format!(
            "{what}: {width}×{height} pixels exceeds the limit of {} megapixels",
            MAX_RENDER_PIXELS >> 20
        )));
    }
    Ok(())
}

/// Bytes in a readable unit ("1.5 GiB").
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", b / (1u64 << 30) as f64)
    } else if b >= (1u64 << 20) as f64 {
        format!("{:.1} MiB", b / (1u64 << 20) as f64)
    } else {
        format!("{:.0} KiB", b / 1024.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_counts_match_the_bake_sampling_and_stop_at_the_limit() {
        for (d, f) in [
            (1.0, 10.0),
            (0.7, 10.0),
            (0.75, 10.0),
            (0.0, 10.0),
            (2.0, 30.0),
            (12.8, 10.0),
        ] {
            assert_eq!(
                frame_count(d, f).unwrap(),
                crate::timeline::frame_times(d, f).len(),
                "{d} s at {f} fps"
            );
        }
        assert_eq!(frame_count(1000.0, 10.0).unwrap(), MAX_FRAMES);
        for (d, f) in [
            (1e30, 10.0),
            (1e6, 10.0),
            (1000.1, 10.0),
            (f32::INFINITY, 10.0),
            (1.0, f32::NAN),
        ] {
            let e = frame_count(d, f).unwrap_err();
            assert!(e.0.contains("frames") || e.0.contains("cannot"), "{e}");
        }
    }
}

/// Largest file (and external buffer or image) the glTF importer reads
/// (`import::MAX_FILE_BYTES`).
pub const MAX_IMPORT_FILE_BYTES: u64 = 1 << 31;

/// The `format` of every pack manifest (`pack::FORMAT_NAME`): what marks a folder as a pack
/// this tool wrote (also to `safe_fs`, which replaces only such folders).
pub const PACK_FORMAT_NAME: &str = "polypostor-pack";
/// The `format` of every representations manifest (`reps::REPS_FORMAT`).
pub const REPS_FORMAT_NAME: &str = "polypostor-representations";
/// File name of a representations folder's manifest (`reps::REPS_FILE`).
pub const REPS_FILE: &str = "representations.json";
