//! What a series may lack and what its files may lie about: missing, unreadable and
//! undecodable slices (refused unless `allow_gaps`), PixelData that does not match Rows x
//! Columns x BitsAllocated, and the one listing of a DICOM path (links, loops, depth).

use super::synthetic::SyntheticSlice;
use super::*;

/// Axial 4 x 3 slices of series "3.3" at the given z (1 mm apart is the regular spacing).
fn write_axial_series(folder: &Path, z_mm: &[f64]) {
    for (k, z) in z_mm.iter().enumerate() {
        SyntheticSlice::axial("3.3", &format!("3.3.{k}"), [4, 3], [0.0, 0.0, *z], |column, row| {
            (100 * k + 10 * row + column) as i16
        })
        .write(&folder.join(format!("s{k}.dcm")));
    }
}

fn allowing_gaps() -> DicomOptions {
    DicomOptions { allow_gaps: true, ..DicomOptions::default() }
}

fn refusal(folder: &Path) -> String {
    match read_series(folder, &DicomOptions::default()) {
        Ok(import) => panic!("opened a series with a hole: {:?}", import.volume.dims),
        Err(error) => {
            assert!(matches!(error, VolumeError::SeriesGap { .. }), "{error}");
            let message = error.to_string();
            assert!(message.contains("--allow-gaps"), "{message}");
            message
        }
    }
}

#[test]
fn a_lost_slice_is_refused_unless_gaps_are_allowed_and_then_resampled_with_a_warning() {
    let folder = tempfile::tempdir().unwrap();
    write_axial_series(folder.path(), &[0.0, 1.0, 2.0, 4.0, 5.0]);
    let message = refusal(folder.path());
    assert!(message.contains("the 2.00 mm gap between slices 3 and 4 is 2.0 times the series' 1.00 mm spacing"));
    let import = read_series(folder.path(), &allowing_gaps()).unwrap();
    assert_eq!(import.volume.dims, [4, 3, 6]);
    assert_eq!(import.warnings.len(), 2, "{:?}", import.warnings);
    assert!(import.warnings[0].starts_with("opened with a missing slice (--allow-gaps): the 2.00 mm gap"));
    // The hole at z = 3 is interpolated between its neighbours (stored 200 + ... and 300 + ...).
    assert_eq!(import.volume.value_at(0, 0, 3), 250.0);
}

#[test]
fn an_unreadable_file_or_slice_is_a_possible_hole() {
    let folder = tempfile::tempdir().unwrap();
    write_axial_series(folder.path(), &[0.0, 1.0, 2.0, 3.0]);
    assert_eq!(read_series(folder.path(), &DicomOptions::default()).unwrap().volume.dims, [4, 3, 4]);
    // A DICOM file cut short: which series it belonged to is unknowable.
    let whole = std::fs::read(folder.path().join("s1.dcm")).unwrap();
    std::fs::write(folder.path().join("cut.dcm"), &whole[..300]).unwrap();
    let message = refusal(folder.path());
    assert!(message.contains("a DICOM file cannot be read") && message.contains("cut.dcm"), "{message}");
    let import = read_series(folder.path(), &allowing_gaps()).unwrap();
    assert_eq!(import.volume.dims, [4, 3, 4]);
    assert!(import.warnings[0].contains("cut.dcm"), "{:?}", import.warnings);
    std::fs::remove_file(folder.path().join("cut.dcm")).unwrap();

    // A slice whose PixelData is shorter than its Rows x Columns: the header reads, the
    // pixels do not.
    let mut short = SyntheticSlice::axial("3.3", "3.3.2", [4, 3], [0.0, 0.0, 2.0], |_, _| 7);
    short.stored.truncate(11);
    short.write(&folder.path().join("s2.dcm"));
    let message = refusal(folder.path());
    assert!(message.contains("s2.dcm") && message.contains("PixelData holds 22 bytes"), "{message}");
    let import = read_series(folder.path(), &allowing_gaps()).unwrap();
    assert_eq!(import.files.len(), 3);
    assert!(import.warnings[0].contains("s2.dcm cannot be decoded"), "{:?}", import.warnings);
    // The slice at z = 2 is interpolated from z = 1 and z = 3.
    assert_eq!(import.volume.dims, [4, 3, 4]);
    assert_eq!(import.volume.value_at(0, 0, 2), 200.0);
    // A header that lies about the matrix inside a series is a mismatch with the others.
    let mut lying = SyntheticSlice::axial("3.3", "3.3.2", [4, 3], [0.0, 0.0, 2.0], |_, _| 7);
    lying.rows = 2;
    lying.write(&folder.path().join("s2.dcm"));
    let message = read_series(folder.path(), &allowing_gaps()).unwrap_err().to_string();
    assert!(message.contains("image size") && message.contains("s2.dcm"), "{message}");
}

#[test]
fn pixel_data_must_match_rows_columns_and_bits() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("one.dcm");
    let mut slice = SyntheticSlice::axial("4.4", "4.4.0", [4, 3], [0.0; 3], |column, _| column as i16);
    slice.write(&path);
    assert!(read_series(&path, &DicomOptions::default()).is_ok());
    for (rows, columns) in [(2, 4), (3, 3), (4, 4)] {
        slice.rows = rows;
        slice.columns = columns;
        slice.write(&path);
        let message = read_series(&path, &DicomOptions::default()).unwrap_err().to_string();
        let needle = format!("PixelData holds 24 bytes but Rows {rows} x Columns {columns}");
        assert!(message.contains(&needle) && message.ends_with("one.dcm"), "{message}");
    }
}

#[test]
fn the_listing_follows_links_once_and_ends_in_loops() {
    let folder = tempfile::tempdir().unwrap();
    let series = folder.path().join("series");
    std::fs::create_dir(&series).unwrap();
    write_axial_series(&series, &[0.0, 1.0, 2.0]);
    // Ten folders deep, behind a link, with a loop back to the top and a second link to the
    // same series.
    let mut deep = folder.path().join("top");
    for level in 0..10 {
        deep = deep.join(format!("level{level}"));
    }
    std::fs::create_dir_all(&deep).unwrap();
    std::os::unix::fs::symlink(&series, deep.join("linked")).unwrap();
    std::os::unix::fs::symlink(&series, deep.join("again")).unwrap();
    std::os::unix::fs::symlink(folder.path().join("top"), deep.join("loop")).unwrap();
    let top = folder.path().join("top");
    let source = list_source(&top, &ReadLimits::default()).unwrap();
    assert_eq!(source.files.len(), 3, "{:?}", source.files);
    assert!(source.unlisted.is_empty(), "{:?}", source.unlisted);
    assert!(source.files.iter().all(|file| file.starts_with(std::fs::canonicalize(&series).unwrap())));
    let import = read_series(&top, &DicomOptions::default()).unwrap();
    assert_eq!(import.volume.dims, [4, 3, 3]);
    // A link to nothing may have been a slice.
    std::os::unix::fs::symlink(folder.path().join("gone.dcm"), deep.join("dangling.dcm")).unwrap();
    let source = list_source(&top, &ReadLimits::default()).unwrap();
    assert_eq!(source.unlisted.len(), 1, "{:?}", source.unlisted);
    assert!(refusal(&top).contains("dangling.dcm"));
}
