//! Whole files through `volume::open`, as each format: header and data together, so the readers'
//! offset and length checks (the part that guards the memory map) and the import cache are
//! exercised too. The first byte picks the file name the open sees.
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

const NAMES: [&str; 7] = ["f.nrrd", "f.nii", "f.mha", "f.nii.gz", "f_4x4x4_uint16.raw", "f.dcm", "f.nhdr"];

fuzz_target!(|data: &[u8]| {
    let Some((&selector, contents)) = data.split_first() else { return };
    let Some(path) = common::write_input(NAMES[selector as usize % NAMES.len()], contents) else { return };
    let Some(cache) = common::folder().map(|folder| folder.join("cache")) else { return };
    let options = volasso::volume::OpenOptions {
        cache_dir: Some(cache.clone()),
        max_decoded_bytes: Some(common::LIMITS.max_decoded_bytes),
        ..Default::default()
    };
    if let Ok(volume) = volasso::volume::open(&path, &options) {
        common::read_all(&volume);
    }
    common::remove(&path);
    // Imports of compressed inputs would otherwise fill the disk over a long run.
    common::remove(&cache);
});
