//! The gallery on screen: the kept results as cards on the chooser after the volumes. What
//! "Save" and a card's tap do is the model's (model.rs).
//!
//! Never: decides what is saved or opened.

use crate::State;
use crate::gallery::{self, Listed};
use crate::ui::ResultCard;
use crate::view::images::rgba_to_slint_image;
use slint::Model;

/// The gallery as listed, onto the chooser's result cards.
pub(crate) fn show_cards(state: &State) {
    let cards: Vec<ResultCard> = state.gallery.listed().iter().map(card).collect();
    state.rows.results.set_vec(cards);
}

fn card(listed: &Listed) -> ResultCard {
    match listed {
        Listed::Entry { entry, thumbnail, .. } => ResultCard {
            name: entry.volume_name.clone().into(),
            date: gallery::date_text(entry.saved_unix).into(),
            thumbnail: thumbnail.as_ref().map_or_else(slint::Image::default, rgba_to_slint_image),
            problem: if entry.volume_missing() { crate::words::tr(&entry.missing_message()).into() } else { "".into() },
        },
        Listed::Damaged { folder, reason } => ResultCard {
            name: folder.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()).into(),
            date: "".into(),
            thumbnail: slint::Image::default(),
            problem: crate::words::tr(&format!("This saved result cannot be read: {reason}")).into(),
        },
    }
}

/// Replay keys: `results` (cards), `result-problem-N` (the message on card N, from 1; empty
/// when it opens).
pub(crate) fn query(state: &State, key: &str) -> Option<String> {
    if key == "results" {
        return Some(state.rows.results.row_count().to_string());
    }
    let number: usize = key.strip_prefix("result-problem-")?.parse().ok()?;
    let card = state.rows.results.row_data(number.checked_sub(1)?)?;
    Some(card.problem.to_string())
}
