//! volasso's DICOM network side and the DICOM objects it writes: the Storage SCP that receives
//! series (`receive`, `volasso receive`), the client of a PACS (`pacs`: C-FIND, C-GET or
//! C-MOVE, C-STORE, over TCP or TLS) and the Segmentation and Secondary Capture of a result
//! (`dicom_out`). The conformance statement is `docs/conformance.md`.
//!
//! Never: knows about a UI, touch input or a display (none is among this crate's
//! dependencies); volumes are read with the pipeline's reader (`volasso-core`), so what the
//! kiosk accepts and what it shows are checked by the same code.

#![warn(missing_docs)]

pub mod dicom_out;
pub mod pacs;
pub mod receive;
