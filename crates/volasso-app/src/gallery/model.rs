//! The gallery as the app uses it, without Slint: "Save" hands the current result to a writer
//! (a thread per save on the panel) and says what happens in the status line; the kept results
//! are listed for the chooser's cards; opening a card gives the scan to open with its session,
//! and once that scan is the open one, the camera and the classes' visibility to put back. A
//! result whose scan is gone is refused with the reason. view.rs shows it.
//!
//! Never: writes on the caller's thread, touches Slint, or opens a result whose volume is
//! missing.

use super::{GalleryEntry, GalleryError, Listed};
use crate::autosave::SavedSession;
use crate::chooser::library::VolumeSource;

use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volasso_core::render::Camera;

/// One kept result to write: where, what, and the 3-D view's picture.
pub(crate) struct SaveJob {
    data_dir: PathBuf,
    entry: GalleryEntry,
    picture: image::RgbaImage,
}

/// The writer of kept results.
pub(crate) type Writer = Box<dyn Worker<SaveJob, Result<PathBuf, GalleryError>>>;

/// The task that writes a kept result (gallery::save).
pub(crate) fn save_task() -> Task<SaveJob, Result<PathBuf, GalleryError>> {
    Arc::new(|job: SaveJob, _: &Ticket, report: &Report<'_, Result<PathBuf, GalleryError>>| {
        report(super::save(&job.data_dir, &job.entry, &job.picture))
    })
}

/// The result on the work screen, as a save keeps it.
pub(crate) struct CurrentResult {
    pub session: SavedSession,
    pub volume_name: String,
    /// A classification is shown (there is something to keep).
    pub classified: bool,
    pub camera: Camera,
    pub visible: Vec<bool>,
}

/// A kept result to open: its scan, with the session to restore on it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Opening {
    pub source: VolumeSource,
    pub session: SavedSession,
    pub volume_name: String,
}

/// The camera and visibility of a result being opened, put back once its scan is open.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Look {
    volume_key: String,
    pub camera: Camera,
    pub visible: Vec<bool>,
}

/// The gallery's part of the app's state.
pub(crate) struct GalleryModel {
    /// The gallery as last listed, in card order.
    listed: Vec<Listed>,
    writer: Writer,
    /// A result being opened: what to put back once its scan is the open one.
    pending: Option<Look>,
}

impl Default for GalleryModel {
    /// Writes on a thread per save.
    fn default() -> Self {
        GalleryModel::with_writer(Box::new(Threaded::new("gallery", save_task())))
    }
}

impl GalleryModel {
    pub(crate) fn with_writer(writer: Writer) -> GalleryModel {
        GalleryModel { listed: Vec::new(), writer, pending: None }
    }

    /// A save is still being written.
    pub(crate) fn busy(&self) -> bool {
        self.writer.busy()
    }

    /// The kept results as last listed, newest first.
    pub(crate) fn listed(&self) -> &[Listed] {
        &self.listed
    }

    /// Lists the gallery of `data_dir` again.
    pub(crate) fn relist(&mut self, data_dir: Option<&Path>) {
        self.listed = data_dir.map(super::list).unwrap_or_default();
    }

    /// "Save" at `saved_unix`: `current` with the 3-D view's `picture` to the gallery of
    /// `data_dir`; the status line, which says why when there is nothing to keep.
    pub(crate) fn save(
        &mut self,
        data_dir: Option<&Path>,
        current: Option<CurrentResult>,
        picture: Option<image::RgbaImage>,
        saved_unix: u64,
    ) -> String {
        match self.prepare(data_dir, current, picture, saved_unix) {
            Ok(job) => {
                self.writer.send(job);
                "Saving to the gallery...".into()
            }
            Err(message) => message.into(),
        }
    }

    fn prepare(
        &self,
        data_dir: Option<&Path>,
        current: Option<CurrentResult>,
        picture: Option<image::RgbaImage>,
        saved_unix: u64,
    ) -> Result<SaveJob, &'static str> {
        if self.busy() {
            return Err("Still saving the last result...");
        }
        let data_dir = data_dir.ok_or("Cannot save: there is no data folder")?;
        let current = current.ok_or("Nothing to save: no scan is open")?;
        if !current.classified {
            return Err("Nothing to save yet: draw two classes first");
        }
        let picture = picture
            .filter(|picture| picture.width() > 0 && picture.height() > 0)
            .ok_or("Nothing to save yet: the 3-D view has no picture")?;
        let entry = GalleryEntry {
            session: current.session,
            volume_name: current.volume_name,
            saved_unix,
            camera: current.camera,
            visible: current.visible,
        };
        Ok(SaveJob { data_dir: data_dir.to_path_buf(), entry, picture })
    }

    /// A finished save: the status line (the caller lists the gallery again).
    pub(crate) fn poll(&mut self) -> Option<String> {
        let finished = match self.writer.poll() {
            Some(delivery) => delivery.output.map_err(|error| error.to_string()),
            // Its thread could not start, or stopped without a word (logged).
            None => Err(self.writer.ended_silently().map(|_| "the gallery writer stopped".to_string())?),
        };
        Some(match finished {
            Ok(folder) => {
                log::info!("result kept in {}", folder.display());
                "Saved to the gallery".into()
            }
            Err(message) => {
                log::warn!("cannot save the result: {message}");
                format!("Cannot save: {message}")
            }
        })
    }

    /// Card `index` tapped: the scan to open with its session (the camera and visibility
    /// follow, [`GalleryModel::look_to_put_back`]); `Err` with the reason when its scan is
    /// gone; `None` when there is no such result.
    pub(crate) fn open(&mut self, index: usize) -> Option<Result<Opening, String>> {
        let Some(Listed::Entry { entry, .. }) = self.listed.get(index) else { return None };
        if entry.volume_missing() {
            return Some(Err(entry.missing_message()));
        }
        self.pending = Some(Look {
            volume_key: entry.session.volume.clone(),
            camera: entry.camera,
            visible: entry.visible.clone(),
        });
        Some(Ok(Opening {
            source: VolumeSource::from_key(&entry.session.volume),
            session: entry.session.clone(),
            volume_name: entry.volume_name.clone(),
        }))
    }

    /// Once nothing is opening (`opening` false): the camera and visibility of the result
    /// being opened when its scan (`open_key`) is the open one; forgotten when another scan
    /// is open or none opened (its card and the banner say why).
    pub(crate) fn look_to_put_back(&mut self, opening: bool, open_key: Option<&str>) -> Option<Look> {
        if opening {
            return None;
        }
        self.pending.take().filter(|look| Some(look.volume_key.as_str()) == open_key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::autosave::SavedLook;
    use crate::worker::Inline;
    use volasso_core::slices::Axis;
    use volasso_core::strokes::{ClassStrokes, Lasso, StrokesFile};

    fn session(volume: &str) -> SavedSession {
        let lasso = Lasso { axis: Axis::Z, slice: 3, points: vec![[1.0, 2.0], [7.5, 2.0], [7.5, 9.0]] };
        SavedSession {
            volume: volume.into(),
            template: String::new(),
            rotation_degrees: 0.0,
            strokes: StrokesFile { classes: vec![ClassStrokes { name: "Class 1".into(), strokes: vec![lasso] }] },
            look: SavedLook::default(),
        }
    }

    fn current(volume: &str) -> CurrentResult {
        CurrentResult {
            session: session(volume),
            volume_name: "Demo: CT foot phantom".into(),
            classified: true,
            camera: Camera { azimuth_degrees: 75.0, ..Camera::default() },
            visible: vec![true, false],
        }
    }

    fn picture() -> Option<image::RgbaImage> {
        Some(image::RgbaImage::from_pixel(40, 30, image::Rgba([200, 40, 40, 255])))
    }

    fn inline() -> GalleryModel {
        GalleryModel::with_writer(Box::new(Inline::new(save_task())))
    }

    #[test]
    fn a_saved_result_is_listed_and_opens_with_its_camera_and_visibility() {
        let data = tempfile::tempdir().unwrap();
        let mut gallery = inline();
        let demo = VolumeSource::Demo.key();
        let status = gallery.save(Some(data.path()), Some(current(&demo)), picture(), 1_700_000_000);
        assert_eq!(status, "Saving to the gallery...");
        assert!(gallery.busy());
        let again = gallery.save(Some(data.path()), Some(current(&demo)), picture(), 1_700_000_000);
        assert_eq!(again, "Still saving the last result...");
        assert_eq!(gallery.poll().as_deref(), Some("Saved to the gallery"));
        assert!(!gallery.busy());
        assert_eq!(gallery.poll(), None, "one save, one answer");
        gallery.relist(Some(data.path()));
        assert_eq!(gallery.listed().len(), 1);
        let opening = gallery.open(0).expect("a card").expect("its scan is there");
        assert_eq!(
            opening,
            Opening { source: VolumeSource::Demo, session: session(&demo), volume_name: current(&demo).volume_name }
        );
        assert_eq!(gallery.look_to_put_back(true, None), None, "not while the scan opens");
        let look = gallery.look_to_put_back(false, Some(&demo)).expect("the scan is open");
        assert_eq!((look.camera, look.visible), (current(&demo).camera, vec![true, false]));
        assert_eq!(gallery.look_to_put_back(false, Some(&demo)), None, "put back once");
        assert!(gallery.open(1).is_none(), "no second card");
    }

    #[test]
    fn a_result_whose_scan_did_not_open_puts_nothing_back() {
        let data = tempfile::tempdir().unwrap();
        let mut gallery = inline();
        let demo = VolumeSource::Demo.key();
        gallery.save(Some(data.path()), Some(current(&demo)), picture(), 1_700_000_000);
        gallery.poll();
        gallery.relist(Some(data.path()));
        assert!(matches!(gallery.open(0), Some(Ok(_))));
        assert_eq!(gallery.look_to_put_back(false, Some("some other scan")), None);
        assert_eq!(gallery.look_to_put_back(false, Some(&demo)), None, "forgotten, not kept for later");
    }

    #[test]
    fn a_result_whose_scan_is_gone_is_refused_with_the_reason() {
        let data = tempfile::tempdir().unwrap();
        let mut gallery = inline();
        let gone = VolumeSource::Path(data.path().join("gone.nrrd")).key();
        let result = CurrentResult { volume_name: "gone.nrrd".into(), ..current(&gone) };
        gallery.save(Some(data.path()), Some(result), picture(), 1_700_000_000);
        gallery.poll();
        gallery.relist(Some(data.path()));
        let refused = gallery.open(0).expect("a card").expect_err("its scan is gone");
        assert!(refused.contains("gone.nrrd"), "{refused}");
        assert_eq!(gallery.look_to_put_back(false, Some(&gone)), None);
    }

    #[test]
    fn nothing_to_keep_is_said_and_nothing_is_written() {
        let data = tempfile::tempdir().unwrap();
        let mut gallery = inline();
        let demo = VolumeSource::Demo.key();
        let unclassified = CurrentResult { classified: false, ..current(&demo) };
        let refusals = [
            (gallery.save(None, Some(current(&demo)), picture(), 1), "Cannot save: there is no data folder"),
            (gallery.save(Some(data.path()), None, picture(), 1), "Nothing to save: no scan is open"),
            (
                gallery.save(Some(data.path()), Some(unclassified), picture(), 1),
                "Nothing to save yet: draw two classes first",
            ),
            (
                gallery.save(Some(data.path()), Some(current(&demo)), None, 1),
                "Nothing to save yet: the 3-D view has no picture",
            ),
            (
                gallery.save(Some(data.path()), Some(current(&demo)), Some(image::RgbaImage::new(0, 0)), 1),
                "Nothing to save yet: the 3-D view has no picture",
            ),
        ];
        for (status, expected) in refusals {
            assert_eq!(status, expected);
        }
        assert_eq!(gallery.poll(), None);
        gallery.relist(Some(data.path()));
        assert!(gallery.listed().is_empty());
    }

    #[test]
    fn a_save_that_fails_says_why() {
        let data = tempfile::tempdir().unwrap();
        // The gallery's folder cannot be made: a file stands where it goes.
        std::fs::write(super::super::gallery_dir(data.path()), b"not a folder").unwrap();
        let mut gallery = inline();
        gallery.save(Some(data.path()), Some(current(&VolumeSource::Demo.key())), picture(), 1);
        let status = gallery.poll().expect("an answer");
        assert!(status.starts_with("Cannot save: "), "{status}");
    }
}
