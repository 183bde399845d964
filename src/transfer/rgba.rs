//! The paper's pre-classified RGBA volume (§3.5, last step): each voxel's class style evaluated
//! at its own gradient factor, 4 x u8 per voxel (straight alpha), background and hidden classes
//! fully transparent; its NRRD file; and a CPU front-to-back compositing along z for previews
//! and tests.
//!
//! Never: renders on the GPU, or changes styles.

use super::harmony::check_labels;
use super::overlay::RgbImage;
use super::{ClassStyle, TransferError};
use crate::atomic_file::write_atomically;
use crate::features::{FeatureSet, FeatureSlabReader};
use crate::volume::Volume;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;

/// z slices per parallel task.
const SLAB_DEPTH_Z: usize = 4;

/// RGBA of every voxel (x fastest), 4 bytes each: `styles[k - 1]` at the voxel's gradient for
/// class `k`, `[0, 0, 0, 0]` for background (label 0); parallel over z slabs.
pub fn rgba_volume(volume: &Volume, labels: &[u8], styles: &[ClassStyle]) -> Result<Vec<u8>, TransferError> {
    check_labels(volume, labels, styles.len())?;
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    let mut rgba = vec![0u8; volume.voxel_count() * 4];
    if plane == 0 || size_z == 0 {
        return Ok(rgba);
    }
    rgba.par_chunks_mut(plane * SLAB_DEPTH_Z * 4).enumerate().try_for_each_init(
        || (FeatureSlabReader::new(volume, FeatureSet::Paper5), Vec::new()),
        |(reader, block), (slab, out)| -> Result<(), TransferError> {
            let z_start = slab * SLAB_DEPTH_Z;
            let z_range = z_start..z_start + out.len() / (plane * 4);
            let first_voxel = z_start * plane;
            let voxel_labels = &labels[first_voxel..first_voxel + out.len() / 4];
            // Skip the features of a slab that is all background.
            if voxel_labels.iter().all(|&l| l == 0) {
                return Ok(());
            }
            reader.compute(z_range, block)?;
            let dim = reader.feature_set().dim();
            for (offset, (&label, pixel)) in voxel_labels.iter().zip(out.chunks_exact_mut(4)).enumerate() {
                if label == 0 {
                    continue;
                }
                let gradient = block[offset * dim + 1];
                let gradient = if gradient.is_finite() { gradient } else { 0.0 };
                let colour = styles[label as usize - 1].rgba(gradient);
                for (byte, channel) in pixel.iter_mut().zip(colour) {
                    *byte = (channel * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
                }
            }
            Ok(())
        },
    )?;
    Ok(rgba)
}

/// Writes an RGBA volume as an attached, raw NRRD (`sizes: 4 X Y Z`, `kinds: RGBA-color domain
/// domain domain`), atomically.
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
    let mut header = String::from("NRRD0004\n");
    for line in comment.lines() {
        header.push_str(&format!("# {line}\n"));
    }
    header.push_str(&format!(
        "type: uint8\ndimension: 4\nsizes: 4 {} {} {}\nspace dimension: 3\nspace directions: none ({},0,0) (0,{},0) (0,0,{})\nkinds: RGBA-color domain domain domain\nencoding: raw\n\n",
        dims[0], dims[1], dims[2], spacing_mm[0], spacing_mm[1], spacing_mm[2],
    ));
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
