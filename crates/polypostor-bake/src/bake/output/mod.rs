//! What a bake tells: `report.json`, the inspector's per-view data, CPU seconds per stage,
//! and the remaining-time estimate of the progress bar.

pub mod eta;
pub mod inspect;
pub mod profile;
pub mod report;
