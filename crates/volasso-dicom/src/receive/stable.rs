//! When a series is published: once it is *stable*, as PACS decide it. A series with pending
//! (acknowledged, unpublished) images is published when
//! * no image of it has arrived for the quiet period ([`Tracker::stable_after`]), no open
//!   association has sent images of it, and the last association that sent images of it was
//!   released normally (one that was aborted or broke holds it back until another sends it); or
//! * as soon as its pending images are all the data say there are ([`Expectation`]): every one
//!   a single-frame image saying Images in Acquisition (0020,1002) = N, of one acquisition, and
//!   N of them; or one multi-frame image outside a concatenation, or all the In-concatenation
//!   Total Number (0020,9163) files of one concatenation.
//!
//! Publishing itself, and what a kill in the middle leaves, is [`super::store`]'s. One thread
//! publishes, one series at a time; each publish prints one JSON line ([`SeriesReport`]).
//! A series that does not import cleanly is reported once and tried again when an image of
//! it arrives (or at the next start).
//!
//! Never: publishes a series while an open association is still sending it (unless the data
//! say it is complete), or twice for the same arrivals.

use super::store::{AcceptedImage, ImageCounts, Published, SeriesReport, Store};
use dicom_dictionary_std::tags;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// What one image says about how many images its series holds.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Expectation {
    /// Number of Frames (0028,0008), 1 when absent.
    frames: u32,
    /// Images in Acquisition (0020,1002).
    images_in_acquisition: Option<u32>,
    /// Acquisition Number (0020,0012).
    acquisition: Option<i64>,
    /// Concatenation UID (0020,9161).
    concatenation: Option<String>,
    /// In-concatenation Total Number (0020,9163).
    concatenation_files: Option<u32>,
}

impl Expectation {
    /// Reads the attributes before Pixel Data of an image the reader has already accepted;
    /// an image whose attributes cannot be read says nothing.
    pub fn read(path: &Path) -> Expectation {
        let Ok(object) = dicom_object::OpenFileOptions::new().read_until(tags::PIXEL_DATA).open_file(path) else {
            return Expectation::default();
        };
        let text = |tag| {
            object
                .element_opt(tag)
                .ok()
                .flatten()
                .and_then(|element| element.to_str().ok())
                .map(|text| text.trim_matches(['\0', ' ']).to_string())
                .filter(|text| !text.is_empty())
        };
        let number = |tag| text(tag).and_then(|text| text.parse::<i64>().ok());
        let count = |tag| number(tag).and_then(|n| u32::try_from(n).ok()).filter(|n| *n > 0);
        Expectation {
            frames: count(tags::NUMBER_OF_FRAMES).unwrap_or(1),
            images_in_acquisition: count(tags::IMAGES_IN_ACQUISITION),
            acquisition: number(tags::ACQUISITION_NUMBER),
            concatenation: text(tags::CONCATENATION_UID),
            concatenation_files: object
                .element_opt(tags::IN_CONCATENATION_TOTAL_NUMBER)
                .ok()
                .flatten()
                .and_then(|element| element.to_int::<u32>().ok())
                .filter(|n| *n > 0),
        }
    }
}

/// Whether `images` are all the images the data say the series holds (see the module doc).
pub fn complete(images: &[&Expectation]) -> bool {
    let Some(first) = images.first() else { return false };
    if first.frames > 1 {
        return match (&first.concatenation, first.concatenation_files) {
            (None, _) => images.len() == 1,
            (Some(uid), Some(total)) => {
                images.len() == total as usize
                    && images.iter().all(|image| image.frames > 1 && image.concatenation.as_ref() == Some(uid))
            }
            (Some(_), None) => false,
        };
    }
    let Some(expected) = first.images_in_acquisition else { return false };
    images.len() == expected as usize
        && images.iter().all(|image| {
            image.frames == 1 && image.images_in_acquisition == Some(expected) && image.acquisition == first.acquisition
        })
}

/// A series with pending images.
struct Series {
    series_uid: String,
    last_arrival: Instant,
    /// Open associations that have sent images of it.
    open_senders: usize,
    /// Why the last association that sent images of it ended badly.
    held: Option<String>,
    /// Images arrived since the last publish or attempt.
    dirty: bool,
    /// By pending file name.
    expectations: BTreeMap<OsString, Expectation>,
    calling_ae: String,
}

/// The series waiting to be published, and the publishing thread's alarm.
pub struct Tracker {
    series: Mutex<BTreeMap<String, Series>>,
    changed: Condvar,
    stable_after: Duration,
}

impl Tracker {
    /// Tracks the series `pending` in `store` (left by an earlier run: each waits a quiet
    /// period from now, or less when complete) and starts the thread that publishes them,
    /// printing one JSON line per outcome to `output`.
    pub fn start(
        store: Arc<Store>,
        pending: Vec<(String, String)>,
        stable_after: Duration,
        output: Arc<Mutex<dyn Write + Send>>,
    ) -> std::io::Result<Arc<Tracker>> {
        let now = Instant::now();
        let mut series = BTreeMap::new();
        for (name, series_uid) in pending {
            let expectations = store
                .pending_files(&name)
                .into_iter()
                .filter_map(|path| Some((path.file_name()?.to_os_string(), Expectation::read(&path))))
                .collect();
            let entry = Series {
                series_uid,
                last_arrival: now,
                open_senders: 0,
                held: None,
                dirty: true,
                expectations,
                calling_ae: String::new(),
            };
            series.insert(name, entry);
        }
        let tracker = Arc::new(Tracker { series: Mutex::new(series), changed: Condvar::new(), stable_after });
        let publisher = Arc::clone(&tracker);
        std::thread::Builder::new()
            .name("receive-publish".into())
            .spawn(move || publisher.publish_forever(&store, &output))?;
        Ok(tracker)
    }

    /// Notes an acknowledged image from an open association (see [`Tracker::ended`]).
    pub fn arrived(&self, image: &AcceptedImage, series_uid: &str, first_of_association: bool, calling_ae: &str) {
        let expectation = Expectation::read(&image.path);
        let mut series = self.lock();
        let entry = series.entry(image.name.clone()).or_insert_with(|| Series {
            series_uid: series_uid.to_string(),
            last_arrival: Instant::now(),
            open_senders: 0,
            held: None,
            dirty: true,
            expectations: BTreeMap::new(),
            calling_ae: String::new(),
        });
        entry.last_arrival = Instant::now();
        entry.dirty = true;
        entry.calling_ae = calling_ae.to_string();
        if first_of_association {
            entry.open_senders += 1;
        }
        entry.expectations.insert(image.file_name.clone(), expectation);
        drop(series);
        self.changed.notify_all();
    }

    /// An association that sent images of the series `names` ended: released normally
    /// (`problem` is `None`), or not, which holds those series back until another
    /// association sends them (or the data say they are complete).
    pub fn ended(&self, names: &[String], problem: Option<&str>) -> Vec<SeriesReport> {
        let mut reports = Vec::new();
        let mut series = self.lock();
        for name in names {
            if let Some(entry) = series.get_mut(name) {
                entry.open_senders = entry.open_senders.saturating_sub(1);
                entry.held =
                    problem.map(|problem| format!("the association that sent it ended without a release ({problem})"));
                if let Some(reason) = &entry.held {
                    reports.push(SeriesReport::Incomplete {
                        name: name.clone(),
                        series_uid: entry.series_uid.clone(),
                        images: entry.expectations.len(),
                        received: entry.expectations.len(),
                        calling_ae: entry.calling_ae.clone(),
                        reason: reason.clone(),
                    });
                }
            }
        }
        drop(series);
        self.changed.notify_all();
        reports
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<String, Series>> {
        self.series.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The next series due for publishing, or how long until one may be.
    fn next_due(&self, series: &mut BTreeMap<String, Series>) -> Result<(String, String, String), Duration> {
        let now = Instant::now();
        let mut wait = Duration::from_secs(1);
        for (name, entry) in series.iter_mut() {
            if !entry.dirty {
                continue;
            }
            let expectations: Vec<&Expectation> = entry.expectations.values().collect();
            let quiet_until = entry.last_arrival + self.stable_after;
            let stable = entry.open_senders == 0 && entry.held.is_none() && quiet_until <= now;
            if stable || complete(&expectations) {
                entry.dirty = false;
                return Ok((name.clone(), entry.series_uid.clone(), entry.calling_ae.clone()));
            }
            if entry.open_senders == 0 && entry.held.is_none() {
                wait = wait.min(quiet_until.saturating_duration_since(now));
            }
        }
        Err(wait.max(Duration::from_millis(10)))
    }

    fn publish_forever(&self, store: &Store, output: &Mutex<dyn Write + Send>) {
        loop {
            let due = {
                let mut series = self.lock();
                loop {
                    match self.next_due(&mut series) {
                        Ok(due) => break due,
                        Err(wait) => {
                            series = self
                                .changed
                                .wait_timeout(series, wait)
                                .unwrap_or_else(|poisoned| poisoned.into_inner())
                                .0;
                        }
                    }
                }
            };
            let (name, series_uid, calling_ae) = due;
            let report = match store.publish(&name, &series_uid) {
                Ok(Published::Nothing) => None,
                Ok(Published::Stored { check, images, received, replaced, taken }) => {
                    let mut series = self.lock();
                    if let Some(entry) = series.get_mut(&name) {
                        for file_name in &taken {
                            entry.expectations.remove(file_name);
                        }
                        if entry.expectations.is_empty() && !entry.dirty && entry.open_senders == 0 {
                            series.remove(&name);
                        }
                    }
                    log::info!("series {name} published: {images} images");
                    let path = store.data_dir().join(&name);
                    let counts = ImageCounts { images, received };
                    Some(SeriesReport::stored(name, path, series_uid, check, counts, replaced, calling_ae))
                }
                Ok(Published::Held { images, received, reason }) => {
                    log::warn!("series {name} is held back until it imports cleanly: {reason}");
                    Some(SeriesReport::Incomplete { name, series_uid, images, received, calling_ae, reason })
                }
                Err(error) => {
                    log::error!("cannot publish series {name}: {error}");
                    Some(SeriesReport::Incomplete {
                        name,
                        series_uid,
                        images: 0,
                        received: 0,
                        calling_ae,
                        reason: format!("cannot write the series ({error})"),
                    })
                }
            };
            if let Some(report) = report {
                print_reports(output, &[report]);
            }
        }
    }
}

/// Prints one JSON line per report.
pub fn print_reports(output: &Mutex<dyn Write + Send>, reports: &[SeriesReport]) {
    if reports.is_empty() {
        return;
    }
    let mut output = output.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    for report in reports {
        if let Ok(line) = serde_json::to_string(report) {
            let _ = writeln!(output, "{line}");
        }
    }
    let _ = output.flush();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn single(images_in_acquisition: Option<u32>, acquisition: Option<i64>) -> Expectation {
        Expectation { frames: 1, images_in_acquisition, acquisition, ..Expectation::default() }
    }

    #[test]
    fn images_in_acquisition_completes_a_series_only_when_all_agree_and_all_are_there() {
        let three = single(Some(3), Some(1));
        assert!(complete(&[&three, &three, &three]));
        assert!(!complete(&[&three, &three]));
        assert!(!complete(&[&three, &three, &three, &three]));
        let other_acquisition = single(Some(3), Some(2));
        assert!(!complete(&[&three, &three, &other_acquisition]));
        let silent = single(None, Some(1));
        assert!(!complete(&[&silent, &silent, &silent]));
        assert!(!complete(&[]));
    }

    #[test]
    fn a_multi_frame_image_is_complete_alone_or_with_its_whole_concatenation() {
        let enhanced = Expectation { frames: 40, ..Expectation::default() };
        assert!(complete(&[&enhanced]));
        assert!(!complete(&[&enhanced, &enhanced]));
        let part = Expectation {
            frames: 20,
            concatenation: Some("1.2.3".into()),
            concatenation_files: Some(2),
            ..Expectation::default()
        };
        assert!(!complete(&[&part]));
        assert!(complete(&[&part, &part]));
        let unnumbered = Expectation { concatenation_files: None, ..part.clone() };
        assert!(!complete(&[&unnumbered]));
    }
}
