//! `volasso pacs find|get|send` against a real PACS: Orthanc, started here on free loopback
//! ports with a configuration written by the test (its DICOM port and AE title, the kiosk as a
//! known modality, storage in a temporary folder, REST on loopback without authentication),
//! loaded with the Philips series through dcmtk's `storescu`, and stopped by its PID when the
//! test ends however it ends. Without Orthanc or dcmtk the tests say so and are skipped
//! (`.ci/run` installs both).

use crate::dicom_codecs::dcmtk_available;
use crate::dicom_export::{attribute, classify_philips, classify_series, export, philips};
use crate::support::{assert_clean_error, run_within};
use dicom_dictionary_std::tags::{SERIES_INSTANCE_UID, SOP_INSTANCE_UID, STUDY_INSTANCE_UID};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The longest Orthanc may take to open its REST port, and a client to finish.
const PATIENCE: Duration = Duration::from_secs(30);

/// A running Orthanc, killed (by PID) and waited for when dropped.
pub(crate) struct Orthanc {
    child: Child,
    dicom_port: u16,
    http_port: u16,
    folder: tempfile::TempDir,
}

/// A TCP port nobody listens on at this moment.
pub(crate) fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

impl Orthanc {
    /// Starts Orthanc (AE title ORTHANC; the kiosk, VOLASSO, a known modality) with the Lua
    /// script `lua`, if any; `None` when Orthanc is not installed.
    pub(crate) fn start(lua: Option<&str>) -> Option<Orthanc> {
        Orthanc::start_configured(lua, 11112, true)
    }

    /// An Orthanc that knows the kiosk (AE title VOLASSO) at `kiosk_port` on loopback, the
    /// destination of its C-MOVEs, and answers the kiosk's C-GETs only when `allow_get`.
    pub(crate) fn start_configured(lua: Option<&str>, kiosk_port: u16, allow_get: bool) -> Option<Orthanc> {
        if Command::new("Orthanc").arg("--version").output().is_err() {
            eprintln!("SKIPPED: Orthanc is not installed (apt-get install orthanc; .ci/run installs it)");
            return None;
        }
        let folder = tempfile::tempdir().unwrap();
        let (dicom_port, http_port) = (free_port(), free_port());
        let storage = folder.path().join("storage");
        let mut lua_scripts = Vec::new();
        if let Some(script) = lua {
            let path = folder.path().join("filter.lua");
            std::fs::write(&path, script).unwrap();
            lua_scripts.push(path);
        }
        let configuration = serde_json::json!({
            "Name": "volasso-test",
            "StorageDirectory": storage,
            "IndexDirectory": storage,
            "DicomAet": "ORTHANC",
            "DicomPort": dicom_port,
            "HttpPort": http_port,
            "RemoteAccessAllowed": false,
            "AuthenticationEnabled": false,
            "DicomCheckCalledAet": true,
            "DicomAlwaysAllowStore": true,
            "DicomAlwaysAllowEcho": true,
            "DicomModalities": {"kiosk": {"AET": "VOLASSO", "Host": "127.0.0.1", "Port": kiosk_port,
                "AllowEcho": true, "AllowFind": true, "AllowGet": allow_get, "AllowMove": true, "AllowStore": true}},
            "DicomCheckModalityHost": true,
            "LuaScripts": lua_scripts,
            "Plugins": [],
            "SaveJobs": false,
        });
        let config = folder.path().join("orthanc.json");
        std::fs::write(&config, configuration.to_string()).unwrap();
        let log = std::fs::File::create(folder.path().join("orthanc.log")).unwrap();
        let child =
            Command::new("Orthanc").arg(&config).stdout(Stdio::null()).stderr(log).spawn().expect("Orthanc starts");
        let orthanc = Orthanc { child, dicom_port, http_port, folder };
        let deadline = Instant::now() + PATIENCE;
        while orthanc.rest("/system").is_none() {
            assert!(Instant::now() < deadline, "Orthanc did not open its REST port: {}", orthanc.log());
            std::thread::sleep(Duration::from_millis(100));
        }
        Some(orthanc)
    }

    pub(crate) fn log(&self) -> String {
        std::fs::read_to_string(self.folder.path().join("orthanc.log")).unwrap_or_default()
    }

    /// `ORTHANC@127.0.0.1:PORT`.
    pub(crate) fn address(&self) -> String {
        format!("ORTHANC@127.0.0.1:{}", self.dicom_port)
    }

    /// GET on the REST API (Python's urllib), as JSON; `None` when it does not answer.
    fn rest(&self, path: &str) -> Option<serde_json::Value> {
        let url = format!("http://127.0.0.1:{}{path}", self.http_port);
        let script =
            "import sys, urllib.request; print(urllib.request.urlopen(sys.argv[1], timeout=5).read().decode())";
        let output = Command::new("python3").args(["-c", script, &url]).output().ok()?;
        output.status.success().then(|| serde_json::from_slice(&output.stdout).ok()).flatten()
    }

    /// (SeriesInstanceUID, Modality) of every series of every study, from the REST API.
    pub(crate) fn series(&self) -> Vec<(String, String, String)> {
        let mut found = Vec::new();
        for study in self.rest("/studies?expand").unwrap().as_array().unwrap() {
            let study_uid = study["MainDicomTags"]["StudyInstanceUID"].as_str().unwrap().to_string();
            for id in study["Series"].as_array().unwrap() {
                let series = self.rest(&format!("/series/{}", id.as_str().unwrap())).unwrap();
                let tags = &series["MainDicomTags"];
                found.push((
                    study_uid.clone(),
                    tags["SeriesInstanceUID"].as_str().unwrap().to_string(),
                    tags["Modality"].as_str().unwrap_or_default().to_string(),
                ));
            }
        }
        found.sort();
        found
    }

    /// Loads the Philips series through dcmtk's storescu.
    pub(crate) fn load_philips(&self) {
        let files: Vec<PathBuf> = std::fs::read_dir(philips())
            .unwrap()
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.file_name().is_some_and(|name| name != "DIRFILE"))
            .collect();
        let output = run_within(
            Command::new("storescu").args(["-aec", "ORTHANC", "127.0.0.1", &self.dicom_port.to_string()]).args(&files),
            PATIENCE,
        );
        assert!(output.status.success(), "storescu: {}", String::from_utf8_lossy(&output.stderr));
        assert_eq!(self.rest("/statistics").unwrap()["CountInstances"], 28, "{}", self.log());
    }
}

impl Drop for Orthanc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `volasso pacs ARGS` with a bounded run time.
fn pacs(args: &[&str], cache: &Path) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_volasso"));
    command.arg("pacs").args(args).env("VOLASSO_CACHE_DIR", cache).env_remove("RUST_LOG").env_remove("VOLASSO_PACS");
    run_within(&mut command, PATIENCE)
}

fn json_lines(output: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(|line| serde_json::from_str(line).expect("a JSON line"))
        .collect()
}

/// A small opaque PNG for the Secondary Capture.
fn picture(path: &Path) {
    let image = image::RgbaImage::from_fn(64, 48, |x, y| image::Rgba([(x * 4) as u8, (y * 5) as u8, 128, 255]));
    image.save(path).unwrap();
}

#[test]
fn a_study_found_retrieved_classified_exported_and_sent_back_lands_in_the_pacs_study() {
    if !dcmtk_available() {
        return;
    }
    let Some(orthanc) = Orthanc::start(None) else { return };
    orthanc.load_philips();
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let source = philips().join("I10");
    let study = attribute(&source, STUDY_INSTANCE_UID);
    let series = attribute(&source, SERIES_INSTANCE_UID);

    // find: the study, with its one series of 28 images; nothing for MR or a later date.
    let output = pacs(&["find", "--pacs", &orthanc.address()], &cache);
    assert!(output.status.success(), "find: {}", String::from_utf8_lossy(&output.stderr));
    let studies = json_lines(&output);
    assert_eq!(studies.len(), 1, "{studies:?}");
    assert_eq!(studies[0]["study_uid"], study.as_str());
    assert_eq!(studies[0]["modalities"], serde_json::json!(["CT"]));
    let listed = studies[0]["series"].as_array().unwrap();
    assert_eq!(listed.len(), 1, "{studies:?}");
    assert_eq!(listed[0]["series_uid"], series.as_str());
    assert_eq!((listed[0]["modality"].as_str(), listed[0]["images"].as_u64()), (Some("CT"), Some(28)));
    assert!(!String::from_utf8_lossy(&output.stdout).contains("PLASTIC"), "a patient ID was printed");
    for filter in [["--modality", "MR"], ["--since", "20990101"], ["--patient-id", "NOBODY"]] {
        let output = pacs(&["find", "--pacs", &orthanc.address(), filter[0], filter[1]], &cache);
        assert!(output.status.success() && output.stdout.is_empty(), "find {filter:?}: {output:?}");
    }
    let output = pacs(&["find", "--pacs", &orthanc.address(), "--patient-id", "PLASTIC"], &cache);
    assert_eq!(json_lines(&output).len(), 1, "{output:?}");

    // get: the study into a data folder, published as a received series, voxels as the source's.
    let data_dir = folder.path().join("data");
    let output = pacs(&["get", "--pacs", &orthanc.address(), "--data-dir", data_dir.to_str().unwrap(), &study], &cache);
    assert!(output.status.success(), "get: {}", String::from_utf8_lossy(&output.stderr));
    let reports = json_lines(&output);
    assert_eq!(reports.len(), 1, "{reports:?}");
    assert_eq!(reports[0]["event"], "stored", "{reports:?}");
    assert_eq!((reports[0]["images"].as_u64(), reports[0]["series_uid"].as_str()), (Some(28), Some(series.as_str())));
    let retrieved = PathBuf::from(reports[0]["path"].as_str().unwrap());
    assert_eq!(retrieved.parent(), Some(data_dir.as_path()));
    let visible: Vec<_> = std::fs::read_dir(&data_dir)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| !name.starts_with('.'))
        .collect();
    assert_eq!(visible.len(), 1, "{visible:?}");
    assert_is_the_philips_series(&retrieved);

    // Only one series, by its UID, retrieves the same; an unknown UID retrieves nothing.
    let again = folder.path().join("again");
    let output =
        pacs(&["get", "--pacs", &orthanc.address(), "--data-dir", again.to_str().unwrap(), &study, &series], &cache);
    assert_eq!(json_lines(&output).len(), 1, "{output:?}");
    let output = pacs(&["get", "--pacs", &orthanc.address(), "--data-dir", again.to_str().unwrap(), "1.2.3.4"], &cache);
    assert_clean_error(&output, "C-GET", "an unknown study");

    // classify the retrieved series, export a SEG and an SC, send both back.
    let labels = classify_series(folder.path(), &retrieved);
    let (seg, sc, png) = (folder.path().join("seg.dcm"), folder.path().join("sc.dcm"), folder.path().join("view.png"));
    picture(&png);
    let outputs = ["--seg", seg.to_str().unwrap(), "--sc", sc.to_str().unwrap(), "--sc-image", png.to_str().unwrap()];
    let output = export(folder.path(), &retrieved, &labels, &outputs);
    assert!(output.status.success(), "export: {}", String::from_utf8_lossy(&output.stderr));
    let output = pacs(&["send", "--pacs", &orthanc.address(), seg.to_str().unwrap(), sc.to_str().unwrap()], &cache);
    assert!(output.status.success(), "send: {}", String::from_utf8_lossy(&output.stderr));
    let sent = json_lines(&output);
    assert_eq!(sent.len(), 2, "{sent:?}");
    for (line, file) in sent.iter().zip([&seg, &sc]) {
        assert_eq!((line["stored"].as_bool(), line["status"].as_str()), (Some(true), Some("0000")), "{line}");
        assert_eq!(line["sop_instance_uid"], attribute(file, SOP_INSTANCE_UID).as_str());
    }

    // Orthanc lists the two new series in the study.
    let expected = vec![
        (study.clone(), attribute(&seg, SERIES_INSTANCE_UID), "SEG".to_string()),
        (study.clone(), attribute(&sc, SERIES_INSTANCE_UID), "OT".to_string()),
        (study.clone(), series.clone(), "CT".to_string()),
    ];
    let mut expected = expected;
    expected.sort();
    assert_eq!(orthanc.series(), expected);
}

#[test]
fn a_pacs_that_is_down_refuses_or_fails_a_store_gives_one_error_and_nothing_half_sent_is_reported_sent() {
    if !dcmtk_available() {
        return;
    }
    // Orthanc fails every Secondary Capture (modality OT) it is sent. (A filter that returns
    // false discards the instance but answers success; an error in the filter answers A700H.)
    let lua = "function ReceivedInstanceFilter(dicom, origin, info)\n  if dicom.Modality == 'OT' then\n    \
               error('this PACS takes no Secondary Capture')\n  end\n  return true\nend\n";
    let Some(orthanc) = Orthanc::start(Some(lua)) else { return };
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let data_dir = folder.path().join("data");
    let labels = classify_philips(folder.path());
    let (seg, sc, png) = (folder.path().join("seg.dcm"), folder.path().join("sc.dcm"), folder.path().join("view.png"));
    picture(&png);
    let outputs = ["--seg", seg.to_str().unwrap(), "--sc", sc.to_str().unwrap(), "--sc-image", png.to_str().unwrap()];
    let output = export(folder.path(), &philips(), &labels, &outputs);
    assert!(output.status.success(), "export: {}", String::from_utf8_lossy(&output.stderr));
    let (seg_text, sc_text) = (seg.to_str().unwrap(), sc.to_str().unwrap());

    // Down: nothing listens on the port.
    let down = format!("ORTHANC@127.0.0.1:{}", free_port());
    for args in [
        vec!["find", "--pacs", &down],
        vec!["get", "--pacs", &down, "--data-dir", data_dir.to_str().unwrap(), "1.2.3"],
        vec!["send", "--pacs", &down, seg_text],
    ] {
        let output = pacs(&args, &cache);
        assert_clean_error(&output, "no association with the PACS", &format!("{} to a PACS that is down", args[0]));
        assert!(output.stdout.is_empty(), "{output:?}");
    }
    // Refused: the PACS does not answer to that AE title.
    let wrong = format!("NOTORTHANC@127.0.0.1:{}", orthanc.dicom_port);
    let output = pacs(&["send", "--pacs", &wrong, seg_text], &cache);
    assert_clean_error(&output, "association rejected", "a called AE title the PACS does not have");
    assert!(output.stdout.is_empty(), "{output:?}");
    assert!(orthanc.series().is_empty(), "{:?}", orthanc.series());

    // A C-STORE answered with a failure: that file is reported not stored, the other stored.
    let output = pacs(&["send", "--pacs", &orthanc.address(), seg_text, sc_text], &cache);
    assert_clean_error(&output, "1 of 2 files were not stored", "a refused Secondary Capture");
    let sent = json_lines(&output);
    assert_eq!(sent.len(), 2, "{sent:?}");
    assert_eq!((sent[0]["stored"].as_bool(), sent[0]["status"].as_str()), (Some(true), Some("0000")), "{sent:?}");
    assert_eq!(sent[1]["stored"].as_bool(), Some(false), "{sent:?}");
    let status = u16::from_str_radix(sent[1]["status"].as_str().unwrap(), 16).unwrap();
    assert!(status != 0 && status & 0xF000 != 0xB000, "a failure status: {sent:?}");
    let held: Vec<String> = orthanc.series().into_iter().map(|(_, _, modality)| modality).collect();
    assert_eq!(held, vec!["SEG".to_string()], "only the stored file is in the PACS");

    // A file that is not DICOM is refused before any association.
    let output = pacs(&["send", "--pacs", &orthanc.address(), labels.to_str().unwrap()], &cache);
    assert_clean_error(&output, "not a DICOM file", "a NRRD sent");
}

#[test]
fn a_peer_that_accepts_the_connection_and_never_answers_is_given_up_after_the_timeout() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    // Holds every connection open without a byte, until the test ends.
    std::thread::spawn(move || {
        let mut held = Vec::new();
        for stream in listener.incoming().take(4) {
            held.push(stream);
        }
    });
    let folder = tempfile::tempdir().unwrap();
    let silent = format!("SILENT@127.0.0.1:{port}");
    let started = Instant::now();
    let output = pacs(&["find", "--pacs", &silent, "--timeout", "1"], folder.path());
    assert_clean_error(&output, "did not answer the association request within 1 s", "a silent peer");
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
}

/// A PACS that refuses the kiosk C-GET (Orthanc without AllowGet, which aborts the association)
/// sends by C-MOVE to the kiosk's own receiver instead: `volasso pacs get` prints the series the
/// receiver published, and its voxels are the source's.
#[test]
fn a_pacs_without_c_get_sends_by_c_move_to_the_kiosk_s_receiver() {
    if !dcmtk_available() {
        return;
    }
    let receiver = crate::dicom_receive::Scp::start(&[]);
    let Some(orthanc) = Orthanc::start_configured(None, receiver.port, false) else { return };
    orthanc.load_philips();
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let study = attribute(&philips().join("I10"), STUDY_INSTANCE_UID);
    let data_dir = receiver.data_dir.to_str().unwrap().to_string();
    let output = pacs(&["get", "--pacs", &orthanc.address(), "--data-dir", &data_dir, &study], &cache);
    assert!(output.status.success(), "get: {}\n{}", String::from_utf8_lossy(&output.stderr), orthanc.log());
    assert!(orthanc.log().contains("Get is not allowed"), "the C-GET was refused: {}", orthanc.log());
    let lines = json_lines(&output);
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert_eq!(lines[0]["event"], "stored");
    assert_eq!(lines[0]["dims"], serde_json::json!([512, 512, 28]));
    assert_eq!(lines[0]["pacs"], orthanc.address());
    assert_is_the_philips_series(Path::new(lines[0]["path"].as_str().unwrap()));
}

/// The series at `retrieved` reads to the Philips series' voxels, type and spacing.
fn assert_is_the_philips_series(retrieved: &Path) {
    let options = volasso::volume::dicom::DicomOptions::default();
    let original = volasso::volume::dicom::read_series(&philips(), &options).unwrap().volume;
    let copy = volasso::volume::dicom::read_series(retrieved, &options).unwrap().volume;
    assert_eq!((copy.dims, copy.voxel_type), (original.dims, original.voxel_type));
    assert!(copy.raw_bytes() == original.raw_bytes(), "the retrieved voxels differ from the source's");
    assert_eq!(copy.spacing_mm, original.spacing_mm);
}

/// Several PACS (`--pacs` twice, or separated by commas): `find` asks each and still lists the
/// studies of the one that answers when another is down (then exits 1 saying which failed);
/// `get` retrieves from the first that can.
#[test]
fn several_pacs_are_each_asked_and_one_that_is_down_is_said() {
    if !dcmtk_available() {
        return;
    }
    let Some(orthanc) = Orthanc::start(None) else { return };
    orthanc.load_philips();
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    let down = format!("DOWN@127.0.0.1:{}", free_port());
    let output = pacs(&["find", "--pacs", &down, "--pacs", &orthanc.address()], &cache);
    assert_clean_error(&output, "DOWN@127.0.0.1", "one PACS down");
    let lines = json_lines(&output);
    assert_eq!(lines.len(), 1, "the other PACS's study is listed: {lines:?}");
    assert_eq!(lines[0]["pacs"], orthanc.address());
    let study = lines[0]["study_uid"].as_str().unwrap().to_string();
    let data_dir = folder.path().join("data");
    let both = format!("{down},{}", orthanc.address());
    let output = pacs(&["get", "--pacs", &both, "--data-dir", data_dir.to_str().unwrap(), &study], &cache);
    assert!(output.status.success(), "get: {}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(json_lines(&output)[0]["event"], "stored");
}
