//! Every DICOM file is read into memory once and its element structure checked against its
//! length before dicom-object parses it: a declared length beyond the file's remaining bytes,
//! sequences nested too deep or too many elements are one clear error, found in a walk over
//! headers that allocates nothing. dicom-object reserves and zero-fills whatever a length field
//! says (a 531 KB file with one element length of 0xFFFFFFF0 took 4.2 GB before its error); it
//! then parses the same checked bytes, so every value it allocates fits inside the file.
//!
//! The walk mirrors dicom-parser's reading (PS3.5 §7): the file meta group (explicit VR little
//! endian, as long as its group length says), then the data set in the transfer syntax's
//! encoding; VRs with 32-bit lengths as dicom-core reads them (an unknown VR counts as UN);
//! in implicit VR the dictionary says which elements are sequences; undefined lengths are
//! sequences of items, or for PixelData, fragments.
//!
//! Entry point: [`read_object`] ([`Scope::Header`]: up to PixelData, read a growing prefix of
//! the file at a time; [`Scope::Whole`]: the whole file).
//!
//! Never: interprets values, or hands dicom-object a byte it has not checked.

use super::deflated::{self, MetaLayout};
use crate::volume::limits::{self, ReadLimits};
use crate::volume::{VolumeError, VoxelType};
use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry};
use dicom_core::{Tag, VR};
use dicom_dictionary_std::{StandardDataDictionary, tags};
use dicom_object::file::{OddLengthStrategy, ReadPreamble};
use dicom_object::{DefaultDicomObject, OpenFileOptions};
use std::io::Read;
use std::path::Path;

/// How much of a file to read and check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scope {
    /// The attributes before the root data set's PixelData.
    Header,
    /// Everything, PixelData included.
    Whole,
}

/// The most bytes of attributes before PixelData: real headers are kilobytes, enhanced
/// multi-frame ones a few megabytes.
const MOST_HEADER_BYTES: u64 = 64 << 20;
/// The first read for a header: the whole header of any single-frame CT or MR file.
const FIRST_HEADER_READ: u64 = 64 << 10;
/// Deeper nesting than this is not a real file (real ones nest 3 or 4 levels).
const MOST_SEQUENCE_DEPTH: usize = 16;
/// Parsed elements and items cost dicom-object about a hundred bytes each: a file of empty
/// elements must not turn a few megabytes into gigabytes.
const MOST_ELEMENTS: usize = 1 << 20;

const ITEM: Tag = Tag(0xFFFE, 0xE000);
const ITEM_END: Tag = Tag(0xFFFE, 0xE00D);
const SEQUENCE_END: Tag = Tag(0xFFFE, 0xE0DD);
const UNDEFINED: u32 = 0xFFFF_FFFF;

/// Reads `path` (a regular file), checks its structure for `scope`, and parses the checked bytes.
pub(super) fn read_object(path: &Path, scope: Scope, limits: &ReadLimits) -> Result<DefaultDicomObject, VolumeError> {
    let (mut file, file_len) = limits::open_regular(path)?;
    let invalid = |problem: String| VolumeError::Dicom { problem, path: path.to_path_buf() };
    let mut bytes = Vec::new();
    let walked = match scope {
        Scope::Whole => {
            limits::check_ceiling(file_len, limits, path)?;
            bytes = limits::reserve(file_len as usize, path)?;
            (&mut file).take(file_len).read_to_end(&mut bytes).map_err(|e| VolumeError::io(e, path))?;
            Walker::new(&bytes, bytes.len() as u64, scope).file()
        }
        Scope::Header => {
            let mut wanted = file_len.min(FIRST_HEADER_READ);
            loop {
                let missing = wanted.saturating_sub(bytes.len() as u64);
                (&mut file).take(missing).read_to_end(&mut bytes).map_err(|e| VolumeError::io(e, path))?;
                // A file that shrank while being read ends where its bytes end.
                let total = if (bytes.len() as u64) < wanted { bytes.len() as u64 } else { file_len };
                match Walker::new(&bytes, total, scope).file() {
                    Err(Stop::NeedMore) if wanted < file_len.min(MOST_HEADER_BYTES) => {
                        wanted = file_len.min(MOST_HEADER_BYTES).min(wanted.saturating_mul(4));
                    }
                    Err(Stop::NeedMore) => {
                        return Err(invalid(format!(
                            "more than {} MiB of attributes before PixelData",
                            MOST_HEADER_BYTES >> 20
                        )));
                    }
                    walked => break walked,
                }
            }
        }
    };
    let (bytes, end) = match walked {
        Ok(end) => (bytes, end),
        Err(Stop::Deflated(meta)) => {
            // The data set is one deflate stream: all of it, inflated, then walked as any file.
            limits::check_ceiling(file_len, limits, path)?;
            let rest = file_len.saturating_sub(bytes.len() as u64);
            (&mut file).take(rest).read_to_end(&mut bytes).map_err(|e| VolumeError::io(e, path))?;
            let inflated = deflated::inflate_file(&bytes, &meta, limits, path)?;
            let end =
                Walker::new(&inflated, inflated.len() as u64, scope).file().map_err(|stop| invalid(stop.problem()))?;
            (inflated, end)
        }
        Err(stop) => return Err(invalid(stop.problem())),
    };
    // The walk above assumed exactly this reading: the preamble, and odd lengths as they are.
    let options =
        OpenFileOptions::new().read_preamble(ReadPreamble::Always).odd_length_strategy(OddLengthStrategy::Accept);
    let options = if scope == Scope::Header { options.read_until(tags::PIXEL_DATA) } else { options };
    options.from_reader(&bytes[..end as usize]).map_err(|error| invalid(format!("unreadable DICOM file ({error})")))
}

/// Why a walk stopped early.
#[derive(Debug, PartialEq)]
enum Stop {
    /// The bytes read so far end before the walk does (only with a prefix of the file).
    NeedMore,
    Invalid(String),
    /// The data set is deflated ([`deflated`]); the meta group's layout.
    Deflated(MetaLayout),
}

impl Stop {
    fn problem(self) -> String {
        match self {
            Stop::NeedMore => "the file ends in the middle of its attributes (truncated)".into(),
            Stop::Invalid(problem) => problem,
            Stop::Deflated(_) => "the deflated data set was not inflated".into(),
        }
    }
}

type Step<T> = Result<T, Stop>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Syntax {
    explicit_vr: bool,
    big_endian: bool,
}

const EXPLICIT_LITTLE: Syntax = Syntax { explicit_vr: true, big_endian: false };

/// One element or item header.
struct Header {
    tag: Tag,
    vr: VR,
    /// `None` for an undefined length.
    length: Option<u64>,
    /// Bytes of the header itself.
    size: u64,
}

struct Walker<'a> {
    bytes: &'a [u8],
    /// The file's length: declared lengths are checked against it, while `bytes` may be a prefix.
    total: u64,
    scope: Scope,
    elements: std::cell::Cell<usize>,
}

impl<'a> Walker<'a> {
    fn new(bytes: &'a [u8], total: u64, scope: Scope) -> Walker<'a> {
        Walker { bytes, total, scope, elements: std::cell::Cell::new(0) }
    }

    /// `count` bytes at `position`, or why not.
    fn need(&self, position: u64, count: u64) -> Step<&'a [u8]> {
        let end = position.saturating_add(count);
        if end > self.total {
            return Err(Stop::Invalid(format!("the file ends inside an element at byte {position} (truncated)")));
        }
        if end > self.bytes.len() as u64 {
            return Err(Stop::NeedMore);
        }
        Ok(&self.bytes[position as usize..end as usize])
    }

    fn u16_at(&self, position: u64, syntax: Syntax) -> Step<u16> {
        let raw: [u8; 2] = self.need(position, 2)?.try_into().unwrap_or_default();
        Ok(if syntax.big_endian { u16::from_be_bytes(raw) } else { u16::from_le_bytes(raw) })
    }

    fn u32_at(&self, position: u64, syntax: Syntax) -> Step<u32> {
        let raw: [u8; 4] = self.need(position, 4)?.try_into().unwrap_or_default();
        Ok(if syntax.big_endian { u32::from_be_bytes(raw) } else { u32::from_le_bytes(raw) })
    }

    /// The whole file: preamble, meta group, data set; returns where parsing may stop.
    fn file(&self) -> Step<u64> {
        if self.need(128, 4)? != b"DICM" {
            return Err(Stop::Invalid("no DICM magic after the 128-byte preamble".into()));
        }
        let first = self.header(132, EXPLICIT_LITTLE)?;
        if first.tag != Tag(0x0002, 0x0000) || first.length != Some(4) {
            return Err(Stop::Invalid("the file meta group does not start with its group length".into()));
        }
        let group_length = u64::from(self.u32_at(132 + first.size, EXPLICIT_LITTLE)?);
        let mut position = 132 + first.size + 4;
        let meta_end = position.saturating_add(group_length);
        let mut transfer_syntax = None;
        let mut elements = Vec::new();
        while position < meta_end && position < self.total {
            let header = self.header(position, EXPLICIT_LITTLE)?;
            let length = header
                .length
                .ok_or_else(|| Stop::Invalid(format!("file meta element {} has an undefined length", header.tag)))?;
            let value_start = position + header.size;
            self.check_fits(&header, value_start, self.total)?;
            if header.tag == Tag(0x0002, 0x0010) {
                let value = self.need(value_start, length)?;
                transfer_syntax = Some(String::from_utf8_lossy(value).trim_matches(['\0', ' ']).to_string());
            }
            self.need(position, header.size + length)?;
            elements.push((header.tag.element(), position as usize, (value_start + length) as usize));
            position = value_start + length;
        }
        let syntax = match transfer_syntax.as_deref() {
            None => return Err(Stop::Invalid("the file meta group names no transfer syntax".into())),
            Some("1.2.840.10008.1.2") => Syntax { explicit_vr: false, big_endian: false },
            Some("1.2.840.10008.1.2.2") => Syntax { explicit_vr: true, big_endian: true },
            Some(deflated::DEFLATED_EXPLICIT_LITTLE) => {
                return Err(Stop::Deflated(MetaLayout { elements, data_set_start: position as usize }));
            }
            Some(uid @ "1.2.840.10008.1.2.4.95") => {
                return Err(Stop::Invalid(format!("transfer syntax {uid} (JPIP referenced deflate) is not read")));
            }
            // Every other syntax (explicit little endian, and all the compressed ones) encodes
            // the data set in explicit VR little endian.
            Some(_) => EXPLICIT_LITTLE,
        };
        let end = self.data_set(position, None, syntax, 0)?;
        // The walk skips values it need not look at; dicom-object reads them all.
        if end > self.bytes.len() as u64 {
            return Err(Stop::NeedMore);
        }
        Ok(end)
    }

    /// The element or item header at `position`.
    fn header(&self, position: u64, syntax: Syntax) -> Step<Header> {
        let count = self.elements.get() + 1;
        if count > MOST_ELEMENTS {
            return Err(Stop::Invalid(format!("more than {MOST_ELEMENTS} elements")));
        }
        self.elements.set(count);
        let tag = Tag(self.u16_at(position, syntax)?, self.u16_at(position + 2, syntax)?);
        let defined = |length: u32| (length != UNDEFINED).then_some(u64::from(length));
        if tag.group() == 0xFFFE {
            return Ok(Header { tag, vr: VR::UN, length: defined(self.u32_at(position + 4, syntax)?), size: 8 });
        }
        if !syntax.explicit_vr {
            let vr = if tag == tags::PIXEL_DATA || (tag.group() >> 8 == 0x60 && tag.element() == 0x3000) {
                VR::OW
            } else {
                StandardDataDictionary.by_tag(tag).map_or(VR::UN, |entry| entry.vr().relaxed())
            };
            return Ok(Header { tag, vr, length: defined(self.u32_at(position + 4, syntax)?), size: 8 });
        }
        let vr_bytes = self.need(position + 4, 2)?;
        let vr = VR::from_binary([vr_bytes[0], vr_bytes[1]]).unwrap_or(VR::UN);
        use VR::*;
        if matches!(
            vr,
            AE | AS | AT | CS | DA | DS | DT | FL | FD | IS | LO | LT | PN | SH | SL | SS | ST | TM | UI | UL | US
        ) {
            Ok(Header { tag, vr, length: Some(u64::from(self.u16_at(position + 6, syntax)?)), size: 8 })
        } else {
            Ok(Header { tag, vr, length: defined(self.u32_at(position + 8, syntax)?), size: 12 })
        }
    }

    /// A defined length must end by `end` (the enclosing item's end or the file's).
    fn check_fits(&self, header: &Header, value_start: u64, end: u64) -> Step<()> {
        let length = header.length.unwrap_or(0);
        if value_start.saturating_add(length) > end {
            return Err(Stop::Invalid(format!(
                "element {} declares {length} bytes but only {} remain (truncated, or a lying length)",
                header.tag,
                end.saturating_sub(value_start)
            )));
        }
        Ok(())
    }

    /// Elements from `position` to `end` (a defined-length item), or to an item delimiter
    /// (`end` None inside a sequence), or to the file's end (the root data set, depth 0).
    fn data_set(&self, mut position: u64, end: Option<u64>, syntax: Syntax, depth: usize) -> Step<u64> {
        loop {
            let limit = end.unwrap_or(self.total);
            if position >= limit {
                if end.is_none() && depth > 0 {
                    return Err(Stop::Invalid("a sequence item has no end (truncated)".into()));
                }
                return Ok(position);
            }
            let header = self.header(position, syntax)?;
            let value_start = position + header.size;
            if depth == 0 && self.scope == Scope::Header && header.tag >= tags::PIXEL_DATA {
                return Ok(value_start);
            }
            if header.tag == ITEM_END && end.is_none() && depth > 0 {
                return Ok(value_start);
            }
            position = match header.length {
                None if header.tag == tags::PIXEL_DATA => self.fragments(value_start, syntax)?,
                None => self.sequence(value_start, None, syntax, depth + 1)?,
                Some(length) => {
                    self.check_fits(&header, value_start, limit)?;
                    if header.vr == VR::SQ {
                        self.sequence(value_start, Some(value_start + length), syntax, depth + 1)?;
                    }
                    value_start + length
                }
            };
        }
    }

    /// Items of a sequence until `end`, or until its delimiter when `end` is None.
    fn sequence(&self, mut position: u64, end: Option<u64>, syntax: Syntax, depth: usize) -> Step<u64> {
        if depth > MOST_SEQUENCE_DEPTH {
            return Err(Stop::Invalid(format!("sequences nested more than {MOST_SEQUENCE_DEPTH} deep")));
        }
        loop {
            if let Some(end) = end
                && position >= end
            {
                return Ok(end);
            }
            let item = self.header(position, syntax)?;
            let content = position + item.size;
            position = match (item.tag, item.length) {
                (SEQUENCE_END, _) if end.is_none() => return Ok(content),
                (ITEM, None) => self.data_set(content, None, syntax, depth)?,
                (ITEM, Some(length)) => {
                    self.check_fits(&item, content, end.unwrap_or(self.total))?;
                    self.data_set(content, Some(content + length), syntax, depth)?;
                    content + length
                }
                (tag, _) => {
                    return Err(Stop::Invalid(format!("a sequence holds {tag} where an item must be")));
                }
            };
        }
    }

    /// Encapsulated PixelData: defined-length fragments up to the sequence delimiter.
    fn fragments(&self, mut position: u64, syntax: Syntax) -> Step<u64> {
        loop {
            let item = self.header(position, syntax)?;
            let content = position + item.size;
            match (item.tag, item.length) {
                (SEQUENCE_END, _) => return Ok(content),
                (ITEM, Some(length)) => {
                    self.check_fits(&item, content, self.total)?;
                    position = content + length;
                }
                (tag, _) => {
                    return Err(Stop::Invalid(format!("encapsulated PixelData holds {tag} where a fragment must be")));
                }
            }
        }
    }
}

/// The PixelData length one image needs: Rows x Columns x SamplesPerPixel x BitsAllocated/8
/// x NumberOfFrames, checked for overflow.
pub(super) fn pixel_data_bytes(
    rows: usize,
    columns: usize,
    samples: usize,
    bits_allocated: usize,
    frames: usize,
) -> Option<u64> {
    [rows, columns, samples, frames]
        .iter()
        .try_fold(bits_allocated as u64, |acc, &n| acc.checked_mul(n as u64))
        .map(|bits| bits.div_ceil(8))
}

/// The decoded size of `voxels` values of `voxel_type`, checked for overflow and the ceiling.
pub(super) fn check_decoded_voxels(
    voxels: u64,
    voxel_type: VoxelType,
    limits: &ReadLimits,
    path: &Path,
) -> Result<(), VolumeError> {
    let bytes = voxels.saturating_mul(voxel_type.size_bytes() as u64);
    limits::check_ceiling(bytes, limits, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CT_SMALL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom/ct_small.dcm");
    const PHILIPS_SLICE: &str =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom/philips_phantom_5mm/I10");

    fn walk(bytes: &[u8], scope: Scope) -> Step<u64> {
        Walker::new(bytes, bytes.len() as u64, scope).file()
    }

    /// Offset of the first explicit-VR element with `tag` (little endian) after the preamble.
    fn find_tag(bytes: &[u8], tag: Tag, vr: &[u8; 2]) -> usize {
        let mut needle = tag.group().to_le_bytes().to_vec();
        needle.extend(tag.element().to_le_bytes());
        needle.extend(vr);
        (132..bytes.len() - 6).find(|&i| bytes[i..i + 6] == needle[..]).expect("tag present")
    }

    #[test]
    fn real_files_walk_to_their_end_and_headers_stop_at_pixel_data() {
        for path in [CT_SMALL, PHILIPS_SLICE] {
            let bytes = std::fs::read(path).unwrap();
            assert_eq!(walk(&bytes, Scope::Whole), Ok(bytes.len() as u64), "{path}");
            let header_end = walk(&bytes, Scope::Header).unwrap();
            assert!(header_end < 20_000, "{path}: {header_end}");
            assert_eq!(Walker::new(&bytes[..1000], bytes.len() as u64, Scope::Header).file(), Err(Stop::NeedMore));
            let limits = ReadLimits::default();
            let object = read_object(Path::new(path), Scope::Header, &limits).unwrap();
            assert!(object.get(tags::ROWS).is_some() && object.get(tags::PIXEL_DATA).is_none());
            let object = read_object(Path::new(path), Scope::Whole, &limits).unwrap();
            assert!(object.get(tags::PIXEL_DATA).is_some());
        }
    }

    #[test]
    fn a_length_beyond_the_file_is_refused_before_any_parsing() {
        let original = std::fs::read(PHILIPS_SLICE).unwrap();
        let pixel_data = find_tag(&original, tags::PIXEL_DATA, b"OW");
        let mut bytes = original.clone();
        bytes[pixel_data + 8..pixel_data + 12].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
        let Err(Stop::Invalid(problem)) = walk(&bytes, Scope::Whole) else { panic!("accepted") };
        assert!(problem.contains("(7FE0,0010) declares 4294967280 bytes"), "{problem}");
        // Before PixelData: a string element (16-bit length) made to overrun the file by a
        // cut, and a sequence item whose length overruns its sequence.
        let description = find_tag(&original, tags::SERIES_DESCRIPTION, b"LO");
        let Err(Stop::Invalid(problem)) = walk(&original[..description + 10], Scope::Header) else {
            panic!("accepted")
        };
        assert!(problem.contains("truncated") || problem.contains("remain"), "{problem}");
        let mut nested = original[..132].to_vec();
        let meta = [0x02u8, 0, 0, 0, b'U', b'L', 4, 0, 28, 0, 0, 0, 2, 0, 0x10, 0, b'U', b'I', 20, 0];
        nested.extend(meta);
        nested.extend(b"1.2.840.10008.1.2.1\0");
        // (0008,1140) SQ, undefined length, one item of length 0xFFFFFFF0.
        nested.extend([0x08, 0, 0x40, 0x11, b'S', b'Q', 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]);
        nested.extend([0xFE, 0xFF, 0x00, 0xE0, 0xF0, 0xFF, 0xFF, 0xFF]);
        let Err(Stop::Invalid(problem)) = walk(&nested, Scope::Header) else { panic!("accepted") };
        assert!(problem.contains("(FFFE,E000) declares 4294967280"), "{problem}");
    }

    #[test]
    fn a_header_without_pixel_data_is_read_whole_however_long() {
        let folder = tempfile::tempdir().unwrap();
        let mut bytes = std::fs::read(CT_SMALL).unwrap();
        let pixel_data = find_tag(&bytes, tags::PIXEL_DATA, b"OW");
        bytes.truncate(pixel_data);
        // A private OB element of 200 KB ends the file: longer than the first header read.
        bytes.extend([0x09, 0x00, 0x10, 0x10, b'O', b'B', 0, 0]);
        bytes.extend(200_000u32.to_le_bytes());
        bytes.extend(std::iter::repeat_n(7u8, 200_000));
        let path = folder.path().join("report.dcm");
        std::fs::write(&path, &bytes).unwrap();
        let object = read_object(&path, Scope::Header, &ReadLimits::default()).unwrap();
        assert!(object.get(Tag(0x0009, 0x1010)).is_some());
    }

    #[test]
    fn deep_nesting_and_missing_magic_are_refused() {
        let original = std::fs::read(CT_SMALL).unwrap();
        let mut no_magic = original.clone();
        no_magic[128] = b'X';
        assert!(matches!(walk(&no_magic, Scope::Whole), Err(Stop::Invalid(p)) if p.contains("DICM")));
        let mut deep = original[..132].to_vec();
        deep.extend([0x02u8, 0, 0, 0, b'U', b'L', 4, 0, 28, 0, 0, 0, 2, 0, 0x10, 0, b'U', b'I', 20, 0]);
        deep.extend(b"1.2.840.10008.1.2.1\0");
        for _ in 0..40 {
            deep.extend([0x08, 0, 0x40, 0x11, b'S', b'Q', 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]);
            deep.extend([0xFE, 0xFF, 0x00, 0xE0, 0xFF, 0xFF, 0xFF, 0xFF]);
        }
        assert!(matches!(walk(&deep, Scope::Whole), Err(Stop::Invalid(p)) if p.contains("nested")));
    }

    #[test]
    fn pixel_data_sizes_multiply_without_overflow() {
        assert_eq!(pixel_data_bytes(512, 512, 1, 16, 1), Some(524_288));
        assert_eq!(pixel_data_bytes(3, 3, 1, 8, 1), Some(9));
        assert_eq!(pixel_data_bytes(usize::MAX, 2, 1, 16, 1), None);
    }
}
