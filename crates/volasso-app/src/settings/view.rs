//! The settings screen on screen: [`show`] writes the model (mod.rs) into SettingsPage, and
//! [`show_language`] switches the screens' words.
//!
//! Never: decides anything (that is `SettingsScreen`'s).

use crate::State;
use crate::ui::{AppWindow, SettingRow, SettingsPage};
use crate::words::tr;
use slint::{ComponentHandle, ModelRc, VecModel};

/// The screens in `language` from now on: Slint's words at once, the app's lines as they are
/// next written (words.rs).
pub(crate) fn show_language(language: volasso_appliance::settings::Language) {
    crate::words::set_language(language);
    if let Err(error) = slint::select_bundled_translation(crate::words::code(language)) {
        log::warn!("the screens stay in English: {error}");
    }
}

/// Writes the model into SettingsPage.
pub(crate) fn show(window: &AppWindow, state: &State) {
    let page = window.global::<SettingsPage>();
    match &state.settings.phase {
        super::Phase::Closed => {}
        super::Phase::Pin(entry) => {
            page.set_phase(0);
            page.set_pin_title(
                tr(match entry.step {
                    super::PinStep::Enter => "Type the PIN",
                    super::PinStep::Choose => "Choose a PIN of 4 to 8 digits",
                    super::PinStep::Confirm { .. } => "Type the new PIN again",
                })
                .into(),
            );
            page.set_pin_length(entry.typed.len() as i32);
            page.set_pin_message(tr(&entry.message).into());
        }
        super::Phase::Rows(rows) => {
            page.set_phase(1);
            page.set_message(tr(&rows.message).into());
            let rows_shown = state.settings.rows();
            let shown: Vec<SettingRow> = rows_shown
                .iter()
                .map(|row| SettingRow {
                    key: row.key.into(),
                    label: tr(row.label).into(),
                    value: tr(&row.value).into(),
                    typed: row.typed,
                    later: row.applies_later,
                })
                .collect();
            let half = shown.len().div_ceil(2);
            page.set_rows_first(ModelRc::new(VecModel::from(shown[..half].to_vec())));
            page.set_rows_second(ModelRc::new(VecModel::from(shown[half..].to_vec())));
            page.set_editing(rows.editing.is_some());
            if let Some(editing) = &rows.editing {
                let label = rows_shown.iter().find(|row| row.key == editing.key).map(|row| row.label);
                page.set_edit_label(tr(label.unwrap_or_default()).into());
                page.set_edit_text(editing.text.as_str().into());
            }
        }
    }
}
