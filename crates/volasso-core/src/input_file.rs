//! Reading the small text files a user names: strokes files, touch scripts and event
//! recordings. Each is read only from a regular file (a FIFO would block the reader for ever,
//! `/dev/zero` would fill memory), never past a ceiling on its size, and a file that is not
//! UTF-8 is refused for its encoding, with a guess at which one it is (UTF-16 from its
//! byte-order mark or its zero bytes, else a single-byte code page such as Latin-1).
//!
//! Entry points: [`read_text`], [`read_bytes`]. Never: parses what it reads, or follows a file past its ceiling.

use std::io::Read;
use std::path::{Path, PathBuf};

/// Why a text input could not be read.
#[derive(Debug, thiserror::Error)]
pub enum InputFileError {
    /// The file cannot be opened or read.
    #[error("cannot read the {what}: {source}, in {}", path.display())]
    Io {
        /// What the file is for ("strokes file", "touch script").
        what: &'static str,
        /// The underlying error.
        source: std::io::Error,
        /// The file.
        path: PathBuf,
    },
    /// The path names a FIFO, a device, a socket or a folder.
    #[error("the {what} is {kind}, not a regular file: {}", path.display())]
    NotRegular {
        /// What the file is for.
        what: &'static str,
        /// What the path names instead ("a folder", "a FIFO", ...).
        kind: &'static str,
        /// The path.
        path: PathBuf,
    },
    /// The file is larger than its ceiling.
    #[error("the {what} has {size_bytes} bytes, more than the {limit_bytes} allowed, in {}", path.display())]
    TooLarge {
        /// What the file is for.
        what: &'static str,
        /// Its size (at least; a file that grew while read may be larger).
        size_bytes: u64,
        /// The ceiling.
        limit_bytes: u64,
        /// The file.
        path: PathBuf,
    },
    /// The bytes are not UTF-8.
    #[error(
        "the {what} is not UTF-8 text (it looks like {encoding}, from byte {offset}): save it as UTF-8, in {}",
        path.display()
    )]
    NotUtf8 {
        /// What the file is for.
        what: &'static str,
        /// The offset of the first byte that is not UTF-8 text (invalid, or a zero byte).
        offset: usize,
        /// The encoding the bytes look like.
        encoding: &'static str,
        /// The file.
        path: PathBuf,
    },
}

/// What a path names, in words, when it is not a regular file.
fn kind_of(file_type: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if file_type.is_dir() {
        "a folder"
    } else if file_type.is_fifo() {
        "a FIFO"
    } else if file_type.is_char_device() {
        "a character device"
    } else if file_type.is_block_device() {
        "a block device"
    } else if file_type.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

/// The bytes of the regular file at `path` (symbolic links followed), at most `limit_bytes`;
/// `what` names the file in errors ("event recording"). A FIFO or device is refused before it
/// is opened, so the call never blocks on one.
pub fn read_bytes(path: &Path, what: &'static str, limit_bytes: u64) -> Result<Vec<u8>, InputFileError> {
    let io = |source| InputFileError::Io { what, source, path: path.to_path_buf() };
    let not_regular = |metadata: &std::fs::Metadata| InputFileError::NotRegular {
        what,
        kind: kind_of(metadata.file_type()),
        path: path.to_path_buf(),
    };
    let too_large = |size_bytes| InputFileError::TooLarge { what, size_bytes, limit_bytes, path: path.to_path_buf() };
    let metadata = std::fs::metadata(path).map_err(io)?;
    if !metadata.is_file() {
        return Err(not_regular(&metadata));
    }
    if metadata.len() > limit_bytes {
        return Err(too_large(metadata.len()));
    }
    let file = std::fs::File::open(path).map_err(io)?;
    // The path may have been replaced between the two looks: the open file is checked again.
    let opened = file.metadata().map_err(io)?;
    if !opened.is_file() {
        return Err(not_regular(&opened));
    }
    let mut bytes = Vec::with_capacity(opened.len().min(limit_bytes) as usize);
    file.take(limit_bytes + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// The text of the regular file at `path`, as [`read_bytes`] reads it, refused when it is not
/// UTF-8 or holds a zero byte (never text; UTF-16 of ASCII is half zero bytes).
pub fn read_text(path: &Path, what: &'static str, limit_bytes: u64) -> Result<String, InputFileError> {
    let bytes = read_bytes(path, what, limit_bytes)?;
    let not_utf8 = |offset, bytes: &[u8]| InputFileError::NotUtf8 {
        what,
        offset,
        encoding: guess_encoding(bytes),
        path: path.to_path_buf(),
    };
    let text =
        String::from_utf8(bytes).map_err(|error| not_utf8(error.utf8_error().valid_up_to(), error.as_bytes()))?;
    match text.bytes().position(|b| b == 0) {
        Some(offset) => Err(not_utf8(offset, text.as_bytes())),
        None => Ok(text),
    }
}

/// Which encoding bytes that are not UTF-8 look like.
fn guess_encoding(bytes: &[u8]) -> &'static str {
    if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        return "UTF-16 (it starts with a UTF-16 byte-order mark)";
    }
    // Text in UTF-16 without a mark has a zero byte beside nearly every ASCII character.
    let zeros = bytes.iter().take(4096).filter(|&&b| b == 0).count();
    if zeros * 4 >= bytes.len().min(4096) {
        return "UTF-16 (every other byte is zero)";
    }
    "a single-byte code page such as Latin-1 or Windows-1252"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_regular_utf8_file() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("a.txt");
        std::fs::write(&path, "tap Start\n").unwrap();
        assert_eq!(read_text(&path, "touch script", 100).unwrap(), "tap Start\n");
    }

    #[test]
    fn refuses_folders_fifos_devices_and_large_files_without_reading_them() {
        let folder = tempfile::tempdir().unwrap();
        let error = read_text(folder.path(), "strokes file", 100).unwrap_err();
        assert!(matches!(error, InputFileError::NotRegular { kind: "a folder", .. }), "{error}");
        let fifo = folder.path().join("fifo");
        let name = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: `name` is a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
        // Opening a FIFO without a writer would block: the check comes first.
        let error = read_text(&fifo, "strokes file", 100).unwrap_err();
        assert!(matches!(error, InputFileError::NotRegular { kind: "a FIFO", .. }), "{error}");
        let error = read_text(Path::new("/dev/zero"), "touch script", 100).unwrap_err();
        assert!(matches!(error, InputFileError::NotRegular { kind: "a character device", .. }), "{error}");
        let large = folder.path().join("large.json");
        std::fs::write(&large, vec![b' '; 101]).unwrap();
        let error = read_text(&large, "strokes file", 100).unwrap_err();
        assert!(matches!(error, InputFileError::TooLarge { size_bytes: 101, limit_bytes: 100, .. }), "{error}");
    }

    #[test]
    fn names_the_encoding_of_text_that_is_not_utf8() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("s.json");
        let utf16: Vec<u8> =
            [0xff, 0xfe].into_iter().chain("{\"a\": 1}".encode_utf16().flat_map(u16::to_le_bytes)).collect();
        std::fs::write(&path, &utf16).unwrap();
        let error = read_text(&path, "strokes file", 1000).unwrap_err();
        assert!(matches!(error, InputFileError::NotUtf8 { offset: 0, .. }), "{error}");
        assert!(error.to_string().contains("UTF-16"), "{error}");
        // Without a mark, UTF-16 of ASCII is valid UTF-8 with a zero byte before each character.
        let no_mark: Vec<u8> = "{\"a\": 1}".encode_utf16().flat_map(u16::to_be_bytes).collect();
        std::fs::write(&path, &no_mark).unwrap();
        let error = read_text(&path, "strokes file", 1000).unwrap_err();
        assert!(matches!(error, InputFileError::NotUtf8 { offset: 0, .. }), "{error}");
        assert!(error.to_string().contains("UTF-16"), "{error}");
        std::fs::write(&path, b"{\"name\": \"os f\xe9mur\"}").unwrap();
        let error = read_text(&path, "strokes file", 1000).unwrap_err();
        assert!(matches!(error, InputFileError::NotUtf8 { offset: 14, .. }), "{error}");
        assert!(error.to_string().contains("Latin-1"), "{error}");
    }
}
