//! Test fixtures: paths to the shared data, running the real binary.

use std::path::{Path, PathBuf};
use std::process::Output;

/// A file or folder of `../shared/data` (how CI sees the shared data beside the checkout).
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data").join(name)
}

/// Runs the `volasso` binary with `args`, with a private cache folder.
pub fn volasso(args: &[&str], cache: &Path) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_volasso"))
        .args(args)
        .env("VOLASSO_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .output()
        .expect("the volasso binary runs")
}

/// Asserts that `output` is a clean failure: non-zero exit, one `volasso: error:` line that
/// contains `expected`, and no panic.
pub fn assert_clean_error(output: &Output, expected: &str, case: &str) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success(),
        "{case}: succeeded but should fail; stdout: {}",
        String::from_utf8_lossy(&output.stdout)
    );
    assert_eq!(output.status.code(), Some(1), "{case}: exit status {:?}, stderr: {stderr}", output.status);
    assert!(!stderr.contains("panicked"), "{case}: panicked: {stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("volasso: error:")).collect();
    assert_eq!(errors.len(), 1, "{case}: expected one error line, got: {stderr}");
    assert!(
        errors[0].to_lowercase().contains(&expected.to_lowercase()),
        "{case}: error '{}' does not mention '{expected}'",
        errors[0]
    );
}
