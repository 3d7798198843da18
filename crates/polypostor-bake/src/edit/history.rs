//! Undo and redo by snapshots: before each edit the caller records the state it started
//! from; undo swaps the current state for the last recorded one. The project document is
//! small (the segmentation is run-length encoded), so whole snapshots are simpler and safer
//! than inverse operations.

/// An undo/redo history of states `T`, each step labelled for the menu ("Undo Paint").
#[derive(Clone, Debug)]
pub struct History<T> {
    undo: Vec<(String, T)>,
    redo: Vec<(String, T)>,
    limit: usize,
}

impl<T> Default for History<T> {
    fn default() -> Self {
        Self::new(256)
    }
}

impl<T> History<T> {
    /// A history keeping at most `limit` undo steps (the oldest are dropped).
    pub fn new(limit: usize) -> Self {
        Self {
            undo: Vec::new(),
            redo: Vec::new(),
            limit: limit.max(1),
        }
    }

    /// Records `before`, the state an edit called `label` started from. Clears the redo
    /// steps (a new edit branches away from them).
    pub fn record(&mut self, label: impl Into<String>, before: T) {
        self.undo.push((label.into(), before));
        self.redo.clear();
        if self.undo.len() > self.limit {
            let extra = self.undo.len() - self.limit;
            self.undo.drain(..extra);
        }
    }

    /// Undoes the last step: returns the state to restore (and its label) and keeps
    /// `current` for redo. `None` (and `current` dropped) when there is nothing to undo.
    pub fn undo(&mut self, current: T) -> Option<(String, T)> {
        let (label, state) = self.undo.pop()?;
        self.redo.push((label.clone(), current));
        Some((label, state))
    }

    /// Redoes the last undone step: returns the state to restore and keeps `current` for
    /// undo.
    pub fn redo(&mut self, current: T) -> Option<(String, T)> {
        let (label, state) = self.redo.pop()?;
        self.undo.push((label.clone(), current));
        Some((label, state))
    }

    pub fn undo_label(&self) -> Option<&str> {
        self.undo.last().map(|(l, _)| l.as_str())
    }

    pub fn redo_label(&self) -> Option<&str> {
        self.redo.last().map(|(l, _)| l.as_str())
    }

    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    pub fn clear(&mut self) {
        self.undo.clear();
        self.redo.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::History;

    /// Against a brute-force model: every state ever reached is kept in a list and undo/redo
    /// move a cursor along it (a new edit cuts the list after the cursor).
    #[test]
    fn undo_redo_follow_a_linear_model() {
        let mut h = History::new(1000);
        let mut state = 0i64;
        let mut model = vec![0i64];
        let mut at = 0usize;
        let mut rng = 12345u64;
        for step in 0..2000 {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            match (rng >> 33) % 4 {
                0 | 1 => {
                    h.record(format!("edit {step}"), state);
                    state = step as i64 + 1;
                    model.truncate(at + 1);
                    model.push(state);
                    at += 1;
                }
                2 => {
                    if let Some((_, s)) = h.undo(state) {
                        state = s;
                        at -= 1;
                    } else {
                        assert_eq!(at, 0);
                    }
                }
                _ => {
                    if let Some((_, s)) = h.redo(state) {
                        state = s;
                        at += 1;
                    } else {
                        assert_eq!(at + 1, model.len());
                    }
                }
            }
            assert_eq!(state, model[at], "step {step}");
        }
    }

    #[test]
    fn the_oldest_steps_are_dropped_past_the_limit() {
        let mut h = History::new(3);
        for i in 0..5 {
            h.record("x", i);
        }
        assert_eq!(h.undo_len(), 3);
        assert_eq!(h.undo(5).unwrap().1, 4);
        assert_eq!(h.undo(4).unwrap().1, 3);
        assert_eq!(h.undo(3).unwrap().1, 2);
        assert!(h.undo(2).is_none());
        assert_eq!(h.redo_label(), Some("x"));
    }
}
