//! Whole NIfTI-1 files through the reader; the first byte picks `.nii` or `.nii.gz` (the rest
//! is the file, gzip or not). An error or a volume that reads end to end, never a panic, an
//! abort or memory past the ceiling.
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, contents)) = data.split_first() else { return };
    let name = if selector % 2 == 0 { "f.nii" } else { "f.nii.gz" };
    let Some(path) = common::write_input(name, contents) else { return };
    if let Ok(read) = volasso::volume::nifti::read_with(&path, &common::LIMITS) {
        common::read_all(&read.volume);
    }
});
