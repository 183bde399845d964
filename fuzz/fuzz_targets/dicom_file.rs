//! One DICOM file through the series reader (the element-length walk, dicom-object's parse of
//! the checked bytes, the pixel-matrix check, decoding): an error or a one-slice volume that
//! reads end to end, never a panic, an abort or memory past the ceiling.
#![no_main]
use libfuzzer_sys::fuzz_target;
use volasso::volume::dicom::{DicomOptions, list_source, read_source};
mod common;

fuzz_target!(|data: &[u8]| {
    let Some(path) = common::write_input("f.dcm", data) else { return };
    let Ok(source) = list_source(&path, &common::LIMITS) else { return };
    if let Ok(import) = read_source(&path, &source, &DicomOptions::default(), &common::LIMITS) {
        common::read_all(&import.volume);
    }
});
