//! Malformed inputs, each written by the test: every one gives exactly one clear error line
//! naming the problem, exit status 1, and no panic.

use crate::support::{assert_clean_error, gzip, nifti_header, volasso};
use std::path::Path;

const NRRD: &str = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n";

fn with_data(header: &str, data_len: usize) -> Vec<u8> {
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend(std::iter::repeat_n(7u8, data_len));
    bytes
}

/// (file name, contents, words the error must contain)
fn cases() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let gz_data = gzip(&[1u8; 1000]);
    vec![
        ("empty.nrrd", Vec::new(), "NRRD0001"),
        ("truncated.nrrd", with_data(NRRD, 500), "truncated"),
        ("lying-type.nrrd", with_data(&NRRD.replace("uint8", "int32\nendian: little"), 1000), "4000 bytes"),
        ("zero-size.nrrd", with_data(&NRRD.replace("10 10 10", "10 0 10"), 1000), "zero"),
        ("overflow.nrrd", with_data(&NRRD.replace("10 10 10", "99999999999 99999999999 99999999999"), 10), "overflow"),
        ("negative-size.nrrd", with_data(&NRRD.replace("10 10 10", "10 -5 10"), 10), "sizes"),
        ("bzip2.nrrd", with_data(&NRRD.replace("raw", "bzip2"), 10), "encoding"),
        ("int64.nrrd", with_data(&NRRD.replace("uint8", "int64"), 10), "int64"),
        ("no-endian.nrrd", with_data(&NRRD.replace("uint8", "short"), 2000), "endian"),
        (
            "missing-detached.nhdr",
            NRRD.replace("encoding: raw\n", "encoding: raw\ndata file: nowhere.raw\n").into_bytes(),
            "nowhere.raw",
        ),
        ("corrupt-gzip.nrrd", with_data(&NRRD.replace("raw", "gzip"), 200), "gzip"),
        (
            "truncated-gzip.nrrd",
            [NRRD.replace("raw", "gzip").as_bytes(), &gz_data[..gz_data.len() / 2]].concat(),
            "gzip",
        ),
        ("short-gzip.nrrd", [NRRD.replace("raw", "gzip").as_bytes(), &gzip(&[1u8; 10])].concat(), "truncated"),
        ("binary-header.nrrd", [b"NRRD0004\n".as_slice(), &[0xff, 0xfe, 0x00, 0x10, b'\n', b'\n']].concat(), "header"),
        ("no-blank-line.nrrd", NRRD.trim_end().as_bytes().to_vec(), "blank line"),
        (
            "dimension-5.nrrd",
            with_data(&NRRD.replace("dimension: 3\nsizes: 10 10 10", "dimension: 5\nsizes: 1 2 3 4 5"), 200),
            "dimension",
        ),
        ("short-header.nii", vec![0u8; 100], "348"),
        ("truncated.nii", [nifti_header(2, 8, [10, 10, 10], 352.0), vec![0u8; 500]].concat(), "truncated"),
        ("datatype.nii", [nifti_header(1024, 8, [10, 10, 10], 352.0), vec![0u8; 1000]].concat(), "datatype"),
        ("offset-beyond.nii", [nifti_header(2, 8, [10, 10, 10], 1.0e9), vec![0u8; 1000]].concat(), "truncated"),
        ("negative-dim.nii", nifti_header(2, 8, [10, -10, 10], 352.0), "dim[2]"),
        ("truncated.nii.gz", gzip(&[nifti_header(4, 16, [10, 10, 10], 352.0), vec![0u8; 100]].concat()), "truncated"),
        (
            "lonely.hdr",
            nifti_header(2, 8, [10, 10, 10], 0.0)
                .into_iter()
                .take(348)
                .collect::<Vec<u8>>()
                .iter()
                .enumerate()
                .map(|(i, &b)| if (344..347).contains(&i) { b"ni1"[i - 344] } else { b })
                .collect(),
            "lonely.img",
        ),
        (
            "truncated.mha",
            with_data("NDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 999),
            "truncated",
        ),
        (
            "long.mha",
            with_data("NDims = 3\nDimSize = 10 10 10\nElementType = MET_ULONG_LONG\nElementDataFile = LOCAL\n", 8000),
            "ElementType",
        ),
        (
            "missing.mhd",
            b"NDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\nElementDataFile = absent.raw\n".to_vec(),
            "absent.raw",
        ),
        ("short_10x10x10_uint8.raw", vec![0u8; 999], "truncated"),
        ("long_10x10x10_uint8.raw", vec![0u8; 1001], "1000 bytes"),
        ("no-convention.raw", vec![0u8; 1000], "--dims"),
        ("mystery.bin", b"just some bytes, no header here".to_vec(), "cannot tell the format"),
    ]
}

#[test]
fn every_malformed_input_gives_one_clear_error() {
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let cases = cases();
    assert!(cases.len() > 20);
    for (name, contents, expected) in &cases {
        let path = folder.path().join(name);
        std::fs::write(&path, contents).unwrap();
        let output = volasso(&["info", path.to_str().unwrap()], &cache);
        assert_clean_error(&output, expected, name);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(name) || stderr.contains(expected), "{name}: the error names the file: {stderr}");
    }
}

#[test]
fn options_and_paths_that_cannot_work_give_clear_errors() {
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let raw = folder.path().join("data.bin");
    std::fs::write(&raw, [0u8; 1000]).unwrap();
    let raw = raw.to_str().unwrap();
    for (args, expected) in [
        (vec!["info", "/nonexistent/volume.nrrd"], "/nonexistent/volume.nrrd"),
        (vec!["info", raw, "--dims", "10,10,10"], "--type"),
        (vec!["info", raw, "--dims", "10,10,11", "--type", "uint8"], "1100 bytes"),
        (vec!["info", raw, "--dims", "5,10,10", "--type", "uint16", "--spacing", "1,1,1"], "1000"),
    ] {
        let output = volasso(&args, &cache);
        if expected == "1000" {
            assert!(output.status.success(), "{args:?} is valid: {}", String::from_utf8_lossy(&output.stderr));
            continue;
        }
        assert_clean_error(&output, expected, &args.join(" "));
    }
    // Usage errors (clap) exit with status 2 and never touch a file.
    let output = volasso(&["info", raw, "--dims", "10,0,10", "--type", "uint8"], &cache);
    assert_eq!(output.status.code(), Some(2));
    assert!(!Path::new(&cache).exists(), "nothing was cached");
}
