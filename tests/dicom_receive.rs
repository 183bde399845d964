//! `volasso receive` against dcmtk's real clients (`storescu`, `echoscu`) on loopback ports the
//! system picks: C-ECHO, the Philips series stored once and replaced when sent again, two
//! compressed series in one association, an association killed midway, an unknown SOP class,
//! a calling AE title not allowed, and a full data partition; `publish` (a series appears
//! whole or not at all, also across kills), `truth` (failures are told to the sender),
//! `hostile_peers` (limits and timeouts) and `tls`. Each client runs under a timeout; without
//! dcmtk the tests say so and are skipped (`.ci/run` installs it).

mod hostile_peers;
mod publish;
mod tls;
mod truth;

use crate::dicom_codecs::dcmtk_available;
use crate::support::{data, run_within};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

/// The longest a client or an expected line may take.
const PATIENCE: Duration = Duration::from_secs(20);

/// The quiet period the tests publish after, unless a test sets its own.
const TEST_STABLE_AFTER: &str = "0.3";

/// A running `volasso receive` on a free loopback port, killed when dropped.
pub(crate) struct Scp {
    child: Child,
    pub(crate) port: u16,
    pub(crate) data_dir: PathBuf,
    /// The data folder, when this receiver made it.
    _owned: Option<tempfile::TempDir>,
    stdout: Receiver<String>,
    stderr: Receiver<String>,
}

impl Scp {
    pub(crate) fn start(extra: &[&str]) -> Scp {
        let data_dir = tempfile::tempdir().unwrap();
        let mut scp = Scp::start_in(data_dir.path(), extra, &[]);
        scp._owned = Some(data_dir);
        scp
    }

    /// A receiver on `data_dir` (which outlives it), with `extra` arguments and environment.
    fn start_in(data_dir: &Path, extra: &[&str], environment: &[(&str, &str)]) -> Scp {
        let mut command = Command::new(env!("CARGO_BIN_EXE_volasso"));
        command.args(["receive", "--port", "0", "--listen", "127.0.0.1", "--data-dir"]).arg(data_dir).args(extra);
        if !extra.contains(&"--stable-after") {
            command.args(["--stable-after", TEST_STABLE_AFTER]);
        }
        let mut child = command
            .envs(environment.iter().copied())
            .env("RUST_LOG", "info")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("volasso runs");
        let lines = |stream: Box<dyn std::io::Read + Send>| {
            let (sender, receiver) = channel();
            std::thread::spawn(move || {
                for line in BufReader::new(stream).lines().map_while(Result::ok) {
                    if sender.send(line).is_err() {
                        break;
                    }
                }
            });
            receiver
        };
        let stdout = lines(Box::new(child.stdout.take().unwrap()));
        let stderr = lines(Box::new(child.stderr.take().unwrap()));
        let mut scp = Scp { child, port: 0, data_dir: data_dir.to_path_buf(), _owned: None, stdout, stderr };
        let listening = scp.wait_line(false, |line| line.contains("listening on 127.0.0.1:"));
        let port = listening.split("127.0.0.1:").nth(1).and_then(|rest| rest.split_whitespace().next());
        scp.port = port.and_then(|port| port.parse().ok()).expect("a port in the listening line");
        scp
    }

    /// The next line of stdout (or stderr) that `wanted` accepts; panics after [`PATIENCE`].
    fn wait_line(&self, stdout: bool, wanted: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + PATIENCE;
        let source = if stdout { &self.stdout } else { &self.stderr };
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match source.recv_timeout(left) {
                Ok(line) if wanted(&line) => return line,
                Ok(_) => {}
                Err(_) => panic!("no expected line from volasso receive within {PATIENCE:?}"),
            }
        }
    }

    /// The next JSON line on stdout.
    fn next_report(&self) -> serde_json::Value {
        serde_json::from_str(&self.wait_line(true, |_| true)).expect("a JSON line")
    }

    /// Runs a dcmtk client against this receiver (called AE title VOLASSO).
    fn client(&self, program: &str, options: &[&str], files: &[PathBuf]) -> Output {
        let mut command = Command::new(program);
        command.args(options).args(["-aec", "VOLASSO", "127.0.0.1", &self.port.to_string()]).args(files);
        run_within(&mut command, PATIENCE)
    }

    /// The entries of the data folder that the chooser would see (not dot-names).
    fn visible_entries(&self) -> Vec<String> {
        visible_entries(&self.data_dir)
    }

    fn stderr_so_far(&self) -> String {
        self.stderr.try_iter().collect::<Vec<_>>().join("\n")
    }
}

impl Drop for Scp {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The entries of `data_dir` that the chooser would see (not dot-names), sorted.
/// The series folders the chooser would list (not hidden, not the audit log's folder).
fn visible_entries(data_dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(data_dir)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| !name.starts_with('.') && name != volasso::appliance::audit::FOLDER)
        .collect();
    names.sort();
    names
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

fn series_files(name: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(data(&format!("dicom/{name}")))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.file_name().is_some_and(|file| file != "DIRFILE"))
        .collect();
    files.sort();
    files
}

/// `volasso info --json` on `path`.
fn info(path: &Path) -> serde_json::Value {
    let cache = tempfile::tempdir().unwrap();
    let output = crate::support::volasso(&["info", path.to_str().unwrap(), "--json"], cache.path());
    assert!(output.status.success(), "info {}: {}", path.display(), String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

#[test]
fn echo_then_the_philips_series_is_stored_once_and_replaced_when_sent_again() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&[]);
    let echo = scp.client("echoscu", &[], &[]);
    assert!(echo.status.success(), "echoscu: {}", text(&echo));
    let files = series_files("philips_phantom_5mm");
    assert_eq!(files.len(), 28);
    let store = scp.client("storescu", &[], &files);
    assert!(store.status.success(), "storescu: {}", text(&store));
    let report = scp.next_report();
    assert_eq!(report["event"], "stored", "{report}");
    let name = report["name"].as_str().unwrap().to_string();
    assert!(name.starts_with("CT-") && name.len() == 19 && name[3..].bytes().all(|b| b.is_ascii_hexdigit()), "{name}");
    assert_eq!(report["images"], 28);
    assert_eq!(report["replaced"], false);
    assert_eq!(scp.visible_entries(), std::slice::from_ref(&name));
    let stored = scp.data_dir.join(&name);
    assert_eq!(info(&stored)["dims"], serde_json::json!([512, 512, 28]));
    // The same series again: the same name, replaced, still 28 files.
    let again = scp.client("storescu", &[], &files);
    assert!(again.status.success(), "storescu: {}", text(&again));
    let report = scp.next_report();
    assert_eq!((report["name"].as_str(), report["replaced"].as_bool()), (Some(name.as_str()), Some(true)));
    assert_eq!(scp.visible_entries(), std::slice::from_ref(&name));
    assert_eq!(std::fs::read_dir(&stored).unwrap().count(), 28);
    // No patient name or ID in what the receiver printed.
    let identity =
        volasso::volume::dicom::read_identity(&files[0], &volasso::volume::limits::ReadLimits::default()).unwrap();
    let printed = format!("{report}\n{}", scp.stderr_so_far());
    for secret in [&identity.patient.name, &identity.patient.id] {
        assert!(secret.len() < 3 || !printed.contains(secret.as_str()), "'{secret}' printed: {printed}");
    }
    // Each store is a line of the audit log: the series' UID hashed, no patient data.
    let audit = volasso::appliance::audit::AuditLog::new(&scp.data_dir).entries(0).unwrap();
    let received: Vec<_> =
        audit.iter().filter(|entry| entry.event == volasso::appliance::audit::Event::SeriesReceived).collect();
    assert_eq!(received.len(), 2, "{audit:?}");
    let hash = volasso::appliance::audit::series_hash(&identity.series_uid);
    assert!(received.iter().all(|entry| entry.series.as_deref() == Some(hash.as_str())));
    assert!(
        received[0].detail.as_deref().is_some_and(|detail| detail.starts_with(&format!("{name}, 28 images"))),
        "{audit:?}"
    );
    let log = std::fs::read_to_string(scp.data_dir.join("audit/receive.log")).unwrap();
    for secret in [&identity.patient.name, &identity.patient.id, &identity.series_uid] {
        assert!(!log.contains(secret.as_str()), "'{secret}' in the audit log: {log}");
    }
}

#[test]
fn two_compressed_series_in_one_association_are_two_volumes() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&[]);
    let compressed = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for file in series_files("philips_phantom_5mm") {
        let copy = compressed.path().join(file.file_name().unwrap());
        let made = Command::new("dcmcjpeg").arg("+e1").arg(&file).arg(&copy).output().unwrap();
        assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
        files.push(copy);
    }
    files.extend(series_files("ge_head_tilt"));
    // -xs proposes JPEG Lossless SV1 (and the uncompressed syntaxes for the GE files).
    let store = scp.client("storescu", &["-xs"], &files);
    assert!(store.status.success(), "storescu: {}", text(&store));
    let mut reports = [scp.next_report(), scp.next_report()];
    reports.sort_by_key(|report| report["dims"][1].as_u64());
    assert!(reports.iter().all(|report| report["event"] == "stored" && report["images"] == 28), "{reports:?}");
    assert_eq!(reports[0]["dims"], serde_json::json!([512, 512, 28]));
    assert_eq!(scp.visible_entries().len(), 2);
    for report in &reports {
        let stored = scp.data_dir.join(report["name"].as_str().unwrap());
        assert_eq!(info(&stored)["dims"], report["dims"]);
    }
}

/// JPEG Extended's 12-bit form (`dcmcjpeg +ee`), as CT and MR use it: negotiated, stored and
/// read back to the series' size.
#[test]
fn a_12_bit_lossy_jpeg_series_is_accepted_and_stored() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&[]);
    let compressed = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for file in series_files("philips_phantom_5mm") {
        let copy = compressed.path().join(file.file_name().unwrap());
        let made = Command::new("dcmcjpeg").arg("+ee").arg(&file).arg(&copy).output().unwrap();
        assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
        files.push(copy);
    }
    // -xx proposes JPEG Extended (and the uncompressed syntaxes).
    let store = scp.client("storescu", &["-xx"], &files);
    assert!(store.status.success(), "storescu: {}", text(&store));
    let report = scp.next_report();
    assert!(report["event"] == "stored" && report["images"] == 28, "{report}");
    let stored = scp.data_dir.join(report["name"].as_str().unwrap());
    assert_eq!(info(&stored)["dims"], serde_json::json!([512, 512, 28]));
}

#[test]
fn an_association_killed_midway_publishes_nothing_until_a_sender_completes_the_series() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&[]);
    // The series ten times over: long enough to be killed while sending.
    let files: Vec<PathBuf> = (0..10).flat_map(|_| series_files("philips_phantom_5mm")).collect();
    let mut sender = Command::new("storescu")
        .args(["-aec", "VOLASSO", "127.0.0.1", &scp.port.to_string()])
        .args(&files)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Killed once the first images are acknowledged (they are then in the pending folder).
    let pending = scp.data_dir.join(volasso::receive::STAGING_FOLDER).join("pending");
    let acknowledged = || {
        std::fs::read_dir(&pending)
            .into_iter()
            .flatten()
            .flatten()
            .flat_map(|series| std::fs::read_dir(series.path()).into_iter().flatten())
            .count()
    };
    let deadline = Instant::now() + PATIENCE;
    while acknowledged() < 3 {
        assert!(Instant::now() < deadline, "nothing arrived");
        assert!(sender.try_wait().unwrap().is_none(), "storescu finished before it could be killed");
        std::thread::sleep(Duration::from_millis(2));
    }
    sender.kill().unwrap();
    sender.wait().unwrap();
    let held = scp.next_report();
    assert_eq!(held["event"], "incomplete", "{held}");
    assert!(held["reason"].as_str().unwrap().contains("ended without a release"), "{held}");
    // Quiet for longer than the quiet period: still nothing published, what was acknowledged kept.
    std::thread::sleep(Duration::from_secs(1));
    assert_eq!(scp.visible_entries(), Vec::<String>::new());
    assert!(scp.stdout.try_recv().is_err(), "a series was reported");
    let kept = acknowledged();
    assert!((3..=28).contains(&kept), "{kept} images kept");
    // The receiver serves on, and a sender that sends the whole series completes it.
    let echo = scp.client("echoscu", &[], &[]);
    assert!(echo.status.success(), "echoscu after the kill: {}", text(&echo));
    let store = scp.client("storescu", &[], &files[..28]);
    assert!(store.status.success(), "storescu: {}", text(&store));
    let report = scp.next_report();
    assert_eq!((report["event"].as_str(), report["images"].as_u64()), (Some("stored"), Some(28)), "{report}");
    assert_eq!(acknowledged(), 0);
}

#[test]
fn an_unknown_sop_class_and_a_calling_title_not_allowed_are_refused() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&["--allow-ae", "PACS,MODALITY"]);
    let folder = tempfile::tempdir().unwrap();
    let secondary_capture = folder.path().join("sc.dcm");
    std::fs::copy(data("dicom/philips_phantom_5mm/I10"), &secondary_capture).unwrap();
    let modified = Command::new("dcmodify")
        .args(["-nb", "-m", "(0008,0016)=1.2.840.10008.5.1.4.1.1.7"])
        .arg(&secondary_capture)
        .output()
        .unwrap();
    assert!(modified.status.success(), "{}", String::from_utf8_lossy(&modified.stderr));
    let unknown = scp.client("storescu", &["-aet", "PACS"], std::slice::from_ref(&secondary_capture));
    assert!(!unknown.status.success());
    assert!(text(&unknown).contains("No presentation context for: (SC)"), "{}", text(&unknown));
    let files = series_files("philips_phantom_5mm");
    let stranger = scp.client("storescu", &["-aet", "STRANGER"], &files[..1]);
    assert!(!stranger.status.success());
    assert!(text(&stranger).contains("Calling AE Title Not Recognized"), "{}", text(&stranger));
    assert_eq!(scp.visible_entries(), Vec::<String>::new());
    let allowed = scp.client("storescu", &["-aet", "MODALITY"], &files[..1]);
    assert!(allowed.status.success(), "{}", text(&allowed));
    assert_eq!(scp.next_report()["event"], "stored");
}

#[test]
fn a_full_data_partition_refuses_with_out_of_resources() {
    if !dcmtk_available() {
        return;
    }
    // Any partition is fuller than 0 %.
    let scp = Scp::start(&["--max-disk-use-percent", "0"]);
    let files = series_files("philips_phantom_5mm");
    let store = scp.client("storescu", &["-v"], &files[..2]);
    assert!(!store.status.success());
    assert!(text(&store).contains("Refused: OutOfResources"), "{}", text(&store));
    scp.wait_line(false, |line| line.contains("the data partition is"));
    assert_eq!(scp.visible_entries(), Vec::<String>::new());
}
