//! Learned presets as the app model applies them: the menus listed again, "Save as preset",
//! "Apply NAME" and a finished save collected.
//!
//! Never: decides how a preset classifies (the controller applies it).

use super::default_name;
use crate::model::{AppModel, Show};

impl AppModel {
    /// Lists the data folder's presets again onto both menus.
    pub(crate) fn relist_presets(&mut self) -> Show {
        self.presets.shelf.relist(self.config.data_dir.as_deref());
        let count = self.presets.shelf.names().len();
        self.presets.chosen = self.presets.chosen.filter(|&chosen| chosen < count);
        Show { presets: true, ..Show::default() }
    }

    /// Collects a finished save.
    pub(crate) fn poll_presets(&mut self) -> Show {
        match self.presets.shelf.poll() {
            Some(status) => {
                self.status = status;
                self.relist_presets().and(Show::status())
            }
            None => Show::default(),
        }
    }

    /// "Save as preset": the classification shown, named after the scan and its classes,
    /// handed to the shelf's writer; the status line says so, or why not.
    pub(crate) fn save_preset(&mut self) -> Show {
        let name = self.ctl.work.as_ref().map(|work| {
            let scan = work.loaded.title.clone().unwrap_or_else(|| work.loaded.source.name());
            let classes: Vec<String> = work.session.classes.iter().map(|class| class.name.clone()).collect();
            default_name(&scan, &classes)
        });
        let preset = name.ok_or("no scan is open".to_string()).and_then(|name| self.ctl.preset_of_shown(&name));
        self.status = match preset {
            Ok(preset) => self.presets.shelf.save(preset),
            Err(reason) => format!("The preset was not saved: {reason}"),
        };
        Show::status()
    }

    /// "Apply NAME" (or the chooser's choice on a scan just opened): the preset at `index`
    /// colours the open scan.
    pub(crate) fn apply_preset(&mut self, index: usize) -> Show {
        let Some((path, preset)) = self.presets.shelf.get(index) else { return Show::default() };
        let changed = self.ctl.apply_preset(preset.clone(), Some(path));
        let applied = changed.failure == crate::controller::Failure::Unchanged;
        let show = self.changed(changed);
        if applied {
            self.status = format!("Preset applied: {}", preset.name);
        }
        show.and(Show::status())
    }
}
