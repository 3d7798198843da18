//! How far the fast fitting mode lands from the exact DP, measured on a few views of a bake's
//! own set-up (same character, parts, frames, key frame and options): the figure issue 3's
//! "within 2 %" is about, for `polypostor bench bake`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::bake::caps::CapOverrides;
use crate::bake::part_fit::{PartFitOptions, fit_part};
use crate::bake::pipeline::{BakeError, BakeOptions, Prepared, part_key};
use crate::bake::segment::Segmentation;
use crate::character::Character;
use crate::gpu::GpuContext;

/// Fast against exact over some views, every part and frame.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FitGap {
    /// The views measured.
    pub views: Vec<usize>,
    /// Part-frames fitted both ways.
    pub part_frames: usize,
    /// Total fit cost, fast mode and exact DP.
    pub fast: f64,
    pub exact: f64,
    /// Part-frames where the fast mode found the optimum (within 1e-9).
    pub optimal: usize,
    /// CPU-summed wall time of each mode's fits.
    pub fast_secs: f64,
    pub exact_secs: f64,
}

impl FitGap {
    /// The fast mode's total above the exact one, in percent.
    pub fn percent(&self) -> f64 {
        if self.exact > 0.0 {
            100.0 * (self.fast / self.exact - 1.0)
        } else {
            0.0
        }
    }
}

/// `count` views spread over `total`, away from the ends.
pub fn spread(count: usize, total: usize) -> Vec<usize> {
    let count = count.min(total);
    (0..count).map(|i| (2 * i + 1) * total / (2 * count)).collect()
}

/// Fits every part of `count` views spread over the bake's views with `options.fit` (fast
/// mode) and with the exact DP, from each part's first key frame ([`part_key`] of `key`).
#[allow(clippy::too_many_arguments)]
pub fn measure(
    ctx: &GpuContext,
    character: &Character,
    segmentation: &Segmentation,
    caps: &CapOverrides,
    options: &BakeOptions,
    key: usize,
    count: usize,
    cancel: &AtomicBool,
) -> Result<FitGap, BakeError> {
    let prepared = Prepared::new(ctx, character, segmentation, caps, options)?;
    let views = spread(count, prepared.directions.len());
    // The gap is the DP's objective; the interior vertices added after it do not change it.
    let fast_options = PartFitOptions {
        exhaustive: false,
        interior_vertices: 0,
        ..options.fit
    };
    let exact_options = PartFitOptions {
        exhaustive: true,
        interior_vertices: 0,
        ..options.fit
    };
    let mut gap = FitGap {
        views: views.clone(),
        ..Default::default()
    };
    for &v in &views {
        if cancel.load(Ordering::Relaxed) {
            return Err(BakeError::Cancelled);
        }
        let data = prepared.render(ctx, v)?;
        let key = key.min(prepared.times.len().saturating_sub(1));
        let per_part: Vec<Option<(Vec<f64>, Vec<f64>, f64, f64)>> = data
            .tiles
            .par_iter()
            .map(|tiles| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let k = part_key(tiles, key, false);
                let t = Instant::now();
                let fast = fit_part(tiles, k, &fast_options, &[]).ok()?;
                let fast_secs = t.elapsed().as_secs_f64();
                let t = Instant::now();
                let exact = fit_part(tiles, k, &exact_options, &[]).ok()?;
                Some((fast.costs, exact.costs, fast_secs, t.elapsed().as_secs_f64()))
            })
            .collect();
        for (fast, exact, fs, es) in per_part.into_iter().flatten() {
            gap.part_frames += fast.len();
            gap.fast += fast.iter().sum::<f64>();
            gap.exact += exact.iter().sum::<f64>();
            gap.optimal += fast.iter().zip(&exact).filter(|(f, e)| **f <= **e + 1e-9).count();
            gap.fast_secs += fs;
            gap.exact_secs += es;
        }
    }
    if cancel.load(Ordering::Relaxed) {
        return Err(BakeError::Cancelled);
    }
    Ok(gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_views_are_distinct_and_inside() {
        assert_eq!(spread(2, 137), vec![34, 102]);
        assert_eq!(spread(5, 3), vec![0, 1, 2]);
        assert!(spread(0, 10).is_empty());
        for n in 1..20 {
            let s = spread(n, 40);
            assert_eq!(s.len(), n);
            assert!(s.windows(2).all(|w| w[0] < w[1]) && s.iter().all(|&v| v < 40));
        }
    }

    #[test]
    fn percent_is_relative_excess() {
        let g = FitGap {
            fast: 102.0,
            exact: 100.0,
            ..Default::default()
        };
        assert!((g.percent() - 2.0).abs() < 1e-12);
        assert_eq!(FitGap::default().percent(), 0.0);
    }
}
