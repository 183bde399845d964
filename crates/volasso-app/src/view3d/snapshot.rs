//! Snapshots of the 3-D view: the picture shown is written as a PNG into the data folder's
//! `snapshots/` and, when a USB stick is mounted and the settings allow USB export, into
//! `volasso-snapshots/` on it, each named by the UTC time alone
//! (`volasso-2026-12-01T23-59-07Z.png`, then `-2`, `-3`... so nothing is ever overwritten; never
//! the scan's name, which may be a patient's). Files are written atomically (src/atomic_file.rs) on a thread
//! of their own: a slow or stuck stick never holds up the UI.
//!
//! A stick is a file system mounted under one of the media roots (`/media`, `/run/media` by
//! default, as udisks and desktop automounters mount them; [`AppConfig`](crate::AppConfig)
//! sets others), read from `/proc/self/mounts`. The appliance's import unit (deploy/) mounts
//! its stick read-only in a namespace of its own, so there a stick appears only when one is
//! mounted for the kiosk.
//!
//! Never: fails the app. A read-only or full stick, a missing data folder, a picture not yet
//! drawn: each becomes a sentence in the confirmation.

use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::SystemTime;
use volasso_core::atomic_file::write_atomically;

/// The folder of the data folder (and of a stick) that holds the snapshots.
pub const SNAPSHOT_FOLDER: &str = "snapshots";
/// The folder on a USB stick that holds the snapshots.
pub const STICK_FOLDER: &str = "volasso-snapshots";
/// Where removable media are mounted unless configured otherwise.
pub const DEFAULT_MEDIA_ROOTS: [&str; 2] = ["/media", "/run/media"];

/// Why one copy of a snapshot was not written.
#[derive(Debug, thiserror::Error)]
pub enum SnapshotError {
    #[error("cannot encode the picture as PNG: {source}, for {}", path.display())]
    Encode { source: image::ImageError, path: PathBuf },
    #[error("cannot create the folder: {source}, {}", path.display())]
    Folder { source: std::io::Error, path: PathBuf },
    #[error("cannot write: {source}, {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
    #[error("no free name among {tried} tried, in {}", folder.display())]
    NoFreeName { tried: usize, folder: PathBuf },
}

/// Where the snapshots of one press went, and what failed.
#[derive(Debug, Default)]
pub struct Outcome {
    pub written: Vec<PathBuf>,
    pub problems: Vec<String>,
}

impl Outcome {
    /// The confirmation's sentence.
    pub fn message(&self) -> String {
        let mut parts = Vec::new();
        if !self.written.is_empty() {
            let places: Vec<String> = self.written.iter().map(|path| path.display().to_string()).collect();
            parts.push(format!("Snapshot saved: {}", places.join(" and ")));
        }
        parts.extend(self.problems.iter().cloned());
        if parts.is_empty() { "Snapshot not saved".to_string() } else { parts.join(". ") }
    }
}

/// Where snapshots go.
#[derive(Clone, Debug, Default)]
pub struct Places {
    /// The data folder (its `snapshots/`); `None`: none configured.
    pub data_dir: Option<PathBuf>,
    /// Where sticks are mounted.
    pub media_roots: Vec<PathBuf>,
}

/// The file name of a snapshot taken at `time`: `volasso-YYYY-MM-DDTHH-MM-SSZ`. Never the
/// The snapshots in `data_dir`'s [`SNAPSHOT_FOLDER`], sorted.
pub fn files_in(data_dir: &Path) -> Vec<PathBuf> {
    let entries = std::fs::read_dir(data_dir.join(SNAPSHOT_FOLDER));
    let mut files: Vec<PathBuf> =
        entries.map(|entries| entries.filter_map(|entry| entry.ok().map(|e| e.path())).collect()).unwrap_or_default();
    files.retain(|path| path.extension().is_some_and(|ext| ext == "png"));
    files.sort();
    files
}

/// scan's name: a folder named after a patient would carry the name onto a USB stick.
pub fn file_stem(time: SystemTime) -> String {
    let seconds = time.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    format!("volasso-{}", volasso_core::calendar::iso_utc(seconds).replace(':', "-"))
}

/// Writes `png` as `folder/STEM.png` (or `STEM-2.png`, ... when taken), creating `folder`;
/// never replaces a file.
pub fn write_new(folder: &Path, stem: &str, png: &[u8]) -> Result<PathBuf, SnapshotError> {
    std::fs::create_dir_all(folder).map_err(|source| SnapshotError::Folder { source, path: folder.to_path_buf() })?;
    const TRIES: usize = 1000;
    let path = (1..=TRIES)
        .map(|n| if n == 1 { folder.join(format!("{stem}.png")) } else { folder.join(format!("{stem}-{n}.png")) })
        .find(|path| !path.exists())
        .ok_or(SnapshotError::NoFreeName { tried: TRIES, folder: folder.to_path_buf() })?;
    write_atomically(&path, |writer| writer.write_all(png))
        .map_err(|source| SnapshotError::Write { source, path: path.clone() })?;
    Ok(path)
}

/// The mount points under `roots` listed in `mounts` (the text of `/proc/self/mounts`: device,
/// mount point with `\040`-style escapes, type, options...).
pub fn mounted_sticks(mounts: &str, roots: &[PathBuf]) -> Vec<PathBuf> {
    let mut sticks: Vec<PathBuf> = mounts
        .lines()
        .filter_map(|line| line.split_whitespace().nth(1))
        .map(|point| PathBuf::from(unescape_mount_point(point)))
        .filter(|point| roots.iter().any(|root| point.starts_with(root) && point != root))
        .collect();
    sticks.sort();
    sticks.dedup();
    sticks
}

/// `/proc/mounts` writes space, tab, newline and backslash as octal escapes.
fn unescape_mount_point(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let octal =
            bytes.get(i + 1..i + 4).filter(|d| bytes[i] == b'\\' && d.iter().all(|c| (b'0'..=b'7').contains(c)));
        match octal {
            Some(digits) => {
                out.push(digits.iter().fold(0u8, |value, d| value.wrapping_mul(8).wrapping_add(d - b'0')));
                i += 4;
            }
            None => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Encodes `image` once and writes it to the data folder and to every stick mounted now.
/// A copy that left on a stick is an `result-exported` line in the data folder's audit log.
pub fn take(image: &image::RgbaImage, places: &Places, time: SystemTime) -> Outcome {
    let mounts = std::fs::read_to_string("/proc/self/mounts").unwrap_or_default();
    let sticks = mounted_sticks(&mounts, &places.media_roots);
    let outcome = take_to(image, places.data_dir.as_deref(), &sticks, time);
    let exported = outcome.written.iter().filter(|path| sticks.iter().any(|stick| path.starts_with(stick))).count();
    if let (Some(data_dir), true) = (&places.data_dir, exported > 0) {
        let unix = time.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |since| since.as_secs());
        let detail = format!("snapshot to {exported} USB stick(s)");
        volasso_appliance::audit::AuditLog::of_writer(data_dir, crate::audit::KIOSK).record(
            unix,
            volasso_appliance::audit::Event::ResultExported,
            None,
            Some(&detail),
        );
    }
    outcome
}

/// [`take`] onto the sticks mounted at `sticks`.
pub fn take_to(image: &image::RgbaImage, data_dir: Option<&Path>, sticks: &[PathBuf], time: SystemTime) -> Outcome {
    let mut outcome = Outcome::default();
    let stem = file_stem(time);
    let mut png = Vec::new();
    let encoded = image::codecs::png::PngEncoder::new(&mut png);
    if let Err(source) = image::ImageEncoder::write_image(
        encoded,
        image.as_raw(),
        image.width(),
        image.height(),
        image::ExtendedColorType::Rgba8,
    ) {
        let error = SnapshotError::Encode { source, path: PathBuf::from(format!("{stem}.png")) };
        outcome.problems.push(error.to_string());
        return outcome;
    }
    match data_dir {
        Some(data_dir) => match write_new(&data_dir.join(SNAPSHOT_FOLDER), &stem, &png) {
            Ok(path) => outcome.written.push(path),
            Err(error) => outcome.problems.push(format!("Not saved in the data folder: {error}")),
        },
        None => outcome.problems.push("No data folder is set for snapshots".to_string()),
    }
    for stick in sticks {
        match write_new(&stick.join(STICK_FOLDER), &stem, &png) {
            Ok(path) => outcome.written.push(path),
            Err(error) => outcome.problems.push(format!("Not saved on the USB stick ({}): {error}", stick.display())),
        }
    }
    outcome
}

/// One snapshot to write: the picture, where it goes and when it was taken.
pub struct SnapshotJob {
    pub image: image::RgbaImage,
    pub places: Places,
    pub time: SystemTime,
}

/// Takes snapshots on a thread per press and hands back their outcomes.
pub struct SnapshotWriter {
    worker: Box<dyn Worker<SnapshotJob, Outcome>>,
}

impl Default for SnapshotWriter {
    fn default() -> Self {
        SnapshotWriter { worker: Box::new(Threaded::new("snapshot", snapshot_task())) }
    }
}

/// The writer's task: one snapshot.
fn snapshot_task() -> Task<SnapshotJob, Outcome> {
    Arc::new(|job: SnapshotJob, _: &Ticket, report: &Report<'_, Outcome>| {
        report(take(&job.image, &job.places, job.time))
    })
}

impl SnapshotWriter {
    /// A writer with no thread: each snapshot is written at `poll`, on the caller's thread.
    #[cfg(test)]
    pub fn inline() -> SnapshotWriter {
        SnapshotWriter { worker: Box::new(crate::worker::Inline::new(snapshot_task())) }
    }

    /// Starts writing `image`; the outcome comes from [`Self::poll`].
    pub fn start(&mut self, image: image::RgbaImage, places: Places) {
        self.worker.send(SnapshotJob { image, places, time: SystemTime::now() });
    }

    /// A finished snapshot's outcome, if one is ready; never blocks.
    pub fn poll(&mut self) -> Option<Outcome> {
        if let Some(delivery) = self.worker.poll() {
            return Some(delivery.output);
        }
        if self.worker.ended_silently().is_some() {
            // Its writer could not start or stopped without an outcome (logged).
            return Some(Outcome {
                written: Vec::new(),
                problems: vec!["Snapshot not saved: its writer stopped".into()],
            });
        }
        None
    }

    /// True while a snapshot is being written.
    pub fn busy(&self) -> bool {
        self.worker.busy()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn names_carry_the_utc_time_and_never_the_scan_s_name() {
        let time = SystemTime::UNIX_EPOCH + Duration::from_secs(1_796_169_547);
        assert_eq!(file_stem(time), "volasso-2026-12-01T23-59-07Z");
        assert_eq!(file_stem(SystemTime::UNIX_EPOCH), "volasso-1970-01-01T00-00-00Z");
        // A leap day.
        assert!(
            file_stem(SystemTime::UNIX_EPOCH + Duration::from_secs(951_782_400)).starts_with("volasso-2000-02-29T")
        );
    }

    #[test]
    fn a_snapshot_never_overwrites_one_taken_before() {
        let folder = tempfile::tempdir().unwrap();
        let first = write_new(folder.path(), "shot", b"one").unwrap();
        let second = write_new(folder.path(), "shot", b"two").unwrap();
        assert_eq!(first.file_name().unwrap(), "shot.png");
        assert_eq!(second.file_name().unwrap(), "shot-2.png");
        assert_eq!(std::fs::read(&first).unwrap(), b"one");
    }

    #[test]
    fn sticks_are_mount_points_under_the_media_roots() {
        let mounts = "/dev/sda1 / ext4 rw 0 0\n/dev/sdb1 /media/STICK vfat rw 0 0\n\
                      /dev/sdc1 /run/media/kiosk/MY\\040PHOTOS exfat rw 0 0\ntmpfs /media tmpfs rw 0 0\n";
        let roots = DEFAULT_MEDIA_ROOTS.map(PathBuf::from);
        assert_eq!(
            mounted_sticks(mounts, &roots),
            [PathBuf::from("/media/STICK"), PathBuf::from("/run/media/kiosk/MY PHOTOS")]
        );
        assert!(mounted_sticks("garbage\n\n", &roots).is_empty());
    }

    #[test]
    fn a_stick_that_cannot_be_written_is_said_and_the_other_copies_are_written() {
        let folder = tempfile::tempdir().unwrap();
        // A file where a stick's snapshot folder would go: as unwritable as a full or read-only
        // stick, even for root.
        let (blocked, fine) = (folder.path().join("blocked"), folder.path().join("fine"));
        std::fs::create_dir_all(&blocked).unwrap();
        std::fs::create_dir_all(&fine).unwrap();
        std::fs::write(blocked.join(STICK_FOLDER), b"in the way").unwrap();
        let data = folder.path().join("data");
        let image = image::RgbaImage::from_pixel(7, 5, image::Rgba([10, 200, 30, 255]));
        let sticks = [blocked.clone(), fine.clone()];
        let outcome = take_to(&image, Some(&data), &sticks, SystemTime::now());
        assert_eq!(outcome.written.len(), 2, "{}", outcome.message());
        assert!(outcome.written[0].starts_with(data.join(SNAPSHOT_FOLDER)));
        assert!(outcome.written[1].starts_with(fine.join(STICK_FOLDER)));
        for path in &outcome.written {
            let written = image::open(path).unwrap();
            assert_eq!((written.width(), written.height()), (7, 5));
        }
        let message = outcome.message();
        assert!(message.starts_with("Snapshot saved: "), "{message}");
        assert!(message.contains("Not saved on the USB stick") && message.contains("blocked"), "{message}");
        let none = take_to(&image, None, &[], SystemTime::now());
        assert_eq!(none.message(), "No data folder is set for snapshots");
    }
}
