//! PNG charts for reports (for example the `polypostor compare` report): a grouped bar
//! chart (memory per variant, optionally on a log axis) and a line chart (error per frame).
//!
//! Drawn with `plotters` into an in-memory RGB buffer and written with the `image` crate, so
//! there is a single `image` version in the build. Text uses the Ubuntu-Light font bundled in
//! `epaint_default_fonts`, registered once with plotters' `ab_glyph` feature; no system fonts
//! are needed. The glyphs themselves are placed by this module's backend wrapper (`Canvas`),
//! because plotters 0.3.7's own `ab_glyph` drawing spaces letters unevenly.
//!
//! Every chart is [`WIDTH`] × [`HEIGHT`] pixels on a white background; series take the colours
//! of [`PALETTE`] in order (cycling after six). Odd input never panics:
//! - NaN and ±infinity values are skipped (a line is broken where a point is skipped);
//! - on a log axis, zero and negative values have no bar (they cannot be shown);
//! - input with nothing drawable (no labels, no series, no finite value, or on a log axis no
//!   positive value) is an `Err` and no file is written;
//! - a bar series whose length differs from the number of labels is an `Err`, and so are
//!   values an axis cannot span (a range overflowing `f64`, or below ~1e-300 on a log axis).
//!
//! The file is always written as PNG, whatever the extension of `path`; the parent folder must
//! exist, and an existing file is replaced only if this tool wrote it
//! ([`crate::safe_fs::write_png`]).

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendColor, BackendCoord, BackendTextStyle, DrawingErrorKind};

/// Width of every chart, in pixels.
pub const WIDTH: u32 = 1000;
/// Height of every chart, in pixels.
pub const HEIGHT: u32 = 600;

/// Series colours, in order (Tableau 10's first six); series `i` uses `PALETTE[i % 6]`.
pub const PALETTE: [(u8, u8, u8); 6] = [
    (31, 119, 180),  // blue
    (255, 127, 14),  // orange
    (44, 160, 44),   // green
    (214, 39, 40),   // red
    (148, 103, 189), // purple
    (140, 86, 75),   // brown
];

/// The font family name registered with plotters.
const FONT: &str = "sans-serif";
const TITLE_SIZE: f64 = 28.0;
const AXIS_DESC_SIZE: f64 = 20.0;
const LABEL_SIZE: f64 = 17.0;
const LEGEND_SIZE: f64 = 18.0;
const VALUE_SIZE: f64 = 15.0;
const TEXT: RGBColor = RGBColor(30, 30, 30);
const GRID: RGBColor = RGBColor(225, 225, 225);
const GRID_BOLD: RGBColor = RGBColor(200, 200, 200);

/// Grouped bar chart: one group per label, one bar per series in each group, a legend.
///
/// `series` is `(name, values)` with `values[i]` belonging to `labels[i]`; each series must
/// have exactly `labels.len()` values. Each bar carries its value (3 significant digits) at
/// its end, if every such label fits the bar width (otherwise no bar has one). With `log_y`, the y axis is logarithmic (powers of
/// ten), so values spanning several decades are all visible; zero and negative values then
/// have no bar. Non-finite values have no bar.
pub fn bar_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    labels: &[String],
    series: &[(String, Vec<f64>)],
    log_y: bool,
) -> Result<(), String> {
    if labels.is_empty() {
        return Err(format!("bar chart \"{title}\": no labels (no groups) to plot"));
    }
    if series.is_empty() {
        return Err(format!("bar chart \"{title}\": no series to plot"));
    }
    if let Some((name, values)) = series.iter().find(|(_, v)| v.len() != labels.len()) {
        return Err(format!(
            "bar chart \"{title}\": series \"{name}\" has {} values but there are {} labels",
            values.len(),
            labels.len()
        ));
    }
    let drawable = |v: f64| v.is_finite() && (!log_y || v > 0.0);
    let values = series.iter().flat_map(|(_, v)| v.iter().copied());
    let Some((min, max)) = finite_min_max(values.filter(|&v| drawable(v))) else {
        return Err(format!(
            "bar chart \"{title}\": no {} value to plot",
            if log_y { "finite positive (log axis)" } else { "finite" }
        ));
    };

    ensure_font()?;
    let names: Vec<&str> = series.iter().map(|(n, _)| n.as_str()).collect();
    render(path, |root| {
        let area = header(root, title, &names, LegendMark::Square)?;
        if log_y {
            // Whole decades, so that the axis always has labelled powers of ten; a little room
            // below the smallest bar and above the tallest one for its value label.
            let lo = 10f64.powf((min.log10() - 0.1).floor());
            let hi = 10f64.powf((max.log10() + 0.15).ceil());
            if !(lo > 0.0 && hi.is_finite() && hi > lo) {
                return Err(format!("bar chart \"{title}\": values out of range for a log axis"));
            }
            let y: LogCoord<f64> = (lo..hi).log_scale().into();
            // Light grid lines at 2..9 × 10^k: plotters spreads about `10 × light_lines` light
            // points over the decades, so one per decade gives exactly those.
            let decades = (hi / lo).log10().round().max(1.0) as usize;
            let axis = YAxis {
                coord: y,
                base: lo,
                light_lines: decades,
            };
            draw_bars(&area, y_label, labels, series, axis, &drawable)
        } else {
            let lo = min.min(0.0);
            let hi = max.max(0.0);
            let pad = if hi > lo { (hi - lo) * 0.12 } else { 1.0 };
            let (lo, hi) = (
                if lo < 0.0 { lo - pad } else { 0.0 },
                if hi > 0.0 || lo == 0.0 { hi + pad } else { 0.0 },
            );
            if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                return Err(format!("bar chart \"{title}\": values too large to plot"));
            }
            let y: RangedCoordf64 = (lo..hi).into();
            let axis = YAxis {
                coord: y,
                base: 0.0,
                light_lines: 4,
            };
            draw_bars(&area, y_label, labels, series, axis, &drawable)
        }
    })
}

/// Line chart: one line (with point markers) per series of `(x, y)` points, legend, axis labels.
///
/// Points are joined in the order given. Points with a non-finite coordinate are skipped and
/// break the line. Markers get smaller as series get longer and are left out above 400
/// points per series (the line alone is clearer there).
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), String> {
    if series.is_empty() {
        return Err(format!("line chart \"{title}\": no series to plot"));
    }
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let points = || series.iter().flat_map(|(_, p)| p.iter().filter(|p| finite(p)));
    let (Some((x_min, x_max)), Some((y_min, y_max))) = (
        finite_min_max(points().map(|p| p.0)),
        finite_min_max(points().map(|p| p.1)),
    ) else {
        return Err(format!("line chart \"{title}\": no finite point to plot"));
    };
    let x_range = padded(x_min, x_max, 0.0);
    // Non-negative data (errors, sizes) keeps 0 as the bottom of the axis.
    let y_range = padded(y_min, y_max, 0.08).map(|r| if y_min >= 0.0 { r.start.max(0.0)..r.end } else { r });
    let (Some(x_range), Some(y_range)) = (x_range, y_range) else {
        return Err(format!("line chart \"{title}\": values too large to plot"));
    };

    ensure_font()?;
    let names: Vec<&str> = series.iter().map(|(n, _)| n.as_str()).collect();
    render(path, |root| {
        let area = header(root, title, &names, LegendMark::Line)?;
        let mut chart = ChartBuilder::on(&area)
            .margin_left(10)
            .margin_right(30)
            .margin_top(10)
            .margin_bottom(5)
            .x_label_area_size(60)
            .y_label_area_size(95)
            .build_cartesian_2d(x_range, y_range)
            .map_err(draw_err)?;
        let fmt = |v: &f64| format_value(*v);
        chart
            .configure_mesh()
            .bold_line_style(GRID_BOLD)
            .light_line_style(GRID)
            .axis_style(TEXT)
            .label_style(font(LABEL_SIZE))
            .axis_desc_style(font(AXIS_DESC_SIZE))
            .x_labels(12)
            .y_labels(10)
            .max_light_lines(4)
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt)
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()
            .map_err(draw_err)?;

        for (i, (_, pts)) in series.iter().enumerate() {
            let colour = colour(i);
            let n = pts.iter().filter(|p| finite(p)).count();
            let marker = match n {
                0..=60 => 4,
                61..=150 => 3,
                151..=400 => 2,
                _ => 0,
            };
            // A wide line is drawn as a polygon with mitred joins: on a dense series that
            // zigzags (hundreds of frames, sharp turns a pixel apart) the mitres shoot far past
            // the plot, over the title. Dense series are drawn one pixel wide (no joins).
            let width = if n > 400 { 1 } else { 2 };
            for run in pts.split(|p| !finite(p)).filter(|r| !r.is_empty()) {
                chart
                    .draw_series(LineSeries::new(run.iter().copied(), colour.stroke_width(width)).point_size(marker))
                    .map_err(draw_err)?;
            }
        }
        Ok(())
    })
}

/// The colour of series `i`.
fn colour(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&TEXT)
}

fn draw_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> String {
    format!("drawing the chart failed: {e}")
}

/// Registers the bundled font with plotters once per process.
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
                .map_err(|_| "the bundled chart font (Ubuntu-Light) could not be loaded".to_string())
        })
        .clone()
}

/// Draws into a white RGB buffer with `draw`, then writes it to `path` as PNG.
fn render<F>(path: &Path, draw: F) -> Result<(), String>
where
    F: FnOnce(&DrawingArea<Canvas<'_>, Shift>) -> Result<(), String>,
{
    let mut buf = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let backend = BitMapBackend::with_buffer_and_format(&mut buf, (WIDTH, HEIGHT))
            .map(Canvas)
            .map_err(|e| format!("chart buffer: {e}"))?;
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    let image =
        image::RgbImage::from_raw(WIDTH, HEIGHT, buf).ok_or_else(|| "chart buffer has the wrong size".to_string())?;
    let rgba = image::DynamicImage::ImageRgb8(image).to_rgba8();
    crate::safe_fs::write_png(path, &rgba).map_err(|e| format!("writing chart {}: {e}", path.display()))
}

/// The bundled font, parsed once, for [`Canvas`]'s own text rendering.
fn ui_font() -> Option<&'static ab_glyph::FontRef<'static>> {
    static FONT_REF: OnceLock<Option<ab_glyph::FontRef<'static>>> = OnceLock::new();
    FONT_REF
        .get_or_init(|| ab_glyph::FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).ok())
        .as_ref()
}

/// Draws `text` in one line on `img` with its top-left corner at (`x`, `y`), `size` pixels
/// high, in `rgb` blended over what is there (the bundled font; clipped at the image's
/// edges). Returns the text's width in pixels (0 when the font cannot be read).
pub fn draw_label(img: &mut image::RgbaImage, x: i32, y: i32, size: f32, text: &str, rgb: [u8; 3]) -> f32 {
    use ab_glyph::Font;
    let Some(font) = ui_font() else { return 0.0 };
    let (glyphs, w, _) = layout_line(font, size as f64, text);
    let (iw, ih) = (img.width() as i32, img.height() as i32);
    for glyph in glyphs {
        let Some(outline) = font.outline_glyph(glyph) else {
            continue;
        };
        let b = outline.px_bounds();
        let (x0, y0) = (x + b.min.x.round() as i32, y + b.min.y.round() as i32);
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (x0 + gx as i32, y0 + gy as i32);
            if px < 0 || py < 0 || px >= iw || py >= ih {
                return;
            }
            let a = coverage.clamp(0.0, 1.0);
            let p = img.get_pixel_mut(px as u32, py as u32);
            for k in 0..3 {
                p[k] = (p[k] as f32 * (1.0 - a) + rgb[k] as f32 * a).round() as u8;
            }
            p[3] = p[3].max((a * 255.0) as u8);
        });
    }
    w
}

/// Glyphs of `text` laid out on one line at pixel `size`, the line's top at y = 0, with the
/// line's width and height.
fn layout_line(font: &ab_glyph::FontRef<'static>, size: f64, text: &str) -> (Vec<ab_glyph::Glyph>, f32, f32) {
    use ab_glyph::{Font, ScaleFont};
    let scaled = font.as_scaled(size as f32);
    let mut glyphs = Vec::with_capacity(text.len());
    let mut x = 0.0f32;
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            x += scaled.kern(p, id);
        }
        glyphs.push(id.with_scale_and_position(scaled.scale(), ab_glyph::point(x, scaled.ascent().round())));
        x += scaled.h_advance(id);
        prev = Some(id);
    }
    (glyphs, x, scaled.height())
}

/// The bitmap backend with its own text rendering.
///
/// plotters 0.3.7's `ab_glyph` text drawing (`FontDataInternal::draw`) drops each glyph's
/// left side bearing and truncates the pen position to whole pixels, which makes the spacing
/// visibly uneven ("a long" reads "along"; compare plotters issue #576), and its anchoring
/// puts text a few pixels too high. Text is laid out here with
/// sub-pixel glyph positions and kerning instead (same font, same sizes); everything else is
/// `BitMapBackend`'s.
struct Canvas<'a>(BitMapBackend<'a>);

impl DrawingBackend for Canvas<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let Some(font) = ui_font() else {
            return self.0.estimate_text_size(text, style);
        };
        let (_, w, h) = layout_line(font, style.size(), text);
        Ok((w.ceil() as u32, h.ceil() as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        use ab_glyph::Font;
        let Some(font) = ui_font() else {
            return self.0.draw_text(text, style, pos);
        };
        let color = style.color();
        if color.alpha <= 0.0 {
            return Ok(());
        }
        let (glyphs, w, h) = layout_line(font, style.size(), text);
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Center => -w / 2.0,
            HPos::Right => -w,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0.0,
            VPos::Center => -h / 2.0,
            VPos::Bottom => -h,
        };
        let transform = style.transform();
        for glyph in glyphs {
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            let (x0, y0) = ((bounds.min.x + dx).round() as i32, (bounds.min.y + dy).round() as i32);
            outline.draw(|gx, gy, coverage| {
                let (x, y) = transform.transform(x0 + gx as i32, y0 + gy as i32);
                let alpha = color.alpha * f64::from(coverage.clamp(0.0, 1.0));
                // Out-of-image pixels are skipped by the bitmap backend; it never fails.
                let _ = self
                    .0
                    .draw_pixel((pos.0 + x, pos.1 + y), BackendColor { alpha, rgb: color.rgb });
            });
        }
        Ok(())
    }
}

#[derive(Clone, Copy)]
enum LegendMark {
    Square,
    Line,
}

/// Draws the title and a legend strip (wrapped onto several rows when needed) at the top of
/// `root`; returns the area left for the chart.
fn header<'a>(
    root: &DrawingArea<Canvas<'a>, Shift>,
    title: &str,
    names: &[&str],
    mark: LegendMark,
) -> Result<DrawingArea<Canvas<'a>, Shift>, String> {
    let title_style = font(TITLE_SIZE).pos(Pos::new(HPos::Center, VPos::Top));
    let title = fit_text(root, title, &title_style, WIDTH - 40)?;
    root.draw_text(&title, &title_style, (WIDTH as i32 / 2, 10))
        .map_err(draw_err)?;
    let title_h = root.estimate_text_size("Mg", &title_style).map_err(draw_err)?.1 as i32;
    let area = root.split_vertically(10 + title_h + 6).1;

    // Lay the legend entries out in rows, at most `MAX_LEGEND_ROWS`; entries that do not fit
    // are summed up as "+N more" (an entry without a mark, index `usize::MAX`).
    const MAX_LEGEND_ROWS: usize = 4;
    let style = font(LEGEND_SIZE);
    let (mark_w, gap, row_h, side) = (28i32, 26i32, 26i32, 40i32);
    let max_row = WIDTH as i32 - 2 * side;
    let text_w =
        |t: &str| -> Result<i32, String> { Ok(root.estimate_text_size(t, &style).map_err(draw_err)?.0 as i32) };
    let row_width = |row: &[(usize, String, i32)]| row.iter().map(|e| e.2 + gap).sum::<i32>() - gap;
    let mut rows: Vec<Vec<(usize, String, i32)>> = vec![vec![]];
    let mut hidden = 0;
    for (i, name) in names.iter().enumerate() {
        let text = fit_text(root, name, &style, (max_row - mark_w - 8) as u32)?;
        let w = mark_w + 8 + text_w(&text)?;
        let row = rows.last_mut().expect("rows is never empty");
        if row.is_empty() || row_width(row) + gap + w <= max_row {
            row.push((i, text, w));
        } else if rows.len() < MAX_LEGEND_ROWS {
            rows.push(vec![(i, text, w)]);
        } else {
            hidden = names.len() - i;
            break;
        }
    }
    if hidden > 0 {
        let row = rows.last_mut().expect("rows is never empty");
        loop {
            let more = format!("+{hidden} more");
            let w = text_w(&more)?;
            if row.len() <= 1 || row_width(row) + gap + w <= max_row {
                row.push((usize::MAX, more, w));
                break;
            }
            row.pop();
            hidden += 1;
        }
    }
    let strip_h = rows.len() as i32 * row_h + 8;
    let (strip, rest) = area.split_vertically(strip_h);
    for (r, row) in rows.iter().enumerate() {
        let mut x = (WIDTH as i32 - row_width(row)) / 2;
        let cy = r as i32 * row_h + row_h / 2;
        for (i, text, w) in row {
            if *i == usize::MAX {
                let style = style.pos(Pos::new(HPos::Left, VPos::Center));
                strip.draw_text(text, &style, (x, cy)).map_err(draw_err)?;
                continue;
            }
            let c = colour(*i);
            match mark {
                LegendMark::Square => {
                    strip.draw(&Rectangle::new([(x + 6, cy - 8), (x + mark_w - 6, cy + 8)], c.filled()))
                }
                LegendMark::Line => strip
                    .draw(&PathElement::new(vec![(x, cy), (x + mark_w, cy)], c.stroke_width(3)))
                    .and_then(|_| strip.draw(&Circle::new((x + mark_w / 2, cy), 4, c.filled()))),
            }
            .map_err(draw_err)?;
            strip
                .draw_text(
                    text,
                    &style.pos(Pos::new(HPos::Left, VPos::Center)),
                    (x + mark_w + 8, cy),
                )
                .map_err(draw_err)?;
            x += w + gap;
        }
    }
    Ok(rest)
}

/// The y axis of [`bar_chart`]: linear or log coordinates, where bars start, and at most how
/// many light grid lines go between two labelled ones.
struct YAxis<Y> {
    coord: Y,
    base: f64,
    light_lines: usize,
}

/// The bars, axes and value labels of [`bar_chart`], for a linear or a log y axis.
fn draw_bars<Y>(
    area: &DrawingArea<Canvas<'_>, Shift>,
    y_label: &str,
    labels: &[String],
    series: &[(String, Vec<f64>)],
    y: YAxis<Y>,
    drawable: &dyn Fn(f64) -> bool,
) -> Result<(), String>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let groups = labels.len();
    let x = GroupAxis { groups };
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(30)
        .margin_top(10)
        .margin_bottom(5)
        .x_label_area_size(40)
        .y_label_area_size(95)
        .build_cartesian_2d(x, y.coord)
        .map_err(draw_err)?;

    // Pixel width of one group, to fit the labels and decide on value labels.
    let group_px = chart.plotting_area().dim_in_pixel().0 as f64 / groups as f64;
    let label_style = font(LABEL_SIZE);
    let mut shown_labels = Vec::with_capacity(groups);
    for label in labels {
        shown_labels.push(fit_text(area, label, &label_style, (group_px - 6.0).max(8.0) as u32)?);
    }
    let x_fmt = |v: &f64| {
        let g = v.floor();
        if g >= 0.0 && (g as usize) < groups {
            shown_labels[g as usize].clone()
        } else {
            String::new()
        }
    };
    let y_fmt = |v: &f64| format_value(*v);
    chart
        .configure_mesh()
        .disable_x_mesh()
        .bold_line_style(GRID_BOLD)
        .light_line_style(GRID)
        .axis_style(TEXT)
        .label_style(label_style.clone())
        .axis_desc_style(font(AXIS_DESC_SIZE))
        .y_labels(10)
        .y_max_light_lines(y.light_lines)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .y_desc(y_label)
        .draw()
        .map_err(draw_err)?;

    // Bars take 80% of a group, side by side.
    let bar_w = 0.8 / series.len() as f64;
    let bar_px = group_px * bar_w;
    let bars = || {
        series.iter().enumerate().flat_map(move |(s, (_, values))| {
            values
                .iter()
                .enumerate()
                .filter(|(_, v)| drawable(**v))
                .map(move |(g, &v)| {
                    let x0 = g as f64 + 0.1 + s as f64 * bar_w;
                    (s, x0, x0 + bar_w, v)
                })
        })
    };
    let inset = (bar_w * 0.06).min(0.01);
    for (s, x0, x1, v) in bars() {
        let rect = Rectangle::new([(x0 + inset, y.base), (x1 - inset, v)], colour(s).filled());
        chart.draw_series(std::iter::once(rect)).map_err(draw_err)?;
    }

    // Value labels, on every bar or on none (when one would be wider than its bar).
    let value_style = font(VALUE_SIZE);
    let mut value_labels = Vec::new();
    for (_, x0, x1, v) in bars() {
        let text = format_value(v);
        let text_w = area.estimate_text_size(&text, &value_style).map_err(draw_err)?.0;
        if f64::from(text_w) > bar_px + 4.0 {
            return Ok(());
        }
        value_labels.push(((x0 + x1) / 2.0, v, text));
    }
    for (x, v, text) in value_labels {
        let (anchor, dy) = if v >= y.base {
            (VPos::Bottom, -3)
        } else {
            (VPos::Top, 3)
        };
        let style = value_style.pos(Pos::new(HPos::Center, anchor));
        let label = EmptyElement::at((x, v)) + Text::new(text, (0, dy), style);
        chart.draw_series(std::iter::once(label)).map_err(draw_err)?;
    }
    Ok(())
}

/// The x axis of [`bar_chart`]: group `g` spans `g..g + 1`, with its tick (and label) at the
/// centre, `g + 0.5`.
struct GroupAxis {
    groups: usize,
}

impl Ranged for GroupAxis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = value / self.groups as f64;
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        (0..self.groups).map(|g| g as f64 + 0.5).collect()
    }

    fn range(&self) -> Range<f64> {
        0.0..self.groups as f64
    }
}

/// `text`, shortened with an ellipsis if it is wider than `max_px` in `style`.
fn fit_text(
    area: &DrawingArea<Canvas<'_>, Shift>,
    text: &str,
    style: &TextStyle,
    max_px: u32,
) -> Result<String, String> {
    let width = |t: &str| area.estimate_text_size(t, style).map(|s| s.0).map_err(draw_err);
    if width(text)? <= max_px {
        return Ok(text.to_string());
    }
    let chars: Vec<char> = text.chars().collect();
    // Longest prefix that fits with the ellipsis (binary search on the char count).
    let (mut lo, mut hi) = (0, chars.len());
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        let candidate: String = chars[..mid].iter().chain(['…'].iter()).collect();
        if width(&candidate)? <= max_px {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    Ok(chars[..lo].iter().chain(['…'].iter()).collect())
}

/// Minimum and maximum of finite values, `None` if there are none.
fn finite_min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.filter(|v| v.is_finite()).fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// `min..max` widened by `frac` of its span on each side (or by a unit-ish amount when the
/// span is zero); `None` if the result is not finite.
fn padded(min: f64, max: f64, frac: f64) -> Option<Range<f64>> {
    let span = max - min;
    let (lo, hi) = if span > 0.0 {
        (min - span * frac, max + span * frac)
    } else {
        let d = if min == 0.0 { 1.0 } else { min.abs() * 0.1 };
        (min - d, max + d)
    };
    (lo.is_finite() && hi.is_finite() && hi > lo).then_some(lo..hi)
}

/// A number with at most 3 significant digits: `12.3`, `0.00456`, `1230`, `1.23e7`, `0`
/// (scientific from 10 000 up and below 0.001).
fn format_value(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let exp = v.abs().log10().floor() as i32;
    // Rounding may carry into the next decade (999.7 → 1000).
    let exp = if (v.abs() / 10f64.powi(exp - 2)).round() >= 1000.0 {
        exp + 1
    } else {
        exp
    };
    if !(-3..4).contains(&exp) {
        let mantissa = v / 10f64.powi(exp);
        let m = trim_zeros(format!("{mantissa:.2}"));
        return format!("{m}e{exp}");
    }
    let decimals = (2 - exp).max(0) as usize;
    let rounded = if exp >= 2 {
        let unit = 10f64.powi(exp - 2);
        (v / unit).round() * unit
    } else {
        v
    };
    let s = format!("{rounded:.decimals$}");
    if decimals > 0 { trim_zeros(s) } else { s }
}

fn trim_zeros(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::format_value;

    #[test]
    fn three_significant_digits() {
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(12.345), "12.3");
        assert_eq!(format_value(1.0), "1");
        assert_eq!(format_value(0.5), "0.5");
        assert_eq!(format_value(0.004567), "0.00457");
        assert_eq!(format_value(123.4), "123");
        assert_eq!(format_value(1234.5), "1230");
        assert_eq!(format_value(9999.0), "1e4");
        assert_eq!(format_value(12345.0), "1.23e4");
        assert_eq!(format_value(999.7), "1000");
        assert_eq!(format_value(-2.5), "-2.5");
        assert_eq!(format_value(1.0e6), "1e6");
        assert_eq!(format_value(12_345_678.0), "1.23e7");
        assert_eq!(format_value(0.000123), "1.23e-4");
        assert_eq!(format_value(f64::NAN), "NaN");
    }
}
