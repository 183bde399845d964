//! Any bytes given to the MetaImage header parser return a header or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = volasso::volume::metaimage::parse_header(data, std::path::Path::new("fuzz.mha"));
});
