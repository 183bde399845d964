//! Autosave: the session (which volume, the defined classes' lassos, the colour template) is
//! written after every change, atomically, and restored when the app starts again (after a
//! crash, a power cut or the watchdog's restart). The idle timeout deletes it: a kiosk's next
//! visitor starts clean.
//!
//! Format `volasso-session/1` (JSON): `{"format", "volume", "template", "rotation_degrees",
//! "strokes"}` where `strokes` is a `volasso-strokes/1` document, so saved sessions can be
//! classified with `volasso classify` as they are.
//!
//! Never: fails the app; a damaged file is logged and ignored (and left for inspection).

use crate::atomic_file::write_atomically;
use crate::strokes::StrokesFile;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

pub const SESSION_FORMAT: &str = "volasso-session/1";

/// The saved session file in a session folder.
pub fn session_path(session_dir: &Path) -> PathBuf {
    session_dir.join("session.json")
}

/// What is saved.
#[derive(Clone, Debug, PartialEq)]
pub struct SavedSession {
    /// `demo` or a volume path.
    pub volume: String,
    pub template: String,
    pub rotation_degrees: f32,
    pub strokes: StrokesFile,
}

#[derive(Serialize, Deserialize)]
struct SessionFile {
    format: String,
    volume: String,
    template: String,
    rotation_degrees: f32,
    strokes: serde_json::Value,
}

/// Writes `session` into `session_dir` (created if missing), whole or not at all.
pub fn save(session_dir: &Path, session: &SavedSession) -> Result<(), String> {
    let strokes_json = session.strokes.to_json().map_err(|e| e.to_string())?;
    let strokes: serde_json::Value = serde_json::from_str(&strokes_json).map_err(|e| e.to_string())?;
    let file = SessionFile {
        format: SESSION_FORMAT.to_string(),
        volume: session.volume.clone(),
        template: session.template.clone(),
        rotation_degrees: session.rotation_degrees,
        strokes,
    };
    let text = serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(session_dir).map_err(|e| format!("cannot create {}: {e}", session_dir.display()))?;
    let path = session_path(session_dir);
    write_atomically(&path, |writer| writer.write_all(text.as_bytes()))
        .map_err(|e| format!("cannot save the session to {}: {e}", path.display()))
}

/// The saved session, if there is a readable one.
pub fn load(session_dir: &Path) -> Option<SavedSession> {
    let path = session_path(session_dir);
    let text = std::fs::read_to_string(&path).ok()?;
    let parsed = serde_json::from_str::<SessionFile>(&text).map_err(|e| e.to_string()).and_then(|file| {
        if file.format != SESSION_FORMAT {
            return Err(format!("format '{}' is not {SESSION_FORMAT}", file.format));
        }
        let strokes = StrokesFile::parse(&file.strokes.to_string()).map_err(|e| e.to_string())?;
        Ok(SavedSession {
            volume: file.volume,
            template: file.template,
            rotation_degrees: file.rotation_degrees,
            strokes,
        })
    });
    match parsed {
        Ok(session) => Some(session),
        Err(problem) => {
            log::warn!("ignoring the saved session {}: {problem}", path.display());
            None
        }
    }
}

/// Forgets the saved session.
pub fn remove(session_dir: &Path) {
    let path = session_path(session_dir);
    if let Err(error) = std::fs::remove_file(&path)
        && error.kind() != std::io::ErrorKind::NotFound
    {
        log::warn!("cannot remove the saved session {}: {error}", path.display());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slices::Axis;
    use crate::strokes::{ClassStrokes, Lasso};

    fn session() -> SavedSession {
        let lasso = Lasso { axis: Axis::Y, slice: 4, points: vec![[1.0, 2.0], [7.5, 2.0], [7.5, 9.0]] };
        SavedSession {
            volume: "demo".into(),
            template: "L".into(),
            rotation_degrees: 42.0,
            strokes: StrokesFile { classes: vec![ClassStrokes { name: "Class 1".into(), strokes: vec![lasso] }] },
        }
    }

    #[test]
    fn a_saved_session_comes_back_and_removal_forgets_it() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path().join("sessions");
        save(&dir, &session()).unwrap();
        assert_eq!(load(&dir), Some(session()));
        remove(&dir);
        assert_eq!(load(&dir), None);
        remove(&dir);
    }

    #[test]
    fn a_damaged_or_foreign_file_is_ignored() {
        let folder = tempfile::tempdir().unwrap();
        save(folder.path(), &session()).unwrap();
        let path = session_path(folder.path());
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, &text[..text.len() / 2]).unwrap();
        assert_eq!(load(folder.path()), None);
        std::fs::write(&path, text.replace(SESSION_FORMAT, "other/1")).unwrap();
        assert_eq!(load(folder.path()), None);
    }
}
