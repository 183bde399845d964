//! A touch on a slice panel, applied to the app: the work decides (`slices.rs`), and its
//! [`SliceOutcome`] says what the screens show again; a lasso drawn goes to the session.
//!
//! Never: decides what a touch means.

use crate::lasso::slices::{SliceIntent, SliceOutcome};
use crate::model::{AppModel, Show};

impl AppModel {
    /// Applies `intent` to the open work; nothing without one.
    pub(crate) fn on_slices(&mut self, intent: SliceIntent) -> Show {
        let Some(work) = self.ctl.work.as_mut() else { return Show::default() };
        let SliceOutcome { path, panels, layout, window, status, lasso } = work.on_slices(intent);
        let mut show = Show { lasso_path: path, slice_layout: layout, work: window, ..Show::default() };
        for panel in panels {
            if let Some(shown) = show.panels.get_mut(panel) {
                *shown = true;
            }
        }
        if let Some(status) = status {
            self.status = status;
            show.status = true;
        }
        match lasso {
            Some(lasso) => show.and(self.edit(|session| {
                session.add_lasso(lasso);
                Ok(())
            })),
            None => show,
        }
    }
}
