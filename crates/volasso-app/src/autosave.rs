//! Autosave: the session (which volume, the defined classes' lassos, the colour template) is
//! written after every change, atomically, and restored when the app starts again (after a
//! crash, a power cut or the watchdog's restart). The idle timeout deletes it: a kiosk's next
//! visitor starts clean.
//!
//! Format `volasso-session/1` (JSON): `{"format", "volume", "template", "rotation_degrees",
//! "strokes"}` where `strokes` is a `volasso-strokes/1` document, so saved sessions can be
//! classified with `volasso classify` as they are. Optional fields (absent in older files,
//! which still load): `class_opacity` (class name to opacity factor, 1 the default rule's) and
//! `clip` (the 3-D view's clip plane, `{"normal", "offset_mm"}`, see [`ClipPlane`]).
//! A gallery entry (gallery.rs) keeps the same record ([`to_record`], [`from_record`]).
//!
//! A restore can itself be what stops the app (a volume that aborts its reader, a session whose
//! classification crashes), and systemd would restart it into the same restore forever. So
//! [`begin_restore`] leaves a marker (`session.restoring`) that [`restored`] removes once the
//! restored session has opened and classified; a marker found at start-up means the last
//! restore never got there, and the session is set aside instead of restored. A session that
//! cannot be read or restored is set aside too: renamed to `session-failed-SECONDS.json`
//! beside it, never deleted, so nothing a visitor drew is lost.
//!
//! Never: fails the app, or restores a session that stopped the app before.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use volasso_core::atomic_file::write_atomically;
use volasso_core::render::settings::ClipPlane;
use volasso_core::strokes::StrokesFile;

pub const SESSION_FORMAT: &str = "volasso-session/1";

/// Why a session cannot be saved or read back; the messages of reading name no path (the
/// banner already says which session).
#[derive(Debug, thiserror::Error)]
pub enum AutosaveError {
    #[error("{0}")]
    Read(#[source] std::io::Error),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    #[error("format '{found}' is not {SESSION_FORMAT}")]
    Format { found: String },
    #[error("{0}")]
    Strokes(#[from] volasso_core::strokes::StrokesError),
    #[error("cannot create the session folder: {source}, in {}", path.display())]
    CreateFolder { source: std::io::Error, path: PathBuf },
    #[error("cannot save the session: {source}, in {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
}

/// The saved session file in a session folder.
pub fn session_path(session_dir: &Path) -> PathBuf {
    session_dir.join("session.json")
}

/// The marker of a restore in progress in a session folder.
pub fn marker_path(session_dir: &Path) -> PathBuf {
    session_dir.join("session.restoring")
}

/// What start-up does with the session folder ([`begin_restore`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Restore {
    /// No saved session.
    Nothing,
    /// Restore this session; the marker is down until [`restored`] or [`abandon`].
    Session(SavedSession),
    /// A saved session that will not be restored, and why; the banner says so.
    SetAside(SetAside),
}

/// A session moved out of the way, for the banner.
#[derive(Clone, Debug, PartialEq)]
pub struct SetAside {
    /// The name of the session's volume, when known.
    pub volume: Option<String>,
    /// Why it is not restored, in words.
    pub reason: String,
    /// Where it went; `None` when even the rename failed (it is then left where it was).
    pub kept_as: Option<PathBuf>,
}

impl SetAside {
    /// The banner's sentence.
    pub fn message(&self) -> String {
        let kept = match &self.kept_as {
            Some(path) => format!("It was kept as {}.", path.file_name().unwrap_or_default().to_string_lossy()),
            None => "It could not be moved aside (see the log).".to_string(),
        };
        let on = self.volume.as_ref().map_or(String::new(), |volume| format!(" ({volume})"));
        format!("The last session{on} was not restored: {}. {kept}", self.reason)
    }
}

/// Start-up: the session to restore (with the marker down), a session set aside (the last
/// restore stopped the app, or the file cannot be read), or nothing.
pub fn begin_restore(session_dir: &Path) -> Restore {
    let marker = marker_path(session_dir);
    if marker.exists() && !session_path(session_dir).exists() {
        // The session went (idle timeout) before the marker: nothing to set aside.
        remove_marker(session_dir);
        return Restore::Nothing;
    }
    if marker.exists() {
        let key = std::fs::read_to_string(&marker).unwrap_or_default();
        let volume = (!key.trim().is_empty()).then(|| volume_name(key.trim()));
        let set_aside = set_aside(session_dir, volume, "the app stopped while opening it".to_string());
        remove_marker(session_dir);
        return Restore::SetAside(set_aside);
    }
    match read(session_dir) {
        Ok(None) => Restore::Nothing,
        Ok(Some(session)) => {
            let written = volasso_core::atomic_file::write_atomically(&marker, |writer| {
                writer.write_all(session.volume.as_bytes())
            });
            if let Err(error) = written {
                // Without a marker a restore that stops the app would repeat: do not restore.
                return Restore::SetAside(set_aside(
                    session_dir,
                    Some(volume_name(&session.volume)),
                    format!("the session folder is not writable ({error})"),
                ));
            }
            Restore::Session(session)
        }
        Err(problem) => {
            log::warn!("cannot read the saved session in {}: {problem}", session_dir.display());
            Restore::SetAside(set_aside(session_dir, None, format!("it cannot be read ({problem})")))
        }
    }
}

/// The restored session opened and classified: a later stop is not the restore's doing.
pub fn restored(session_dir: &Path) {
    remove_marker(session_dir);
}

/// The restore failed without stopping the app (`reason`, e.g. why the volume `volume` cannot
/// be opened): the session is set aside and the marker removed.
pub fn abandon(session_dir: &Path, volume: String, reason: String) -> SetAside {
    let set_aside = set_aside(session_dir, Some(volume), reason);
    remove_marker(session_dir);
    set_aside
}

/// Renames the saved session to `session-failed-SECONDS[-N].json` beside it.
fn set_aside(session_dir: &Path, volume: Option<String>, reason: String) -> SetAside {
    let path = session_path(session_dir);
    if !path.exists() {
        return SetAside { volume, reason, kept_as: None };
    }
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let free = (0..100)
        .map(|n| match n {
            0 => session_dir.join(format!("session-failed-{seconds}.json")),
            n => session_dir.join(format!("session-failed-{seconds}-{n}.json")),
        })
        .find(|candidate| !candidate.exists());
    let kept_as = free.and_then(|target| match std::fs::rename(&path, &target) {
        Ok(()) => Some(target),
        Err(error) => {
            log::error!("cannot set the saved session {} aside: {error}", path.display());
            None
        }
    });
    log::warn!("the saved session was not restored: {reason}");
    if kept_as.is_none() {
        // Left in place, it would be restored again: out of the way at any price.
        remove(session_dir);
    }
    SetAside { volume, reason, kept_as }
}

/// A saved volume key as the banner names it: the file's name, or the key itself (`demo`).
fn volume_name(key: &str) -> String {
    Path::new(key).file_name().map_or_else(|| key.to_string(), |name| name.to_string_lossy().into_owned())
}

fn remove_marker(session_dir: &Path) {
    let marker = marker_path(session_dir);
    if let Err(error) = std::fs::remove_file(&marker)
        && error.kind() != std::io::ErrorKind::NotFound
    {
        log::error!("cannot remove the restore marker {}: {error}", marker.display());
    }
}

/// What is saved.
#[derive(Clone, Debug, PartialEq)]
pub struct SavedSession {
    /// `demo` or a volume path.
    pub volume: String,
    pub template: String,
    pub rotation_degrees: f32,
    pub strokes: StrokesFile,
    /// How the classes are shown beyond their colours (optional in the file).
    pub look: SavedLook,
}

/// The optional parts of a session: what the user set on the 3-D view and the classes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SavedLook {
    /// Per class name, its opacity factor (absent: 1).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub class_opacity: BTreeMap<String, f32>,
    /// The clip plane through the 3-D view and the slices; `None`: nothing cut.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip: Option<ClipPlane>,
    /// The learned preset the classes were coloured with (its file): its classes are in the
    /// strokes without lassos of their own. `None`: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<std::path::PathBuf>,
}

impl SavedLook {
    /// What a lying file cannot turn into a renderer error: opacities outside 0 to
    /// [`volasso_core::render::MAX_CLASS_OPACITY_FACTOR`] are clamped (not a number: 1), and a clip
    /// plane that is not finite or has no direction is dropped.
    pub fn sanitised(mut self) -> SavedLook {
        for factor in self.class_opacity.values_mut() {
            *factor = if factor.is_finite() {
                factor.clamp(0.0, volasso_core::render::MAX_CLASS_OPACITY_FACTOR)
            } else {
                1.0
            };
        }
        self.clip = self.clip.filter(ClipPlane::is_usable);
        self
    }
}

#[derive(Serialize, Deserialize)]
struct SessionFile {
    format: String,
    volume: String,
    template: String,
    rotation_degrees: f32,
    strokes: serde_json::Value,
    #[serde(flatten)]
    look: SavedLook,
}

/// The session as the JSON record autosave writes (`volasso-session/1`); the gallery keeps
/// the same record in each entry, so every field of the session travels with it.
pub fn to_record(session: &SavedSession) -> Result<serde_json::Value, AutosaveError> {
    let strokes_json = session.strokes.to_json()?;
    let strokes: serde_json::Value = serde_json::from_str(&strokes_json)?;
    let file = SessionFile {
        format: SESSION_FORMAT.to_string(),
        volume: session.volume.clone(),
        template: session.template.clone(),
        rotation_degrees: session.rotation_degrees,
        strokes,
        look: session.look.clone(),
    };
    Ok(serde_json::to_value(file)?)
}

/// The session a record of [`to_record`] holds.
pub fn from_record(record: serde_json::Value) -> Result<SavedSession, AutosaveError> {
    let file = serde_json::from_value::<SessionFile>(record)?;
    if file.format != SESSION_FORMAT {
        return Err(AutosaveError::Format { found: file.format });
    }
    let strokes = StrokesFile::parse(&file.strokes.to_string())?;
    Ok(SavedSession {
        volume: file.volume,
        template: file.template,
        rotation_degrees: file.rotation_degrees,
        strokes,
        look: file.look.sanitised(),
    })
}

/// Writes `session` into `session_dir` (created if missing), whole or not at all.
pub fn save(session_dir: &Path, session: &SavedSession) -> Result<(), AutosaveError> {
    let text = serde_json::to_string_pretty(&to_record(session)?)?;
    std::fs::create_dir_all(session_dir)
        .map_err(|source| AutosaveError::CreateFolder { source, path: session_dir.to_path_buf() })?;
    let path = session_path(session_dir);
    write_atomically(&path, |writer| writer.write_all(text.as_bytes()))
        .map_err(|source| AutosaveError::Write { source, path })
}

/// The saved session, if there is a readable one.
pub fn load(session_dir: &Path) -> Option<SavedSession> {
    match read(session_dir) {
        Ok(session) => session,
        Err(problem) => {
            log::warn!("ignoring the saved session {}: {problem}", session_path(session_dir).display());
            None
        }
    }
}

/// The saved session; `Ok(None)` when there is none, `Err` when it cannot be read.
fn read(session_dir: &Path) -> Result<Option<SavedSession>, AutosaveError> {
    let path = session_path(session_dir);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(error) => return Err(AutosaveError::Read(error)),
    };
    from_record(serde_json::from_str(&text)?).map(Some)
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
    use volasso_core::slices::Axis;
    use volasso_core::strokes::{ClassStrokes, Lasso};

    fn session() -> SavedSession {
        let lasso = Lasso { axis: Axis::Y, slice: 4, points: vec![[1.0, 2.0], [7.5, 2.0], [7.5, 9.0]] };
        SavedSession {
            volume: "demo".into(),
            template: "L".into(),
            rotation_degrees: 42.0,
            strokes: StrokesFile { classes: vec![ClassStrokes { name: "Class 1".into(), strokes: vec![lasso] }] },
            look: SavedLook::default(),
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

    fn files(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn a_restore_that_stopped_the_app_is_set_aside_at_the_next_start() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path();
        assert_eq!(begin_restore(dir), Restore::Nothing);
        save(dir, &session()).unwrap();
        // First start: restore, with the marker down.
        assert_eq!(begin_restore(dir), Restore::Session(session()));
        assert_eq!(files(dir), ["session.json", "session.restoring"]);
        // The app died before `restored`: the next start sets the session aside, once.
        let Restore::SetAside(aside) = begin_restore(dir) else { panic!("the session must be set aside") };
        assert_eq!(aside.volume.as_deref(), Some("demo"));
        assert!(aside.message().starts_with("The last session (demo) was not restored: the app stopped while opening it. It was kept as session-failed-"), "{}", aside.message());
        let kept = aside.kept_as.clone().unwrap();
        assert_eq!(files(dir), [kept.file_name().unwrap().to_string_lossy().into_owned()]);
        assert!(kept.file_name().unwrap().to_string_lossy().starts_with("session-failed-"));
        // Nothing is lost: the file set aside is the session.
        let text = std::fs::read_to_string(&kept).unwrap();
        assert!(text.contains(SESSION_FORMAT) && text.contains("Class 1"));
        assert_eq!(begin_restore(dir), Restore::Nothing);
    }

    #[test]
    fn a_restore_that_opened_keeps_the_session_and_one_that_failed_sets_it_aside() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path();
        save(dir, &session()).unwrap();
        assert!(matches!(begin_restore(dir), Restore::Session(_)));
        restored(dir);
        assert_eq!(files(dir), ["session.json"]);
        assert!(matches!(begin_restore(dir), Restore::Session(_)));
        let aside = abandon(dir, "demo".into(), "the reader failed".into());
        assert_eq!(aside.reason, "the reader failed");
        assert_eq!(files(dir).len(), 1);
        assert!(files(dir)[0].starts_with("session-failed-"));
        // A second failure in the same second does not overwrite the first.
        save(dir, &session()).unwrap();
        assert!(matches!(begin_restore(dir), Restore::Session(_)));
        abandon(dir, "demo".into(), "again".into());
        assert_eq!(files(dir).len(), 2);
    }

    #[test]
    fn an_unreadable_session_is_set_aside_not_overwritten() {
        let folder = tempfile::tempdir().unwrap();
        std::fs::write(session_path(folder.path()), b"{\"format\": \"volasso-session/1\", \"vol").unwrap();
        let Restore::SetAside(aside) = begin_restore(folder.path()) else { panic!("a damaged file is set aside") };
        assert!(aside.reason.starts_with("it cannot be read"), "{}", aside.reason);
        assert!(aside.kept_as.unwrap().exists());
        assert!(!session_path(folder.path()).exists());
    }

    #[test]
    fn opacities_and_the_clip_plane_come_back_and_older_files_still_load() {
        let folder = tempfile::tempdir().unwrap();
        let mut with_look = session();
        with_look.look.class_opacity.insert("Class 1".into(), 0.4);
        with_look.look.clip = Some(ClipPlane { normal: [0.0, -1.0, 0.0], offset_mm: 12.5 });
        save(folder.path(), &with_look).unwrap();
        assert_eq!(load(folder.path()), Some(with_look));
        // A file written before these fields existed loads with the defaults.
        let path = session_path(folder.path());
        let old = serde_json::json!({
            "format": SESSION_FORMAT, "volume": "demo", "template": "L", "rotation_degrees": 42.0,
            "strokes": serde_json::from_str::<serde_json::Value>(&session().strokes.to_json().unwrap()).unwrap(),
        });
        std::fs::write(&path, old.to_string()).unwrap();
        assert_eq!(load(folder.path()), Some(session()));
        // Lying values are made harmless: clamped opacities, no plane without a direction.
        let lying = old.as_object().unwrap().clone().into_iter().chain([
            ("class_opacity".to_string(), serde_json::json!({"Class 1": 1e9, "Class 2": -3.0})),
            ("clip".to_string(), serde_json::json!({"normal": [0.0, 0.0, 0.0], "offset_mm": 1.0})),
        ]);
        std::fs::write(&path, serde_json::Value::Object(lying.collect()).to_string()).unwrap();
        let look = load(folder.path()).unwrap().look;
        assert_eq!(look.class_opacity["Class 1"], volasso_core::render::MAX_CLASS_OPACITY_FACTOR);
        assert_eq!(look.class_opacity["Class 2"], 0.0);
        assert_eq!(look.clip, None);
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
