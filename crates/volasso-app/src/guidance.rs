//! Where to draw next: the "Show unsure" toggle stripes, on the slices, the voxels the classifier
//! is least sure of, and "Draw here next" moves a panel to the slice that holds most of them
//! (`volasso_core::uncertainty`; in the paper's user survey, §4.1, users could miss regions
//! the slices do not show). Both act on the classification shown; before there is one they
//! say so.
//!
//! The panel moved is the enlarged one when a slice is enlarged (the user is working there),
//! otherwise whichever of the three panels' axes has the slice with the most unsure voxels.
//! The stripes are turned on with it, so the user sees what to draw around.
//!
//! Never: changes the classes or the classification; it only moves panels and marks pictures.

use crate::Work;
use crate::model::{AppModel, Show};

/// Said when there is nothing to be unsure of yet.
pub const NOTHING_CLASSIFIED: &str = "Draw two classes first: then the classifier can say where it is unsure";

/// Shown on the panel "Draw here next" moved, until the next touch on a slice.
pub const PANEL_HINT: &str = "Draw here next: the least sure slice (striped)";

/// The panel, its slice and the unsure voxels the survey found there: the enlarged panel's
/// best slice when one is enlarged, else the best over the three panels. `None` before a
/// classification with a survey, or when no voxel is unsure.
pub(super) fn next_place(work: &Work) -> Option<(usize, usize, u32)> {
    let survey = &work.guidance()?.survey;
    let candidates: Vec<usize> = match work.enlarged {
        Some(panel) => vec![panel],
        None => (0..work.panels.len()).collect(),
    };
    candidates
        .into_iter()
        .filter_map(|panel| {
            let (slice, count) = survey.most_unsure_slice(work.panels.get(panel)?.axis)?;
            Some((panel, slice, count))
        })
        .max_by_key(|&(panel, _, count)| (count, std::cmp::Reverse(panel)))
}

/// The status line for the stripes turned on or off.
fn describe(work: &Work) -> String {
    match work.guidance() {
        Some(guidance) if work.unsure_shown => {
            format!("Striped: the {:.0} % least sure voxels", 100.0 * guidance.survey.unsure_fraction())
        }
        Some(_) => "Unsure voxels hidden".to_string(),
        None => NOTHING_CLASSIFIED.to_string(),
    }
}

impl AppModel {
    /// "Unsure": stripes on or off.
    pub(crate) fn toggle_unsure(&mut self) -> Show {
        let Some(work) = self.ctl.work.as_mut() else { return Show::default() };
        let surveyed = work.guidance().is_some();
        work.unsure_shown = surveyed && !work.unsure_shown;
        self.status = describe(work);
        Show::work()
    }

    /// "Draw here next": the panel moves to the slice with the most unsure voxels, stripes on.
    pub(crate) fn draw_here_next(&mut self) -> Show {
        let Some(work) = self.ctl.work.as_mut() else { return Show::default() };
        let place = next_place(work);
        self.status = match place {
            Some((panel, slice, _)) => {
                let order = &work.loaded.entropies.axis(work.panels[panel].axis).order;
                let shown = &mut work.panels[panel];
                shown.slice = slice;
                shown.rank = order.iter().position(|&s| s == slice).unwrap_or(shown.rank);
                work.unsure_shown = true;
                // Said on the panel itself, so the eye finds the slice that moved.
                work.feedback = Some((panel, PANEL_HINT.to_string()));
                let title =
                    shown.layout.plane.map_or_else(|| format!("slice {}", shown.axis), |p| p.name().to_string());
                format!("Draw here next: {title} {slice}")
            }
            None if work.guidance().is_some() => "The classifier is sure of every voxel it classified".to_string(),
            None => NOTHING_CLASSIFIED.to_string(),
        };
        if place.is_some() { Show::work() } else { Show::status() }
    }
}
