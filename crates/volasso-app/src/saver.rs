//! The autosave writer: the session is written (atomically, with an fsync, `autosave::save`) on a
//! thread of its own, so the UI thread only hands over a copy and never waits for the disk.
//!
//! Requests are applied in the order given, and the newest wins: when several are waiting, only
//! the last is carried out, because each (a save, or forgetting the session) decides the whole
//! of `session.json` alone. It is a [`Serial`] worker whose newer request supersedes a waiting
//! one. [`AutosaveWriter::flush`] waits until everything handed over is on disk (the idle reset
//! and the app's end call it); dropping the writer flushes too.
//!
//! Never: touches the UI, or leaves a request handed over unwritten when the app ends normally.

use super::autosave::{self, SavedSession};
use super::worker::{Report, Serial, Supersedes, Task, Ticket, Worker};
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// The longest [`AutosaveWriter::flush`] waits for the disk.
pub const FLUSH_LIMIT: Duration = Duration::from_secs(30);

/// What the writer is asked to do; each decides the whole of the folder's session alone.
enum Request {
    /// Write this session into the folder.
    Save(PathBuf, Box<SavedSession>),
    /// Remove the saved session and the restore marker from the folder.
    Forget(PathBuf),
}

/// The UI thread's handle on the autosave writer.
pub struct AutosaveWriter {
    worker: RefCell<Box<dyn Worker<Request, ()>>>,
}

impl Default for AutosaveWriter {
    fn default() -> Self {
        AutosaveWriter::new()
    }
}

/// The writer's task: one request carried out.
fn write_task() -> Task<Request, ()> {
    Arc::new(|request: Request, _: &Ticket, _: &Report<'_, ()>| carry_out(request))
}

impl AutosaveWriter {
    /// The writer on a thread of its own (on the caller's thread, late but losing nothing,
    /// when that cannot start).
    pub fn new() -> AutosaveWriter {
        let supersedes: Supersedes<Request> = Arc::new(|_, _| true);
        AutosaveWriter { worker: RefCell::new(Box::new(Serial::new("autosave", write_task(), supersedes))) }
    }

    /// A writer without a thread: each request is carried out on the caller's thread as it is
    /// handed over. For tests, which must start no thread.
    #[cfg(test)]
    pub fn inline() -> AutosaveWriter {
        AutosaveWriter { worker: RefCell::new(Box::new(super::worker::Inline::new(write_task()))) }
    }

    /// Saves `session` into `session_dir` soon; returns at once.
    pub fn save(&self, session_dir: PathBuf, session: SavedSession) {
        self.send(Request::Save(session_dir, Box::new(session)));
    }

    /// Forgets the saved session in `session_dir` (after every save handed over before).
    pub fn forget(&self, session_dir: PathBuf) {
        self.send(Request::Forget(session_dir));
    }

    /// Waits until every request handed over so far is on disk (at most [`FLUSH_LIMIT`]: a
    /// disk that hangs for longer is logged, and the app goes on).
    pub fn flush(&self) {
        let mut worker = self.worker.borrow_mut();
        let started = std::time::Instant::now();
        loop {
            while worker.poll().is_some() {}
            while worker.ended_silently().is_some() {}
            if !worker.busy() {
                return;
            }
            if started.elapsed() > FLUSH_LIMIT {
                log::error!("the session was not written within {} s", FLUSH_LIMIT.as_secs());
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn send(&self, request: Request) {
        let mut worker = self.worker.borrow_mut();
        worker.send(request);
        // Collects what has ended (an inline writer carries the request out here).
        while worker.poll().is_some() {}
        while worker.ended_silently().is_some() {}
    }
}

impl Drop for AutosaveWriter {
    fn drop(&mut self) {
        self.flush();
    }
}

fn carry_out(request: Request) {
    match request {
        Request::Save(dir, session) => {
            if let Err(message) = autosave::save(&dir, &session) {
                log::warn!("{message}");
            }
        }
        Request::Forget(dir) => {
            autosave::remove(&dir);
            autosave::restored(&dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volasso_core::strokes::StrokesFile;

    fn session(volume: &str) -> SavedSession {
        SavedSession {
            volume: volume.to_string(),
            template: String::new(),
            rotation_degrees: 0.0,
            strokes: StrokesFile::default(),
            look: Default::default(),
        }
    }

    #[test]
    fn saves_land_on_disk_in_order_and_the_caller_never_syncs() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path().join("session");
        let writer = AutosaveWriter::new();
        let syncs_before = volasso_core::atomic_file::syncs_on_this_thread();
        for n in 0..20 {
            writer.save(dir.clone(), session(&format!("volume-{n}")));
        }
        writer.flush();
        assert_eq!(autosave::load(&dir).unwrap().volume, "volume-19");
        // A forget after saves removes the file; a save after it writes it again.
        writer.save(dir.clone(), session("a"));
        writer.forget(dir.clone());
        writer.flush();
        assert!(!autosave::session_path(&dir).exists());
        writer.forget(dir.clone());
        writer.save(dir.clone(), session("b"));
        drop(writer);
        assert_eq!(autosave::load(&dir).unwrap().volume, "b");
        // Every fsync ran on the writer thread, none on the caller's.
        assert_eq!(volasso_core::atomic_file::syncs_on_this_thread(), syncs_before);
        volasso_core::atomic_file::write_atomically(&dir.join("probe"), |_| Ok(())).unwrap();
        assert!(volasso_core::atomic_file::syncs_on_this_thread() > syncs_before, "the counter counts");
    }

    #[test]
    fn the_inline_writer_writes_as_it_is_handed_over() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path().join("session");
        let writer = AutosaveWriter::inline();
        writer.save(dir.clone(), session("a"));
        assert_eq!(autosave::load(&dir).unwrap().volume, "a");
        writer.forget(dir.clone());
        assert!(!autosave::session_path(&dir).exists());
    }
}
