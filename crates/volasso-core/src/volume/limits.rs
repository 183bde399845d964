//! What a reader may take from a file: which files it opens at all, where a detached data file
//! may lie, and how many bytes it may decode into memory. Every reader checks a header's claims
//! here *before* it allocates, so a file of a few hundred bytes that promises a terabyte gets an
//! error, not an abort (`interfaces.md`: bad input gives one clear error).
//!
//! * Regular files only ([`open_regular`]): a device (`/dev/zero`), a pipe or a socket is never
//!   opened, so nothing reads forever or blocks.
//! * Detached data files ([`detached_data_file`]: NRRD `data file`, MetaImage
//!   `ElementDataFile`, the `.img` of a NIfTI pair) lie in or below their header's folder after
//!   symbolic links are resolved, unless [`ReadLimits::allow_external_data`] says otherwise: a
//!   header on a USB stick cannot point at `/etc/passwd`.
//! * Decoded data (gzip, zlib, ASCII) is bounded twice before a byte is allocated: by what the
//!   encoded bytes can hold (deflate expands at most [`DEFLATE_MOST_EXPANSION`]-fold; an ASCII
//!   value takes at least two characters), and by a ceiling, [`ReadLimits::max_decoded_bytes`]
//!   (default [`default_max_decoded_bytes`]). It is then decoded into a buffer reserved with
//!   `try_reserve_exact` and filled as the data arrives ([`decode_exactly`]), so memory follows
//!   what the stream really holds, a short stream is an error naming expected and found bytes,
//!   and a longer one is an error too (its header lies about the sizes or the type, the rule
//!   `raw` applies to raw files and [`super::VoxelBytes::map_final_region`] to mapped data).
//!   Data a header declares compressed must start with a gzip or zlib header
//!   ([`check_compressed`]), so raw data under such a header is named as such.
//!
//! Never: guesses a size, or reads past what a header promises plus one byte.

use super::VolumeError;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The most a deflate stream (gzip, zlib) can expand: 258 bytes from one 2-bit code at best,
/// 1032 to 1 in the limit (RFC 1951; zlib's technical details give the same figure).
pub const DEFLATE_MOST_EXPANSION: u64 = 1032;

/// The largest default ceiling on decoded bytes: 16 GiB.
pub const DEFAULT_CEILING_CAP_BYTES: u64 = 16 << 30;

/// What readers may do; built from [`super::OpenOptions`] by [`super::open()`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// The most bytes a compressed or text encoding may decode into memory.
    pub max_decoded_bytes: u64,
    /// Read detached data files outside their header's folder.
    pub allow_external_data: bool,
}

impl Default for ReadLimits {
    fn default() -> ReadLimits {
        ReadLimits { max_decoded_bytes: default_max_decoded_bytes(), allow_external_data: false }
    }
}

/// The default ceiling on decoded bytes: the smallest of 16 GiB, the machine's memory
/// (`MemTotal` in `/proc/meminfo`) and the memory limit of the process's cgroup (`memory.max`,
/// e.g. a systemd unit's `MemoryMax`). Decoded data lives in RAM until the import cache has it
/// on disk, so it can never usefully exceed the memory the process may use; the 16 GiB cap
/// keeps a lying header on a large workstation from paging everything out before it is found
/// out. Where neither file can be read, 16 GiB.
pub fn default_max_decoded_bytes() -> u64 {
    let mut ceiling = DEFAULT_CEILING_CAP_BYTES;
    if let Some(total) = mem_total_bytes() {
        ceiling = ceiling.min(total);
    }
    if let Some(limit) = cgroup_memory_max_bytes() {
        ceiling = ceiling.min(limit);
    }
    ceiling
}

fn mem_total_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|line| line.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The smallest `memory.max` of the process's cgroup (v2) and its ancestors, if any is set.
fn cgroup_memory_max_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let relative = text.lines().find_map(|line| line.strip_prefix("0::"))?;
    let mut folder = Path::new("/sys/fs/cgroup").join(relative.trim_start_matches('/'));
    let mut smallest: Option<u64> = None;
    loop {
        if let Ok(value) = std::fs::read_to_string(folder.join("memory.max"))
            && let Ok(limit) = value.trim().parse::<u64>()
        {
            smallest = Some(smallest.map_or(limit, |s| s.min(limit)));
        }
        if folder == Path::new("/sys/fs/cgroup") || !folder.pop() {
            return smallest;
        }
    }
}

/// Opens `path` for reading if it is a regular file (following symbolic links), with its length.
pub fn open_regular(path: &Path) -> Result<(std::fs::File, u64), VolumeError> {
    let metadata = std::fs::metadata(path).map_err(|e| VolumeError::io(e, path))?;
    if !metadata.is_file() {
        return Err(VolumeError::NotRegularFile { path: path.to_path_buf() });
    }
    let file = std::fs::File::open(path).map_err(|e| VolumeError::io(e, path))?;
    let length = file.metadata().map_err(|e| VolumeError::io(e, path))?.len();
    Ok((file, length))
}

/// The first `limit` bytes of a regular file (a header).
pub fn read_head(path: &Path, limit: u64) -> Result<Vec<u8>, VolumeError> {
    let (file, _) = open_regular(path)?;
    let mut head = Vec::new();
    file.take(limit).read_to_end(&mut head).map_err(|e| VolumeError::io(e, path))?;
    Ok(head)
}

/// Resolves a detached data file named in the header at `header`: relative to the header's
/// folder, symbolic links resolved, a regular file, and (unless `limits` allow external data)
/// inside the header's folder, or inside the folder of the file a linked header points to.
/// Returns the resolved path, which is what the reader then opens.
pub fn detached_data_file(header: &Path, name: &Path, limits: &ReadLimits) -> Result<PathBuf, VolumeError> {
    let folder = match header.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let joined = folder.join(name);
    let resolved = std::fs::canonicalize(&joined).map_err(|e| VolumeError::io(e, &joined))?;
    if !limits.allow_external_data {
        let canonical_folder = std::fs::canonicalize(folder).map_err(|e| VolumeError::io(e, folder))?;
        let target_folder =
            std::fs::canonicalize(header).ok().and_then(|target| target.parent().map(Path::to_path_buf));
        let inside = resolved.starts_with(&canonical_folder)
            || target_folder.is_some_and(|target_folder| resolved.starts_with(target_folder));
        if !inside {
            return Err(VolumeError::ExternalData {
                data_file: resolved,
                folder: canonical_folder,
                path: header.to_path_buf(),
            });
        }
    }
    let metadata = std::fs::metadata(&resolved).map_err(|e| VolumeError::io(e, &resolved))?;
    if !metadata.is_file() {
        return Err(VolumeError::NotRegularFile { path: resolved });
    }
    Ok(resolved)
}

/// Refuses `bytes` of decoded data above the ceiling.
pub fn check_ceiling(bytes: u64, limits: &ReadLimits, path: &Path) -> Result<(), VolumeError> {
    if bytes > limits.max_decoded_bytes {
        return Err(VolumeError::TooLarge { bytes, ceiling: limits.max_decoded_bytes, path: path.to_path_buf() });
    }
    Ok(())
}

/// An empty vector with room for exactly `bytes` bytes, or an error instead of an abort.
pub fn reserve(bytes: usize, path: &Path) -> Result<Vec<u8>, VolumeError> {
    let mut buffer = Vec::new();
    buffer
        .try_reserve_exact(bytes)
        .map_err(|_| VolumeError::OutOfMemory { bytes: bytes as u64, path: path.to_path_buf() })?;
    Ok(buffer)
}

/// `bytes` zeroed bytes, or an error instead of an abort.
pub fn zeroed(bytes: usize, path: &Path) -> Result<Vec<u8>, VolumeError> {
    let mut buffer = reserve(bytes, path)?;
    buffer.resize(bytes, 0);
    Ok(buffer)
}

/// Refuses a deflate stream of `compressed` bytes that is to yield `skip + expected` bytes
/// when no deflate stream that short can.
pub fn check_deflate_can_hold(skip: u64, expected: u64, compressed: u64, path: &Path) -> Result<(), VolumeError> {
    let most = compressed.saturating_mul(DEFLATE_MOST_EXPANSION);
    let wanted = skip.saturating_add(expected);
    if wanted > most {
        return Err(VolumeError::CannotHold {
            expected: wanted,
            encoding: "compressed",
            available: compressed,
            most,
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

/// The wrappers a deflate stream comes in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Deflate {
    /// gzip (RFC 1952): magic bytes 1f 8b.
    Gzip,
    /// zlib (RFC 1950): a method byte of 8 (deflate) whose two header bytes are a multiple of 31.
    Zlib,
}

/// Which wrapper `start` (the first bytes of the compressed data, at least two) begins with;
/// `None` for neither (the data are not compressed, whatever the header says).
pub fn deflate_wrapper(start: &[u8]) -> Option<Deflate> {
    match start {
        [0x1f, 0x8b, ..] => Some(Deflate::Gzip),
        [method, flags, ..]
            if method & 0x0f == 8 && method >> 4 <= 7 && (u16::from(*method) * 256 + u16::from(*flags)) % 31 == 0 =>
        {
            Some(Deflate::Zlib)
        }
        _ => None,
    }
}

/// Refuses compressed data whose first bytes (`reader`'s buffer, looked at, not consumed) are
/// not one of `accepted` wrappers, naming the header's `declaration` and the bytes found, so
/// that raw data under a header that says "compressed" is not blamed as corrupt gzip. Returns
/// the wrapper found, or `None` when fewer than two bytes are there (left to the decoder, which
/// reports them short).
pub fn check_compressed(
    reader: &mut impl std::io::BufRead,
    accepted: &[Deflate],
    declaration: &'static str,
    path: &Path,
) -> Result<Option<Deflate>, VolumeError> {
    let start = reader.fill_buf().map_err(|e| VolumeError::io(e, path))?;
    if start.len() < 2 {
        return Ok(None);
    }
    match deflate_wrapper(start) {
        Some(wrapper) if accepted.contains(&wrapper) => Ok(Some(wrapper)),
        _ => Err(VolumeError::NotCompressed {
            declaration,
            start: start.iter().take(8).map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" "),
            path: path.to_path_buf(),
        }),
    }
}

/// Decodes `skip` bytes (discarded) and then exactly `expected` bytes from `decoder`, checked
/// against the ceiling first; a short stream is [`VolumeError::DataSize`], a corrupt one
/// [`VolumeError::Decompress`], and one more byte is [`VolumeError::ExtraData`] (as bytes after
/// mapped data are, [`super::VoxelBytes::map_final_region`]). Memory grows as the data
/// arrives, never past `expected`.
pub fn decode_exactly(
    mut decoder: impl Read,
    skip: u64,
    expected: usize,
    limits: &ReadLimits,
    path: &Path,
) -> Result<Vec<u8>, VolumeError> {
    check_ceiling(expected as u64, limits, path)?;
    let decompress = |source: std::io::Error| VolumeError::Decompress { source, path: path.to_path_buf() };
    let skipped = std::io::copy(&mut (&mut decoder).take(skip), &mut std::io::sink()).map_err(decompress)?;
    if skipped < skip {
        return Err(VolumeError::DataSize { expected, found: 0, path: path.to_path_buf() });
    }
    let mut data = reserve(expected, path)?;
    (&mut decoder).take(expected as u64).read_to_end(&mut data).map_err(decompress)?;
    if data.len() < expected {
        return Err(VolumeError::DataSize { expected, found: data.len(), path: path.to_path_buf() });
    }
    let mut probe = [0u8; 1];
    loop {
        match decoder.read(&mut probe) {
            Ok(0) => return Ok(data),
            Ok(_) => return Err(VolumeError::ExtraData { expected: expected as u64, path: path.to_path_buf() }),
            Err(error) if error.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(error) => return Err(decompress(error)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut encoder, bytes).unwrap();
        encoder.finish().unwrap()
    }

    fn decode(compressed: &[u8], skip: u64, expected: usize) -> Result<Vec<u8>, VolumeError> {
        let limits = ReadLimits { max_decoded_bytes: 1 << 20, allow_external_data: false };
        decode_exactly(flate2::read::MultiGzDecoder::new(compressed), skip, expected, &limits, Path::new("t"))
    }

    #[test]
    fn decoding_stops_at_the_promise_and_names_short_and_long_streams() {
        let data: Vec<u8> = (0..=255u8).cycle().take(1000).collect();
        let compressed = gzip(&data);
        assert_eq!(decode(&compressed, 0, 1000).unwrap(), data);
        assert_eq!(decode(&compressed, 10, 990).unwrap(), data[10..]);
        assert!(matches!(decode(&compressed, 0, 600), Err(VolumeError::ExtraData { expected: 600, .. })));
        assert!(matches!(decode(&compressed, 0, 1001), Err(VolumeError::DataSize { expected: 1001, found: 1000, .. })));
        assert!(matches!(decode(&compressed, 2000, 10), Err(VolumeError::DataSize { found: 0, .. })));
        assert!(matches!(decode(&compressed, 0, (1 << 20) + 1), Err(VolumeError::TooLarge { ceiling: 1048576, .. })));
        assert!(matches!(decode(&compressed[..40], 0, 1000), Err(VolumeError::Decompress { .. })));
    }

    #[test]
    fn wrappers_are_told_from_their_first_bytes() {
        let zlib = {
            let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
            std::io::Write::write_all(&mut encoder, b"voxels").unwrap();
            encoder.finish().unwrap()
        };
        assert_eq!(deflate_wrapper(&gzip(b"voxels")), Some(Deflate::Gzip));
        assert_eq!(deflate_wrapper(&zlib), Some(Deflate::Zlib));
        for raw in [&[7u8, 7, 7, 7][..], &[0, 0], &[0x78, 0x00], b"NRRD", &[0x1f, 0x8c]] {
            assert_eq!(deflate_wrapper(raw), None, "{raw:?}");
            let error =
                check_compressed(&mut &raw[..], &[Deflate::Gzip, Deflate::Zlib], "encoding: gzip", Path::new("t"))
                    .unwrap_err();
            assert!(error.to_string().contains("not compressed as 'encoding: gzip' declares"), "{error}");
        }
        let only_gzip = check_compressed(&mut &zlib[..], &[Deflate::Gzip], "encoding: gzip", Path::new("t"));
        assert!(matches!(only_gzip, Err(VolumeError::NotCompressed { .. })));
        assert_eq!(check_compressed(&mut &[0x1f][..], &[Deflate::Gzip], "x", Path::new("t")).unwrap(), None);
    }

    #[test]
    fn deflate_plausibility_and_allocation_failures_are_errors() {
        assert!(check_deflate_can_hold(0, 1032, 1, Path::new("t")).is_ok());
        assert!(matches!(
            check_deflate_can_hold(1, 1032, 1, Path::new("t")),
            Err(VolumeError::CannotHold { most: 1032, .. })
        ));
        assert!(check_deflate_can_hold(u64::MAX, u64::MAX, 1, Path::new("t")).is_err());
        assert!(matches!(reserve(usize::MAX, Path::new("t")), Err(VolumeError::OutOfMemory { .. })));
    }

    #[test]
    fn the_default_ceiling_is_positive_and_at_most_16_gib() {
        let ceiling = default_max_decoded_bytes();
        assert!(ceiling > 0 && ceiling <= DEFAULT_CEILING_CAP_BYTES, "{ceiling}");
    }

    #[test]
    fn data_files_stay_beside_their_header_unless_allowed() {
        let folder = tempfile::tempdir().unwrap();
        let inner = folder.path().join("scan");
        std::fs::create_dir_all(inner.join("below")).unwrap();
        std::fs::write(inner.join("below/data.raw"), [0u8; 4]).unwrap();
        std::fs::write(folder.path().join("outside.raw"), [0u8; 4]).unwrap();
        std::os::unix::fs::symlink(folder.path().join("outside.raw"), inner.join("link.raw")).unwrap();
        let header = inner.join("v.nhdr");
        let strict = ReadLimits { max_decoded_bytes: 1 << 20, allow_external_data: false };
        let relaxed = ReadLimits { allow_external_data: true, ..strict };
        assert!(detached_data_file(&header, Path::new("below/data.raw"), &strict).is_ok());
        for name in ["../outside.raw", "link.raw", "/etc/passwd"] {
            let error = detached_data_file(&header, Path::new(name), &strict).unwrap_err();
            assert!(matches!(error, VolumeError::ExternalData { .. }), "{name}: {error}");
            assert!(error.to_string().contains("--allow-external-data"), "{error}");
        }
        assert!(detached_data_file(&header, Path::new("../outside.raw"), &relaxed).is_ok());
        let device = detached_data_file(&header, Path::new("/dev/zero"), &relaxed).unwrap_err();
        assert!(matches!(device, VolumeError::NotRegularFile { .. }), "{device}");
        assert!(matches!(open_regular(Path::new("/dev/zero")), Err(VolumeError::NotRegularFile { .. })));
    }
}
