//! Replay expectations on the label volume the app shows, for scripts that check what a
//! classification did with the user's lassos:
//!
//! * `expect air-classified-below 5%`: of the *air around the body* (voxels below the volume's
//!   Otsu threshold that a path of such voxels joins to the edge of their own z slice: what a
//!   radiologist calls outside on an axial slice; lungs and airways, ringed by the chest wall
//!   in every axial slice, are not in it, even where they leave the volume through a face),
//!   less than this share has a class. Fails when the air became a class, the bug of a 3-D
//!   view that shows an opaque box. Measured independently of how the segmentation finds the
//!   body.
//! * `expect lasso-voxels-kept 90%`: for every class, at least this share of its own lassoed
//!   voxels carry its label. A lasso's own voxels are those outside that air: the air a loop
//!   takes in at a body's edge is not what the user lassoed, and must stay background by the
//!   first expectation.
//!
//! * `expect class-share-above 1:5%`: class 1 (the first defined) holds more than this share of
//!   the volume's voxels: what its loops were drawn around was classified as it, not only the
//!   loops themselves (a lung whose loop the air took in keeps only its lassoed voxels).
//!
//! Values are percentages (`5%`) or fractions (`0.05`). The runner calls [`check`] with the
//! app's volume, labels and the lassos they were trained on.
//!
//! Never: touches the UI; it only measures.

use crate::strokes::{StrokesFile, TrainingSet};
use crate::volume::Volume;

/// The expectation keys [`check`] knows.
pub const KEYS: [&str; 3] = ["air-classified-below", "lasso-voxels-kept", "class-share-above"];

/// A share written as `5%` or `0.05`, within 0..=1.
pub fn parse_share(text: &str) -> Option<f64> {
    let text = text.trim();
    let share = match text.strip_suffix('%') {
        Some(percent) => percent.trim().parse::<f64>().ok()? / 100.0,
        None => text.parse::<f64>().ok()?,
    };
    (0.0..=1.0).contains(&share).then_some(share)
}

/// The air around the body (the module doc), one flag per voxel.
pub fn air_around_the_body(volume: &Volume) -> Vec<bool> {
    let [nx, ny, nz] = volume.dims;
    let level = volume.otsu_threshold();
    let mut air = vec![false; volume.voxel_count()];
    let mut stack = Vec::new();
    for z in 0..nz {
        let plane = nx * ny * z;
        let dark = |k: usize| volume.value(plane + k) < level;
        let edge = (0..nx).flat_map(|x| [x, x + nx * (ny - 1)]).chain((0..ny).flat_map(|y| [nx * y, nx * y + nx - 1]));
        stack.extend(edge.filter(|&k| dark(k)));
        while let Some(k) = stack.pop() {
            if air[plane + k] || !dark(k) {
                continue;
            }
            air[plane + k] = true;
            let (x, y) = (k % nx, k / nx);
            stack.extend(
                [
                    (x > 0).then(|| k - 1),
                    (x + 1 < nx).then(|| k + 1),
                    (y > 0).then(|| k - nx),
                    (y + 1 < ny).then(|| k + nx),
                ]
                .into_iter()
                .flatten(),
            );
        }
    }
    air
}

/// The air around the body of `volume` (voxels) and the share of it that `labels` classify
/// (0 when there is none).
pub fn air_classified(volume: &Volume, labels: &[u8]) -> (usize, f64) {
    let air = air_around_the_body(volume);
    let count = air.iter().filter(|&&a| a).count();
    let classified = air.iter().zip(labels).filter(|(a, l)| **a && **l != 0).count();
    (count, if count == 0 { 0.0 } else { classified as f64 / count as f64 })
}

/// For each class of `strokes`, the share of its lassoed voxels outside the air around the
/// body that `labels` give that class (1 for a class with none).
pub fn lasso_voxels_kept(volume: &Volume, labels: &[u8], strokes: &StrokesFile) -> Result<Vec<f64>, String> {
    let training = TrainingSet::from_strokes_keeping_empty(strokes, volume.dims).map_err(|e| e.to_string())?;
    let air = air_around_the_body(volume);
    Ok(training
        .classes
        .iter()
        .enumerate()
        .map(|(position, class)| {
            let own: Vec<usize> = class.voxels.iter().copied().filter(|&v| !air[v]).collect();
            let kept = own.iter().filter(|&&v| labels.get(v) == Some(&(position as u8 + 1))).count();
            if own.is_empty() { 1.0 } else { kept as f64 / own.len() as f64 }
        })
        .collect())
}

/// Checks expectation `key` (one of [`KEYS`]) with `value` against a classification.
pub fn check(key: &str, value: &str, volume: &Volume, labels: &[u8], strokes: &StrokesFile) -> Result<(), String> {
    if key == "class-share-above" {
        let parsed = value
            .split_once(':')
            .and_then(|(class, share)| Some((class.trim().parse::<u8>().ok()?, parse_share(share)?)));
        let (class, wanted) = parsed.ok_or(format!("{key} wants a class and a share such as 1:5%, not '{value}'"))?;
        let share = labels.iter().filter(|&&l| l == class).count() as f64 / labels.len().max(1) as f64;
        return if share > wanted {
            Ok(())
        } else {
            Err(format!("class {class} holds {:.2} % of the voxels", 100.0 * share))
        };
    }
    let wanted = parse_share(value).ok_or(format!("{key} wants a share such as 5% or 0.05, not '{value}'"))?;
    if labels.len() != volume.voxel_count() {
        return Err(format!("the label volume has {} voxels, the volume {}", labels.len(), volume.voxel_count()));
    }
    match key {
        "air-classified-below" => {
            let (air, share) = air_classified(volume, labels);
            if share < wanted {
                Ok(())
            } else {
                Err(format!("{:.1} % of the {air} voxels of air around the body have a class", 100.0 * share))
            }
        }
        "lasso-voxels-kept" => {
            let kept = lasso_voxels_kept(volume, labels, strokes)?;
            match kept.iter().enumerate().find(|(_, share)| **share < wanted) {
                None => Ok(()),
                Some((position, share)) => Err(format!(
                    "class {} ('{}') keeps {:.1} % of its lassoed voxels",
                    position + 1,
                    strokes.classes[position].name,
                    100.0 * share
                )),
            }
        }
        _ => Err(format!("unknown label expectation '{key}'")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slices::Axis;
    use crate::strokes::{ClassStrokes, Lasso};
    use std::path::Path;

    /// Air (0) around a block of tissue (100) at x, y 4..12 through every z.
    fn block() -> Volume {
        let values: Vec<f32> = (0..16 * 16 * 4)
            .map(|i| if (4..12).contains(&(i % 16)) && (4..12).contains(&(i / 16 % 16)) { 100.0 } else { 0.0 })
            .collect();
        Volume::from_f32([16, 16, 4], [1.0; 3], &values, Path::new("block")).unwrap()
    }

    fn square(from: f64, to: f64) -> Lasso {
        Lasso { axis: Axis::Z, slice: 2, points: vec![[from, from], [to, from], [to, to], [from, to]] }
    }

    #[test]
    fn shares_parse_as_percentages_or_fractions() {
        assert_eq!(parse_share("5%"), Some(0.05));
        assert_eq!(parse_share("0.9"), Some(0.9));
        assert_eq!(parse_share(" 90 % "), Some(0.9));
        assert_eq!(parse_share("150%"), None);
        assert_eq!(parse_share("most"), None);
    }

    #[test]
    fn the_air_check_counts_classified_air_around_the_body() {
        let volume = block();
        let tissue_only: Vec<u8> = (0..volume.voxel_count()).map(|i| u8::from(volume.value(i) > 50.0)).collect();
        let strokes = StrokesFile { classes: vec![] };
        assert_eq!(air_classified(&volume, &tissue_only), (16 * 16 * 4 - 8 * 8 * 4, 0.0));
        assert!(check("air-classified-below", "5%", &volume, &tissue_only, &strokes).is_ok());
        let everything = vec![1u8; volume.voxel_count()];
        let failure = check("air-classified-below", "5%", &volume, &everything, &strokes).unwrap_err();
        assert!(failure.contains("100.0 %"), "{failure}");
    }

    #[test]
    fn a_class_share_is_checked_against_the_whole_volume() {
        let volume = block();
        let strokes = StrokesFile { classes: vec![] };
        let labels: Vec<u8> = (0..volume.voxel_count()).map(|i| u8::from(volume.value(i) > 50.0)).collect();
        // The block is 8 x 8 of 16 x 16: a quarter of the voxels.
        assert!(check("class-share-above", "1:20%", &volume, &labels, &strokes).is_ok());
        let failure = check("class-share-above", "1:30%", &volume, &labels, &strokes).unwrap_err();
        assert!(failure.contains("25.00 %"), "{failure}");
        assert!(check("class-share-above", "30%", &volume, &labels, &strokes).is_err());
    }

    #[test]
    fn air_ringed_by_the_body_in_its_slice_is_not_air_around_it() {
        // A lung: dark x, y 6..10 inside the block, on every plane, so also on the faces z = 0, 3.
        let values: Vec<f32> = (0..16 * 16 * 4)
            .map(|i| {
                let (x, y) = (i % 16, i / 16 % 16);
                let block = (4..12).contains(&x) && (4..12).contains(&y);
                let lung = (6..10).contains(&x) && (6..10).contains(&y);
                if block && !lung { 100.0 } else { 0.0 }
            })
            .collect();
        let volume = Volume::from_f32([16, 16, 4], [1.0; 3], &values, Path::new("chest")).unwrap();
        let air = air_around_the_body(&volume);
        assert!(!air[8 + 16 * (8 + 16 * 3)], "the lung on the top face");
        assert!(air[1 + 16 * (1 + 16 * 3)]);
        assert_eq!(air.iter().filter(|&&a| a).count(), 16 * 16 * 4 - 8 * 8 * 4);
    }

    #[test]
    fn lassoed_voxels_in_the_air_are_not_the_lassos_own() {
        let volume = block();
        // Class 1 lassoes tissue and air (x, y 1..7), class 2 tissue only (x, y 8..11).
        let strokes = StrokesFile {
            classes: vec![
                ClassStrokes { name: "edge".into(), strokes: vec![square(0.5, 6.5)] },
                ClassStrokes { name: "core".into(), strokes: vec![square(7.5, 10.5)] },
            ],
        };
        let mut labels: Vec<u8> = (0..volume.voxel_count()).map(|i| u8::from(volume.value(i) > 50.0) * 2).collect();
        // Class 1's own voxels (tissue at x, y 4..6 on plane 2) get class 1.
        for y in 4..7 {
            for x in 4..7 {
                labels[x + 16 * (y + 16 * 2)] = 1;
            }
        }
        assert_eq!(lasso_voxels_kept(&volume, &labels, &strokes).unwrap(), vec![1.0, 1.0]);
        assert!(check("lasso-voxels-kept", "90%", &volume, &labels, &strokes).is_ok());
        labels[5 + 16 * (5 + 16 * 2)] = 2;
        let kept = lasso_voxels_kept(&volume, &labels, &strokes).unwrap();
        assert!((kept[0] - 8.0 / 9.0).abs() < 1e-12);
        let failure = check("lasso-voxels-kept", "90%", &volume, &labels, &strokes).unwrap_err();
        assert!(failure.contains("class 1 ('edge')"), "{failure}");
    }
}
