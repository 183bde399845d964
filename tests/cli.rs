//! The `volasso` binary's contracts (`interfaces.md`): output, exit codes, atomic writes (and
//! outputs written as one unit under SIGKILL), clear errors.

use crate::support::{self, data, volasso};

#[test]
fn info_json_reports_geometry_and_a_small_anonymous_footprint() {
    let cache = tempfile::tempdir().unwrap();
    let output = volasso(&["info", data("engine_256x256x256_uint8.raw").to_str().unwrap(), "--json"], cache.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let info: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(info["dims"], serde_json::json!([256, 256, 256]));
    assert_eq!(info["type"], "uint8");
    assert_eq!(info["memory_mapped"], true);
    // The 16 MiB volume is mapped, not copied: anonymous memory stays far below its size.
    let anonymous = info["resident_memory"]["anonymous_bytes"].as_u64().unwrap();
    assert!(anonymous < 8 << 20, "anonymous resident memory {anonymous} bytes");
}

#[test]
fn import_writes_a_mappable_nrrd_and_replaces_it_atomically() {
    let folder = tempfile::tempdir().unwrap();
    let out = folder.path().join("tooth.nrrd");
    let output =
        volasso(&["import", data("tooth.nrrd").to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let imported = volasso::volume::open(&out, &Default::default()).unwrap();
    let original = volasso::volume::open(&data("tooth.nrrd"), &Default::default()).unwrap();
    assert_eq!(imported.raw_bytes(), original.raw_bytes());
    assert!(imported.is_memory_mapped());

    // A failing import leaves the existing output as it was and no temporary files behind.
    let before = std::fs::read(&out).unwrap();
    let bad = folder.path().join("bad_2x2x2_uint8.raw");
    std::fs::write(&bad, [0u8; 3]).unwrap();
    let output = volasso(&["import", bad.to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(!output.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), before);
    let leftovers: Vec<_> = std::fs::read_dir(folder.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn render_classifies_and_writes_a_png_of_the_requested_size() {
    let folder = tempfile::tempdir().unwrap();
    let out = folder.path().join("demo.png");
    // What a render killed while writing left: removed by the next run.
    let stale = folder.path().join(".demo.png.4999999-0.tmp");
    std::fs::write(&stale, b"half a PNG").unwrap();
    let strokes = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json");
    let output = volasso(
        &["render", "demo", "--strokes", strokes, "--out", out.to_str().unwrap(), "--size", "160x120"],
        folder.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(!stale.exists());
    let image = image::open(&out).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (160, 120));
    // The foot fills part of the frame: some pixels are lit, the corners are background.
    let lit = image.pixels().filter(|p| p.0[0] as u32 + p.0[1] as u32 + p.0[2] as u32 > 120).count();
    assert!(lit > 160 * 120 / 20 && lit < 160 * 120 * 3 / 4, "{lit} lit pixels");
}

#[test]
fn render_divides_an_mr_scan_s_shading_out_as_classify_does() {
    // The brain phantom's 30 % bias field: `classify` divides it out of an MR scan, and
    // `render`, which says it classifies as `classify` does, must too (a NRRD does not say its
    // modality, so both take `--modality`).
    let folder = tempfile::tempdir().unwrap();
    let phantom = volasso::phantom::procedural::brain_mri([88, 104, 80], 3).unwrap();
    let volume = folder.path().join("head.nrrd");
    support::write_u16_nrrd(&volume, &phantom.volume);
    let strokes = folder.path().join("head.strokes.json");
    volasso::phantom::lassos_inside(&phantom, &[3, 5], 2, 1.5).write(&strokes).unwrap();
    let (volume, strokes) = (volume.to_str().unwrap(), strokes.to_str().unwrap());
    let out = folder.path().join("head.png");
    let labels = folder.path().join("head-labels.nrrd");
    for (flags, divided) in
        [(&["--modality", "mr"][..], true), (&["--modality", "mr", "--keep-shading"], false), (&[], false)]
    {
        let mut args =
            vec!["render", "-v", volume, "--strokes", strokes, "--out", out.to_str().unwrap(), "--size", "96x72"];
        args.extend_from_slice(flags);
        let output = volasso(&args, folder.path());
        let log = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{flags:?}: {log}");
        assert_eq!(log.contains("shading (up to"), divided, "render {flags:?}: {log}");
        let mut args = vec!["classify", volume, "--strokes", strokes, "--out", labels.to_str().unwrap()];
        args.extend_from_slice(flags);
        let output = volasso(&args, folder.path());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(report["shading_divided_out"], divided, "classify {flags:?}");
    }
}

#[test]
fn info_json_gives_anatomical_axes_or_null_and_import_keeps_them() {
    let folder = tempfile::tempdir().unwrap();
    let info = |path: &str| -> serde_json::Value {
        let output = volasso(&["info", path, "--json"], folder.path());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        serde_json::from_slice(&output.stdout).unwrap()
    };
    let nifti = data("anatomical.nii");
    assert_eq!(info(nifti.to_str().unwrap())["anatomical_axes"], serde_json::json!(["L", "A", "S"]));
    assert_eq!(
        info(data("dicom/ge_head_tilt").to_str().unwrap())["anatomical_axes"],
        serde_json::json!(["L", "P", "S"])
    );
    assert_eq!(
        info(data("lobster_301x324x56_uint8.raw").to_str().unwrap())["anatomical_axes"],
        serde_json::Value::Null
    );
    // `import` writes the orientation as an LPS space; the NRRD reads back with the same axes.
    let out = folder.path().join("anatomical.nrrd");
    let output = volasso(&["import", nifti.to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let header = String::from_utf8_lossy(&std::fs::read(&out).unwrap()[..400]).into_owned();
    assert!(
        header.contains(
            "space: left-posterior-superior\nspace directions: (2,0,0) (0,-2,0) (0,0,2)\nspace origin: (-32,40,-16)\n"
        ),
        "{header}"
    );
    assert_eq!(info(out.to_str().unwrap())["anatomical_axes"], serde_json::json!(["L", "A", "S"]));
}

/// The run named in an output: the `# volasso run RUN` line of an NRRD, the `run` field of a
/// class table; `None` when the file is missing.
fn run_of(path: &std::path::Path) -> Option<String> {
    let bytes = std::fs::read(path).ok()?;
    if path.extension().is_some_and(|e| e == "json") {
        let table: serde_json::Value = serde_json::from_slice(&bytes).expect("a whole class table");
        return Some(table["run"].as_str().expect("the table names its run").to_string());
    }
    let header = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]).into_owned();
    let run = header.lines().find_map(|line| line.strip_prefix("# volasso run ")).expect("the header names its run");
    Some(run.to_string())
}

/// A run's start time in nanoseconds (`NANOSECONDS-PID`).
fn started(run: &str) -> u128 {
    run.split('-').next().and_then(|n| n.parse().ok()).expect("NANOSECONDS-PID")
}

fn temporaries(folder: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".tmp"))
        .collect()
}

/// `classify` killed (SIGKILL) at moments spread over a whole run: after every kill the outputs
/// on disk are each old or whole, and the newer ones are renamed first (RGBA volume, class
/// table, labels last), so labels never sit beside an older table. The next complete run
/// leaves three outputs of one run and no temporary file, its own or a killed run's.
#[test]
fn classify_killed_at_any_moment_leaves_matching_outputs_after_the_next_run() {
    let folder = tempfile::tempdir().unwrap();
    let (labels, table, rgba) =
        (folder.path().join("labels.nrrd"), folder.path().join("labels.classes.json"), folder.path().join("rgba.nrrd"));
    let strokes = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json");
    let args =
        ["classify", "demo", "--strokes", strokes, "--out", labels.to_str().unwrap(), "--rgba", rgba.to_str().unwrap()];
    let command = || {
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_volasso"));
        command.args(args).env("VOLASSO_CACHE_DIR", folder.path().join("cache")).env_remove("RUST_LOG");
        command.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
        command
    };
    let check_order = |moment: &str| {
        let (l, t, r) = (run_of(&labels), run_of(&table), run_of(&rgba));
        if let Some(l) = &l {
            let t = t.as_ref().unwrap_or_else(|| panic!("{moment}: labels without a class table"));
            assert!(started(t) >= started(l), "{moment}: labels of run {l} beside an older table {t}");
        }
        if let (Some(t), Some(r)) = (&t, &r) {
            assert!(started(r) >= started(t), "{moment}: table of run {t} beside an older RGBA volume {r}");
        }
    };
    // One whole run, to spread the kills over its length.
    let whole = std::time::Instant::now();
    assert!(command().status().unwrap().success());
    let length = whole.elapsed();
    let mut left_temporaries = 0;
    for step in 1..=8u32 {
        let mut child = command().spawn().unwrap();
        std::thread::sleep(length * step / 8);
        let _ = child.kill();
        let _ = child.wait();
        left_temporaries += usize::from(!temporaries(folder.path()).is_empty());
        check_order(&format!("kill {step} at {:?}", length * step / 8));
    }
    // A killed run of a process that is gone, whatever the kills above hit.
    std::fs::write(folder.path().join(".labels.nrrd.4999999-0.tmp"), b"half").unwrap();
    std::fs::write(folder.path().join(".rgba.nrrd.4999999-3.tmp"), b"half").unwrap();
    assert!(command().status().unwrap().success());
    let run = run_of(&labels).unwrap();
    assert_eq!((run_of(&table).unwrap(), run_of(&rgba).unwrap()), (run.clone(), run));
    assert_eq!(temporaries(folder.path()), Vec::<String>::new());
    eprintln!("run of {length:?}; {left_temporaries} of 8 kills left temporary files");
}

/// Strokes files that are wrong in ways a user makes say what is wrong; a UTF-8 byte-order
/// mark (Windows editors) is not one of them.
#[test]
fn strokes_errors_say_what_is_wrong_and_a_byte_order_mark_is_accepted() {
    let folder = tempfile::tempdir().unwrap();
    let out = folder.path().join("labels.nrrd");
    let square =
        |x: f64, size: f64| format!("[[{x},{x}],[{},{x}],[{},{}],[{x},{}]]", x + size, x + size, x + size, x + size);
    let class = |name: &str, points: &str| {
        format!(r#"{{"name":"{name}","strokes":[{{"axis":"z","slice":40,"points":{points}}}]}}"#)
    };
    let file = |classes: &[String]| format!(r#"{{"format":"volasso-strokes/1","classes":[{}]}}"#, classes.join(","));
    let cases = [
        ("no-class", file(&[]), "the strokes file defines no class"),
        (
            // Inside bone's loop but too large to be a loop drawn inside it (26 x 26 of 30 x 30).
            "over-another",
            file(&[class("bone", &square(40.0, 30.0)), class("marrow", &square(42.0, 26.0))]),
            "class 2 'marrow' select only voxels that class 1 'bone' also selects",
        ),
    ];
    for (name, text, expected) in cases {
        let path = folder.path().join(format!("{name}.json"));
        std::fs::write(&path, text).unwrap();
        let output = volasso(
            &["classify", "demo", "--strokes", path.to_str().unwrap(), "--out", out.to_str().unwrap()],
            folder.path(),
        );
        crate::support::assert_clean_error(&output, expected, name);
        assert!(!out.exists(), "{name}: nothing is written on error");
    }
    // A loop drawn inside another class's loop is that class's: nothing is contested.
    let path = folder.path().join("nested.json");
    std::fs::write(&path, file(&[class("bone", &square(40.0, 30.0)), class("marrow", &square(50.0, 5.0))])).unwrap();
    let output = volasso(
        &["classify", "demo", "--strokes", path.to_str().unwrap(), "--out", out.to_str().unwrap()],
        folder.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(summary["contested_voxels"], 0, "{summary}");
    std::fs::remove_file(&out).unwrap();
    let strokes =
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json")).unwrap();
    let path = folder.path().join("bom.json");
    std::fs::write(&path, [b"\xEF\xBB\xBF".as_slice(), &strokes].concat()).unwrap();
    let output = volasso(
        &["classify", "demo", "--strokes", path.to_str().unwrap(), "--out", out.to_str().unwrap()],
        folder.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

/// `accuracy --export`: each method's result lies beside the case's truth, one truth class a
/// voxel, and the Dice the harness printed is the Dice of those files.
#[test]
fn accuracy_export_writes_each_method_s_result_beside_the_truth() {
    let folder = tempfile::tempdir().unwrap();
    let export = folder.path().join("export");
    let args = ["accuracy", "--quick", "--cases", "foot16", "--seeds", "5", "--hands", "clean"];
    let output = volasso(
        &[&args[..], &["--methods", "default", "--json", "--export", export.to_str().unwrap()]].concat(),
        folder.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let case = export.join("foot16-5-clean");
    // A .npy file of one u8 array: its header's length is the little-endian u16 at byte 8.
    let array = |name: &str| {
        let bytes = std::fs::read(case.join(name)).unwrap();
        let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        bytes[10 + header..].to_vec()
    };
    let (truth, predicted) = (array("truth.npy"), array("predicted-default.npy"));
    assert_eq!(truth.len(), predicted.len());
    let dice = |class: u8| {
        let (t, p) = (truth.iter().filter(|&&c| c == class).count(), predicted.iter().filter(|&&c| c == class).count());
        let both = truth.iter().zip(&predicted).filter(|&(&t, &p)| t == class && p == class).count();
        2.0 * both as f64 / (t + p).max(1) as f64
    };
    let classes = printed["dice"].as_object().unwrap().len() as u8;
    let expected: Vec<f64> = (0..classes).map(dice).collect();
    let macro_dice = expected.iter().sum::<f64>() / expected.len() as f64;
    assert!((printed["macro_dice"].as_f64().unwrap() - macro_dice).abs() < 1e-9, "{printed} against {expected:?}");
}

/// `classify --save-preset` then `--preset`: the preset classifies the scan again without loops,
/// takes added loops, and a preset that does not fit (another modality, another version, a
/// file cut short, a CT preset for a scan not in Hounsfield units) is one clear error with
/// nothing written.
#[test]
fn a_saved_preset_classifies_again_and_refuses_what_it_does_not_fit() {
    let folder = tempfile::tempdir().unwrap();
    let path = |name: &str| folder.path().join(name).to_str().unwrap().to_string();
    let strokes = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json");
    let (preset, first, again) = (path("foot.volasso-preset"), path("first.nrrd"), path("again.nrrd"));
    let args =
        ["classify", "demo", "--modality", "ct", "--strokes", strokes, "--out", &first, "--save-preset", &preset];
    let output = volasso(&args, folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let saved: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(saved["saved_preset"]["scale"]["kind"], "hounsfield", "{saved}");

    let output =
        volasso(&["classify", "demo", "--modality", "ct", "--preset", &preset, "--out", &again], folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let applied: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(applied["preset"]["name"], "foot", "{applied}");
    assert_eq!(applied["classes"], saved["classes"]);
    let labels = |file: &str| {
        let bytes = std::fs::read(file).unwrap();
        let start = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
        bytes[start..].to_vec()
    };
    let (first_labels, again_labels) = (labels(&first), labels(&again));
    let same = first_labels.iter().zip(&again_labels).filter(|(a, b)| a == b).count();
    assert!(same as f64 > 0.999 * first_labels.len() as f64, "{same} of {}", first_labels.len());

    // A loop of a new class drawn on the scan joins the preset's classes.
    let extra = path("extra.json");
    std::fs::write(
        &extra,
        r#"{"format":"volasso-strokes/1","classes":[{"name":"probe","strokes":[{"axis":"z","slice":72,"points":[[60,60],[66,60],[66,66],[60,66]]}]}]}"#,
    )
    .unwrap();
    let joined = path("joined.nrrd");
    let args = ["classify", "demo", "--modality", "ct", "--preset", &preset, "--strokes", &extra, "--out", &joined];
    let output = volasso(&args, folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let classes = summary["classes"].as_array().unwrap();
    assert_eq!(classes.len(), saved["classes"].as_array().unwrap().len() + 1, "{summary}");
    assert_ne!(labels(&joined), again_labels);

    let text = std::fs::read_to_string(&preset).unwrap();
    std::fs::write(path("newer.volasso-preset"), text.replace("volasso-preset/1", "volasso-preset/9")).unwrap();
    std::fs::write(path("cut.volasso-preset"), &text[..text.len() * 2 / 3]).unwrap();
    let engine = crate::support::data("engine_256x256x256_uint8.raw");
    let engine = engine.to_str().unwrap();
    let raw = ["--dims", "256,256,256", "--type", "uint8"];
    let cases: [(&str, Vec<&str>, &str); 4] = [
        ("modality", vec!["demo", "--modality", "mr"], "trained on CT and this scan is MR"),
        ("version", vec!["demo", "--modality", "ct"], "preset of another version (volasso-preset/9)"),
        ("truncated", vec!["demo", "--modality", "ct"], "is not a readable volasso preset"),
        ("not hounsfield", [&[engine][..], &raw].concat(), "not known to be one"),
    ];
    for (case, volume, expected) in cases {
        let file = match case {
            "version" => path("newer.volasso-preset"),
            "truncated" => path("cut.volasso-preset"),
            _ => preset.clone(),
        };
        let out = path(&format!("{}.nrrd", case.replace(' ', "-")));
        let args = [&["classify"][..], &volume, &["--preset", &file, "--out", &out]].concat();
        let output = volasso(&args, folder.path());
        crate::support::assert_clean_error(&output, expected, case);
        assert!(!std::path::Path::new(&out).exists(), "{case}: nothing is written on error");
    }
}
