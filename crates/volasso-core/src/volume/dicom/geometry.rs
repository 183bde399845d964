//! Where the slices of one series lie: their order along the slice normal, their spacing, and
//! whether they form a regular grid.
//!
//! Nouns: the *row direction* r and *column direction* c are ImageOrientationPatient's two
//! cosine triples (r points along a row, towards increasing column index, i.e. along x); the
//! *normal* is n = r × c. A slice's *first pixel* ImagePositionPatient is described by its
//! projections (u, v, w) on (r, c, n). Slices are ordered by w; the *gaps* are the differences
//! of consecutive w; a nonzero change of (u, v) between slices is a *tilt* (gantry tilt makes
//! each slice shift in-plane as the table moves).
//!
//! Entry points: [`order_slices`] (checks consistency, sorts, removes duplicate files) and
//! [`StackGeometry::regularity`]. SliceThickness is never used for spacing: it describes the
//! slice profile, not where the next slice is.
//!
//! Never: reads pixel data or resamples.

use super::header::SliceHeader;
use crate::volume::VolumeError;

/// The in-plane shift below which slices count as stacked straight (fraction of a pixel).
const TILT_TOLERANCE_PIXELS: f64 = 0.1;
/// Gaps whose spread is within this fraction of the median gap count as even.
const EVEN_GAP_TOLERANCE: f64 = 0.01;
/// Slices closer than this fraction of a pixel along the normal share one position.
const DUPLICATE_TOLERANCE_PIXELS: f64 = 0.01;
/// A gap at least this many times the series' spacing leaves room for a slice that is not
/// there (see [`StackGeometry::missing_slices`]).
const MISSING_SLICE_RATIO: f64 = 1.9;
/// Gaps on each side whose median is a gap's local spacing.
const LOCAL_GAPS: usize = 3;

/// A gap with room for a missing slice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct MissingSlice {
    /// The gap lies between slice `after` and slice `after + 1` (in normal order).
    pub after: usize,
    pub gap_mm: f64,
    /// The spacing the gap was compared with.
    pub spacing_mm: f64,
}

impl MissingSlice {
    pub fn describe(&self) -> String {
        format!(
            "the {:.2} mm gap between slices {} and {} is {:.1} times the series' {:.2} mm spacing",
            self.gap_mm,
            self.after + 1,
            self.after + 2,
            self.gap_mm / self.spacing_mm,
            self.spacing_mm
        )
    }
}

/// The geometry of an ordered series (slice k is `first_pixel_mm[k]`).
#[derive(Clone, Debug)]
pub(super) struct StackGeometry {
    pub rows: usize,
    pub columns: usize,
    /// [between columns (x), between rows (y)]: PixelSpacing in the order of the volume axes.
    pub pixel_spacing_mm: [f64; 2],
    /// ImagePositionPatient of each slice as (u, v, w) on (row, column, normal); w ascending.
    pub first_pixel_mm: Vec<[f64; 3]>,
    /// The spacing to report for a one-slice volume (SpacingBetweenSlices, SliceThickness or 1).
    pub single_slice_spacing_mm: f64,
    /// The frames of one file without positions, stacked in file order: which way that runs
    /// through the patient is unknown, so the volume gets no patient orientation.
    pub unplaced: bool,
}

/// How far a series is from a regular grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct StackRegularity {
    pub gap_min_mm: f64,
    pub gap_max_mm: f64,
    pub gap_median_mm: f64,
    /// Angle between the line through the first pixels of the end slices and the normal.
    pub tilt_degrees: f64,
    pub even_gaps: bool,
    pub tilted: bool,
}

impl StackRegularity {
    pub fn is_regular(&self) -> bool {
        self.even_gaps && !self.tilted
    }

    /// What is irregular, e.g. "gantry tilt 18.5 deg and uneven slice gaps 1.08..7.00 mm".
    pub fn describe(&self) -> String {
        let tilt = format!("gantry tilt {:.1} deg", self.tilt_degrees);
        let gaps = format!("uneven slice gaps {:.2}..{:.2} mm", self.gap_min_mm, self.gap_max_mm);
        match (self.tilted, self.even_gaps) {
            (true, false) => format!("{tilt} and {gaps}"),
            (true, true) => format!("{tilt} (slices shift in-plane; gap {:.2} mm)", self.gap_median_mm),
            (false, false) => gaps,
            (false, true) => format!("regular slices {:.2} mm apart", self.gap_median_mm),
        }
    }
}

impl StackGeometry {
    pub fn slice_count(&self) -> usize {
        self.first_pixel_mm.len()
    }

    /// Differences of consecutive normal positions (one fewer than slices).
    pub fn gaps_mm(&self) -> Vec<f64> {
        self.first_pixel_mm.windows(2).map(|pair| pair[1][2] - pair[0][2]).collect()
    }

    pub fn regularity(&self) -> StackRegularity {
        let gaps = self.gaps_mm();
        if gaps.is_empty() {
            return StackRegularity {
                gap_min_mm: self.single_slice_spacing_mm,
                gap_max_mm: self.single_slice_spacing_mm,
                gap_median_mm: self.single_slice_spacing_mm,
                tilt_degrees: 0.0,
                even_gaps: true,
                tilted: false,
            };
        }
        let gap_min_mm = gaps.iter().copied().fold(f64::INFINITY, f64::min);
        let gap_max_mm = gaps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let gap_median_mm = median(&gaps);
        let first = self.first_pixel_mm[0];
        let in_plane_shift_mm = |p: &[f64; 3]| (p[0] - first[0]).hypot(p[1] - first[1]);
        let largest_shift_mm = self.first_pixel_mm.iter().map(in_plane_shift_mm).fold(0.0, f64::max);
        let last = self.first_pixel_mm[self.slice_count() - 1];
        let tilt_degrees = in_plane_shift_mm(&last).atan2(last[2] - first[2]).to_degrees();
        let pixel_mm = self.pixel_spacing_mm[0].min(self.pixel_spacing_mm[1]);
        StackRegularity {
            gap_min_mm,
            gap_max_mm,
            gap_median_mm,
            tilt_degrees,
            even_gaps: gap_max_mm - gap_min_mm <= EVEN_GAP_TOLERANCE * gap_median_mm,
            tilted: largest_shift_mm > TILT_TOLERANCE_PIXELS * pixel_mm,
        }
    }

    /// Gaps that leave room for a slice the series lacks. A gap counts as a missing slice when
    /// it is at least [`MISSING_SLICE_RATIO`] (1.9) times the series' spacing there, taken as
    /// the smaller of the median of all gaps and the median of up to [`LOCAL_GAPS`] gaps on
    /// each side of it: one lost slice doubles a gap (2.0), two triple it, and 1.9 leaves 5 %
    /// for rounding in the positions. The local median finds a lost slice in the wider part
    /// of a series whose spacing changes; the series median one at the change. Uneven gaps
    /// that leave no such room (the GE head's 7.00 mm gaps are 1.75 times its 4.00 mm median,
    /// its 1.08 mm gap is an overlap) are uneven spacing, resampled as such.
    pub fn missing_slices(&self) -> Vec<MissingSlice> {
        let gaps = self.gaps_mm();
        let series_spacing_mm = median(&gaps);
        (0..gaps.len())
            .filter_map(|index| {
                let neighbours: Vec<f64> = (index.saturating_sub(LOCAL_GAPS)..(index + LOCAL_GAPS + 1).min(gaps.len()))
                    .filter(|&other| other != index)
                    .map(|other| gaps[other])
                    .collect();
                if neighbours.is_empty() {
                    return None;
                }
                let spacing_mm = series_spacing_mm.min(median(&neighbours));
                (spacing_mm > 0.0 && gaps[index] >= MISSING_SLICE_RATIO * spacing_mm).then_some(MissingSlice {
                    after: index,
                    gap_mm: gaps[index],
                    spacing_mm,
                })
            })
            .collect()
    }

    /// The geometry of the slices whose `keep` flag is set (in order).
    pub fn keeping(&self, keep: &[bool]) -> StackGeometry {
        let first_pixel_mm = self.first_pixel_mm.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect();
        StackGeometry { first_pixel_mm, ..self.clone() }
    }

    /// The slice spacing of a resampled grid when the caller gives none: the smallest gap that
    /// is at least half the median gap. It keeps the finest real sampling of the series while
    /// ignoring the odd overlapping slice (the GE head series has one 1.08 mm gap among 4 and
    /// 7 mm ones), which would multiply the slice count for no information.
    pub fn automatic_slice_spacing_mm(&self) -> f64 {
        let gaps = self.gaps_mm();
        let half_median = 0.5 * median(&gaps);
        gaps.iter().copied().filter(|gap| *gap >= half_median).fold(f64::INFINITY, f64::min)
    }
}

/// Checks that `headers` (one series, any order) agree on image size, pixel spacing and
/// orientation, sorts them along the normal and drops repeated copies of one image.
///
/// Duplicate positions: two files with the same SOPInstanceUID at one position are the same
/// image twice; the later (by path) is dropped with a warning. Two *different* images at one
/// position (several phases or acquisitions in one series) are an error, because choosing
/// one would silently drop data.
pub(super) fn order_slices(
    headers: Vec<SliceHeader>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<SliceHeader>, StackGeometry), VolumeError> {
    let Some(first) = headers.first() else {
        return Err(VolumeError::Dicom {
            problem: "the series has no image files".into(),
            path: std::path::PathBuf::new(),
        });
    };
    let multi_slice = headers.len() > 1;
    for header in &headers[1..] {
        check_consistent(first, header)?;
    }
    // The frames of one enhanced file without functional groups ([`super::header`]): stacked in
    // file order, SpacingBetweenSlices (else SliceThickness, else 1 mm) apart.
    let unplaced_frames = multi_slice && headers.iter().all(|h| h.path == first.path && h.position_mm.is_none());
    let frame_spacing_mm = first.slice_thickness_mm.unwrap_or(1.0);
    if unplaced_frames {
        warnings.push(format!(
            "the {} frames of {} carry no positions (no functional groups): stacked in file order, {frame_spacing_mm} mm apart ({}), without a patient orientation",
            headers.len(),
            first.path.display(),
            if first.slice_thickness_mm.is_some() { "SpacingBetweenSlices or SliceThickness" } else { "neither SpacingBetweenSlices nor SliceThickness is given" }
        ));
    }
    if multi_slice && !unplaced_frames {
        for header in &headers {
            let missing = if header.position_mm.is_none() {
                Some("ImagePositionPatient")
            } else if header.orientation.is_none() {
                Some("ImageOrientationPatient")
            } else {
                None
            };
            if let Some(field) = missing {
                return Err(VolumeError::Dicom {
                    problem: format!(
                        "{field} is missing, and slices of a {}-file series cannot be placed without it",
                        headers.len()
                    ),
                    path: header.path.clone(),
                });
            }
        }
    }
    let orientation = first.orientation.unwrap_or([1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let row_direction = [orientation[0], orientation[1], orientation[2]];
    let column_direction = [orientation[3], orientation[4], orientation[5]];
    let normal = cross(row_direction, column_direction);
    let pixel_spacing_mm = match first.pixel_spacing_mm {
        Some([between_rows, between_columns]) => [between_columns, between_rows],
        None => {
            warnings.push(match first.zero_pixel_spacing {
                Some([a, b]) => format!("PixelSpacing is {a} \\ {b} mm (0 means unknown): assuming 1 mm square pixels"),
                None => "PixelSpacing is missing: assuming 1 mm square pixels".into(),
            });
            [1.0, 1.0]
        }
    };
    let single_slice_spacing_mm = first.slice_thickness_mm.unwrap_or(1.0);
    let project = |header: &SliceHeader| {
        if unplaced_frames {
            return [0.0, 0.0, f64::from(header.frame) * frame_spacing_mm];
        }
        let p = header.position_mm.unwrap_or([0.0; 3]);
        [dot(p, row_direction), dot(p, column_direction), dot(p, normal)]
    };
    let mut placed: Vec<([f64; 3], SliceHeader)> = headers.into_iter().map(|h| (project(&h), h)).collect();
    placed.sort_by(|a, b| a.0[2].total_cmp(&b.0[2]).then_with(|| a.1.path.cmp(&b.1.path)));

    let duplicate_mm = DUPLICATE_TOLERANCE_PIXELS * pixel_spacing_mm[0].min(pixel_spacing_mm[1]);
    let mut kept: Vec<([f64; 3], SliceHeader)> = Vec::with_capacity(placed.len());
    for (position, header) in placed {
        if let Some((previous_position, previous)) = kept.last()
            && (position[2] - previous_position[2]).abs() <= duplicate_mm
        {
            if !header.sop_instance_uid.is_empty() && header.sop_instance_uid == previous.sop_instance_uid {
                warnings.push(format!(
                    "{} repeats the image {} (same SOPInstanceUID): skipped",
                    header.path.display(),
                    previous.path.display()
                ));
                continue;
            }
            return Err(VolumeError::Dicom {
                problem: format!(
                    "two different images lie at {:.3} mm along the slice normal ({} and this file); \
                     the series holds several phases or acquisitions and is not one volume",
                    position[2],
                    previous.path.display()
                ),
                path: header.path.clone(),
            });
        }
        kept.push((position, header));
    }
    let (first_pixel_mm, ordered): (Vec<[f64; 3]>, Vec<SliceHeader>) = kept.into_iter().unzip();
    let geometry = StackGeometry {
        rows: ordered[0].rows,
        columns: ordered[0].columns,
        pixel_spacing_mm,
        first_pixel_mm,
        single_slice_spacing_mm,
        unplaced: unplaced_frames,
    };
    Ok((ordered, geometry))
}

/// One series, one image size, one pixel spacing, one orientation.
fn check_consistent(first: &SliceHeader, other: &SliceHeader) -> Result<(), VolumeError> {
    let mismatch = |what: &str, here: String, there: String| VolumeError::Dicom {
        problem: format!("{what} {here} differs from {there} in {} of the same series", first.path.display()),
        path: other.path.clone(),
    };
    if (other.columns, other.rows) != (first.columns, first.rows) {
        return Err(mismatch(
            "image size (columns x rows)",
            format!("{}x{}", other.columns, other.rows),
            format!("{}x{}", first.columns, first.rows),
        ));
    }
    let spacing_agrees = match (first.pixel_spacing_mm, other.pixel_spacing_mm) {
        (Some(a), Some(b)) => a.iter().zip(&b).all(|(a, b)| (a - b).abs() <= 1e-4 * a.abs()),
        (None, None) => true,
        _ => false,
    };
    if !spacing_agrees {
        return Err(mismatch(
            "PixelSpacing",
            format!("{:?}", other.pixel_spacing_mm),
            format!("{:?}", first.pixel_spacing_mm),
        ));
    }
    let orientation_agrees = match (first.orientation, other.orientation) {
        (Some(a), Some(b)) => a.iter().zip(&b).all(|(a, b)| (a - b).abs() <= 1e-4),
        (None, None) => true,
        _ => false,
    };
    if !orientation_agrees {
        return Err(mismatch(
            "ImageOrientationPatient",
            format!("{:?}", other.orientation),
            format!("{:?}", first.orientation),
        ));
    }
    Ok(())
}

fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let middle = sorted.len() / 2;
    if sorted.len() % 2 == 0 { 0.5 * (sorted[middle - 1] + sorted[middle]) } else { sorted[middle] }
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stack_at(normal_positions_mm: &[f64]) -> StackGeometry {
        StackGeometry {
            rows: 2,
            columns: 2,
            pixel_spacing_mm: [1.0, 1.0],
            first_pixel_mm: normal_positions_mm.iter().map(|w| [0.0, 0.0, *w]).collect(),
            single_slice_spacing_mm: 1.0,
            unplaced: false,
        }
    }

    fn missing_after(normal_positions_mm: &[f64]) -> Vec<usize> {
        stack_at(normal_positions_mm).missing_slices().iter().map(|m| m.after).collect()
    }

    #[test]
    fn a_doubled_or_tripled_gap_is_a_missing_slice_and_uneven_spacing_is_not() {
        assert_eq!(missing_after(&[0.0, 5.0, 10.0, 20.0, 25.0, 30.0]), [2]);
        assert_eq!(missing_after(&[0.0, 5.0, 20.0, 25.0, 30.0]), [1]);
        assert!(missing_after(&[0.0, 5.0, 10.0, 15.0]).is_empty());
        assert!(missing_after(&[0.0, 5.0]).is_empty());
        // The GE head: thirteen 4.00 mm gaps, one 1.08 mm, thirteen 7.00 mm.
        let mut ge = vec![0.0];
        for gap in std::iter::repeat_n(4.0, 13).chain([1.08]).chain(std::iter::repeat_n(7.0, 13)) {
            ge.push(ge[ge.len() - 1] + gap);
        }
        assert!(missing_after(&ge).is_empty());
        // A slice lost in its 7 mm part leaves 14 mm, found by the local spacing.
        ge.remove(22);
        assert_eq!(missing_after(&ge), [21]);
        let described = stack_at(&[0.0, 5.0, 15.0, 20.0]).missing_slices()[0].describe();
        assert_eq!(described, "the 10.00 mm gap between slices 2 and 3 is 2.0 times the series' 5.00 mm spacing");
    }
}
