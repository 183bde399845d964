//! The kiosk's screens: `app.slint` and the files it imports, compiled to Rust at build time
//! (build.rs): `AppWindow`, the `Session` global and the structs it shows. A crate of its own
//! so that the generated code is compiled once, not again for volasso's unit tests.
#![allow(clippy::all, clippy::pedantic, missing_docs, unused_qualifications)]

slint::include_modules!();
