//! The chooser's cards on screen: the cards that changed (cards.rs) written into the
//! `Session.volumes` rows.
//!
//! Never: decides anything (the model does, `loading.rs`).

use crate::State;
use crate::chooser::cards::{Card, Changes};
use crate::ui::VolumeCard;
use crate::view::images::to_slint_image;
use slint::Model;

/// Shows the cards that changed in the chooser.
pub(crate) fn show_cards(state: &mut State) {
    let changes = state.cards.take_changes();
    let model = state.rows.volumes.clone();
    let card = |index: usize| state.cards.card(index).map(to_volume_card);
    match changes {
        Changes::None => {}
        Changes::All => model.set_vec((0..state.cards.len()).filter_map(card).collect::<Vec<_>>()),
        Changes::Rows(rows) => {
            for index in rows {
                let Some(shown) = card(index) else { continue };
                if index < model.row_count() {
                    model.set_row_data(index, shown);
                } else {
                    // New cards come in order after the shown ones.
                    while model.row_count() < index {
                        let Some(before) = card(model.row_count()) else { break };
                        model.push(before);
                    }
                    model.push(shown);
                }
            }
        }
    }
}

/// A card as the chooser shows it.
fn to_volume_card(card: &Card) -> VolumeCard {
    VolumeCard {
        name: card.name.clone().into(),
        detail: crate::words::tr(&card.detail).into(),
        patient: card.patient.clone().into(),
        expires: crate::words::tr(&card.expires).into(),
        thumbnail: card.thumbnail.as_ref().map_or_else(slint::Image::default, to_slint_image),
        failed: card.failed,
    }
}
