//! The settings screen on screen: SettingsPage's callbacks become [`SettingsIntent`]s, the
//! poll ticks the long press, and [`push`] writes the model into SettingsPage. What a change
//! applies at once: the idle timeout, the retention period, USB export and the mode (whose
//! scans' cards are listed again, with or without their patient).
//!
//! Never: decides anything (that is `SettingsScreen`'s).

use super::{SettingsEffects, SettingsIntent};
use crate::chooser::cards::Cards;
use crate::chooser::library::{self, Loader};
use crate::ui::{AppWindow, SettingRow, SettingsPage};
use crate::words::tr;
use crate::{Screen, State, refresh};
use slint::{ComponentHandle, ModelRc, VecModel};
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use volasso_appliance::audit::Event;
use volasso_appliance::settings::Effective;

type Shared = Rc<RefCell<State>>;

/// What the user did on the settings screen or to the start screen's title.
pub(crate) fn intent(window: &AppWindow, shared: &Shared, intent: SettingsIntent) {
    let effects = {
        let mut state = shared.borrow_mut();
        let now = state.config.clock.now();
        let rows = |state: &State| matches!(state.settings.phase, super::Phase::Rows(_));
        let before = rows(&state);
        let effects = state.settings.update(intent, now);
        if !before && rows(&state) {
            log::info!("settings screen: open (the PIN was accepted)");
        }
        effects
    };
    apply(window, shared, effects);
}

/// The poll's tick: the keypad opens once the title has been held long enough, and only
/// while the start screen shows (a finger that left with the screen never says it lifted).
pub(crate) fn tick(window: &AppWindow, shared: &Shared) {
    let on_start = window.global::<crate::ui::Session>().get_screen() == Screen::Start as i32;
    let effects = {
        let mut state = shared.borrow_mut();
        let now = state.config.clock.now();
        if !on_start {
            state.settings.update(SettingsIntent::TitleHeld(false), now);
        }
        state.settings.tick(now)
    };
    if effects != SettingsEffects::default() {
        apply(window, shared, effects);
    }
}

fn apply(window: &AppWindow, shared: &Shared, effects: SettingsEffects) {
    let mut cards_changed = false;
    {
        let mut state = shared.borrow_mut();
        for (event, detail) in effects.audit {
            log::info!(
                "settings screen: {} ({detail})",
                if event == Event::PinRefused { "a wrong PIN refused" } else { "changed" }
            );
            state.audit.record(event, None, Some(detail));
        }
        if let Some(effective) = &effects.applied {
            cards_changed = apply_settings(&mut state, effective);
        }
    }
    if cards_changed {
        crate::chooser::loading::show_cards(shared);
    }
    match effects.shown {
        Some(true) => {
            log::info!("settings screen: the PIN keypad (a long press on the title)");
            crate::attract::view::end(window, shared);
            refresh::show_screen(window, Screen::Settings);
        }
        Some(false) => {
            log::info!("settings screen: closed");
            refresh::show_screen(window, Screen::Start);
            crate::attract::view::begin(window, shared);
        }
        None => {}
    }
    push(window, shared);
}

/// The screens in `language` from now on: Slint's words at once, the app's lines as they are
/// next written (words.rs).
pub(crate) fn show_language(language: volasso_appliance::settings::Language) {
    crate::words::set_language(language);
    if let Err(error) = slint::select_bundled_translation(crate::words::code(language)) {
        log::warn!("the screens stay in English: {error}");
    }
}

/// Applies what applies at once; true when the chooser's cards were made anew (the mode
/// changed whether they show whose scan it is).
fn apply_settings(state: &mut State, effective: &Effective) -> bool {
    state.config.language = effective.language;
    show_language(effective.language);
    state.idle.timeout = effective.idle_timeout();
    state.expiry.set_retention(effective.retention());
    if !effective.usb_export {
        state.config.media_roots.clear();
    } else if state.config.media_roots.is_empty() {
        state.config.media_roots = crate::view3d::snapshot::DEFAULT_MEDIA_ROOTS.map(PathBuf::from).to_vec();
    }
    let shown = effective.patient_shown();
    if shown == state.config.patient {
        return false;
    }
    // Whose scan it is was read (or not) when each card was made: the cards and the loader
    // that made them are made anew, and nothing opened under the old mode stays.
    state.config.patient = shown;
    state.ctl.forget();
    state.opening = None;
    state.loader = Loader::new(state.config.open_options.clone(), shown);
    state.cards = Cards::new(library::scan(state.config.data_dir.as_deref()));
    state.thumbnails_requested = false;
    state.thumbnails_pending = 0;
    true
}

/// Writes the model into SettingsPage.
pub(crate) fn push(window: &AppWindow, shared: &Shared) {
    let state = shared.borrow();
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
