//! Volumes: a regular 3-D grid of scalar voxels, memory-mapped from local storage.
//!
//! A [`Volume`] knows its dimensions, physical spacing, scalar type and byte order, and where its
//! voxel bytes live ([`VoxelBytes`]: a memory map of the file whenever the encoding allows it,
//! owned bytes for generated or decoded data). Voxel order everywhere is x fastest, then y, then
//! z (`interfaces.md`). Values are read on demand and converted to `f32`/`f64` there, so a 16-bit
//! big-endian file at an odd offset is as usable as a native `u8` one, and nothing is copied.
//!
//! Entry point: [`open()`] (any supported file or folder, see [`open::OpenOptions`]).
//! Readers live beside this file, one per format; [`cache`] turns compressed files and DICOM
//! series into mappable NRRD files once.
//!
//! Never: decides what a voxel means (that is `features`), or writes anywhere but the cache
//! folder and the paths it is given.

pub mod array;
pub mod body;
pub mod cache;
pub mod dicom;
pub mod error;
mod fields;
mod foreground;
pub mod histogram;
pub mod limits;
pub mod metaimage;
pub mod nifti;
pub mod nrrd;
pub mod open;
pub mod orientation;
pub mod raw;
pub mod shading;
pub mod storage;

pub use array::StoredVoxel;
pub use error::VolumeError;
pub use foreground::{ForegroundRows, any_at_or_above};
pub use open::{OpenOptions, open};
pub use orientation::{PatientDirection, PatientOrientation};
pub use storage::VoxelBytes;

use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The scalar type of one voxel, as stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VoxelType {
    /// Unsigned 8-bit integer (`uint8`).
    U8,
    /// Signed 8-bit integer (`int8`).
    I8,
    /// Unsigned 16-bit integer (`uint16`).
    U16,
    /// Signed 16-bit integer (`int16`), the usual CT type.
    I16,
    /// Unsigned 32-bit integer (`uint32`).
    U32,
    /// Signed 32-bit integer (`int32`).
    I32,
    /// IEEE 754 single-precision float (`float32`).
    F32,
    /// IEEE 754 double-precision float (`float64`).
    F64,
}

impl VoxelType {
    /// Every type, in the order of the Open SciVis names.
    pub const ALL: [VoxelType; 8] = [
        VoxelType::U8,
        VoxelType::I8,
        VoxelType::U16,
        VoxelType::I16,
        VoxelType::U32,
        VoxelType::I32,
        VoxelType::F32,
        VoxelType::F64,
    ];

    /// Bytes per voxel.
    pub fn size_bytes(self) -> usize {
        match self {
            VoxelType::U8 | VoxelType::I8 => 1,
            VoxelType::U16 | VoxelType::I16 => 2,
            VoxelType::U32 | VoxelType::I32 | VoxelType::F32 => 4,
            VoxelType::F64 => 8,
        }
    }

    /// The Open SciVis / NRRD canonical name (`uint8`, `int16`, `float32`, ...).
    pub fn name(self) -> &'static str {
        match self {
            VoxelType::U8 => "uint8",
            VoxelType::I8 => "int8",
            VoxelType::U16 => "uint16",
            VoxelType::I16 => "int16",
            VoxelType::U32 => "uint32",
            VoxelType::I32 => "int32",
            VoxelType::F32 => "float32",
            VoxelType::F64 => "float64",
        }
    }

    /// Parses the Open SciVis names (`uint8` ... `float64`) used in raw file names and `--type`.
    pub fn from_name(name: &str) -> Option<VoxelType> {
        VoxelType::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Floating-point types may hold NaN or infinities; integer types cannot.
    pub fn is_float(self) -> bool {
        matches!(self, VoxelType::F32 | VoxelType::F64)
    }
}

/// Byte order of multi-byte voxels in storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ByteOrder {
    /// Least significant byte first.
    Little,
    /// Most significant byte first.
    Big,
}

/// A linear map from stored values to physical values (NIfTI `scl_slope`/`scl_inter`, DICOM
/// rescale). `value = stored * slope + intercept`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueScale {
    /// Factor applied to each stored value.
    pub slope: f64,
    /// Offset added after the factor, in the physical unit (Hounsfield units for CT).
    pub intercept: f64,
}

impl ValueScale {
    /// The scale that leaves stored values as they are (slope 1, intercept 0).
    pub const IDENTITY: ValueScale = ValueScale { slope: 1.0, intercept: 0.0 };

    /// True when the scale leaves stored values unchanged.
    pub fn is_identity(&self) -> bool {
        self.slope == 1.0 && self.intercept == 0.0
    }
}

/// The smallest and largest finite value, and how many voxels were not finite (NaN, inf).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    /// Smallest finite value, after scaling.
    pub min: f64,
    /// Largest finite value, after scaling.
    pub max: f64,
    /// Number of voxels holding NaN or an infinity (skipped by `min` and `max`).
    pub non_finite_voxels: u64,
}

/// A regular 3-D scalar volume. Cheap to share behind an `Arc`; reading is `&self` and
/// thread-safe.
#[derive(Debug)]
pub struct Volume {
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Distance between voxel centres along x, y, z, in millimetres (or the file's unit).
    pub spacing_mm: [f64; 3],
    /// Scalar type of each stored voxel.
    pub voxel_type: VoxelType,
    /// Byte order of the stored voxels.
    pub byte_order: ByteOrder,
    /// Applied to every stored value on read.
    pub scale: ValueScale,
    /// Where the data came from (the file the user named, not the cache file).
    pub source: PathBuf,
    /// Where the voxel axes point in the patient, when the file says ([`orientation`]);
    /// `None` for raw files and files without (or with unusable) orientation fields.
    pub orientation: Option<PatientOrientation>,
    /// What the reader tolerated or changed (a DICOM series resampled across a missing slice
    /// with `--allow-gaps`, skipped files), one sentence each, for the caller to show.
    pub warnings: Vec<String>,
    bytes: VoxelBytes,
    range: ValueRange,
    /// [`Volume::otsu_threshold`], once asked for.
    otsu: std::sync::OnceLock<f64>,
    /// [`Volume::body`], once asked for.
    body: std::sync::OnceLock<std::sync::Arc<body::Body>>,
    /// The last body [`Volume::body_at`] found at another level (the background rule asks for
    /// the same one several times in a training).
    body_elsewhere: std::sync::Mutex<Option<std::sync::Arc<body::Body>>>,
}

impl Volume {
    /// Builds a volume over `bytes`, checking that they hold exactly `dims` voxels of
    /// `voxel_type` and that the spacing is one a scan can have ([`check_spacing`]), and
    /// computes the value range (one parallel pass), refusing a volume without a finite value
    /// or with values beyond `f32` after the scale.
    pub fn new(
        dims: [usize; 3],
        spacing_mm: [f64; 3],
        voxel_type: VoxelType,
        byte_order: ByteOrder,
        scale: ValueScale,
        bytes: VoxelBytes,
        source: &Path,
    ) -> Result<Volume, VolumeError> {
        let voxel_count = checked_voxel_count(dims, voxel_type, source)?;
        let expected = voxel_count * voxel_type.size_bytes();
        if bytes.len() != expected {
            return Err(VolumeError::DataSize { expected, found: bytes.len(), path: source.to_path_buf() });
        }
        check_spacing(spacing_mm, source)?;
        if !(scale.slope.is_finite() && scale.intercept.is_finite() && scale.slope != 0.0) {
            return Err(VolumeError::Header {
                field: "value scale".into(),
                problem: format!(
                    "slope {} and intercept {} must be finite, slope non-zero",
                    scale.slope, scale.intercept
                ),
                path: source.to_path_buf(),
            });
        }
        let mut volume = Volume {
            dims,
            spacing_mm,
            voxel_type,
            byte_order,
            scale,
            source: source.to_path_buf(),
            orientation: None,
            warnings: Vec::new(),
            bytes,
            range: ValueRange { min: 0.0, max: 0.0, non_finite_voxels: 0 },
            otsu: std::sync::OnceLock::new(),
            body: std::sync::OnceLock::new(),
            body_elsewhere: std::sync::Mutex::new(None),
        };
        volume.range = volume.compute_range()?;
        Ok(volume)
    }

    /// Builds an in-memory volume from `f32` values (x fastest), stored as `float32`.
    pub fn from_f32(
        dims: [usize; 3],
        spacing_mm: [f64; 3],
        values: &[f32],
        source: &Path,
    ) -> Result<Volume, VolumeError> {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
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

    /// Number of voxels.
    pub fn voxel_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Index of voxel (x, y, z) in x-fastest order.
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The range of physical values, computed once when the volume was opened.
    pub fn value_range(&self) -> ValueRange {
        self.range
    }

    /// Otsu's threshold of the value histogram (see [`histogram`]): computed on the first
    /// call (a pass over a sample of the planes), then kept. A caller that wants the cost out
    /// of an interactive path (training on every lasso) asks once when it opens the volume.
    pub fn otsu_threshold(&self) -> f64 {
        *self.otsu.get_or_init(|| histogram::otsu_threshold(self))
    }

    /// Otsu's split of the finite values below `ceiling`, and its separability (see
    /// [`histogram`]); `None` without two distinct values there.
    pub fn split_below(&self, ceiling: f64) -> Option<histogram::Split> {
        histogram::split_below(self, ceiling)
    }

    /// The scanned body ([`body::Body::find`]): found on the first call (a few parallel passes
    /// over the volume), then kept. The kiosk asks when it opens a volume, so that no lasso
    /// waits for it.
    pub fn body(&self) -> std::sync::Arc<body::Body> {
        self.body.get_or_init(|| std::sync::Arc::new(body::Body::find(self, self.otsu_threshold()))).clone()
    }

    /// This volume with `other`'s Otsu threshold and body outline, where `other` has the same
    /// dimensions: a copy of a scan whose values were rescaled a little (its shading divided
    /// out, `shading`) rings the same body, and finding it again would cost a labelling's time.
    pub fn sharing_body_of(self, other: &Volume) -> Volume {
        if self.dims == other.dims {
            let _ = self.otsu.set(other.otsu_threshold());
            let _ = self.body.set(other.body());
        }
        self
    }

    /// The scanned body above `level` ([`body::Body::find`]): [`body`](Self::body) when `level`
    /// is Otsu's threshold, else found anew.
    pub fn body_at(&self, level: f64) -> std::sync::Arc<body::Body> {
        if level == self.otsu_threshold() {
            return self.body();
        }
        // A poisoned lock only means another thread panicked while finding a body; the cache
        // itself is always whole.
        let mut last = self.body_elsewhere.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        match last.as_ref() {
            Some(body) if body.level == level => body.clone(),
            _ => {
                let body = std::sync::Arc::new(body::Body::find(self, level));
                *last = Some(body.clone());
                body
            }
        }
    }

    /// True when the bytes are a memory map of a file (not a copy in RAM).
    pub fn is_memory_mapped(&self) -> bool {
        self.bytes.is_mapped()
    }

    /// An error when the file under a memory-mapped volume has shrunk since it was opened
    /// (reading it would crash with SIGBUS); always `Ok` for volumes in memory. The pipeline's
    /// entry points call it before each whole-volume pass (see [`storage`]).
    pub fn check_still_mapped(&self) -> Result<(), VolumeError> {
        self.bytes.check_still_mapped()
    }

    /// The stored bytes, as they are in the file.
    pub fn raw_bytes(&self) -> &[u8] {
        self.bytes.as_slice()
    }

    /// The physical value of voxel `index` (x-fastest). Panics when `index` is out of range,
    /// like slice indexing: callers iterate over `0..voxel_count()`.
    #[inline]
    pub fn value(&self, index: usize) -> f64 {
        let stored = read_stored(self.bytes.as_slice(), self.voxel_type, self.byte_order, index);
        stored * self.scale.slope + self.scale.intercept
    }

    /// The physical value at (x, y, z).
    #[inline]
    pub fn value_at(&self, x: usize, y: usize, z: usize) -> f64 {
        self.value(self.index(x, y, z))
    }

    /// Converts voxels `start..start + out.len()` to physical `f32` values into `out`.
    /// This is how whole-volume passes read: a slab at a time, into a reused buffer.
    pub fn read_f32(&self, start: usize, out: &mut [f32]) {
        let bytes = self.bytes.as_slice();
        let (slope, intercept) = (self.scale.slope, self.scale.intercept);
        let identity = self.scale.is_identity();
        // The byte order and the scale are decided outside the loops, so that each loop is
        // one tight conversion the compiler can vectorise (this runs on every plane of every
        // classification).
        macro_rules! convert {
            ($t:ty, $size:literal) => {{
                let stored = &bytes[start * $size..][..out.len() * $size];
                match (self.byte_order, identity) {
                    (ByteOrder::Little, true) => each(stored, out, |raw| <$t>::from_le_bytes(raw) as f64 as f32),
                    (ByteOrder::Little, false) => {
                        each(stored, out, |raw| (<$t>::from_le_bytes(raw) as f64 * slope + intercept) as f32)
                    }
                    (ByteOrder::Big, true) => each(stored, out, |raw| <$t>::from_be_bytes(raw) as f64 as f32),
                    (ByteOrder::Big, false) => {
                        each(stored, out, |raw| (<$t>::from_be_bytes(raw) as f64 * slope + intercept) as f32)
                    }
                }
            }};
        }
        match self.voxel_type {
            VoxelType::U8 => convert_bytes(&bytes[start..start + out.len()], self.scale, out),
            VoxelType::I8 => convert!(i8, 1),
            VoxelType::U16 => convert!(u16, 2),
            VoxelType::I16 => convert!(i16, 2),
            VoxelType::U32 => convert!(u32, 4),
            VoxelType::I32 => convert!(i32, 4),
            VoxelType::F32 => convert!(f32, 4),
            VoxelType::F64 => convert!(f64, 8),
        }
    }

    /// Physical `f32` values of z-slice `z` (`dims[0] * dims[1]` values).
    pub fn read_z_slice_f32(&self, z: usize, out: &mut [f32]) {
        let plane = self.dims[0] * self.dims[1];
        self.read_f32(z * plane, &mut out[..plane]);
    }

    /// The exact range of stored values (one parallel pass over z planes, each a tight loop
    /// per type), then mapped through the scale, which is linear and so maps extremes to
    /// extremes. Refuses a volume without one finite value (nothing to show, no range to
    /// report) and one whose values pass `f32`'s range, in which every later stage computes
    /// (they would turn infinite there while the range said otherwise).
    fn compute_range(&self) -> Result<ValueRange, VolumeError> {
        let plane_bytes = self.dims[0] * self.dims[1] * self.voxel_type.size_bytes();
        let (voxel_type, order) = (self.voxel_type, self.byte_order);
        let (min, max, non_finite) = self
            .bytes
            .as_slice()
            .par_chunks(plane_bytes)
            .map(|bytes| stored_range(bytes, voxel_type, order))
            .reduce(|| (f64::INFINITY, f64::NEG_INFINITY, 0u64), |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 + b.2));
        if min > max {
            return Err(VolumeError::NoFiniteValue { voxels: non_finite, path: self.source.clone() });
        }
        let (low, high) =
            (min * self.scale.slope + self.scale.intercept, max * self.scale.slope + self.scale.intercept);
        let (low, high) = (low.min(high), low.max(high));
        let largest = f64::from(f32::MAX);
        if let Some(value) = [low, high].into_iter().find(|value| !(-largest..=largest).contains(value)) {
            return Err(VolumeError::ValueOverflow {
                value,
                scaled: !self.scale.is_identity(),
                path: self.source.clone(),
            });
        }
        Ok(ValueRange { min: low, max: high, non_finite_voxels: non_finite })
    }
}

/// Smallest and largest finite stored value in `bytes`, and the count of non-finite ones.
fn stored_range(bytes: &[u8], voxel_type: VoxelType, order: ByteOrder) -> (f64, f64, u64) {
    macro_rules! range {
        ($t:ty, $n:expr) => {{
            let (mut min, mut max, mut non_finite) = (<$t>::MAX, <$t>::MIN, 0u64);
            for chunk in bytes.chunks_exact($n) {
                let mut raw = [0u8; $n];
                raw.copy_from_slice(chunk);
                let v = match order {
                    ByteOrder::Little => <$t>::from_le_bytes(raw),
                    ByteOrder::Big => <$t>::from_be_bytes(raw),
                };
                if (v as f64).is_finite() {
                    min = if v < min { v } else { min };
                    max = if v > max { v } else { max };
                } else {
                    non_finite += 1;
                }
            }
            (min as f64, max as f64, non_finite)
        }};
    }
    let (min, max, non_finite) = match voxel_type {
        VoxelType::U8 => range!(u8, 1),
        VoxelType::I8 => range!(i8, 1),
        VoxelType::U16 => range!(u16, 2),
        VoxelType::I16 => range!(i16, 2),
        VoxelType::U32 => range!(u32, 4),
        VoxelType::I32 => range!(i32, 4),
        VoxelType::F32 => range!(f32, 4),
        VoxelType::F64 => range!(f64, 8),
    };
    // An empty or all-non-finite run leaves the sentinels; report "no values".
    let count = bytes.len() / voxel_type.size_bytes();
    if non_finite as usize == count { (f64::INFINITY, f64::NEG_INFINITY, non_finite) } else { (min, max, non_finite) }
}

/// Reads stored voxel `index` as `f64`, honouring type and byte order; no alignment needed.
#[inline]
fn read_stored(bytes: &[u8], voxel_type: VoxelType, order: ByteOrder, index: usize) -> f64 {
    macro_rules! read {
        ($t:ty, $n:expr) => {{
            let mut raw = [0u8; $n];
            raw.copy_from_slice(&bytes[index * $n..index * $n + $n]);
            (match order {
                ByteOrder::Little => <$t>::from_le_bytes(raw),
                ByteOrder::Big => <$t>::from_be_bytes(raw),
            }) as f64
        }};
    }
    match voxel_type {
        VoxelType::U8 => bytes[index] as f64,
        VoxelType::I8 => bytes[index] as i8 as f64,
        VoxelType::U16 => read!(u16, 2),
        VoxelType::I16 => read!(i16, 2),
        VoxelType::U32 => read!(u32, 4),
        VoxelType::I32 => read!(i32, 4),
        VoxelType::F32 => read!(f32, 4),
        VoxelType::F64 => read!(f64, 8),
    }
}

/// `u8` voxels to physical values: the one conversion of bytes, shared by [`Volume::read_f32`]
/// and [`ForegroundRows`] (which must agree with it to the last bit).
#[inline]
fn convert_bytes(bytes: &[u8], scale: ValueScale, out: &mut [f32]) {
    let (slope, intercept) = (scale.slope, scale.intercept);
    if scale.is_identity() {
        each(bytes, out, |[byte]| f32::from(byte));
    } else {
        each(bytes, out, |[byte]| (f64::from(byte) * slope + intercept) as f32);
    }
}

/// `out[i] = convert(voxel i's SIZE bytes of stored)` for every `i`, as a plain indexed loop
/// always inlined into its caller: the tests' build (opt-level 1) does not inline iterator
/// adapters, and a call per voxel made reading a volume there hundreds of times slower.
#[inline(always)]
fn each<const SIZE: usize>(stored: &[u8], out: &mut [f32], convert: impl Fn([u8; SIZE]) -> f32) {
    let count = out.len().min(stored.len() / SIZE);
    let (stored, out) = (&stored[..count * SIZE], &mut out[..count]);
    let mut i = 0;
    while i < count {
        let mut raw = [0u8; SIZE];
        let mut k = 0;
        while k < SIZE {
            raw[k] = stored[i * SIZE + k];
            k += 1;
        }
        out[i] = convert(raw);
        i += 1;
    }
}

/// The finest voxel spacing a volume may have: 0.1 µm, in millimetres. Finer than any CT or MRI
/// (micro-CT reaches about 0.5 µm); a smaller figure is a header in the wrong unit or garbage,
/// and would make the features' gradients overflow.
pub const SMALLEST_SPACING_MM: f64 = 1e-4;

/// The coarsest voxel spacing a volume may have: 10 m, in millimetres. No scan has voxels this
/// large; a larger figure is a corrupt header, and the 3-D view of it would be empty.
pub const LARGEST_SPACING_MM: f64 = 1e4;

/// Refuses a spacing that is not a finite number within
/// [`SMALLEST_SPACING_MM`]..=[`LARGEST_SPACING_MM`] along some axis (zero, negative, NaN and
/// infinite included), the bounds taken within `f32`'s rounding (NIfTI stores its spacing as
/// `f32`, in which 0.0001 is a little less). Every reader's spacing and `--spacing` pass through
/// here: such a scan is refused, never shown squashed to a plane or blown up to nothing.
pub fn check_spacing(spacing_mm: [f64; 3], path: &Path) -> Result<(), VolumeError> {
    let rounding = f64::from(f32::EPSILON);
    let usable = SMALLEST_SPACING_MM * (1.0 - rounding)..=LARGEST_SPACING_MM * (1.0 + rounding);
    for (axis, &value) in spacing_mm.iter().enumerate() {
        if !usable.contains(&value) {
            return Err(VolumeError::BadSpacing { axis, value, path: path.to_path_buf() });
        }
    }
    Ok(())
}

/// The number of voxels, refusing zero and overflowing dimensions.
pub fn checked_voxel_count(dims: [usize; 3], voxel_type: VoxelType, path: &Path) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::BadDimensions {
            dims: dims.map(|d| d as u64),
            problem: "a dimension is zero",
            path: path.to_path_buf(),
        });
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .and_then(|n| n.checked_mul(voxel_type.size_bytes()).map(|_| n))
        .filter(|&n| n <= isize::MAX as usize / 8)
        .ok_or_else(|| VolumeError::BadDimensions {
            dims: dims.map(|d| d as u64),
            problem: "the voxel count overflows",
            path: path.to_path_buf(),
        })
}

#[cfg(test)]
mod tests;
