//! An honest remaining-time estimate for a bake's progress bar (editor and command line).
//!
//! A bake reports its progress stage by stage ([`crate::bake::pipeline::Progress`]: a stage name and
//! `done` of `total` units). The units of one stage cost about the same (views of the same
//! character at the same settings), while different stages do not, so the estimate is per
//! stage: the time the current stage has taken so far, divided by the units it has finished,
//! times the units left. It is given only once the stage has finished at least
//! [`MIN_UNITS`] units over at least [`MIN_SECONDS`], so that the start-up of a stage (the
//! first view pays for uploads and thread start) does not show as a wild guess; until then
//! the bar says that it is still measuring. The stages that follow the current one (writing,
//! other representations) are not in the figure, and the caller says so.

use std::time::{Duration, Instant};

/// Units a stage must have finished before its rate is trusted.
pub const MIN_UNITS: usize = 2;

/// Seconds a stage must have run before its rate is trusted.
pub const MIN_SECONDS: f64 = 1.0;

/// Follows a bake's progress and estimates what is left of the current stage.
#[derive(Clone, Debug, Default)]
pub struct Eta {
    stage: String,
    started: Option<Instant>,
    /// Units finished when the stage's clock started (a stage may be entered part-done).
    first_done: usize,
    done: usize,
    total: usize,
    /// When `done` was reported.
    last: Option<Instant>,
}

impl Eta {
    pub fn new() -> Self {
        Self::default()
    }

    /// Records a progress report made at `now`. A new stage name, or a count that goes
    /// backwards, restarts the stage's clock.
    pub fn update(&mut self, stage: &str, done: usize, total: usize, now: Instant) {
        if stage != self.stage || done < self.done || self.started.is_none() {
            self.stage = stage.to_owned();
            self.started = Some(now);
            self.first_done = done;
        }
        self.done = done;
        self.total = total;
        self.last = Some(now);
    }

    /// Starts on a named first stage with nothing done (`done` 0 of `total`).
    pub fn starting(stage: &str, total: usize) -> Self {
        Self {
            stage: stage.to_owned(),
            total,
            ..Self::default()
        }
    }

    /// The current stage's name.
    pub fn stage(&self) -> &str {
        &self.stage
    }

    /// Units of the current stage done, and its total.
    pub fn counts(&self) -> (usize, usize) {
        (self.done, self.total)
    }

    /// Time left in the current stage at `now`, once enough of it has run to tell (see the
    /// module documentation); zero when the stage is complete. The rate is the stage's up to
    /// its last report; the time since that report counts down from what was left then
    /// (never below zero).
    pub fn remaining(&self, now: Instant) -> Option<Duration> {
        let (started, last) = (self.started?, self.last?);
        if self.done >= self.total {
            return Some(Duration::ZERO);
        }
        let finished = self.done.saturating_sub(self.first_done);
        let elapsed = last.saturating_duration_since(started).as_secs_f64();
        if finished < MIN_UNITS || elapsed < MIN_SECONDS {
            return None;
        }
        let per_unit = elapsed / finished as f64;
        let since = now.saturating_duration_since(last).as_secs_f64();
        let left = per_unit * (self.total - self.done) as f64 - since;
        left.is_finite().then(|| Duration::from_secs_f64(left.max(0.0)))
    }

    /// "about 1 min 20 s left in this stage", "finishing this stage…" (its time is up but it
    /// has not ended: "about 0 s left" read as the whole bake's end while it went on),
    /// "measuring…" or "" when nothing is known yet.
    pub fn describe(&self, now: Instant) -> String {
        match (self.started, self.remaining(now)) {
            (None, _) => String::new(),
            (Some(_), None) => "measuring…".to_owned(),
            (Some(_), Some(d)) if d < Duration::from_secs(1) => "finishing this stage…".to_owned(),
            (Some(_), Some(d)) => format!("about {} left in this stage", human(d)),
        }
    }
}

/// A duration as people read it: "45 s", "3 min 05 s", "1 h 02 min".
pub fn human(d: Duration) -> String {
    let s = d.as_secs_f64().round() as u64;
    if s < 60 {
        format!("{s} s")
    } else if s < 3600 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{} h {:02} min", s / 3600, (s % 3600) / 60)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_stage_is_estimated_from_its_own_rate() {
        let t0 = Instant::now();
        let at = |s: f64| t0 + Duration::from_secs_f64(s);
        let mut e = Eta::new();
        e.update("key frame", 0, 4, at(0.0));
        e.update("key frame", 4, 4, at(8.0));
        // A new stage starts its own clock: the earlier, slower stage does not count.
        e.update("views", 0, 100, at(8.0));
        assert_eq!(e.remaining(at(8.0)), None, "nothing finished yet");
        e.update("views", 1, 100, at(8.5));
        assert_eq!(e.remaining(at(8.5)), None, "one unit is not a rate");
        // 10 views in 5 s: 0.5 s a view, 90 left.
        e.update("views", 10, 100, at(13.0));
        let left = e.remaining(at(13.0)).unwrap().as_secs_f64();
        assert!((left - 45.0).abs() < 1e-6, "{left}");
        assert_eq!(e.describe(at(13.0)), "about 45 s left in this stage");
        // Its time is up but the stage goes on: not "about 0 s left".
        assert_eq!(e.describe(at(100.0)), "finishing this stage…");
        // Between reports it counts down.
        assert!((e.remaining(at(23.0)).unwrap().as_secs_f64() - 35.0).abs() < 1e-6);
        assert_eq!(e.remaining(at(100.0)), Some(Duration::ZERO));
        e.update("views", 100, 100, at(58.0));
        assert_eq!(e.remaining(at(58.0)), Some(Duration::ZERO));
        assert_eq!(e.stage(), "views");
    }

    #[test]
    fn a_count_that_goes_back_restarts_the_clock() {
        let t0 = Instant::now();
        let at = |s: f64| t0 + Duration::from_secs_f64(s);
        let mut e = Eta::new();
        e.update("views", 50, 100, at(0.0));
        e.update("views", 60, 100, at(10.0));
        // Entered part-done: 10 units in 10 s, 40 left.
        assert!((e.remaining(at(10.0)).unwrap().as_secs_f64() - 40.0).abs() < 1e-6);
        e.update("views", 0, 20, at(10.0));
        e.update("views", 4, 20, at(12.0));
        assert!((e.remaining(at(12.0)).unwrap().as_secs_f64() - 8.0).abs() < 1e-6);
        assert_eq!(Eta::new().describe(at(0.0)), "");
    }

    #[test]
    fn durations_read_as_people_say_them() {
        assert_eq!(human(Duration::from_secs(45)), "45 s");
        assert_eq!(human(Duration::from_secs(185)), "3 min 05 s");
        assert_eq!(human(Duration::from_secs(3720)), "1 h 02 min");
    }
}
