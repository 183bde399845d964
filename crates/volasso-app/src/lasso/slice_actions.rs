//! Touches on the slice panels, from the window to the work and back: each callback is a
//! [`SliceIntent`] that the work applies (`slices.rs`, where all of it is decided and tested
//! without a window), and its [`SliceOutcome`] is shown here.
//!
//! Never: decides what a touch means.

use crate::lasso::slices::{SliceIntent, SliceOutcome};
use crate::ui::AppWindow;
use crate::{State, refresh};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// Applies `intent` to the open work and shows what changed; nothing without one.
pub(crate) fn slice_intent(window: &AppWindow, state: &Shared, intent: SliceIntent) {
    let outcome = {
        let mut state_ref = state.borrow_mut();
        let Some(work) = state_ref.ctl.work.as_mut() else { return };
        let outcome = work.on_slices(intent);
        if let Some(status) = &outcome.status {
            state_ref.status = status.clone();
        }
        outcome
    };
    show(window, state, outcome);
}

fn show(window: &AppWindow, state: &Shared, outcome: SliceOutcome) {
    let SliceOutcome { path, panels, layout, window: window_changed, status, lasso } = outcome;
    for panel in panels {
        refresh::push_slice(window, state, panel);
    }
    if path {
        refresh::push_lasso(window, state);
    }
    if window_changed {
        refresh::push_work(window, state);
    } else if layout {
        refresh::push_slice_layout(window, state);
    }
    if status.is_some() {
        refresh::push_status(window, state);
    }
    if let Some(lasso) = lasso {
        refresh::edit_session(window, state, |session| {
            session.add_lasso(lasso);
            Ok(())
        });
    }
}
