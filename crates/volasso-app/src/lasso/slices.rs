//! What touches on a slice do to the work, without a window: finger paths become lassos or
//! swipes (decided in drawing.rs, with feedback on the panel for anything else), the ranked and
//! scrubbed slice changes, a slice is enlarged to fill the work area and zoomed and panned there
//! with two fingers, and the display window is picked from the choices or dragged with two
//! fingers on a slice of the grid. Each [`SliceIntent`] changes the [`Work`] and says what the
//! screen must show again ([`SliceOutcome`]); `on_slices.rs` applies it to the app.
//!
//! Never: changes what the classifier sees other than through lassos (windows are display
//! only), or calls Slint.

use crate::lasso::drawing::{FingerPath, PathMeaning, Unclear};
use crate::windowing::{self, CUSTOM};
use crate::work::Work;
use volasso_core::slices::Axis;
use volasso_core::strokes::Lasso;

/// The zoom of an enlarged slice: 1 fits the work area.
pub const ZOOM_RANGE: (f32, f32) = (1.0, 8.0);

/// A touch on the slice panels, as the screen reports it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum SliceIntent {
    /// A finger landed on `panel` at `point` (fractions of the picture as shown, `picture_px`
    /// its size in pixels) at `ms`.
    Down { panel: usize, point: [f32; 2], picture_px: [f32; 2], ms: f64 },
    /// The finger moved.
    Move { panel: usize, point: [f32; 2], ms: f64 },
    /// The finger lifted; a negative point: the touch was cancelled (a second finger made it a
    /// two-finger gesture, which is not a path).
    Up { panel: usize, point: [f32; 2], ms: f64 },
    /// The slice `delta` ranks further along the panel's ranking (◀ ▶).
    Step { panel: usize, delta: i32 },
    /// Slice `slice` of the panel's axis (the scrubber).
    Scrub { panel: usize, slice: i32 },
    /// The panel fills the work area.
    Enlarge(usize),
    /// Back to the three slices.
    Shrink,
    /// A display window chosen by name.
    ChooseWindow(String),
    /// Two fingers on the slice normal to `axis`: on the enlarged slice they zoom (`zoom`
    /// multiplies) and pan (`pan` in fractions of the visible area); on a slice of the grid
    /// they drag the display window (windowing.rs).
    Gesture { axis: Axis, zoom: f32, pan: [f32; 2] },
}

/// What the screen shows again after an intent.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SliceOutcome {
    /// The finger path being drawn.
    pub(crate) path: bool,
    /// These panels (their slice, numbers or feedback).
    pub(crate) panels: Vec<usize>,
    /// Which slice is enlarged, its zoom and pan.
    pub(crate) layout: bool,
    /// The display window: every slice and the window's name.
    pub(crate) window: bool,
    /// A new status line.
    pub(crate) status: Option<String>,
    /// A lasso drawn: it goes to the session (which classifies again).
    pub(crate) lasso: Option<Lasso>,
}

impl Work {
    /// Applies a touch on the slices (module doc).
    pub(crate) fn on_slices(&mut self, intent: SliceIntent) -> SliceOutcome {
        match intent {
            SliceIntent::Down { panel, point, picture_px, ms } => {
                let had_feedback = self.feedback.take().map(|(on, _)| on);
                let broken_off = self.broken_off.take().filter(|(on, _)| *on == panel).map(|(_, path)| path);
                self.drawing = Some((panel, FingerPath::resumed_or_new(broken_off, picture_px, point, ms)));
                SliceOutcome { path: true, panels: had_feedback.into_iter().collect(), ..SliceOutcome::default() }
            }
            SliceIntent::Move { panel, point, ms } => match self.drawing.as_mut() {
                Some((drawn_on, path)) if *drawn_on == panel => {
                    path.add(point, ms);
                    SliceOutcome { path: true, ..SliceOutcome::default() }
                }
                _ => SliceOutcome::default(),
            },
            SliceIntent::Up { panel, point, ms } => self.finger_lifted(panel, point, ms),
            SliceIntent::Step { panel, delta } => self.move_slice(panel, |rank, order| {
                let rank = (rank as i64 + delta as i64).clamp(0, order.len() as i64 - 1) as usize;
                (rank, order[rank])
            }),
            SliceIntent::Scrub { panel, slice } => self.move_slice(panel, |_, order| {
                let slice = (slice.max(0) as usize).min(order.len() - 1);
                (order.iter().position(|&s| s == slice).unwrap_or(0), slice)
            }),
            SliceIntent::Enlarge(panel) if panel < self.panels.len() => {
                self.enlarged = Some(panel);
                self.zoom = 1.0;
                self.pan = [0.0; 2];
                self.drawing = None;
                self.broken_off = None;
                SliceOutcome { layout: true, ..SliceOutcome::default() }
            }
            SliceIntent::Enlarge(_) => SliceOutcome::default(),
            SliceIntent::Shrink => {
                self.enlarged = None;
                self.drawing = None;
                self.broken_off = None;
                SliceOutcome { layout: true, ..SliceOutcome::default() }
            }
            SliceIntent::ChooseWindow(name) => {
                let Some(choice) = self.loaded.windows.find(&name) else { return SliceOutcome::default() };
                self.window = choice.window;
                self.window_name = choice.name.to_string();
                let status = Some(windowing::describe(choice.name, choice.window));
                SliceOutcome { window: true, status, ..SliceOutcome::default() }
            }
            SliceIntent::Gesture { axis, zoom, pan } => self.gesture(axis, zoom, pan),
        }
    }

    /// The finger lifted: a lasso, a swipe, or feedback on the panel. A path that broke off
    /// open is kept a moment, for the finger to land again and go on with it.
    fn finger_lifted(&mut self, panel: usize, point: [f32; 2], ms: f64) -> SliceOutcome {
        let Some((drawn_on, mut path)) = self.drawing.take() else { return SliceOutcome::default() };
        let lifted = SliceOutcome { path: true, ..SliceOutcome::default() };
        let meaning = if drawn_on != panel {
            None
        } else if point[0] < 0.0 {
            path.cancelled().map(PathMeaning::Unclear)
        } else {
            path.add(point, ms);
            let dims = self.loaded.volume.dims;
            let meaning = self.panels.get(drawn_on).map(|p| path.meaning(dims, &p.layout, p.slice));
            if let Some(PathMeaning::Unclear(Unclear::Open)) = meaning {
                self.broken_off = Some((drawn_on, path));
            }
            meaning
        };
        match meaning {
            Some(PathMeaning::Lasso(lasso)) => SliceOutcome { lasso: Some(lasso), ..lifted },
            Some(PathMeaning::Swipe(delta)) => {
                SliceOutcome { path: true, ..self.on_slices(SliceIntent::Step { panel: drawn_on, delta }) }
            }
            Some(PathMeaning::Unclear(unclear)) => {
                self.feedback = Some((drawn_on, unclear.message().into()));
                SliceOutcome { panels: vec![drawn_on], status: Some(unclear.message().into()), ..lifted }
            }
            None => lifted,
        }
    }

    /// Shows on `panel` the (rank, slice) that `choose` picks from the current rank and the
    /// axis's ranking (never empty: an axis has at least one slice).
    fn move_slice(&mut self, panel: usize, choose: impl FnOnce(usize, &[usize]) -> (usize, usize)) -> SliceOutcome {
        self.feedback = None;
        let ranking = &self.loaded.entropies;
        let Some(shown) = self.panels.get_mut(panel) else { return SliceOutcome::default() };
        (shown.rank, shown.slice) = choose(shown.rank, &ranking.axis(shown.axis).order);
        SliceOutcome { panels: vec![panel], ..SliceOutcome::default() }
    }

    fn gesture(&mut self, axis: Axis, zoom: f32, pan: [f32; 2]) -> SliceOutcome {
        if !(zoom.is_finite() && zoom > 0.0 && pan.iter().all(|p| p.is_finite())) {
            return SliceOutcome::default();
        }
        let Some(panel) = self.panels.iter().position(|p| p.axis == axis) else { return SliceOutcome::default() };
        if self.enlarged == Some(panel) {
            let zoomed = (self.zoom * zoom).clamp(ZOOM_RANGE.0, ZOOM_RANGE.1);
            let ratio = zoomed / self.zoom;
            self.zoom = zoomed;
            // The point at the area's centre stays there as the zoom changes; the picture
            // cannot be pushed further than its edges.
            let limit = (zoomed - 1.0) / 2.0;
            self.pan = std::array::from_fn(|a| (self.pan[a] * ratio + pan[a]).clamp(-limit, limit));
            SliceOutcome { layout: true, ..SliceOutcome::default() }
        } else if self.enlarged.is_none() && pan != [0.0; 2] {
            let range = self.loaded.volume.value_range();
            self.window = windowing::dragged(self.window, pan, range);
            self.window_name = CUSTOM.to_string();
            let status = Some(windowing::describe(CUSTOM, self.window));
            SliceOutcome { window: true, status, ..SliceOutcome::default() }
        } else {
            SliceOutcome::default()
        }
    }
}

#[cfg(test)]
#[path = "slices_tests.rs"]
mod tests;
