//! 8-bit polygon positions (pack format 7 and the GPU layout of every pack; used by the pack
//! loader and the renderer, so it belongs to neither).
//!
//! A key's polygon moves inside a small part of its view, so its positions are stored as one
//! byte per coordinate inside the block's box: the smallest rectangle, in normalised u16 steps
//! of the view plane, that holds every position of every frame of the block. A coordinate `q`
//! (0 to 255) means `(lo + q · size / 255) / 65535` of the view, `(x + 1) / 2`. A part
//! spanning the whole view moves in half-pixel steps at 128² (a quarter pixel at most off the
//! fitted position); a typical limb, a quarter of the view, in eighth-pixel steps. The GPU
//! decodes the same numbers (`unpack2x16unorm(lo) + unpack4x8unorm(q) · unpack2x16unorm(size)`).

/// The box a block's positions are quantised in, in normalised u16 steps of the view plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PositionBox {
    /// Lower corner (x, y).
    pub lo: [u16; 2],
    /// Side lengths (x, y), at least 1, `lo + size` at most 65535.
    pub size: [u16; 2],
}

/// Slack when snapping a box to u16 steps: values decoded from a box give that box back.
const SNAP: f32 = 0.01;

impl PositionBox {
    /// The box around interleaved x, y `values` (clamped to [0, 1]); a unit box at 0 when
    /// there are none.
    pub fn around(values: &[f32]) -> Self {
        let mut lo = [f32::INFINITY; 2];
        let mut hi = [f32::NEG_INFINITY; 2];
        for xy in values.chunks_exact(2) {
            for a in 0..2 {
                let v = xy[a].clamp(0.0, 1.0) * 65535.0;
                lo[a] = lo[a].min(v);
                hi[a] = hi[a].max(v);
            }
        }
        if !lo[0].is_finite() {
            return Self {
                lo: [0; 2],
                size: [1; 2],
            };
        }
        let mut out = Self {
            lo: [0; 2],
            size: [1; 2],
        };
        for a in 0..2 {
            let l = (lo[a] + SNAP).floor().clamp(0.0, 65534.0) as u16;
            let h = ((hi[a] - SNAP).ceil().clamp(0.0, 65535.0) as u16).max(l + 1);
            out.lo[a] = l;
            out.size[a] = h - l;
        }
        out
    }

    /// The box as stored: `lo` x, y then `size` x, y.
    pub fn to_words(self) -> [u16; 4] {
        [self.lo[0], self.lo[1], self.size[0], self.size[1]]
    }

    /// A stored box; `None` when a side is 0 or the box runs past 65535.
    pub fn from_words(w: [u16; 4]) -> Option<Self> {
        let ok = (0..2).all(|a| w[2 + a] > 0 && u32::from(w[a]) + u32::from(w[2 + a]) <= 65535);
        ok.then_some(Self {
            lo: [w[0], w[1]],
            size: [w[2], w[3]],
        })
    }

    /// Coordinate `value` (axis 0 x, 1 y; in [0, 1]) as a byte of this box, nearest step.
    pub fn quantise(&self, axis: usize, value: f32) -> u8 {
        let v = value.clamp(0.0, 1.0) * 65535.0 - f32::from(self.lo[axis]);
        (v / f32::from(self.size[axis]) * 255.0).round().clamp(0.0, 255.0) as u8
    }

    /// The value byte `q` of this box stands for, as the GPU computes it.
    pub fn value(&self, axis: usize, q: u8) -> f32 {
        f32::from(self.lo[axis]) / 65535.0 + f32::from(q) / 255.0 * (f32::from(self.size[axis]) / 65535.0)
    }

    /// Interleaved x, y `values` as bytes of this box.
    pub fn quantise_all(&self, values: &[f32]) -> Vec<u8> {
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| self.quantise(i % 2, v))
            .collect()
    }

    /// Bytes of this box back to interleaved x, y values.
    pub fn values(self, bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
        bytes.iter().enumerate().map(move |(i, &q)| self.value(i % 2, q))
    }

    /// Largest distance (in [0, 1] view units, per axis) between a value and its byte's value:
    /// half a step.
    pub fn max_error(&self) -> [f32; 2] {
        self.size.map(|s| f32::from(s) / 65535.0 / 255.0 / 2.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 40) as f32) / (1u64 << 24) as f32
    }

    #[test]
    fn every_value_lands_within_half_a_step() {
        let mut seed = 7;
        for case in 0..200 {
            // Blocks of every extent, from a sliver to the whole view, anywhere in it.
            let extent = [0.001, 0.05, 0.3, 1.0][case % 4];
            let (cx, cy) = (lcg(&mut seed) * (1.0 - extent), lcg(&mut seed) * (1.0 - extent));
            let values: Vec<f32> = (0..60)
                .flat_map(|_| [cx + lcg(&mut seed) * extent, cy + lcg(&mut seed) * extent])
                .collect();
            let b = PositionBox::around(&values);
            let bytes = b.quantise_all(&values);
            let err = b.max_error();
            for (i, (v, back)) in values.iter().zip(b.values(&bytes)).enumerate() {
                // Half a step, plus the box's snap to whole u16 steps.
                let bound = err[i % 2] + 1.5 / 65535.0;
                assert!((v - back).abs() <= bound, "case {case}: {v} -> {back} (bound {bound})");
            }
            // Brute force: no other byte is nearer than the chosen one.
            for (i, (&v, &q)) in values.iter().zip(&bytes).enumerate() {
                let best = (0..=255u8)
                    .min_by(|&a, &c| {
                        (b.value(i % 2, a) - v)
                            .abs()
                            .partial_cmp(&(b.value(i % 2, c) - v).abs())
                            .unwrap()
                    })
                    .unwrap();
                assert!((b.value(i % 2, best) - v).abs() + 1e-6 >= (b.value(i % 2, q) - v).abs());
            }
        }
    }

    #[test]
    fn decoded_values_give_their_box_and_bytes_back() {
        // The GPU quantises what the loader decoded: the same box and bytes must come back.
        let mut seed = 11;
        for _ in 0..100 {
            let values: Vec<f32> = (0..40).map(|_| 0.2 + lcg(&mut seed) * 0.5).collect();
            let b = PositionBox::around(&values);
            let bytes = b.quantise_all(&values);
            let decoded: Vec<f32> = b.values(&bytes).collect();
            let again = PositionBox::around(&decoded);
            assert_eq!(again, b);
            assert_eq!(again.quantise_all(&decoded), bytes);
        }
    }

    #[test]
    fn degenerate_and_stored_boxes() {
        let still = PositionBox::around(&[0.5, 0.5, 0.5, 0.5]);
        assert!(still.size.iter().all(|&s| s >= 1));
        assert!((still.value(0, still.quantise(0, 0.5)) - 0.5).abs() < 2.0 / 65535.0);
        let edge = PositionBox::around(&[1.0, 1.0, 1.2, -0.3]);
        assert!(u32::from(edge.lo[0]) + u32::from(edge.size[0]) <= 65535);
        assert_eq!(PositionBox::from_words(edge.to_words()), Some(edge));
        assert_eq!(PositionBox::from_words([0, 0, 0, 5]), None);
        assert_eq!(PositionBox::from_words([65000, 0, 600, 5]), None);
        assert_eq!(PositionBox::around(&[]).size, [1, 1]);
    }
}
