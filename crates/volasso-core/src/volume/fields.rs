//! The fields of a text header (NRRD, MetaImage) as a reader collects them: each field once.
//!
//! A field given twice with different values is refused ([`VolumeError::RepeatedField`]): which
//! of two `sizes` (or `DimSize`, `type`, `endian`, ...) the writer meant cannot be told, and
//! taking either one shows a wrong scan. The same field given twice with the same value (up to
//! the spacing between words) says nothing new and is kept once. Keys are compared in the form
//! the reader gives them ([`HeaderFields::insert`]: NRRD lowercases and maps `datafile` to
//! `data file`; MetaImage compares keys without regard to case).
//!
//! Never: interprets a value.

use super::VolumeError;
use std::path::Path;

/// The fields read so far, in file order, each key once.
#[derive(Debug, Default)]
pub(crate) struct HeaderFields {
    /// (key as compared, key as the file spells it, value trimmed).
    fields: Vec<(String, String, String)>,
}

impl HeaderFields {
    /// Adds `value` under `key` (compared as `key`, named in errors as `spelled`); refuses a
    /// key given before with a different value.
    pub(crate) fn insert(&mut self, key: String, spelled: &str, value: &str, path: &Path) -> Result<(), VolumeError> {
        let value = value.trim();
        if let Some((_, first_spelling, first)) = self.fields.iter().find(|(k, _, _)| *k == key) {
            if same_words(first, value) {
                return Ok(());
            }
            return Err(VolumeError::RepeatedField {
                field: first_spelling.clone(),
                values: Box::new([shown(first), shown(value)]),
                path: path.to_path_buf(),
            });
        }
        self.fields.push((key, spelled.trim().to_string(), value.to_string()));
        Ok(())
    }

    /// The value of `key` (in the compared form), if given.
    pub(crate) fn get(&self, key: &str) -> Option<&str> {
        self.fields.iter().find(|(k, _, _)| k == key).map(|(_, _, v)| v.as_str())
    }
}

/// True when `a` and `b` hold the same words (whitespace runs count as one space).
fn same_words(a: &str, b: &str) -> bool {
    a.split_whitespace().eq(b.split_whitespace())
}

/// The first 60 characters of a value, for messages.
fn shown(value: &str) -> String {
    value.chars().take(60).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_field_twice_is_kept_once_when_equal_and_refused_when_not() {
        let path = Path::new("t");
        let mut fields = HeaderFields::default();
        fields.insert("sizes".into(), "sizes", "64 64 64", path).unwrap();
        fields.insert("sizes".into(), "Sizes", " 64  64 64 ", path).unwrap();
        assert_eq!(fields.get("sizes"), Some("64 64 64"));
        for other in ["32 32 32", "64 64", "64 64 64 1", ""] {
            let error = fields.insert("sizes".into(), "sizes", other, path).unwrap_err();
            assert!(
                matches!(&error, VolumeError::RepeatedField { field, values, .. }
                    if field == "sizes" && values[0] == "64 64 64" && values[1] == other),
                "{other}: {error}"
            );
            assert!(error.to_string().contains("given twice with different values"), "{error}");
        }
    }
}
