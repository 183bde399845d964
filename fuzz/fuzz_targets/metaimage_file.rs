//! Whole MetaImage files (header and local raw or zlib data) through the reader: an error or a
//! volume that reads end to end, never a panic, an abort or memory past the ceiling.
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let Some(path) = common::write_input("f.mha", data) else { return };
    if let Ok(read) = volasso::volume::metaimage::read_with(&path, &common::LIMITS) {
        common::read_all(&read.volume);
    }
});
