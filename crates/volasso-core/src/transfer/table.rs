//! The per-class table kept beside a label volume (`labels.nrrd` + `labels.classes.json`):
//! template, clip box and one [`ClassStyle`] per class. It is what lets the renderer classify
//! after interpolation and lets template, emphasis, visibility and clipping change colours
//! without running the classifier again (the paper's §3.5 limitations; `docs/colour.md`).
//!
//! Never: stores per-voxel data.

use super::harmony::{ClipBox, apply_template, class_statistics, styles_from_statistics};
use super::opacity::{OpacityRule, class_surfaces, see_through_opacities};
use super::templates::HueTemplate;
use super::{ClassStyle, TransferError};
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The `format` field of a class table file.
pub const CLASS_TABLE_FORMAT: &str = "volasso-classes/1";

/// The styles of a label volume's classes (class `k` at index `k - 1`) and what they were
/// computed for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClassTable {
    /// Always [`CLASS_TABLE_FORMAT`].
    pub format: String,
    /// The harmonic hue template the hues were placed on.
    pub template: HueTemplate,
    /// How the default opacities were set (tables written before the field existed read as
    /// the default rule; their styles are kept as written until restyled).
    #[serde(default)]
    pub opacity_rule: OpacityRule,
    /// The box the statistics were taken over; `None`: the whole volume.
    pub clip: Option<ClipBox>,
    /// Voxels of each class inside the box.
    pub voxel_counts: Vec<u64>,
    /// Each class's style, class `k` at index `k - 1`.
    pub styles: Vec<ClassStyle>,
}

impl ClassTable {
    /// Styles for the whole volume with the default opacity rule; a class with no voxels
    /// starts hidden.
    pub fn compute(
        volume: &Volume,
        labels: &[u8],
        class_count: usize,
        template: HueTemplate,
    ) -> Result<ClassTable, TransferError> {
        ClassTable::compute_with_rule(volume, labels, class_count, template, OpacityRule::default())
    }

    /// [`compute`](Self::compute) with the opacities of `opacity_rule`.
    pub fn compute_with_rule(
        volume: &Volume,
        labels: &[u8],
        class_count: usize,
        template: HueTemplate,
        opacity_rule: OpacityRule,
    ) -> Result<ClassTable, TransferError> {
        let mut table = ClassTable {
            format: CLASS_TABLE_FORMAT.to_string(),
            template,
            opacity_rule,
            clip: None,
            voxel_counts: Vec::new(),
            styles: vec![neutral_style(); class_count],
        };
        table.restyle(volume, labels, None)?;
        for (style, &count) in table.styles.iter_mut().zip(&table.voxel_counts) {
            style.visible = count > 0;
        }
        Ok(table)
    }

    /// Recomputes the statistics for the voxels in `clip` (`None`: the whole volume), keeping
    /// every class's emphasis and visibility.
    pub fn restyle(&mut self, volume: &Volume, labels: &[u8], clip: Option<ClipBox>) -> Result<(), TransferError> {
        let whole =
            ClipBox::whole(volume.dims).ok_or(TransferError::ClipBox { lo: [0; 3], hi: [0; 3], dims: volume.dims })?;
        let statistics = class_statistics(volume, labels, self.styles.len(), clip.unwrap_or(whole))?;
        let mut styles = styles_from_statistics(&statistics, &self.template);
        if self.opacity_rule == OpacityRule::SeeThrough {
            let surfaces = class_surfaces(volume, labels, self.styles.len(), clip.unwrap_or(whole))?;
            let reference_step_mm = volume.spacing_mm.iter().copied().fold(f64::INFINITY, f64::min);
            for (style, opacity) in styles.iter_mut().zip(see_through_opacities(&surfaces, reference_step_mm)) {
                style.opacity = opacity;
            }
        }
        for (style, old) in styles.iter_mut().zip(&self.styles) {
            style.emphasis = old.emphasis;
            style.visible = old.visible;
        }
        self.styles = styles;
        self.voxel_counts = statistics.iter().map(|s| s.voxel_count).collect();
        self.clip = clip;
        Ok(())
    }

    /// Changes the template; only the hue ranges change.
    pub fn set_template(&mut self, template: HueTemplate) {
        self.template = template;
        apply_template(&mut self.styles, &template);
    }

    /// Writes the table as pretty JSON, atomically.
    pub fn write(&self, path: &Path) -> Result<(), TransferError> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|source| TransferError::TableJson { source, path: path.to_path_buf() })?;
        crate::atomic_file::write_atomically(path, |file| file.write_all(text.as_bytes()))
            .map_err(|source| TransferError::Io { source, path: path.to_path_buf() })
    }

    /// Reads a table written by [`write`](Self::write).
    pub fn read(path: &Path) -> Result<ClassTable, TransferError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| TransferError::Io { source, path: path.to_path_buf() })?;
        let table: ClassTable = serde_json::from_str(&text)
            .map_err(|source| TransferError::TableJson { source, path: path.to_path_buf() })?;
        if table.format != CLASS_TABLE_FORMAT {
            return Err(TransferError::TableFormat {
                expected: CLASS_TABLE_FORMAT,
                found: table.format,
                path: path.to_path_buf(),
            });
        }
        if table.voxel_counts.len() != table.styles.len() {
            return Err(TransferError::StyleCount {
                styles: table.styles.len(),
                class_count: table.voxel_counts.len(),
            });
        }
        Ok(table)
    }
}

/// `labels.classes.json` for `labels.nrrd` (any extension is replaced).
pub fn class_table_path(labels_path: &Path) -> PathBuf {
    labels_path.with_extension("classes.json")
}

fn neutral_style() -> ClassStyle {
    ClassStyle {
        hue_degrees: [0.0, 0.0],
        saturation: 1.0,
        value: 1.0,
        opacity: [0.2, 0.2],
        gradient_max: 0.0,
        emphasis: 1.0,
        visible: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::templates::TemplateType;

    fn two_blocks() -> (Volume, Vec<u8>) {
        let dims = [12, 10, 8];
        let mut values = vec![0f32; 960];
        let mut labels = vec![0u8; 960];
        for z in 0..8 {
            for y in 0..10 {
                for x in 0..12 {
                    let i = x + 12 * (y + 10 * z);
                    if x < 4 {
                        labels[i] = 1;
                        values[i] = 100.0;
                    } else if x >= 6 && y >= 2 {
                        labels[i] = 2;
                        values[i] = 50.0 + y as f32;
                    }
                }
            }
        }
        (Volume::from_f32(dims, [1.0, 1.0, 2.0], &values, Path::new("blocks")).unwrap(), labels)
    }

    #[test]
    fn json_round_trips_and_template_changes_only_hues() {
        let (volume, labels) = two_blocks();
        let mut table = ClassTable::compute(&volume, &labels, 3, HueTemplate::default_for(3)).unwrap();
        assert_eq!(table.voxel_counts[2], 0);
        assert!(!table.styles[2].visible, "an empty class starts hidden");
        table.styles[0].emphasis = 0.5;
        let folder = tempfile::tempdir().unwrap();
        let path = class_table_path(&folder.path().join("labels.nrrd"));
        assert!(path.ends_with("labels.classes.json"));
        table.write(&path).unwrap();
        assert_eq!(ClassTable::read(&path).unwrap(), table);

        let before = table.clone();
        table.set_template(HueTemplate::new(TemplateType::X, 10.0));
        for (new, old) in table.styles.iter().zip(&before.styles) {
            assert_ne!(new.hue_degrees, old.hue_degrees);
            assert_eq!(
                (new.saturation, new.value, new.opacity, new.emphasis),
                (old.saturation, old.value, old.opacity, old.emphasis)
            );
        }

        std::fs::write(&path, r#"{"format":"other","template":{"template":"V","rotation_degrees":0},"clip":null,"voxel_counts":[],"styles":[]}"#).unwrap();
        assert!(matches!(ClassTable::read(&path), Err(TransferError::TableFormat { .. })));
    }

    #[test]
    fn restyling_for_a_clip_box_keeps_emphasis_and_visibility() {
        let (volume, labels) = two_blocks();
        let mut table = ClassTable::compute(&volume, &labels, 2, HueTemplate::default_for(2)).unwrap();
        table.styles[1].emphasis = 2.0;
        table.styles[0].visible = false;
        let whole = table.clone();
        table.restyle(&volume, &labels, Some(ClipBox { lo: [0, 0, 0], hi: [7, 9, 7] })).unwrap();
        assert_eq!(table.styles[1].emphasis, 2.0);
        assert!(!table.styles[0].visible);
        assert!(table.voxel_counts[1] < whole.voxel_counts[1]);
        assert_ne!(table.styles[1].value, whole.styles[1].value);
        table.restyle(&volume, &labels, None).unwrap();
        assert_eq!(table.styles, {
            let mut w = whole.styles.clone();
            w[1].emphasis = 2.0;
            w[0].visible = false;
            w
        });
        let outside = ClipBox { lo: [0, 0, 0], hi: [12, 9, 7] };
        assert!(matches!(table.restyle(&volume, &labels, Some(outside)), Err(TransferError::ClipBox { .. })));
    }
}
