//! Peers that hold connections: sixteen silent connections and a slow-drip peer leave a
//! well-behaved `echoscu` answered within 5 s, and those over the per-address limit are told
//! "local limit exceeded"; over the global limit `echoscu` itself is rejected so, at once; the
//! ACSE, idle and overall timeouts end a peer that sends a byte now and then. Hostile peers
//! connect from other loopback addresses (127.0.0.2, ...), as other hosts would.

use super::{Scp, dcmtk_available, text};
use dicom_ul::Pdu;
use dicom_ul::pdu::{AssociationRQ, PDataValue, PDataValueType, PresentationContextProposed, UserVariableItem};
use std::io::{Read, Write};
use std::net::{Ipv4Addr, TcpStream};
use std::os::fd::FromRawFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The rejection a peer over a limit reads: A-ASSOCIATE-RJ, transient, service provider
/// (presentation), local limit exceeded.
const LIMIT_REJECTION: [u8; 10] = [0x03, 0, 0, 0, 0, 4, 0, 2, 3, 2];

/// A TCP connection to `port` on 127.0.0.1 from the loopback address `source`.
fn connect_from(source: Ipv4Addr, port: u16) -> TcpStream {
    let address = |ip: Ipv4Addr, port: u16| libc::sockaddr_in {
        sin_family: libc::AF_INET as libc::sa_family_t,
        sin_port: port.to_be(),
        sin_addr: libc::in_addr { s_addr: u32::from(ip).to_be() },
        sin_zero: [0; 8],
    };
    let length = std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t;
    // SAFETY: a new socket, bound and connected with fully initialised addresses of the
    // length given; its descriptor is owned by the TcpStream from then on.
    unsafe {
        let socket = libc::socket(libc::AF_INET, libc::SOCK_STREAM | libc::SOCK_CLOEXEC, 0);
        assert!(socket >= 0, "socket: {}", std::io::Error::last_os_error());
        let stream = TcpStream::from_raw_fd(socket);
        let local = address(source, 0);
        let bound = libc::bind(socket, (&raw const local).cast(), length);
        assert_eq!(bound, 0, "bind {source}: {}", std::io::Error::last_os_error());
        let remote = address(Ipv4Addr::LOCALHOST, port);
        let connected = libc::connect(socket, (&raw const remote).cast(), length);
        assert_eq!(connected, 0, "connect from {source}: {}", std::io::Error::last_os_error());
        stream
    }
}

/// An A-ASSOCIATE-RQ for Verification, calling VOLASSO, as bytes.
fn association_request() -> Vec<u8> {
    let request = Pdu::AssociationRQ(AssociationRQ {
        protocol_version: 1,
        calling_ae_title: "DRIP".into(),
        called_ae_title: "VOLASSO".into(),
        application_context_name: "1.2.840.10008.3.1.1.1".into(),
        presentation_contexts: vec![PresentationContextProposed {
            id: 1,
            abstract_syntax: "1.2.840.10008.1.1".into(),
            transfer_syntaxes: vec!["1.2.840.10008.1.2".into()],
        }],
        user_variables: vec![UserVariableItem::MaxLength(16384)],
    });
    let mut bytes = Vec::new();
    dicom_ul::write_pdu(&mut bytes, &request).unwrap();
    bytes
}

/// Sends `bytes` one at a time, `pause` apart, until they run out, `stop` is set or the
/// receiver closes the connection; returns how long the connection lasted.
fn drip(mut stream: TcpStream, bytes: Vec<u8>, pause: Duration, stop: Arc<AtomicBool>) -> Duration {
    let started = Instant::now();
    for byte in bytes {
        if stop.load(Ordering::SeqCst) || stream.write_all(&[byte]).is_err() {
            break;
        }
        std::thread::sleep(pause);
    }
    started.elapsed()
}

/// Whether the receiver closed `stream`, waiting at most `patience`.
fn closed_within(stream: &mut TcpStream, patience: Duration) -> bool {
    stream.set_read_timeout(Some(patience)).unwrap();
    let mut sink = [0u8; 1024];
    loop {
        match stream.read(&mut sink) {
            Ok(0) => return true,
            Ok(_) => {}
            Err(error) => {
                return !matches!(error.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut);
            }
        }
    }
}

#[test]
fn sixteen_silent_connections_and_a_slow_drip_leave_echo_answered_within_five_seconds() {
    if !dcmtk_available() {
        return;
    }
    // The default limits (16 in all, 8 per address) and timeouts (30 s to associate).
    let scp = Scp::start(&[]);
    let silent: Vec<TcpStream> = (0..16).map(|_| connect_from(Ipv4Addr::new(127, 0, 0, 2), scp.port)).collect();
    let stop = Arc::new(AtomicBool::new(false));
    let dripping = {
        let stream = connect_from(Ipv4Addr::new(127, 0, 0, 3), scp.port);
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || drip(stream, association_request(), Duration::from_secs(2), stop))
    };
    std::thread::sleep(Duration::from_millis(300));
    let started = Instant::now();
    let echo = scp.client("echoscu", &[], &[]);
    let answered = started.elapsed();
    assert!(echo.status.success(), "echoscu: {}", text(&echo));
    assert!(answered < Duration::from_secs(5), "echo answered after {answered:?}");
    // The eight silent connections over the per-address limit were told so, once they had
    // had their chance to send a request.
    std::thread::sleep(volasso::receive::REJECT_PATIENCE.saturating_sub(started.elapsed()) + Duration::from_secs(1));
    let rejected = silent
        .into_iter()
        .filter_map(|mut stream| {
            stream.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
            let mut answer = [0u8; 10];
            stream.read_exact(&mut answer).ok().map(|()| answer)
        })
        .collect::<Vec<_>>();
    assert_eq!(rejected.len(), 8, "{rejected:?}");
    assert!(rejected.iter().all(|answer| *answer == LIMIT_REJECTION), "{rejected:?}");
    stop.store(true, Ordering::SeqCst);
    dripping.join().unwrap();
    eprintln!("echo answered in {answered:?} beside 16 silent connections and a slow drip");
}

#[test]
fn over_the_global_limit_echo_is_rejected_at_once_and_served_once_a_place_is_free() {
    if !dcmtk_available() {
        return;
    }
    let scp = Scp::start(&["--max-associations", "2"]);
    let first = connect_from(Ipv4Addr::new(127, 0, 0, 2), scp.port);
    let _second = connect_from(Ipv4Addr::new(127, 0, 0, 3), scp.port);
    std::thread::sleep(Duration::from_millis(300));
    let started = Instant::now();
    let refused = scp.client("echoscu", &[], &[]);
    let answered = started.elapsed();
    assert!(!refused.status.success());
    let said = text(&refused).to_lowercase();
    assert!(said.contains("rejected") && said.contains("local limit exceeded"), "{said}");
    assert!(answered < Duration::from_secs(5), "rejected after {answered:?}");
    drop(first);
    std::thread::sleep(Duration::from_millis(300));
    let served = scp.client("echoscu", &[], &[]);
    assert!(served.status.success(), "echoscu once a place was free: {}", text(&served));
}

#[test]
fn peers_that_close_early_or_send_garbage_free_their_place_at_once() {
    if !dcmtk_available() {
        return;
    }
    // One place only: each misbehaving peer must give it back for the echo to be served.
    let scp = Scp::start(&["--max-associations", "1"]);
    let malformed = [0x01, 0, 0, 0, 0, 4, 0xFF, 0xFF, 0xFF, 0xFF];
    let tls_prefix = [0x16, 0x03, 0x01, 0x02, 0x00, 0x01];
    for (source, bytes) in [(10, &[][..]), (11, &malformed[..]), (12, &tls_prefix[..]), (13, &[0x01, 0, 0][..])] {
        let mut peer = connect_from(Ipv4Addr::new(127, 0, 0, source), scp.port);
        peer.write_all(bytes).unwrap();
        drop(peer);
        std::thread::sleep(Duration::from_millis(300));
        let echo = scp.client("echoscu", &[], &[]);
        assert!(echo.status.success(), "after a peer sent {bytes:?} and closed: {}", text(&echo));
    }
}

#[test]
fn acse_idle_and_overall_timeouts_end_peers_that_send_a_byte_now_and_then() {
    let scp = Scp::start(&["--acse-timeout", "1.5", "--idle-timeout", "1.5", "--association-timeout", "4"]);
    let stop = Arc::new(AtomicBool::new(false));
    // Negotiation, a byte every 0.5 s: never a whole request; cut by the ACSE timeout.
    let stream = connect_from(Ipv4Addr::new(127, 0, 0, 4), scp.port);
    let lasted = drip(stream, association_request(), Duration::from_millis(500), Arc::clone(&stop));
    assert!(lasted > Duration::from_millis(1200) && lasted < Duration::from_secs(4), "lasted {lasted:?}");
    // Associated, then one byte of a PDU every 0.5 s: cut by the idle timeout (no whole PDU).
    let mut idle = connect_from(Ipv4Addr::new(127, 0, 0, 5), scp.port);
    idle.write_all(&association_request()).unwrap();
    let mut accepted = [0u8; 1];
    idle.read_exact(&mut accepted).unwrap();
    assert_eq!(accepted[0], 0x02, "A-ASSOCIATE-AC");
    let started = Instant::now();
    // A P-DATA-TF header announcing 4096 bytes, then its bytes one at a time.
    let mut slow = vec![0x04, 0, 0, 0, 0x10, 0];
    slow.resize(100, 0);
    let lasted = drip(idle.try_clone().unwrap(), slow, Duration::from_millis(500), Arc::clone(&stop));
    assert!(
        lasted > Duration::from_millis(1200) && lasted < Duration::from_secs(4),
        "an idle association lasted {lasted:?}"
    );
    // Associated, and a whole small PDU every 0.5 s (a command never finished): only the
    // overall deadline ends it.
    let mut busy = connect_from(Ipv4Addr::new(127, 0, 0, 6), scp.port);
    let connected = Instant::now();
    busy.write_all(&association_request()).unwrap();
    busy.read_exact(&mut accepted).unwrap();
    let fragment = Pdu::PData {
        data: vec![PDataValue {
            presentation_context_id: 1,
            value_type: PDataValueType::Command,
            is_last: false,
            data: vec![0; 2],
        }],
    };
    let mut bytes = Vec::new();
    dicom_ul::write_pdu(&mut bytes, &fragment).unwrap();
    while busy.write_all(&bytes).is_ok() && connected.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(500));
    }
    let lasted = connected.elapsed();
    assert!(
        lasted > Duration::from_millis(3500) && lasted < Duration::from_secs(6),
        "a busy association lasted {lasted:?}"
    );
    assert!(closed_within(&mut busy, Duration::from_secs(1)));
    let log = scp.stderr_so_far();
    assert!(log.matches("timed out").count() >= 3, "{log}");
    // And the receiver still serves.
    assert!(started.elapsed() < Duration::from_secs(20));
    if dcmtk_available() {
        let echo = scp.client("echoscu", &[], &[]);
        assert!(echo.status.success(), "{}", text(&echo));
    }
}
