//! Atlas packing: each key image is cut to the texels its polygon can sample (every triangle
//! of every level the run time draws, one texel round, in cells of two texels or more), and
//! the cut-outs are packed into a colour atlas and a half-resolution normal atlas with the
//! same layout so that they interlock (a bottom-left fill on a bitmap of cells, four ways
//! round), with the empty texels round each polygon filled by dilation so filtering never
//! bleeds in the background. Until 2026-12-02 each key image took its polygon's bounding rectangle: a
//! polygon covers 38-43 % of its rectangle on the default character (a limb seen slanting,
//! a bent arm), so most of the atlas held texels no polygon reads.

use polypostor_runtime::pack::MAX_ATLAS_SIDE;

/// A placed key image: where its cut-out, whose bounding box in the tile starts at `src`
/// (tile pixels), went in the atlas (`x`, `y`, `w`, `h`: the cut-out's bounding box there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasRect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
    /// Top-left of the cut-out's bounding box in the source tile.
    pub src_x: u32,
    pub src_y: u32,
    /// The image is stored transposed (its x runs down the atlas), when that packs tighter.
    pub transposed: bool,
    /// The image (transposed or not) is stored turned half round (both ways reversed).
    pub turned: bool,
}

impl AtlasRect {
    /// Where the tile point `q` (pixels) lies in the atlas (pixels).
    pub fn to_atlas(&self, q: [f32; 2]) -> [f32; 2] {
        let (dx, dy) = (q[0] - self.src_x as f32, q[1] - self.src_y as f32);
        let (a, b) = if self.transposed { (dy, dx) } else { (dx, dy) };
        let (a, b) = if self.turned {
            (self.w as f32 - a, self.h as f32 - b)
        } else {
            (a, b)
        };
        [self.x as f32 + a, self.y as f32 + b]
    }
}

/// A packed atlas: `color` is `width × height`, `normal` the same layout at half resolution
/// (`width / 2 × height / 2`; shading normals are smooth, so a quarter of the texels serves).
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    pub color: image::RgbaImage,
    pub normal: image::RgbaImage,
    pub rects: Vec<Option<AtlasRect>>,
    /// Per item, the colour texels of its cut-out (its kept cells; 0 for `None`).
    pub texels: Vec<u64>,
}

/// One key image to place: its colour and normal tiles (the same size) and every triangle,
/// in tile pixels, that any level of its polygon draws (the polygon's own, its coarse level's
/// and the crowd's thinned ones, [`polypostor_runtime::triangulate::thinned`]): the atlas
/// keeps the texels those can sample and no others.
pub struct AtlasItem<'a> {
    pub color: &'a image::RgbaImage,
    pub normal: &'a image::RgbaImage,
    pub triangles: Vec<[[f32; 2]; 3]>,
}

/// Padding texels round each polygon: one is all bilinear filtering reads past it. A cell is
/// kept where it lies within this of a triangle (a colour texel is read by points less than
/// a texel from its centre; a half-resolution normal texel, the cell's own two-texel square,
/// by points less than one colour texel outside it).
pub const PADDING: u32 = 1;

/// Both sides of every colour atlas are multiples of this, so that the colour atlas and the
/// half-resolution normal atlas are whole 4 × 4 blocks (BC7 compresses them block by block).
pub const SIDE_MULTIPLE: u32 = 8;

/// Side of the cells (texels, a power of two, at least 2 so a cell is whole texels of the
/// half-resolution normal atlas) the cut-outs are made of, for tiles of side `tile`: 2 up to
/// 256 texels, then growing with the tile, so a cut-out is at most about 128 cells across
/// and the packing's cost does not grow with the resolution.
pub fn cell_size(tile: u32) -> u32 {
    2 * tile.div_ceil(256).max(1).next_power_of_two()
}

/// Which way round a cut-out is placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Way {
    transposed: bool,
    turned: bool,
}

impl Way {
    const ALL: [Way; 4] = [
        Way {
            transposed: false,
            turned: false,
        },
        Way {
            transposed: true,
            turned: false,
        },
        Way {
            transposed: false,
            turned: true,
        },
        Way {
            transposed: true,
            turned: true,
        },
    ];
}

/// An item's cut-out: cells of side `cell` from the tile texel `origin`, `w × h` of them,
/// `keep[y * w + x]` where a triangle can sample the cell.
#[derive(Clone, Debug)]
struct Mask {
    origin: [u32; 2],
    w: u32,
    h: u32,
    keep: Vec<bool>,
}

impl Mask {
    fn of(item: &AtlasItem<'_>, cell: u32) -> Mask {
        let tile = [item.color.width(), item.color.height()];
        let pad = PADDING as f32;
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for t in &item.triangles {
            for q in t {
                for c in 0..2 {
                    lo[c] = lo[c].min(q[c]);
                    hi[c] = hi[c].max(q[c]);
                }
            }
        }
        if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
            (lo, hi) = ([0.0; 2], [1.0; 2]);
        }
        let cells = |c: usize| tile[c].div_ceil(cell).max(1);
        let first = |c: usize| (((lo[c] - pad) / cell as f32).floor().max(0.0) as u32).min(cells(c) - 1);
        let end = |c: usize| (((hi[c] + pad) / cell as f32).ceil().max(0.0) as u32).clamp(first(c) + 1, cells(c));
        let (cx0, cy0) = (first(0), first(1));
        let (w, h) = (end(0) - cx0, end(1) - cy0);
        let mut keep = vec![false; (w * h) as usize];
        for t in &item.triangles {
            let tlo = [0, 1].map(|c| t.iter().map(|q| q[c]).fold(f32::INFINITY, f32::min));
            let thi = [0, 1].map(|c| t.iter().map(|q| q[c]).fold(f32::NEG_INFINITY, f32::max));
            if !(tlo[0].is_finite() && tlo[1].is_finite() && thi[0].is_finite() && thi[1].is_finite()) {
                continue;
            }
            let range = |c: usize, c0: u32, n: u32| {
                let a = ((tlo[c] - pad) / cell as f32).floor() as i64 - c0 as i64;
                let b = ((thi[c] + pad) / cell as f32).ceil() as i64 - c0 as i64;
                a.clamp(0, n as i64) as u32..b.clamp(0, n as i64) as u32
            };
            for y in range(1, cy0, h) {
                for x in range(0, cx0, w) {
                    let b0 = [((cx0 + x) * cell) as f32 - pad, ((cy0 + y) * cell) as f32 - pad];
                    let b1 = [b0[0] + (cell + 2 * PADDING) as f32, b0[1] + (cell + 2 * PADDING) as f32];
                    if triangle_meets_box(t, b0, b1) {
                        keep[(y * w + x) as usize] = true;
                    }
                }
            }
        }
        if !keep.contains(&true) {
            keep.fill(true);
        }
        // Trimmed to its kept cells, so the placed box is the cut-out's own.
        let rows: Vec<u32> = (0..h).filter(|&y| (0..w).any(|x| keep[(y * w + x) as usize])).collect();
        let cols: Vec<u32> = (0..w).filter(|&x| (0..h).any(|y| keep[(y * w + x) as usize])).collect();
        let (y0, y1, x0, x1) = (rows[0], rows[rows.len() - 1] + 1, cols[0], cols[cols.len() - 1] + 1);
        let trimmed = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .map(|(x, y)| keep[(y * w + x) as usize])
            .collect();
        debug_assert!(
            x1 - x0 <= 128 && y1 - y0 <= 128,
            "cut-outs are at most 128 cells across"
        );
        Mask {
            origin: [(cx0 + x0) * cell, (cy0 + y0) * cell],
            w: x1 - x0,
            h: y1 - y0,
            keep: trimmed,
        }
    }

    /// Cell `(x, y)` of the cut-out placed the way `o` says ([`Way`]).
    fn at(&self, x: u32, y: u32, o: Way) -> bool {
        let (w, h) = self.size(o);
        let (x, y) = if o.turned { (w - 1 - x, h - 1 - y) } else { (x, y) };
        if o.transposed {
            self.keep[(x * self.w + y) as usize]
        } else {
            self.keep[(y * self.w + x) as usize]
        }
    }

    /// Side lengths in cells as placed.
    fn size(&self, o: Way) -> (u32, u32) {
        if o.transposed {
            (self.h, self.w)
        } else {
            (self.w, self.h)
        }
    }

    /// Its rows as placed, one bit a cell (bit `x` for column `x`; at most 128 cells across,
    /// [`cell_size`]).
    fn rows(&self, o: Way) -> Vec<u128> {
        let (w, h) = self.size(o);
        (0..h)
            .map(|y| {
                (0..w.min(128))
                    .filter(|&x| self.at(x, y, o))
                    .fold(0u128, |r, x| r | 1 << x)
            })
            .collect()
    }
}

/// The cells taken so far, one bit a cell, row by row (`width` cells a row).
struct Occupancy {
    width: u32,
    words: usize,
    rows: Vec<Vec<u64>>,
}

impl Occupancy {
    fn new(width: u32) -> Self {
        Self {
            width,
            words: width.div_ceil(64) as usize,
            rows: Vec::new(),
        }
    }

    /// Cells `x .. x + 128` of row `y` (free past the end).
    fn window(&self, x: u32, y: usize) -> u128 {
        let Some(row) = self.rows.get(y) else { return 0 };
        let (w, b) = ((x / 64) as usize, x % 64);
        let word = |i: usize| u128::from(row.get(i).copied().unwrap_or(0));
        let bits = word(w) | word(w + 1) << 64;
        let bits = bits >> b;
        if b == 0 { bits } else { bits | word(w + 2) << (128 - b) }
    }

    fn fits(&self, rows: &[u128], x: u32, y: usize) -> bool {
        rows.iter().enumerate().all(|(r, &m)| self.window(x, y + r) & m == 0)
    }

    fn take(&mut self, rows: &[u128], x: u32, y: usize) {
        while self.rows.len() < y + rows.len() {
            self.rows.push(vec![0; self.words]);
        }
        for (r, &m) in rows.iter().enumerate() {
            for bit in (0..128).filter(|&b| m >> b & 1 == 1) {
                let c = x + bit;
                self.rows[y + r][(c / 64) as usize] |= 1 << (c % 64);
            }
        }
    }

    /// The lowest, then leftmost, place where `rows` (`w` cells wide) fits.
    fn lowest(&self, rows: &[u128], w: u32) -> (u32, usize) {
        for y in 0.. {
            if y >= self.rows.len() {
                return (0, y);
            }
            for x in 0..=(self.width - w) {
                if self.fits(rows, x, y) {
                    return (x, y);
                }
            }
        }
        unreachable!("the rows past the last taken are free")
    }

    fn height(&self) -> u32 {
        let last = self.rows.iter().rposition(|r| r.iter().any(|&w| w != 0));
        last.map_or(0, |y| y as u32 + 1)
    }
}

/// Whether the closed triangle `t` and the box `[b0, b1]` share a point (separating axes: the
/// box's two and the triangle's three edge normals). A degenerate triangle meets the box
/// where its bounds do.
fn triangle_meets_box(t: &[[f32; 2]; 3], b0: [f32; 2], b1: [f32; 2]) -> bool {
    for c in 0..2 {
        let (lo, hi) = (
            t.iter().map(|q| q[c]).fold(f32::INFINITY, f32::min),
            t.iter().map(|q| q[c]).fold(f32::NEG_INFINITY, f32::max),
        );
        if hi < b0[c] || lo > b1[c] {
            return false;
        }
    }
    let corners = [[b0[0], b0[1]], [b1[0], b0[1]], [b0[0], b1[1]], [b1[0], b1[1]]];
    for i in 0..3 {
        let (a, b, o) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
        let n = [b[1] - a[1], a[0] - b[0]];
        let side = |q: [f32; 2]| n[0] * (q[0] - a[0]) + n[1] * (q[1] - a[1]);
        let s = side(o);
        if s == 0.0 {
            continue;
        }
        if corners.iter().all(|&q| side(q) * s.signum() < 0.0) {
            return false;
        }
    }
    true
}

/// Packs `items` (per key image, or `None`): each cut-out, in turn (three orders, largest
/// first, and about a dozen atlas widths tried, the smallest atlas kept), goes to the lowest,
/// then leftmost, place where its cells are all free, of the four ways round the one whose
/// top is lowest (a bottom-left fill on a bitmap of cells: a later cut-out may fill a hole
/// the earlier ones left).
pub fn pack_atlas(items: &[Option<AtlasItem<'_>>]) -> Atlas {
    let tile = items.iter().flatten().map(|it| it.color.width()).max().unwrap_or(2);
    let cell = cell_size(tile);
    let masks: Vec<Option<Mask>> = items
        .iter()
        .map(|it| it.as_ref().map(|it| Mask::of(it, cell)))
        .collect();
    let present: Vec<usize> = (0..masks.len()).filter(|&i| masks[i].is_some()).collect();
    let mask = |i: usize| masks[i].as_ref().expect("present");
    let shapes: Vec<[Vec<u128>; 4]> = masks
        .iter()
        .map(|m| m.as_ref().map_or(Default::default(), |m| Way::ALL.map(|o| m.rows(o))))
        .collect();
    let kept = |i: usize| mask(i).keep.iter().filter(|&&k| k).count() as u64;
    let area: u64 = present.iter().map(|&i| kept(i)).sum();
    // Orders to try: tallest, widest, most cells first.
    let orders: Vec<Vec<usize>> = [0usize, 1, 2]
        .iter()
        .map(|&k| {
            let mut o = present.clone();
            o.sort_by_key(|&i| {
                let m = mask(i);
                let key = [m.h.max(m.w) as u64, m.w as u64, kept(i)][k];
                (std::cmp::Reverse(key), i)
            });
            o
        })
        .collect();

    // Atlas widths in cells whose texels are whole multiples of SIDE_MULTIPLE.
    let unit = (SIDE_MULTIPLE / cell).max(1);
    let side = |cells: u32| (cells * cell).next_multiple_of(SIDE_MULTIPLE);
    let fill = |width: u32, order: &[usize]| -> (u32, Vec<Option<(u32, u32, Way)>>) {
        let mut taken = Occupancy::new(width);
        let mut placed: Vec<Option<(u32, u32, Way)>> = vec![None; masks.len()];
        for &i in order {
            // Of the four ways round: lowest top, then lowest bottom, then leftmost.
            let mut best: Option<(usize, usize, u32, usize)> = None;
            for (k, &o) in Way::ALL.iter().enumerate() {
                let (w, h) = mask(i).size(o);
                if w > width {
                    continue;
                }
                let (x, y) = taken.lowest(&shapes[i][k], w);
                if best.is_none_or(|(by, bh, bx, _)| (y + h as usize, y, x) < (by + bh, by, bx)) {
                    best = Some((y, h as usize, x, k));
                }
            }
            let (y, _, x, k) = best.expect("the width fits the narrowest side of every cut-out");
            taken.take(&shapes[i][k], x, y);
            placed[i] = Some((x, y as u32, Way::ALL[k]));
        }
        (side(taken.height()).max(SIDE_MULTIPLE), placed)
    };
    // The loader's bound on the atlas's texels for these keys.
    let most = polypostor_runtime::pack::atlas_area_bound(u64::from(tile), present.len() as u64);
    // At most ~12 widths and three orders, so large atlases stay cheap.
    let narrowest = present.iter().map(|&i| mask(i).w.min(mask(i).h)).max().unwrap_or(1);
    let lo = narrowest.next_multiple_of(unit).max(unit);
    let hi = (((area as f64).sqrt() * 2.0).ceil() as u32).max(lo);
    let step = ((hi - lo) / 12).max(unit).next_multiple_of(unit);
    // And whole multiples of the widest cut-out, where cut-outs of one size (whole tiles)
    // sit side by side with nothing over.
    let widest = present.iter().map(|&i| mask(i).w.max(mask(i).h)).max().unwrap_or(1);
    let mut widths: Vec<u32> = (lo..=hi).step_by(step as usize).collect();
    widths.extend(
        (1..=16)
            .map(|k| (k * widest).next_multiple_of(unit))
            .filter(|w| (lo..=hi).contains(w)),
    );
    widths.sort_unstable();
    widths.dedup();
    let (width, (height, placed)) = widths
        .into_iter()
        .flat_map(|w| orders.iter().map(move |o| (w, o)))
        .map(|(w, o)| (w, fill(w, o)))
        // Sides the loader accepts first, then the least area, then the squarest: on a tie
        // in area (whole tiles) the narrowest width stacked nine 2048² keys into an atlas
        // 18,432 texels tall, which the loader refuses.
        .min_by_key(|(w, (h, _))| {
            let (aw, ah) = (side(*w), *h);
            let area = aw as u64 * ah as u64;
            (aw.max(ah) > MAX_ATLAS_SIDE, area > most, area, aw.max(ah), *w)
        })
        .expect("at least one width");
    let width = side(width);
    let mut color = image::RgbaImage::new(width, height);
    let mut normal_full = image::RgbaImage::new(width, height);
    let mut rects = vec![None; items.len()];
    let mut texels = vec![0u64; items.len()];
    for i in present {
        let (Some((px, py, o)), Some(item), Some(m)) = (placed[i], items[i].as_ref(), masks[i].as_ref()) else {
            continue;
        };
        let (pw, ph) = m.size(o);
        let r = AtlasRect {
            x: px * cell,
            y: py * cell,
            w: pw * cell,
            h: ph * cell,
            src_x: m.origin[0],
            src_y: m.origin[1],
            transposed: o.transposed,
            turned: o.turned,
        };
        let (bw, bh) = (m.w * cell, m.h * cell);
        for (image, src) in [(&mut color, item.color), (&mut normal_full, item.normal)] {
            let mut block = image::RgbaImage::from_fn(bw, bh, |u, v| {
                let (sx, sy) = (r.src_x + u, r.src_y + v);
                if sx < src.width() && sy < src.height() {
                    *src.get_pixel(sx, sy)
                } else {
                    image::Rgba([0; 4])
                }
            });
            dilate(&mut block, PADDING + 2);
            for cy in 0..m.h {
                for cx in 0..m.w {
                    if !m.keep[(cy * m.w + cx) as usize] {
                        continue;
                    }
                    for v in cy * cell..(cy + 1) * cell {
                        for u in cx * cell..(cx + 1) * cell {
                            let (a, b) = if o.transposed { (v, u) } else { (u, v) };
                            let (a, b) = if o.turned { (r.w - 1 - a, r.h - 1 - b) } else { (a, b) };
                            let (ax, ay) = (r.x + a, r.y + b);
                            image.put_pixel(ax, ay, *block.get_pixel(u, v));
                        }
                    }
                }
            }
        }
        rects[i] = Some(r);
        texels[i] = kept(i) * u64::from(cell * cell);
    }
    Atlas {
        width,
        height,
        color,
        normal: half_normals(&normal_full),
        rects,
        texels,
    }
}

/// Box-filters an encoded normal image (`n × 0.5 + 0.5`, alpha = coverage) to half size,
/// renormalising the averaged normals.
pub fn half_normals(img: &image::RgbaImage) -> image::RgbaImage {
    let (w, h) = (img.width() / 2, img.height() / 2);
    image::RgbaImage::from_fn(w.max(1), h.max(1), |x, y| {
        let mut n = [0.0f32; 3];
        let mut a = 0u32;
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let p = img.get_pixel((2 * x + dx).min(img.width() - 1), (2 * y + dy).min(img.height() - 1));
            for c in 0..3 {
                n[c] += p[c] as f32 / 255.0 * 2.0 - 1.0;
            }
            a += p[3] as u32;
        }
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let enc = |v: f32| (((if len > 1e-6 { v / len } else { 0.0 }) * 0.5 + 0.5) * 255.0).round() as u8;
        image::Rgba([enc(n[0]), enc(n[1]), enc(n[2]), ((a + 2) / 4) as u8])
    })
}

/// Fills transparent texels from covered neighbours, `steps` rings deep (alpha stays 0, so
/// coverage is unchanged; only colour bleeds outwards).
pub fn dilate(img: &mut image::RgbaImage, steps: u32) {
    let (w, h) = img.dimensions();
    let mut filled: Vec<bool> = img.pixels().map(|p| p[3] > 0).collect();
    for _ in 0..steps {
        let snapshot = img.clone();
        let was = filled.clone();
        for y in 0..h {
            for x in 0..w {
                if was[(y * w + x) as usize] {
                    continue;
                }
                let mut sum = [0u32; 3];
                let mut n = 0;
                for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0
                        && ny >= 0
                        && (nx as u32) < w
                        && (ny as u32) < h
                        && was[(ny as u32 * w + nx as u32) as usize]
                    {
                        let p = snapshot.get_pixel(nx as u32, ny as u32);
                        for c in 0..3 {
                            sum[c] += p[c] as u32;
                        }
                        n += 1;
                    }
                }
                if n > 0 {
                    let p = img.get_pixel_mut(x, y);
                    for c in 0..3 {
                        p[c] = (sum[c] / n) as u8;
                    }
                    filled[(y * w + x) as usize] = true;
                }
            }
        }
    }
}

/// Fills every transparent texel with the colour of the nearest covered ones, ring by ring
/// as [`dilate`] does but until nothing is left (alpha stays 0). For images projected onto
/// geometry that may reach past their silhouette (NP3D's key images): there the surface shows
/// the nearest edge colour instead of the background's black. Linear in the texel count.
pub fn fill_background(img: &mut image::RgbaImage) {
    let (w, h) = img.dimensions();
    let (w, h) = (w as usize, h as usize);
    let mut filled: Vec<bool> = img.pixels().map(|p| p[3] > 0).collect();
    if !filled.iter().any(|&f| f) {
        return;
    }
    let neighbours = |i: usize| {
        let (x, y) = (i % w, i / w);
        [
            (x + 1 < w).then(|| i + 1),
            (x > 0).then(|| i - 1),
            (y + 1 < h).then(|| i + w),
            (y > 0).then(|| i - w),
        ]
    };
    let mut queued = filled.clone();
    let mut ring: Vec<usize> = Vec::new();
    for i in 0..w * h {
        if !filled[i] && neighbours(i).into_iter().flatten().any(|n| filled[n]) {
            queued[i] = true;
            ring.push(i);
        }
    }
    let mut colours: Vec<[u8; 3]> = Vec::new();
    while !ring.is_empty() {
        colours.clear();
        for &i in &ring {
            let mut sum = [0u32; 3];
            let mut n = 0;
            for j in neighbours(i).into_iter().flatten().filter(|&j| filled[j]) {
                let p = img.as_raw();
                for c in 0..3 {
                    sum[c] += p[4 * j + c] as u32;
                }
                n += 1;
            }
            colours.push(std::array::from_fn(|c| (sum[c] / n.max(1)) as u8));
        }
        let raw: &mut [u8] = &mut *img;
        for (&i, c) in ring.iter().zip(&colours) {
            raw[4 * i..4 * i + 3].copy_from_slice(c);
            filled[i] = true;
        }
        let mut next = Vec::new();
        for &i in &ring {
            for j in neighbours(i).into_iter().flatten() {
                if !queued[j] {
                    queued[j] = true;
                    next.push(j);
                }
            }
        }
        ring = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use polypostor_runtime::pack::atlas_area_bound;

    #[test]
    fn filling_the_background_matches_dilating_until_full() {
        // An independent answer: the ring-by-ring dilation repeated until no texel is left.
        let mut img = image::RgbaImage::new(23, 17);
        for (x, y) in [(3u32, 4u32), (4, 4), (15, 12), (20, 2)] {
            img.put_pixel(x, y, image::Rgba([(x * 11) as u8, (y * 13) as u8, 200, 255]));
        }
        let mut expected = img.clone();
        dilate(&mut expected, 64);
        let mut filled = img.clone();
        fill_background(&mut filled);
        assert_eq!(filled, expected);
        assert!(
            filled.pixels().filter(|p| p[3] == 0).all(|p| p[2] == 200),
            "every texel coloured"
        );
        // An empty image stays empty, a full one unchanged.
        let mut empty = image::RgbaImage::new(5, 5);
        fill_background(&mut empty);
        assert!(empty.pixels().all(|p| p.0 == [0; 4]));
    }

    /// Bilinear sample of `img` at `q` (pixels; texel centres at half-integers, zero outside).
    fn bilinear(img: &image::RgbaImage, q: [f32; 2]) -> [f32; 4] {
        let (fx, fy) = (q[0] - 0.5, q[1] - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let get = |x: i64, y: i64| -> [f32; 4] {
            if x < 0 || y < 0 || x >= img.width() as i64 || y >= img.height() as i64 {
                [0.0; 4]
            } else {
                img.get_pixel(x as u32, y as u32).0.map(f32::from)
            }
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (a, b, c, d) = (get(x0, y0), get(x0 + 1, y0), get(x0, y0 + 1), get(x0 + 1, y0 + 1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            top + (bottom - top) * ty
        })
    }

    /// Tiles of random colours (every texel covered) and polygons that slant, bend and hug
    /// the tile's edges, as the key images of a view.
    fn tiles_and_triangles(size: u32, count: usize, seed: u64) -> (Vec<image::RgbaImage>, Vec<Vec<[[f32; 2]; 3]>>) {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as f32 / (1u64 << 31) as f32
        };
        let s = size as f32;
        let mut tiles = Vec::new();
        let mut tris = Vec::new();
        for k in 0..count {
            let bytes: Vec<u8> = (0..size * size * 4).map(|_| (next() * 255.0) as u8 | 1).collect();
            tiles.push(image::RgbaImage::from_raw(size, size, bytes).expect("sized"));
            // A bent strip (two slanting quads) of random width, or a triangle at a corner.
            let t: Vec<[[f32; 2]; 3]> = if k % 3 == 2 {
                vec![[[0.0, 0.0], [s * next(), 0.3], [0.2, s * next()]]]
            } else {
                let (a, b, c) = (
                    [s * next(), s * next()],
                    [s * next(), s * next()],
                    [s * next(), s * next()],
                );
                let wd = 1.0 + 6.0 * next();
                let quad = |p: [f32; 2], q: [f32; 2]| {
                    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
                    let l = (dx * dx + dy * dy).sqrt().max(1e-3);
                    let n = [-dy / l * wd, dx / l * wd];
                    let (p2, q2) = ([p[0] + n[0], p[1] + n[1]], [q[0] + n[0], q[1] + n[1]]);
                    [[p, q, q2], [p, q2, p2]]
                };
                quad(a, b).into_iter().chain(quad(b, c)).collect()
            };
            tris.push(t);
        }
        (tiles, tris)
    }

    /// `count` key images of `tile`, each polygon covering the whole tile.
    fn whole_tile_items(tile: &image::RgbaImage, count: usize) -> Vec<Option<AtlasItem<'_>>> {
        let s = tile.width() as f32;
        (0..count)
            .map(|_| {
                Some(AtlasItem {
                    color: tile,
                    normal: tile,
                    triangles: vec![[[0.0, 0.0], [s, 0.0], [s, s]], [[0.0, 0.0], [s, s], [0.0, s]]],
                })
            })
            .collect()
    }

    /// A key image whose polygon covers its whole tile (a prop filling its view) packs within
    /// the loader's bound at every kind of tile size: sides not a multiple of the atlas's
    /// 8-texel blocks, and sides just past a multiple of a larger cell (1032 = 64·16 + 8,
    /// 16-texel cells), where a cut-out rounded up outgrows the tile and its padding. Before
    /// the bound counted the rounding, these packs were refused as damaged.
    #[test]
    fn a_key_image_filling_its_tile_packs_within_the_loader_s_bound() {
        for size in [16u32, 37, 100, 257, 1030, 1032, 2048] {
            let tile = image::RgbaImage::from_pixel(size, size, image::Rgba([90, 140, 200, 255]));
            for count in [1usize, 2, 3] {
                let a = pack_atlas(&whole_tile_items(&tile, count));
                let area = u64::from(a.width) * u64::from(a.height);
                assert!(
                    area <= atlas_area_bound(u64::from(size), count as u64),
                    "{count} × {size}²: a {}×{} atlas",
                    a.width,
                    a.height
                );
                // The bound is not vacuous: the atlas holds the cut-outs.
                assert!(area >= count as u64 * u64::from(size) * u64::from(size));
            }
        }
    }

    /// Whole 2048² key images tie in area at every width that is a whole number of tiles;
    /// the packer took the narrowest, one tile wide and nine tall (18,432 texels: a pack the
    /// loader refuses). It now takes sides the loader accepts, and the squarest on a tie.
    #[test]
    fn whole_tile_keys_pack_square_within_the_loader_s_side() {
        let size = 2048u32;
        let tile = image::RgbaImage::from_pixel(size, size, image::Rgba([90, 140, 200, 255]));
        for count in [4usize, 9, 11] {
            let a = pack_atlas(&whole_tile_items(&tile, count));
            assert!(
                a.width.max(a.height) <= MAX_ATLAS_SIDE,
                "{count} × {size}²: a {}×{} atlas",
                a.width,
                a.height
            );
            // Square within a tile and its padding: the side a square grid of tiles needs.
            let per_side = (count as f64).sqrt().ceil() as u32;
            assert!(
                a.width.max(a.height) <= per_side * (size + 64),
                "{count}: {}×{}",
                a.width,
                a.height
            );
            let placed = a.rects.iter().flatten().count();
            assert_eq!(placed, count);
            let area = u64::from(a.width) * u64::from(a.height);
            assert!(
                area <= atlas_area_bound(u64::from(size), count as u64),
                "{count}: {}×{}",
                a.width,
                a.height
            );
        }
    }

    #[test]
    fn every_point_a_polygon_draws_samples_its_own_texels() {
        // The independent answer: sampling the source tile (colour) and its half-resolution
        // normals at the point itself. Any overlap of two cut-outs, any texel of the
        // footprint left out, or a wrong transposition changes the sample.
        let mut ways = std::collections::HashSet::new();
        for (size, count, seed) in [
            (64u32, 9usize, 1u64),
            (128, 14, 2),
            (600, 5, 3),
            (37, 6, 4),
            (96, 16, 5),
        ] {
            let (tiles, tris) = tiles_and_triangles(size, count, seed);
            let normals: Vec<image::RgbaImage> = tiles
                .iter()
                .map(|t| {
                    let mut n = t.clone();
                    n.pixels_mut().for_each(|p| p[3] = 255);
                    n
                })
                .collect();
            let items: Vec<Option<AtlasItem<'_>>> = (0..count)
                .map(|k| {
                    (k != 4).then(|| AtlasItem {
                        color: &tiles[k],
                        normal: &normals[k],
                        triangles: tris[k].clone(),
                    })
                })
                .collect();
            let a = pack_atlas(&items);
            assert_eq!(a.width % SIDE_MULTIPLE, 0);
            assert_eq!(a.height % SIDE_MULTIPLE, 0);
            assert_eq!(a.normal.dimensions(), (a.width / 2, a.height / 2));
            assert!(a.rects[4].is_none());
            // The loader's bound on an atlas (`pack::load`).
            let present = (count - 1) as u64;
            assert!(u64::from(a.width) * u64::from(a.height) <= atlas_area_bound(u64::from(size), present));
            let mut samples = 0;
            for k in (0..count).filter(|&k| k != 4) {
                let r = a.rects[k].expect("placed");
                ways.insert((r.transposed, r.turned));
                assert!(r.x + r.w <= a.width && r.y + r.h <= a.height, "{r:?}");
                let half_tile = half_normals(&normals[k]);
                for t in &tris[k] {
                    for i in 0..6 {
                        for j in 0..6 - i {
                            let (wa, wb) = (i as f32 / 5.0, j as f32 / 5.0);
                            let q =
                                std::array::from_fn(|c| t[0][c] + wa * (t[1][c] - t[0][c]) + wb * (t[2][c] - t[0][c]));
                            // Inside the tile (the run time never samples past its key image).
                            if !(q[0] >= 0.5 && q[1] >= 0.5 && q[0] <= size as f32 - 0.5 && q[1] <= size as f32 - 0.5) {
                                continue;
                            }
                            if (size % 2 == 1) && (q[0] > size as f32 - 2.0 || q[1] > size as f32 - 2.0) {
                                continue;
                            }
                            let p = r.to_atlas(q);
                            let (want, got) = (bilinear(&tiles[k], q), bilinear(&a.color, p));
                            assert!(
                                want.iter().zip(&got).all(|(x, y)| (x - y).abs() < 0.01),
                                "item {k} at {q:?}: {want:?} vs {got:?} ({r:?})"
                            );
                            samples += 1;
                            // A normal sampled within two texels of the tile's edge reads past
                            // the tile (there is nothing of the part there to keep).
                            let edge = 2.0;
                            if q.iter().any(|&c| c < edge || c > size as f32 - edge) {
                                continue;
                            }
                            let (wn, gn) = (
                                bilinear(&half_tile, [q[0] / 2.0, q[1] / 2.0]),
                                bilinear(&a.normal, [p[0] / 2.0, p[1] / 2.0]),
                            );
                            assert!(
                                wn.iter().zip(&gn).all(|(x, y)| (x - y).abs() < 0.01),
                                "normal of item {k} at {q:?}: {wn:?} vs {gn:?}"
                            );
                        }
                    }
                }
            }
            assert!(samples > 100, "{samples} samples");
        }
        assert_eq!(ways.len(), 4, "every way round was tried and checked: {ways:?}");
    }

    #[test]
    fn slanting_strips_take_less_than_their_rectangles() {
        // Diagonal limbs: a bounding-rectangle packing takes at least the rectangles' area.
        let (tiles, _) = tiles_and_triangles(128, 12, 7);
        let strip = |k: usize| {
            let (a, b) = ([4.0 + k as f32, 6.0], [100.0 - 3.0 * k as f32, 110.0]);
            let n = [-0.7071 * 5.0, 0.7071 * 5.0];
            vec![
                [a, b, [b[0] + n[0], b[1] + n[1]]],
                [a, [b[0] + n[0], b[1] + n[1]], [a[0] + n[0], a[1] + n[1]]],
            ]
        };
        let items: Vec<Option<AtlasItem<'_>>> = (0..12)
            .map(|k| {
                Some(AtlasItem {
                    color: &tiles[k],
                    normal: &tiles[k],
                    triangles: strip(k),
                })
            })
            .collect();
        let rect_area: f32 = (0..12)
            .map(|k| {
                let t = strip(k);
                let xs = t.iter().flatten().map(|q| q[0]);
                let ys = t.iter().flatten().map(|q| q[1]);
                let w = xs.clone().fold(f32::MIN, f32::max) - xs.fold(f32::MAX, f32::min) + 2.0;
                let h = ys.clone().fold(f32::MIN, f32::max) - ys.fold(f32::MAX, f32::min) + 2.0;
                w * h
            })
            .sum();
        let a = pack_atlas(&items);
        let atlas = (a.width * a.height) as f32;
        assert!(
            atlas < 0.6 * rect_area,
            "atlas {atlas} texels against {rect_area} in rectangles"
        );
    }

    #[test]
    fn a_triangle_meets_a_box_as_brute_force_sampling_says() {
        // Dense sampling of the triangle against the box (closed), away from the boundary's
        // rounding: where the samples say they meet by a margin, so must the test; where
        // every sample is clear of the box by a margin, it must not.
        let mut state = 9u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as f32 / (1u64 << 31) as f32 * 20.0
        };
        for _ in 0..3000 {
            let t = [[next(), next()], [next(), next()], [next(), next()]];
            let b0 = [next(), next()];
            let b1 = [b0[0] + next() / 4.0, b0[1] + next() / 4.0];
            let mut inside_by = f32::NEG_INFINITY;
            for i in 0..=40 {
                for j in 0..=40 - i {
                    let (u, v) = (i as f32 / 40.0, j as f32 / 40.0);
                    let q: [f32; 2] =
                        std::array::from_fn(|c| t[0][c] + u * (t[1][c] - t[0][c]) + v * (t[2][c] - t[0][c]));
                    let d = (0..2)
                        .map(|c| (q[c] - b0[c]).min(b1[c] - q[c]))
                        .fold(f32::INFINITY, f32::min);
                    inside_by = inside_by.max(d);
                }
            }
            if inside_by > 0.01 {
                assert!(triangle_meets_box(&t, b0, b1), "{t:?} {b0:?} {b1:?}");
            }
            // Clear by more than the sampling's spacing: the triangle's points all outside.
            let spacing = t
                .iter()
                .flat_map(|p| t.iter().map(move |q| (p[0] - q[0]).hypot(p[1] - q[1])))
                .fold(0.0, f32::max)
                / 40.0;
            if inside_by < -spacing - 0.01 {
                assert!(!triangle_meets_box(&t, b0, b1), "{t:?} {b0:?} {b1:?}");
            }
        }
    }

    #[test]
    fn half_normals_average_and_renormalise() {
        // Left column points +x, right column +y: the average is the unit diagonal.
        let img = image::RgbaImage::from_fn(2, 2, |x, _| {
            if x == 0 {
                image::Rgba([255, 128, 128, 255])
            } else {
                image::Rgba([128, 255, 128, 0])
            }
        });
        let h = half_normals(&img);
        assert_eq!(h.dimensions(), (1, 1));
        let p = h.get_pixel(0, 0);
        let d = |v: u8| v as f32 / 255.0 * 2.0 - 1.0;
        let (x, y, z) = (d(p[0]), d(p[1]), d(p[2]));
        assert!((x * x + y * y + z * z - 1.0).abs() < 0.03, "{p:?}");
        assert!((x - y).abs() < 0.02 && x > 0.6, "{p:?}");
        assert_eq!(p[3], 128);
    }

    #[test]
    fn dilation_fills_colour_but_not_coverage() {
        let mut img = image::RgbaImage::new(8, 8);
        img.put_pixel(4, 4, image::Rgba([200, 100, 50, 255]));
        dilate(&mut img, 2);
        assert_eq!(*img.get_pixel(5, 4), image::Rgba([200, 100, 50, 0]));
        assert_eq!(*img.get_pixel(6, 4), image::Rgba([200, 100, 50, 0]));
        assert_eq!(img.get_pixel(7, 4)[0], 0);
    }
}
