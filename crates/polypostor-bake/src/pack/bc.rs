//! BC7 encoding of the pack's textures (Intel's ISPC texture compressor, through
//! `intel_tex_2`); the KTX2 container and the decoder are the runtime crate's
//! ([`polypostor_runtime::texture`]).

use polypostor_runtime::texture::{BcFormat, CompressedImage, bc7_bytes, write_ktx2};

/// `img` as BC7 blocks in `format` (`None` when a side is not a multiple of 4); normals
/// ([`BcFormat::Bc7Unorm`]) are encoded opaque (alpha 255). Uses the
/// compressor's "fast" alpha settings (about 0.01 dB of PSNR behind its "basic" ones on our
/// atlases at a third of the time; see the README).
pub fn encode_bc7(img: &image::RgbaImage, format: BcFormat) -> Option<CompressedImage> {
    let (w, h) = img.dimensions();
    bc7_bytes(w, h)?;
    if w == 0 || h == 0 {
        return None;
    }
    // Normals: the renderer reads only their RGB, so they are stored opaque and every bit of
    // each block goes to the normal (with the alpha kept, BC7 spent its bits on the surface's
    // edge and the normals came out 15 dB worse).
    let opaque;
    let (data, settings) = match format {
        BcFormat::Bc7Srgb => (img, intel_tex_2::bc7::alpha_fast_settings()),
        BcFormat::Bc7Unorm => {
            let mut o = img.clone();
            o.pixels_mut().for_each(|p| p[3] = 255);
            opaque = o;
            (&opaque, intel_tex_2::bc7::opaque_fast_settings())
        }
    };
    let blocks = compress_sparse(&settings, data);
    Some(CompressedImage {
        width: w,
        height: h,
        format,
        blocks,
    })
}

/// Blocks of one colour (the empty space round the characters on impostor sheets and
/// atlases: most of their blocks) take one encoding per colour; the other blocks are packed
/// into a strip, encoded together and put back. BC7 encodes each block on its own, so the
/// bytes are those of encoding the whole image (tested).
fn compress_sparse(settings: &intel_tex_2::bc7::EncodeSettings, img: &image::RgbaImage) -> Vec<u8> {
    let (w, h) = img.dimensions();
    let (bw, bh) = ((w / 4) as usize, (h / 4) as usize);
    let raw = img.as_raw();
    let stride = 4 * w as usize;
    let whole = || {
        let surface = intel_tex_2::RgbaSurface {
            data: raw,
            width: w,
            height: h,
            stride: stride as u32,
        };
        intel_tex_2::bc7::compress_blocks(settings, &surface)
    };
    // Per block: its colour when all 16 texels share it.
    let uniform: Vec<Option<[u8; 4]>> = (0..bw * bh)
        .map(|b| {
            let (x, y) = (4 * (b % bw), 4 * (b / bw));
            let first: [u8; 4] = raw[y * stride + 4 * x..][..4].try_into().expect("4 bytes");
            (0..4)
                .all(|r| {
                    raw[(y + r) * stride + 4 * x..][..16]
                        .chunks_exact(4)
                        .all(|p| p == first)
                })
                .then_some(first)
        })
        .collect();
    let varied: Vec<usize> = (0..bw * bh).filter(|&b| uniform[b].is_none()).collect();
    if varied.len() * 8 > bw * bh * 7 {
        return whole();
    }
    let encode = |pixels: &[u8], width: usize, height: usize| {
        let surface = intel_tex_2::RgbaSurface {
            data: pixels,
            width: width as u32,
            height: height as u32,
            stride: 4 * width as u32,
        };
        intel_tex_2::bc7::compress_blocks(settings, &surface)
    };
    let mut out = vec![0u8; 16 * bw * bh];
    let mut colours: std::collections::HashMap<[u8; 4], [u8; 16]> = std::collections::HashMap::new();
    for (b, u) in uniform.iter().enumerate() {
        if let Some(c) = u {
            let block = *colours.entry(*c).or_insert_with(|| {
                let texels: Vec<u8> = c.repeat(16);
                encode(&texels, 4, 4).try_into().expect("one block")
            });
            out[16 * b..16 * b + 16].copy_from_slice(&block);
        }
    }
    // The other blocks side by side in rows of up to 256, 4 texels tall.
    const ROW: usize = 256;
    for chunk in varied.chunks(ROW * 64) {
        let per_row = chunk.len().min(ROW);
        let rows = chunk.len().div_ceil(per_row);
        let width = 4 * per_row;
        let mut strip = vec![0u8; 4 * width * 4 * rows];
        for (i, &b) in chunk.iter().enumerate() {
            let (sx, sy) = (4 * (b % bw), 4 * (b / bw));
            let (dx, dy) = (4 * (i % per_row), 4 * (i / per_row));
            for r in 0..4 {
                strip[((dy + r) * width + dx) * 4..][..16].copy_from_slice(&raw[(sy + r) * stride + 4 * sx..][..16]);
            }
        }
        let encoded = encode(&strip, width, 4 * rows);
        for (i, &b) in chunk.iter().enumerate() {
            out[16 * b..16 * b + 16].copy_from_slice(&encoded[16 * i..16 * i + 16]);
        }
    }
    out
}

/// The KTX2 file of `img` in BC7 (`None` when a side is not a multiple of 4).
pub fn encode_ktx2(img: &image::RgbaImage, format: BcFormat) -> Option<Vec<u8>> {
    encode_bc7(img, format).map(|c| write_ktx2(&c))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole image through the encoder in one surface: what `compress_sparse` must match.
    fn whole(settings: &intel_tex_2::bc7::EncodeSettings, img: &image::RgbaImage) -> Vec<u8> {
        let surface = intel_tex_2::RgbaSurface {
            data: img.as_raw(),
            width: img.width(),
            height: img.height(),
            stride: 4 * img.width(),
        };
        intel_tex_2::bc7::compress_blocks(settings, &surface)
    }

    /// An impostor-like sheet: empty space, flat patches of a few colours, and noisy figures
    /// whose edges cut blocks at every offset.
    fn sheet(w: u32, h: u32, seed: u32) -> image::RgbaImage {
        let mut state = seed.wrapping_mul(2654435761).max(1);
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let mut img = image::RgbaImage::new(w, h);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let (cx, cy) = (x as i64 - w as i64 / 3, y as i64 - h as i64 / 2);
            if cx * cx + cy * cy < (w as i64 / 5).pow(2) {
                let v = rnd();
                *p = image::Rgba([v as u8, (v >> 8) as u8, (v >> 16) as u8, 128 + (v >> 25) as u8]);
            } else if x > 3 * w / 4 && y < h / 3 {
                *p = image::Rgba([200, 30, 40, 255]);
            } else if x + 1 == y {
                *p = image::Rgba([255, 255, 255, 255]);
            }
        }
        img
    }

    #[test]
    fn uniform_blocks_encoded_once_give_the_whole_images_bytes() {
        for (w, h, seed) in [(64, 64, 1), (260, 36, 2), (1028, 516, 3), (4, 4, 4), (8, 1200, 5)] {
            let img = sheet(w, h, seed);
            for format in [BcFormat::Bc7Srgb, BcFormat::Bc7Unorm] {
                let got = encode_bc7(&img, format).expect("multiple of 4");
                let settings = match format {
                    BcFormat::Bc7Srgb => intel_tex_2::bc7::alpha_fast_settings(),
                    BcFormat::Bc7Unorm => intel_tex_2::bc7::opaque_fast_settings(),
                };
                let mut reference = img.clone();
                if format == BcFormat::Bc7Unorm {
                    reference.pixels_mut().for_each(|p| p[3] = 255);
                }
                assert!(got.blocks == whole(&settings, &reference), "{w}×{h} {format:?}");
            }
        }
        // All one colour, and no colour repeated: both paths.
        let flat = image::RgbaImage::from_pixel(32, 32, image::Rgba([1, 2, 3, 4]));
        let s = intel_tex_2::bc7::alpha_fast_settings();
        assert_eq!(compress_sparse(&s, &flat), whole(&s, &flat));
        let mut noisy = sheet(32, 32, 9);
        noisy.pixels_mut().enumerate().for_each(|(i, p)| p[0] = i as u8);
        assert_eq!(compress_sparse(&s, &noisy), whole(&s, &noisy));
    }
}
