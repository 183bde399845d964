//! The screens' language: the words the screens hold (`@tr` in `ui/*.slint`) and the lines the
//! app writes into them (status, hints, the settings screen) come from one catalog per language,
//! `ui/translations/LANG/LC_MESSAGES/volasso-ui.po` (gettext), bundled into the binary. The app
//! thinks and logs in English, its source language; [`tr`] translates a finished line where it
//! is handed to the screen, matching the catalog's phrases with `{}` standing for a value (a
//! number or a date, written in the language's own form: `1,58 s`, `06.12.2026`).
//!
//! Never: translates names (scans, classes, AE titles: scripts and people find things by them)
//! or anything written to files and logs.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};
use volasso_appliance::settings::Language;

/// The German catalog.
const GERMAN_PO: &str = include_str!("../../../ui/translations/de/LC_MESSAGES/volasso-ui.po");

/// The language shown: 0 English, 1 German.
static CURRENT: AtomicU8 = AtomicU8::new(0);

/// The app's lines in `language` from now on, as they are next written (the screens' own
/// words are switched by the view, `settings::view::show_language`).
pub fn set_language(language: Language) {
    CURRENT.store(if language == Language::De { 1 } else { 0 }, Ordering::Relaxed);
}

/// `language`'s code, as the catalogs' folders are named.
pub fn code(language: Language) -> &'static str {
    if language == Language::De { "de" } else { "en" }
}

/// The language shown.
pub fn language() -> Language {
    if CURRENT.load(Ordering::Relaxed) == 1 { Language::De } else { Language::En }
}

/// `english` in the language shown: the catalog's phrase that matches it whole, its `{}` taking
/// any text; the line as it is when none does (or in English).
pub fn tr(english: &str) -> String {
    if language() == Language::En || english.is_empty() {
        return english.to_string();
    }
    translate(german(), english).unwrap_or_else(|| english.to_string())
}

fn german() -> &'static [(String, String)] {
    static CATALOG: OnceLock<Vec<(String, String)>> = OnceLock::new();
    CATALOG.get_or_init(|| parse_po(GERMAN_PO))
}

/// The catalog's translation of `line`: an exact phrase first, else the first phrase with `{}`
/// whose fixed parts frame the line.
fn translate(catalog: &[(String, String)], line: &str) -> Option<String> {
    if let Some((_, translated)) = catalog.iter().find(|(id, _)| id == line) {
        return Some(translated.clone());
    }
    catalog.iter().filter(|(id, _)| id.contains("{}")).find_map(|(id, translated)| {
        let values = values_in(id, line)?;
        let mut out = String::new();
        let mut pieces = translated.split("{}");
        out.push_str(pieces.next().unwrap_or_default());
        for (piece, value) in pieces.zip(values) {
            out.push_str(&german_form(value));
            out.push_str(piece);
        }
        Some(out)
    })
}

/// The texts `line` holds where `pattern` has `{}`, when its fixed parts match.
fn values_in<'a>(pattern: &str, line: &'a str) -> Option<Vec<&'a str>> {
    let parts: Vec<&str> = pattern.split("{}").collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    let inner = line.strip_prefix(first)?.strip_suffix(last)?;
    let mut values = Vec::new();
    let mut rest = inner;
    for part in &parts[1..parts.len() - 1] {
        let at = rest.find(part).filter(|_| !part.is_empty())?;
        values.push(&rest[..at]);
        rest = &rest[at + part.len()..];
    }
    values.push(rest);
    (values.len() == parts.len() - 1).then_some(values)
}

/// A value as German writes it: a decimal comma, a date day first.
fn german_form(value: &str) -> String {
    let bytes = value.as_bytes();
    let is_date = bytes.len() == 10
        && bytes[4] == b'-'
        && bytes[7] == b'-'
        && value.chars().enumerate().all(|(i, c)| i == 4 || i == 7 || c.is_ascii_digit());
    if is_date {
        return format!("{}.{}.{}", &value[8..10], &value[5..7], &value[..4]);
    }
    if value.parse::<f64>().is_ok() && value.contains('.') {
        return value.replace('.', ",");
    }
    value.to_string()
}

/// The singular `msgid`/`msgstr` pairs of a gettext catalog (plural entries are the screens').
fn parse_po(text: &str) -> Vec<(String, String)> {
    #[derive(PartialEq)]
    enum Field {
        None,
        Id,
        Translated,
    }
    let mut entries = Vec::new();
    // A phrase in a context (`msgctxt`, the screens' short forms) is the screens' too.
    let (mut id, mut translated, mut plural, mut field) = (String::new(), String::new(), false, Field::None);
    let mut finish = |id: &mut String, translated: &mut String, plural: &mut bool| {
        if !*plural && !id.is_empty() && !translated.is_empty() {
            entries.push((std::mem::take(id), std::mem::take(translated)));
        }
        id.clear();
        translated.clear();
        *plural = false;
    };
    for line in text.lines().map(str::trim) {
        if let Some(rest) = line.strip_prefix("msgid ") {
            if !id.is_empty() || !translated.is_empty() {
                finish(&mut id, &mut translated, &mut plural);
            }
            id = unquote(rest);
            field = Field::Id;
        } else if line.starts_with("msgctxt ") {
            finish(&mut id, &mut translated, &mut plural);
            plural = true;
            field = Field::None;
        } else if line.starts_with("msgid_plural ") || line.starts_with("msgstr[") {
            plural = true;
            field = Field::None;
        } else if let Some(rest) = line.strip_prefix("msgstr ") {
            translated = unquote(rest);
            field = Field::Translated;
        } else if line.starts_with('"') {
            match field {
                Field::Id => id.push_str(&unquote(line)),
                Field::Translated => translated.push_str(&unquote(line)),
                Field::None => {}
            }
        } else if line.is_empty() {
            field = Field::None;
        }
    }
    finish(&mut id, &mut translated, &mut plural);
    entries
}

/// A gettext string's text.
fn unquote(quoted: &str) -> String {
    let inner = quoted.trim().strip_prefix('"').and_then(|s| s.strip_suffix('"')).unwrap_or_default();
    let mut out = String::new();
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some(other) => out.push(other),
            None => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_matched_whole_with_values_in_the_languages_form() {
        let catalog = parse_po(
            "msgid \"\"\nmsgstr \"Content-Type: text/plain\"\n\n\
             msgid \"Classifying...\"\nmsgstr \"Klassifiziere ...\"\n\n\
             msgid \"Classified in {} s\"\nmsgstr \"Klassifiziert in {} s\"\n\n\
             msgid \"study {}\"\nmsgstr \"Studie vom {}\"\n\n\
             msgctxt \"narrow\"\nmsgid \"Undo\"\nmsgstr \"Zurück\"\n\n\
             msgid \"{n} lasso\"\nmsgid_plural \"{n} lassos\"\nmsgstr[0] \"{n} Lasso\"\nmsgstr[1] \"{n} Lassos\"\n",
        );
        assert_eq!(catalog.len(), 3, "the header and plural entries are the screens': {catalog:?}");
        assert_eq!(translate(&catalog, "Classifying...").as_deref(), Some("Klassifiziere ..."));
        assert_eq!(translate(&catalog, "Classified in 1.58 s").as_deref(), Some("Klassifiziert in 1,58 s"));
        assert_eq!(translate(&catalog, "study 2015-02-06").as_deref(), Some("Studie vom 06.02.2015"));
        assert_eq!(translate(&catalog, "Classified in 1.58 s!"), None, "a phrase matches the whole line");
        assert_eq!(translate(&catalog, "Unknown"), None);
    }

    #[test]
    fn every_phrase_of_the_german_catalog_reads_and_keeps_its_values() {
        let catalog = german();
        assert!(catalog.len() > 40, "{}", catalog.len());
        for (id, translated) in catalog {
            assert_eq!(id.matches("{}").count(), translated.matches("{}").count(), "{id} -> {translated}");
        }
    }
}
