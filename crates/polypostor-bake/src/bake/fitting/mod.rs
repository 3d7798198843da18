//! Fitting a part's key polygon onto every frame: the exact dynamic program, its objective,
//! one part in one view over all frames (fast or exact), and the fast mode's gap to the exact.

pub mod fit;
pub mod gap;
pub mod image_cost;
pub mod interior;
pub mod part_fit;
pub mod subpixel;
