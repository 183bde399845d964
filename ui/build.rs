//! Compiles the kiosk UI (`app.slint`) into Rust; see `src/app` of volasso.
fn main() {
    // Debug info lets the replay harness find elements by accessible label (`tap "Define
    // class"`); the software renderer draws glyphs from the fonts app.slint imports, so the
    // appliance and headless tests need no system fonts.
    // The screens' words (`@tr`) in every language under translations/ are bundled into the
    // binary (no gettext on the appliance); without a context, so one msgid is one phrase.
    let config = slint_build::CompilerConfiguration::new()
        .with_debug_info(true)
        .with_bundled_translations("translations")
        .with_default_translation_context(slint_build::DefaultTranslationContext::None);
    println!("cargo:rerun-if-changed=translations");
    if let Err(error) = slint_build::compile_with_config("app.slint", config) {
        eprintln!("ui/app.slint: {error}");
        std::process::exit(1);
    }
}
