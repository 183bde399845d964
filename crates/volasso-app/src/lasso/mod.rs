//! Drawing a lasso on a slice (paper §3.2): a finger's path becomes a closed loop, a tap or
//! nothing (`drawing.rs`, with the loops a path holds found in `path_loops.rs`), and what a
//! touch on a slice panel does to the work (`slices.rs`: drawing, stepping and scrubbing
//! slices, enlarging a panel, the display window; `on_slices.rs` applies it to the app).
//!
//! Never: classifies; a lasso goes to the work session, which asks for a classification.

pub mod drawing;
pub(crate) mod on_slices;
pub(crate) mod panel;
pub(crate) mod path_loops;
pub(crate) mod slices;
