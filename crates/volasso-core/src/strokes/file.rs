//! The `volasso-strokes/1` JSON file (`interfaces.md`): reading with located errors, and
//! atomic writing.

use super::{ClassStrokes, Lasso, StrokesError};
use crate::slices::{Axis, slice_count};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// The format string every strokes file starts with.
pub const FORMAT: &str = "volasso-strokes/1";

/// The largest strokes file read, in bytes: a hand draws kilobytes; this bounds what a
/// hostile file can make the reader hold (about three million points).
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// A strokes file: classes with their lassos. Class id k is `classes[k - 1]`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct StrokesFile {
    /// The classes in id order: class id k is `classes[k - 1]`.
    pub classes: Vec<ClassStrokes>,
}

/// The file as written, before axis and slice are checked (so errors can name the stroke).
/// Unknown fields are ignored: the format may grow fields without breaking readers.
#[derive(Deserialize)]
struct RawFile {
    classes: Vec<RawClass>,
}

#[derive(Deserialize)]
struct RawClass {
    name: String,
    strokes: Vec<RawStroke>,
}

#[derive(Deserialize)]
struct RawStroke {
    axis: String,
    slice: i64,
    points: Vec<[f64; 2]>,
}

/// Just the format field, read first so that another JSON file is refused for what it is.
#[derive(Deserialize)]
struct FormatOnly {
    format: Option<serde_json::Value>,
}

#[derive(Serialize)]
struct FileOut<'a> {
    format: &'static str,
    classes: &'a [ClassStrokes],
}

impl StrokesFile {
    /// Parses the JSON text of a strokes file (a leading UTF-8 byte-order mark is skipped);
    /// checks format, axes, slice signs and points.
    pub fn parse(text: &str) -> Result<StrokesFile, StrokesError> {
        // Editors on Windows start UTF-8 files with a byte-order mark; JSON has no use for it.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let format: FormatOnly = serde_json::from_str(text).map_err(|source| StrokesError::Json { source })?;
        match format.format {
            Some(serde_json::Value::String(found)) if found == FORMAT => {}
            Some(serde_json::Value::String(found)) => {
                return Err(StrokesError::WrongFormat { found });
            }
            Some(other) => {
                return Err(StrokesError::WrongFormat { found: other.to_string() });
            }
            None => {
                return Err(StrokesError::WrongFormat { found: "(no format field)".into() });
            }
        }
        let raw: RawFile = serde_json::from_str(text).map_err(|source| StrokesError::Json { source })?;
        let mut classes = Vec::with_capacity(raw.classes.len());
        for raw_class in raw.classes {
            let mut strokes = Vec::with_capacity(raw_class.strokes.len());
            for (stroke, raw_stroke) in raw_class.strokes.into_iter().enumerate() {
                let axis = Axis::from_name(&raw_stroke.axis).ok_or_else(|| StrokesError::BadAxis {
                    class: raw_class.name.clone(),
                    stroke,
                    found: raw_stroke.axis.clone(),
                })?;
                let slice = usize::try_from(raw_stroke.slice).map_err(|_| StrokesError::NegativeSlice {
                    class: raw_class.name.clone(),
                    stroke,
                    slice: raw_stroke.slice,
                })?;
                strokes.push(Lasso { axis, slice, points: raw_stroke.points });
            }
            classes.push(ClassStrokes { name: raw_class.name, strokes });
        }
        let file = StrokesFile { classes };
        file.check_points()?;
        Ok(file)
    }

    /// Reads and parses the strokes file at `path`, a regular file of at most
    /// [`MAX_FILE_BYTES`] in UTF-8; errors name the path.
    pub fn read(path: &Path) -> Result<StrokesFile, StrokesError> {
        let text = crate::input_file::read_text(path, "strokes file", MAX_FILE_BYTES)?;
        StrokesFile::parse(&text).map_err(|e| e.with_path(path))
    }

    /// Reads the strokes file at `path` and checks it against a volume of `dims`.
    pub fn read_for_volume(path: &Path, dims: [usize; 3]) -> Result<StrokesFile, StrokesError> {
        let file = StrokesFile::read(path)?;
        file.check_for_volume(dims).map_err(|e| e.with_path(path))?;
        Ok(file)
    }

    /// Checks that every point is finite (a file cannot hold NaN, a program can).
    pub fn check_points(&self) -> Result<(), StrokesError> {
        for class in &self.classes {
            for (stroke, lasso) in class.strokes.iter().enumerate() {
                if let Some(point) = lasso.points.iter().position(|p| !(p[0].is_finite() && p[1].is_finite())) {
                    return Err(StrokesError::NonFinitePoint { class: class.name.clone(), stroke, point });
                }
            }
        }
        Ok(())
    }

    /// Checks that every stroke lies on a slice of a volume of `dims`, every point is finite,
    /// and the classes fit in a `u8` label.
    pub fn check_for_volume(&self, dims: [usize; 3]) -> Result<(), StrokesError> {
        if self.classes.len() > u8::MAX as usize {
            return Err(StrokesError::TooManyClasses { count: self.classes.len() });
        }
        self.check_points()?;
        for class in &self.classes {
            for (stroke, lasso) in class.strokes.iter().enumerate() {
                let count = slice_count(dims, lasso.axis);
                if lasso.slice >= count {
                    return Err(StrokesError::SliceOutOfRange {
                        class: class.name.clone(),
                        stroke,
                        axis: lasso.axis,
                        slice: lasso.slice,
                        slice_count: count,
                    });
                }
            }
        }
        Ok(())
    }

    /// The file's JSON text (pretty-printed, one point pair per line is not promised).
    pub fn to_json(&self) -> Result<String, StrokesError> {
        self.check_points()?;
        let out = FileOut { format: FORMAT, classes: &self.classes };
        serde_json::to_string_pretty(&out).map_err(|source| StrokesError::Json { source })
    }

    /// Writes the file atomically: to a temporary file in the same folder, flushed to disk,
    /// then renamed over `path`. On failure `path` is untouched and the temporary file removed.
    pub fn write(&self, path: &Path) -> Result<(), StrokesError> {
        let mut text = self.to_json().map_err(|e| e.with_path(path))?;
        text.push('\n');
        crate::atomic_file::write_atomically(path, |file| file.write_all(text.as_bytes()))
            .map_err(|source| StrokesError::Io { source, path: path.to_path_buf() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{"format": "volasso-strokes/1",
 "classes": [
   {"name": "bone",
    "strokes": [ {"axis": "z", "slice": 87, "points": [[10.0, 12.5], [40.0, 12.0], [38.5, 50.0]]} ]},
   {"name": "soft tissue", "strokes": [
      {"axis": "x", "slice": 3, "points": [[1, 2], [3, 4], [5, 1]], "pressure": 0.5},
      {"axis": "y", "slice": 0, "points": []} ]}
 ], "note": "unknown fields are ignored"}"#;

    fn error_of(text: &str) -> StrokesError {
        StrokesFile::parse(text).unwrap_err()
    }

    #[test]
    fn reads_the_interface_example() {
        let file = StrokesFile::parse(GOOD).unwrap();
        assert_eq!(file.classes.len(), 2);
        assert_eq!(file.classes[0].name, "bone");
        assert_eq!(
            file.classes[0].strokes[0],
            Lasso { axis: Axis::Z, slice: 87, points: vec![[10.0, 12.5], [40.0, 12.0], [38.5, 50.0]] }
        );
        assert_eq!(file.classes[1].strokes[0].axis, Axis::X);
        assert!(file.classes[1].strokes[1].points.is_empty());
        file.check_for_volume([100, 100, 100]).unwrap();
    }

    #[test]
    fn a_byte_order_mark_is_accepted() {
        let with_bom = format!("\u{feff}{GOOD}");
        assert_eq!(StrokesFile::parse(&with_bom).unwrap(), StrokesFile::parse(GOOD).unwrap());
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("bom.json");
        std::fs::write(&path, with_bom.as_bytes()).unwrap();
        assert_eq!(StrokesFile::read(&path).unwrap().classes.len(), 2);
    }

    #[test]
    fn round_trips_through_an_atomic_write() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("strokes.json");
        let file = StrokesFile::parse(GOOD).unwrap();
        file.write(&path).unwrap();
        assert_eq!(StrokesFile::read(&path).unwrap(), file);
        // Overwrite in place: still whole, and no temporary file left beside it.
        let mut changed = file.clone();
        changed.classes.pop();
        changed.write(&path).unwrap();
        assert_eq!(StrokesFile::read(&path).unwrap(), changed);
        let names: Vec<_> = std::fs::read_dir(folder.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"format\": \"volasso-strokes/1\""));
        assert!(text.contains("\"axis\": \"z\""));
    }

    #[test]
    fn a_failed_write_leaves_nothing_behind() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("no such folder").join("strokes.json");
        let error = StrokesFile::default().write(&path).unwrap_err();
        assert!(matches!(error, StrokesError::Io { .. }), "{error}");
        let mut bad = StrokesFile::parse(GOOD).unwrap();
        bad.classes[0].strokes[0].points[1][0] = f64::NAN;
        let path = folder.path().join("strokes.json");
        let error = bad.write(&path).unwrap_err();
        assert!(matches!(
            error.innermost(),
            StrokesError::NonFinitePoint { stroke: 0, point: 1, class } if class == "bone"
        ));
        assert_eq!(std::fs::read_dir(folder.path()).unwrap().count(), 0);
    }

    #[test]
    fn refuses_a_wrong_or_missing_format_string() {
        let wrong = GOOD.replace("volasso-strokes/1", "volasso-strokes/2");
        assert!(matches!(error_of(&wrong), StrokesError::WrongFormat { found } if found == "volasso-strokes/2"));
        let missing = r#"{"classes": []}"#;
        assert!(matches!(error_of(missing), StrokesError::WrongFormat { .. }));
        let number = r#"{"format": 1, "classes": []}"#;
        assert!(matches!(error_of(number), StrokesError::WrongFormat { found } if found == "1"));
        // Another JSON file is refused for its format, not for a missing "classes".
        let other = r#"{"format": "something-else", "layers": 3}"#;
        let message = error_of(other).to_string();
        assert!(message.contains("'something-else'"), "{message}");
    }

    #[test]
    fn names_the_class_and_stroke_of_a_bad_axis_or_negative_slice() {
        let bad_axis = GOOD.replace(r#""axis": "y""#, r#""axis": "w""#);
        let error = error_of(&bad_axis);
        assert!(
            matches!(&error, StrokesError::BadAxis { class, stroke: 1, found } if class == "soft tissue" && found == "w")
        );
        assert!(error.to_string().contains("soft tissue"));
        let negative = GOOD.replace(r#""slice": 87"#, r#""slice": -2"#);
        assert!(matches!(error_of(&negative), StrokesError::NegativeSlice { slice: -2, stroke: 0, .. }));
    }

    #[test]
    fn refuses_slices_outside_the_volume_and_broken_json() {
        let file = StrokesFile::parse(GOOD).unwrap();
        let error = file.check_for_volume([100, 100, 87]).unwrap_err();
        assert!(matches!(
            error,
            StrokesError::SliceOutOfRange { axis: Axis::Z, slice: 87, slice_count: 87, stroke: 0, .. }
        ));
        assert!(matches!(error_of("{\"format\": "), StrokesError::Json { .. }));
        let three_numbers = GOOD.replace("[38.5, 50.0]", "[38.5, 50.0, 1.0]");
        assert!(matches!(error_of(&three_numbers), StrokesError::Json { .. }));
        let huge = GOOD.replace("38.5", "1e999");
        assert!(matches!(error_of(&huge), StrokesError::Json { .. }));
    }

    #[test]
    fn read_errors_carry_the_path_last() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("s.json");
        std::fs::write(&path, GOOD).unwrap();
        let error = StrokesFile::read_for_volume(&path, [4, 4, 4]).unwrap_err();
        let message = error.to_string();
        assert!(message.ends_with(&format!("in {}", path.display())), "{message}");
        assert!(matches!(error.innermost(), StrokesError::SliceOutOfRange { .. }));
        let missing = StrokesFile::read(&folder.path().join("none.json")).unwrap_err();
        assert!(matches!(missing, StrokesError::Read(crate::input_file::InputFileError::Io { .. })));
        assert!(missing.to_string().starts_with("cannot read the strokes file: "), "{missing}");
    }
}
