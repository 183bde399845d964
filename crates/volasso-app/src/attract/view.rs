//! The attract mode on the start screen: the picture and caption the model (mod.rs) says are
//! due, written into Session.
//!
//! Never: decides what to show or when.

use crate::model::AttractShow;
use crate::ui::{AppWindow, Session};
use slint::ComponentHandle;

/// Shows what changed on the turntable.
pub(crate) fn show(window: &AppWindow, shown: AttractShow) {
    let session = window.global::<Session>();
    match shown {
        AttractShow::Begin => session.set_attract_caption("".into()),
        AttractShow::End => {
            session.set_attracting(false);
            session.set_attract_picture(slint::Image::default());
        }
        AttractShow::Frame(shown) => {
            session.set_attracting(true);
            session.set_attract_caption(shown.caption.into());
            session.set_attract_picture(crate::view::images::rgba_to_slint_image(&shown.frame));
        }
    }
}

/// The side of a turntable picture in pixels: the start screen's picture at its scale (the
/// model keeps it within its bounds).
pub(crate) fn picture_side(window: &AppWindow) -> u32 {
    let scale = window.window().scale_factor();
    (window.global::<Session>().get_attract_size() * scale).round() as u32
}
