//! The quality sheet: the real mesh beside every representation, from the same camera at the
//! same scale, at a baked frame and half-way to the next, each tile labelled with its PSNR and
//! SSIM against the real mesh ([`crate::metrics`]). Rows show the Polypostor's worst views
//! first, then a spread of others, each at the baked frame where the Polypostor is worst from
//! that view. This is the picture to look at after any change to baking or drawing.

use super::compare::{ErrorRow, Renders, masked_rmse};
use crate::bake::raster::psnr;
use crate::crowd::lod::Level;
use crate::gpu::GpuError;

/// One row of the sheet: a view at a display time (in frames).
#[derive(Clone, Debug, PartialEq)]
pub struct SheetRow {
    pub view: usize,
    pub time: f32,
    /// Why it is shown ("worst 1", "spread", …).
    pub why: String,
}

/// The representations a sheet shows, in column order after the real mesh.
pub const COLUMNS: [Level; 3] = [Level::Polypostor, Level::Impostor, Level::Np3d];

/// Rows for `worst` views with the lowest Polypostor PSNR (or, without a Polypostor, of the
/// first representation measured) and `spread` others spread evenly over the remaining
/// compared views; each view gets a row at its worst baked frame and one half-way to the next.
pub fn sheet_rows(errors: &[ErrorRow], worst: usize, spread: usize) -> Vec<SheetRow> {
    let Some(row) = errors
        .iter()
        .find(|e| e.representation == Level::Polypostor.name())
        .or_else(|| errors.iter().find(|e| e.representation != Level::Skinned.name()))
    else {
        return Vec::new();
    };
    let mut by_psnr = row.per_view.clone();
    by_psnr.sort_by(|a, b| a.psnr.total_cmp(&b.psnr).then(a.view.cmp(&b.view)));
    let mut chosen: Vec<(usize, u32, String)> = by_psnr
        .iter()
        .take(worst)
        .enumerate()
        .map(|(i, v)| (v.view, v.worst_frame, format!("worst {}", i + 1)))
        .collect();
    let mut rest: Vec<_> = by_psnr.iter().skip(worst).collect();
    rest.sort_by_key(|v| v.view);
    let take = spread.min(rest.len());
    for i in 0..take {
        let v = rest[i * rest.len() / take];
        chosen.push((v.view, v.worst_frame, "spread".into()));
    }
    chosen
        .into_iter()
        .flat_map(|(view, frame, why)| {
            [
                SheetRow {
                    view,
                    time: frame as f32,
                    why: why.clone(),
                },
                SheetRow {
                    view,
                    time: frame as f32 + 0.5,
                    why,
                },
            ]
        })
        .collect()
}

const MARGIN: u32 = 12;
const HEADER: u32 = 34;
const ROW_TITLE: u32 = 24;
const CAPTION: u32 = 40;
const GAP: u32 = 8;
const PAPER: [u8; 4] = [250, 250, 250, 255];
const TILE_BACK: [u8; 3] = [56, 58, 64];
const INK: [u8; 3] = [30, 30, 30];

/// Error of one tile against the real mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileError {
    pub psnr: f64,
    pub ssim: f64,
}

/// Renders the sheet: a column for the real mesh and one per representation in [`COLUMNS`]
/// that the folder holds, a row per [`SheetRow`]; tiles `tile` pixels square (the renders
/// scaled down when larger). Returns the image and each row's tile errors (per column).
pub fn render_sheet(
    renders: &mut Renders<'_>,
    title: &str,
    rows: &[SheetRow],
    tile: u32,
) -> Result<(image::RgbaImage, Vec<Vec<Option<TileError>>>), GpuError> {
    // Readable captions need a tile of ~160 px; larger renders are scaled down to `tile`.
    let tile = tile.clamp(160, 1024);
    let columns: Vec<Level> = COLUMNS.iter().copied().filter(|l| renders.levels.contains(l)).collect();
    let ncol = 1 + columns.len() as u32;
    let width = 2 * MARGIN + ncol * tile + (ncol - 1) * GAP;
    let row_h = ROW_TITLE + tile + CAPTION;
    let height = 2 * MARGIN + HEADER + rows.len() as u32 * (row_h + GAP);
    let mut sheet = image::RgbaImage::from_pixel(width, height, image::Rgba(PAPER));
    crate::plot::draw_label(&mut sheet, MARGIN as i32, MARGIN as i32, 18.0, title, INK);
    let mut errors = Vec::with_capacity(rows.len());
    for (r, row) in rows.iter().enumerate() {
        let y0 = MARGIN + HEADER + r as u32 * (row_h + GAP);
        // In a pack of several clips, the clip too ("baked frame 37" said nothing of which).
        let clip = renders.clip_at(row.time);
        let when = match (row.time.fract() == 0.0, clip) {
            (true, None) => format!("baked frame {}", row.time as u32),
            (true, Some((name, t))) => format!("baked frame {} ({name} {})", row.time as u32, t as u32),
            (false, None) => format!("frame {:.1} (half-way, interpolated)", row.time),
            (false, Some((name, t))) => format!("frame {:.1} ({name} {t:.1}, half-way, interpolated)", row.time),
        };
        crate::plot::draw_label(
            &mut sheet,
            MARGIN as i32,
            y0 as i32 + 2,
            16.0,
            &format!("view {} · {} · {}", row.view, when, row.why),
            INK,
        );
        let Some(truth) = renders.truth(row.view, row.time)? else {
            errors.push(vec![None; columns.len()]);
            continue;
        };
        let mut row_errors = Vec::with_capacity(columns.len());
        for c in 0..ncol {
            let x0 = MARGIN + c * (tile + GAP);
            let (img, caption, err) = if c == 0 {
                (truth.clone(), ("real mesh".to_string(), "(skinned)".to_string()), None)
            } else {
                let level = columns[c as usize - 1];
                let Some(img) = renders.level(level, row.view, row.time)? else {
                    row_errors.push(None);
                    continue;
                };
                let e = TileError {
                    psnr: psnr(masked_rmse(&truth, &img)),
                    ssim: crate::metrics::ssim_rgba8(&truth, &img).unwrap_or(0.0),
                };
                (
                    img,
                    (
                        level.name().to_string(),
                        format!("{:.1} dB · SSIM {:.3}", e.psnr, e.ssim),
                    ),
                    Some(e),
                )
            };
            if c > 0 {
                row_errors.push(err);
            }
            place_tile(&mut sheet, &img, x0, y0 + ROW_TITLE, tile);
            let y = (y0 + ROW_TITLE + tile + 3) as i32;
            crate::plot::draw_label(&mut sheet, x0 as i32 + 2, y, 14.0, &caption.0, INK);
            crate::plot::draw_label(&mut sheet, x0 as i32 + 2, y + 17, 14.0, &caption.1, INK);
        }
        errors.push(row_errors);
    }
    Ok((sheet, errors))
}

/// Draws `img` (RGBA, alpha = coverage) over the tile background into `sheet` at (`x`, `y`),
/// scaled to `tile` pixels square.
fn place_tile(sheet: &mut image::RgbaImage, img: &image::RgbaImage, x: u32, y: u32, tile: u32) {
    let scaled = if img.width() == tile && img.height() == tile {
        img.clone()
    } else {
        image::imageops::resize(img, tile, tile, image::imageops::FilterType::Triangle)
    };
    for (tx, ty, p) in scaled.enumerate_pixels() {
        let (sx, sy) = (x + tx, y + ty);
        if sx >= sheet.width() || sy >= sheet.height() {
            continue;
        }
        let a = p[3] as f32 / 255.0;
        let mut out = [0u8; 4];
        for k in 0..3 {
            out[k] = (p[k] as f32 * a + TILE_BACK[k] as f32 * (1.0 - a)).round() as u8;
        }
        out[3] = 255;
        sheet.put_pixel(sx, sy, image::Rgba(out));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reps::compare::ViewError;

    fn row(name: &str, psnrs: &[f64]) -> ErrorRow {
        ErrorRow {
            representation: name.into(),
            mean_psnr: 0.0,
            mean_psnr_on_frames: 0.0,
            mean_psnr_between_frames: 0.0,
            mean_ssim: 0.0,
            mean_ssim_on_frames: 0.0,
            mean_ssim_between_frames: 0.0,
            mean_silhouette_iou: 1.0,
            truth_brightness: 0.5,
            worst_view: 0,
            worst_view_psnr: 0.0,
            samples: Vec::new(),
            per_view: psnrs
                .iter()
                .enumerate()
                .map(|(i, &p)| ViewError {
                    view: i * 2,
                    psnr: p,
                    ssim: 0.5,
                    worst_frame: i as u32,
                })
                .collect(),
            per_clip: Vec::new(),
        }
    }

    #[test]
    fn rows_show_the_worst_polypostor_views_first_then_a_spread() {
        let errors = vec![
            row("skinned", &[40.0; 8]),
            row("polypostor", &[20.0, 12.0, 18.0, 25.0, 11.0, 30.0, 22.0, 19.0]),
        ];
        let rows = sheet_rows(&errors, 2, 3);
        let views: Vec<usize> = rows.iter().map(|r| r.view).collect();
        // Worst: view index 4 (11 dB) then 1 (12 dB); views are numbered i * 2.
        assert_eq!(&views[..4], &[8, 8, 2, 2]);
        assert_eq!(rows.len(), 10, "five views, two rows each");
        assert_eq!(rows[0].time, 4.0, "at the view's worst baked frame");
        assert_eq!(rows[1].time, 4.5, "and half-way to the next");
        assert!(rows[0].why.starts_with("worst"));
        assert!(rows[4..].iter().all(|r| r.why == "spread"));
        let spread: Vec<usize> = rows[4..].iter().step_by(2).map(|r| r.view).collect();
        assert!(spread.iter().all(|v| *v != 8 && *v != 2), "no view twice: {spread:?}");
        // Fewer views than asked for: every view once.
        assert_eq!(sheet_rows(&errors, 10, 10).len(), 16);
        assert!(sheet_rows(&[], 3, 3).is_empty());
    }

    #[test]
    fn a_label_puts_ink_on_the_sheet() {
        let mut img = image::RgbaImage::from_pixel(200, 40, image::Rgba(PAPER));
        let w = crate::plot::draw_label(&mut img, 4, 4, 16.0, "view 3 · 14.2 dB", INK);
        assert!(w > 60.0, "{w}");
        let dark = img.pixels().filter(|p| p[0] < 128).count();
        assert!(dark > 30, "{dark} dark pixels");
        // Clipped at the edges, never out of bounds.
        crate::plot::draw_label(&mut img, 190, 30, 30.0, "clipped", INK);
    }
}
