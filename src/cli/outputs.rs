//! Outputs never written over inputs: each command lists the files it reads and the files it
//! will write, and [`check`] refuses, before any work, an output that names an input (the same
//! path, a symbolic link to it or a hard link of it), two outputs that name one file, an
//! output that is a folder, and an output inside a folder the command reads (a DICOM series).
//! Once a volume is open, [`check_mapped`] compares the outputs with every file the process
//! has mapped: a detached data file (NRRD `data file`, MetaImage `ElementDataFile`, NIfTI
//! `.img`) or the import cache the voxels are read from.
//!
//! Files are compared by canonical path and, where they exist, by device and inode.
//!
//! Never: creates, removes or opens anything for writing.

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// Why a command refuses its output paths.
#[derive(Debug, thiserror::Error)]
pub enum PathClash {
    /// An output names a file the command reads.
    #[error("the {output} would write over the {input}; choose another output path: {}", path.display())]
    OutputIsInput {
        /// What the output is ("label volume (--out)").
        output: &'static str,
        /// What the input is ("volume").
        input: &'static str,
        /// The path of the output as given.
        path: PathBuf,
    },
    /// Two outputs name the same file.
    #[error("the {first} and the {second} are the same file; give each its own path: {}", path.display())]
    SameOutput {
        /// The first output.
        first: &'static str,
        /// The second output.
        second: &'static str,
        /// The path of the second as given.
        path: PathBuf,
    },
    /// An output names a folder.
    #[error("the {output} is a folder; name a file (e.g. a file in that folder): {}", path.display())]
    OutputIsFolder {
        /// What the output is.
        output: &'static str,
        /// The folder.
        path: PathBuf,
    },
    /// An output lies inside a folder the command reads.
    #[error("the {output} would be written inside the folder of the {input}; write it elsewhere: {}", path.display())]
    OutputInInputFolder {
        /// What the output is.
        output: &'static str,
        /// What the folder is.
        input: &'static str,
        /// The path of the output as given.
        path: PathBuf,
    },
}

/// Where a path leads: its canonical path (the parent's, joined with the name, when it does
/// not exist yet), and its device and inode when it exists.
struct Identity {
    canonical: PathBuf,
    file: Option<(u64, u64)>,
    is_dir: bool,
}

fn identity(path: &Path) -> Option<Identity> {
    if let Ok(metadata) = std::fs::metadata(path) {
        let canonical = std::fs::canonicalize(path).ok()?;
        return Some(Identity { canonical, file: Some((metadata.dev(), metadata.ino())), is_dir: metadata.is_dir() });
    }
    // Not there yet (or a dangling link): where it would be created.
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let canonical = std::fs::canonicalize(parent).ok()?.join(name);
    Some(Identity { canonical, file: None, is_dir: false })
}

fn same(a: &Identity, b: &Identity) -> bool {
    match (a.file, b.file) {
        (Some(a), Some(b)) => a == b,
        _ => a.canonical == b.canonical,
    }
}

/// Checks the `outputs` a command will write against the `inputs` it reads and against each
/// other; each path comes with what it is, for the message ("label volume (--out)").
pub fn check(inputs: &[(&'static str, &Path)], outputs: &[(&'static str, &Path)]) -> Result<(), PathClash> {
    // An input that is not there (`demo`, or a typo the reader will report) cannot be written over.
    let inputs: Vec<(&str, Identity)> = inputs
        .iter()
        .filter(|(_, path)| path.exists())
        .filter_map(|&(what, path)| Some((what, identity(path)?)))
        .collect();
    let mut checked: Vec<(&str, Identity)> = Vec::new();
    for &(output, path) in outputs {
        // An output whose folder does not exist cannot clash; writing it fails later and says so.
        let Some(found) = identity(path) else { continue };
        if found.is_dir {
            return Err(PathClash::OutputIsFolder { output, path: path.to_path_buf() });
        }
        for (input, read) in &inputs {
            if same(&found, read) {
                return Err(PathClash::OutputIsInput { output, input, path: path.to_path_buf() });
            }
            if read.is_dir && found.canonical.starts_with(&read.canonical) {
                return Err(PathClash::OutputInInputFolder { output, input, path: path.to_path_buf() });
            }
        }
        if let Some((first, _)) = checked.iter().find(|(_, other)| same(&found, other)) {
            return Err(PathClash::SameOutput { first, second: output, path: path.to_path_buf() });
        }
        checked.push((output, found));
    }
    Ok(())
}

/// Checks the `outputs` against every file this process has mapped into memory (Linux
/// `/proc/self/maps`): the voxels of an open volume are read from a mapped file, which may be
/// a data file its header names or the import cache. `input` says what those files are.
pub fn check_mapped(input: &'static str, outputs: &[(&'static str, &Path)]) -> Result<(), PathClash> {
    let Ok(maps) = std::fs::read_to_string("/proc/self/maps") else { return Ok(()) };
    let mapped = mapped_files(&maps);
    for &(output, path) in outputs {
        let Ok(metadata) = std::fs::metadata(path) else { continue };
        let (major, minor) = (libc::major(metadata.dev()), libc::minor(metadata.dev()));
        if mapped.contains(&(u64::from(major), u64::from(minor), metadata.ino())) {
            return Err(PathClash::OutputIsInput { output, input, path: path.to_path_buf() });
        }
    }
    Ok(())
}

/// (device major, device minor, inode) of each file mapping in `/proc/self/maps` text.
fn mapped_files(maps: &str) -> Vec<(u64, u64, u64)> {
    maps.lines()
        .filter_map(|line| {
            let mut fields = line.split_whitespace();
            let device = fields.nth(3)?;
            let inode: u64 = fields.next()?.parse().ok()?;
            let (major, minor) = device.split_once(':')?;
            let major = u64::from_str_radix(major, 16).ok()?;
            let minor = u64::from_str_radix(minor, 16).ok()?;
            (inode != 0).then_some((major, minor, inode))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_names_an_input_by_path_link_or_hard_link_is_refused() {
        let folder = tempfile::tempdir().unwrap();
        let volume = folder.path().join("ct.nrrd");
        let strokes = folder.path().join("s.json");
        std::fs::write(&volume, b"NRRD0004\n").unwrap();
        std::fs::write(&strokes, b"{}").unwrap();
        let inputs = [("volume", volume.as_path()), ("strokes file", strokes.as_path())];
        let refused = |out: &Path| check(&inputs, &[("label volume (--out)", out)]).unwrap_err();
        assert!(matches!(refused(&volume), PathClash::OutputIsInput { input: "volume", .. }));
        // The same file by another spelling, a symbolic link and a hard link.
        let dotted = folder.path().join(".").join("s.json");
        assert!(matches!(refused(&dotted), PathClash::OutputIsInput { input: "strokes file", .. }));
        let link = folder.path().join("link.nrrd");
        std::os::unix::fs::symlink(&volume, &link).unwrap();
        assert!(matches!(refused(&link), PathClash::OutputIsInput { input: "volume", .. }));
        let hard = folder.path().join("hard.nrrd");
        std::fs::hard_link(&volume, &hard).unwrap();
        assert!(matches!(refused(&hard), PathClash::OutputIsInput { input: "volume", .. }));
        let message = refused(&volume).to_string();
        assert!(message.starts_with("the label volume (--out) would write over the volume"), "{message}");
        assert!(message.ends_with(&volume.display().to_string()), "{message}");
        // A new file beside them is fine.
        check(&inputs, &[("label volume (--out)", &folder.path().join("labels.nrrd"))]).unwrap();
    }

    #[test]
    fn two_outputs_in_one_file_a_folder_and_a_file_in_an_input_folder_are_refused() {
        let folder = tempfile::tempdir().unwrap();
        let out = folder.path().join("labels.nrrd");
        let error = check(&[], &[("label volume", &out), ("RGBA volume", &out)]).unwrap_err();
        assert!(matches!(error, PathClash::SameOutput { first: "label volume", second: "RGBA volume", .. }));
        let error = check(&[], &[("imported volume (--out)", folder.path())]).unwrap_err();
        assert!(matches!(error, PathClash::OutputIsFolder { .. }), "{error}");
        assert!(error.to_string().contains("is a folder"), "{error}");
        let series = folder.path().join("series");
        std::fs::create_dir(&series).unwrap();
        let error = check(&[("DICOM series", &series)], &[("out", &series.join("v.nrrd"))]).unwrap_err();
        assert!(matches!(error, PathClash::OutputInInputFolder { .. }), "{error}");
    }

    #[test]
    fn a_mapped_file_is_an_input() {
        let folder = tempfile::tempdir().unwrap();
        let data = folder.path().join("ct.raw");
        std::fs::write(&data, vec![7u8; 8192]).unwrap();
        let other = folder.path().join("other.raw");
        std::fs::write(&other, b"x").unwrap();
        check_mapped("volume's data", &[("out", &data)]).unwrap();
        let file = std::fs::File::open(&data).unwrap();
        // SAFETY: the file is private to this test and not changed while mapped.
        let map = unsafe { memmap2::Mmap::map(&file) }.unwrap();
        let error = check_mapped("volume's data", &[("out", &other), ("out", &data)]).unwrap_err();
        assert!(matches!(error, PathClash::OutputIsInput { input: "volume's data", .. }), "{error}");
        drop(map);
    }
}
