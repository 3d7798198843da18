//! The artist's corrections to a bake, kept in the project and applied by every later bake:
//! per view a texture key frame, a drawing order, and pinned vertex correspondences per part
//! and frame. They refer to view numbers, so they apply only to bakes with the same number of
//! views, coverage and frame count they were made for (recorded beside them).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// One pinned correspondence: at `frame`, key-polygon vertex `source` maps to target-contour
/// vertex `target` (P(source) = target).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Pin {
    pub frame: usize,
    pub source: usize,
    pub target: usize,
}

/// The corrections of one view.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewOverride {
    /// The texture key frame of this view (absent: the bake's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub key_frame: Option<usize>,
    /// Drawing order, back to front, as part numbers (absent: computed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<Vec<usize>>,
    /// Pins per part number.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub pins: BTreeMap<usize, Vec<Pin>>,
}

impl ViewOverride {
    pub fn is_empty(&self) -> bool {
        self.key_frame.is_none() && self.order.is_none() && self.pins.values().all(Vec::is_empty)
    }

    /// The pins of `part` as the fitter takes them: per frame, `(source, target)` pairs.
    pub fn pins_per_frame(&self, part: usize, frames: usize) -> Vec<Vec<(usize, usize)>> {
        let mut out = vec![Vec::new(); frames];
        for p in self.pins.get(&part).into_iter().flatten() {
            if let Some(list) = out.get_mut(p.frame) {
                list.push((p.source, p.target));
            }
        }
        out
    }
}

/// What the overrides' view numbers refer to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OverrideBasis {
    pub views: usize,
    pub full_sphere: bool,
    pub frames: usize,
}

/// Every correction of a project.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BakeOverrides {
    pub basis: OverrideBasis,
    pub views: BTreeMap<usize, ViewOverride>,
}

impl BakeOverrides {
    pub fn is_empty(&self) -> bool {
        self.views.values().all(ViewOverride::is_empty)
    }

    /// The corrections for view `v` of a bake on `basis`; none when the basis differs.
    pub fn view(&self, basis: OverrideBasis, v: usize) -> Option<&ViewOverride> {
        (self.basis == basis).then(|| self.views.get(&v)).flatten()
    }

    /// The corrections of view `v`, to change (resetting everything when the basis changed).
    pub fn view_mut(&mut self, basis: OverrideBasis, v: usize) -> &mut ViewOverride {
        if self.basis != basis {
            self.views.clear();
            self.basis = basis;
        }
        self.views.entry(v).or_default()
    }

    /// Drops empty entries.
    pub fn tidy(&mut self) {
        for o in self.views.values_mut() {
            o.pins.retain(|_, list| !list.is_empty());
        }
        self.views.retain(|_, o| !o.is_empty());
    }
}

/// `order` if it lists every part of `0..parts` exactly once.
pub fn valid_order(order: &[usize], parts: usize) -> bool {
    let mut seen = vec![false; parts];
    order.len() == parts
        && order
            .iter()
            .all(|&p| p < parts && !std::mem::replace(&mut seen[p], true))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_round_trip_and_respect_their_basis() {
        let basis = OverrideBasis {
            views: 137,
            full_sphere: false,
            frames: 10,
        };
        let mut o = BakeOverrides::default();
        let v = o.view_mut(basis, 5);
        v.key_frame = Some(3);
        v.order = Some(vec![2, 0, 1]);
        v.pins.insert(
            1,
            vec![Pin {
                frame: 4,
                source: 7,
                target: 11,
            }],
        );
        let text = serde_json::to_string(&o).unwrap();
        let back: BakeOverrides = serde_json::from_str(&text).unwrap();
        assert_eq!(back, o);
        assert!(back.view(basis, 5).is_some());
        assert!(back.view(OverrideBasis { views: 24, ..basis }, 5).is_none());
        let per_frame = back.view(basis, 5).unwrap().pins_per_frame(1, 10);
        assert_eq!(per_frame[4], vec![(7, 11)]);
        assert!(per_frame.iter().enumerate().all(|(f, l)| f == 4 || l.is_empty()));
        // A different basis starts over.
        let mut o2 = back.clone();
        o2.view_mut(OverrideBasis { views: 24, ..basis }, 0).key_frame = Some(1);
        assert_eq!(o2.views.len(), 1);
        o2.views.get_mut(&0).unwrap().key_frame = None;
        o2.tidy();
        assert!(o2.is_empty() && o2.views.is_empty());
    }

    #[test]
    fn valid_orders_are_permutations() {
        assert!(valid_order(&[2, 0, 1], 3));
        assert!(!valid_order(&[0, 0, 1], 3));
        assert!(!valid_order(&[0, 1], 3));
        assert!(!valid_order(&[0, 1, 3], 3));
        assert!(valid_order(&[], 0));
    }
}
