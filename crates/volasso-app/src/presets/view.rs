//! Learned presets on the screens: the chooser's preset menu (the preset that colours the next
//! scan opened), the work screen's "Presets" menu ("Save as preset", "Apply NAME"). What a
//! preset is and does is the core's and the controller's; this file moves it between them,
//! the shelf in the data folder and the window.
//!
//! Never: decides how a preset classifies (the controller applies it).

use super::{Shelf, default_name};
use crate::State;
use crate::refresh;
use crate::ui::{AppWindow, Session};
use slint::ComponentHandle;
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// The presets' part of the app's state: the shelf and the chooser's choice.
#[derive(Default)]
pub(crate) struct Presets {
    pub(crate) shelf: Shelf,
    /// The preset the chooser applies to the next scan opened.
    pub(crate) chosen: Option<usize>,
}

/// Lists the data folder's presets again onto both menus.
pub(crate) fn relist(window: &AppWindow, state: &Shared) {
    {
        let mut state = state.borrow_mut();
        let data_dir = state.config.data_dir.clone();
        state.presets.shelf.relist(data_dir.as_deref());
        let count = state.presets.shelf.names().len();
        state.presets.chosen = state.presets.chosen.filter(|&chosen| chosen < count);
    }
    push(window, state);
}

/// Collects a finished save; called by the poll timer.
pub(crate) fn poll(window: &AppWindow, state: &Shared) {
    let finished = state.borrow_mut().presets.shelf.poll();
    if let Some(status) = finished {
        state.borrow_mut().status = status;
        relist(window, state);
        refresh::push_status(window, state);
    }
}

fn push(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
    let session = window.global::<Session>();
    let names: Vec<slint::SharedString> = state.presets.shelf.names().into_iter().map(Into::into).collect();
    session.set_preset_names(Rc::new(slint::VecModel::from(names)).into());
    session.set_chooser_preset(state.presets.chosen.map_or(-1, |chosen| chosen as i32));
}

/// The chooser's menu: `index` colours the next scan opened (-1: none).
pub(crate) fn choose(window: &AppWindow, state: &Shared, index: i32) {
    state.borrow_mut().presets.chosen = usize::try_from(index).ok();
    push(window, state);
}

/// "Save as preset": the classification shown, named after the scan and its classes, handed
/// to the shelf's writer; the status line says so, or why not.
pub(crate) fn save(window: &AppWindow, state: &Shared) {
    {
        let mut state = state.borrow_mut();
        let name = state.ctl.work.as_ref().map(|work| {
            let scan = work.loaded.title.clone().unwrap_or_else(|| work.loaded.source.name());
            let classes: Vec<String> = work.session.classes.iter().map(|class| class.name.clone()).collect();
            default_name(&scan, &classes)
        });
        let preset = name.ok_or("no scan is open".to_string()).and_then(|name| state.ctl.preset_of_shown(&name));
        state.status = match preset {
            Ok(preset) => state.presets.shelf.save(preset),
            Err(reason) => format!("The preset was not saved: {reason}"),
        };
    }
    refresh::push_status(window, state);
}

/// "Apply NAME": the preset at `index` colours the open scan.
pub(crate) fn apply(window: &AppWindow, state: &Shared, index: i32) {
    let preset = usize::try_from(index).ok().and_then(|index| state.borrow().presets.shelf.get(index));
    let Some((path, preset)) = preset else { return };
    let changed = state.borrow_mut().ctl.apply_preset(preset.clone(), Some(path));
    let applied = changed.failure == crate::controller::Failure::Unchanged;
    refresh::apply(window, state, changed);
    if applied {
        state.borrow_mut().status = format!("Preset applied: {}", preset.name);
        refresh::push_status(window, state);
    }
}

/// A scan just opened from the chooser: the preset chosen there colours it.
pub(crate) fn apply_chosen(window: &AppWindow, state: &Shared) {
    let chosen = state.borrow().presets.chosen;
    if let Some(index) = chosen {
        apply(window, state, index as i32);
    }
}
