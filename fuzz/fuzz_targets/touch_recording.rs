//! Any bytes given to the touch recording parsers (volasso-events/1, evemu-record text) and the
//! replay script parser return a value or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = volasso::touch::format::parse(&text);
    let _ = volasso::touch::evemu::parse(&text);
    let _ = volasso::touch::script::parse(&text);
});
