//! Block-compressed textures in KTX2 containers: BC7 images (one 16-byte block per 4 × 4
//! texels, a quarter of RGBA8's bytes), written by the studio's bake and read here.
//!
//! A file is a KTX 2.0 container (Khronos, "KTX File Format Specification 2.0") holding one
//! 2D image, one mip level, no supercompression: `vkFormat` 146 (`VK_FORMAT_BC7_SRGB_BLOCK`,
//! colour) or 145 (`VK_FORMAT_BC7_UNORM_BLOCK`, normals and other data), a basic data format
//! descriptor (colour model BC7, BT.709 primaries, sRGB or linear transfer), no key/value data.
//! [`read_ktx2`] checks every header field and offset against the file's length and the size
//! the caller expects before it copies a byte; [`CompressedImage::decode`] expands the blocks
//! to RGBA8 for adapters without BC support and for CPU work.

/// The block-compressed formats a pack uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BcFormat {
    /// BC7 with sRGB-encoded colour (colour atlases and impostor colour sheets).
    Bc7Srgb,
    /// BC7 with linear values (normal atlases and sheets).
    Bc7Unorm,
}

impl BcFormat {
    /// The Vulkan format number KTX2 files name it by.
    pub fn vk_format(self) -> u32 {
        match self {
            BcFormat::Bc7Srgb => 146,
            BcFormat::Bc7Unorm => 145,
        }
    }

    /// The wgpu texture format it uploads as.
    pub fn wgpu_format(self) -> wgpu::TextureFormat {
        match self {
            BcFormat::Bc7Srgb => wgpu::TextureFormat::Bc7RgbaUnormSrgb,
            BcFormat::Bc7Unorm => wgpu::TextureFormat::Bc7RgbaUnorm,
        }
    }

    /// The uncompressed wgpu format with the same meaning (what decoded images upload as).
    pub fn rgba8_format(self) -> wgpu::TextureFormat {
        match self {
            BcFormat::Bc7Srgb => wgpu::TextureFormat::Rgba8UnormSrgb,
            BcFormat::Bc7Unorm => wgpu::TextureFormat::Rgba8Unorm,
        }
    }
}

/// Bytes of one BC7 block (4 × 4 texels).
pub const BLOCK_BYTES: usize = 16;

/// A block-compressed image: `width × height` texels (both multiples of 4), blocks row by
/// row, left to right.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompressedImage {
    /// Width in texels (a multiple of 4).
    pub width: u32,
    /// Height in texels (a multiple of 4).
    pub height: u32,
    /// How the blocks are encoded.
    pub format: BcFormat,
    /// `(width / 4) · (height / 4)` blocks of [`BLOCK_BYTES`] each.
    pub blocks: Vec<u8>,
}

/// Bytes of the blocks of a `width × height` BC7 image (`None` when a side is not a
/// multiple of 4 or the size overflows).
pub fn bc7_bytes(width: u32, height: u32) -> Option<usize> {
    if !width.is_multiple_of(4) || !height.is_multiple_of(4) {
        return None;
    }
    (width as usize / 4)
        .checked_mul(height as usize / 4)?
        .checked_mul(BLOCK_BYTES)
}

impl CompressedImage {
    /// Blocks per row (each [`BLOCK_BYTES`]).
    pub fn blocks_per_row(&self) -> u32 {
        self.width / 4
    }

    /// The `w × h` texels at `(x, y)` as blocks of their own (`None` unless all four are
    /// multiples of 4 and the rectangle lies inside the image).
    pub fn crop(&self, x: u32, y: u32, w: u32, h: u32) -> Option<CompressedImage> {
        let aligned = [x, y, w, h].iter().all(|v| v % 4 == 0);
        if !aligned || x.checked_add(w)? > self.width || y.checked_add(h)? > self.height {
            return None;
        }
        let (row, bx, bw) = (self.blocks_per_row() as usize, (x / 4) as usize, (w / 4) as usize);
        let mut blocks = Vec::with_capacity(bw * (h / 4) as usize * BLOCK_BYTES);
        for by in (y / 4) as usize..((y + h) / 4) as usize {
            let start = (by * row + bx) * BLOCK_BYTES;
            blocks.extend_from_slice(self.blocks.get(start..start + bw * BLOCK_BYTES)?);
        }
        Some(CompressedImage {
            width: w,
            height: h,
            format: self.format,
            blocks,
        })
    }

    /// The image expanded to RGBA8 (the values a GPU's BC7 decoder gives: BC7 decoding is
    /// exact).
    pub fn decode(&self) -> image::RgbaImage {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut out = vec![0u8; w * h * 4];
        let pitch = w * 4;
        for (b, block) in self.blocks.chunks_exact(BLOCK_BYTES).enumerate() {
            let (bx, by) = (b % (w / 4), b / (w / 4));
            let start = by * 4 * pitch + bx * 16;
            bcdec_rs::bc7(block, &mut out[start..], pitch);
        }
        image::RgbaImage::from_raw(self.width, self.height, out).expect("the buffer holds width × height texels")
    }
}

const IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];
/// Header (identifier, nine u32 fields, the index) and one level's index entry.
const HEADER_BYTES: usize = 12 + 9 * 4 + 4 * 4 + 2 * 8;
const LEVEL_INDEX_BYTES: usize = 3 * 8;
/// The data format descriptor: its total size, a 24-byte basic block and one sample.
const DFD_BYTES: usize = 4 + 24 + 16;
/// `KHR_DF_MODEL_BC7`.
const DF_MODEL_BC7: u32 = 134;
/// `KHR_DF_PRIMARIES_BT709`.
const DF_PRIMARIES_BT709: u32 = 1;
/// `KHR_DF_TRANSFER_LINEAR` and `KHR_DF_TRANSFER_SRGB`.
const DF_TRANSFER_LINEAR: u32 = 1;
const DF_TRANSFER_SRGB: u32 = 2;

/// The KTX2 file of `img`.
pub fn write_ktx2(img: &CompressedImage) -> Vec<u8> {
    let dfd_offset = HEADER_BYTES + LEVEL_INDEX_BYTES;
    // Level data aligned to 16 bytes (the least common multiple of the block size and 4).
    let data_offset = (dfd_offset + DFD_BYTES).next_multiple_of(16);
    let mut f = Vec::with_capacity(data_offset + img.blocks.len());
    let u32le = |f: &mut Vec<u8>, v: u32| f.extend_from_slice(&v.to_le_bytes());
    let u64le = |f: &mut Vec<u8>, v: u64| f.extend_from_slice(&v.to_le_bytes());
    f.extend_from_slice(&IDENTIFIER);
    u32le(&mut f, img.format.vk_format());
    u32le(&mut f, 1); // typeSize: 1 for block-compressed formats
    u32le(&mut f, img.width);
    u32le(&mut f, img.height);
    u32le(&mut f, 0); // pixelDepth: a 2D image
    u32le(&mut f, 0); // layerCount: not an array
    u32le(&mut f, 1); // faceCount
    u32le(&mut f, 1); // levelCount
    u32le(&mut f, 0); // supercompressionScheme: none
    u32le(&mut f, dfd_offset as u32);
    u32le(&mut f, DFD_BYTES as u32);
    u32le(&mut f, 0); // kvdByteOffset
    u32le(&mut f, 0); // kvdByteLength
    u64le(&mut f, 0); // sgdByteOffset
    u64le(&mut f, 0); // sgdByteLength
    u64le(&mut f, data_offset as u64);
    u64le(&mut f, img.blocks.len() as u64);
    u64le(&mut f, img.blocks.len() as u64);
    // Data format descriptor: total size, then the basic descriptor block.
    u32le(&mut f, DFD_BYTES as u32);
    u32le(&mut f, 0); // vendorId 0 (Khronos), descriptorType 0 (basic)
    u32le(&mut f, 2 | ((24 + 16) << 16)); // versionNumber 2, descriptorBlockSize
    let transfer = match img.format {
        BcFormat::Bc7Srgb => DF_TRANSFER_SRGB,
        BcFormat::Bc7Unorm => DF_TRANSFER_LINEAR,
    };
    u32le(&mut f, DF_MODEL_BC7 | (DF_PRIMARIES_BT709 << 8) | (transfer << 16)); // flags 0: straight alpha
    u32le(&mut f, 3 | (3 << 8)); // texel block 4 × 4 × 1 × 1, each stored minus one
    u32le(&mut f, BLOCK_BYTES as u32); // bytesPlane0
    u32le(&mut f, 0); // bytesPlane4..7
    // One sample: bits 0..127, channel 0 (BC7 colour), position 0, full range.
    u32le(&mut f, 127 << 16);
    u32le(&mut f, 0);
    u32le(&mut f, 0);
    u32le(&mut f, u32::MAX);
    f.resize(data_offset, 0);
    f.extend_from_slice(&img.blocks);
    f
}

/// Reads a KTX2 file written by [`write_ktx2`] (or any single-level 2D BC7 KTX2 without
/// supercompression) that must hold a `size` image in `format`; `name` is the file's name in
/// errors. Every field is checked before the blocks are copied.
pub fn read_ktx2(name: &str, bytes: &[u8], size: [u32; 2], format: BcFormat) -> Result<CompressedImage, String> {
    let bad = |what: String| format!("{name}: {what}");
    if bytes.len() < HEADER_BYTES + LEVEL_INDEX_BYTES || bytes[..12] != IDENTIFIER {
        return Err(bad("not a KTX2 file".into()));
    }
    let u32at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let vk = u32at(12);
    if vk != format.vk_format() {
        return Err(bad(format!(
            "Vulkan format {vk}, expected {} ({format:?})",
            format.vk_format()
        )));
    }
    let [w, h] = [u32at(20), u32at(24)];
    if [w, h] != size {
        return Err(bad(format!(
            "{w}×{h} texels, the manifest says {}×{}",
            size[0], size[1]
        )));
    }
    let (depth, layers, faces, levels, scheme) = (u32at(28), u32at(32), u32at(36), u32at(40), u32at(44));
    if depth != 0 || layers > 1 || faces != 1 || levels > 1 || scheme != 0 {
        return Err(bad(format!(
            "depth {depth}, {layers} layers, {faces} faces, {levels} levels, supercompression {scheme}: \
             a pack's textures are single 2D images without supercompression"
        )));
    }
    let expected = bc7_bytes(w, h).ok_or_else(|| bad(format!("{w}×{h} is not a whole number of 4 × 4 blocks")))?;
    let (offset, length) = (u64at(80), u64at(88));
    let end = offset.checked_add(length);
    if length != expected as u64 || end.is_none_or(|e| e > bytes.len() as u64) || offset < (HEADER_BYTES as u64) {
        return Err(bad(format!(
            "level data at {offset}, {length} bytes: expected {expected} bytes inside the file's {}",
            bytes.len()
        )));
    }
    let offset = offset as usize;
    Ok(CompressedImage {
        width: w,
        height: h,
        format,
        blocks: bytes[offset..offset + expected].to_vec(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, seed: u8) -> CompressedImage {
        let n = bc7_bytes(w, h).unwrap();
        CompressedImage {
            width: w,
            height: h,
            format: BcFormat::Bc7Srgb,
            blocks: (0..n).map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed)).collect(),
        }
    }

    #[test]
    fn round_trip_and_every_damage_is_named() {
        let img = image(8, 12, 3);
        let f = write_ktx2(&img);
        assert_eq!(read_ktx2("a.ktx2", &f, [8, 12], BcFormat::Bc7Srgb).unwrap(), img);
        assert!(f.len() - img.blocks.len() >= HEADER_BYTES + LEVEL_INDEX_BYTES + DFD_BYTES);
        // Wrong expectations.
        assert!(
            read_ktx2("a", &f, [8, 8], BcFormat::Bc7Srgb)
                .unwrap_err()
                .contains("8×12")
        );
        assert!(
            read_ktx2("a", &f, [8, 12], BcFormat::Bc7Unorm)
                .unwrap_err()
                .contains("Vulkan format")
        );
        // Truncations at every length never panic.
        for cut in 0..f.len() {
            assert!(
                read_ktx2("a", &f[..cut], [8, 12], BcFormat::Bc7Srgb).is_err(),
                "cut {cut}"
            );
        }
        // Forged fields.
        let mut g = f.clone();
        g[40] = 2; // levelCount
        assert!(read_ktx2("a", &g, [8, 12], BcFormat::Bc7Srgb).is_err());
        let mut g = f.clone();
        g[80..88].copy_from_slice(&u64::MAX.to_le_bytes()); // level offset
        assert!(read_ktx2("a", &g, [8, 12], BcFormat::Bc7Srgb).is_err());
        let mut g = f.clone();
        g[88..96].copy_from_slice(&(1u64 << 40).to_le_bytes()); // level length
        assert!(read_ktx2("a", &g, [8, 12], BcFormat::Bc7Srgb).is_err());
        let mut g = f.clone();
        g[0] = 0;
        assert!(
            read_ktx2("a", &g, [8, 12], BcFormat::Bc7Srgb)
                .unwrap_err()
                .contains("not a KTX2")
        );
        // Sides that are not whole blocks.
        assert_eq!(bc7_bytes(6, 8), None);
    }

    #[test]
    fn a_crop_of_whole_blocks_decodes_to_the_crop_of_the_decoding() {
        let img = image(16, 12, 3);
        let whole = img.decode();
        for (x, y, w, h) in [(0, 0, 16, 12), (4, 4, 8, 8), (12, 8, 4, 4), (0, 8, 16, 4)] {
            let c = img.crop(x, y, w, h).unwrap();
            assert_eq!(
                c.decode(),
                image::imageops::crop_imm(&whole, x, y, w, h).to_image(),
                "{x},{y} {w}×{h}"
            );
        }
        assert!(img.crop(2, 0, 4, 4).is_none(), "not on a block edge");
        assert!(img.crop(8, 8, 12, 4).is_none(), "past the right edge");
        assert!(img.crop(0, 12, 4, 4).is_none(), "past the bottom");
    }

    #[test]
    fn decoding_places_each_block_at_its_texels() {
        // Mode 6 blocks of one flat colour each: block b decodes to a colour of its own.
        // Mode 6: bit 6 set (mode bits 0000001), then 7-bit R0 R1 G0 G1 B0 B1 A0 A1, P0 P1,
        // then indices; all-zero indices give endpoint 0 everywhere.
        let flat = |r: u8, g: u8, b: u8| -> [u8; 16] {
            let mut bits: u128 = 1 << 6;
            let mut at = 7;
            for v in [r >> 1, r >> 1, g >> 1, g >> 1, b >> 1, b >> 1, 127, 127] {
                bits |= (v as u128) << at;
                at += 7;
            }
            // P bits 1: endpoint values (v << 1) | 1.
            bits |= 1 << at;
            bits |= 1 << (at + 1);
            bits.to_le_bytes()
        };
        let colours = [(10u8, 200u8, 30u8), (250, 4, 100), (60, 60, 240), (128, 128, 128)];
        let blocks: Vec<u8> = colours.iter().flat_map(|&(r, g, b)| flat(r, g, b)).collect();
        let img = CompressedImage {
            width: 8,
            height: 8,
            format: BcFormat::Bc7Srgb,
            blocks,
        };
        let rgba = img.decode();
        for (k, &(r, g, b)) in colours.iter().enumerate() {
            let (x0, y0) = ((k % 2) as u32 * 4, (k / 2) as u32 * 4);
            for y in y0..y0 + 4 {
                for x in x0..x0 + 4 {
                    let p = rgba.get_pixel(x, y).0;
                    let want = [(r >> 1) << 1 | 1, (g >> 1) << 1 | 1, (b >> 1) << 1 | 1, 255];
                    assert_eq!(p, want, "block {k} texel {x},{y}");
                }
            }
        }
    }
}
