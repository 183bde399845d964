//! Hostile files, each written by the test into a temporary folder: headers that promise
//! terabytes, skips that wrap around, data files that point at devices or outside their
//! folder, compression bombs, and DICOM files edited to lie. `volasso info` on each gives
//! exactly one clear error line, exit status 1, no panic, no abort, and peaks under 300 MB.
//!
//! Memory: the child runs under `RLIMIT_DATA` = 300 MB, set between fork and exec, so the
//! kernel refuses it any private writable memory beyond that (heap, anonymous maps, thread
//! stacks; not the read-only maps of its files). A reader that tried to hold more gets an
//! allocation failure, which is an abort or a "cannot allocate" error: either fails the case.
//! The figure printed is the largest `VmHWM` (peak resident set) polled from `/proc` every
//! millisecond once the child runs `volasso` (a lower bound, for the log). `wait4`'s
//! `ru_maxrss` cannot serve: exec carries the spawning test process's own peak into it.
//! A case that runs longer than 30 s is killed and fails.

use crate::support::{assert_clean_error, data, gzip, nifti_header};
use std::io::Read;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The most a hostile file may make `volasso info` hold.
const MOST_PEAK_BYTES: u64 = 300 << 20;

const NRRD: &str = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n";
const META: &str = "ObjectType = Image\nNDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\n";

/// What one run of the binary did.
struct Measured {
    output: std::process::Output,
    /// The largest peak resident set seen while it ran.
    peak_bytes: u64,
}

/// Runs `volasso args` with a private cache under the memory limit, polling its peak.
fn run_measured(args: &[&str], cache: &Path) -> Measured {
    let mut command = Command::new(env!("CARGO_BIN_EXE_volasso"));
    command
        .args(args)
        .env("VOLASSO_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // SAFETY: setrlimit is async-signal-safe and touches no memory of the parent.
    unsafe {
        command.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: MOST_PEAK_BYTES, rlim_max: MOST_PEAK_BYTES };
            if libc::setrlimit(libc::RLIMIT_DATA, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = command.spawn().expect("the volasso binary starts");
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut pipe) = pipe {
                let _ = pipe.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let stdout = drain(child.stdout.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let stderr = drain(child.stderr.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let status_file = format!("/proc/{}/status", child.id());
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut peak_bytes = 0u64;
    let status = loop {
        if let Ok(text) = std::fs::read_to_string(&status_file)
            && text.lines().any(|line| line.starts_with("Name:") && line.ends_with("volasso"))
            && let Some(kib) = text
                .lines()
                .find_map(|line| line.strip_prefix("VmHWM:"))
                .and_then(|value| value.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        {
            peak_bytes = peak_bytes.max(kib * 1024);
        }
        if let Some(status) = child.try_wait().expect("waiting for volasso") {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("volasso {args:?} ran for more than 30 s");
        }
        std::thread::sleep(Duration::from_millis(1));
    };
    let output = std::process::Output { status, stdout: stdout.join().unwrap(), stderr: stderr.join().unwrap() };
    Measured { output, peak_bytes }
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut encoder, bytes).unwrap();
    encoder.finish().unwrap()
}

/// The offset of the first explicit-VR little-endian element `(group,element)` with `vr`.
fn element_at(bytes: &[u8], group: u16, element: u16, vr: &[u8; 2]) -> usize {
    let mut needle = group.to_le_bytes().to_vec();
    needle.extend(element.to_le_bytes());
    needle.extend(vr);
    bytes.windows(6).position(|w| w == needle.as_slice()).expect("the element is in the file")
}

/// A copy of the first Philips slice with the US value of `(0028,element)` set to `value`.
fn philips_with(edits: &[(u16, u16)]) -> Vec<u8> {
    let mut bytes = std::fs::read(data("dicom/philips_phantom_5mm/I10")).unwrap();
    for &(element, value) in edits {
        let at = element_at(&bytes, 0x0028, element, b"US") + 8;
        bytes[at..at + 2].copy_from_slice(&value.to_le_bytes());
    }
    bytes
}

/// A folder of links to the Philips series without `left_out`, plus `extra` files.
fn philips_folder(folder: &Path, left_out: &str, extra: &[(&str, Vec<u8>)]) {
    std::fs::create_dir_all(folder).unwrap();
    for entry in std::fs::read_dir(data("dicom/philips_phantom_5mm")).unwrap() {
        let target = std::fs::canonicalize(entry.unwrap().path()).unwrap();
        let name = target.file_name().unwrap().to_owned();
        if name != left_out {
            std::os::unix::fs::symlink(&target, folder.join(name)).unwrap();
        }
    }
    for (name, bytes) in extra {
        std::fs::write(folder.join(name), bytes).unwrap();
    }
}

/// One hostile case: what to write into its folder, what to open, and what the error says.
struct Case {
    name: &'static str,
    write: Box<dyn Fn(&Path) -> PathBuf>,
    extra_args: &'static [&'static str],
    expected: &'static str,
}

fn case(name: &'static str, expected: &'static str, write: impl Fn(&Path) -> PathBuf + 'static) -> Case {
    Case { name, write: Box::new(write), extra_args: &[], expected }
}

/// A file `name` with `bytes` in the case folder.
fn file(name: &'static str, bytes: Vec<u8>) -> impl Fn(&Path) -> PathBuf {
    move |folder| {
        let path = folder.join(name);
        std::fs::write(&path, &bytes).unwrap();
        path
    }
}

fn nrrd(fields: &str, data: &[u8]) -> Vec<u8> {
    [NRRD.replace("encoding: raw\n", fields).as_bytes(), b"\n", data].concat()
}

fn cases() -> Vec<Case> {
    let zeros = vec![0u8; 64 << 20];
    let bomb = gzip(&zeros);
    let zlib_bomb = zlib(&zeros);
    let small = gzip(&[1u8; 1000]);
    vec![
        // Sizes no data can hold, in every decoded encoding.
        case("gzip-terabyte.nrrd", "can hold at most", {
            let header = NRRD.replace("10 10 10", "1000000 1000000 1000").replace("raw", "gzip");
            file("gzip-terabyte.nrrd", [header.as_bytes(), b"\n", &small].concat())
        }),
        case("ascii-terabyte.nrrd", "ASCII", {
            let header = NRRD.replace("10 10 10", "1000000 1000000 1000").replace("raw", "ascii");
            file("ascii-terabyte.nrrd", [header.as_bytes(), b"\n1 2 3 4\n"].concat())
        }),
        case(
            "byte-skip-wraps.nrrd",
            "byte skip",
            file("byte-skip-wraps.nrrd", nrrd("encoding: raw\nbyte skip: 18446744073709551615\n", &[7u8; 1000])),
        ),
        case("byte-skip-wraps-small.nrrd", "byte skip", {
            let header = NRRD.replace("10 10 10", "2 2 2") + "byte skip: 18446744073709551615\n";
            file("byte-skip-wraps-small.nrrd", [header.as_bytes(), b"\n", &[1u8; 9]].concat())
        }),
        case(
            "gzip-byte-skip.nrrd",
            "can hold at most",
            file("gzip-byte-skip.nrrd", nrrd("encoding: gzip\nbyte skip: 18446744073709551615\n", &small)),
        ),
        case(
            "line-skip.nrrd",
            "line skip",
            file("line-skip.nrrd", nrrd("encoding: raw\nline skip: 18446744073709551615\n", &[7u8; 1000])),
        ),
        // Compression bombs: 64 MiB of zeros where the header promises 1000 bytes.
        case("gzip-bomb.nrrd", "more than the 1000 bytes", file("gzip-bomb.nrrd", nrrd("encoding: gzip\n", &bomb))),
        case(
            "gzip-one-more.nrrd",
            "more than the 1000 bytes",
            file("gzip-one-more.nrrd", nrrd("encoding: gzip\n", &gzip(&[1u8; 1001]))),
        ),
        case("bad-gzip.nrrd", "gzip", file("bad-gzip.nrrd", nrrd("encoding: gzip\n", &[0x1f, 0x8b, 8, 0, 9, 9, 9]))),
        case("truncated-gzip.nrrd", "gzip", file("truncated-gzip.nrrd", nrrd("encoding: gzip\n", &small[..20]))),
        case("ascii-extra.nrrd", "more than", {
            let header = NRRD.replace("10 10 10", "2 1 1").replace("raw", "ascii");
            file("ascii-extra.nrrd", [header.as_bytes(), b"\n1 2 3\n"].concat())
        }),
        case("ascii-long-value.nrrd", "longer than", {
            let header = NRRD.replace("10 10 10", "2 1 1").replace("raw", "ascii");
            file("ascii-long-value.nrrd", [header.as_bytes(), b"\n", &[b'9'; 100_000]].concat())
        }),
        case("truncated-raw.nrrd", "truncated", file("truncated-raw.nrrd", nrrd("encoding: raw\n", &[7u8; 10]))),
        case("zero-dims.nrrd", "zero", {
            let header = NRRD.replace("10 10 10", "10 0 10");
            file("zero-dims.nrrd", [header.as_bytes(), b"\n", &[1u8; 100]].concat())
        }),
        case("negative-sizes.nrrd", "sizes", {
            let header = NRRD.replace("10 10 10", "10 -5 10");
            file("negative-sizes.nrrd", [header.as_bytes(), b"\n", &[1u8; 500]].concat())
        }),
        case("nan-spacing.nrrd", "spacing", {
            let header = NRRD.to_string() + "space dimension: 3\nspace directions: (nan,0,0) (0,1,0) (0,0,1)\n";
            file("nan-spacing.nrrd", [header.as_bytes(), b"\n", &[1u8; 1000]].concat())
        }),
        // Detached data files that are not the header's to read.
        case(
            "dev-zero.nhdr",
            "outside the header's folder",
            file("dev-zero.nhdr", nrrd("encoding: gzip\ndata file: /dev/zero\n", &[])),
        ),
        case(
            "passwd.nhdr",
            "outside the header's folder",
            file("passwd.nhdr", nrrd("encoding: raw\nbyte skip: -1\ndata file: /etc/passwd\n", &[])),
        ),
        case("parent.nhdr", "outside the header's folder", |folder: &Path| {
            std::fs::write(folder.join("../parent-data.raw"), [0u8; 1000]).unwrap();
            file("parent.nhdr", nrrd("encoding: raw\ndata file: ../parent-data.raw\n", &[]))(folder)
        }),
        case("linked.nhdr", "outside the header's folder", |folder: &Path| {
            std::os::unix::fs::symlink("/etc/passwd", folder.join("data.raw")).unwrap();
            file("linked.nhdr", nrrd("encoding: raw\nbyte skip: -1\ndata file: data.raw\n", &[]))(folder)
        }),
        Case {
            extra_args: &["--allow-external-data"],
            ..case(
                "dev-zero-allowed.nhdr",
                "not a regular file",
                file("dev-zero-allowed.nhdr", nrrd("encoding: gzip\ndata file: /dev/zero\n", &[])),
            )
        },
        case("fifo.nrrd", "not a regular file", |folder: &Path| {
            let path = folder.join("fifo.nrrd");
            let name = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
            path
        }),
        // MetaImage.
        case("zlib-terabyte.mha", "can hold at most", {
            let header =
                META.replace("10 10 10", "100000 100000 1000") + "CompressedData = True\nElementDataFile = LOCAL\n";
            file("zlib-terabyte.mha", [header.as_bytes(), &zlib(&[1u8; 100])].concat())
        }),
        case("zlib-bomb.mha", "more than the 1000 bytes", {
            let header = META.to_string() + "CompressedData = True\nElementDataFile = LOCAL\n";
            file("zlib-bomb.mha", [header.as_bytes(), &zlib_bomb].concat())
        }),
        case(
            "dev-zero.mhd",
            "outside the header's folder",
            file("dev-zero.mhd", (META.to_string() + "ElementDataFile = /dev/zero\n").into_bytes()),
        ),
        case("parent.mhd", "outside the header's folder", |folder: &Path| {
            std::fs::write(folder.join("../x.raw"), [0u8; 1000]).unwrap();
            file("parent.mhd", (META.to_string() + "ElementDataFile = ../x.raw\n").into_bytes())(folder)
        }),
        case("header-size.mha", "HeaderSize", {
            let header = META.to_string() + "HeaderSize = 18446744073709551615\nElementDataFile = LOCAL\n";
            file("header-size.mha", [header.as_bytes(), &[1u8; 1000]].concat())
        }),
        case("nan-spacing.mha", "spacing", {
            let header = META.to_string() + "ElementSpacing = nan 1 1\nElementDataFile = LOCAL\n";
            file("nan-spacing.mha", [header.as_bytes(), &[1u8; 1000]].concat())
        }),
        // NIfTI.
        case(
            "huge-dims.nii",
            "truncated",
            file("huge-dims.nii", [nifti_header(64, 64, [32767; 3], 352.0), vec![0; 1000]].concat()),
        ),
        case(
            "huge-dims.nii.gz",
            "can hold at most",
            file("huge-dims.nii.gz", gzip(&[nifti_header(64, 64, [32767; 3], 352.0), vec![0; 1000]].concat())),
        ),
        case(
            "offset-past-end.nii",
            "truncated",
            file("offset-past-end.nii", [nifti_header(2, 8, [10; 3], 4.0e9), vec![0; 1000]].concat()),
        ),
        case(
            "offset-past-end.nii.gz",
            "can hold at most",
            file("offset-past-end.nii.gz", gzip(&[nifti_header(2, 8, [10; 3], 3.0e38), vec![0; 1000]].concat())),
        ),
        case(
            "bomb.nii.gz",
            "more than the 1000 bytes",
            file("bomb.nii.gz", gzip(&[nifti_header(2, 8, [10; 3], 352.0), vec![0; 64 << 20]].concat())),
        ),
        case("linked-image.hdr", "outside the header's folder", |folder: &Path| {
            std::os::unix::fs::symlink("/dev/zero", folder.join("linked-image.img")).unwrap();
            let mut header = nifti_header(2, 8, [10; 3], 0.0);
            header[344..348].copy_from_slice(b"ni1\0");
            file("linked-image.hdr", header[..348].to_vec())(folder)
        }),
        // DICOM: copies of a real slice, edited to lie.
        case("pixel-length.dcm", "declares 4294967280 bytes", {
            let mut bytes = philips_with(&[]);
            let at = element_at(&bytes, 0x7FE0, 0x0010, b"OW");
            bytes[at + 8..at + 12].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
            file("pixel-length.dcm", bytes)
        }),
        case("item-length.dcm", "declares 4294967280 bytes", {
            let mut bytes = philips_with(&[]);
            let at = element_at(&bytes, 0x0008, 0x1111, b"SQ") + 12;
            bytes[at + 4..at + 8].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
            file("item-length.dcm", bytes)
        }),
        case(
            "rows-256.dcm",
            "PixelData holds 524288 bytes but Rows 256",
            file("rows-256.dcm", philips_with(&[(0x0010, 256)])),
        ),
        case("columns-511.dcm", "Columns 511", file("columns-511.dcm", philips_with(&[(0x0011, 511)]))),
        case(
            "bits-8.dcm",
            "BitsAllocated 8",
            file("bits-8.dcm", philips_with(&[(0x0100, 8), (0x0101, 8), (0x0102, 7)])),
        ),
        case("truncated.dcm", "truncated", file("truncated.dcm", philips_with(&[])[..5000].to_vec())),
        case("missing-slice", "the 10.00 mm gap between slices 13 and 14", |folder: &Path| {
            philips_folder(&folder.join("series"), "I140", &[]);
            folder.join("series")
        }),
        case("unreadable-slice", "a DICOM file cannot be read", |folder: &Path| {
            philips_folder(&folder.join("series"), "I140", &[("I140", philips_with(&[])[..3000].to_vec())]);
            folder.join("series")
        }),
        case("undecodable-slice", "I140 cannot be decoded", |folder: &Path| {
            let mut bytes = std::fs::read(data("dicom/philips_phantom_5mm/I140")).unwrap();
            let at = element_at(&bytes, 0x7FE0, 0x0010, b"OW");
            bytes[at + 8..at + 12].copy_from_slice(&524_286u32.to_le_bytes());
            bytes.truncate(bytes.len() - 2);
            philips_folder(&folder.join("series"), "I140", &[("I140", bytes)]);
            folder.join("series")
        }),
    ]
}

#[test]
fn hostile_files_give_one_clear_error_and_stay_small() {
    let root = tempfile::tempdir().unwrap();
    let cache = root.path().join("cache");
    let cases = cases();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut largest = (0u64, "");
    for (index, case) in cases.iter().enumerate() {
        let folder = root.path().join(format!("case{index}"));
        std::fs::create_dir(&folder).unwrap();
        let path = (case.write)(&folder);
        let mut args = vec!["info", path.to_str().unwrap()];
        args.extend(case.extra_args);
        let measured = run_measured(&args, &cache);
        assert_clean_error(&measured.output, case.expected, case.name);
        assert!(
            measured.peak_bytes < MOST_PEAK_BYTES,
            "{}: peak resident memory {} MiB",
            case.name,
            measured.peak_bytes >> 20
        );
        if measured.peak_bytes > largest.0 {
            largest = (measured.peak_bytes, case.name);
        }
    }
    println!("{} hostile cases; largest peak seen {} MiB ({})", cases.len(), largest.0 >> 20, largest.1);
}

/// The limit bites: 400 MiB decoded from a gzip NRRD (valid, and within the default ceiling)
/// cannot be allocated under it, while 64 MiB can and shows in the polled peak.
#[test]
fn the_memory_limit_refuses_more_than_300_mb() {
    let root = tempfile::tempdir().unwrap();
    let cache = root.path().join("cache");
    let write = |name: &str, size_z: usize| {
        let header =
            format!("NRRD0004\ntype: float\ndimension: 3\nsizes: 256 256 {size_z}\nendian: little\nencoding: gzip\n\n");
        let mut encoder = flate2::write::GzEncoder::new(header.into_bytes(), flate2::Compression::fast());
        let plane = vec![0u8; 256 * 256 * 4];
        for _ in 0..size_z {
            std::io::Write::write_all(&mut encoder, &plane).unwrap();
        }
        let path = root.path().join(name);
        std::fs::write(&path, encoder.finish().unwrap()).unwrap();
        path
    };
    let small = write("small.nrrd", 256);
    let measured = run_measured(&["info", small.to_str().unwrap()], &cache);
    assert!(measured.output.status.success(), "{}", String::from_utf8_lossy(&measured.output.stderr));
    assert!(measured.peak_bytes > 64 << 20, "peak {} MiB", measured.peak_bytes >> 20);
    let large = write("large.nrrd", 1600);
    let measured = run_measured(&["info", large.to_str().unwrap()], &cache);
    assert_clean_error(&measured.output, "cannot allocate 419430400 bytes", "400 MiB under the limit");
}

/// `--allow-gaps` opens a series with a missing slice and says so.
#[test]
fn a_series_with_a_missing_slice_opens_with_allow_gaps_and_a_warning() {
    let root = tempfile::tempdir().unwrap();
    let series = root.path().join("series");
    philips_folder(&series, "I140", &[]);
    let measured = run_measured(&["info", series.to_str().unwrap(), "--allow-gaps"], &root.path().join("cache"));
    let stdout = String::from_utf8_lossy(&measured.output.stdout);
    assert!(measured.output.status.success(), "{}", String::from_utf8_lossy(&measured.output.stderr));
    assert!(stdout.contains("dimensions:  512 x 512 x 28"), "{stdout}");
    assert!(stdout.contains("warning:     opened with a missing slice (--allow-gaps): the 10.00 mm gap"), "{stdout}");
}
