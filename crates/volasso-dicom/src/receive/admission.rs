//! Who gets an association: at most [`Limits::total`] connections at once, at most
//! [`Limits::per_peer`] from one peer address. A connection over either limit is answered with
//! A-ASSOCIATE-RJ, rejected-transient, source "service-provider (presentation)", reason
//! "local-limit-exceeded" (PS3.8 §9.3.4), on a short-lived thread of its own: the accepting
//! loop never waits, and a peer over the limit is told so at once instead of hanging.
//!
//! The rejecting thread reads the peer's A-ASSOCIATE-RQ first (for at most [`REJECT_PATIENCE`],
//! so its bytes are not left unread and the close is not a reset that could swallow the
//! answer), then sends the rejection and closes. At most [`MOST_REJECTING`] rejections run at
//! once; beyond that a connection is closed at once.
//!
//! Never: reads more than one PDU (capped at [`MOST_REQUEST_BYTES`]) from a rejected peer.

use dicom_ul::Pdu;
use dicom_ul::pdu::{
    AssociationRJ, AssociationRJResult, AssociationRJServiceProviderPresentationReason, AssociationRJSource,
};
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{IpAddr, Shutdown, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The longest a rejected peer is given to send its request and read the answer.
pub const REJECT_PATIENCE: Duration = Duration::from_secs(3);
/// Rejections under way at once.
pub const MOST_REJECTING: usize = 64;
/// An A-ASSOCIATE-RQ longer than this is not read to its end before the rejection.
const MOST_REQUEST_BYTES: u64 = 1 << 20;

/// The limits on connections.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Connections served at once, from all peers.
    pub total: usize,
    /// Connections served at once from one peer address.
    pub per_peer: usize,
}

/// Why a connection was not admitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverLimit {
    Total,
    PerPeer,
}

#[derive(Default)]
struct Counts {
    total: usize,
    by_peer: HashMap<IpAddr, usize>,
}

/// The connections being served, counted.
#[derive(Clone)]
pub struct Admission {
    limits: Limits,
    counts: Arc<Mutex<Counts>>,
    rejecting: Arc<AtomicUsize>,
}

impl Admission {
    pub fn new(limits: Limits) -> Admission {
        Admission { limits, counts: Arc::default(), rejecting: Arc::default() }
    }

    /// A place for a connection from `peer`, held until the returned slot is dropped, or the
    /// limit it is over.
    pub fn admit(&self, peer: IpAddr) -> Result<Slot, OverLimit> {
        let mut counts = self.counts.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if counts.total >= self.limits.total {
            return Err(OverLimit::Total);
        }
        let from_peer = counts.by_peer.entry(peer).or_insert(0);
        if *from_peer >= self.limits.per_peer {
            return Err(OverLimit::PerPeer);
        }
        *from_peer += 1;
        counts.total += 1;
        Ok(Slot { counts: Arc::clone(&self.counts), peer })
    }

    /// Answers `stream` with a local-limit-exceeded rejection on a thread of its own, through
    /// `wrap` (TLS when the port speaks it); closes it at once when too many rejections are
    /// under way already.
    pub fn reject<S, F>(&self, stream: TcpStream, wrap: F)
    where
        S: Read + Write,
        F: FnOnce(TcpStream) -> Option<S> + Send + 'static,
    {
        if self.rejecting.fetch_add(1, Ordering::SeqCst) >= MOST_REJECTING {
            self.rejecting.fetch_sub(1, Ordering::SeqCst);
            let _ = stream.shutdown(Shutdown::Both);
            return;
        }
        let rejecting = Arc::clone(&self.rejecting);
        let spawned = std::thread::Builder::new().name("receive-reject".into()).spawn(move || {
            answer_and_close(stream, wrap, &limit_rejection());
            rejecting.fetch_sub(1, Ordering::SeqCst);
        });
        if spawned.is_err() {
            self.rejecting.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// One admitted connection's place, given back when dropped.
pub struct Slot {
    counts: Arc<Mutex<Counts>>,
    peer: IpAddr,
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut counts = self.counts.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        counts.total = counts.total.saturating_sub(1);
        if let Some(count) = counts.by_peer.get_mut(&self.peer) {
            *count = count.saturating_sub(1);
            if *count == 0 {
                counts.by_peer.remove(&self.peer);
            }
        }
    }
}

/// The bytes of the rejection every peer over a limit gets.
pub fn limit_rejection() -> Vec<u8> {
    let pdu = Pdu::AssociationRJ(AssociationRJ {
        result: AssociationRJResult::Transient,
        source: AssociationRJSource::ServiceProviderPresentation(
            AssociationRJServiceProviderPresentationReason::LocalLimitExceeded,
        ),
    });
    let mut bytes = Vec::new();
    // Writing a fixed ten-byte PDU into memory cannot fail.
    let _ = dicom_ul::write_pdu(&mut bytes, &pdu);
    bytes
}

/// Reads the peer's request (see the module doc), answers it with `answer` through `wrap`
/// (TLS, when the port speaks it) and closes the connection.
pub fn answer_and_close<S: Read + Write>(stream: TcpStream, wrap: impl FnOnce(TcpStream) -> Option<S>, answer: &[u8]) {
    let started = Instant::now();
    if stream.set_read_timeout(Some(REJECT_PATIENCE)).is_err()
        || stream.set_write_timeout(Some(REJECT_PATIENCE)).is_err()
    {
        return;
    }
    let Ok(socket) = stream.try_clone() else { return };
    let Some(mut peer) = wrap(stream) else { return };
    // The request's header, then its body (discarded), while time is left.
    let mut header = [0u8; 6];
    if peer.read_exact(&mut header).is_ok() && header[0] == 0x01 && started.elapsed() < REJECT_PATIENCE {
        let length = u64::from(u32::from_be_bytes([header[2], header[3], header[4], header[5]]));
        let _ = std::io::copy(&mut (&mut peer).take(length.min(MOST_REQUEST_BYTES)), &mut std::io::sink());
    }
    if peer.write_all(answer).and_then(|()| peer.flush()).is_ok() {
        // The peer closes once it has read the answer; wait for that briefly, so the close is
        // not a reset racing the answer.
        let _ = socket.shutdown(Shutdown::Write);
        let left = REJECT_PATIENCE.saturating_sub(started.elapsed()).max(Duration::from_millis(100));
        let _ = socket.set_read_timeout(Some(left));
        let _ = std::io::copy(&mut (&socket).take(MOST_REQUEST_BYTES), &mut std::io::sink());
    }
    let _ = socket.shutdown(Shutdown::Both);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::{Ipv4Addr, TcpListener};

    #[test]
    fn limits_count_per_peer_and_in_total_and_free_on_drop() {
        let admission = Admission::new(Limits { total: 3, per_peer: 2 });
        let (a, b, c) = (IpAddr::from([10, 0, 0, 1]), IpAddr::from([10, 0, 0, 2]), IpAddr::from([10, 0, 0, 3]));
        let first = admission.admit(a).unwrap();
        let _second = admission.admit(a).unwrap();
        assert_eq!(admission.admit(a).err(), Some(OverLimit::PerPeer));
        let _third = admission.admit(b).unwrap();
        assert_eq!(admission.admit(c).err(), Some(OverLimit::Total));
        drop(first);
        assert!(admission.admit(c).is_ok());
    }

    #[test]
    fn a_rejected_peer_reads_a_transient_local_limit_rejection() {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap();
        let mut client = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let (accepted, _) = listener.accept().unwrap();
        Admission::new(Limits { total: 0, per_peer: 0 }).reject(accepted, Some);
        // An A-ASSOCIATE-RQ header announcing four bytes, then those bytes.
        client.write_all(&[0x01, 0, 0, 0, 0, 4, 1, 2, 3, 4]).unwrap();
        client.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut answer = Vec::new();
        client.read_to_end(&mut answer).unwrap();
        // Type 3 (A-ASSOCIATE-RJ), result 2 (transient), source 3 (presentation), reason 2.
        assert_eq!(answer, [0x03, 0, 0, 0, 0, 4, 0, 2, 3, 2]);
        assert_eq!(answer, limit_rejection());
    }
}
