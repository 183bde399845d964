//! Compiles the kiosk UI (`ui/app.slint`) into Rust; see `src/app`.
fn main() {
    // Debug info lets the replay harness find elements by accessible label (`tap "Define
    // class"`); the software renderer draws glyphs from the fonts ui/app.slint imports, so the
    // appliance and headless tests need no system fonts.
    let config = slint_build::CompilerConfiguration::new().with_debug_info(true);
    if let Err(error) = slint_build::compile_with_config("ui/app.slint", config) {
        eprintln!("ui/app.slint: {error}");
        std::process::exit(1);
    }
}
