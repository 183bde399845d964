//! A NRRD header's voxel spacing: `space directions` (the norms of the axis vectors) or
//! `spacings`, checked to lie in the range any scan has ([`crate::volume::check_spacing`]).

use super::truncate;
use crate::volume::VolumeError;
use std::path::Path;

/// Spacing per spatial axis from `space directions` (vector norms) or `spacings`; 1 where
/// neither says. With it, a warning (for the user: the shape may be wrong) when `spacings`
/// marks a spatial axis as non-spatial (NaN) beside axes whose spacing it gives.
pub(super) fn parse_spacing(
    directions: Option<&str>,
    spacings: Option<&str>,
    spatial_axes: &[usize],
    dimension: usize,
    path: &Path,
) -> Result<([f64; 3], Option<String>), VolumeError> {
    let mut spacing = [1.0f64; 3];
    let mut unknown = Vec::new();
    if let Some(value) = directions {
        let vectors = split_direction_vectors(value);
        if vectors.len() != dimension {
            return Err(VolumeError::header(
                "space directions",
                format!("{} entries for dimension {dimension}", vectors.len()),
                path,
            ));
        }
        for (i, &axis) in spatial_axes.iter().enumerate() {
            let entry = vectors[axis];
            if entry == "none" {
                return Err(VolumeError::header(
                    "space directions",
                    format!("spatial axis {axis} has direction 'none'"),
                    path,
                ));
            }
            let components: Vec<f64> = entry
                .trim_start_matches('(')
                .trim_end_matches(')')
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    VolumeError::header(
                        "space directions",
                        format!("'{}' is not a vector of numbers", truncate(entry)),
                        path,
                    )
                })?;
            let norm = components.iter().map(|c| c * c).sum::<f64>().sqrt();
            spacing[i] = norm;
        }
    } else if let Some(value) = spacings {
        let values: Vec<&str> = value.split_whitespace().collect();
        if values.len() != dimension {
            return Err(VolumeError::header(
                "spacings",
                format!("{} entries for dimension {dimension}", values.len()),
                path,
            ));
        }
        for (i, &axis) in spatial_axes.iter().enumerate() {
            let parsed = values[axis].parse::<f64>().map_err(|_| {
                VolumeError::header("spacings", format!("'{}' is not a number", truncate(values[axis])), path)
            })?;
            // NaN marks a non-spatial axis; treat as unknown (1).
            spacing[i] = if parsed.is_nan() { 1.0 } else { parsed };
            if parsed.is_nan() {
                unknown.push(i);
            }
        }
    }
    let known: Vec<String> =
        (0..spatial_axes.len()).filter(|i| !unknown.contains(i)).map(|i| format!("{} mm", spacing[i])).collect();
    let warning = (!unknown.is_empty() && !known.is_empty()).then(|| {
        let names: Vec<&str> = unknown.iter().map(|&i| ["x", "y", "z"][i]).collect();
        format!(
            "the file gives no spacing for axis {} (NaN); shown at 1 mm beside {}, so the scan may look stretched or squashed along it",
            names.join(" and "),
            known.join(" and ")
        )
    });
    crate::volume::check_spacing(spacing, path)?;
    Ok((spacing, warning))
}

/// Splits `(1,0,0) (0,1,0) none` into its entries, allowing spaces inside the parentheses.
pub(crate) fn split_direction_vectors(value: &str) -> Vec<&str> {
    let mut entries = Vec::new();
    let mut rest = value.trim_start();
    while !rest.is_empty() {
        let end = if rest.starts_with('(') {
            rest.find(')').map_or(rest.len(), |i| i + 1)
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        entries.push(&rest[..end]);
        rest = rest[end..].trim_start();
    }
    entries
}
