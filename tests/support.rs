//! Test fixtures: paths to the shared data, running the real binary, bytes of test files.

use std::path::{Path, PathBuf};
use std::process::Output;

/// Runs `command` with its output captured, killing it (and failing the test) once it has run
/// longer than `limit`: a client or peer that hangs ends the test instead of the run.
pub fn run_within(command: &mut std::process::Command, limit: std::time::Duration) -> Output {
    use std::process::Stdio;
    let mut child = command.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("the command runs");
    let deadline = std::time::Instant::now() + limit;
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("{command:?} ran longer than {limit:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

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

/// `bytes` compressed as one gzip member.
pub fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut encoder, bytes).unwrap();
    encoder.finish().unwrap()
}

/// A little-endian single-file NIfTI-1 header (352 bytes with the extension flag, magic
/// `n+1`) for `dims` of `datatype` and `bitpix`, its data at `vox_offset`.
pub fn nifti_header(datatype: i16, bitpix: i16, dims: [i16; 3], vox_offset: f32) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    h[40..42].copy_from_slice(&3i16.to_le_bytes());
    for (i, d) in dims.iter().enumerate() {
        h[42 + 2 * i..44 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&datatype.to_le_bytes());
    h[72..74].copy_from_slice(&bitpix.to_le_bytes());
    h[108..112].copy_from_slice(&vox_offset.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

/// Writes `volume` (8-bit, little-endian as stored) as a raw NRRD with its spacing.
pub fn write_u8_nrrd(path: &Path, volume: &volasso::volume::Volume) {
    assert_eq!(volume.voxel_type, volasso::volume::VoxelType::U8);
    write_nrrd(path, volume, "uint8");
}

/// Writes `volume` (16-bit unsigned, little-endian as stored) as a raw NRRD with its spacing.
pub fn write_u16_nrrd(path: &Path, volume: &volasso::volume::Volume) {
    assert_eq!(volume.voxel_type, volasso::volume::VoxelType::U16);
    assert_eq!(volume.byte_order, volasso::volume::ByteOrder::Little);
    write_nrrd(path, volume, "uint16");
}

fn write_nrrd(path: &Path, volume: &volasso::volume::Volume, type_name: &str) {
    let [x, y, z] = volume.dims;
    let [sx, sy, sz] = volume.spacing_mm;
    let header = format!(
        "NRRD0004\ntype: {type_name}\ndimension: 3\nsizes: {x} {y} {z}\nspacings: {sx} {sy} {sz}\nendian: little\nencoding: raw\n\n"
    );
    std::fs::write(path, [header.as_bytes(), volume.raw_bytes()].concat()).unwrap();
}
