//! The gallery of kept results: "Save" on the work screen keeps the current result under the
//! data folder's `gallery/`, and the chooser offers each as a card that restores it. One entry
//! is one folder, `gallery/result-SECONDS[-N]/`, holding `thumbnail.png` (the 3-D view, at most
//! [`THUMBNAIL_SIDE`] pixels a side) and `entry.json` (format `volasso-gallery/1`):
//! `{"format", "saved_unix", "volume_name", "camera", "visible", "session"}` where `session` is
//! the record autosave writes (`volasso-session/1`: volume, strokes, template and hue; whatever
//! it gains travels along), `camera` the 3-D view's orbit and `visible` each class's
//! visibility. Both files are written atomically, `entry.json` last: an entry without it was
//! never finished and is listed as damaged.
//!
//! Reading is hostile-file safe: a folder whose entry cannot be read, or whose thumbnail is not
//! a small PNG, becomes a [`Listed::Damaged`] with the reason; an entry whose volume is gone is
//! listed with [`GalleryEntry::volume_missing`] set, so its card can say so.
//!
//! Never: overwrites or deletes an entry; touches Slint.

pub(crate) mod app;
pub(crate) mod model;
pub(crate) mod view;

use crate::autosave::{self, AutosaveError, SavedSession};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use volasso_core::atomic_file::write_atomically;
use volasso_core::phantom::source::VolumeSource;
use volasso_core::render::Camera;

pub const GALLERY_FORMAT: &str = "volasso-gallery/1";

/// The gallery's folder inside the data folder.
pub const FOLDER: &str = "gallery";

/// The largest side of a stored thumbnail, in pixels.
pub const THUMBNAIL_SIDE: u32 = 256;

/// The most entries listed, newest first.
pub const MAX_LISTED: usize = 100;

/// The largest `entry.json` read; a kept result is a few kilobytes of lassos.
const MAX_ENTRY_BYTES: u64 = 8 << 20;

const ENTRY_FILE: &str = "entry.json";
const THUMBNAIL_FILE: &str = "thumbnail.png";

/// Why an entry cannot be kept or read back; the path last.
#[derive(Debug, thiserror::Error)]
pub enum GalleryError {
    #[error("cannot create the gallery folder: {source}, in {}", path.display())]
    CreateFolder { source: std::io::Error, path: PathBuf },
    #[error("the gallery has no free entry name, in {}", path.display())]
    NoFreeName { path: PathBuf },
    #[error("cannot write: {source}, in {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
    #[error("cannot encode the thumbnail: {source}, in {}", path.display())]
    Encode { source: image::ImageError, path: PathBuf },
    #[error("the entry is incomplete (no {ENTRY_FILE}), in {}", path.display())]
    Incomplete { path: PathBuf },
    #[error("cannot read: {source}, in {}", path.display())]
    Read { source: std::io::Error, path: PathBuf },
    #[error("the entry is {bytes} bytes, more than a kept result can be, in {}", path.display())]
    TooLarge { bytes: u64, path: PathBuf },
    #[error("the entry is not valid JSON ({source}), in {}", path.display())]
    Json { source: serde_json::Error, path: PathBuf },
    #[error("format '{found}' is not {GALLERY_FORMAT}, in {}", path.display())]
    Format { found: String, path: PathBuf },
    #[error("its session cannot be read ({source}), in {}", path.display())]
    Session { source: AutosaveError, path: PathBuf },
    #[error("the thumbnail is not a usable PNG ({reason}), in {}", path.display())]
    Thumbnail { reason: String, path: PathBuf },
}

/// A kept result.
#[derive(Clone, Debug, PartialEq)]
pub struct GalleryEntry {
    pub session: SavedSession,
    /// The volume's name as the chooser shows it.
    pub volume_name: String,
    /// When it was kept, in seconds since 1970 (UTC).
    pub saved_unix: u64,
    /// The 3-D view's orbit (its projection is the view's default).
    pub camera: Camera,
    /// Per defined class, whether it is shown.
    pub visible: Vec<bool>,
}

impl GalleryEntry {
    /// True when the entry names a file or folder that is not there.
    pub fn volume_missing(&self) -> bool {
        match VolumeSource::from_key(&self.session.volume) {
            VolumeSource::Demo => false,
            VolumeSource::Path(path) => !path.exists(),
            // A folder still there whose series was removed is said by the loader on opening.
            VolumeSource::Series { folder, .. } => !folder.is_dir(),
        }
    }

    /// The card's sentence for an entry whose volume is gone.
    pub fn missing_message(&self) -> String {
        format!("The scan this result needs is missing: {}", self.volume_name)
    }
}

#[derive(Serialize, Deserialize)]
struct CameraFile {
    azimuth_degrees: f32,
    elevation_degrees: f32,
    zoom: f32,
    pan_mm: [f32; 2],
}

#[derive(Serialize, Deserialize)]
struct EntryFile {
    format: String,
    saved_unix: u64,
    volume_name: String,
    camera: CameraFile,
    visible: Vec<bool>,
    session: serde_json::Value,
}

/// One folder of the gallery, as listed.
#[derive(Clone, Debug)]
pub enum Listed {
    Entry {
        folder: PathBuf,
        entry: Box<GalleryEntry>,
        thumbnail: Option<image::RgbaImage>,
    },
    /// It cannot be read: why, for its card.
    Damaged {
        folder: PathBuf,
        reason: String,
    },
}

/// The gallery folder of a data folder.
pub fn gallery_dir(data_dir: &Path) -> PathBuf {
    data_dir.join(FOLDER)
}

/// Keeps `entry` with `picture` (the 3-D view, scaled down to the thumbnail) as a new folder of
/// the gallery in `data_dir`; returns the folder. Never replaces an existing entry.
pub fn save(data_dir: &Path, entry: &GalleryEntry, picture: &image::RgbaImage) -> Result<PathBuf, GalleryError> {
    let gallery = gallery_dir(data_dir);
    std::fs::create_dir_all(&gallery).map_err(|source| GalleryError::CreateFolder { source, path: gallery.clone() })?;
    let folder = new_folder(&gallery, entry.saved_unix)?;
    let mut png = Vec::new();
    let thumbnail = scaled_to_fit(picture, THUMBNAIL_SIDE);
    let path = folder.join(THUMBNAIL_FILE);
    thumbnail
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|source| GalleryError::Encode { source, path: path.clone() })?;
    write_atomically(&path, |writer| writer.write_all(&png)).map_err(|source| GalleryError::Write { source, path })?;
    let path = folder.join(ENTRY_FILE);
    let session =
        autosave::to_record(&entry.session).map_err(|source| GalleryError::Session { source, path: path.clone() })?;
    let camera = &entry.camera;
    let file = EntryFile {
        format: GALLERY_FORMAT.to_string(),
        saved_unix: entry.saved_unix,
        volume_name: entry.volume_name.clone(),
        camera: CameraFile {
            azimuth_degrees: camera.azimuth_degrees,
            elevation_degrees: camera.elevation_degrees,
            zoom: camera.zoom,
            pan_mm: camera.pan_mm,
        },
        visible: entry.visible.clone(),
        session,
    };
    let text =
        serde_json::to_string_pretty(&file).map_err(|source| GalleryError::Json { source, path: path.clone() })?;
    write_atomically(&path, |writer| writer.write_all(text.as_bytes()))
        .map_err(|source| GalleryError::Write { source, path })?;
    Ok(folder)
}

/// Creates `result-SECONDS` (or `-1`, `-2`, ... when taken) in `gallery`: creating, not
/// reusing, so two saves never share a folder.
fn new_folder(gallery: &Path, seconds: u64) -> Result<PathBuf, GalleryError> {
    for n in 0..1000 {
        let name = if n == 0 { format!("result-{seconds}") } else { format!("result-{seconds}-{n}") };
        let folder = gallery.join(name);
        match std::fs::create_dir(&folder) {
            Ok(()) => return Ok(folder),
            Err(error) if error.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(source) => return Err(GalleryError::CreateFolder { source, path: folder }),
        }
    }
    Err(GalleryError::NoFreeName { path: gallery.to_path_buf() })
}

/// `image` scaled down (never up) so its larger side is at most `side`.
fn scaled_to_fit(image: &image::RgbaImage, side: u32) -> image::RgbaImage {
    let (width, height) = image.dimensions();
    let largest = width.max(height).max(1);
    if largest <= side {
        return image.clone();
    }
    let scale = side as f32 / largest as f32;
    let size = |n: u32| ((n as f32 * scale).round() as u32).max(1);
    image::imageops::thumbnail(image, size(width), size(height))
}

/// The gallery of `data_dir`, newest first; damaged entries listed with the reason.
pub fn list(data_dir: &Path) -> Vec<Listed> {
    let Ok(entries) = std::fs::read_dir(gallery_dir(data_dir)) else { return Vec::new() };
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| !path.file_name().is_some_and(|name| name.to_string_lossy().starts_with('.')))
        .filter(|path| path.is_dir())
        .collect();
    // Newest first: by the seconds in the name, then the name.
    folders.sort_by_key(|path| std::cmp::Reverse((saved_seconds(path), path.clone())));
    folders.truncate(MAX_LISTED);
    folders
        .into_iter()
        .map(|folder| match read(&folder) {
            Ok((entry, thumbnail)) => Listed::Entry { folder, entry: Box::new(entry), thumbnail },
            Err(error) => {
                log::warn!("gallery: {error}");
                // The card names the entry: the reason without the path errors carry last.
                let message = error.to_string();
                let reason = message.rsplit_once(", in ").map_or(message.as_str(), |(reason, _)| reason).to_string();
                Listed::Damaged { folder, reason }
            }
        })
        .collect()
}

/// The seconds of a `result-SECONDS[-N]` folder name (0 for other names).
fn saved_seconds(folder: &Path) -> u64 {
    let name = folder.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    name.strip_prefix("result-").and_then(|rest| rest.split('-').next()?.parse().ok()).unwrap_or(0)
}

/// An entry and its thumbnail (`None` when it has none).
pub fn read(folder: &Path) -> Result<(GalleryEntry, Option<image::RgbaImage>), GalleryError> {
    let path = folder.join(ENTRY_FILE);
    let bytes = match std::fs::metadata(&path) {
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => {
            return Err(GalleryError::Incomplete { path: folder.to_path_buf() });
        }
        Err(source) => return Err(GalleryError::Read { source, path }),
        Ok(metadata) => metadata.len(),
    };
    if bytes > MAX_ENTRY_BYTES {
        return Err(GalleryError::TooLarge { bytes, path });
    }
    let text = std::fs::read_to_string(&path).map_err(|source| GalleryError::Read { source, path: path.clone() })?;
    let file: EntryFile =
        serde_json::from_str(&text).map_err(|source| GalleryError::Json { source, path: path.clone() })?;
    if file.format != GALLERY_FORMAT {
        return Err(GalleryError::Format { found: file.format, path });
    }
    let session =
        autosave::from_record(file.session).map_err(|source| GalleryError::Session { source, path: path.clone() })?;
    let finite = |value: f32, fallback: f32| if value.is_finite() { value } else { fallback };
    let default = Camera::default();
    let camera = Camera {
        azimuth_degrees: finite(file.camera.azimuth_degrees, default.azimuth_degrees),
        elevation_degrees: finite(file.camera.elevation_degrees, default.elevation_degrees).clamp(-89.0, 89.0),
        zoom: finite(file.camera.zoom, 1.0).clamp(0.25, 8.0),
        pan_mm: file.camera.pan_mm.map(|p| finite(p, 0.0)),
        ..default
    };
    let entry = GalleryEntry {
        session,
        volume_name: file.volume_name,
        saved_unix: file.saved_unix,
        camera,
        visible: file.visible,
    };
    let thumbnail = read_thumbnail(&folder.join(THUMBNAIL_FILE))?;
    Ok((entry, thumbnail))
}

/// A stored thumbnail: a PNG of at most twice [`THUMBNAIL_SIDE`] a side, decoded within a
/// memory limit; `None` when the entry has none.
fn read_thumbnail(path: &Path) -> Result<Option<image::RgbaImage>, GalleryError> {
    let reader = match image::ImageReader::open(path) {
        Ok(reader) => reader,
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(GalleryError::Read { source, path: path.to_path_buf() }),
    };
    let mut reader = reader;
    reader.set_format(image::ImageFormat::Png);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(2 * THUMBNAIL_SIDE);
    limits.max_image_height = Some(2 * THUMBNAIL_SIDE);
    limits.max_alloc = Some(16 << 20);
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|error| GalleryError::Thumbnail { reason: error.to_string(), path: path.to_path_buf() })?;
    Ok(Some(decoded.to_rgba8()))
}

/// `YYYY-MM-DD HH:MM` (UTC) of seconds since 1970, for a card.
pub fn date_text(unix_seconds: u64) -> String {
    let minutes = unix_seconds % 86_400 / 60;
    let [year, month, day] = volasso_core::calendar::civil_from_days((unix_seconds / 86_400) as i64);
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02}", minutes / 60, minutes % 60)
}

#[cfg(test)]
mod tests;
