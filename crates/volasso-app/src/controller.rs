//! The work behind the work screen, without Slint: the open volume with its classes and
//! lassos ([`Work`]), the colour template, and the workers that act on them (classification
//! jobs, the autosave writer, the 3-D view's renderer). It takes what the user did (a lasso
//! drawn, a class defined, undo, a class hidden, a template chosen, a volume opened with or
//! without a saved session) and says what changed ([`Changed`]); the app's model
//! (`AppModel::changed`) turns that into what the view shows again.
//!
//! Every edit of the classes is autosaved and, when at least two classes can be told apart
//! (the defined ones plus the pending lassos as a provisional next class), classified again
//! (paper §3.2-3.5, beyond the paper in classifying before a class is defined). A change of
//! colours or visibility sends the class table alone to the 3-D view, never the labels; so
//! does a class's opacity (beyond the paper's eq. 9, which fixes it: an outer class can be
//! faded to show the inner ones), and it is autosaved with the clip plane of the 3-D view.
//!
//! Never: calls Slint, waits for a worker, or touches the disk itself (the autosave writer
//! does).

use super::autosave::{SavedLook, SavedSession};
use super::jobs::{AppliedPreset, ClassificationJobs, JobOutcome};
use super::saver::AutosaveWriter;
use super::session::{SessionError, WorkSession};
use super::view3d::ViewRenderer;
use super::{Work, autosave};
use std::path::PathBuf;
use std::sync::Arc;
use volasso_core::preset::Preset;
use volasso_core::strokes::{ClassStrokes, StrokesFile};
use volasso_core::transfer::{ClassStyle, HueTemplate, TemplateType, apply_template};

/// What a finished job or an edit means for the banner of a failed classification.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Failure {
    /// Nothing new.
    #[default]
    Unchanged,
    /// A classification failed, for this reason: the banner says so ([`failure_banner`]).
    Failed(String),
    /// A classification succeeded, or no classification is wanted any more: a failure's
    /// banner goes.
    Cleared,
}

/// The banner of a classification that failed for `reason`.
pub fn failure_banner(reason: &str) -> String {
    format!("{FAILURE_BANNER_START}{reason}")
}

/// How the banner of a failed classification starts (so that it alone is cleared).
pub const FAILURE_BANNER_START: &str = "Classification failed: ";

/// What an intent or a finished job changed, for the UI to show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Changed {
    /// Classes, lassos, colours or visibility: the class bar and the slice pictures.
    pub classes: bool,
    /// The 3-D view needs a new frame.
    pub view: bool,
    /// No classification stands any more: the 3-D view is emptied.
    pub view_cleared: bool,
    /// A line for the status bar.
    pub status: Option<String>,
    /// The banner of a failed classification.
    pub failure: Failure,
}

/// The user's work and its workers.
pub struct Controller {
    pub(super) work: Option<Work>,
    pub(super) jobs: ClassificationJobs,
    pub(super) renderer: ViewRenderer,
    saver: AutosaveWriter,
    /// The template the user picked; until then each class count gets its default
    /// ([`HueTemplate::default_for`]).
    pub(super) chosen_template: Option<HueTemplate>,
    /// Where the session is autosaved; `None`: no autosave.
    session_dir: Option<PathBuf>,
    /// Per class name, its opacity factor, and the clip plane (saved with the session).
    pub(super) look: SavedLook,
}

/// The class opacity slider's range, in percent of the default rule's opacity.
pub const MAX_OPACITY_PERCENT: i32 = 200;

/// The workers a controller drives: on the panel each on a thread of its own (the renderer on
/// the GPU); in tests [`ControllerWorkers::inline`], which starts no thread and opens no GPU.
pub struct ControllerWorkers {
    pub renderer: ViewRenderer,
    pub jobs: ClassificationJobs,
    pub saver: AutosaveWriter,
}

impl ControllerWorkers {
    /// A render thread (the GPU opened there), a thread per classification, an autosave thread.
    pub fn threaded() -> ControllerWorkers {
        ControllerWorkers {
            renderer: ViewRenderer::new(),
            jobs: ClassificationJobs::default(),
            saver: AutosaveWriter::new(),
        }
    }

    /// No thread and no GPU: classifications run at the next poll, the renderer takes requests
    /// and draws nothing ([`ViewRenderer::without_gpu`]), the session is written at once.
    #[cfg(test)]
    pub fn inline() -> ControllerWorkers {
        ControllerWorkers {
            renderer: ViewRenderer::without_gpu(),
            jobs: ClassificationJobs::inline(),
            saver: AutosaveWriter::inline(),
        }
    }
}

impl Controller {
    /// A controller whose workers run on threads and whose 3-D view renders on the GPU.
    pub fn new(session_dir: Option<PathBuf>) -> Controller {
        Controller::with_workers(session_dir, ControllerWorkers::threaded())
    }

    /// A controller over these workers.
    pub fn with_workers(session_dir: Option<PathBuf>, workers: ControllerWorkers) -> Controller {
        let ControllerWorkers { renderer, jobs, saver } = workers;
        Controller { work: None, jobs, renderer, saver, chosen_template: None, session_dir, look: SavedLook::default() }
    }

    /// The classes the classifier is trained on: the defined ones, and the pending lassos as
    /// a provisional next class.
    pub fn training_class_count(&self) -> usize {
        self.work.as_ref().map_or(0, |work| work.session.classes.len() + usize::from(!work.session.pending.is_empty()))
    }

    /// The template in use for the current number of classes.
    pub fn template(&self) -> HueTemplate {
        self.chosen_template.unwrap_or_else(|| HueTemplate::default_for(self.training_class_count()))
    }

    /// A volume was opened: work on it starts, with the classes and template of `saved` when
    /// that session was saved for this volume.
    pub fn open(&mut self, mut work: Work, saved: Option<SavedSession>) -> Changed {
        self.look = SavedLook::default();
        let mut preset_lost = None;
        if let Some(saved) = saved
            && saved.volume == work.loaded.source.key()
        {
            work.session = WorkSession::from_strokes(&saved.strokes);
            // No template saved: the class count's default, not the last volume's choice.
            self.chosen_template = TemplateType::from_name(&saved.template)
                .map(|template| HueTemplate::new(template, saved.rotation_degrees));
            self.look = saved.look.sanitised();
            if let Some(path) = self.look.preset.clone() {
                match Preset::read(&path) {
                    Ok(preset) => {
                        // Its classes are those it names that have no lassos of their own.
                        let names = preset.class_names();
                        for class in &mut work.session.classes {
                            class.from_preset = class.lassos.is_empty() && names.contains(&class.name);
                        }
                        work.preset = Some(Arc::new(preset));
                        work.preset_path = Some(path);
                    }
                    Err(error) => {
                        // Its classes have no lassos of their own: without it they are nothing.
                        log::warn!("the saved session's preset is gone: {error}");
                        work.session.classes.retain(|class| !class.lassos.is_empty());
                        self.look.preset = None;
                        preset_lost = Some(format!("The preset of the saved session cannot be read: {error}"));
                    }
                }
            }
        }
        self.jobs.cancel();
        self.renderer.set_volume(work.loaded.volume.clone());
        self.renderer.set_clip(self.look.clip);
        self.work = Some(work);
        let changed = self.session_changed();
        match preset_lost {
            Some(reason) => Changed { failure: Failure::Failed(reason), ..changed },
            None => changed,
        }
    }

    /// A lasso drawn, a class defined or deleted, undo, clear: `edit` on the classes and
    /// lassos; on success autosaved and classified again.
    pub fn edit(&mut self, edit: impl FnOnce(&mut WorkSession) -> Result<(), SessionError>) -> Changed {
        let Some(work) = self.work.as_mut() else { return Changed::default() };
        match edit(&mut work.session) {
            Ok(()) => Changed { status: Some(String::new()), ..self.session_changed() },
            Err(error) => Changed { status: Some(error.to_string()), ..Changed::default() },
        }
    }

    /// Hides a shown class or shows a hidden one.
    pub fn toggle_class(&mut self, index: usize) -> Changed {
        let Some(work) = self.work.as_mut() else { return Changed::default() };
        if work.session.toggle_visible(index).is_err() {
            return Changed::default();
        }
        self.save();
        self.restyle()
    }

    /// The opacity factor of class `index` (1: the default rule's).
    pub fn class_opacity(&self, index: usize) -> f32 {
        let work = self.work.as_ref();
        let name = work.and_then(|work| work.session.classes.get(index)).map(|class| class.name.as_str());
        name.and_then(|name| self.look.class_opacity.get(name)).copied().unwrap_or(1.0)
    }

    /// The opacity slider of class `index` moved to `percent`: the 3-D view redraws with the
    /// new factor at once (the class table alone, no reclassification) and the session is
    /// saved. `classes` is set only when the class appears or disappears on the slices.
    pub fn set_class_opacity(&mut self, index: usize, percent: i32) -> Changed {
        let Some(name) = self.work.as_ref().and_then(|work| work.session.classes.get(index)).map(|c| c.name.clone())
        else {
            return Changed::default();
        };
        let factor = percent.clamp(0, MAX_OPACITY_PERCENT) as f32 / 100.0;
        let before = self.class_opacity(index);
        if before == factor {
            return Changed::default();
        }
        self.look.class_opacity.insert(name, factor);
        self.save();
        let classified = self.work.as_ref().and_then(|work| work.classified.as_ref());
        let view = classified.is_some_and(|c| index < c.table.styles.len());
        if view && let Ok(label) = u8::try_from(index + 1) {
            self.renderer.set_class_opacity(label, factor);
        }
        Changed { classes: (before == 0.0) != (factor == 0.0), view, ..Changed::default() }
    }

    /// A template (or its rotation) chosen.
    pub fn choose_template(&mut self, template: HueTemplate) -> Changed {
        self.chosen_template = Some(template);
        self.save();
        self.restyle()
    }

    /// Collects a finished classification; never blocks.
    pub fn poll(&mut self) -> Changed {
        match self.jobs.poll() {
            Some(JobOutcome::Preview(classified)) => {
                let status = Some(format!("First look in {:.2} s; refining...", classified.seconds));
                self.show_classified(classified, status, true)
            }
            Some(JobOutcome::Done(classified)) => {
                let status = Some(format!("Classified in {:.2} s", classified.seconds));
                self.show_classified(classified, status, false)
            }
            Some(JobOutcome::Guidance(guidance)) => {
                let Some(classified) = self.work.as_mut().and_then(|work| work.classified.as_mut()) else {
                    return Changed::default();
                };
                classified.guidance = Some(guidance);
                Changed { classes: true, ..Changed::default() }
            }
            Some(JobOutcome::Failed(reason)) => {
                log::warn!("classification failed: {reason}");
                // The last good result stays on screen, under the banner that says why the
                // newest one failed.
                if let Some(work) = self.work.as_mut() {
                    work.failure = Some(reason.clone());
                }
                Changed {
                    status: Some("Classification failed".to_string()),
                    failure: Failure::Failed(reason),
                    ..Changed::default()
                }
            }
            None => Changed::default(),
        }
    }

    /// Shows a classification (a first look or the exact one): its labels in the 3-D view, the
    /// failure banner cleared.
    fn show_classified(
        &mut self,
        classified: super::jobs::ClassificationResult,
        status: Option<String>,
        first_look: bool,
    ) -> Changed {
        let Some(work) = self.work.as_mut() else { return Changed::default() };
        let labels = classified.labels.clone();
        work.classified = Some(classified);
        work.failure = None;
        let styles = self.display_styles();
        let view = styles.is_some();
        match styles {
            Some(styles) if first_look => self.renderer.set_first_look(labels, styles),
            Some(styles) => self.renderer.set_labels(labels, styles),
            None => {}
        }
        Changed { classes: true, view, view_cleared: false, status, failure: Failure::Cleared }
    }

    /// The idle timeout: the work and its saved session are forgotten (on disk before this
    /// returns).
    pub fn forget(&mut self) {
        self.jobs.cancel();
        self.work = None;
        self.chosen_template = None;
        self.look = SavedLook::default();
        self.renderer.set_clip(None);
        if let Some(dir) = self.session_dir.clone() {
            self.saver.forget(dir);
            self.saver.flush();
        }
    }

    /// Waits until every autosave handed over is on disk (the app's end).
    pub fn flush(&self) {
        self.saver.flush();
    }

    /// The classification's styles with the current template and the user's visibility.
    pub fn display_styles(&self) -> Option<Vec<ClassStyle>> {
        let work = self.work.as_ref()?;
        let classified = work.classified.as_ref()?;
        let mut styles = classified.table.styles.clone();
        apply_template(&mut styles, &self.template());
        for (index, style) in styles.iter_mut().enumerate() {
            let shown = work.session.classes.get(index).is_none_or(|class| class.visible);
            style.visible = style.visible && shown;
            style.emphasis = self.class_opacity(index);
        }
        Some(styles)
    }

    /// New colours or visibility: the class table alone to the 3-D view.
    fn restyle(&mut self) -> Changed {
        let styles = self.display_styles();
        let view = styles.is_some();
        if let Some(styles) = styles {
            self.renderer.set_styles(styles);
        }
        Changed { classes: true, view, ..Changed::default() }
    }

    /// After the classes or lassos changed: autosave, classify again when the training set
    /// changed, forget the classification when fewer than two classes remain.
    fn session_changed(&mut self) -> Changed {
        self.save();
        let template = self.template();
        let training = self.training_strokes();
        let applied = self.applied_preset();
        let Some(work) = self.work.as_mut() else { return Changed::default() };
        let mut failure = Failure::Unchanged;
        match training {
            Some(strokes) if work.requested.as_ref() != Some(&strokes) => {
                self.jobs.start(work.loaded.volume.clone(), work.loaded.modality, strokes.clone(), applied, template);
                work.requested = Some(strokes);
            }
            Some(_) => {}
            None => {
                self.jobs.cancel();
                work.requested = None;
                work.classified = None;
                if work.failure.take().is_some() {
                    failure = Failure::Cleared;
                }
            }
        }
        Changed { classes: true, view: false, view_cleared: work.classified.is_none(), status: None, failure }
    }

    /// The line over the 3-D view while it has nothing to show: what to do next, or that a
    /// classification is on its way or failed (never "Classifying..." once the job ended).
    pub fn view_hint(&self) -> &'static str {
        let Some(work) = self.work.as_ref() else { return "" };
        if work.classified.is_some() {
            ""
        } else if work.session.classes.is_empty() && work.session.pending.is_empty() {
            "Draw a loop around a structure on any slice, then tap Define class. Each class gets its colour here in 3-D."
        } else if self.training_class_count() < 2 {
            "Now draw a loop around something else: the 3-D view appears once two classes can be told apart."
        } else if self.jobs.busy() {
            "Classifying..."
        } else if work.failure.is_some() {
            "The classification failed (the banner above says why): undo or change a lasso to try again."
        } else {
            "Classifying..."
        }
    }

    /// Why the newest classification failed, if it did.
    pub fn failure(&self) -> Option<&str> {
        self.work.as_ref()?.failure.as_deref()
    }

    /// A learned preset chosen for the open scan: the session becomes the preset's classes (no
    /// lassos of their own), its colours the preset's, and the scan is classified with it at
    /// once; loops drawn afterwards add to it. A preset that does not fit the scan (another
    /// modality, not in Hounsfield units) changes nothing and says why in the banner.
    pub fn apply_preset(&mut self, preset: Arc<Preset>, path: Option<PathBuf>) -> Changed {
        let Some(work) = self.work.as_mut() else { return Changed::default() };
        if let Err(error) = preset.check_scan(&work.loaded.volume, work.loaded.modality) {
            return Changed { failure: Failure::Failed(error.to_string()), ..Changed::default() };
        }
        let count = preset.classes.len();
        if count > crate::session::MAX_CLASSES {
            let reason = format!(
                "the preset '{}' has {count} classes and the class bar holds at most {}",
                preset.name,
                crate::session::MAX_CLASSES
            );
            return Changed { failure: Failure::Failed(reason), ..Changed::default() };
        }
        work.session.replace_with_preset(&preset.class_names());
        work.preset = Some(preset.clone());
        work.preset_path = path;
        work.requested = None;
        self.chosen_template = Some(preset.template);
        self.look = SavedLook::default();
        Changed { status: Some(String::new()), ..self.session_changed() }
    }

    /// The classification shown as a learned preset named `name`: its training, its classes'
    /// names and looks. Why not, when there is no finished classification to keep.
    pub fn preset_of_shown(&self, name: &str) -> Result<Preset, String> {
        let work = self.work.as_ref().ok_or("no scan is open")?;
        let classified = work.classified.as_ref().ok_or("classify the scan first")?;
        let guidance = classified.guidance.as_ref().ok_or("wait until the classification is finished")?;
        let names = self.classified_names().ok_or("classify the scan first")?;
        let mut table = classified.table.clone();
        if let Some(styles) = self.display_styles() {
            table.styles = styles;
        }
        table.template = self.template();
        Preset::of(name, &guidance.segmenter, &work.loaded.volume, work.loaded.modality, &names, &table)
            .map_err(|error| error.to_string())
    }

    /// The names of the classes the classification is of, in class order: the preset's still
    /// in the session, then the session's others and the pending lassos' provisional class.
    fn classified_names(&self) -> Option<Vec<String>> {
        let strokes = self.training_strokes()?;
        Some(super::jobs::class_names(self.applied_preset().as_ref(), &strokes))
    }

    /// The applied preset with its classes the session still has (a class deleted, or the
    /// application undone, stays out); `None` without a preset or when none of its classes is
    /// left.
    fn applied_preset(&self) -> Option<AppliedPreset> {
        let work = self.work.as_ref()?;
        let names: Vec<String> =
            work.session.classes.iter().filter(|class| class.from_preset).map(|class| class.name.clone()).collect();
        let preset = work.preset.as_ref()?.only(&names)?;
        Some(AppliedPreset { preset: Arc::new(preset), modality: work.loaded.modality })
    }

    /// The defined classes plus the pending lassos as the provisional next class; `None` when
    /// there are fewer than two.
    fn training_strokes(&self) -> Option<StrokesFile> {
        let work = self.work.as_ref()?;
        let mut strokes = work.session.strokes();
        if !work.session.pending.is_empty() {
            strokes
                .classes
                .push(ClassStrokes { name: work.session.next_class_name(), strokes: work.session.pending.clone() });
        }
        // One class has nothing to be told apart from: its lassos are shown, nothing is trained.
        (strokes.classes.len() >= 2).then_some(strokes)
    }

    /// Hands the session to the autosave writer, when autosave is on and a volume is open.
    pub(super) fn save(&self) {
        let (Some(dir), Some(saved)) = (&self.session_dir, self.saved_session()) else { return };
        self.saver.save(dir.clone(), saved);
    }

    /// The session as autosave writes it (and the gallery keeps it); `None` without a volume.
    pub fn saved_session(&self) -> Option<SavedSession> {
        let work = self.work.as_ref()?;
        let template = self.chosen_template;
        Some(autosave::SavedSession {
            volume: work.loaded.source.key(),
            template: template.map_or(String::new(), |t| t.template.name().to_string()),
            rotation_degrees: template.map_or(0.0, |t| t.rotation_degrees),
            strokes: work.session.strokes(),
            look: self.saved_look(),
        })
    }
}

impl Controller {
    /// The look to save: the opacities of the classes that exist (not those deleted).
    fn saved_look(&self) -> SavedLook {
        let mut look = self.look.clone();
        if let Some(work) = &self.work {
            look.class_opacity.retain(|name, _| work.session.classes.iter().any(|class| &class.name == name));
            look.preset = work.preset.as_ref().and(work.preset_path.clone());
        }
        look
    }
}

#[cfg(test)]
#[path = "controller_tests.rs"]
mod tests;
