//! Opening any supported volume: picks the reader from the path (folder, extension, magic
//! bytes) and routes decoded data through the import [`cache`].
//!
//! Entry point: [`open`]. Formats (`interfaces.md`): NRRD (`.nrrd`, `.nhdr`), MetaImage
//! (`.mha`, `.mhd`), NIfTI-1 (`.nii`, `.hdr`, `.nii.gz`), DICOM (a folder, a DICOMDIR, a
//! file), Open SciVis raw (`name_XxYxZ_type.raw`), any raw file with explicit dims and type.
//!
//! Every reader works within [`OpenOptions::limits`] ([`super::limits`]); a detached data file
//! is checked before the cache is consulted, and the cache key covers exactly the files the
//! reader reads (the header and its data file, or the DICOM listing).
//!
//! Never: opens anything but a regular file or a folder.

use super::dicom::{self, DicomOptions};
use super::limits::{self, ReadLimits};
use super::{Volume, VolumeError, cache, metaimage, nifti, nrrd, raw};
use std::path::{Path, PathBuf};

/// How to open a volume; the default opens any self-describing file.
#[derive(Clone, Debug, Default)]
pub struct OpenOptions {
    /// Treat the file as headerless raw data with these dimensions (requires `voxel_type`).
    pub dims: Option<[usize; 3]>,
    /// Treat the file as headerless raw data of this voxel type (requires `dims`).
    pub voxel_type: Option<super::VoxelType>,
    /// Overrides the spacing from the file (raw files have none: 1 mm is assumed).
    pub spacing_mm: Option<[f64; 3]>,
    /// How to read a DICOM series.
    pub dicom: DicomOptions,
    /// Where imports are cached; `None` for [`cache::default_folder`].
    pub cache_dir: Option<PathBuf>,
    /// The most bytes a compressed or text encoding (or a DICOM series) may decode into
    /// memory; `None` for [`limits::default_max_decoded_bytes`] (the smallest of 16 GiB, the
    /// machine's memory and the process's cgroup limit).
    pub max_decoded_bytes: Option<u64>,
    /// Read detached data files outside their header's folder (`--allow-external-data`).
    pub allow_external_data: bool,
}

impl OpenOptions {
    /// The limits readers work within.
    pub fn limits(&self) -> ReadLimits {
        ReadLimits {
            max_decoded_bytes: self.max_decoded_bytes.unwrap_or_else(limits::default_max_decoded_bytes),
            allow_external_data: self.allow_external_data,
        }
    }
}

/// The formats [`open`] tells apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// NRRD (`.nrrd`, `.nhdr`).
    Nrrd,
    /// MetaImage (`.mha`, `.mhd`).
    MetaImage,
    /// NIfTI-1 (`.nii`, `.nii.gz`, `.hdr`/`.img`).
    Nifti,
    /// A DICOM file or a folder holding a DICOM series.
    Dicom,
    /// Headerless raw voxels, named `name_XxYxZ_type.raw` or given dimensions and type.
    Raw,
}

/// Opens the volume at `path`.
pub fn open(path: &Path, options: &OpenOptions) -> Result<Volume, VolumeError> {
    if let Some(spacing) = options.spacing_mm {
        super::check_spacing(spacing, path)?;
    }
    let format = detect_format(path, options)?;
    log::debug!("{}: opening as {format:?}", path.display());
    let cache_dir = options.cache_dir.clone().unwrap_or_else(cache::default_folder);
    let limits = options.limits();
    let mut volume = match format {
        Format::Raw => {
            let naming = match (options.dims, options.voxel_type) {
                (Some(dims), Some(voxel_type)) => raw::RawNaming { dims, voxel_type },
                (Some(_), None) | (None, Some(_)) => {
                    return Err(VolumeError::UnknownFormat {
                        hint: "a raw file needs both --dims and --type".into(),
                        path: path.to_path_buf(),
                    });
                }
                (None, None) => {
                    file_name(path).as_deref().and_then(raw::parse_name).ok_or_else(|| VolumeError::UnknownFormat {
                        hint: "a raw file needs a name like name_256x256x128_uint8.raw, or --dims X,Y,Z --type T"
                            .into(),
                        path: path.to_path_buf(),
                    })?
                }
            };
            if options.spacing_mm.is_none() {
                log::warn!("{}: raw files carry no spacing; assuming 1 x 1 x 1 mm (pass --spacing)", path.display());
            }
            raw::read(path, naming, options.spacing_mm.unwrap_or([1.0; 3]))?
        }
        Format::Nrrd => {
            let header = nrrd::parse_header(&limits::read_head(path, 1 << 16)?, path)?;
            // The data file is resolved (and checked) here, before any cache lookup.
            let data = nrrd::data_path(path, &header, &limits)?;
            if header.encoding == nrrd::NrrdEncoding::Gzip {
                let files = source_files(path, &data);
                cache::open_or_import(&cache_dir, &files, "nrrd", path, || {
                    nrrd::read_with(path, &limits).map(|r| with_warnings(r.volume))
                })?
            } else {
                nrrd::read_with(path, &limits)?.volume
            }
        }
        Format::MetaImage => {
            let header = metaimage::parse_header(&limits::read_head(path, 1 << 16)?, path)?;
            let data = match &header.data_file {
                Some(name) => limits::detached_data_file(path, name, &limits)?,
                None => path.to_path_buf(),
            };
            if header.compressed {
                let files = source_files(path, &data);
                cache::open_or_import(&cache_dir, &files, "metaimage", path, || {
                    metaimage::read_with(path, &limits).map(|r| with_warnings(r.volume))
                })?
            } else {
                metaimage::read_with(path, &limits)?.volume
            }
        }
        Format::Nifti => {
            if nifti::is_gzip(path)? {
                cache::open_or_import(&cache_dir, &[path.to_path_buf()], "nifti", path, || {
                    nifti::read_with(path, &limits).map(|r| with_warnings(r.volume))
                })?
            } else {
                nifti::read_with(path, &limits)?.volume
            }
        }
        Format::Dicom => open_dicom(path, &options.dicom, &limits, &cache_dir)?,
    };
    if let Some(spacing) = options.spacing_mm {
        volume.spacing_mm = spacing;
    }
    Ok(volume)
}

/// A volume and its reader's warnings, as the cache keeps them beside the entry.
fn with_warnings(mut volume: Volume) -> (Volume, Vec<String>) {
    let warnings = std::mem::take(&mut volume.warnings);
    (volume, warnings)
}

/// The header and, when it is another file, the data file.
fn source_files(header: &Path, data: &Path) -> Vec<PathBuf> {
    if data == header { vec![header.to_path_buf()] } else { vec![header.to_path_buf(), data.to_path_buf()] }
}

/// A DICOM series, imported through the cache. The key covers exactly the files the reader
/// reads (one listing, [`dicom::list_source`], serves both) and the options, so a hit skips
/// reading DICOM at all and a changed, added or removed file is a miss.
fn open_dicom(
    path: &Path,
    options: &DicomOptions,
    limits: &ReadLimits,
    cache_dir: &Path,
) -> Result<Volume, VolumeError> {
    let source = dicom::list_source(path, limits)?;
    let settings = format!(
        "dicom series={:?} resample={:?} spacing={:?} allow_gaps={} unlisted={:?}",
        options.series_uid, options.resample, options.slice_spacing_mm, options.allow_gaps, source.unlisted
    );
    cache::open_or_import(cache_dir, &source.files, &settings, path, || {
        let imported = dicom::read_source(path, &source, options, limits)?;
        Ok((imported.volume, imported.warnings))
    })
}

/// Decides the format from the options, the path and, failing those, the first bytes.
pub fn detect_format(path: &Path, options: &OpenOptions) -> Result<Format, VolumeError> {
    if options.dims.is_some() || options.voxel_type.is_some() {
        return Ok(Format::Raw);
    }
    let metadata = std::fs::metadata(path).map_err(|e| VolumeError::io(e, path))?;
    if metadata.is_dir() {
        return Ok(Format::Dicom);
    }
    if !metadata.is_file() {
        return Err(VolumeError::NotRegularFile { path: path.to_path_buf() });
    }
    let name = file_name(path).unwrap_or_default().to_ascii_lowercase();
    let by_extension = [
        (".nrrd", Format::Nrrd),
        (".nhdr", Format::Nrrd),
        (".mha", Format::MetaImage),
        (".mhd", Format::MetaImage),
        (".nii", Format::Nifti),
        (".nii.gz", Format::Nifti),
        (".hdr", Format::Nifti),
        (".dcm", Format::Dicom),
        (".raw", Format::Raw),
    ];
    if let Some((_, format)) = by_extension.iter().find(|(ext, _)| name.ends_with(ext)) {
        return Ok(*format);
    }
    if name == "dicomdir" {
        return Ok(Format::Dicom);
    }
    let head = limits::read_head(path, 352)?;
    if head.starts_with(b"NRRD000") {
        Ok(Format::Nrrd)
    } else if head.len() >= 132 && &head[128..132] == b"DICM" {
        Ok(Format::Dicom)
    } else if head.len() >= 348 && (head[0..4] == 348i32.to_le_bytes() || head[0..4] == 348i32.to_be_bytes()) {
        Ok(Format::Nifti)
    } else if head.starts_with(b"ObjectType") || head.starts_with(b"NDims") {
        Ok(Format::MetaImage)
    } else {
        Err(VolumeError::UnknownFormat {
            hint: "not NRRD, MetaImage, NIfTI-1, DICOM or a name_XxYxZ_type.raw file; for other raw data pass --dims and --type".into(),
            path: path.to_path_buf(),
        })
    }
}

fn file_name(path: &Path) -> Option<String> {
    path.file_name().map(|n| n.to_string_lossy().into_owned())
}
