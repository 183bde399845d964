//! Drawing a lasso on a slice (paper §3.2): a finger's path becomes a closed loop, a tap or
//! nothing (`drawing.rs`, with the loops a path holds found in `path_loops.rs`), and what a
//! touch on a slice panel does to the work (`slices.rs`: drawing, stepping and scrubbing
//! slices, enlarging a panel, the display window; `slice_actions.rs` shows it).
//!
//! Never: classifies; a lasso goes to the work session, which asks for a classification.

pub mod drawing;
pub(crate) mod path_loops;
pub(crate) mod slice_actions;
pub(crate) mod slices;
