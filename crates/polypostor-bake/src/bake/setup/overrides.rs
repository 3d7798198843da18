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
    /// The view's key frames after the first, as the artist set them (absent: chosen by the
    /// bake, see [`crate::bake::keys`]; empty: one key).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keys: Option<Vec<usize>>,
}

impl ViewOverride {
    pub fn is_empty(&self) -> bool {
        self.key_frame.is_none() && self.order.is_none() && self.pins.values().all(Vec::is_empty) && self.keys.is_none()
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
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

    /// Follows the removal of part `p` whose triangles went to part `into` (numbers before
    /// the removal; later parts move down one, as [`crate::edit::paint::remove_part`] does):
    /// drawing orders lose `p` and are renumbered, pins of later parts are renumbered, and the
    /// pins of `p` and of `into` (whose outline changes) are dropped. Returns how many pins
    /// were dropped.
    pub fn remove_part(&mut self, p: usize, into: usize) -> usize {
        let down = |k: usize| if k > p { k - 1 } else { k };
        let mut dropped = 0;
        for o in self.views.values_mut() {
            if let Some(order) = &mut o.order {
                order.retain(|&k| k != p);
                for k in order.iter_mut() {
                    *k = down(*k);
                }
            }
            let pins = std::mem::take(&mut o.pins);
            for (k, list) in pins {
                if k == p || k == into {
                    dropped += list.len();
                } else {
                    o.pins.insert(down(k), list);
                }
            }
        }
        self.tidy();
        dropped
    }

    /// A part `p` was added (the last): every hand-set drawing order draws it last, in
    /// front (an order that did not list every part was ignored by the bake, so adding a part
    /// silently threw away each of them). Returns how many orders were extended.
    pub fn add_part(&mut self, p: usize) -> usize {
        let mut extended = 0;
        for o in self.views.values_mut() {
            if let Some(order) = &mut o.order
                && !order.contains(&p)
            {
                order.push(p);
                extended += 1;
            }
        }
        extended
    }

    /// Drops empty entries.
    pub fn tidy(&mut self) {
        for o in self.views.values_mut() {
            o.pins.retain(|_, list| !list.is_empty());
        }
        self.views.retain(|_, o| !o.is_empty());
    }
}

/// Corrections a bake could not apply, counted by kind, so none is dropped without a word
/// (the command line prints [`DroppedCorrections::lines`], the editor logs them and shows a
/// notice in the Views tab, `report.json` keeps them).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct DroppedCorrections {
    /// Corrections made for another bake (other view count, coverage or frame count): none
    /// of them applies.
    pub other_basis: usize,
    /// The bake they were made for, when `other_basis` is not zero.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub made_for: Option<OverrideBasis>,
    /// Corrections of views the bake does not have.
    pub views: usize,
    /// Key frames past the clip's frames.
    pub key_frames: usize,
    /// Key images set by hand past the most a view holds ([`crate::bake::keys::MAX_KEYS`]
    /// with its first).
    pub keys_over: usize,
    /// Drawing orders that are not a permutation of the bake's parts.
    pub orders: usize,
    /// Pins on frames, parts or polygon vertices the bake does not have, or on parts not
    /// fitted in their view.
    pub pins: usize,
}

impl DroppedCorrections {
    pub fn is_empty(&self) -> bool {
        self.total() == 0
    }

    pub fn total(&self) -> usize {
        self.other_basis + self.views + self.key_frames + self.keys_over + self.orders + self.pins
    }

    /// Adds `other`'s counts.
    pub fn add(&mut self, other: &DroppedCorrections) {
        self.other_basis += other.other_basis;
        if self.made_for.is_none() {
            self.made_for = other.made_for;
        }
        self.views += other.views;
        self.key_frames += other.key_frames;
        self.keys_over += other.keys_over;
        self.orders += other.orders;
        self.pins += other.pins;
    }

    /// One line per kind of dropped correction, with its count.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.other_basis > 0 {
            let b = self.made_for.unwrap_or_default();
            out.push(format!(
                "{} correction(s) were made for a bake of {} views{} and {} frames and do not apply to this one; ignored (bake with those settings to use them)",
                self.other_basis,
                b.views,
                if b.full_sphere { " on the whole sphere" } else { "" },
                b.frames
            ));
        }
        let mut line = |n: usize, what: &str| {
            if n > 0 {
                out.push(format!("{n} {what}; ignored"));
            }
        };
        line(self.views, "correction(s) refer to views this bake does not have");
        line(self.key_frames, "key frame(s) lie past the clip's frames");
        let most = crate::bake::keys::MAX_KEYS;
        line(
            self.keys_over,
            &format!(
                "key image(s) set by hand go past the {most} a view holds (its first and {})",
                most - 1
            ),
        );
        line(self.orders, "drawing order(s) do not list each part of the bake once");
        line(
            self.pins,
            "pin(s) refer to frames, parts or polygon vertices this bake does not have",
        );
        out
    }
}

impl ViewOverride {
    /// Pins in this view (all parts).
    pub fn pin_count(&self) -> usize {
        self.pins.values().map(Vec::len).sum()
    }

    /// Corrections in this view: its key frame, its order and its pins.
    pub fn count(&self) -> usize {
        usize::from(self.key_frame.is_some())
            + usize::from(self.order.is_some())
            + self.pin_count()
            + usize::from(self.keys.is_some())
    }
}

impl BakeOverrides {
    /// Every correction: key frames, orders and pins.
    pub fn count(&self) -> usize {
        self.views.values().map(ViewOverride::count).sum()
    }

    /// What of these corrections a bake on `basis` with `parts` parts cannot apply, as far
    /// as it can be told before fitting (pins past a polygon's vertices are counted by the
    /// fit itself).
    pub fn audit(&self, basis: OverrideBasis, parts: usize) -> DroppedCorrections {
        let mut d = DroppedCorrections::default();
        if self.is_empty() {
            return d;
        }
        if self.basis != basis {
            d.other_basis = self.count();
            d.made_for = Some(self.basis);
            return d;
        }
        for (&v, o) in &self.views {
            if v >= basis.views {
                d.views += o.count();
                continue;
            }
            if o.key_frame.is_some_and(|k| k >= basis.frames) {
                d.key_frames += 1;
            }
            if let Some(keys) = &o.keys {
                d.key_frames += keys.iter().filter(|&&k| k >= basis.frames).count();
            }
            if o.order.as_ref().is_some_and(|order| !valid_order(order, parts)) {
                d.orders += 1;
            }
            for (&part, list) in &o.pins {
                d.pins += list.iter().filter(|p| part >= parts || p.frame >= basis.frames).count();
            }
        }
        d
    }
}

/// How many of the key frames set by hand for a view (`keys`, after its first key `first`)
/// a view cannot hold: at most [`crate::bake::keys::MAX_KEYS`] − 1 after the first (thirteen
/// set by hand drew eight, five dropped without a word). Frames past `frames`, repeats and the
/// first key itself take no room.
pub fn keys_over(keys: &[usize], frames: usize, first: usize) -> usize {
    let mut kept: Vec<usize> = keys.iter().copied().filter(|&k| k < frames && k != first).collect();
    kept.sort_unstable();
    kept.dedup();
    kept.len().saturating_sub(crate::bake::keys::MAX_KEYS - 1)
}

pub use polypostor_runtime::pack::valid_order;

#[cfg(test)]
mod tests {
    use super::*;

    /// Removing part 1 of 4 into part 0: orders lose it and renumber, pins of parts 2 and 3
    /// become 1 and 2, pins of parts 0 and 1 are dropped; each order stays a permutation.
    #[test]
    fn removing_a_part_renumbers_orders_and_pins() {
        let pin = |frame| Pin {
            frame,
            source: 3,
            target: 7,
        };
        let mut o = BakeOverrides::default();
        let v = o.view_mut(OverrideBasis::default(), 2);
        v.order = Some(vec![3, 1, 0, 2]);
        v.key_frame = Some(4);
        for part in 0..4 {
            v.pins.insert(part, vec![pin(part), pin(part + 10)]);
        }
        o.view_mut(OverrideBasis::default(), 5).pins.insert(1, vec![pin(0)]);
        let dropped = o.remove_part(1, 0);
        assert_eq!(dropped, 5);
        let v = &o.views[&2];
        assert_eq!(v.order, Some(vec![2, 0, 1]));
        assert_eq!(v.key_frame, Some(4));
        assert_eq!(v.pins.keys().copied().collect::<Vec<_>>(), [1, 2]);
        assert_eq!(v.pins[&1], [pin(2), pin(12)]);
        assert_eq!(v.pins[&2], [pin(3), pin(13)]);
        assert!(!o.views.contains_key(&5), "a view left with nothing is tidied away");
        let mut sorted = v.order.clone().unwrap();
        sorted.sort();
        assert_eq!(sorted, [0, 1, 2]);
    }

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
    fn every_dropped_correction_is_counted_by_kind() {
        let basis = OverrideBasis {
            views: 10,
            full_sphere: false,
            frames: 8,
        };
        let mut o = BakeOverrides::default();
        let pin = |frame| Pin {
            frame,
            source: 1,
            target: 2,
        };
        o.view_mut(basis, 2).key_frame = Some(3); // fine
        o.view_mut(basis, 3).key_frame = Some(8); // past the frames
        o.view_mut(basis, 4).order = Some(vec![0, 1, 2]); // 3 of 5 parts
        o.view_mut(basis, 5).order = Some(vec![4, 3, 2, 1, 0]); // fine
        o.view_mut(basis, 6).pins.insert(1, vec![pin(0), pin(9)]); // one past the frames
        o.view_mut(basis, 6).pins.insert(7, vec![pin(0)]); // no part 7
        o.view_mut(basis, 12).key_frame = Some(1); // no view 12
        o.view_mut(basis, 12).pins.insert(0, vec![pin(0)]);
        // Every frame a key, one twice, one past the frames (that one is counted here; what
        // a view cannot hold is counted by the bake, which knows each view's first key).
        o.view_mut(basis, 7).keys = Some(vec![0, 1, 2, 3, 4, 5, 6, 7, 7, 9]);
        let d = o.audit(basis, 5);
        assert_eq!(
            (d.other_basis, d.views, d.key_frames, d.orders, d.pins),
            (0, 2, 2, 1, 2),
            "{d:?}"
        );
        assert_eq!(d.lines().len(), 4);
        assert!(d.lines().iter().all(|l| l.contains("ignored")));
        // 8 distinct frames: with the first key elsewhere, one past the 7 a view holds; with
        // the first key among them, none.
        assert_eq!(keys_over(&[0, 1, 2, 3, 4, 5, 6, 7, 7, 9], 8, 20), 1);
        assert_eq!(keys_over(&[0, 1, 2, 3, 4, 5, 6, 7, 7, 9], 8, 3), 0);
        assert_eq!(keys_over(&(0..13).collect::<Vec<_>>(), 20, 0), 5);
        let said = DroppedCorrections {
            keys_over: 5,
            ..Default::default()
        };
        assert!(
            said.lines()[0].starts_with("5 key image(s) set by hand go past the 8"),
            "{:?}",
            said.lines()
        );
        // Another bake: everything is dropped, and said so once.
        let other = o.audit(OverrideBasis { views: 24, ..basis }, 5);
        assert_eq!(other.other_basis, o.count());
        assert_eq!(o.count(), 10);
        let lines = other.lines();
        assert_eq!(lines.len(), 1);
        assert!(
            lines[0].contains("10 views") && lines[0].contains("8 frames"),
            "{lines:?}"
        );
        assert!(BakeOverrides::default().audit(basis, 5).is_empty());
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
