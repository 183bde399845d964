//! The attract mode on the start screen: starts and ends the model (mod.rs) where the app
//! goes back to or leaves the start screen, and shows the picture each tick says is due.
//!
//! Never: decides what to show or when; the model does.

use crate::State;
use crate::ui::{AppWindow, Session};
use slint::ComponentHandle;
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// The idle timeout brought the start screen back: the turntable starts.
pub(crate) fn begin(window: &AppWindow, state: &Shared) {
    let side = picture_side(window);
    let mut state = state.borrow_mut();
    let Some(showing) = super::what_to_show(state.config.data_dir.as_deref()) else { return };
    let (options, now) = (state.config.open_options.clone(), state.config.clock.now());
    state.attract.begin(showing, side, options, now);
    window.global::<Session>().set_attract_caption("".into());
}

/// The start screen is left: the turntable stops.
pub(crate) fn end(window: &AppWindow, state: &Shared) {
    state.borrow_mut().attract.end();
    let session = window.global::<Session>();
    session.set_attracting(false);
    session.set_attract_picture(slint::Image::default());
}

/// The poll's tick: the model moves on, and a picture that is due is shown.
pub(crate) fn tick(window: &AppWindow, state: &Shared) {
    let shown = {
        let mut state = state.borrow_mut();
        let now = state.config.clock.now();
        state.attract.tick(now)
    };
    let Some(shown) = shown else { return };
    let session = window.global::<Session>();
    session.set_attracting(true);
    session.set_attract_caption(shown.caption.into());
    session.set_attract_picture(crate::refresh::rgba_to_slint_image(&shown.frame));
}

/// The side of a turntable picture in pixels: the start screen's picture at its scale.
fn picture_side(window: &AppWindow) -> u32 {
    let scale = window.window().scale_factor();
    ((window.global::<Session>().get_attract_size() * scale).round() as u32).clamp(64, super::MAX_SIDE)
}
