//! The settings screen as the app model applies it: each intent, the long press's tick, and
//! what a change applies at once (the language, the idle timeout, the retention, USB export,
//! the mode).
//!
//! Never: touches Slint or writes the settings file itself (`SettingsScreen` does).

use super::{Phase, SettingsEffects, SettingsIntent, SettingsScreen};
use crate::model::{AppModel, Show};
use std::path::PathBuf;
use volasso_appliance::audit::Event;
use volasso_appliance::settings::Effective;

impl AppModel {
    /// What the user did on the settings screen or to the start screen's title.
    pub(crate) fn settings_intent(&mut self, intent: SettingsIntent) -> Show {
        let now = self.config.clock.now();
        let rows = |screen: &SettingsScreen| matches!(screen.phase, Phase::Rows(_));
        let before = rows(&self.settings);
        let effects = self.settings.update(intent, now);
        if !before && rows(&self.settings) {
            log::info!("settings screen: open (the PIN was accepted)");
        }
        self.settings_effects(effects)
    }

    /// The poll's tick: the keypad opens once the title has been held long enough, and only
    /// while the start screen shows (a finger that left with the screen never says it lifted).
    pub(crate) fn tick_settings(&mut self) -> Show {
        let now = self.config.clock.now();
        if self.screen != crate::model::Screen::Start {
            self.settings.update(SettingsIntent::TitleHeld(false), now);
        }
        let effects = self.settings.tick(now);
        if effects == SettingsEffects::default() { Show::default() } else { self.settings_effects(effects) }
    }

    fn settings_effects(&mut self, effects: SettingsEffects) -> Show {
        let mut show = Show { settings: true, ..Show::default() };
        for (event, detail) in effects.audit {
            log::info!(
                "settings screen: {} ({detail})",
                if event == Event::PinRefused { "a wrong PIN refused" } else { "changed" }
            );
            self.audit.record(event, None, Some(detail));
        }
        if let Some(effective) = &effects.applied {
            show = show.and(self.apply_settings(effective));
        }
        match effects.shown {
            Some(true) => {
                log::info!("settings screen: the PIN keypad (a long press on the title)");
                self.screen = crate::model::Screen::Settings;
                show.and(self.end_attract()).and(Show { screen: true, ..Show::default() })
            }
            Some(false) => {
                log::info!("settings screen: closed");
                self.screen = crate::model::Screen::Start;
                show.and(Show { screen: true, ..Show::default() }).and(self.begin_attract())
            }
            None => show,
        }
    }

    /// Applies what applies at once: the language, the idle timeout, the retention, USB export,
    /// and the mode (whose scans' cards are made anew, with or without whose scan it is).
    fn apply_settings(&mut self, effective: &Effective) -> Show {
        let language = self.config.language != effective.language;
        self.config.language = effective.language;
        self.idle.timeout = effective.idle_timeout();
        self.expiry.set_retention(effective.retention());
        if !effective.usb_export {
            self.config.media_roots.clear();
        } else if self.config.media_roots.is_empty() {
            self.config.media_roots = crate::view3d::snapshot::DEFAULT_MEDIA_ROOTS.map(PathBuf::from).to_vec();
        }
        let shown = effective.patient_shown();
        let show = Show { language, ..Show::default() };
        if shown == self.config.patient {
            return show;
        }
        // Whose scan it is was read (or not) when each card was made: the cards and the loader
        // that made them are made anew, and nothing opened under the old mode stays.
        self.config.patient = shown;
        self.ctl.forget();
        self.opening = None;
        self.loader = crate::chooser::library::Loader::new(self.config.open_options.clone(), shown);
        self.cards = crate::chooser::cards::Cards::new(crate::chooser::library::scan(self.config.data_dir.as_deref()));
        self.thumbnails_requested = false;
        self.thumbnails_pending = 0;
        show.and(Show { cards: true, ..Show::default() })
    }
}
