//! The autosave writer: the session is written (atomically, with an fsync, `autosave::save`) on a
//! thread of its own, so the UI thread only hands over a copy and never waits for the disk.
//!
//! Requests are applied in the order given, and the newest wins: when several are waiting, only
//! the last is carried out, because each (a save, or forgetting the session) decides the whole
//! of `session.json` alone. [`AutosaveWriter::flush`] waits until everything handed over is on
//! disk (the idle reset and the app's end call it); dropping the writer flushes too.
//!
//! Never: touches the UI, or leaves a request handed over unwritten when the app ends normally.

use super::autosave::{self, SavedSession};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

/// What the writer thread is asked to do.
enum Request {
    /// Write this session into the folder.
    Save(PathBuf, Box<SavedSession>),
    /// Remove the saved session and the restore marker from the folder.
    Forget(PathBuf),
    /// Answer once everything before is done.
    Flush(Sender<()>),
}

/// The UI thread's handle on the autosave thread.
pub struct AutosaveWriter {
    requests: Option<Sender<Request>>,
    thread: Option<JoinHandle<()>>,
}

impl Default for AutosaveWriter {
    fn default() -> Self {
        AutosaveWriter::new()
    }
}

impl AutosaveWriter {
    /// Starts the thread; when it cannot start, requests are carried out on the caller's thread
    /// (late, but nothing is lost).
    pub fn new() -> AutosaveWriter {
        let (requests, received) = channel();
        let thread = std::thread::Builder::new()
            .name("autosave".into())
            .spawn(move || write_thread(received))
            .map_err(|error| log::error!("cannot start the autosave thread, saving on the UI thread: {error}"))
            .ok();
        AutosaveWriter { requests: thread.as_ref().map(|_| requests), thread }
    }

    /// A writer without a thread: each request is carried out on the caller's thread as it is
    /// handed over. For tests, which must start no thread.
    #[cfg(test)]
    pub fn inline() -> AutosaveWriter {
        AutosaveWriter { requests: None, thread: None }
    }

    /// Saves `session` into `session_dir` soon; returns at once.
    pub fn save(&self, session_dir: PathBuf, session: SavedSession) {
        self.send(Request::Save(session_dir, Box::new(session)));
    }

    /// Forgets the saved session in `session_dir` (after every save handed over before).
    pub fn forget(&self, session_dir: PathBuf) {
        self.send(Request::Forget(session_dir));
    }

    /// Waits until every request handed over so far is on disk.
    pub fn flush(&self) {
        let (done, finished) = channel();
        self.send(Request::Flush(done));
        let _ = finished.recv();
    }

    fn send(&self, request: Request) {
        let unsent = match &self.requests {
            Some(requests) => match requests.send(request) {
                Ok(()) => return,
                Err(error) => error.0,
            },
            None => request,
        };
        carry_out(unsent);
    }
}

impl Drop for AutosaveWriter {
    fn drop(&mut self) {
        // Closing the channel ends the thread once it has written what it was given.
        self.requests = None;
        if let Some(thread) = self.thread.take()
            && thread.join().is_err()
        {
            log::error!("the autosave thread failed");
        }
    }
}

fn write_thread(requests: Receiver<Request>) {
    while let Ok(first) = requests.recv() {
        let mut waiting = vec![first];
        waiting.extend(requests.try_iter());
        // The last save or forget decides the file; flushes are answered after it.
        let newest = waiting.iter().rposition(|request| !matches!(request, Request::Flush(_)));
        for (index, request) in waiting.into_iter().enumerate() {
            if matches!(request, Request::Flush(_)) || Some(index) == newest {
                carry_out(request);
            }
        }
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
        Request::Flush(done) => {
            let _ = done.send(());
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
