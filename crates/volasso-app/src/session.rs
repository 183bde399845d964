//! The user's work on one volume: the classes defined so far, the lassos waiting to become the
//! next class, and undo. Plain data; the UI shows it and the classifier reads it as a
//! [`StrokesFile`] (paper §3.2: lassos per class, then "define class").
//!
//! Never: touches the UI, the volume's voxels or the classifier.

use volasso_core::strokes::{ClassStrokes, Lasso, StrokesFile};

/// How many steps undo remembers; older ones are forgotten, so a long session stays bounded.
pub const UNDO_DEPTH: usize = 64;

/// The most classes a session holds: the class bar has room for this many rows at 1280x800,
/// and the harmonic templates keep this many hues apart.
pub const MAX_CLASSES: usize = 8;

/// A class the user defined, with the lassos that define it.
#[derive(Clone, Debug, PartialEq)]
pub struct DefinedClass {
    pub name: String,
    pub lassos: Vec<Lasso>,
    pub visible: bool,
    /// A class of the learned preset applied (no lassos of its own; the preset trains it).
    pub from_preset: bool,
}

/// What the user has drawn and defined; see the module doc.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorkSession {
    pub classes: Vec<DefinedClass>,
    /// Lassos drawn since the last "define class".
    pub pending: Vec<Lasso>,
    undo: Vec<Snapshot>,
    /// Names are never reused within a session, so "Class 3" stays class 3 after a delete.
    next_number: usize,
}

#[derive(Clone, Debug, PartialEq)]
struct Snapshot {
    classes: Vec<DefinedClass>,
    pending: Vec<Lasso>,
    next_number: usize,
}

/// Why an action did nothing.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SessionError {
    #[error("draw a lasso on a slice first")]
    NothingPending,
    #[error("at most {MAX_CLASSES} classes; delete one first")]
    TooManyClasses,
    #[error("there is no class {index}")]
    NoSuchClass { index: usize },
    #[error("nothing to undo")]
    NothingToUndo,
}

impl WorkSession {
    /// A session restored from a strokes file (autosave): every class defined and visible.
    pub fn from_strokes(file: &StrokesFile) -> WorkSession {
        let classes: Vec<DefinedClass> = file
            .classes
            .iter()
            .take(MAX_CLASSES)
            .map(|class| DefinedClass {
                name: class.name.clone(),
                lassos: class.strokes.clone(),
                visible: true,
                from_preset: false,
            })
            .collect();
        let next_number = classes.len();
        WorkSession { classes, pending: Vec::new(), undo: Vec::new(), next_number }
    }

    /// The defined classes as a strokes file (what the classifier trains on and autosave
    /// writes). Pending lassos are not in it: they are not a class yet.
    pub fn strokes(&self) -> StrokesFile {
        StrokesFile {
            classes: self
                .classes
                .iter()
                .map(|class| ClassStrokes { name: class.name.clone(), strokes: class.lassos.clone() })
                .collect(),
        }
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_define(&self) -> bool {
        !self.pending.is_empty() && self.classes.len() < MAX_CLASSES
    }

    pub fn add_lasso(&mut self, lasso: Lasso) {
        self.remember();
        self.pending.push(lasso);
    }

    /// Turns the pending lassos into a new class; returns its index.
    pub fn define_class(&mut self) -> Result<usize, SessionError> {
        if self.pending.is_empty() {
            return Err(SessionError::NothingPending);
        }
        if self.classes.len() >= MAX_CLASSES {
            return Err(SessionError::TooManyClasses);
        }
        self.remember();
        self.next_number += 1;
        let lassos = std::mem::take(&mut self.pending);
        self.classes.push(DefinedClass {
            name: format!("Class {}", self.next_number),
            lassos,
            visible: true,
            from_preset: false,
        });
        Ok(self.classes.len() - 1)
    }

    pub fn delete_class(&mut self, index: usize) -> Result<(), SessionError> {
        if index >= self.classes.len() {
            return Err(SessionError::NoSuchClass { index });
        }
        self.remember();
        self.classes.remove(index);
        Ok(())
    }

    /// Shows or hides a class in the 3-D view and the overlays; not an undo step (it changes
    /// no training data and is undone by tapping again).
    pub fn toggle_visible(&mut self, index: usize) -> Result<bool, SessionError> {
        let class = self.classes.get_mut(index).ok_or(SessionError::NoSuchClass { index })?;
        class.visible = !class.visible;
        Ok(class.visible)
    }

    /// Every class and lasso replaced by a learned preset's classes `names` (without lassos;
    /// undoable, and undo takes the preset's classes back). Names of classes defined afterwards
    /// go on from the highest number used.
    pub fn replace_with_preset(&mut self, names: &[String]) {
        self.remember();
        let file = StrokesFile {
            classes: names.iter().map(|name| ClassStrokes { name: name.clone(), strokes: Vec::new() }).collect(),
        };
        let mut replaced = WorkSession::from_strokes(&file);
        for class in &mut replaced.classes {
            class.from_preset = true;
        }
        self.classes = replaced.classes;
        self.pending.clear();
        self.next_number = self.next_number.max(replaced.next_number);
    }

    /// Removes every class and lasso (undoable).
    pub fn clear(&mut self) {
        if self.classes.is_empty() && self.pending.is_empty() {
            return;
        }
        self.remember();
        self.classes.clear();
        self.pending.clear();
    }

    pub fn undo(&mut self) -> Result<(), SessionError> {
        let snapshot = self.undo.pop().ok_or(SessionError::NothingToUndo)?;
        // Visibility is not part of undo: keep what the user sees for classes that survive.
        let visible: Vec<(String, bool)> = self.classes.iter().map(|c| (c.name.clone(), c.visible)).collect();
        self.classes = snapshot.classes;
        for class in &mut self.classes {
            if let Some((_, shown)) = visible.iter().find(|(name, _)| *name == class.name) {
                class.visible = *shown;
            }
        }
        self.pending = snapshot.pending;
        self.next_number = snapshot.next_number;
        Ok(())
    }

    /// The name the next defined class will get.
    pub fn next_class_name(&self) -> String {
        format!("Class {}", self.next_number + 1)
    }

    fn remember(&mut self) {
        if self.undo.len() == UNDO_DEPTH {
            self.undo.remove(0);
        }
        self.undo.push(Snapshot {
            classes: self.classes.clone(),
            pending: self.pending.clone(),
            next_number: self.next_number,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volasso_core::slices::Axis;

    fn lasso(slice: usize) -> Lasso {
        Lasso { axis: Axis::Z, slice, points: vec![[1.0, 1.0], [5.0, 1.0], [5.0, 5.0]] }
    }

    #[test]
    fn define_class_moves_pending_lassos_into_a_named_class() {
        let mut session = WorkSession::default();
        assert_eq!(session.define_class(), Err(SessionError::NothingPending));
        session.add_lasso(lasso(1));
        session.add_lasso(lasso(2));
        assert_eq!(session.define_class(), Ok(0));
        assert!(session.pending.is_empty());
        assert_eq!(session.classes[0].name, "Class 1");
        assert_eq!(session.classes[0].lassos.len(), 2);
        assert_eq!(session.strokes().classes[0].strokes, vec![lasso(1), lasso(2)]);
    }

    #[test]
    fn undo_reverses_each_step_in_order() {
        let mut session = WorkSession::default();
        session.add_lasso(lasso(1));
        session.define_class().unwrap();
        session.add_lasso(lasso(2));
        session.define_class().unwrap();
        session.delete_class(0).unwrap();
        assert_eq!(session.classes.len(), 1);
        session.undo().unwrap();
        assert_eq!(session.classes.len(), 2);
        session.undo().unwrap();
        assert_eq!((session.classes.len(), session.pending.len()), (1, 1));
        session.undo().unwrap();
        session.undo().unwrap();
        session.undo().unwrap();
        assert_eq!(session, WorkSession::default());
        assert_eq!(session.undo(), Err(SessionError::NothingToUndo));
    }

    #[test]
    fn names_are_not_reused_after_a_delete() {
        let mut session = WorkSession::default();
        for slice in 0..2 {
            session.add_lasso(lasso(slice));
            session.define_class().unwrap();
        }
        session.delete_class(0).unwrap();
        session.add_lasso(lasso(3));
        session.define_class().unwrap();
        let names: Vec<&str> = session.classes.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["Class 2", "Class 3"]);
    }

    #[test]
    fn the_class_count_and_the_undo_history_are_bounded() {
        let mut session = WorkSession::default();
        for slice in 0..MAX_CLASSES {
            session.add_lasso(lasso(slice));
            session.define_class().unwrap();
        }
        session.add_lasso(lasso(99));
        assert!(!session.can_define());
        assert_eq!(session.define_class(), Err(SessionError::TooManyClasses));
        for slice in 0..3 * UNDO_DEPTH {
            session.add_lasso(lasso(slice));
        }
        assert_eq!(session.undo.len(), UNDO_DEPTH);
        assert_eq!(session.delete_class(MAX_CLASSES), Err(SessionError::NoSuchClass { index: MAX_CLASSES }));
    }

    #[test]
    fn visibility_survives_undo_and_restoring_gives_visible_classes() {
        let mut session = WorkSession::default();
        session.add_lasso(lasso(1));
        session.define_class().unwrap();
        session.add_lasso(lasso(2));
        assert_eq!(session.toggle_visible(0), Ok(false));
        session.undo().unwrap();
        assert!(!session.classes[0].visible);
        let restored = WorkSession::from_strokes(&session.strokes());
        assert!(restored.classes[0].visible);
        assert_eq!(restored.next_class_name(), "Class 2");
    }
}
