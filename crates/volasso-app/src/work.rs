//! The work on an open volume: the volume, the session of classes and lassos, the three slice
//! panels, the finger path being drawn, the classification shown and the display window.
//! Plain data, read and changed by the controller and the screens' logic.
//!
//! Never: calls Slint or starts work; it is what the work is, not what happens to it.

use crate::chooser::library::LoadedVolume;
use crate::jobs::{self, ClassificationResult};
use crate::lasso::drawing::FingerPath;
use crate::session::WorkSession;
use volasso_core::slices::{Axis, DisplayWindow, SliceLayout};
use volasso_core::strokes::StrokesFile;

/// The panels of the work screen: axial, coronal, sagittal (`slices::plane_axes`).
pub(crate) const PANEL_COUNT: usize = 3;

/// One slice panel: which axis, where in that axis's ranking it stands, and how it lies on the
/// screen.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Panel {
    pub(crate) axis: Axis,
    /// 0 = the highest-ranked slice.
    pub(crate) rank: usize,
    pub(crate) slice: usize,
    pub(crate) layout: SliceLayout,
}

/// An open volume and the user's work on it.
pub(crate) struct Work {
    pub(crate) loaded: LoadedVolume,
    pub(crate) session: WorkSession,
    pub(crate) panels: [Panel; PANEL_COUNT],
    /// The finger path being drawn, on which panel.
    pub(crate) drawing: Option<(usize, FingerPath)>,
    /// The last path that broke off open, on which panel: a finger landing again where it left
    /// goes on with it ([`FingerPath::resumed_or_new`]).
    pub(crate) broken_off: Option<(usize, FingerPath)>,
    pub(crate) classified: Option<ClassificationResult>,
    /// Why the newest classification failed; `None` once one succeeds, and while fewer than
    /// two classes are drawn. The last good result stays in `classified`.
    pub(crate) failure: Option<String>,
    /// The training data of the newest job started, so an unchanged set is not sent again.
    pub(crate) requested: Option<StrokesFile>,
    /// The learned preset applied to this scan: its classes are the session's first ones
    /// (without lassos of their own until the user draws some), and it trains with them.
    pub(crate) preset: Option<std::sync::Arc<volasso_core::preset::Preset>>,
    /// Its file, where it came from one (a saved session names it).
    pub(crate) preset_path: Option<std::path::PathBuf>,
    /// The display window of the slices and its name (a preset, or "Custom" after a drag).
    pub(crate) window: DisplayWindow,
    pub(crate) window_name: String,
    /// The panel that fills the work area, if one does, with its zoom (1 = fits) and pan
    /// (fractions of the visible area, from its centre).
    pub(crate) enlarged: Option<usize>,
    pub(crate) zoom: f32,
    pub(crate) pan: [f32; 2],
    /// Why the last path on a panel meant nothing, shown on that panel until the next touch.
    pub(crate) feedback: Option<(usize, String)>,
    /// The voxels the classifier is least sure of are striped on the slices (guidance.rs).
    pub(crate) unsure_shown: bool,
}

impl Work {
    /// The trained classifier and the survey of where it is unsure, for the classification
    /// shown; `None` before one (or when its survey failed).
    pub(crate) fn guidance(&self) -> Option<&jobs::Guidance> {
        self.classified.as_ref()?.guidance.as_deref()
    }

    /// Work on a newly opened volume: no classes yet, each panel on its highest-ranked slice,
    /// the volume's first display window.
    pub(crate) fn new(loaded: LoadedVolume) -> Work {
        let orientation = loaded.volume.orientation.as_ref();
        let panels = volasso_core::slices::plane_axes(orientation).map(|axis| Panel {
            axis,
            rank: 0,
            slice: loaded.entropies.axis(axis).top(),
            layout: SliceLayout::new(orientation, axis),
        });
        let initial = loaded.windows.initial();
        Work {
            session: WorkSession::default(),
            panels,
            drawing: None,
            broken_off: None,
            classified: None,
            failure: None,
            requested: None,
            preset: None,
            preset_path: None,
            window: initial.window,
            window_name: initial.name.to_string(),
            enlarged: None,
            zoom: 1.0,
            pan: [0.0; 2],
            feedback: None,
            unsure_shown: false,
            loaded,
        }
    }
}
