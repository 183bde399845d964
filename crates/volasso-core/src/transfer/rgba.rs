//! The paper's pre-classified RGBA volume (§3.5, last step): each voxel's class style evaluated
//! at its own gradient factor, 4 x u8 per voxel (straight alpha), background and hidden classes
//! fully transparent; its NRRD file, streamed a group of z slices at a time so that a 1024³
//! volume's 4 GiB never sit in memory; and a CPU front-to-back compositing along z for previews
//! and tests.
//!
//! Never: renders on the GPU, or changes styles.

use super::harmony::check_labels;
use super::overlay::RgbImage;
use super::{ClassStyle, TransferError};
use crate::atomic_file::{Staged, stage, write_atomically};
use crate::features::{FeatureSet, FeatureSlabReader};
use crate::volume::Volume;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;

/// z slices one parallel task colours, one after another (its feature reader keeps the planes
/// around the last slice, so neighbours are read once).
const TASK_SLICES: usize = 4;

/// The most RGBA bytes held at once while streaming: one group of slices coloured in parallel.
pub const GROUP_BYTES: usize = 64 << 20;

/// Colours the RGBA volume a group of whole z slices at a time (x fastest within each) and
/// hands each group to `sink` in z order: `styles[k - 1]` at the voxel's gradient for class
/// `k`, `[0, 0, 0, 0]` for background (label 0). At most [`GROUP_BYTES`] (or one slice, if
/// larger) are held; the groups' slices are coloured in parallel.
pub fn for_each_rgba_group(
    volume: &Volume,
    labels: &[u8],
    styles: &[ClassStyle],
    mut sink: impl FnMut(&[u8]) -> Result<(), TransferError>,
) -> Result<(), TransferError> {
    check_labels(volume, labels, styles.len())?;
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    if plane == 0 || size_z == 0 {
        return Ok(());
    }
    let slice_bytes = plane * 4;
    let threads = rayon::current_num_threads().max(1);
    let group_slices = (GROUP_BYTES / slice_bytes).min(threads * TASK_SLICES).max(1);
    let task_slices = group_slices.div_ceil(threads).clamp(1, TASK_SLICES);
    let mut group = Vec::new();
    for group_start in (0..size_z).step_by(group_slices) {
        let group_end = (group_start + group_slices).min(size_z);
        group.clear();
        group.resize((group_end - group_start) * slice_bytes, 0u8);
        group.par_chunks_mut(task_slices * slice_bytes).enumerate().try_for_each_init(
            || (FeatureSlabReader::new(volume, FeatureSet::Paper5), Vec::new(), Vec::new()),
            |(reader, block, selected), (task, out)| -> Result<(), TransferError> {
                for (offset, slice_out) in out.chunks_exact_mut(slice_bytes).enumerate() {
                    let z = group_start + task * task_slices + offset;
                    let slice_labels = &labels[z * plane..(z + 1) * plane];
                    colour_slice(reader, z, slice_labels, styles, slice_out, block, selected)?;
                }
                Ok(())
            },
        )?;
        sink(&group)?;
    }
    Ok(())
}

/// Colours one z slice into `out` (zeroed): features only of its labelled voxels.
fn colour_slice(
    reader: &mut FeatureSlabReader,
    z: usize,
    labels: &[u8],
    styles: &[ClassStyle],
    out: &mut [u8],
    block: &mut Vec<f32>,
    selected: &mut Vec<usize>,
) -> Result<(), TransferError> {
    selected.clear();
    selected.extend(labels.iter().enumerate().filter(|&(_, &label)| label != 0).map(|(i, _)| i));
    if selected.is_empty() {
        return Ok(());
    }
    reader.compute_selected(z, selected, block)?;
    let dim = reader.feature_set().dim();
    for (k, &i) in selected.iter().enumerate() {
        let gradient = block[k * dim + 1];
        let gradient = if gradient.is_finite() { gradient } else { 0.0 };
        let colour = styles[labels[i] as usize - 1].rgba(gradient);
        for (byte, channel) in out[4 * i..4 * i + 4].iter_mut().zip(colour) {
            *byte = (channel * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
        }
    }
    Ok(())
}

/// The whole RGBA volume in memory (4 bytes per voxel, x fastest); see [`for_each_rgba_group`].
/// For small volumes, previews and tests: files are written with [`stage_rgba_nrrd`].
pub fn rgba_volume(volume: &Volume, labels: &[u8], styles: &[ClassStyle]) -> Result<Vec<u8>, TransferError> {
    let mut rgba = Vec::with_capacity(volume.voxel_count() * 4);
    for_each_rgba_group(volume, labels, styles, |group| {
        rgba.extend_from_slice(group);
        Ok(())
    })?;
    rgba.resize(volume.voxel_count() * 4, 0);
    Ok(rgba)
}

/// The header of an attached raw RGBA NRRD (`sizes: 4 X Y Z`, `kinds: RGBA-color domain domain
/// domain`), each line of `comment` as a `#` line.
fn rgba_header(dims: [usize; 3], spacing_mm: [f64; 3], comment: &str) -> String {
    let mut header = String::from("NRRD0004\n");
    for line in comment.lines() {
        header.push_str(&format!("# {line}\n"));
    }
    header.push_str(&format!(
        "type: uint8\ndimension: 4\nsizes: 4 {} {} {}\nspace dimension: 3\nspace directions: none ({},0,0) (0,{},0) (0,0,{})\nkinds: RGBA-color domain domain domain\nencoding: raw\n\n",
        dims[0], dims[1], dims[2], spacing_mm[0], spacing_mm[1], spacing_mm[2],
    ));
    header
}

/// Writes the RGBA volume of `volume`'s `labels` as an attached raw NRRD beside `path`,
/// streamed group by group, and returns it staged: nothing is at `path` until the caller
/// commits it (with the other outputs of the same run).
pub fn stage_rgba_nrrd(
    path: &Path,
    volume: &Volume,
    labels: &[u8],
    styles: &[ClassStyle],
    comment: &str,
) -> Result<Staged, TransferError> {
    check_labels(volume, labels, styles.len())?;
    let header = rgba_header(volume.dims, volume.spacing_mm, comment);
    // The colouring's own error, kept apart from the file's: `stage` only carries io errors.
    let mut failure = None;
    let staged = stage(path, |file| {
        file.write_all(header.as_bytes())?;
        let result = for_each_rgba_group(volume, labels, styles, |group| {
            file.write_all(group).map_err(|source| TransferError::Io { source, path: path.to_path_buf() })
        });
        result.map_err(|error| {
            let io = std::io::Error::other(error.to_string());
            failure = Some(error);
            io
        })
    });
    match (staged, failure) {
        (Ok(staged), _) => Ok(staged),
        (Err(_), Some(error)) => Err(error),
        (Err(source), None) => Err(TransferError::Io { source, path: path.to_path_buf() }),
    }
}

/// Writes an RGBA volume already in memory as an attached, raw NRRD, atomically.
pub fn write_rgba_nrrd(
    path: &Path,
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    rgba: &[u8],
    comment: &str,
) -> Result<(), TransferError> {
    let expected = dims.iter().product::<usize>() * 4;
    if rgba.len() != expected {
        return Err(TransferError::RgbaSize { dims, expected, found: rgba.len() });
    }
    let header = rgba_header(dims, spacing_mm, comment);
    write_atomically(path, |file| {
        file.write_all(header.as_bytes())?;
        file.write_all(rgba)
    })
    .map_err(|source| TransferError::Io { source, path: path.to_path_buf() })
}

/// Front-to-back "over" compositing of an RGBA volume along z (z = 0 in front) onto a black
/// background: an x-by-y RGB picture of what a ray caster looking down z would show, with
/// opacities taken per voxel step as stored.
pub fn composite_along_z(rgba: &[u8], dims: [usize; 3]) -> RgbImage {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    let mut pixels = vec![0u8; plane * 3];
    pixels.par_chunks_mut(3).enumerate().for_each(|(p, pixel)| {
        let mut colour = [0f32; 3];
        let mut transmittance = 1.0f32;
        for z in 0..size_z {
            let voxel = &rgba[(z * plane + p) * 4..(z * plane + p) * 4 + 4];
            let alpha = voxel[3] as f32 / 255.0;
            for c in 0..3 {
                colour[c] += transmittance * alpha * voxel[c] as f32 / 255.0;
            }
            transmittance *= 1.0 - alpha;
            if transmittance < 1e-3 {
                break;
            }
        }
        for c in 0..3 {
            pixel[c] = (colour[c] * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
        }
    });
    RgbImage { width: size_x, height: size_y, pixels }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::demo_foot_with;
    use crate::transfer::{HueTemplate, class_styles};

    #[test]
    fn background_is_transparent_and_classes_follow_their_style() {
        let phantom = demo_foot_with([40, 28, 20], 3).unwrap();
        let (volume, labels) = (phantom.volume, phantom.truth);
        let mut styles = class_styles(&volume, &labels, 3, &HueTemplate::default_for(3)).unwrap();
        let rgba = rgba_volume(&volume, &labels, &styles).unwrap();
        assert_eq!(rgba.len(), labels.len() * 4);
        let mut seen = [0usize; 4];
        for (index, (&label, pixel)) in labels.iter().zip(rgba.chunks_exact(4)).enumerate() {
            seen[label as usize] += 1;
            if label == 0 {
                assert_eq!(pixel, [0, 0, 0, 0], "background voxel {index}");
            } else {
                let gradient = crate::features::features_at(&volume, index)[1];
                let expected = styles[label as usize - 1].rgba(gradient).map(|c| (c * 255.0 + 0.5) as u8);
                let close = pixel.iter().zip(expected).all(|(&a, b)| a.abs_diff(b) <= 1);
                assert!(close, "voxel {index}: {pixel:?} vs {expected:?}");
                assert!(pixel[3] >= 50, "every class keeps at least the 0.2 floor");
            }
        }
        assert!(seen.iter().all(|&n| n > 0));

        styles[1].visible = false;
        let hidden = rgba_volume(&volume, &labels, &styles).unwrap();
        for ((&label, pixel), shown) in labels.iter().zip(hidden.chunks_exact(4)).zip(rgba.chunks_exact(4)) {
            if label == 2 {
                assert_eq!(pixel, [0, 0, 0, 0], "a hidden class is transparent");
            } else {
                assert_eq!(pixel, shown, "other classes do not change");
            }
        }
        assert!(matches!(rgba_volume(&volume, &labels, &styles[..2]), Err(TransferError::LabelOutOfRange { .. })));
    }

    #[test]
    fn the_streamed_file_holds_the_same_bytes_in_groups_no_larger_than_the_bound() {
        // 30 slices of 48 x 40: several groups of at most 4 slices per thread each.
        let phantom = demo_foot_with([48, 40, 30], 5).unwrap();
        let (volume, labels) = (phantom.volume, phantom.truth);
        let styles = class_styles(&volume, &labels, 3, &HueTemplate::default_for(3)).unwrap();
        let whole = rgba_volume(&volume, &labels, &styles).unwrap();
        let mut largest = 0;
        let mut streamed = Vec::new();
        for_each_rgba_group(&volume, &labels, &styles, |group| {
            largest = largest.max(group.len());
            assert_eq!(group.len() % (48 * 40 * 4), 0, "whole slices only");
            streamed.extend_from_slice(group);
            Ok(())
        })
        .unwrap();
        assert_eq!(streamed, whole);
        assert!(largest <= GROUP_BYTES);

        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("rgba.nrrd");
        let staged = stage_rgba_nrrd(&path, &volume, &labels, &styles, "run 7").unwrap();
        assert!(!path.exists(), "nothing at the target before the commit");
        staged.commit().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"NRRD0004\n# run 7\n"));
        assert!(bytes.ends_with(&whole));
        // Labels that do not fit the styles: an error, and no file or temporary left.
        let failed = stage_rgba_nrrd(&folder.path().join("bad.nrrd"), &volume, &labels, &styles[..1], "");
        assert!(matches!(failed, Err(TransferError::LabelOutOfRange { .. })));
        assert_eq!(std::fs::read_dir(folder.path()).unwrap().count(), 1);
    }

    #[test]
    fn compositing_stops_at_an_opaque_voxel_and_the_nrrd_header_names_rgba() {
        // Two voxels deep: an opaque red voxel in front of green shows red; a transparent one
        // lets the green through.
        let rgba = [255, 0, 0, 255, 0, 0, 0, 0, 0, 255, 0, 255, 0, 255, 0, 255];
        let picture = composite_along_z(&rgba, [2, 1, 2]);
        assert_eq!(picture.pixels, [255, 0, 0, 0, 255, 0]);
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("rgba.nrrd");
        write_rgba_nrrd(&path, [2, 1, 2], [1.0, 1.0, 2.5], &rgba, "test").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("sizes: 4 2 1 2\n") && text.contains("kinds: RGBA-color domain domain domain\n"));
        assert!(bytes.ends_with(&rgba));
        assert!(write_rgba_nrrd(&path, [2, 2, 2], [1.0; 3], &rgba, "").is_err());
    }
}
