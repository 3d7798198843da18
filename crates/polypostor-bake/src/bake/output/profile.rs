//! Where a bake's CPU time goes, stage by stage.
//!
//! A [`Scope`] times a region of code on the thread that runs it. Scopes nest: each one
//! records its *exclusive* time (its own elapsed time less that of the scopes opened inside
//! it on the same thread), so nothing is counted twice — also when rayon runs another task
//! on a thread that waits inside a scope (that task opens its own scope and is subtracted).
//! A *root* scope names a job ("part fit", "key choice", "render"); the leaf scopes opened
//! inside it ("trace", "restart", "simplify") are recorded as `root/leaf`, so the same leaf
//! stage run for different jobs stays apart.
//!
//! The figures are process-wide: [`snapshot`] before and after a piece of work and
//! [`Snapshot::since`] give what was spent in between (a second bake running at the same
//! time in the same process would be counted too). They are CPU seconds summed over
//! threads, not wall-clock time: on two busy cores they add up to about twice the wall time.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

static TOTALS: Mutex<BTreeMap<String, (f64, u64)>> = Mutex::new(BTreeMap::new());

struct Open {
    name: &'static str,
    root: bool,
    start: Instant,
    inner: Duration,
}

thread_local! {
    static STACK: RefCell<Vec<Open>> = const { RefCell::new(Vec::new()) };
}

/// A timed region; records its exclusive time when dropped.
#[must_use = "a scope times the region until it is dropped"]
pub struct Scope(());

/// Opens a root scope: a job whose leaf scopes are recorded under its name.
pub fn root(name: &'static str) -> Scope {
    open(name, true)
}

/// Opens a leaf scope, recorded as `root/name` under the nearest enclosing root (or
/// `other/name` outside any).
pub fn leaf(name: &'static str) -> Scope {
    open(name, false)
}

/// Runs `f` inside a root scope.
pub fn in_root<R>(name: &'static str, f: impl FnOnce() -> R) -> R {
    let _s = root(name);
    f()
}

/// Runs `f` inside a leaf scope.
pub fn in_leaf<R>(name: &'static str, f: impl FnOnce() -> R) -> R {
    let _s = leaf(name);
    f()
}

fn open(name: &'static str, root: bool) -> Scope {
    STACK.with(|s| {
        s.borrow_mut().push(Open {
            name,
            root,
            start: Instant::now(),
            inner: Duration::ZERO,
        })
    });
    Scope(())
}

impl Drop for Scope {
    fn drop(&mut self) {
        let (key, exclusive) = STACK.with(|s| {
            let mut s = s.borrow_mut();
            let Some(top) = s.pop() else {
                return (None, Duration::ZERO);
            };
            let elapsed = top.start.elapsed();
            if let Some(parent) = s.last_mut() {
                parent.inner += elapsed;
            }
            let key = if top.root {
                top.name.to_string()
            } else {
                let root = s.iter().rev().find(|o| o.root).map_or("other", |o| o.name);
                format!("{root}/{}", top.name)
            };
            (Some(key), elapsed.saturating_sub(top.inner))
        });
        if let Some(key) = key {
            let mut t = TOTALS.lock().unwrap_or_else(|e| e.into_inner());
            let e = t.entry(key).or_insert((0.0, 0));
            e.0 += exclusive.as_secs_f64();
            e.1 += 1;
        }
    }
}

/// Counts an event (no time) under `name`: what happened how often (`restart improved`).
pub fn tally(name: &str) {
    let mut t = TOTALS.lock().unwrap_or_else(|e| e.into_inner());
    t.entry(name.to_string()).or_insert((0.0, 0)).1 += 1;
}

/// Adds `n` to the count under `name` (no time): how much work of one kind was done
/// (triangle costs evaluated).
pub fn count(name: &str, n: u64) {
    if n == 0 {
        return;
    }
    let mut t = TOTALS.lock().unwrap_or_else(|e| e.into_inner());
    t.entry(name.to_string()).or_insert((0.0, 0)).1 += n;
}

/// The totals so far: seconds and count per stage.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshot(pub BTreeMap<String, (f64, u64)>);

/// The process's totals now.
pub fn snapshot() -> Snapshot {
    Snapshot(TOTALS.lock().unwrap_or_else(|e| e.into_inner()).clone())
}

impl Snapshot {
    /// CPU seconds per stage spent since `self` was taken (stages with nothing spent left out).
    pub fn since(&self) -> BTreeMap<String, f64> {
        let now = snapshot();
        now.0
            .into_iter()
            .filter_map(|(k, (secs, n))| {
                let (s0, n0) = self.0.get(&k).copied().unwrap_or((0.0, 0));
                (n > n0).then(|| (k, (secs - s0).max(0.0)))
            })
            .collect()
    }

    /// Calls per stage since `self` was taken.
    pub fn counts_since(&self) -> BTreeMap<String, u64> {
        let now = snapshot();
        now.0
            .into_iter()
            .filter_map(|(k, (_, n))| {
                let n0 = self.0.get(&k).map_or(0, |v| v.1);
                (n > n0).then(|| (k, n - n0))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spin(ms: u64) {
        let t = Instant::now();
        while t.elapsed() < Duration::from_millis(ms) {
            std::hint::black_box(0);
        }
    }

    #[test]
    fn nested_scopes_count_exclusive_time_under_their_root() {
        let before = snapshot();
        {
            let _r = root("test-root-a");
            spin(20);
            {
                let _l = leaf("inner");
                spin(30);
            }
            // A root inside a root (a stolen job) is its own stage and is subtracted.
            {
                let _r2 = root("test-root-b");
                spin(25);
                let _l = leaf("inner");
                spin(10);
            }
        }
        let d = before.since();
        let a = d["test-root-a"];
        let a_inner = d["test-root-a/inner"];
        let b = d["test-root-b"];
        let b_inner = d["test-root-b/inner"];
        // Each is its own spin, give or take scheduling.
        assert!((0.019..0.06).contains(&a), "{a}");
        assert!((0.029..0.07).contains(&a_inner), "{a_inner}");
        assert!((0.024..0.065).contains(&b), "{b}");
        assert!((0.009..0.05).contains(&b_inner), "{b_inner}");
        // Nothing counted twice: the parts add up to the outer wall time, not more.
        let counts = before.counts_since();
        assert_eq!(counts["test-root-a/inner"], 1);
        assert_eq!(counts["test-root-b"], 1);
    }

    #[test]
    fn leaves_outside_any_root_go_under_other() {
        let before = snapshot();
        in_leaf("test-lonely", || spin(2));
        assert!(before.since().contains_key("other/test-lonely"));
    }
}
