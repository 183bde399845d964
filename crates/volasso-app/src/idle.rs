//! The idle timeout: after [`Idle::timeout`] without a touch and without work the user waits
//! for (a volume opening, a classification, the 3-D view being drawn), the app goes back to
//! the start screen and forgets the session, once per idle period. It counts from the later of
//! the last touch and the end of that work: a slow panel must not throw away the result the
//! user is waiting for. A model fed by the poll's ticks and the touches, on the app's
//! [`crate::clock::Clock`].
//!
//! Never: reads the clock itself or clears anything; [`Idle::tick`] says when.

use std::time::Duration;

/// The idle timeout's accounting.
#[derive(Clone, Debug, PartialEq)]
pub struct Idle {
    /// `None`: never.
    pub timeout: Option<Duration>,
    /// The last touch or the last tick with work, whichever came later.
    quiet_since: Duration,
    /// The reset of this idle period happened (until the next touch).
    reset_done: bool,
}

impl Idle {
    /// The accounting of an app started at `now`: the timeout counts from the start.
    pub fn new(timeout: Option<Duration>, now: Duration) -> Idle {
        Idle { timeout, quiet_since: now, reset_done: false }
    }

    /// A touch at `now`: the timeout starts again.
    pub fn touched(&mut self, now: Duration) {
        self.quiet_since = now;
        self.reset_done = false;
    }

    /// The poll's tick at `now`, `working` when work the user waits for is under way: true
    /// when the app goes back to the start screen now.
    pub fn tick(&mut self, now: Duration, working: bool) -> bool {
        if working {
            self.quiet_since = self.quiet_since.max(now);
            return false;
        }
        let Some(timeout) = self.timeout else { return false };
        if self.reset_done || now.saturating_sub(self.quiet_since) < timeout {
            return false;
        }
        self.reset_done = true;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINUTE: Duration = Duration::from_secs(60);
    const TICK: Duration = Duration::from_millis(16);

    /// Ticks without work from `from` to `to`; the times at which the idle reset came.
    fn run(idle: &mut Idle, from: Duration, to: Duration) -> Vec<Duration> {
        let mut resets = Vec::new();
        let mut now = from;
        while now <= to {
            if idle.tick(now, false) {
                resets.push(now);
            }
            now += TICK;
        }
        resets
    }

    #[test]
    fn the_reset_comes_once_the_timeout_after_the_last_touch() {
        let mut idle = Idle::new(Some(2 * MINUTE), Duration::ZERO);
        idle.touched(MINUTE);
        let resets = run(&mut idle, MINUTE, 10 * MINUTE);
        assert_eq!(resets.len(), 1, "once per idle period: {resets:?}");
        assert!(resets[0] >= 3 * MINUTE && resets[0] < 3 * MINUTE + TICK, "{resets:?}");
        // The next touch starts a new period with its own reset.
        idle.touched(11 * MINUTE);
        let resets = run(&mut idle, 11 * MINUTE, 14 * MINUTE);
        assert_eq!(resets.len(), 1);
        assert!(resets[0] >= 13 * MINUTE && resets[0] < 13 * MINUTE + TICK, "{resets:?}");
    }

    #[test]
    fn an_untouched_app_resets_the_timeout_after_it_started() {
        let mut idle = Idle::new(Some(MINUTE), Duration::from_secs(5));
        let resets = run(&mut idle, Duration::from_secs(5), 3 * MINUTE);
        assert_eq!(resets.len(), 1);
        assert!(resets[0] >= MINUTE + Duration::from_secs(5), "{resets:?}");
    }

    #[test]
    fn work_the_user_waits_for_holds_the_timeout_off_until_it_ends() {
        let mut idle = Idle::new(Some(2 * MINUTE), Duration::ZERO);
        // A classification on a slow panel from the first to the fourth minute.
        let mut now = MINUTE;
        while now <= 4 * MINUTE {
            assert!(!idle.tick(now, true), "no reset while working, at {now:?}");
            now += TICK;
        }
        let last_work = now - TICK;
        let resets = run(&mut idle, now, 10 * MINUTE);
        assert_eq!(resets.len(), 1);
        assert!(resets[0] >= last_work + 2 * MINUTE && resets[0] < last_work + 2 * MINUTE + TICK, "{resets:?}");
    }

    #[test]
    fn without_a_timeout_the_app_never_resets() {
        let mut idle = Idle::new(None, Duration::ZERO);
        assert!(run(&mut idle, Duration::ZERO, 60 * MINUTE).is_empty());
    }

    #[test]
    fn a_touch_just_before_the_timeout_puts_it_off() {
        let mut idle = Idle::new(Some(MINUTE), Duration::ZERO);
        assert!(run(&mut idle, Duration::ZERO, MINUTE - TICK).is_empty());
        idle.touched(MINUTE - TICK);
        assert!(!idle.tick(MINUTE, false));
        assert!(idle.tick(2 * MINUTE - TICK, false));
    }
}
