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
    let surface = intel_tex_2::RgbaSurface {
        data: data.as_raw(),
        width: w,
        height: h,
        stride: 4 * w,
    };
    let blocks = intel_tex_2::bc7::compress_blocks(&settings, &surface);
    Some(CompressedImage {
        width: w,
        height: h,
        format,
        blocks,
    })
}

/// The KTX2 file of `img` in BC7 (`None` when a side is not a multiple of 4).
pub fn encode_ktx2(img: &image::RgbaImage, format: BcFormat) -> Option<Vec<u8>> {
    encode_bc7(img, format).map(|c| write_ktx2(&c))
}
