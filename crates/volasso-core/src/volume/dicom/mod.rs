//! DICOM series to a [`Volume`] in physical units (Hounsfield units for CT);
//! `interfaces.md` (inputs: "a DICOM series (a folder, or a DICOMDIR)").
//!
//! Entry points: [`read_series`], or [`list_source`] then [`read_source`] (the import cache
//! keys the listing's files, so the two read the same). A *series* is the image files sharing
//! one SeriesInstanceUID. The path may be
//! * a folder: scanned recursively, symbolic links followed (`series.rs`); files without the
//!   `DICM` preamble are skipped quietly (counted in a debug log), DICOM files without an
//!   image (DICOMDIR, reports) are skipped, and a DICOM file that cannot be parsed is a
//!   possible missing slice (which series it belonged to is unknowable; see below);
//! * a DICOMDIR: its folder is scanned as above. The directory records are not followed: every
//!   file they list lies under that folder, and scanning also finds files whose names differ
//!   in case from the records, as happens on copied CDs;
//! * any other DICOM file: a one-slice volume.
//!
//! Choosing (`series.rs`): with [`DicomOptions::series_uid`] unset, several readable image
//! series are an error listing each (UID, description, slice count); nothing is picked
//! silently. Series this reader cannot decode (colour, a transfer syntax without a decoder,
//! multi-frame without per-frame positions) are skipped with a warning when exactly one
//! readable series remains, and are the error when none does. [`list_series`] lists them all
//! (for a series picker) without reading pixel data.
//!
//! Pixel data (`pixels.rs`): native, deflated (`deflated.rs`), and the compressed syntaxes
//! whose decoders dicom-rs's transfer syntax registry holds in this build: JPEG baseline,
//! extended and lossless, JPEG-LS, JPEG 2000 and RLE ([`readable_transfer_syntax`]), 12-bit
//! lossy JPEG through libjpeg-turbo (`jpeg12.rs`). Values are rescaled, or mapped through the
//! file's Modality LUT (`modality_lut.rs`), as a viewer shows them. Attributes stored with VR UN
//! are read in their dictionary VR (`unknown_vr.rs`). An enhanced multi-frame CT or MR file
//! gives one slice per frame (`frames.rs`); one stripped of its functional groups, its frames
//! stacked in file order with a warning (`geometry.rs`).
//!
//! Geometry (`geometry.rs`): slices are ordered along the slice normal; a regular stack (even
//! gaps within 1 %, no in-plane shift) is copied as it is, an irregular one (gantry tilt,
//! uneven gaps) is resampled onto a regular grid with a warning (`resample.rs`), or refused
//! with [`Resample::Refuse`]. Volume axes: x along the image rows (ImageOrientationPatient's
//! row cosines), y down the columns, z along their cross product. A resampled grid starts at
//! the first slice and the smallest in-plane position of any slice's first pixel. The volume's
//! patient orientation records these axes and that origin in LPS ([`super::orientation`]).
//!
//! Missing slices: a series is refused with [`VolumeError::SeriesGap`] when a slice may be
//! missing: a gap with room for a slice (`geometry`'s rule: at least 1.9 times the series'
//! spacing), a slice whose pixels cannot be decoded, a DICOM file that cannot be read, or a
//! folder that cannot be searched. With [`DicomOptions::allow_gaps`] it is opened anyway,
//! resampled across the hole, and the warnings (which the volume carries) say why.
//!
//! Every file is read through `bounds`: its element lengths are checked against its size
//! before dicom-object parses it, and a slice's PixelData must be exactly as long as its
//! Rows, Columns and BitsAllocated need (`pixels`).
//!
//! Never: reads colour images or multi-frame images whose frames it cannot place (other than
//! the frames of one enhanced CT or MR file, see above), shows stored values where the file
//! maps them (a Modality LUT it cannot apply is an error), or writes files (the import cache is
//! the caller's).

mod bounds;
mod codestream;
mod deflated;
mod frames;
mod geometry;
mod header;
mod jpeg12;
mod listing;
#[cfg(test)]
mod missing_tests;
mod modality_lut;
mod pixels;
#[cfg(test)]
mod real_data_tests;
mod resample;
mod series;
#[cfg(test)]
mod synthetic;
#[cfg(test)]
mod tests;
mod unknown_vr;

use super::limits::{self, ReadLimits};
use super::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType, orientation};
use geometry::StackGeometry;
pub use header::readable_transfer_syntax;
use header::{FileKind, SliceHeader};
pub use listing::{InstanceIdentity, PatientIdentity, PatientShown, SeriesSummary, list_series, read_identity};
use pixels::DecodedSlice;
use rayon::prelude::*;
pub use series::{DicomSource, MOST_FOLDER_DEPTH, list_source};
use series::{FoundImages, choose_series, read_folder_headers};
use std::path::{Path, PathBuf};

/// Whether an irregular series may be resampled onto a regular grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resample {
    /// Resample tilted or unevenly spaced series, with a warning saying so.
    #[default]
    Auto,
    /// Refuse such series with an error naming the tilt and gaps.
    Refuse,
}

/// How to read a DICOM series: which one, and what to do with irregular slice spacing.
#[derive(Clone, Debug, Default)]
pub struct DicomOptions {
    /// The SeriesInstanceUID to read when the path holds several image series.
    pub series_uid: Option<String>,
    /// What to do with a tilted gantry or uneven slice spacing.
    pub resample: Resample,
    /// Slice spacing of a resampled grid; regular series keep their own spacing.
    pub slice_spacing_mm: Option<f64>,
    /// Open a series with a missing or unreadable slice (resampled across the hole, with a
    /// warning); without it such a series is refused (`--allow-gaps`).
    pub allow_gaps: bool,
}

/// A series read into memory.
#[derive(Debug)]
pub struct DicomImport {
    /// Owned bytes: `VoxelType::I16` when every rescaled value is an integer in i16 range
    /// (typical CT), else `F32` (always for resampled series).
    pub volume: Volume,
    /// What was tolerated or changed (resampling, skipped files), one sentence each.
    pub warnings: Vec<String>,
    /// SeriesInstanceUID of the series read.
    pub series_uid: String,
    /// SeriesDescription, empty when absent.
    pub description: String,
    /// The files used, in slice order.
    pub files: Vec<PathBuf>,
}

/// Reads one DICOM series (see the module doc for what `path` may be) with the default limits.
pub fn read_series(path: &Path, options: &DicomOptions) -> Result<DicomImport, VolumeError> {
    let limits = ReadLimits::default();
    read_source(path, &list_source(path, &limits)?, options, &limits)
}

/// A series checked exactly as [`read_source`] reads it (every slice decoded, gaps and
/// geometry checked), without keeping its voxels: memory stays at a few slices whatever the
/// series' length.
#[derive(Debug)]
pub struct SeriesCheck {
    /// The dimensions the volume would have.
    pub dims: [usize; 3],
    /// What reading it would tolerate or change, one sentence each.
    pub warnings: Vec<String>,
    /// SeriesInstanceUID of the series checked.
    pub series_uid: String,
    /// SeriesDescription, empty when absent.
    pub description: String,
    /// Modality of the series' first slice, empty when absent.
    pub modality: String,
    /// The files used, in slice order, each once.
    pub files: Vec<PathBuf>,
}

/// Reads one DICOM series from the files `source` lists for `path` (see [`list_source`]).
pub fn read_source(
    path: &Path,
    source: &DicomSource,
    options: &DicomOptions,
    limits: &ReadLimits,
) -> Result<DicomImport, VolumeError> {
    let (volume, check) = assemble(path, source, options, limits, true)?;
    let volume =
        volume.ok_or_else(|| VolumeError::Dicom { problem: "no volume assembled".into(), path: path.to_path_buf() })?;
    let SeriesCheck { warnings, series_uid, description, files, .. } = check;
    Ok(DicomImport { volume, warnings, series_uid, description, files })
}

/// Checks one DICOM series as [`read_source`] would read it (see [`SeriesCheck`]).
pub fn check_source(
    path: &Path,
    source: &DicomSource,
    options: &DicomOptions,
    limits: &ReadLimits,
) -> Result<SeriesCheck, VolumeError> {
    Ok(assemble(path, source, options, limits, false)?.1)
}

/// Reads or checks a series: with `keep_values` the volume is built, else only its size.
fn assemble(
    path: &Path,
    source: &DicomSource,
    options: &DicomOptions,
    limits: &ReadLimits,
    keep_values: bool,
) -> Result<(Option<Volume>, SeriesCheck), VolumeError> {
    let mut warnings = Vec::new();
    // Why a slice may be missing: files or folders that could not be read, undecodable
    // slices, gaps with room for a slice.
    let mut holes: Vec<String> = source.unlisted.iter().map(|what| format!("{what} could not be searched")).collect();
    let found = match (&source.folder, source.files.as_slice()) {
        (Some(folder), files) => read_folder_headers(files, folder, path, limits)?,
        (None, [file]) => match header::read_header(file, limits)? {
            FileKind::Image(headers) => {
                FoundImages { readable: headers, unsupported: Vec::new(), unreadable: Vec::new() }
            }
            FileKind::Unsupported { error, .. } => return Err(error),
            FileKind::NotImage => {
                return Err(VolumeError::Dicom {
                    problem: "the file holds no image (no Rows/Columns)".into(),
                    path: path.to_path_buf(),
                });
            }
        },
        (None, _) => {
            return Err(VolumeError::Dicom { problem: "no DICOM file to read".into(), path: path.to_path_buf() });
        }
    };
    holes.extend(found.unreadable.iter().map(|error| format!("a DICOM file cannot be read ({error})")));
    let (series_uid, headers) =
        choose_series(FoundImages { unreadable: Vec::new(), ..found }, options, path, &mut warnings)?;
    let description = headers[0].series_description.clone();
    let modality = headers[0].modality.clone();
    let (headers, geometry) = geometry::order_slices(headers, &mut warnings)?;
    let plane = (geometry.rows as u64) * (geometry.columns as u64);
    bounds::check_decoded_voxels(plane.saturating_mul(2 * headers.len() as u64), VoxelType::F32, limits, path)?;
    let decoded = decode_slices(&headers, limits, keep_values);
    let keep: Vec<bool> = decoded.iter().map(Result::is_ok).collect();
    let notes: Vec<(&Path, &str)> = headers
        .iter()
        .zip(&decoded)
        .filter_map(|(header, slice)| match slice {
            Ok(DecodedSlice { note: Some(note), .. }) => Some((header.path.as_path(), note.as_str())),
            _ => None,
        })
        .collect();
    if let Some((file, note)) = notes.first() {
        let others = match notes.len() {
            1 => String::new(),
            count => format!(" (and {} more files)", count - 1),
        };
        warnings.push(format!("{}: {note}{others}", file.display()));
    }
    let mut slices = Vec::with_capacity(decoded.len());
    // A file that cannot be decoded is one hole however many frames it holds (its frames share
    // one error); the first error of each such file.
    let mut failed: Vec<(PathBuf, VolumeError)> = Vec::new();
    for (header, result) in headers.iter().zip(decoded) {
        match result {
            Ok(slice) => slices.push(slice),
            Err(error) if headers.len() == 1 => return Err(error),
            Err(error) => {
                if !failed.iter().any(|(file, _)| *file == header.path) {
                    holes.push(format!("slice {} cannot be decoded ({error})", header.path.display()));
                    failed.push((header.path.clone(), error));
                }
            }
        }
    }
    if slices.is_empty() {
        // One file (a multi-frame one) and nothing else wrong: its own error.
        if let ([(_, _)], 1) = (failed.as_slice(), holes.len())
            && let Some((_, error)) = failed.pop()
        {
            return Err(error);
        }
        return Err(VolumeError::SeriesGap { problem: summarise(&holes), path: path.to_path_buf() });
    }
    let geometry = geometry.keeping(&keep);
    let headers: Vec<SliceHeader> = headers.into_iter().zip(&keep).filter(|(_, k)| **k).map(|(h, _)| h).collect();
    holes.extend(geometry.missing_slices().iter().map(|missing| missing.describe()));
    if !holes.is_empty() {
        let summary = summarise(&holes);
        if !options.allow_gaps {
            return Err(VolumeError::SeriesGap { problem: summary, path: path.to_path_buf() });
        }
        warnings.push(format!("opened with a missing slice (--allow-gaps): {summary}"));
    }
    let regularity = geometry.regularity();
    if !regularity.is_regular() && options.resample == Resample::Refuse {
        return Err(VolumeError::Dicom {
            problem: format!(
                "{} across {} slices: they do not form a regular grid, and resampling onto one was refused \
                 (run without --no-resample to resample it)",
                regularity.describe(),
                geometry.slice_count()
            ),
            path: path.to_path_buf(),
        });
    }
    let mut seen = std::collections::HashSet::new();
    let files: Vec<PathBuf> = headers.iter().filter(|h| seen.insert(&h.path)).map(|h| h.path.clone()).collect();
    let mut check = SeriesCheck { dims: [0; 3], warnings: Vec::new(), series_uid, description, modality, files };
    let volume = if regularity.is_regular() {
        check.dims = [geometry.columns, geometry.rows, geometry.slice_count()];
        if keep_values {
            let mut volume = stack_slices(&slices, &geometry, &headers, path)?;
            volume.orientation = if geometry.unplaced { None } else { series_orientation(&headers[0], None, path) };
            Some(volume)
        } else {
            None
        }
    } else {
        let (volume, grid) = if keep_values {
            let (mut volume, grid) = resample_slices(&slices, &geometry, options, limits, path)?;
            volume.orientation = series_orientation(&headers[0], Some(grid.origin_mm), path);
            (Some(volume), grid)
        } else {
            (None, resample_grid(&geometry, options, path)?)
        };
        check.dims = grid.dims;
        warnings.push(format!(
            "{}: resampled onto {:.3} x {:.3} x {:.3} mm ({} x {} x {} voxels) along the image rows, columns and slice normal",
            regularity.describe(),
            grid.spacing_mm[0],
            grid.spacing_mm[1],
            grid.spacing_mm[2],
            grid.dims[0],
            grid.dims[1],
            grid.dims[2],
        ));
        volume
    };
    check.warnings = warnings;
    Ok((volume, check))
}

/// Decodes every slice, each file once (all its frames together), files in parallel; the
/// results are in the order of `headers`. Every frame of a file that fails gets its error.
/// Without `keep_values` each slice keeps only its range (its values are dropped at once).
fn decode_slices(
    headers: &[SliceHeader],
    limits: &ReadLimits,
    keep_values: bool,
) -> Vec<Result<DecodedSlice, VolumeError>> {
    let mut by_file: std::collections::BTreeMap<&Path, Vec<usize>> = std::collections::BTreeMap::new();
    for (index, header) in headers.iter().enumerate() {
        by_file.entry(header.path.as_path()).or_default().push(index);
    }
    let files: Vec<(&Path, Vec<usize>)> = by_file.into_iter().collect();
    type FileSlices = (Vec<usize>, Result<Vec<DecodedSlice>, VolumeError>);
    let decoded: Vec<FileSlices> = files
        .into_par_iter()
        .map(|(_, indices)| {
            let frames: Vec<&SliceHeader> = indices.iter().map(|&index| &headers[index]).collect();
            let mut result = pixels::read_frames(&frames, limits);
            if !keep_values && let Ok(slices) = &mut result {
                slices.iter_mut().for_each(|slice| slice.values = Vec::new());
            }
            (indices, result)
        })
        .collect();
    let mut slices: Vec<Option<Result<DecodedSlice, VolumeError>>> = headers.iter().map(|_| None).collect();
    for (indices, result) in decoded {
        match result {
            Ok(frames) => {
                for (index, slice) in indices.into_iter().zip(frames) {
                    slices[index] = Some(Ok(slice));
                }
            }
            Err(error) => {
                let problem = error.to_string();
                let mut error = Some(error);
                for index in indices {
                    slices[index] = Some(Err(error.take().unwrap_or_else(|| VolumeError::Dicom {
                        problem: problem.clone(),
                        path: headers[index].path.clone(),
                    })));
                }
            }
        }
    }
    slices
        .into_iter()
        .zip(headers)
        .map(|(slice, header)| {
            slice.unwrap_or_else(|| Err(VolumeError::MissingField { field: "PixelData", path: header.path.clone() }))
        })
        .collect()
}

/// The first three reasons, and how many more.
fn summarise(reasons: &[String]) -> String {
    let mut summary = reasons.iter().take(3).cloned().collect::<Vec<_>>().join("; ");
    if reasons.len() > 3 {
        summary.push_str(&format!("; and {} more", reasons.len() - 3));
    }
    summary
}

/// True for a folder holding DICOM files (looked for in its first few hundred entries,
/// recursively), a DICOMDIR, or a file with the `DICM` preamble.
pub fn looks_like_dicom(path: &Path) -> bool {
    if path.is_dir() {
        let mut found = false;
        let mut budget = 256usize;
        series::walk_files(path, &mut |file| {
            budget = budget.saturating_sub(1);
            found = series::is_dicomdir_name(file) || series::has_dicm_preamble(file);
            !found && budget > 0
        });
        found
    } else {
        series::is_dicomdir_name(path) || series::has_dicm_preamble(path)
    }
}

/// The series' patient orientation: x along the rows, y down the columns, z along the normal
/// (see the module doc). Voxel (0, 0, 0) is the first slice's first pixel, or for a resampled
/// grid the point `grid_origin` = (u, v, w) on those three directions.
fn series_orientation(
    first: &SliceHeader,
    grid_origin: Option<[f64; 3]>,
    path: &Path,
) -> Option<orientation::PatientOrientation> {
    let cosines = first.orientation?;
    let Some(uvw) = grid_origin else {
        return orientation::from_dicom(cosines, first.position_mm, path);
    };
    let frame = orientation::from_dicom(cosines, None, path)?;
    let origin = (0..3).fold([0.0; 3], |sum: [f64; 3], axis| {
        let direction = frame.axis_direction_lps(axis);
        std::array::from_fn(|c| sum[c] + uvw[axis] * direction[c])
    });
    orientation::from_dicom(cosines, Some(origin), path)
}

/// A regular stack: the slices as they are, spaced by their mean gap.
fn stack_slices(
    slices: &[DecodedSlice],
    geometry: &StackGeometry,
    headers: &[SliceHeader],
    source: &Path,
) -> Result<Volume, VolumeError> {
    let count = geometry.slice_count();
    let spacing_z_mm = if count > 1 {
        (geometry.first_pixel_mm[count - 1][2] - geometry.first_pixel_mm[0][2]) / (count - 1) as f64
    } else {
        geometry.single_slice_spacing_mm
    };
    let dims = [geometry.columns, geometry.rows, count];
    let spacing_mm = [geometry.pixel_spacing_mm[0], geometry.pixel_spacing_mm[1], spacing_z_mm];
    let integral_rescale = headers.iter().all(|h| h.rescale.slope.fract() == 0.0 && h.rescale.intercept.fract() == 0.0);
    let fits_i16 = slices.iter().all(|s| s.min >= f32::from(i16::MIN) && s.max <= f32::from(i16::MAX));
    if integral_rescale && fits_i16 {
        // Integer samples times an integer slope plus an integer intercept: the f32 values
        // are exact integers, so the cast loses nothing.
        let mut bytes = limits::zeroed(dims[0] * dims[1] * count * 2, source)?;
        bytes.par_chunks_mut(dims[0] * dims[1] * 2).zip(slices).for_each(|(out, slice)| {
            for (pair, value) in out.chunks_exact_mut(2).zip(&slice.values) {
                pair.copy_from_slice(&(*value as i16).to_le_bytes());
            }
        });
        return Volume::new(
            dims,
            spacing_mm,
            VoxelType::I16,
            ByteOrder::Little,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(bytes),
            source,
        );
    }
    let planes: Vec<&[f32]> = slices.iter().map(|s| s.values.as_slice()).collect();
    float_volume(dims, spacing_mm, &planes, source)
}

/// A `float32` volume from planes of values (x fastest), converted to bytes in parallel.
fn float_volume(
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    planes: &[&[f32]],
    source: &Path,
) -> Result<Volume, VolumeError> {
    let plane_bytes = dims[0] * dims[1] * 4;
    let mut bytes = limits::zeroed(plane_bytes * planes.len(), source)?;
    bytes.par_chunks_mut(plane_bytes).zip(planes).for_each(|(out, plane)| {
        for (quad, value) in out.chunks_exact_mut(4).zip(plane.iter()) {
            quad.copy_from_slice(&value.to_le_bytes());
        }
    });
    Volume::new(
        dims,
        spacing_mm,
        VoxelType::F32,
        ByteOrder::Little,
        ValueScale::IDENTITY,
        VoxelBytes::Owned(bytes),
        source,
    )
}

/// The regular grid an irregular stack is resampled onto.
fn resample_grid(
    geometry: &StackGeometry,
    options: &DicomOptions,
    source: &Path,
) -> Result<resample::ResampleGrid, VolumeError> {
    let (slice_spacing_mm, exact_span) = match options.slice_spacing_mm {
        Some(spacing) => (spacing, false),
        None => (geometry.automatic_slice_spacing_mm(), true),
    };
    resample::plan_grid(geometry, slice_spacing_mm, exact_span, source)
}

/// An irregular stack, resampled; returns the volume and the grid it was sampled on.
fn resample_slices(
    slices: &[DecodedSlice],
    geometry: &StackGeometry,
    options: &DicomOptions,
    limits: &ReadLimits,
    source: &Path,
) -> Result<(Volume, resample::ResampleGrid), VolumeError> {
    let grid = resample_grid(geometry, options, source)?;
    let voxels = grid.dims.iter().fold(1u64, |n, &d| n.saturating_mul(d as u64));
    bounds::check_decoded_voxels(voxels, VoxelType::F32, limits, source)?;
    let pad = slices.iter().map(|s| s.min).fold(f32::INFINITY, f32::min);
    let bytes = resample::resample(slices, geometry, &grid, pad, source)?;
    let volume = Volume::new(
        grid.dims,
        grid.spacing_mm,
        VoxelType::F32,
        ByteOrder::Little,
        ValueScale::IDENTITY,
        VoxelBytes::Owned(bytes),
        source,
    )?;
    Ok((volume, grid))
}
