//! Spatial coherence after classification: a voxel whose label disagrees with a face neighbour
//! takes its 3 x 3 x 3 neighbourhood's majority label, over [`DEFAULT_PASSES`] passes. The rule:
//! remove isolated wrong voxels and ragged borders, but not what the image says is one voxel thin.
//!
//! Bands: a voxel inside its own label's band ([`LabelBands`]) takes only a label its intensity
//! could be mixed from ([`PARTIAL_VOLUME_REACH`]), so a small structure far brighter or darker
//! than its surroundings is not voted away (`docs/decisions/0009-majority-filter.md`).
//!
//! Face anchor: a voxel with at least [`FACE_ANCHOR`] faces of its own label keeps it where its
//! band holds its intensity and the winner's does not, so the vote does not erase what is one
//! voxel thin: sulcal CSF, a nucleus's rim, a granule (`docs/decisions/0009-majority-filter.md`).
//!
//! Sandwich: an anchored voxel between two other labels on opposite faces, its intensity between
//! their band centres, is a partial-volume shell and follows the majority, so a shell around a
//! bone at a vessel's intensity does not stay a vessel (`docs/decisions/0009-majority-filter.md`).
//!
//! Thick slices: slices more than [`THICK_SLICE_RATIO`] times the pixel size apart vote each
//! within itself ([`Neighbourhood::Plane`]), so a layer one slice thick (a knee's joint space)
//! is not erased (`docs/decisions/0010-thick-slices.md`).
//!
//! Never: changes background voxels (label 0) or counts them as votes, so it never grows a
//! class into the air or erodes it there.

mod rows;

use rayon::prelude::*;
use rows::{ROW_COUNT_SHARE, classified_span, disagreeing_voxels, unflag_unbeatable, unopposed};

/// How far past its band a label reaches for a voxel to take it, as a share of the band's
/// width; at 0 the bands are too narrow for noise, and noisy voxels keep a wrong label
/// (`docs/decisions/0009-majority-filter.md`).
pub const PARTIAL_VOLUME_REACH: f32 = 0.5;

/// Face neighbours of its own label that anchor a voxel whose intensity speaks for its label;
/// at 2 the vote erases pairs of voxels such as a real brain's speckled sulcal CSF
/// (`docs/decisions/0009-majority-filter.md`).
pub const FACE_ANCHOR: usize = 1;

/// Each label's intensity band and each voxel's intensity, for the filter's band rules.
pub struct LabelBands<'a> {
    /// Per label (index = label), its band (low, high); `None`: any intensity.
    bands: Vec<Option<(f32, f32)>>,
    /// Per label, its band widened by [`PARTIAL_VOLUME_REACH`] on each side; `None` as above.
    widened: Vec<Option<(f32, f32)>>,
    /// The intensity of a voxel (index into the label volume).
    intensity: &'a (dyn Fn(usize) -> f32 + Sync),
}

impl<'a> LabelBands<'a> {
    /// Bands per label (index = label; `None`: any intensity) and the voxels' intensities.
    pub fn new(bands: Vec<Option<(f32, f32)>>, intensity: &'a (dyn Fn(usize) -> f32 + Sync)) -> LabelBands<'a> {
        let widened = bands
            .iter()
            .map(|band| {
                band.map(|(low, high)| {
                    let reach = PARTIAL_VOLUME_REACH * (high - low);
                    (low - reach, high + reach)
                })
            })
            .collect();
        LabelBands { bands, widened, intensity }
    }

    /// The band of `label`; `None`: any intensity.
    fn band(&self, label: u8) -> Option<(f32, f32)> {
        self.bands.get(label as usize).copied().flatten()
    }

    /// Whether the band of `label` holds `intensity` (a label without a band holds none).
    fn holds(&self, label: u8, intensity: f32) -> bool {
        self.band(label).is_some_and(|(low, high)| low <= intensity && intensity <= high)
    }

    /// Whether `voxel` of label `own` may take a label of `others` (the neighbourhood's labels but
    /// `own` and background): its intensity lies within their widened bands or outside its own.
    fn allows(&self, voxel: usize, own: u8, others: &[u8]) -> bool {
        let intensity = (self.intensity)(voxel);
        if !self.holds(own, intensity) {
            return true;
        }
        let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
        for &label in others {
            let Some((band_low, band_high)) = self.widened.get(label as usize).copied().flatten() else {
                return true;
            };
            low = low.min(band_low);
            high = high.max(band_high);
        }
        low <= intensity && intensity <= high
    }

    /// Whether an anchored voxel of label `own` may still take `best`: its intensity does not
    /// set the two apart, or lies between the band centres of two `sandwich` labels on opposite
    /// faces ([`sandwiching_labels`]).
    fn releases_anchored(&self, voxel: usize, own: u8, best: u8, sandwich: &[u8]) -> bool {
        let intensity = (self.intensity)(voxel);
        if !self.holds(own, intensity) || self.holds(best, intensity) {
            return true;
        }
        let (mut darker, mut brighter) = (false, false);
        for &label in sandwich {
            let Some((low, high)) = self.band(label) else {
                return true;
            };
            let centre = (low + high) / 2.0;
            darker |= centre <= intensity;
            brighter |= centre >= intensity;
        }
        darker && brighter
    }
}

/// Passes of the filter before the Potts sweeps ([`super::Coherence::Potts`]); with one, borders
/// the first pass changed stay ragged (`docs/decisions/0009-majority-filter.md`).
pub const DEFAULT_PASSES: usize = 2;

/// Which voxels around a voxel vote ([`majority_passes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Neighbourhood {
    /// Its 3 x 3 x 3 neighbourhood.
    Cube,
    /// Its 3 x 3 neighbourhood in its z plane, for thick slices ([`Neighbourhood::for_spacing`]).
    Plane,
}

/// The largest slice spacing, in in-plane voxel sizes, at which the planes above and below vote;
/// past it the cube erases layers one slice thick, such as a knee's joint space
/// (`docs/decisions/0010-thick-slices.md`).
pub const THICK_SLICE_RATIO: f64 = 3.5;

impl Neighbourhood {
    /// The neighbourhood for voxels of `spacing_mm` (x, y, z): [`Neighbourhood::Plane`] when
    /// the slices lie more than [`THICK_SLICE_RATIO`] times the larger in-plane voxel size apart.
    pub fn for_spacing(spacing_mm: [f64; 3]) -> Neighbourhood {
        let in_plane = spacing_mm[0].max(spacing_mm[1]);
        if spacing_mm[2] > THICK_SLICE_RATIO * in_plane { Neighbourhood::Plane } else { Neighbourhood::Cube }
    }

    /// Votes of its own label (itself included) that no other label can beat: 14 of 27, 5 of 9.
    fn unbeatable_votes(self) -> u8 {
        let voxels = match self {
            Neighbourhood::Cube => 27,
            Neighbourhood::Plane => 9,
        };
        voxels / 2 + 1
    }
}

/// `passes` passes, each on the labels the one before left; returns the voxels changed in all.
/// With `bands`, the band rules apply ([`LabelBands`]). A later pass visits only the planes a
/// change can reach, and the passes stop once one changes nothing.
pub fn majority_passes(
    labels: &mut [u8],
    dims: [usize; 3],
    passes: usize,
    bands: Option<&LabelBands>,
    neighbourhood: Neighbourhood,
) -> usize {
    let plane = dims[0] * dims[1];
    if plane == 0 {
        return 0;
    }
    let mut visit = vec![true; dims[2]];
    let mut changed = 0;
    for _ in 0..passes {
        let original: &[u8] = labels;
        let changes: Vec<Vec<(usize, u8)>> = (0..dims[2])
            .into_par_iter()
            .map(|z| if visit[z] { majority_plane(original, dims, z, bands, neighbourhood) } else { Vec::new() })
            .collect();
        visit.fill(false);
        let mut changed_here = 0;
        for (z, plane_changes) in changes.iter().enumerate() {
            for &(index, label) in plane_changes {
                labels[z * plane + index] = label;
            }
            if !plane_changes.is_empty() {
                match neighbourhood {
                    Neighbourhood::Cube => visit[z.saturating_sub(1)..(z + 2).min(dims[2])].fill(true),
                    Neighbourhood::Plane => visit[z] = true,
                }
            }
            changed_here += plane_changes.len();
        }
        changed += changed_here;
        if changed_here == 0 {
            break;
        }
    }
    changed
}

/// The changes of plane `z`: (index in the plane, new label).
fn majority_plane(
    original: &[u8],
    dims: [usize; 3],
    z: usize,
    bands: Option<&LabelBands>,
    neighbourhood: Neighbourhood,
) -> Vec<(usize, u8)> {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    let here = &original[z * plane..][..plane];
    let across = neighbourhood == Neighbourhood::Cube;
    let below = (across && z > 0).then(|| &original[(z - 1) * plane..][..plane]);
    let above = (across && z + 1 < size_z).then(|| &original[(z + 1) * plane..][..plane]);
    let unbeatable = neighbourhood.unbeatable_votes();
    let mut changes = Vec::new();
    let mut flags = vec![0u8; size_x];
    let mut votes = vec![0u8; size_x];
    for (y, row) in here.chunks_exact(size_x).enumerate() {
        // Only the span between the row's first and last classified voxel can hold a flagged one.
        let Some((first, last)) = classified_span(row) else {
            continue;
        };
        let span = first..last + 1;
        let start = y * size_x;
        let neighbours = [
            (y > 0).then(|| &here[start - size_x..start][span.clone()]),
            (y + 1 < size_y).then(|| &here[start + size_x..][..size_x][span.clone()]),
            below.map(|p| &p[start..][..size_x][span.clone()]),
            above.map(|p| &p[start..][..size_x][span.clone()]),
        ];
        let row_span = &row[span.clone()];
        if unopposed(row_span, row[first], neighbours) {
            // Nothing here disagrees with a face neighbour.
            continue;
        }
        let flags = &mut flags[..row_span.len()];
        disagreeing_voxels(row_span, neighbours, flags);
        let flagged: usize = flags.iter().map(|&flag| usize::from(flag)).sum();
        if flagged * ROW_COUNT_SHARE >= flags.len() {
            let rows_around = [below, Some(here), above].map(|neighbour_plane| {
                [y.checked_sub(1), Some(y), (y + 1 < size_y).then_some(y + 1)]
                    .map(|row_y| Some(&neighbour_plane?[row_y? * size_x..][..size_x]))
            });
            let votes = &mut votes[..row_span.len()];
            unflag_unbeatable(row, first, rows_around.as_flattened(), flags, votes, unbeatable);
        }
        // Few voxels of a row are flagged: skip eight unflagged ones at a time.
        for (chunk, eight) in flags.chunks(8).enumerate() {
            let mut bits = eight.iter().rev().fold(0u64, |bits, &flag| bits << 8 | u64::from(flag));
            while bits != 0 {
                let x = first + chunk * 8 + bits.trailing_zeros() as usize / 8;
                bits &= bits - 1;
                let own = row[x];
                let voxel = z * plane + start + x;
                let allowed = |others: &[u8], best: u8| {
                    bands.is_none_or(|bands| {
                        bands.allows(voxel, own, others) && {
                            let faces = face_labels(below, here, above, size_x, size_y, x, y);
                            own_faces(&faces, own) < FACE_ANCHOR || {
                                let (sandwich, count) = sandwiching_labels(&faces, own);
                                bands.releases_anchored(voxel, own, best, &sandwich[..count])
                            }
                        }
                    })
                };
                let best = neighbourhood_majority([below, Some(here), above], size_x, size_y, x, y, own, &allowed);
                if best != own {
                    changes.push((start + x, best));
                }
            }
        }
    }
    changes
}

/// One bit per position of `block` that holds `label` (a byte comparison that vectorises).
fn positions_of(block: &[u8; 32], label: u8) -> u32 {
    block.iter().enumerate().fold(0u32, |bits, (position, &held)| bits | u32::from(held == label) << position)
}

/// The labels of the six face neighbours of (x, y) (in `here`, `below`, `above`), in opposite
/// pairs: -x, +x, -y, +y, below, above; `None` outside the volume.
pub(super) fn face_labels(
    below: Option<&[u8]>,
    here: &[u8],
    above: Option<&[u8]>,
    size_x: usize,
    size_y: usize,
    x: usize,
    y: usize,
) -> [Option<u8>; 6] {
    let index = y * size_x + x;
    [
        (x > 0).then(|| here[index - 1]),
        (x + 1 < size_x).then(|| here[index + 1]),
        (y > 0).then(|| here[index - size_x]),
        (y + 1 < size_y).then(|| here[index + size_x]),
        below.map(|plane| plane[index]),
        above.map(|plane| plane[index]),
    ]
}

/// How many of the `faces` ([`face_labels`]) hold the voxel's own label `own`.
fn own_faces(faces: &[Option<u8>; 6], own: u8) -> usize {
    faces.iter().filter(|&&label| label == Some(own)).count()
}

/// The pairs of labels on opposite `faces` ([`face_labels`]) that differ and are neither `own`
/// nor background (a one-voxel shell's sides), up to three pairs, and the count filled in.
fn sandwiching_labels(faces: &[Option<u8>; 6], own: u8) -> ([u8; 6], usize) {
    let mut labels = [0u8; 6];
    let mut count = 0;
    for pair in faces.chunks_exact(2) {
        if let [Some(a), Some(b)] = *pair
            && a != b
            && ![a, b].iter().any(|&label| label == 0 || label == own)
        {
            labels[count] = a;
            labels[count + 1] = b;
            count += 2;
        }
    }
    (labels, count)
}

/// The non-zero label with the most votes around (x, y) over `planes`: `own` unless another has
/// strictly more and `allowed` (given the other labels, each once) admits the change.
#[allow(clippy::too_many_arguments)]
fn neighbourhood_majority(
    planes: [Option<&[u8]>; 3],
    size_x: usize,
    size_y: usize,
    x: usize,
    y: usize,
    own: u8,
    allowed: &dyn Fn(&[u8], u8) -> bool,
) -> u8 {
    // A fixed block, background (no vote) past its end, so the counts below never branch.
    let mut block = [0u8; 32];
    let mut filled = 0;
    if let ([Some(below), Some(here), Some(above)], true) =
        (planes, (1..size_x - 1).contains(&x) && (1..size_y - 1).contains(&y))
    {
        // Inside the volume (almost every voxel): nine rows of three.
        let first = (y - 1) * size_x + x - 1;
        for neighbour_plane in [below, here, above] {
            for row_start in [first, first + size_x, first + 2 * size_x] {
                block[filled..filled + 3].copy_from_slice(&neighbour_plane[row_start..row_start + 3]);
                filled += 3;
            }
        }
    } else {
        let (columns, rows) = (x.saturating_sub(1)..(x + 2).min(size_x), y.saturating_sub(1)..(y + 2).min(size_y));
        for neighbour_plane in planes.into_iter().flatten() {
            for ny in rows.clone() {
                for &label in &neighbour_plane[ny * size_x..][columns.clone()] {
                    block[filled] = label;
                    filled += 1;
                }
            }
        }
    }
    // Common case: at most one other label (the largest; the only one if it has every other vote).
    let (mut own_votes, mut voting, mut other) = (0u8, 0u8, 0u8);
    for &label in &block {
        own_votes += u8::from(label == own);
        voting += u8::from(label != 0);
        other = other.max(if label == own { 0 } else { label });
    }
    let other_votes: u8 = block.iter().map(|&label| u8::from(label == other) & u8::from(other != 0)).sum();
    if voting - own_votes == other_votes {
        return if other_votes > own_votes && allowed(&[other], other) { other } else { own };
    }
    // Several others: each one's votes from one comparison of the block (a histogram's stores
    // and loads would wait on each other).
    let (mut others, mut count) = ([0u8; 27], 0);
    let (mut best, mut best_votes) = (own, own_votes);
    let mut remaining = !positions_of(&block, 0) & !positions_of(&block, own);
    while remaining != 0 {
        let label = block[remaining.trailing_zeros() as usize];
        let positions = positions_of(&block, label);
        let votes = positions.count_ones() as u8;
        if votes > best_votes {
            (best, best_votes) = (label, votes);
        }
        others[count] = label;
        count += 1;
        remaining &= !positions;
    }
    if best != own && allowed(&others[..count], best) { best } else { own }
}

#[cfg(test)]
mod tests;
