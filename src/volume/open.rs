//! Opening any supported volume: picks the reader from the path (folder, extension, magic
//! bytes) and routes decoded data through the import [`cache`](super::cache).
//!
//! Entry point: [`open`]. Formats (`interfaces.md`): NRRD (`.nrrd`, `.nhdr`), MetaImage
//! (`.mha`, `.mhd`), NIfTI-1 (`.nii`, `.hdr`, `.nii.gz`), DICOM (a folder, a DICOMDIR, a
//! file), Open SciVis raw (`name_XxYxZ_type.raw`), any raw file with explicit dims and type.

use super::dicom::{self, DicomOptions};
use super::{Volume, VolumeError, cache, metaimage, nifti, nrrd, raw};
use std::io::Read;
use std::path::{Path, PathBuf};

/// How to open a volume; the default opens any self-describing file.
#[derive(Clone, Debug, Default)]
pub struct OpenOptions {
    /// Treat the file as headerless raw data with these dimensions (requires `voxel_type`).
    pub dims: Option<[usize; 3]>,
    pub voxel_type: Option<super::VoxelType>,
    /// Overrides the spacing from the file (raw files have none: 1 mm is assumed).
    pub spacing_mm: Option<[f64; 3]>,
    pub dicom: DicomOptions,
    /// Where imports are cached; `None` for [`cache::default_folder`].
    pub cache_dir: Option<PathBuf>,
}

/// The formats [`open`] tells apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Nrrd,
    MetaImage,
    Nifti,
    Dicom,
    Raw,
}

/// Opens the volume at `path`.
pub fn open(path: &Path, options: &OpenOptions) -> Result<Volume, VolumeError> {
    let format = detect_format(path, options)?;
    log::debug!("{}: opening as {format:?}", path.display());
    let cache_dir = options.cache_dir.clone().unwrap_or_else(cache::default_folder);
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
            if nrrd_is_compressed(path)? {
                let key = cache::content_key(&[path.to_path_buf()], "nrrd")?;
                cache::open_or_import(&cache_dir, &key, path, || nrrd::read(path).map(|r| (r.volume, Vec::new())))?
            } else {
                nrrd::read(path)?.volume
            }
        }
        Format::MetaImage => {
            let head = read_head(path, 1 << 16)?;
            let header = metaimage::parse_header(&head, path)?;
            if header.compressed {
                let mut files = vec![path.to_path_buf()];
                if let Some(data) = &header.data_file {
                    files.push(path.parent().unwrap_or(Path::new(".")).join(data));
                }
                let key = cache::content_key(&files, "metaimage")?;
                cache::open_or_import(&cache_dir, &key, path, || metaimage::read(path).map(|r| (r.volume, Vec::new())))?
            } else {
                metaimage::read(path)?.volume
            }
        }
        Format::Nifti => {
            if nifti::is_gzip(path)? {
                let key = cache::content_key(&[path.to_path_buf()], "nifti")?;
                cache::open_or_import(&cache_dir, &key, path, || nifti::read(path).map(|r| (r.volume, Vec::new())))?
            } else {
                nifti::read(path)?.volume
            }
        }
        Format::Dicom => open_dicom(path, &options.dicom, &cache_dir)?,
    };
    if let Some(spacing) = options.spacing_mm {
        for (axis, &s) in spacing.iter().enumerate() {
            if !(s.is_finite() && s > 0.0) {
                return Err(VolumeError::BadSpacing { axis, value: s, path: path.to_path_buf() });
            }
        }
        volume.spacing_mm = spacing;
    }
    Ok(volume)
}

/// A DICOM series, imported through the cache. The key covers every file the series could come
/// from (the folder's files, or the one file) and the options, so a hit skips reading DICOM at all.
fn open_dicom(path: &Path, options: &DicomOptions, cache_dir: &Path) -> Result<Volume, VolumeError> {
    let is_dicomdir = path.is_file() && file_name(path).is_some_and(|n| n.eq_ignore_ascii_case("dicomdir"));
    let files = if path.is_dir() || is_dicomdir {
        let folder = if is_dicomdir { path.parent().unwrap_or(Path::new(".")) } else { path };
        let mut files = Vec::new();
        list_files(folder, &mut files, 0)?;
        files.sort();
        files
    } else {
        vec![path.to_path_buf()]
    };
    let settings = format!(
        "dicom series={:?} resample={:?} spacing={:?}",
        options.series_uid, options.resample, options.slice_spacing_mm
    );
    let key = cache::content_key(&files, &settings)?;
    cache::open_or_import(cache_dir, &key, path, || {
        let imported = dicom::read_series(path, options)?;
        Ok((imported.volume, imported.warnings))
    })
}

/// Every regular file below `folder` (symbolic links are not followed, so a loop cannot hang).
fn list_files(folder: &Path, files: &mut Vec<PathBuf>, depth: usize) -> Result<(), VolumeError> {
    const MAX_DEPTH: usize = 8;
    for entry in std::fs::read_dir(folder).map_err(|e| VolumeError::io(e, folder))? {
        let entry = entry.map_err(|e| VolumeError::io(e, folder))?;
        let file_type = entry.file_type().map_err(|e| VolumeError::io(e, entry.path()))?;
        if file_type.is_file() {
            files.push(entry.path());
        } else if file_type.is_dir() && depth < MAX_DEPTH {
            list_files(&entry.path(), files, depth + 1)?;
        }
    }
    Ok(())
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
    let head = read_head(path, 352)?;
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

fn nrrd_is_compressed(path: &Path) -> Result<bool, VolumeError> {
    let header = nrrd::parse_header(&read_head(path, 1 << 16)?, path)?;
    Ok(header.encoding == nrrd::NrrdEncoding::Gzip)
}

fn read_head(path: &Path, limit: u64) -> Result<Vec<u8>, VolumeError> {
    let file = std::fs::File::open(path).map_err(|e| VolumeError::io(e, path))?;
    let mut head = Vec::new();
    file.take(limit).read_to_end(&mut head).map_err(|e| VolumeError::io(e, path))?;
    Ok(head)
}

fn file_name(path: &Path) -> Option<String> {
    path.file_name().map(|n| n.to_string_lossy().into_owned())
}
