//! The replay harness: the real UI (`volasso-app` on the kiosk's own platform, `volasso-kiosk`)
//! driven headless from touch scripts and recordings on a scripted clock (`harness`, `replay`,
//! its expectations in `replay/checks.rs`), with the check that every control fits a finger
//! (`layout`). `volasso replay`, the replay tests and the image test (which compiles its touches
//! here) run it.
//!
//! Never: reads a touch device or draws on a display (the kiosk crate's DRM loop does), or
//! parses a command line.

pub mod harness;
pub mod layout;
pub mod replay;

// The other crates' modules, by the names this crate's code uses for them.
use volasso_app as app;
use volasso_core::{atomic_file, input_file, transfer};
use volasso_kiosk::kiosk::{KioskError, platform, router};
use volasso_kiosk::touch;
