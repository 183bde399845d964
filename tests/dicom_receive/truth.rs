//! The sender is told the truth: a data set the kiosk could not read (pixel data cut to half
//! its length, a Rows that does not match the pixel data) is answered with a failure status
//! and an Error Comment, never success; an image whose SOP Instance UID is not a valid UID
//! (as pydicom's `bad_sequence.dcm`) but that reads is stored.

use super::{Scp, dcmtk_available, series_files, text};
use crate::support::data;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A copy of the Philips image I10 as `name` in `folder`, changed by `dcmodify` arguments.
fn modified_copy(folder: &Path, name: &str, changes: &[&str]) -> PathBuf {
    let copy = folder.join(name);
    std::fs::copy(data("dicom/philips_phantom_5mm/I10"), &copy).unwrap();
    if !changes.is_empty() {
        let modified = Command::new("dcmodify").arg("-nb").args(changes).arg(&copy).output().unwrap();
        assert!(modified.status.success(), "{}", String::from_utf8_lossy(&modified.stderr));
    }
    copy
}

/// A copy of I10 whose Pixel Data element holds half its bytes (length and file cut to match:
/// a well-formed file that dcmtk sends as it is).
fn half_pixel_data(folder: &Path) -> PathBuf {
    let mut bytes = std::fs::read(data("dicom/philips_phantom_5mm/I10")).unwrap();
    // Explicit VR Little Endian: (7FE0,0010) OW, two reserved bytes, a 4-byte length.
    let header = [0xE0, 0x7F, 0x10, 0x00, b'O', b'W', 0, 0];
    let at = bytes.windows(8).rposition(|window| window == header).expect("a Pixel Data element");
    let length = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
    assert_eq!(length, 512 * 512 * 2);
    bytes[at + 8..at + 12].copy_from_slice(&(length / 2).to_le_bytes());
    bytes.truncate(at + 12 + (length / 2) as usize);
    let path = folder.join("half.dcm");
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn data_sets_the_kiosk_cannot_read_are_answered_with_a_failure_and_a_comment() {
    if !dcmtk_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    let half = half_pixel_data(folder.path());
    let lying_rows = modified_copy(folder.path(), "rows.dcm", &["-m", "(0028,0010)=600"]);
    let scp = Scp::start(&[]);
    for (file, expected) in [(&half, "PixelData holds 262144 bytes"), (&lying_rows, "Rows 600")] {
        // -d prints the response's status and its Error Comment.
        let store = scp.client("storescu", &["-d"], std::slice::from_ref(file));
        let said = text(&store);
        assert!(!store.status.success(), "storescu exited with success: {said}");
        assert!(said.contains("DIMSE Status                  : 0xc000: Error: Cannot understand"), "{said}");
        let comment = said.lines().find(|line| line.contains("ErrorComment")).unwrap_or_else(|| panic!("{said}"));
        assert!(comment.contains(expected), "{comment}");
    }
    // Nothing was kept for either, and the receiver says why in its log, without patient data.
    std::thread::sleep(std::time::Duration::from_millis(800));
    let staging = scp.data_dir.join(volasso::receive::STAGING_FOLDER).join("pending");
    assert_eq!(std::fs::read_dir(&staging).unwrap().count(), 0);
    assert_eq!(scp.visible_entries(), Vec::<String>::new());
    assert!(scp.stdout.try_recv().is_err(), "a refused image was reported as a series");
    let log = scp.stderr_so_far();
    assert_eq!(log.matches("refused an image (0xc000)").count(), 2, "{log}");
    // A good image after them is stored: the association and the receiver go on.
    let good = scp.client("storescu", &[], &series_files("philips_phantom_5mm")[..1]);
    assert!(good.status.success(), "{}", text(&good));
    assert_eq!(scp.next_report()["event"], "stored");
}

#[test]
fn an_image_whose_sop_instance_uid_is_not_a_uid_is_stored_when_it_reads() {
    if !dcmtk_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    // bad_sequence.dcm's SOP Instance UID: 64 hex digits, not digits and dots. The file meta
    // keeps the original UID (-nmu), as in that file.
    let uid = "dccc9599087131742838cc1162a630fea87ba9bf61ac09bfda90d4adfa5ddaed";
    let changes = ["-nmu", "-m", &format!("(0008,0018)={uid}"), "-m", "(0020,000e)=1.2.826.0.1.3680043.8.498.77"];
    let odd = modified_copy(folder.path(), "odd.dcm", &changes);
    let scp = Scp::start(&[]);
    let store = scp.client("storescu", &["-v"], &[odd]);
    assert!(store.status.success(), "{}", text(&store));
    assert!(text(&store).contains("Received Store Response (Success)"), "{}", text(&store));
    let report = scp.next_report();
    assert_eq!((report["event"].as_str(), report["images"].as_u64()), (Some("stored"), Some(1)), "{report}");
}
