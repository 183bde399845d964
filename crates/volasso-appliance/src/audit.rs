//! The audit log hospital IT reads: one JSON line per event that matters to them (a scan
//! opened, received, retrieved, sent, exported or expired; a setting changed; a PIN refused),
//! with the UTC time and, for a series, a hash of its UID, never a name. It lives in
//! `audit/` in the data folder, one file per writer (the kiosk and the receiver run as different
//! users, and neither may write the other's files): `WRITER.log` the newest; past
//! [`MAX_FILE_BYTES`] it moves to `WRITER.log.1` (the older ones up by one) and the
//! [`KEPT_FILES`]th oldest goes. Reading merges every writer's files by time.
//!
//! A line is `{"time":"2026-12-06T11:02:03Z","unix":1796554923,"event":"settings-changed",
//! "detail":"mode=demo"}`, with `"series":"<16 hex digits>"` for an event about a series.
//!
//! Never: writes a patient's name, ID or birth date (a detail is the caller's words about the
//! appliance, and a UID only hashed), or stops the caller when the log cannot be written (that
//! is logged, once per event).

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// The log's folder in the data folder.
pub const FOLDER: &str = "audit";
/// The writer of the command line's lines (`volasso settings set`).
pub const COMMAND_LINE: &str = "audit";
/// A file grows to this before the next is begun.
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// Files kept: the newest and the older ones numbered 1 to `KEPT_FILES - 1`.
pub const KEPT_FILES: usize = 5;

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Event {
    ScanOpened,
    SeriesReceived,
    SeriesRetrieved,
    ResultSent,
    ResultExported,
    DataExpired,
    SettingsChanged,
    PinRefused,
}

/// One line of the log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// UTC, ISO 8601 to the second.
    pub time: String,
    pub unix: u64,
    pub event: Event,
    /// [`series_hash`] of the series the event is about.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub series: Option<String>,
    /// The appliance's words: a setting's key and value, a count, a reason.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detail: Option<String>,
}

/// A series UID as the log names it: the first 16 hex digits of its SHA-256.
pub fn series_hash(uid: &str) -> String {
    let digest = Sha256::digest(uid.trim_end_matches(['\0', ' ']).as_bytes());
    digest.iter().take(8).map(|byte| format!("{byte:02x}")).collect()
}

/// The audit log of a data folder, as one writer writes it.
#[derive(Clone, Debug)]
pub struct AuditLog {
    folder: PathBuf,
    /// This writer's newest file's name, `WRITER.log`.
    file: String,
}

impl AuditLog {
    /// The log in `data_dir` as the command line writes it (its folder is made at the first
    /// event).
    pub fn new(data_dir: &Path) -> AuditLog {
        AuditLog::of_writer(data_dir, COMMAND_LINE)
    }

    /// The log in `data_dir` as `writer` (`kiosk`, `receive`) writes it.
    pub fn of_writer(data_dir: &Path, writer: &str) -> AuditLog {
        AuditLog { folder: data_dir.join(FOLDER), file: format!("{writer}.log") }
    }

    /// Appends `event` at `unix` seconds, about the series `series_uid` if any, with `detail`;
    /// a failure to write is logged, never the caller's problem.
    pub fn record(&self, unix: u64, event: Event, series_uid: Option<&str>, detail: Option<&str>) {
        let entry = Entry {
            time: volasso_core::calendar::iso_utc(unix),
            unix,
            event,
            series: series_uid.map(series_hash),
            detail: detail.map(String::from),
        };
        if let Err(error) = self.append(&entry) {
            log::error!("cannot write the audit log in {}: {error}", self.folder.display());
        }
    }

    /// [`record`](Self::record) at the system clock's time.
    pub fn record_now(&self, event: Event, series_uid: Option<&str>, detail: Option<&str>) {
        let unix =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |since| since.as_secs());
        self.record(unix, event, series_uid, detail);
    }

    fn append(&self, entry: &Entry) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.folder)?;
        let newest = self.folder.join(&self.file);
        if std::fs::metadata(&newest).is_ok_and(|meta| meta.len() >= MAX_FILE_BYTES) {
            self.rotate()?;
        }
        let mut line = serde_json::to_string(entry).map_err(std::io::Error::other)?;
        line.push('\n');
        let mut file = std::fs::OpenOptions::new().create(true).append(true).read(true).open(&newest)?;
        // A line torn at a power cut is ended first, so this one stands on a line of its own.
        if ends_torn(&mut file)? {
            line.insert(0, '\n');
        }
        file.write_all(line.as_bytes())?;
        file.sync_data()
    }

    /// `WRITER.log.N` to `.N+1` from the oldest kept, `WRITER.log` to `.1`.
    fn rotate(&self) -> std::io::Result<()> {
        let numbered = |n: usize| self.folder.join(format!("{}.{n}", self.file));
        let _ = std::fs::remove_file(numbered(KEPT_FILES - 1));
        for n in (1..KEPT_FILES - 1).rev() {
            if numbered(n).exists() {
                std::fs::rename(numbered(n), numbered(n + 1))?;
            }
        }
        std::fs::rename(self.folder.join(&self.file), numbered(1))
    }

    /// Every writer's entry at or after `since` (unix seconds), oldest first (in the order
    /// written among equal times), over the kept files; a line that does not parse (a torn
    /// write at a power cut) is skipped.
    pub fn entries(&self, since: u64) -> std::io::Result<Vec<Entry>> {
        let mut writers: Vec<String> = match std::fs::read_dir(&self.folder) {
            Ok(read) => read
                .filter_map(|entry| entry.ok()?.file_name().into_string().ok())
                .filter(|name| name.ends_with(".log"))
                .collect(),
            Err(error) if error.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(error) => return Err(error),
        };
        writers.sort();
        let mut files = Vec::new();
        for newest in &writers {
            files.extend((1..KEPT_FILES).rev().map(|n| self.folder.join(format!("{newest}.{n}"))));
            files.push(self.folder.join(newest));
        }
        let mut entries = Vec::new();
        for path in files {
            let file = match std::fs::File::open(&path) {
                Ok(file) => file,
                Err(error) if error.kind() == std::io::ErrorKind::NotFound => continue,
                Err(error) => return Err(error),
            };
            for line in std::io::BufReader::new(file).lines() {
                if let Ok(entry) = serde_json::from_str::<Entry>(&line?)
                    && entry.unix >= since
                {
                    entries.push(entry);
                }
            }
        }
        entries.sort_by_key(|entry| entry.unix);
        Ok(entries)
    }
}

/// Whether `file` is not empty and does not end with a newline.
fn ends_torn(file: &mut std::fs::File) -> std::io::Result<bool> {
    use std::io::{Read, Seek, SeekFrom};
    if file.metadata()?.len() == 0 {
        return Ok(false);
    }
    file.seek(SeekFrom::End(-1))?;
    let mut last = [0u8];
    file.read_exact(&mut last)?;
    Ok(last[0] != b'\n')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_come_back_in_order_with_the_series_hashed() {
        let data = tempfile::tempdir().unwrap();
        let log = AuditLog::new(data.path());
        let uid = "1.2.840.113619.2.55.3.604688119";
        log.record(1_796_554_923, Event::SeriesReceived, Some(uid), Some("28 images"));
        log.record(1_796_555_000, Event::SettingsChanged, None, Some("mode=demo"));
        let entries = log.entries(0).unwrap();
        assert_eq!(entries.len(), 2);
        assert_eq!(entries[0].time, "2026-12-06T11:02:03Z");
        assert_eq!(entries[0].series.as_deref(), Some(series_hash(uid).as_str()));
        assert_eq!(entries[0].series.as_ref().map(String::len), Some(16));
        assert_eq!(entries[1].event, Event::SettingsChanged);
        assert_eq!(log.entries(1_796_554_924).unwrap().len(), 1, "--since");
        let text = std::fs::read_to_string(data.path().join(FOLDER).join("audit.log")).unwrap();
        assert!(!text.contains(uid), "the UID itself is never written");
        assert!(text.contains("\"event\":\"series-received\""), "{text}");
    }

    #[test]
    fn each_writer_has_its_file_and_reading_merges_them_by_time() {
        let data = tempfile::tempdir().unwrap();
        let (kiosk, receiver) =
            (AuditLog::of_writer(data.path(), "kiosk"), AuditLog::of_writer(data.path(), "receive"));
        receiver.record(5, Event::SeriesReceived, Some("1.2.3"), None);
        kiosk.record(7, Event::ScanOpened, Some("1.2.3"), None);
        receiver.record(9, Event::SeriesReceived, Some("4.5.6"), None);
        assert!(
            data.path().join(FOLDER).join("kiosk.log").exists()
                && data.path().join(FOLDER).join("receive.log").exists()
        );
        let unix: Vec<u64> = AuditLog::new(data.path()).entries(0).unwrap().iter().map(|entry| entry.unix).collect();
        assert_eq!(unix, [5, 7, 9]);
    }

    #[test]
    fn a_full_file_rotates_and_the_oldest_goes() {
        let data = tempfile::tempdir().unwrap();
        let log = AuditLog::new(data.path());
        let detail = "x".repeat(4096);
        let per_file = (MAX_FILE_BYTES as usize).div_ceil(4096 + 80);
        let total = per_file * (KEPT_FILES + 1);
        for n in 0..total {
            log.record(n as u64, Event::ScanOpened, None, Some(&detail));
        }
        let folder = data.path().join(FOLDER);
        assert!(folder.join(format!("audit.log.{}", KEPT_FILES - 1)).exists());
        assert!(!folder.join(format!("audit.log.{KEPT_FILES}")).exists());
        let entries = log.entries(0).unwrap();
        assert!(entries.len() < total && entries.len() >= per_file * (KEPT_FILES - 1), "{}", entries.len());
        assert!(entries.windows(2).all(|pair| pair[0].unix < pair[1].unix), "oldest first, none twice");
        assert_eq!(entries.last().map(|entry| entry.unix), Some(total as u64 - 1));
    }

    #[test]
    fn a_torn_line_is_skipped_and_an_unwritable_log_does_not_stop_the_caller() {
        let data = tempfile::tempdir().unwrap();
        let log = AuditLog::new(data.path());
        log.record(10, Event::ScanOpened, None, None);
        let path = data.path().join(FOLDER).join("audit.log");
        let mut file = std::fs::OpenOptions::new().append(true).open(&path).unwrap();
        file.write_all(b"{\"time\":\"2026-").unwrap();
        drop(file);
        log.record(11, Event::ScanOpened, None, None);
        let unix: Vec<u64> = log.entries(0).unwrap().iter().map(|entry| entry.unix).collect();
        assert_eq!(unix, [10, 11], "the torn line is skipped, the next one kept");
        // A file where the folder should be: the event is lost with an error logged, no panic.
        let blocked = tempfile::tempdir().unwrap();
        std::fs::write(blocked.path().join(FOLDER), b"").unwrap();
        AuditLog::new(blocked.path()).record(12, Event::PinRefused, None, None);
    }
}
