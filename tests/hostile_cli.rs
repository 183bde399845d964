//! Hostile use of the command line and the kiosk, each case written by the test into a
//! temporary folder: outputs that name an input, strokes files and touch scripts that are not
//! files (a FIFO, `/dev/zero`) or not UTF-8, lassos that would cost points x rows, thousands
//! of repeated loops, 255 classes, constant volumes, and camera and size options out of
//! range. Each gives one clear error or a sensible result, and never touches an input.
//!
//! Bounded work: the heavy cases run under `RLIMIT_DATA` = 1 GB (set between fork and exec:
//! the kernel refuses the child any private writable memory beyond it) and are killed after
//! 30 s; the figure printed is the peak resident set (`VmHWM`) polled from `/proc`.

use crate::support::{assert_clean_error, volasso};
use std::io::{Read, Write};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The most a case may make `volasso` hold.
const MOST_PEAK_BYTES: u64 = 1 << 30;

/// What one bounded run did.
struct Measured {
    output: Output,
    peak_bytes: u64,
    seconds: f64,
}

/// Runs `volasso args` under `RLIMIT_DATA` = 1 GB, killed after 30 s, polling its peak.
fn run_bounded(args: &[&str], cache: &Path) -> Measured {
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
    let started = Instant::now();
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
        if started.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("volasso {args:?} ran for more than 30 s");
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let seconds = started.elapsed().as_secs_f64();
    let output = Output { status, stdout: stdout.join().unwrap(), stderr: stderr.join().unwrap() };
    eprintln!("volasso {:?}: {seconds:.2} s, peak {} MB", &args[..args.len().min(2)], peak_bytes >> 20);
    Measured { output, peak_bytes, seconds }
}

/// A raw NRRD (little-endian) of `dims` voxels whose bytes are `data`, of NRRD `kind`.
fn nrrd(path: &Path, kind: &str, dims: [usize; 3], data: &[u8]) {
    let header = format!(
        "NRRD0004\ntype: {kind}\ndimension: 3\nsizes: {} {} {}\nspacings: 1 1 1\nencoding: raw\nendian: little\n\n",
        dims[0], dims[1], dims[2]
    );
    let mut file = std::fs::File::create(path).unwrap();
    file.write_all(header.as_bytes()).unwrap();
    file.write_all(data).unwrap();
}

/// A float NRRD of `dims` with `value(x, y, z)`.
fn float_nrrd(path: &Path, dims: [usize; 3], value: impl Fn(usize, usize, usize) -> f32) {
    let bytes: Vec<u8> = (0..dims[0] * dims[1] * dims[2])
        .flat_map(|i| value(i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])).to_le_bytes())
        .collect();
    nrrd(path, "float", dims, &bytes);
}

/// Deterministic noise in -8..8.
fn noise(x: usize, y: usize, z: usize) -> f32 {
    (volasso::rng::hash64(11, (x + 1000 * (y + 1000 * z)) as u64) % 1600) as f32 / 100.0 - 8.0
}

/// A square loop x0..x0+size, y0..y0+size on axial slice `z`, as strokes-file JSON.
fn square(z: usize, x0: f64, y0: f64, size: f64) -> String {
    format!(
        r#"{{"axis": "z", "slice": {z}, "points": [[{x0}, {y0}], [{}, {y0}], [{}, {}], [{x0}, {}]]}}"#,
        x0 + size,
        x0 + size,
        y0 + size,
        y0 + size
    )
}

/// A strokes file of `classes` (name, strokes JSON).
fn strokes_json(classes: &[(String, Vec<String>)]) -> String {
    let classes: Vec<String> = classes
        .iter()
        .map(|(name, strokes)| format!(r#"{{"name": "{name}", "strokes": [{}]}}"#, strokes.join(", ")))
        .collect();
    format!(r#"{{"format": "volasso-strokes/1", "classes": [{}]}}"#, classes.join(", "))
}

/// A 32 x 32 x 8 float volume of two materials (100 left, 400 right) and its two-class strokes.
fn two_materials(folder: &Path) -> (PathBuf, PathBuf) {
    let volume = folder.join("ct.nrrd");
    float_nrrd(&volume, [32, 32, 8], |x, y, z| if x < 16 { 100.0 } else { 400.0 } + noise(x, y, z));
    let strokes = folder.join("s.json");
    let json = strokes_json(&[
        ("soft".into(), vec![square(4, 3.5, 3.5, 8.0)]),
        ("bone".into(), vec![square(4, 20.5, 20.5, 8.0)]),
    ]);
    std::fs::write(&strokes, json).unwrap();
    (volume, strokes)
}

fn text(path: &Path) -> &str {
    path.to_str().unwrap()
}

// ----- No command writes over one of its inputs.

#[test]
fn no_output_path_may_name_an_input_or_another_output() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let (volume, strokes) = two_materials(dir);
    let volume_bytes = std::fs::read(&volume).unwrap();
    let strokes_bytes = std::fs::read(&strokes).unwrap();
    // The class table beside `S.nrrd` is `S.classes.json`: here, a strokes file.
    let table_named_strokes = dir.join("t.classes.json");
    std::fs::write(&table_named_strokes, &strokes_bytes).unwrap();
    let hard_link = dir.join("hard.nrrd");
    std::fs::hard_link(&volume, &hard_link).unwrap();
    let rgba = dir.join("rgba.nrrd");
    let (t_out, l_out) = (dir.join("t.nrrd"), dir.join("l.nrrd"));
    let (v, s) = (text(&volume), text(&strokes));
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["classify", v, "--strokes", s, "--out", v], "the label volume (--out) would write over the volume"),
        (vec!["classify", v, "--strokes", s, "--out", s], "would write over the strokes file"),
        (vec!["classify", v, "--strokes", s, "--out", text(&hard_link)], "would write over the volume"),
        (
            vec!["classify", v, "--strokes", text(&table_named_strokes), "--out", text(&t_out)],
            "the class table written beside --out would write over the strokes file",
        ),
        (
            vec!["classify", v, "--strokes", s, "--out", text(&rgba), "--rgba", text(&rgba)],
            "the label volume (--out) and the RGBA volume (--rgba) are the same file",
        ),
        (vec!["classify", v, "--strokes", s, "--out", text(&l_out), "--rgba", v], "would write over the volume"),
        (vec!["render", v, "--strokes", s, "--out", v], "the image (--out) would write over the volume"),
        (vec!["render", v, "--strokes", s, "--out", s], "would write over the strokes file"),
        (vec!["import", v, "--out", v], "the imported volume (--out) would write over the source volume"),
        (vec!["import", v, "--out", text(dir)], "the imported volume (--out) is a folder"),
    ];
    for (args, expected) in cases {
        let output = volasso(&args, &dir.join("cache"));
        assert_clean_error(&output, expected, &format!("{args:?}"));
        assert_eq!(std::fs::read(&volume).unwrap(), volume_bytes, "{args:?} changed the volume");
        assert_eq!(std::fs::read(&strokes).unwrap(), strokes_bytes, "{args:?} changed the strokes");
        assert_eq!(std::fs::read(&table_named_strokes).unwrap(), strokes_bytes, "{args:?}");
        assert!(!rgba.exists() && !l_out.exists(), "{args:?} wrote an output");
    }
}

#[test]
fn a_detached_data_file_is_an_input_too() {
    // An NRRD header whose voxels lie in `ct.raw`: writing the labels there would destroy them.
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let data: Vec<u8> = (0..32 * 32 * 8).map(|i| if i % 32 < 16 { 60 } else { 200 }).collect();
    std::fs::write(dir.join("ct.raw"), &data).unwrap();
    std::fs::write(
        dir.join("ct.nhdr"),
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 32 32 8\nencoding: raw\ndata file: ct.raw\n\n",
    )
    .unwrap();
    let strokes = dir.join("s.json");
    let json = strokes_json(&[
        ("dark".into(), vec![square(4, 3.5, 3.5, 8.0)]),
        ("bright".into(), vec![square(4, 20.5, 20.5, 8.0)]),
    ]);
    std::fs::write(&strokes, json).unwrap();
    let raw = dir.join("ct.raw");
    for args in [
        vec!["classify", text(&dir.join("ct.nhdr")), "--strokes", text(&strokes), "--out", text(&raw)],
        vec!["import", text(&dir.join("ct.nhdr")), "--out", text(&raw)],
    ] {
        let output = volasso(&args, &dir.join("cache"));
        assert_clean_error(&output, "voxel data", &format!("{args:?}"));
        assert_eq!(std::fs::read(&raw).unwrap(), data, "{args:?} changed the data file");
    }
}

// ----- Strokes files and touch scripts are read only from regular files under a ceiling.

#[test]
fn strokes_and_scripts_that_are_not_regular_utf8_files_are_refused_at_once() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let (volume, _) = two_materials(dir);
    let fifo = dir.join("fifo");
    let name = std::ffi::CString::new(text(&fifo)).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
    let latin1 = dir.join("latin1.json");
    std::fs::write(
        &latin1,
        b"{\"format\": \"volasso-strokes/1\", \"classes\": [{\"name\": \"f\xe9mur\", \"strokes\": []}]}",
    )
    .unwrap();
    let utf16 = dir.join("utf16.json");
    let bytes: Vec<u8> = [0xff, 0xfe]
        .into_iter()
        .chain(r#"{"format": "volasso-strokes/1"}"#.encode_utf16().flat_map(u16::to_le_bytes))
        .collect();
    std::fs::write(&utf16, bytes).unwrap();
    // 65 MiB of nothing (a sparse file): over the ceiling, refused before it is read.
    let huge = dir.join("huge.json");
    std::fs::File::create(&huge).unwrap().set_len(65 << 20).unwrap();
    let out = dir.join("labels.nrrd");
    for (strokes, expected) in [
        (fifo.as_path(), "the strokes file is a FIFO, not a regular file"),
        (Path::new("/dev/zero"), "the strokes file is a character device, not a regular file"),
        (latin1.as_path(), "the strokes file is not UTF-8 text (it looks like a single-byte code page such as Latin-1"),
        (utf16.as_path(), "the strokes file is not UTF-8 text (it looks like UTF-16"),
        (huge.as_path(), "more than the 67108864 allowed"),
    ] {
        let measured = run_bounded(
            &["classify", text(&volume), "--strokes", text(strokes), "--out", text(&out)],
            &dir.join("cache"),
        );
        assert_clean_error(&measured.output, expected, &strokes.display().to_string());
        assert!(measured.seconds < 30.0 && measured.peak_bytes < MOST_PEAK_BYTES);
    }
    for (script, expected) in [
        (fifo.as_path(), "the touch script is a FIFO, not a regular file"),
        (Path::new("/dev/zero"), "the touch script is a character device"),
        (latin1.as_path(), "the touch script is not UTF-8 text"),
    ] {
        let measured = run_bounded(&["replay", text(script)], &dir.join("cache"));
        assert_clean_error(&measured.output, expected, &script.display().to_string());
    }
    assert!(!out.exists());
}

// ----- Bounded work: zig-zag loops, repeated loops, 255 classes.

/// A 512 x 512 x 2 uint8 volume: dark left, bright right, with noise.
fn slice_512(folder: &Path) -> PathBuf {
    let volume = folder.join("big.nrrd");
    let data: Vec<u8> = (0..512 * 512 * 2)
        .map(|i| {
            let (x, y) = (i % 512, (i / 512) % 512);
            (if x < 256 { 60.0 } else { 180.0 } + noise(x, y, i / (512 * 512))) as u8
        })
        .collect();
    nrrd(&volume, "uint8", [512, 512, 2], &data);
    volume
}

#[test]
fn a_million_point_zig_zag_loop_is_refused_within_bounds() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let volume = slice_512(dir);
    // 10^6 points, each edge from below row 0 to past row 511 (a 20 MB file).
    let points: Vec<String> = (0..1_000_000)
        .map(|k| format!("[{:.4}, {}]", k as f64 * 511.0 / 1e6, if k % 2 == 0 { -0.5 } else { 511.5 }))
        .collect();
    let zig_zag = format!(r#"{{"axis": "z", "slice": 1, "points": [{}]}}"#, points.join(","));
    let strokes = dir.join("zigzag.json");
    std::fs::write(
        &strokes,
        strokes_json(&[("zig".into(), vec![zig_zag]), ("zag".into(), vec![square(0, 4.5, 4.5, 9.0)])]),
    )
    .unwrap();
    let out = dir.join("labels.nrrd");
    let measured =
        run_bounded(&["classify", text(&volume), "--strokes", text(&strokes), "--out", text(&out)], &dir.join("cache"));
    assert_clean_error(&measured.output, "crossings of slice rows, more than the 67108864", "zig-zag");
    assert!(measured.peak_bytes < MOST_PEAK_BYTES);
}

#[test]
fn twenty_thousand_copies_of_a_full_slice_loop_classify_within_bounds() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let volume = slice_512(dir);
    let full = r#"{"axis": "z", "slice": 1, "points": [[-1, -1], [255.4, -1], [255.4, 512], [-1, 512]]}"#;
    let copies = vec![full.to_string(); 20_000];
    let strokes = dir.join("copies.json");
    std::fs::write(
        &strokes,
        strokes_json(&[("dark".into(), copies), ("bright".into(), vec![square(0, 300.5, 100.5, 60.0)])]),
    )
    .unwrap();
    let out = dir.join("labels.nrrd");
    let measured =
        run_bounded(&["classify", text(&volume), "--strokes", text(&strokes), "--out", text(&out)], &dir.join("cache"));
    let stderr = String::from_utf8_lossy(&measured.output.stderr);
    assert!(measured.output.status.success(), "{stderr}");
    let line: serde_json::Value = serde_json::from_slice(&measured.output.stdout).unwrap();
    assert_eq!(line["classes"], serde_json::json!(["dark", "bright"]));
    assert!(measured.peak_bytes < MOST_PEAK_BYTES);
}

/// A volume and strokes of `count` classes: class k lassos a 3 x 3 patch of its own value.
fn many_classes(folder: &Path, count: usize) -> (PathBuf, PathBuf) {
    let volume = folder.join("patches.nrrd");
    // 16 x 16 patches of 4 x 4 voxels on a 64 x 64 x 4 volume, patch k at value 10 k.
    float_nrrd(&volume, [64, 64, 4], |x, y, z| ((x / 4) + 16 * (y / 4)) as f32 * 10.0 + 0.05 * noise(x, y, z));
    let classes: Vec<(String, Vec<String>)> = (0..count)
        .map(|k| {
            let (x0, y0) = ((k % 16) as f64 * 4.0, (k / 16) as f64 * 4.0);
            (format!("c{k}"), vec![square(2, x0 + 0.5, y0 + 0.5, 2.0)])
        })
        .collect();
    let strokes = folder.join("many.json");
    std::fs::write(&strokes, strokes_json(&classes)).unwrap();
    (volume, strokes)
}

#[test]
fn two_hundred_fifty_five_classes_go_to_the_forest_and_the_json_line_says_so() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let (volume, strokes) = many_classes(dir, 255);
    let out = dir.join("labels.nrrd");
    let args = ["classify", text(&volume), "--strokes", text(&strokes), "--out", text(&out)];
    let measured = run_bounded(&args, &dir.join("cache"));
    let stderr = String::from_utf8_lossy(&measured.output.stderr);
    assert!(measured.output.status.success(), "{stderr}");
    let line: serde_json::Value = serde_json::from_slice(&measured.output.stdout).unwrap();
    assert_eq!(line["classifier"], "forest");
    let fallback = line["classifier_fallback"].as_str().unwrap_or_default();
    assert!(fallback.starts_with("255 classes: more than the 32 the SN-SVM classifies"), "{line}");
    assert!(measured.peak_bytes < MOST_PEAK_BYTES);

    // The SN-SVM asked for by name says why it will not, at once.
    let output = volasso(&[&args[..], &["--classifier", "snsvm"]].concat(), &dir.join("cache"));
    assert_clean_error(&output, "255 classes are more than the 32 the SN-SVM classifies", "--classifier snsvm");
    // 32 classes stay with the SN-SVM.
    let (volume, strokes) = many_classes(dir, 32);
    let output =
        volasso(&["classify", text(&volume), "--strokes", text(&strokes), "--out", text(&out)], &dir.join("cache"));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let line: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(line["classifier"], "snsvm");
    assert!(line["classifier_fallback"].is_null());
}

// ----- Classes that cannot be told apart.

#[test]
fn a_constant_volume_or_two_classes_on_one_flat_material_are_refused_clearly() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let constant = dir.join("zero.nrrd");
    nrrd(&constant, "uint8", [32, 32, 8], &[0; 32 * 32 * 8]);
    let (_, strokes) = two_materials(dir);
    let out = dir.join("labels.nrrd");
    let output = volasso(&["classify", text(&constant), "--strokes", text(&strokes), "--out", text(&out)], dir);
    assert_clean_error(&output, "the classes cannot be told apart", "constant volume");
    let output =
        volasso(&["render", text(&constant), "--strokes", text(&strokes), "--out", text(&dir.join("o.png"))], dir);
    assert_clean_error(&output, "is the volume constant?", "render a constant volume");
    // Left half flat: two loops there are one material.
    let flat = dir.join("flat.nrrd");
    float_nrrd(&flat, [32, 32, 8], |x, y, z| if x < 16 { 100.0 } else { 400.0 + noise(x, y, z) });
    let json = strokes_json(&[
        ("a".into(), vec![square(4, 3.5, 3.5, 6.0)]),
        ("b".into(), vec![square(4, 20.5, 20.5, 6.0)]),
        ("c".into(), vec![square(4, 3.5, 20.5, 6.0)]),
    ]);
    std::fs::write(&strokes, json).unwrap();
    let output = volasso(&["classify", text(&flat), "--strokes", text(&strokes), "--out", text(&out)], dir);
    assert_clean_error(&output, "classes 'a' and 'c' cannot be told apart", "one flat material");
    assert!(!out.exists());
}

#[test]
fn voxels_or_features_that_are_not_finite_are_named() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let (_, strokes) = two_materials(dir);
    let out = dir.join("labels.nrrd");
    let nan = dir.join("nan.nrrd");
    float_nrrd(&nan, [32, 32, 8], |x, y, z| if x < 12 && y < 12 { f32::NAN } else { 100.0 + noise(x, y, z) });
    let output = volasso(&["classify", text(&nan), "--strokes", text(&strokes), "--out", text(&out)], dir);
    assert_clean_error(&output, "voxel (4, 4, 4) of class 'soft' is NaN", "NaN voxels");
    let huge = dir.join("huge.nrrd");
    float_nrrd(&huge, [32, 32, 8], |x, _, _| match x {
        0..8 => 3e38,
        8..16 => -3e38,
        _ => 400.0,
    });
    let output = volasso(&["classify", text(&huge), "--strokes", text(&strokes), "--out", text(&out)], dir);
    assert_clean_error(&output, "of class 'soft' (value", "values near the float limit");
    assert_clean_error(&output, "overflow single precision", "values near the float limit");
}

// ----- Camera and size options.

#[test]
fn camera_and_size_options_are_checked_and_negative_values_read_after_a_space() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let (volume, strokes) = two_materials(dir);
    let out = dir.join("o.png");
    let render = ["render", text(&volume), "--strokes", text(&strokes), "--out", text(&out)];
    for (option, value, expected) in [
        ("--zoom", "-1", "'-1' is not a zoom from 0.25 to 8"),
        ("--zoom", "0", "is not a zoom"),
        ("--zoom", "NaN", "is not a zoom"),
        ("--azimuth", "1e308", "'1e308' is not an angle in degrees from -3600 to 3600"),
        ("--azimuth", "NaN", "is not an angle"),
        ("--elevation", "1e9", "is not an elevation in degrees from -90 to 90"),
        ("--size", "4096x4096", "'4096x4096' is not WxH with sides from 1 to 2048"),
    ] {
        let output = volasso(&[&render[..], &[option, value]].concat(), dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        // clap's usage errors: status 2, the value and why.
        assert_eq!(output.status.code(), Some(2), "{option} {value}: {stderr}");
        assert!(stderr.contains(expected), "{option} {value}: {stderr}");
        assert!(!out.exists());
    }
    let help = volasso(&["render", "--help"], dir);
    assert!(String::from_utf8_lossy(&help.stdout).contains("at most 2048 per side"));
    let labels = dir.join("l.nrrd");
    let classify = ["classify", text(&volume), "--strokes", text(&strokes), "--out", text(&labels)];
    let output = volasso(&[&classify[..], &["--cap", "0"]].concat(), dir);
    assert!(String::from_utf8_lossy(&output.stderr).contains("at least 1"));
    // A CT value below zero after a space, as a user types it.
    let output = volasso(&[&classify[..], &["--background", "-500"]].concat(), dir);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let line: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(line["background_threshold"], -500.0);
}

// ----- The kiosk.

/// The volume of `classification-fails.touch`: two materials (rows 0-23 at 100, 24-47 at
/// 400, with noise) and a column of NaN voxels at x 35-43, y 4-12 through every slice.
pub(crate) fn write_nan_column(path: &Path) {
    float_nrrd(path, [48, 48, 24], |x, y, z| {
        if (35..44).contains(&x) && (4..13).contains(&y) {
            f32::NAN
        } else {
            (if y < 24 { 100.0 } else { 400.0 }) + noise(x, y, z)
        }
    });
}

#[test]
fn a_failed_classification_shows_a_banner_and_keeps_the_last_result() {
    let work = tempfile::tempdir().unwrap();
    let volume = work.path().join("nan-column.nrrd");
    write_nan_column(&volume);
    let shots = work.path().join("shots");
    let script = crate::replay::script("classification-fails.touch");
    let report = crate::replay::replay(
        &["replay", text(&script), "--volume", text(&volume), "--screenshots", text(&shots)],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert!(shots.join("classification-failed.png").exists());
}

/// The address space the kiosk must fit: an appliance may run it under `LimitAS`.
const ADDRESS_SPACE_BYTES: u64 = 3_000_000_000;

/// `command` under `RLIMIT_AS` = [`ADDRESS_SPACE_BYTES`] (as `prlimit --as=3000000000`), set
/// between fork and exec and inherited by what it execs.
fn in_three_gigabytes(mut command: Command) -> Command {
    // SAFETY: setrlimit is async-signal-safe and touches no memory of the parent.
    unsafe {
        command.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: ADDRESS_SPACE_BYTES, rlim_max: ADDRESS_SPACE_BYTES };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    command
}

/// Runs `volasso args` (in three gigabytes) with every CPU's L3 cache reported as 480 MiB
/// (32 MiB per CPU on 15 cores, as a VM the hostile probe ran on reported it), in a mount
/// namespace of its own; `None` where mount namespaces are not allowed (not root) or there
/// is no `unshare`.
fn with_large_l3(args: &[&str], cache: &Path) -> Option<Output> {
    let size = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(size.path(), "491520K\n").unwrap();
    let script = format!(
        "for c in /sys/devices/system/cpu/cpu*/cache/index3; do mount --bind {} $c/size || exit 97; done; exec \"$@\"",
        text(size.path())
    );
    let mut command = Command::new("unshare");
    command
        .args(["-m", "sh", "-c", &script, "sh", env!("CARGO_BIN_EXE_volasso")])
        .args(args)
        .env("VOLASSO_CACHE_DIR", cache)
        .env_remove("RUST_LOG");
    let output = in_three_gigabytes(command).output().ok()?;
    (output.status.code() != Some(97) && !String::from_utf8_lossy(&output.stderr).contains("unshare failed"))
        .then_some(output)
}

/// Twelve classes defined one after another in the kiosk (eight, then four more after deleting
/// four), each classified, under a 3 GB address-space limit: the matrix product's scratch per
/// thread no longer grows with the L3 cache the machine reports (`Cargo.toml`, faer). Where
/// this runs as root it runs again with the L3 reported as 480 MiB per CPU, the case that
/// aborted ("memory allocation of 1006632960 bytes failed") before.
#[test]
#[ignore = "slow: two twelve-class kiosk runs, over a minute on 2 cores; .ci/memory runs it"]
fn twelve_classes_in_the_kiosk_fit_a_three_gigabyte_address_space() {
    let work = tempfile::tempdir().unwrap();
    let script = crate::replay::script("twelve-classes.touch");
    let cache = work.path().join("cache");
    let args = ["replay", text(&script)];
    let mut command = Command::new(env!("CARGO_BIN_EXE_volasso"));
    command.args(args).env("VOLASSO_CACHE_DIR", &cache).env_remove("RUST_LOG");
    let runs = [Some(in_three_gigabytes(command).output().unwrap()), with_large_l3(&args, &cache)];
    for output in runs.into_iter().flatten() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        assert!(!stderr.contains("memory allocation"), "{stderr}");
        let line: serde_json::Value =
            serde_json::from_str(String::from_utf8_lossy(&output.stdout).lines().last().unwrap_or_default()).unwrap();
        assert_eq!(line["failures"].as_array().map(Vec::len), Some(0), "{line}");
    }
}
