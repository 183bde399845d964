//! Learned presets on screen: the chooser's preset menu (the preset that colours the next scan
//! opened) and the work screen's "Presets" menu ("Save as preset", "Apply NAME"), written from
//! the shelf (mod.rs).
//!
//! Never: decides anything.

use crate::State;
use crate::ui::{AppWindow, Session};
use slint::ComponentHandle;
use std::rc::Rc;

/// Both menus: the presets' names and the chooser's choice.
pub(crate) fn show(window: &AppWindow, state: &State) {
    let session = window.global::<Session>();
    let names: Vec<slint::SharedString> = state.presets.shelf.names().into_iter().map(Into::into).collect();
    session.set_preset_names(Rc::new(slint::VecModel::from(names)).into());
    session.set_chooser_preset(state.presets.chosen.map_or(-1, |chosen| chosen as i32));
}
