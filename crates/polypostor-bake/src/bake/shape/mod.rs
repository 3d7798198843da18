//! From a part's mask to its polygon: outer-contour tracing, then simplification with the
//! edge-length-ratio term.

pub mod contour;
pub mod simplify;
