//! The appliance's scripts where they can run outside the image: the USB import
//! (`deploy/rootfs/usr/lib/volasso/import-volumes --from FOLDER --to FOLDER`) on a hostile
//! stick made of folders, symbolic links and FIFOs.

use std::os::unix::fs::{PermissionsExt, symlink};
use std::path::Path;

const IMPORT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/deploy/rootfs/usr/lib/volasso/import-volumes");

fn make_fifo(path: &Path) {
    let status = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(status.success());
}

/// Every entry below `folder` with its kind (`d`, `f`, `l`, `p`), sorted.
fn tree(folder: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![folder.to_path_buf()];
    while let Some(current) = stack.pop() {
        for entry in std::fs::read_dir(&current).unwrap() {
            let path = entry.unwrap().path();
            let kind = std::fs::symlink_metadata(&path).unwrap().file_type();
            let relative = path.strip_prefix(folder).unwrap().display().to_string();
            let letter = if kind.is_symlink() {
                "l"
            } else if kind.is_dir() {
                stack.push(path.clone());
                "d"
            } else if kind.is_file() {
                "f"
            } else {
                "p"
            };
            found.push(format!("{letter} {relative}"));
        }
    }
    found.sort();
    found
}

/// Symbolic links (to a file, to a folder, dangling, as `volumes/` itself), FIFOs and a name the
/// kiosk already has: only the regular files and real folders arrive, no link is copied or
/// followed, nothing outside the stick changes mode, and an existing volume is left alone.
#[test]
fn the_usb_import_copies_regular_files_and_folders_and_never_follows_a_link() {
    let work = tempfile::tempdir().unwrap();
    let (stick, target, outside) =
        (work.path().join("stick"), work.path().join("volumes"), work.path().join("outside"));
    for folder in [&stick.join("volumes/series/sub"), &target, &outside.join("secrets")] {
        std::fs::create_dir_all(folder).unwrap();
    }
    std::fs::write(outside.join("passwd"), b"root:x:0:0").unwrap();
    std::fs::write(outside.join("secrets/key"), b"secret").unwrap();
    std::fs::set_permissions(outside.join("secrets"), std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::set_permissions(outside.join("passwd"), std::fs::Permissions::from_mode(0o644)).unwrap();

    std::fs::write(stick.join("top.nii"), b"top").unwrap();
    std::fs::write(stick.join("notes.txt"), b"not a volume").unwrap();
    symlink(outside.join("passwd"), stick.join("passwd.nrrd")).unwrap();
    symlink(work.path().join("nowhere"), stick.join("dangling.nrrd")).unwrap();
    make_fifo(&stick.join("fifo.nrrd"));
    std::fs::create_dir(stick.join("folder.nrrd")).unwrap();
    std::fs::write(stick.join("volumes/a.nrrd"), b"a").unwrap();
    std::fs::write(stick.join("volumes/kept.nrrd"), b"new").unwrap();
    symlink(outside.join("secrets"), stick.join("volumes/linked-series")).unwrap();
    std::fs::write(stick.join("volumes/series/IM1.dcm"), b"1").unwrap();
    std::fs::write(stick.join("volumes/series/sub/IM2.dcm"), b"2").unwrap();
    symlink(outside.join("passwd"), stick.join("volumes/series/IM3.dcm")).unwrap();
    symlink(outside.join("secrets"), stick.join("volumes/series/secrets")).unwrap();
    make_fifo(&stick.join("volumes/series/sub/pipe.dcm"));
    // Already on the kiosk: a volume, and a link where a stick's file would land.
    std::fs::write(target.join("kept.nrrd"), b"old").unwrap();
    symlink(outside.join("passwd"), target.join("top-link.nii")).unwrap();
    std::fs::write(stick.join("top-link.nii"), b"would write through the link").unwrap();

    let output = std::process::Command::new("sh")
        .args([IMPORT, "--from", stick.to_str().unwrap(), "--to", target.to_str().unwrap()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));

    assert_eq!(
        tree(&target),
        [
            "d series",
            "d series/sub",
            "f a.nrrd",
            "f kept.nrrd",
            "f series/IM1.dcm",
            "f series/sub/IM2.dcm",
            "f top.nii",
            "l top-link.nii",
        ],
        "{stdout}"
    );
    assert_eq!(std::fs::read(target.join("kept.nrrd")).unwrap(), b"old");
    assert_eq!(std::fs::read(target.join("series/sub/IM2.dcm")).unwrap(), b"2");
    assert_eq!(std::fs::read(outside.join("passwd")).unwrap(), b"root:x:0:0");
    let mode = |path: &Path| std::fs::metadata(path).unwrap().permissions().mode() & 0o777;
    assert_eq!((mode(&outside.join("secrets")), mode(&outside.join("passwd"))), (0o755, 0o644));
    assert_eq!((mode(&target.join("series")), mode(&target.join("a.nrrd"))), (0o700, 0o600));
    for skipped in
        ["passwd.nrrd (a symbolic link)", "linked-series (a symbolic link)", "fifo.nrrd (not a regular file)"]
    {
        assert!(stdout.contains(&format!("skipped {skipped}")), "{skipped}: {stdout}");
    }
    assert!(stdout.contains("skipped ./IM3.dcm in series"), "{stdout}");
    assert!(stdout.contains("skipped ./sub/pipe.dcm in series"), "{stdout}");
    assert!(stdout.contains("3 imported, "), "{stdout}");
    assert!(stdout.contains(", 0 failed"), "{stdout}");
}
