//! Hostile header values, generated per format and field with several values each: absurd
//! spacings, fields given twice, byte-order flags in every spelling, ASCII values out of their
//! type's range, NIfTI series, vector data and scalings, trailing bytes, volumes without a
//! finite value, data declared compressed that is not. `volasso info --json` on each gives
//! either one clear error naming the problem (exit status 1) or the sensible volume: the
//! right values and spacing, and a warning in `warnings` exactly where the reader assumed
//! something.

mod containers;
mod fields;

use crate::support::{assert_clean_error, gzip, nifti_header, volasso};
use containers::{nifti_cases, trailing_cases, value_cases};
use fields::{ascii_cases, byte_order_cases, repeated_field_cases, spacing_cases};

/// What `info` must do with a case.
enum Expect {
    /// One error line containing these words.
    Error(String),
    /// Opens with this value range and spacing, and a warning containing the words (`None`:
    /// no warning at all).
    Opens { range: [f64; 2], spacing_mm: [f64; 3], warning: Option<&'static str> },
}

fn error(words: impl Into<String>) -> Expect {
    Expect::Error(words.into())
}

fn opens(range: [f64; 2], spacing_mm: [f64; 3]) -> Expect {
    Expect::Opens { range, spacing_mm, warning: None }
}

fn warns(range: [f64; 2], spacing_mm: [f64; 3], warning: &'static str) -> Expect {
    Expect::Opens { range, spacing_mm, warning: Some(warning) }
}

/// One generated file: its name, bytes, extra `info` arguments and what must happen.
struct Case {
    name: String,
    bytes: Vec<u8>,
    args: Vec<String>,
    /// The bytes of `data.raw` beside the file, for a detached header.
    detached: Option<Vec<u8>>,
    expect: Expect,
}

fn case(name: impl Into<String>, bytes: Vec<u8>, expect: Expect) -> Case {
    Case { name: name.into(), bytes, args: Vec::new(), detached: None, expect }
}

/// A raw file opened with `--spacing`.
fn raw_with_spacing(name: String, bytes: Vec<u8>, spacing: &str, expect: Expect) -> Case {
    Case { args: vec!["--spacing".into(), spacing.into()], ..case(name, bytes, expect) }
}

/// The voxels every generated volume holds: 2 x 2 x 2 int16 values from -950 to 1050.
const VALUES: [i16; 8] = [-950, -200, 0, 40, 300, 700, 1000, 1050];
const RANGE: [f64; 2] = [-950.0, 1050.0];
const ONE_MM: [f64; 3] = [1.0; 3];

fn little(values: &[i16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn big(values: &[i16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_be_bytes()).collect()
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut encoder, bytes).unwrap();
    encoder.finish().unwrap()
}

/// An attached NRRD of [`VALUES`] with `fields` added to its header, `encoding` raw or gzip.
fn nrrd(fields: &str, encoding: &str) -> Vec<u8> {
    let data = little(&VALUES);
    nrrd_over(fields, encoding, &if encoding == "gzip" { gzip(&data) } else { data })
}

/// An attached NRRD header for 2 x 2 x 2 little-endian shorts with `fields`, over `data` as given.
fn nrrd_over(fields: &str, encoding: &str, data: &[u8]) -> Vec<u8> {
    let header =
        format!("NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: {encoding}\n{fields}\n");
    [header.as_bytes(), data].concat()
}

/// A MetaImage with `fields` before `ElementDataFile`, then `data`.
fn metaimage(fields: &str, data: &[u8]) -> Vec<u8> {
    let header = format!(
        "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n{fields}ElementDataFile = LOCAL\n"
    );
    [header.as_bytes(), data].concat()
}

/// A single-file NIfTI of [`VALUES`] (pixdim 1, scl_slope 1) with `edit` applied to its header.
fn nifti(edit: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    let mut header = nifti_header(4, 16, [2, 2, 2], 352.0);
    for axis in 0..3 {
        set_f32(&mut header, 80 + 4 * axis, 1.0);
    }
    set_f32(&mut header, 112, 1.0);
    edit(&mut header);
    [header, little(&VALUES)].concat()
}

fn set_f32(header: &mut [u8], offset: usize, value: f32) {
    header[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
}

fn set_i16(header: &mut [u8], offset: usize, value: i16) {
    header[offset..offset + 2].copy_from_slice(&value.to_le_bytes());
}

#[test]
fn hostile_header_values_give_one_clear_error_or_the_sensible_volume() {
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let groups = [
        spacing_cases(),
        repeated_field_cases(),
        byte_order_cases(),
        ascii_cases(),
        nifti_cases(),
        trailing_cases(),
        value_cases(),
    ];
    let counts: Vec<usize> = groups.iter().map(Vec::len).collect();
    let mut failures = Vec::new();
    for (index, case) in groups.into_iter().flatten().enumerate() {
        // A folder per case: raw names carry their dimensions, and names may repeat across groups.
        let case_folder = folder.path().join(index.to_string());
        std::fs::create_dir(&case_folder).unwrap();
        let path = case_folder.join(&case.name);
        std::fs::write(&path, &case.bytes).unwrap();
        if let Some(data) = &case.detached {
            std::fs::write(case_folder.join("data.raw"), data).unwrap();
        }
        let mut args = vec!["info".to_string(), path.to_str().unwrap().to_string(), "--json".to_string()];
        args.extend(case.args.iter().cloned());
        let output = volasso(&args.iter().map(String::as_str).collect::<Vec<_>>(), &cache);
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match &case.expect {
            Expect::Error(words) => assert_clean_error(&output, words, &case.name),
            Expect::Opens { range, spacing_mm, warning } => {
                let stderr = String::from_utf8_lossy(&output.stderr);
                assert!(output.status.success(), "{}: failed: {stderr}", case.name);
                let info: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
                let number = |key: &str| info[key].as_f64().unwrap();
                assert_eq!([number("value_min"), number("value_max")], *range, "{}: range", case.name);
                let spacing: Vec<f64> =
                    info["spacing_mm"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
                assert_eq!(spacing, spacing_mm.to_vec(), "{}: spacing", case.name);
                assert_eq!(
                    info["non_finite_voxels"].as_u64().unwrap() > 0,
                    case.name.starts_with("some-nan"),
                    "{}",
                    case.name
                );
                let warnings: Vec<&str> =
                    info["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap()).collect();
                match warning {
                    Some(words) => assert!(
                        warnings.len() == 1 && warnings[0].contains(words),
                        "{}: warnings {warnings:?}",
                        case.name
                    ),
                    None => assert!(warnings.is_empty(), "{}: warnings {warnings:?}", case.name),
                }
            }
        }));
        if outcome.is_err() {
            failures.push(case.name);
        }
    }
    println!(
        "hostile values: {} cases (spacing, twice, byte order, ASCII, NIfTI, trailing, values: {counts:?})",
        counts.iter().sum::<usize>()
    );
    assert!(failures.is_empty(), "{} cases failed: {failures:?}", failures.len());
}

/// A cache folder that is a file: the volume opens from memory, and the log says what is wrong
/// with the folder (not the operating system's "File exists").
#[test]
fn a_cache_folder_that_is_a_file_is_named_and_the_volume_still_opens() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("v.nrrd");
    std::fs::write(&path, nrrd("", "gzip")).unwrap();
    let file = folder.path().join("cache");
    std::fs::write(&file, b"a file").unwrap();
    let output = volasso(&["info", path.to_str().unwrap(), "--json"], &file);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("the import cache folder is unusable: it is a file, not a folder"), "{stderr}");
    assert!(!stderr.contains("File exists"), "{stderr}");
    assert_eq!(std::fs::read(&file).unwrap(), b"a file");
}
