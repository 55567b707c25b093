//! Textures on the host: checked, decoded to 16-bit linear channels (sRGB colour channels
//! through the exact transfer function, rounded once), their mip chains built by 2×2 box
//! filtering in integers, and laid out for the kernels (`TextureInfo`, two words a texel).
//! The kernels filter what this builds (`programs::texture`); both backends read the same
//! words, so the chain's arithmetic needs no care beyond being fixed.

use crate::Error;
use rayon::prelude::*;
use std::sync::Arc;
use tileraster_kernels::abi::{Address, Filter, MAX_MIP_LEVELS, TextureInfo};

/// Largest width or height of a texture (Vulkan's required `maxImageDimension2D` is 4096;
/// every desktop GPU has 16384).
pub const MAX_TEXTURE_DIM: u32 = 16384;

/// A base-colour texture: RGBA8 texels, row 0 at `v = 0` (glTF's convention: the image's first
/// row), and how it is sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// RGBA8, row by row.
    pub rgba: Vec<u8>,
    /// Whether red, green and blue are sRGB-encoded (base-colour images are); alpha is linear.
    pub srgb: bool,
    pub filter: Filter,
    pub address_u: Address,
    pub address_v: Address,
}

impl Texture {
    /// An sRGB texture, filtered trilinearly and repeated.
    pub fn srgb(width: u32, height: u32, rgba: Vec<u8>) -> Texture {
        Texture { width, height, rgba, srgb: true, filter: Filter::Trilinear, address_u: Address::Repeat, address_v: Address::Repeat }
    }

    pub(super) fn check(&self, index: usize) -> Result<(), Error> {
        let too_large = |reason: String| Err(Error::TextureTooLarge { texture: index, width: self.width, height: self.height, reason });
        if self.width == 0 || self.height == 0 {
            return Err(Error::InvalidTexture { texture: index, reason: format!("it is {}×{} texels; give at least one", self.width, self.height) });
        }
        if self.width > MAX_TEXTURE_DIM || self.height > MAX_TEXTURE_DIM {
            return too_large(format!("each side may have at most {MAX_TEXTURE_DIM} texels"));
        }
        let expected = self.width as usize * self.height as usize * 4;
        if self.rgba.len() != expected {
            return Err(Error::InvalidTexture {
                texture: index,
                reason: format!("{} bytes of RGBA8 for {}×{} texels; give {expected}", self.rgba.len(), self.width, self.height),
            });
        }
        Ok(())
    }
}

/// sRGB-encoded 8-bit values to 16-bit linear ones: the transfer function in `f64`, rounded.
fn srgb_table() -> [u16; 256] {
    std::array::from_fn(|c| {
        let x = c as f64 / 255.0;
        let linear = if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) };
        (linear * 65535.0).round() as u16
    })
}

/// A mesh's textures laid out for the kernels, kept for its later frames: they take them as
/// they are where their filter and address overrides are the same (the texels shared, so a
/// backend that holds them from the last frame is handed none again).
#[derive(Clone)]
pub struct LaidOutTextures {
    filter: Option<Filter>,
    address: Option<Address>,
    /// Which textures they are: each one's texels' address and length and its size (a guard
    /// against a caller's mix-up; the caller keeps them for one mesh's frames).
    sources: Vec<(usize, usize, u32, u32)>,
    pub(super) infos: Vec<TextureInfo>,
    pub(super) texels: Arc<Vec<u64>>,
}

impl LaidOutTextures {
    /// `textures` laid out with the overrides, or `kept` where it was laid out with the same
    /// ones from the same textures (the caller's promise, which the texels' addresses and the
    /// sizes back up).
    pub(super) fn of(textures: &[&Texture], filter: Option<Filter>, address: Option<Address>, kept: Option<&LaidOutTextures>) -> Result<Self, Error> {
        let sources: Vec<(usize, usize, u32, u32)> = textures.iter().map(|t| (t.rgba.as_ptr() as usize, t.rgba.len(), t.width, t.height)).collect();
        match kept {
            Some(k) if k.filter == filter && k.address == address && k.sources == sources => Ok(k.clone()),
            _ => {
                let (infos, texels) = lay_out(textures, filter, address)?;
                Ok(LaidOutTextures { filter, address, sources, infos, texels: Arc::new(texels) })
            }
        }
    }
}

/// The textures as the kernels take them: their descriptions and their texels.
fn lay_out(textures: &[&Texture], filter: Option<Filter>, address: Option<Address>) -> Result<(Vec<TextureInfo>, Vec<u64>), Error> {
    let table = srgb_table();
    let mut infos = Vec::with_capacity(textures.len());
    let mut texels: Vec<u64> = Vec::new();
    for (index, texture) in textures.iter().enumerate() {
        texture.check(index)?;
        let filter = filter.unwrap_or(texture.filter);
        let (au, av) = address.map_or((texture.address_u, texture.address_v), |a| (a, a));
        let (w, h) = (texture.width, texture.height);
        let levels = if filter == Filter::Trilinear { 32 - w.max(h).leading_zeros() } else { 1 };
        let mut info = TextureInfo { width: w, height: h, levels, flags: TextureInfo::flags_of(filter, au, av), ..Default::default() };
        // Level 0: 16-bit linear channels.
        let mut level: Vec<[u16; 4]> = texture
            .rgba
            .par_chunks_exact(4)
            .map(|t| std::array::from_fn(|c| if texture.srgb && c < 3 { table[t[c] as usize] } else { t[c] as u16 * 257 }))
            .collect();
        let (mut lw, mut lh) = (w, h);
        for k in 0..levels as usize {
            let offset = u32::try_from(texels.len()).ok().filter(|o| o.checked_add(lw * lh).is_some());
            let Some(offset) = offset else {
                return Err(Error::TextureTooLarge { texture: index, width: w, height: h, reason: "the frame's texels pass 2^32".into() });
            };
            info.offsets[k] = offset;
            texels.par_extend(level.par_iter().map(|t| t.iter().rev().fold(0u64, |word, &c| word << 16 | c as u64)));
            if k + 1 < levels as usize {
                (level, lw, lh) = halve(&level, lw, lh);
            }
        }
        debug_assert!(levels as usize <= MAX_MIP_LEVELS);
        infos.push(info);
    }
    Ok((infos, texels))
}

/// The next mip level: each texel the rounded mean of the 2×2 block above it (the last row or
/// column repeated where a side is odd-sized and 1 texel long).
fn halve(level: &[[u16; 4]], w: u32, h: u32) -> (Vec<[u16; 4]>, u32, u32) {
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let at = |x: u32, y: u32| &level[(y.min(h - 1) * w + x.min(w - 1)) as usize];
    let out = (0..nh * nw)
        .into_par_iter()
        .map(|k| (k % nw, k / nw))
        .map(|(x, y)| {
            let block = [at(2 * x, 2 * y), at(2 * x + 1, 2 * y), at(2 * x, 2 * y + 1), at(2 * x + 1, 2 * y + 1)];
            std::array::from_fn(|c| ((block.iter().map(|t| t[c] as u32).sum::<u32>() + 2) / 4) as u16)
        })
        .collect();
    (out, nw, nh)
}
