//! The app's clock: real time on a panel, or time a replay script advances by hand. The
//! platform's timers and the app's own accounting (the idle timeout) read the same clock, so a
//! scripted `wait 121s` is two minutes to both.
//!
//! Never: sleeps, or is the wall-clock date (file ages use the system time).

use std::cell::Cell;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Time since the app started.
#[derive(Clone, Debug)]
pub enum Clock {
    Real(Instant),
    /// Advanced by its owner (the replay harness, a test): scripted time.
    Manual(Rc<Cell<Duration>>),
}

impl Default for Clock {
    /// Real time from now.
    fn default() -> Self {
        Clock::Real(Instant::now())
    }
}

impl Clock {
    pub fn now(&self) -> Duration {
        match self {
            Clock::Real(start) => start.elapsed(),
            Clock::Manual(now) => now.get(),
        }
    }
}
