//! Any file name given to the Open SciVis raw naming parser returns a naming or `None`, and a
//! naming it returns has dimensions whose byte count is checked without overflow.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(name) = std::str::from_utf8(data) else { return };
    if let Some(naming) = volasso::volume::raw::parse_name(name) {
        let _ = volasso::volume::checked_voxel_count(naming.dims, naming.voxel_type, std::path::Path::new(name));
    }
});
