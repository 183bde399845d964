//! The paper's pre-classified volume (§3.5, its output): straight-alpha RGBA8 per voxel from
//! the label volume and the class table, `ClassStyle::rgba` at each voxel's gradient magnitude.
//!
//! The gradient is the central difference one voxel apart along each axis in value units per
//! mm (neighbours clamped at the faces), the same estimate the shader's `scalar_gradient`
//! makes at voxel centres, so pre- and post-classified renders of one scene agree away from
//! class borders. Reads the volume three z-slices at a time.
//!
//! Never: classifies voxels or chooses colours; it only evaluates the given table.

use super::RenderError;
use crate::transfer::ClassStyle;
use crate::volume::Volume;

/// 4 bytes per voxel (x fastest): RGBA of `styles[label - 1]`, transparent black for label 0
/// and for labels without a style.
pub fn preclassified_rgba(volume: &Volume, labels: &[u8], styles: &[ClassStyle]) -> Result<Vec<u8>, RenderError> {
    let dims = volume.dims;
    if labels.len() != volume.voxel_count() {
        return Err(RenderError::DataSize {
            what: "label volume",
            dims,
            expected: volume.voxel_count(),
            found: labels.len(),
        });
    }
    let [nx, ny, nz] = dims;
    let plane = nx * ny;
    let spacing = volume.spacing_mm.map(|s| s as f32);
    // Slices z - 1, z, z + 1 (clamped), rotated as z advances.
    let mut slices = [vec![0f32; plane], vec![0f32; plane], vec![0f32; plane]];
    volume.read_z_slice_f32(0, &mut slices[0]);
    volume.read_z_slice_f32(0, &mut slices[1]);
    volume.read_z_slice_f32(1.min(nz - 1), &mut slices[2]);
    let mut rgba = vec![0u8; 4 * volume.voxel_count()];
    for z in 0..nz {
        if z > 0 {
            slices.rotate_left(1);
            volume.read_z_slice_f32((z + 1).min(nz - 1), &mut slices[2]);
        }
        let [below, here, above] = &slices;
        for y in 0..ny {
            for x in 0..nx {
                let index = x + nx * (y + ny * z);
                let label = labels[index] as usize;
                let Some(style) = label.checked_sub(1).and_then(|class| styles.get(class)) else {
                    continue;
                };
                let at = |x: usize, y: usize| x + nx * y;
                let gradient = [
                    (here[at((x + 1).min(nx - 1), y)] - here[at(x.saturating_sub(1), y)]) / (2.0 * spacing[0]),
                    (here[at(x, (y + 1).min(ny - 1))] - here[at(x, y.saturating_sub(1))]) / (2.0 * spacing[1]),
                    (above[at(x, y)] - below[at(x, y)]) / (2.0 * spacing[2]),
                ];
                let magnitude = gradient.iter().map(|g| g * g).sum::<f32>().sqrt();
                let colour = style.rgba(if magnitude.is_finite() { magnitude } else { 0.0 });
                for (out, channel) in rgba[4 * index..4 * index + 4].iter_mut().zip(colour) {
                    *out = (channel.clamp(0.0, 1.0) * 255.0).round() as u8;
                }
            }
        }
    }
    Ok(rgba)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn opacity_follows_the_central_difference_gradient_in_value_per_mm() {
        // Values rise 3 per voxel along x with 1.5 mm spacing: 2 per mm inside, half at the faces.
        let dims = [5, 2, 3];
        let values: Vec<f32> = (0..30).map(|i| 3.0 * (i % 5) as f32).collect();
        let volume = Volume::from_f32(dims, [1.5, 1.0, 1.0], &values, Path::new("ramp")).unwrap();
        let style = ClassStyle {
            hue_degrees: [0.0, 120.0],
            saturation: 1.0,
            value: 1.0,
            opacity: [0.0, 1.0],
            gradient_max: 4.0,
            emphasis: 1.0,
            visible: true,
        };
        let mut labels = vec![1u8; 30];
        labels[7] = 0;
        labels[8] = 2;
        let rgba = preclassified_rgba(&volume, &labels, std::slice::from_ref(&style)).unwrap();
        let expected = |gradient: f32| style.rgba(gradient).map(|c| (c * 255.0).round() as u8);
        assert_eq!(rgba[4 * 2..4 * 3], expected(2.0), "interior voxel: F = 0.5");
        assert_eq!(rgba[0..4], expected(1.0), "face voxel: one-sided difference over two spacings");
        assert_eq!(rgba[4 * 7..4 * 8], [0; 4], "background");
        assert_eq!(rgba[4 * 8..4 * 9], [0; 4], "a label with no style");
        assert!(matches!(
            preclassified_rgba(&volume, &labels[1..], &[style]),
            Err(RenderError::DataSize { expected: 30, found: 29, .. })
        ));
    }
}
