//! The kiosk's learned presets: the `*.volasso-preset` files in the data folder's `presets/`
//! folder (`volasso_core::preset`), listed for the chooser and the work screen, and a
//! classification saved as a new one. A preset holds no patient data (only the modality), so
//! the retention sweep leaves it, as it leaves volumes copied in by hand; it survives restarts
//! as a file. A file that cannot be read is left out of the list and logged once per listing.
//!
//! Never: calls Slint, or classifies (the controller applies a preset).

pub(crate) mod app;
pub(crate) mod view;

use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volasso_core::preset::{PRESET_EXTENSION, Preset, PresetError};

/// The folder of presets inside a data folder.
pub const PRESETS_FOLDER: &str = "presets";

/// The writer of new presets (a file write and its sync, off the UI thread).
pub(crate) type Writer = Box<dyn Worker<(PathBuf, Preset), Result<PathBuf, PresetError>>>;

/// The presets of one data folder, by name, and the writer of new ones.
pub struct Shelf {
    /// Where they live; `None` without a data folder (nothing to list, nowhere to save).
    folder: Option<PathBuf>,
    /// The readable ones, by name then file.
    presets: Vec<(PathBuf, Arc<Preset>)>,
    writer: Writer,
}

impl Default for Shelf {
    fn default() -> Self {
        Shelf::with_writer(None, Box::new(Threaded::new("presets", write_task())))
    }
}

/// The writer's task: the preset to its path, atomically.
pub(crate) fn write_task() -> Task<(PathBuf, Preset), Result<PathBuf, PresetError>> {
    Arc::new(|(path, preset): (PathBuf, Preset), _: &Ticket, report: &Report<'_, Result<PathBuf, PresetError>>| {
        report(preset.write(&path).map(|()| path))
    })
}

impl Shelf {
    /// The presets under `data_dir` (read by [`relist`](Self::relist)), saved through `writer`.
    pub(crate) fn with_writer(data_dir: Option<&Path>, writer: Writer) -> Shelf {
        Shelf { folder: data_dir.map(|dir| dir.join(PRESETS_FOLDER)), presets: Vec::new(), writer }
    }

    /// Lists the presets of `data_dir` again (a preset copied in appears).
    pub fn relist(&mut self, data_dir: Option<&Path>) {
        self.folder = data_dir.map(|dir| dir.join(PRESETS_FOLDER));
        self.presets.clear();
        let Some(entries) = self.folder.as_ref().and_then(|folder| std::fs::read_dir(folder).ok()) else { return };
        for path in entries.flatten().map(|entry| entry.path()) {
            if path.extension().is_none_or(|ext| ext != PRESET_EXTENSION) {
                continue;
            }
            match Preset::read(&path) {
                Ok(preset) => self.presets.push((path, Arc::new(preset))),
                Err(error) => log::warn!("preset left out: {error}"),
            }
        }
        self.presets.sort_by(|a, b| a.1.name.cmp(&b.1.name).then(a.0.cmp(&b.0)));
    }

    /// The presets' names, in list order.
    pub fn names(&self) -> Vec<String> {
        self.presets.iter().map(|(_, preset)| preset.name.clone()).collect()
    }

    /// The preset at `index` of the list, with its file.
    pub fn get(&self, index: usize) -> Option<(PathBuf, Arc<Preset>)> {
        self.presets.get(index).cloned()
    }

    /// Whether presets can be saved (there is a data folder).
    pub fn can_save(&self) -> bool {
        self.folder.is_some()
    }

    /// Hands `preset` to the writer, as a new file named after it; the status line.
    pub fn save(&mut self, preset: Preset) -> String {
        let Some(folder) = self.folder.clone() else { return "Cannot save: there is no data folder".into() };
        if self.writer.busy() {
            return "Still saving the last preset...".into();
        }
        if let Err(error) = std::fs::create_dir_all(&folder) {
            return format!("The preset was not saved: {error}");
        }
        self.writer.send((free_name(&folder, &preset.name), preset));
        "Saving the preset...".into()
    }

    /// A finished save: the status line (the caller lists the presets again).
    pub fn poll(&mut self) -> Option<String> {
        let finished = match self.writer.poll() {
            Some(delivery) => delivery.output.map_err(|error| error.to_string()),
            None => Err(self.writer.ended_silently().map(|_| "the preset writer stopped".to_string())?),
        };
        Some(match finished {
            Ok(path) => {
                log::info!("preset saved as {}", path.display());
                let name = Preset::read(&path).map_or_else(|_| path.display().to_string(), |preset| preset.name);
                format!("Saved as preset: {name}")
            }
            Err(message) => {
                log::warn!("cannot save the preset: {message}");
                format!("The preset was not saved: {message}")
            }
        })
    }

    /// A save is being written.
    pub fn busy(&self) -> bool {
        self.writer.busy()
    }
}

/// The next free `NAME.volasso-preset` in `folder`, the name made safe for a file name
/// (`NAME 2.volasso-preset` ... when taken).
fn free_name(folder: &Path, name: &str) -> PathBuf {
    let safe: String = name
        .chars()
        .map(|c| if c.is_alphanumeric() || " -_.".contains(c) { c } else { '-' })
        .collect::<String>()
        .trim_matches(['.', ' ', '-'])
        .chars()
        .take(64)
        .collect();
    let safe = if safe.is_empty() { "preset".to_string() } else { safe };
    (1..)
        .map(|n| if n == 1 { safe.clone() } else { format!("{safe} {n}") })
        .map(|stem| folder.join(format!("{stem}.{PRESET_EXTENSION}")))
        .find(|path| !path.exists())
        .unwrap_or_else(|| folder.join(format!("preset.{PRESET_EXTENSION}")))
}

/// The name a preset saved on the kiosk gets: the scan's name and its classes', e.g.
/// `demo foot: Class 1, Class 2`, at most 60 characters.
pub fn default_name(scan: &str, classes: &[String]) -> String {
    let name = format!("{scan}: {}", classes.join(", "));
    if name.chars().count() <= 60 { name } else { name.chars().take(59).collect::<String>() + "…" }
}

/// The presets' part of the app: the shelf and the chooser's choice.
pub(crate) struct Presets {
    pub(crate) shelf: Shelf,
    /// The preset the chooser applies to the next scan opened.
    pub(crate) chosen: Option<usize>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::worker::Inline;

    #[test]
    fn names_are_made_safe_and_never_overwrite() {
        let folder = tempfile::tempdir().unwrap();
        let first = free_name(folder.path(), "../bone/vessels");
        assert_eq!(first, folder.path().join("bone-vessels.volasso-preset"));
        std::fs::write(&first, "x").unwrap();
        assert_eq!(free_name(folder.path(), "../bone/vessels"), folder.path().join("bone-vessels 2.volasso-preset"));
        assert_eq!(free_name(folder.path(), "///"), folder.path().join("preset.volasso-preset"));
        assert!(
            default_name("a long scan name", &vec!["a class with a long name".to_string(); 4]).chars().count() <= 60
        );
    }

    #[test]
    fn a_shelf_lists_readable_presets_and_leaves_out_the_rest() {
        let folder = tempfile::tempdir().unwrap();
        let presets = folder.path().join(PRESETS_FOLDER);
        std::fs::create_dir_all(&presets).unwrap();
        std::fs::write(presets.join("broken.volasso-preset"), "{\"format\": \"volasso-preset/1\"").unwrap();
        std::fs::write(presets.join("notes.txt"), "not a preset").unwrap();
        let mut shelf = Shelf::with_writer(None, Box::new(Inline::new(write_task())));
        shelf.relist(Some(folder.path()));
        assert!(shelf.names().is_empty());
        assert!(shelf.can_save());
        shelf.relist(None);
        assert!(!shelf.can_save());
    }
}
