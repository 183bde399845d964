//! Learned presets: the training of one classification, kept to classify the next scan of the
//! same kind without loops, and refined by loops drawn on that scan (the paper's classifier,
//! §3.3-§3.4, carried from scan to scan instead of a hand-made transfer function).
//!
//! A preset ([`Preset`], a `volasso-preset/1` JSON file, `docs/interfaces.md`) holds the
//! classes with their looks (§3.5), the training vectors as the classifier was fitted on them
//! (capped like any training set), each class's band of intensities, the background's levels
//! and which class was drawn in the air around the body, the features' definition, the
//! modality and the value scale.
//!
//! **The standard scale** makes vectors from one scan mean the same on another. CT in
//! Hounsfield units is the same on every scanner and is kept as it is; any other scan (MRI,
//! whose gain is arbitrary; 8-bit exports; a file of unknown kind) is mapped linearly so that
//! the [`LANDMARK_PERCENTILES`] of its body's voxels ([`crate::volume::body`]) become 0 and
//! [`STANDARD_SPAN`]. Every feature is an intensity (it moves with the map) or a difference of
//! intensities (it scales with it: gradients, curvatures, the gap depth), so the preset's
//! vectors are mapped into each scan's own units ([`ValueMap`]) and the scan itself is read as
//! it is. A bias field is a local change the features already live with; the map takes out
//! gain and offset.
//!
//! Never: holds a voxel's position or anything of the patient (only the modality), reads a
//! scan's header, or trains (it hands [`TrainingSamples`] to `segmentation::fit`).

use crate::features::FeatureSet;
use crate::segmentation::gate::Band;
use crate::segmentation::{BackgroundPlan, Segmenter, TrainingSamples};
use crate::transfer::{ClassStyle, ClassTable, HueTemplate, OpacityRule};
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[cfg(test)]
mod tests;

/// The `format` of the files this version writes and reads.
pub const PRESET_FORMAT: &str = "volasso-preset/1";

/// The file name extension of presets.
pub const PRESET_EXTENSION: &str = "volasso-preset";

/// A preset file larger than this is refused unread (one holds a few hundred vectors per class,
/// some hundred kilobytes).
pub const MAX_PRESET_BYTES: u64 = 32 << 20;

/// The body's percentiles that the standard scale puts at 0 and [`STANDARD_SPAN`]: inside the
/// tissue's range on CT and MRI alike, past the air and noise that a field of view adds.
pub const LANDMARK_PERCENTILES: [f64; 2] = [5.0, 95.0];

/// The standard scale's value at the upper landmark.
pub const STANDARD_SPAN: f64 = 1000.0;

/// A CT whose lowest value is above this is not in Hounsfield units (air is -1000 HU, lung
/// about -850): a windowed 8-bit export, or a file on another scale.
pub const HOUNSFIELD_AIR_BELOW: f64 = -500.0;

/// At most this many body voxels are read for the landmarks (an even grid over the volume).
const LANDMARK_SAMPLES: usize = 1 << 20;

/// What kind of scan: a preset trained on one is refused for the other.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Modality {
    /// Computed tomography.
    #[serde(rename = "CT")]
    Ct,
    /// Magnetic resonance.
    #[serde(rename = "MR")]
    Mr,
    /// Not known (a file format without a modality, none given).
    #[serde(rename = "unknown")]
    Unknown,
}

impl Modality {
    /// From a DICOM Modality code ("CT", "MR"); anything else is unknown.
    pub fn from_code(code: &str) -> Modality {
        match code.trim().to_ascii_uppercase().as_str() {
            "CT" => Modality::Ct,
            "MR" | "MRI" => Modality::Mr,
            _ => Modality::Unknown,
        }
    }

    /// The name in messages and files: `CT`, `MR`, `unknown`.
    pub fn name(self) -> &'static str {
        match self {
            Modality::Ct => "CT",
            Modality::Mr => "MR",
            Modality::Unknown => "unknown",
        }
    }
}

/// The scale a preset's values are in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StandardScale {
    /// Hounsfield units, as a CT gives them.
    Hounsfield,
    /// Each scan mapped linearly: its body's `percentiles` at 0 and [`STANDARD_SPAN`].
    BodyPercentiles {
        /// The lower and upper landmark, in percent of the body's voxels.
        percentiles: [f64; 2],
    },
}

impl StandardScale {
    /// The scale for a scan of `modality`: Hounsfield units for a CT that is in them, else the
    /// body's percentiles.
    pub fn for_scan(volume: &Volume, modality: Modality) -> StandardScale {
        if modality == Modality::Ct && volume.value_range().min < HOUNSFIELD_AIR_BELOW {
            StandardScale::Hounsfield
        } else {
            StandardScale::BodyPercentiles { percentiles: LANDMARK_PERCENTILES }
        }
    }
}

/// One scan's map to the standard scale: `standard = (value - offset) * gain`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueMap {
    /// The scan's value at the standard scale's 0.
    pub offset: f64,
    /// Standard units per unit of the scan's values.
    pub gain: f64,
}

impl ValueMap {
    /// The map of `volume` onto `scale`.
    pub fn of(volume: &Volume, scale: StandardScale) -> Result<ValueMap, PresetError> {
        let StandardScale::BodyPercentiles { percentiles } = scale else {
            return Ok(ValueMap { offset: 0.0, gain: 1.0 });
        };
        let [low, high] = body_percentiles(volume, percentiles);
        if !(low.is_finite() && high.is_finite() && high > low) {
            return Err(PresetError::NoSpread { low, high });
        }
        Ok(ValueMap { offset: low, gain: STANDARD_SPAN / (high - low) })
    }

    /// `features` (row-major vectors of `intensity.len()` features) from the scan's units to
    /// the standard scale; `intensity` flags the features that are intensities.
    pub fn to_standard(&self, features: &mut [f32], intensity: &[bool]) {
        for vector in features.chunks_exact_mut(intensity.len()) {
            for (value, &is_intensity) in vector.iter_mut().zip(intensity) {
                let offset = if is_intensity { self.offset } else { 0.0 };
                *value = ((*value as f64 - offset) * self.gain) as f32;
            }
        }
    }

    /// The inverse of [`to_standard`](Self::to_standard).
    pub fn from_standard(&self, features: &mut [f32], intensity: &[bool]) {
        for vector in features.chunks_exact_mut(intensity.len()) {
            for (value, &is_intensity) in vector.iter_mut().zip(intensity) {
                let offset = if is_intensity { self.offset } else { 0.0 };
                *value = (*value as f64 / self.gain + offset) as f32;
            }
        }
    }

    fn value_to_standard(&self, value: f32) -> f32 {
        ((value as f64 - self.offset) * self.gain) as f32
    }

    fn value_from_standard(&self, value: f32) -> f32 {
        (value as f64 / self.gain + self.offset) as f32
    }
}

/// The `percentiles` of the values inside `volume`'s body, read on an even grid.
fn body_percentiles(volume: &Volume, percentiles: [f64; 2]) -> [f64; 2] {
    let body = volume.body();
    let count = volume.voxel_count();
    let step = count.div_ceil(LANDMARK_SAMPLES).max(1);
    let mut values: Vec<f64> = (0..count)
        .step_by(step)
        .filter(|&voxel| body.contains(voxel))
        .map(|voxel| volume.value(voxel))
        .filter(|value| value.is_finite())
        .collect();
    if values.is_empty() {
        return [f64::NAN; 2];
    }
    values.sort_unstable_by(f64::total_cmp);
    percentiles.map(|percent| {
        let position = (percent / 100.0 * (values.len() - 1) as f64).round() as usize;
        values[position.min(values.len() - 1)]
    })
}

/// One class of a preset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PresetClass {
    /// The class's name as drawn.
    pub name: String,
    /// Its look when the preset was saved (hue, saturation, value, emphasis, shown); its
    /// opacity and gradient range are the new scan's own.
    pub style: Option<ClassStyle>,
}

/// The background a preset's training decided (`segmentation::background`), in the standard
/// scale: a new scan of the same kind has its background at the same levels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PresetBackground {
    /// Voxels below it are background; `None`: every voxel is classified.
    pub threshold: Option<f32>,
    /// The dark region joined to the volume's faces below it is background (or the air class,
    /// where there is one); `None`: no such region.
    pub face_level: Option<f32>,
}

impl PresetBackground {
    /// The plan for `volume`, whose values `map` takes to the standard scale.
    fn plan(&self, volume: &Volume, map: &ValueMap, air_class: Option<usize>, classes: usize) -> BackgroundPlan {
        BackgroundPlan {
            threshold: self.threshold.map(|level| map.value_from_standard(level) as f64),
            body: self.face_level.map(|level| volume.body_at(map.value_from_standard(level) as f64)),
            dropped_per_class: vec![0; classes],
            air_is_a_class: air_class.is_some(),
            air_class,
        }
    }
}

/// One training vector: its class id (1 = the first class) and its features in the standard
/// scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PresetSample {
    /// Class id, 1-based.
    pub class: u8,
    /// The features, in the order of the preset's `feature_names`.
    pub features: Vec<f32>,
}

/// A learned preset (module doc). Read it with [`Preset::read`], write it with [`Preset::write`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Preset {
    /// Always [`PRESET_FORMAT`].
    pub format: String,
    /// What the user called it.
    pub name: String,
    /// When it was saved (UTC, ISO 8601).
    pub created: String,
    /// The program that saved it.
    pub made_by: String,
    /// The modality it was trained on.
    pub modality: Modality,
    /// The scale of its values.
    pub scale: StandardScale,
    /// The feature set's name (`--features`).
    pub features: String,
    /// The features, in order (checked against this version's definition on reading).
    pub feature_names: Vec<String>,
    /// The hue template of its colours.
    pub template: HueTemplate,
    /// The opacity rule of its colours.
    pub opacity_rule: OpacityRule,
    /// Its classes, class id `k` at index `k - 1`.
    pub classes: Vec<PresetClass>,
    /// The class drawn in the air around the body (index into `classes`), if one was.
    pub air_class: Option<usize>,
    /// The background decided when it was trained, in the standard scale.
    pub background: PresetBackground,
    /// Each class's band of intensities in the standard scale; `None` for an open gate.
    pub bands: Option<Vec<[f32; 2]>>,
    /// The training vectors.
    pub samples: Vec<PresetSample>,
}

/// Why a preset cannot be made, read, written or applied.
#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    /// The file cannot be read.
    #[error(transparent)]
    Read(#[from] crate::input_file::InputFileError),
    /// The file is not a preset, or is damaged or cut short.
    #[error("{} is not a readable volasso preset ({reason})", path.display())]
    Damaged {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The file is a preset of another version.
    #[error(
        "{} is a preset of another version ({found}); this volasso reads {PRESET_FORMAT}: save the preset again with this version",
        path.display()
    )]
    Version {
        /// The file.
        path: PathBuf,
        /// Its `format`.
        found: String,
    },
    /// The preset was trained on another modality than the scan's.
    #[error(
        "the preset '{name}' was trained on {preset} and this scan is {scan}: a preset classifies scans of its own modality only"
    )]
    Modality {
        /// The preset's name.
        name: String,
        /// The preset's modality.
        preset: &'static str,
        /// The scan's modality.
        scan: &'static str,
    },
    /// The preset is in Hounsfield units and the scan is not known to be.
    #[error(
        "the preset '{name}' was trained on CT in Hounsfield units and this scan is not known to be one (a CT whose values reach below -500 HU{hint})"
    )]
    NotHounsfield {
        /// The preset's name.
        name: String,
        /// What the user can do.
        hint: &'static str,
    },
    /// The scan's body has no spread of values to standardise.
    #[error(
        "this scan's body has no spread of values to map onto the preset's scale (its landmarks are {low} and {high})"
    )]
    NoSpread {
        /// The lower landmark.
        low: f64,
        /// The upper landmark.
        high: f64,
    },
    /// The classification has nothing a preset can keep.
    #[error("this classification cannot be kept as a preset: {0}")]
    Unsuitable(String),
    /// The file cannot be written.
    #[error("cannot write the preset {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

impl Preset {
    /// The preset of a classification of `volume` (of `modality`): `segmenter`'s training
    /// samples in the standard scale, the classes' `names` and their look in `table`.
    pub fn of(
        name: &str,
        segmenter: &Segmenter,
        volume: &Volume,
        modality: Modality,
        names: &[String],
        table: &ClassTable,
    ) -> Result<Preset, PresetError> {
        let samples = &segmenter.samples;
        if names.len() != samples.class_count {
            return Err(PresetError::Unsuitable(format!(
                "{} class names for {} classes",
                names.len(),
                samples.class_count
            )));
        }
        let scale = StandardScale::for_scan(volume, modality);
        let map = ValueMap::of(volume, scale)?;
        let feature_set = samples.feature_set;
        let intensity = feature_set.intensity_features();
        let mut features = samples.features.clone();
        map.to_standard(&mut features, &intensity);
        let classes = names
            .iter()
            .enumerate()
            .map(|(position, name)| PresetClass { name: name.clone(), style: table.styles.get(position).cloned() })
            .collect();
        Ok(Preset {
            format: PRESET_FORMAT.into(),
            name: name.trim().to_string(),
            created: crate::calendar::iso_utc(
                std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()),
            ),
            made_by: format!("volasso {}", env!("CARGO_PKG_VERSION")),
            modality,
            scale,
            features: feature_set.name().into(),
            feature_names: feature_set.names().iter().map(|n| n.to_string()).collect(),
            template: table.template,
            opacity_rule: table.opacity_rule,
            classes,
            air_class: samples.background.air_class,
            background: PresetBackground {
                threshold: samples.background.threshold.map(|level| map.value_to_standard(level as f32)),
                face_level: samples.background.body.as_ref().map(|body| map.value_to_standard(body.level as f32)),
            },
            bands: samples.bands.as_ref().map(|bands| {
                bands.iter().map(|band| [map.value_to_standard(band.low), map.value_to_standard(band.high)]).collect()
            }),
            samples: features
                .chunks_exact(feature_set.dim())
                .zip(&samples.labels)
                .map(|(vector, &class)| PresetSample { class, features: vector.to_vec() })
                .collect(),
        })
    }

    /// The preset in `path`, checked: its version, its features against this version's, every
    /// vector's length and class, its bands.
    pub fn read(path: &Path) -> Result<Preset, PresetError> {
        let text = crate::input_file::read_text(path, "preset", MAX_PRESET_BYTES)?;
        let damaged = |reason: String| PresetError::Damaged { path: path.to_path_buf(), reason };
        let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| damaged(e.to_string()))?;
        match value.get("format").and_then(|f| f.as_str()) {
            Some(PRESET_FORMAT) => {}
            Some(found) if found.starts_with("volasso-preset/") => {
                return Err(PresetError::Version { path: path.to_path_buf(), found: found.into() });
            }
            _ => return Err(damaged(format!("no \"format\": \"{PRESET_FORMAT}\""))),
        }
        let preset: Preset = serde_json::from_value(value).map_err(|e| damaged(e.to_string()))?;
        preset.check().map_err(damaged)?;
        Ok(preset)
    }

    /// Whether the preset is whole and fits this version; the reason when not.
    fn check(&self) -> Result<(), String> {
        let feature_set = self.feature_set().ok_or_else(|| format!("unknown features '{}'", self.features))?;
        if feature_set.names().iter().ne(self.feature_names.iter()) {
            return Err(format!("its features {:?} are not this version's {}", self.feature_names, self.features));
        }
        let count = self.classes.len();
        if !(1..=255).contains(&count) {
            return Err(format!("{count} classes"));
        }
        if self.air_class.is_some_and(|air| air >= count) {
            return Err("its air class is not one of its classes".into());
        }
        if self.bands.as_ref().is_some_and(|bands| bands.len() != count) {
            return Err(format!("{} bands for {count} classes", self.bands.as_ref().map_or(0, Vec::len)));
        }
        let dim = feature_set.dim();
        for (position, sample) in self.samples.iter().enumerate() {
            if sample.features.len() != dim || sample.features.iter().any(|v| !v.is_finite()) {
                return Err(format!("training vector {position} is not {dim} finite numbers"));
            }
            if !(1..=count).contains(&(sample.class as usize)) {
                return Err(format!("training vector {position} has class {}", sample.class));
            }
        }
        for class in 1..=count {
            if !self.samples.iter().any(|sample| sample.class as usize == class) {
                return Err(format!("class '{}' has no training vector", self.classes[class - 1].name));
            }
        }
        Ok(())
    }

    /// The feature set the preset's vectors hold; `None` for a name this version lacks.
    pub fn feature_set(&self) -> Option<FeatureSet> {
        [FeatureSet::Paper5, FeatureSet::Paper5Gap, FeatureSet::Multiscale, FeatureSet::MultiscaleFine]
            .into_iter()
            .find(|set| set.name() == self.features)
    }

    /// The preset with only the classes named in `names` (in its own order, renumbered), as a
    /// user who deleted some of its classes on a scan wants it; `None` when none is left.
    pub fn only(&self, names: &[String]) -> Option<Preset> {
        let kept: Vec<usize> = (0..self.classes.len()).filter(|&c| names.contains(&self.classes[c].name)).collect();
        if kept.is_empty() {
            return None;
        }
        let new_id = |old: u8| kept.iter().position(|&c| c + 1 == old as usize).map(|p| p as u8 + 1);
        Some(Preset {
            classes: kept.iter().map(|&c| self.classes[c].clone()).collect(),
            air_class: self.air_class.and_then(|air| kept.iter().position(|&c| c == air)),
            bands: self.bands.as_ref().map(|bands| kept.iter().map(|&c| bands[c]).collect()),
            samples: self
                .samples
                .iter()
                .filter_map(|sample| new_id(sample.class).map(|class| PresetSample { class, ..sample.clone() }))
                .collect(),
            ..self.clone()
        })
    }

    /// The class names, in class order.
    pub fn class_names(&self) -> Vec<String> {
        self.classes.iter().map(|class| class.name.clone()).collect()
    }

    /// The preset as its file holds it (JSON).
    pub fn to_json(&self) -> std::io::Result<String> {
        serde_json::to_string(self).map_err(std::io::Error::other)
    }

    /// Writes the preset to `path` atomically (a reader sees the old file or the whole new one).
    pub fn write(&self, path: &Path) -> Result<(), PresetError> {
        let write = |source| PresetError::Write { source, path: path.to_path_buf() };
        let text = self.to_json().map_err(write)?;
        crate::atomic_file::write_atomically(path, |file| std::io::Write::write_all(file, text.as_bytes()))
            .map_err(write)
    }

    /// Whether the preset can classify a scan of `modality` in `volume`; the reason when not.
    pub fn check_scan(&self, volume: &Volume, modality: Modality) -> Result<(), PresetError> {
        let known = |m: Modality| m != Modality::Unknown;
        if known(self.modality) && known(modality) && self.modality != modality {
            return Err(PresetError::Modality {
                name: self.name.clone(),
                preset: self.modality.name(),
                scan: modality.name(),
            });
        }
        if self.scale == StandardScale::Hounsfield
            && StandardScale::for_scan(volume, modality) != StandardScale::Hounsfield
        {
            let hint = if modality == Modality::Unknown { "; if it is, say it is a CT" } else { "" };
            return Err(PresetError::NotHounsfield { name: self.name.clone(), hint });
        }
        Ok(())
    }

    /// The preset's training samples in `volume`'s units, with its background at the preset's
    /// levels (the face air found in `volume` at its level).
    pub fn samples_for(&self, volume: &Volume, modality: Modality) -> Result<TrainingSamples, PresetError> {
        self.check_scan(volume, modality)?;
        let feature_set = self.feature_set().ok_or_else(|| PresetError::Damaged {
            path: PathBuf::from(&self.name),
            reason: format!("unknown features '{}'", self.features),
        })?;
        let map = ValueMap::of(volume, self.scale)?;
        let mut features: Vec<f32> = self.samples.iter().flat_map(|s| s.features.iter().copied()).collect();
        map.from_standard(&mut features, &feature_set.intensity_features());
        let labels: Vec<u8> = self.samples.iter().map(|sample| sample.class).collect();
        let count = self.classes.len();
        let samples = TrainingSamples {
            class_count: count,
            feature_set,
            features,
            labels,
            bands: self.bands.as_ref().map(|bands| {
                bands
                    .iter()
                    .map(|&[low, high]| Band { low: map.value_from_standard(low), high: map.value_from_standard(high) })
                    .collect()
            }),
            background: Default::default(),
            lassoed: Vec::new(),
            used_per_class: (1..=count)
                .map(|c| self.samples.iter().filter(|s| s.class as usize == c).count())
                .collect(),
            dropped_per_class: vec![0; count],
            contested_voxels: 0,
            features_seconds: 0.0,
        };
        Ok(TrainingSamples { background: self.background.plan(volume, &map, self.air_class, count), ..samples })
    }

    /// `table` (computed on the new scan) in the preset's look: each preset class keeps its
    /// hue, saturation, value, emphasis and whether it is shown; opacities and gradient ranges
    /// stay the new scan's.
    pub fn restyle(&self, table: &mut ClassTable) {
        for (style, class) in table.styles.iter_mut().zip(&self.classes) {
            if let Some(kept) = &class.style {
                style.hue_degrees = kept.hue_degrees;
                style.saturation = kept.saturation;
                style.value = kept.value;
                style.emphasis = kept.emphasis;
                style.visible = kept.visible;
            }
        }
    }
}

/// The classes of a preset with loops drawn on a new scan: the preset's, then each drawn class
/// whose name is not among them; and, per drawn class, its class id in that list.
pub fn joined_classes(preset: &[String], drawn: &[String]) -> (Vec<String>, Vec<u8>) {
    let mut names = preset.to_vec();
    let ids = drawn
        .iter()
        .map(|name| {
            let position = names.iter().position(|known| known == name).unwrap_or_else(|| {
                names.push(name.clone());
                names.len() - 1
            });
            (position + 1) as u8
        })
        .collect();
    (names, ids)
}

/// A preset's samples and those of loops drawn on the same scan as one training set: the drawn
/// classes renumbered by `drawn_ids` ([`joined_classes`]), each class capped at `cap` vectors
/// (the drawn ones first: the user is correcting the preset on this scan), the bands of a class
/// in both joined, the background of both.
pub fn join_samples(
    preset: TrainingSamples,
    air_class: Option<usize>,
    drawn: TrainingSamples,
    drawn_ids: &[u8],
    class_count: usize,
    cap: usize,
) -> TrainingSamples {
    let dim = preset.feature_set.dim();
    let mut features = Vec::new();
    let mut labels = Vec::new();
    let mut used_per_class = vec![0usize; class_count];
    let mut dropped_per_class = vec![0usize; class_count];
    let drawn_vectors = drawn.features.chunks_exact(dim).zip(drawn.labels.iter().map(|&l| drawn_ids[l as usize - 1]));
    let preset_vectors = preset.features.chunks_exact(dim).zip(preset.labels.iter().copied());
    for (vector, class) in drawn_vectors.chain(preset_vectors) {
        let position = class as usize - 1;
        if used_per_class[position] < cap {
            features.extend_from_slice(vector);
            labels.push(class);
            used_per_class[position] += 1;
        } else {
            dropped_per_class[position] += 1;
        }
    }
    let band_of =
        |samples: &TrainingSamples, position: usize| samples.bands.as_ref().and_then(|b| b.get(position).copied());
    let bands = (preset.bands.is_some() && drawn.bands.is_some()).then(|| {
        (0..class_count)
            .map(|position| {
                let from_drawn = drawn_ids
                    .iter()
                    .enumerate()
                    .filter(|&(_, &id)| id as usize == position + 1)
                    .filter_map(|(drawn_position, _)| band_of(&drawn, drawn_position));
                band_of(&preset, position).into_iter().chain(from_drawn).fold(
                    Band { low: f32::INFINITY, high: f32::NEG_INFINITY },
                    |joined, band| Band { low: joined.low.min(band.low), high: joined.high.max(band.high) },
                )
            })
            .collect()
    });
    // The loops drawn on this scan decide its background where they can (the places of their
    // dark voxels are known); the preset's lowers the threshold to its darkest class's, and
    // its air class and face air stand where the loops have none.
    let drawn_air = drawn.background.air_class.map(|position| drawn_ids[position] as usize - 1);
    let air_class = drawn_air.or(air_class);
    let threshold = match (drawn.background.threshold, preset.background.threshold) {
        (Some(drawn), Some(preset)) => Some(drawn.min(preset)),
        _ => None,
    };
    let body = match drawn_air {
        Some(_) => drawn.background.body.clone(),
        None if air_class.is_some() => preset.background.body.clone(),
        None => drawn.background.body.clone().or_else(|| preset.background.body.clone()),
    };
    let background = BackgroundPlan {
        threshold,
        body,
        dropped_per_class: vec![0; class_count],
        air_is_a_class: air_class.is_some(),
        air_class,
    };
    TrainingSamples {
        class_count,
        feature_set: preset.feature_set,
        features,
        labels,
        bands,
        background,
        lassoed: drawn.lassoed.iter().map(|&(voxel, id)| (voxel, drawn_ids[id as usize - 1])).collect(),
        used_per_class,
        dropped_per_class,
        contested_voxels: drawn.contested_voxels,
        features_seconds: drawn.features_seconds,
    }
}

/// The modality of the scan at `path` as its DICOM headers give it (the series `options`
/// choose, else the one modality of every readable series); unknown for other files.
pub fn modality_of(path: &Path, options: &crate::volume::OpenOptions) -> Modality {
    use crate::volume::dicom::{PatientShown, list_series};
    let Ok(listed) = list_series(path, PatientShown::Hidden, &options.limits()) else {
        return Modality::Unknown;
    };
    let chosen: Vec<Modality> = listed
        .iter()
        .filter(|series| series.unreadable.is_none())
        .filter(|series| options.dicom.series_uid.as_ref().is_none_or(|uid| *uid == series.series_uid))
        .map(|series| Modality::from_code(&series.modality))
        .collect();
    match chosen.split_first() {
        Some((first, rest)) if rest.iter().all(|m| m == first) => *first,
        _ => Modality::Unknown,
    }
}
