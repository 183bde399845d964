//! The volasso kiosk's platform: the app (`volasso-app`) shown on a DRM display with touch read
//! from evdev (`display`, `touch`, `kiosk::drm_loop`), touches routed to the UI
//! (`kiosk::router`), and touch scripts and recordings as data (`touch::script`,
//! `touch::format`). The replay harness that drives the same platform headless is the crate
//! `volasso-replay`.
//!
//! Never: parses a command line or reads the settings file (the `volasso` binary does, and
//! hands the app its set-up); the app crate knows nothing of this one, so cargo refuses an
//! import of the DRM or touch code from the app.

pub mod display;
pub mod kiosk;
pub mod touch;

// The pipeline's and the app's modules, by the names this crate's code uses for them.
use volasso_app as app;
use volasso_core::{input_file, rng, slices, strokes, transfer, volume};
