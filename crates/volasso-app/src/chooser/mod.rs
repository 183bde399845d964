//! The chooser: the volumes the kiosk offers (`library.rs`: the data folder listed, each volume
//! opened and thumbnailed off the UI thread, a folder of several DICOM series split into a card
//! each), the cards as data (`cards.rs`) and what a card's tap and the loader's reports do to
//! the app (`loading.rs`, which shows the cards).
//!
//! Never: opens a file on the UI thread, or lets a file that fails take the chooser down.

pub(crate) mod cards;
pub mod library;
pub(crate) mod loading;
pub(crate) mod view;
