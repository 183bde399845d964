//! Deadlines for connections: one thread shuts down the socket of any connection whose
//! deadline has passed, which ends whatever read or write its association thread is blocked
//! in (a TLS one too: it reads from the same socket). A peer that sends one byte now and then
//! defeats a socket's read timeout, never this.
//!
//! Each connection's deadline is the earliest of the phase's own (the ACSE timeout while
//! negotiating; the idle timeout after the last complete PDU once associated) and the
//! association's overall deadline.
//!
//! Never: reads or writes a socket's data, or closes one it was not given.

use std::collections::BTreeMap;
use std::net::{Shutdown, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often deadlines are looked at: a connection lives at most this much past its own.
const TICK: Duration = Duration::from_millis(100);

struct Watched {
    socket: TcpStream,
    deadline: Instant,
    expired: Arc<AtomicBool>,
}

/// The connections watched, by number.
#[derive(Clone, Default)]
pub struct Watchdog {
    watched: Arc<Mutex<BTreeMap<u64, Watched>>>,
    next: Arc<AtomicU64>,
}

impl Watchdog {
    /// Starts the thread that enforces the deadlines; it runs as long as the process.
    pub fn start() -> std::io::Result<Watchdog> {
        let watchdog = Watchdog::default();
        let watched = Arc::clone(&watchdog.watched);
        std::thread::Builder::new().name("receive-watchdog".into()).spawn(move || {
            loop {
                std::thread::sleep(TICK);
                let now = Instant::now();
                let mut watched = watched.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                for entry in watched.values_mut() {
                    if entry.deadline <= now && !entry.expired.swap(true, Ordering::SeqCst) {
                        let _ = entry.socket.shutdown(Shutdown::Both);
                    }
                }
            }
        })?;
        Ok(watchdog)
    }

    /// Watches `socket` (a clone of the connection's) until the returned guard is dropped.
    pub fn watch(&self, socket: &TcpStream, deadline: Instant) -> std::io::Result<Deadline> {
        let socket = socket.try_clone()?;
        let number = self.next.fetch_add(1, Ordering::Relaxed);
        let expired = Arc::new(AtomicBool::new(false));
        let entry = Watched { socket, deadline, expired: Arc::clone(&expired) };
        self.watched.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).insert(number, entry);
        Ok(Deadline { watchdog: self.clone(), number, expired })
    }
}

/// One watched connection; dropping it stops the watch.
pub struct Deadline {
    watchdog: Watchdog,
    number: u64,
    expired: Arc<AtomicBool>,
}

impl Deadline {
    /// Moves the connection's deadline.
    pub fn set(&self, deadline: Instant) {
        let mut watched = self.watchdog.watched.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(entry) = watched.get_mut(&self.number) {
            entry.deadline = deadline;
        }
    }

    /// Whether the watchdog shut the connection down.
    pub fn expired(&self) -> bool {
        self.expired.load(Ordering::SeqCst)
    }
}

impl Drop for Deadline {
    fn drop(&mut self) {
        self.watchdog.watched.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).remove(&self.number);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::TcpListener;

    #[test]
    fn a_read_blocked_past_its_deadline_ends_and_an_extended_one_does_not() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let _first = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let _second = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let (mut short, _) = listener.accept().unwrap();
        let (long, _) = listener.accept().unwrap();
        let watchdog = Watchdog::start().unwrap();
        let started = Instant::now();
        let short_deadline = watchdog.watch(&short, started + Duration::from_millis(300)).unwrap();
        let long_deadline = watchdog.watch(&long, started + Duration::from_millis(300)).unwrap();
        long_deadline.set(started + Duration::from_secs(3600));
        // The peer sends nothing: only the watchdog ends this read.
        let read = short.read(&mut [0u8; 16]).unwrap_or(0);
        assert_eq!(read, 0);
        let waited = started.elapsed();
        assert!(waited >= Duration::from_millis(300) && waited < Duration::from_secs(2), "{waited:?}");
        assert!(short_deadline.expired());
        assert!(!long_deadline.expired());
    }
}
