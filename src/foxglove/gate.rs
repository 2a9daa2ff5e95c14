//! The door in front of the Foxglove server: it takes the viewers' TCP
//! connections on the public address and passes their bytes both ways to
//! the server, which listens on an ephemeral loopback port.
//!
//! `foxglove` 0.30 gives its server no admission control: no client
//! address, no way to refuse or close one client. So the limits live here:
//! - at most [`Limits::max_clients`] connections at once; one more gets an
//!   HTTP 503 that says why, and the refusal is logged (once per
//!   [`LOG_EVERY`], with the count since);
//! - a connection that neither subscribes to a channel nor advertises one
//!   within [`Limits::subscribe_timeout`] is closed. The gate reads the
//!   client's side of the WebSocket (after the HTTP upgrade, masked frames,
//!   RFC 6455 §5.2) just far enough to see a text frame with `"op":
//!   "subscribe"` or `"op": "advertise"`, then only copies;
//! - a connection that takes no byte of what the server sends it for
//!   [`Limits::read_timeout`] is closed, and that is logged (a viewer that
//!   subscribes and never reads would otherwise hold its place for ever:
//!   16 such held every place, issue 45). The gate keeps the viewer's send
//!   buffer small ([`SEND_BUFFER`]), so what waits for a stalled viewer is
//!   bounded and the clock starts soon after it stops reading.
//!
//! Each connection costs two threads, so the limits bound the view's
//! threads and memory whatever the clients do.

use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The gate's limits (`[foxglove] max-clients`, `subscribe-timeout`).
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Most connections at once.
    pub max_clients: usize,
    /// A connection that has not subscribed this long after it opened is
    /// closed; `None`: never.
    pub subscribe_timeout: Option<Duration>,
    /// A connection that takes no byte of what the server sends it for
    /// this long, while there is some to send, is closed; `None`: never.
    pub read_timeout: Option<Duration>,
}

/// Refusals and idle closes are logged at most this often, with a count.
pub const LOG_EVERY: Duration = Duration::from_secs(5);

/// The kernel's send buffer asked for each viewer's socket (it doubles
/// it): what the server sent and a viewer has not read waits there, and
/// in the viewer's own receive buffer, before the gate's write blocks.
pub const SEND_BUFFER: libc::c_int = 128 * 1024;

/// How long the gate waits for the server behind it to accept.
const INNER_CONNECT: Duration = Duration::from_secs(2);

/// How long a refusal's reply may take to write: a client that does not
/// read it does not hold the accepting thread.
const REFUSAL_WRITE: Duration = Duration::from_millis(200);

/// Counters of what the gate did, for tests and the log.
#[derive(Debug, Default)]
pub struct Counts {
    /// Connections open now.
    pub open: AtomicUsize,
    /// Connections admitted since the start.
    pub admitted: AtomicU64,
    /// Connections refused at the limit.
    pub refused: AtomicU64,
    /// Connections closed for not subscribing in time.
    pub idle_closed: AtomicU64,
    /// Connections closed for reading nothing of what was sent to them.
    pub stalled_closed: AtomicU64,
}

/// The running gate; [`Gate::stop`] (or drop) ends it and its connections.
pub struct Gate {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    counts: Arc<Counts>,
    accept: Option<JoinHandle<()>>,
}

impl Gate {
    /// Listens on `public` and passes each admitted connection to `inner`.
    pub fn start(public: SocketAddr, inner: SocketAddr, limits: Limits) -> io::Result<Gate> {
        let listener = TcpListener::bind(public)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let counts = Arc::new(Counts::default());
        let (st, co) = (stop.clone(), counts.clone());
        let accept = std::thread::Builder::new()
            .name("foxglove-gate".into())
            .spawn(move || accept_loop(&listener, inner, limits, &st, &co))?;
        Ok(Gate {
            addr,
            stop,
            counts,
            accept: Some(accept),
        })
    }

    /// The address the gate listens on (its port, when 0 was asked).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// What the gate did so far.
    pub fn counts(&self) -> &Counts {
        &self.counts
    }

    /// Stops accepting; open connections end when their peers do.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the blocking accept with a connection of our own.
        let mut wake = self.addr;
        if wake.ip().is_unspecified() {
            wake.set_ip(if wake.is_ipv4() {
                std::net::Ipv4Addr::LOCALHOST.into()
            } else {
                std::net::Ipv6Addr::LOCALHOST.into()
            });
        }
        let _ = TcpStream::connect_timeout(&wake, INNER_CONNECT);
        if let Some(h) = self.accept.take() {
            let _ = h.join();
        }
    }
}

impl Drop for Gate {
    fn drop(&mut self) {
        if self.accept.is_some() {
            self.halt();
        }
    }
}

/// Says something at most once per [`LOG_EVERY`], counting what it did not
/// say in between.
struct Throttled {
    last: Option<Instant>,
    unsaid: u64,
}

impl Throttled {
    const fn new() -> Self {
        Self {
            last: None,
            unsaid: 0,
        }
    }

    fn say(&mut self, what: impl FnOnce(u64) -> String) {
        if self.last.is_some_and(|t| t.elapsed() < LOG_EVERY) {
            self.unsaid += 1;
            return;
        }
        eprintln!("anguilla foxglove: {}", what(self.unsaid));
        self.last = Some(Instant::now());
        self.unsaid = 0;
    }
}

fn since(unsaid: u64) -> String {
    if unsaid == 0 {
        String::new()
    } else {
        format!(" ({unsaid} more since the last line)")
    }
}

static IDLE_LOG: Mutex<Throttled> = Mutex::new(Throttled::new());
static STALLED_LOG: Mutex<Throttled> = Mutex::new(Throttled::new());

fn accept_loop(
    listener: &TcpListener,
    inner: SocketAddr,
    limits: Limits,
    stop: &AtomicBool,
    counts: &Arc<Counts>,
) {
    let mut refusals = Throttled::new();
    let mut failures = Throttled::new();
    loop {
        let accepted = listener.accept();
        if stop.load(Ordering::SeqCst) {
            return;
        }
        let (client, peer) = match accepted {
            Ok(c) => c,
            Err(e) => {
                // Out of descriptors, say: accept fails at once until one is
                // freed, so back off a little instead of spinning; tell, go on.
                failures.say(|n| format!("accepting a viewer: {e}{}", since(n)));
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        if counts.open.load(Ordering::SeqCst) >= limits.max_clients {
            counts.refused.fetch_add(1, Ordering::SeqCst);
            refusals.say(|n| {
                format!(
                    "refused a viewer from {peer}: {} connected already ([foxglove] max-clients){}",
                    limits.max_clients,
                    since(n)
                )
            });
            refuse(client, limits.max_clients);
            continue;
        }
        counts.open.fetch_add(1, Ordering::SeqCst);
        counts.admitted.fetch_add(1, Ordering::SeqCst);
        let co = counts.clone();
        let spawned = std::thread::Builder::new()
            .name("foxglove-viewer".into())
            .spawn(move || {
                serve(client, peer, inner, limits, &co);
                co.open.fetch_sub(1, Ordering::SeqCst);
            });
        if let Err(e) = spawned {
            counts.open.fetch_sub(1, Ordering::SeqCst);
            failures.say(|n| format!("no thread for a viewer from {peer}: {e}{}", since(n)));
        }
    }
}

/// Answers a connection over the limit with an HTTP 503 and closes it.
fn refuse(mut client: TcpStream, max: usize) {
    let body = format!(
        "anguilla foxglove: {max} viewers are connected already ([foxglove] max-clients)\n"
    );
    let reply = format!(
        "HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\nContent-Type: text/plain\r\n\
         Content-Length: {}\r\n\r\n{body}",
        body.len()
    );
    let _ = client.set_write_timeout(Some(REFUSAL_WRITE));
    let _ = client.write_all(reply.as_bytes());
    let _ = client.shutdown(Shutdown::Both);
}

/// Passes one connection's bytes both ways until either side ends.
fn serve(client: TcpStream, peer: SocketAddr, inner: SocketAddr, limits: Limits, counts: &Counts) {
    let Ok(server) = TcpStream::connect_timeout(&inner, INNER_CONNECT) else {
        return;
    };
    let _ = client.set_nodelay(true);
    let _ = server.set_nodelay(true);
    small_send_buffer(&client);
    let (Ok(to_client), Ok(from_server)) = (client.try_clone(), server.try_clone()) else {
        return;
    };
    let down = std::thread::Builder::new()
        .name("foxglove-viewer-down".into())
        .spawn(move || {
            let stalled = down(&from_server, &to_client, limits.read_timeout) == Down::Stalled;
            let _ = to_client.shutdown(Shutdown::Both);
            let _ = from_server.shutdown(Shutdown::Both);
            stalled
        });
    if up(&client, &server, limits) == Up::Idle {
        counts.idle_closed.fetch_add(1, Ordering::SeqCst);
        if let Ok(mut log) = IDLE_LOG.lock() {
            log.say(|n| {
                format!(
                    "closed a viewer from {peer}: it subscribed to nothing within {:?} \
                     ([foxglove] subscribe-timeout){}",
                    limits.subscribe_timeout.unwrap_or_default(),
                    since(n)
                )
            });
        }
    }
    let _ = client.shutdown(Shutdown::Both);
    let _ = server.shutdown(Shutdown::Both);
    if let Ok(h) = down
        && h.join().unwrap_or(false)
    {
        counts.stalled_closed.fetch_add(1, Ordering::SeqCst);
        if let Ok(mut log) = STALLED_LOG.lock() {
            log.say(|n| {
                format!(
                    "closed a viewer from {peer}: it read nothing of what was sent to it for {:?} \
                     ([foxglove] read-timeout){}",
                    limits.read_timeout.unwrap_or_default(),
                    since(n)
                )
            });
        }
    }
}

/// Asks for a small kernel send buffer on a viewer's socket
/// ([`SEND_BUFFER`]); on failure the default stays (only slower to see a
/// stalled viewer).
fn small_send_buffer(s: &TcpStream) {
    use std::os::fd::AsRawFd as _;
    let size = SEND_BUFFER;
    // SAFETY: a valid socket descriptor, and a c_int option of its size.
    let _ = unsafe {
        libc::setsockopt(
            s.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_SNDBUF,
            (&raw const size).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
}

#[derive(Debug, PartialEq, Eq)]
enum Down {
    /// Either side closed or failed.
    Ended,
    /// The viewer took no byte for the read timeout.
    Stalled,
}

/// Server to client, until either ends or the client stops reading: a
/// write that moves no byte within `read_timeout` (the socket's send
/// timeout: a write returns what it moved, or times out having moved
/// nothing).
fn down(mut server: &TcpStream, mut client: &TcpStream, read_timeout: Option<Duration>) -> Down {
    if client.set_write_timeout(read_timeout).is_err() {
        return Down::Ended;
    }
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        let n = match server.read(&mut buf) {
            Ok(0) => return Down::Ended,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) => return Down::Ended,
        };
        let mut rest = &buf[..n];
        while !rest.is_empty() {
            match client.write(rest) {
                Ok(0) => return Down::Ended,
                Ok(k) => rest = &rest[k..],
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Down::Stalled;
                }
                Err(_) => return Down::Ended,
            }
        }
    }
}

#[derive(Debug, PartialEq, Eq)]
enum Up {
    /// Either side closed or failed.
    Ended,
    /// Closed for not subscribing in time.
    Idle,
}

/// Client to server, watching for the first subscription.
fn up(mut client: &TcpStream, mut server: &TcpStream, limits: Limits) -> Up {
    let deadline = limits.subscribe_timeout.map(|t| Instant::now() + t);
    let mut watch = Watch::default();
    let mut buf = [0u8; 16 * 1024];
    loop {
        let waiting = deadline.filter(|_| !watch.engaged());
        if let Some(d) = waiting {
            let left = d.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Up::Idle;
            }
            let _ = client.set_read_timeout(Some(left));
        } else {
            let _ = client.set_read_timeout(None);
        }
        let n = match client.read(&mut buf) {
            Ok(0) => return Up::Ended,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                continue;
            }
            Err(_) => return Up::Ended,
        };
        if !watch.engaged() {
            watch.feed(&buf[..n]);
        }
        if server.write_all(&buf[..n]).is_err() {
            return Up::Ended;
        }
    }
}

/// How much of a text frame's start is kept to look for the `op`.
const OP_WINDOW: usize = 256;

/// Reads the client's side of a WebSocket connection far enough to see its
/// first subscription (or advertisement): the HTTP upgrade request, then
/// frame headers and the start of each text frame.
#[derive(Debug, Default)]
struct Watch {
    phase: Phase,
    /// The frame header read so far (at most 14 bytes).
    header: Vec<u8>,
    /// The current frame: its mask, payload bytes left, whether it is text,
    /// and its start.
    mask: Option<[u8; 4]>,
    left: u64,
    offset: u64,
    text: bool,
    start: Vec<u8>,
}

#[derive(Debug, Default, PartialEq, Eq)]
enum Phase {
    /// In the HTTP request, until its last four bytes are CRLF CRLF.
    #[default]
    Http,
    Header,
    Payload,
    /// A subscription or advertisement was seen: no more watching.
    Engaged,
}

impl Watch {
    fn engaged(&self) -> bool {
        self.phase == Phase::Engaged
    }

    fn feed(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() && !self.engaged() {
            match self.phase {
                Phase::Http => {
                    // The request's end: the last four bytes are CRLF CRLF.
                    let b = bytes[0];
                    bytes = &bytes[1..];
                    self.header.push(b);
                    if self.header.len() > 4 {
                        self.header.remove(0);
                    }
                    if self.header == b"\r\n\r\n" {
                        self.header.clear();
                        self.phase = Phase::Header;
                    }
                }
                Phase::Header => {
                    self.header.push(bytes[0]);
                    bytes = &bytes[1..];
                    if let Some(h) = parse_header(&self.header) {
                        self.header.clear();
                        self.mask = h.mask;
                        self.left = h.len;
                        self.offset = 0;
                        // Text frames (opcode 1) carry the JSON operations.
                        self.text = h.opcode == 1;
                        self.start.clear();
                        self.phase = Phase::Payload;
                        self.end_frame_if_done();
                    }
                }
                Phase::Payload => {
                    let take = usize::try_from(self.left)
                        .unwrap_or(usize::MAX)
                        .min(bytes.len());
                    if self.text && self.start.len() < OP_WINDOW {
                        for &b in &bytes[..take.min(OP_WINDOW - self.start.len())] {
                            let k = self.mask.map_or(0, |m| m[(self.offset % 4) as usize]);
                            self.start.push(b ^ k);
                            self.offset += 1;
                        }
                    }
                    bytes = &bytes[take..];
                    self.left -= take as u64;
                    self.end_frame_if_done();
                }
                Phase::Engaged => {}
            }
        }
    }

    fn end_frame_if_done(&mut self) {
        if self.left == 0 && self.phase == Phase::Payload {
            self.phase = if self.text && is_engagement(&self.start) {
                Phase::Engaged
            } else {
                Phase::Header
            };
        }
    }
}

struct FrameHeader {
    opcode: u8,
    mask: Option<[u8; 4]>,
    len: u64,
}

/// A whole frame header from its first bytes, or `None` while incomplete.
fn parse_header(h: &[u8]) -> Option<FrameHeader> {
    if h.len() < 2 {
        return None;
    }
    let masked = h[1] & 0x80 != 0;
    let (len, at) = match h[1] & 0x7F {
        126 => (
            u64::from(u16::from_be_bytes(h.get(2..4)?.try_into().ok()?)),
            4,
        ),
        127 => (u64::from_be_bytes(h.get(2..10)?.try_into().ok()?), 10),
        n => (u64::from(n), 2),
    };
    let mask = if masked {
        Some(h.get(at..at + 4)?.try_into().ok()?)
    } else {
        None
    };
    Some(FrameHeader {
        opcode: h[0] & 0x0F,
        mask,
        len,
    })
}

/// Whether a text frame's start is a subscription or advertisement
/// (`"op"`, optional spaces, `:`, optional spaces, the name in quotes).
fn is_engagement(start: &[u8]) -> bool {
    let Ok(text) =
        std::str::from_utf8(start).or_else(|e| std::str::from_utf8(&start[..e.valid_up_to()]))
    else {
        return false;
    };
    text.match_indices("\"op\"").any(|(i, _)| {
        let rest = text[i + 4..].trim_start();
        rest.strip_prefix(':').is_some_and(|r| {
            let r = r.trim_start();
            r.starts_with("\"subscribe\"") || r.starts_with("\"advertise\"")
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A client frame as a browser sends it: FIN, the opcode, masked.
    fn frame(opcode: u8, payload: &[u8], mask: [u8; 4]) -> Vec<u8> {
        let mut f = vec![0x80 | opcode];
        match payload.len() {
            n if n < 126 => f.push(0x80 | n as u8),
            n if n <= 0xFFFF => {
                f.push(0x80 | 126);
                f.extend_from_slice(&(n as u16).to_be_bytes());
            }
            n => {
                f.push(0x80 | 127);
                f.extend_from_slice(&(n as u64).to_be_bytes());
            }
        }
        f.extend_from_slice(&mask);
        f.extend(payload.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        f
    }

    const UPGRADE: &[u8] = b"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\n\r\n";
    const SUBSCRIBE: &[u8] =
        br#"{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 2}]}"#;

    #[test]
    fn a_subscription_is_seen_however_the_bytes_are_split() {
        let mut all = UPGRADE.to_vec();
        // A binary frame and a long text frame without an op come first.
        all.extend(frame(2, &[0x22; 300], [1, 2, 3, 4]));
        all.extend(frame(1, "x".repeat(70_000).as_bytes(), [9, 8, 7, 6]));
        all.extend(frame(1, SUBSCRIBE, [0xA5, 0x5A, 0x0F, 0xF0]));
        for chunk in [1, 2, 3, 7, 13, 4096, all.len()] {
            let mut w = Watch::default();
            for piece in all.chunks(chunk) {
                w.feed(piece);
            }
            assert!(w.engaged(), "split every {chunk} bytes");
        }
    }

    #[test]
    fn other_operations_are_not_a_subscription() {
        let mut w = Watch::default();
        w.feed(UPGRADE);
        for op in [
            br#"{"op":"unsubscribe","subscriptionIds":[1]}"#.as_slice(),
            br#"{"op":"getParameters","parameterNames":[]}"#,
            br#"{"topic":"\"op\"","x":1}"#,
            b"not json \"op\" : 3",
        ] {
            w.feed(&frame(1, op, [3, 1, 4, 1]));
        }
        // The subscription's words, but in a binary frame.
        w.feed(&frame(2, SUBSCRIBE, [0, 0, 0, 0]));
        assert!(!w.engaged());
        w.feed(&frame(
            1,
            br#"{ "op" :  "advertise", "channels": []}"#,
            [5, 6, 7, 8],
        ));
        assert!(w.engaged());
    }

    /// A server that echoes what it is sent, as the Foxglove server stands in.
    fn echo_server() -> SocketAddr {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let a = l.local_addr().unwrap();
        std::thread::spawn(move || {
            for c in l.incoming().flatten() {
                std::thread::spawn(move || {
                    let mut r = c.try_clone().unwrap();
                    let mut w = c;
                    let _ = io::copy(&mut r, &mut w);
                });
            }
        });
        a
    }

    fn viewer(gate: SocketAddr, subscribe: bool) -> TcpStream {
        let mut c = TcpStream::connect(gate).unwrap();
        let mut hello = UPGRADE.to_vec();
        if subscribe {
            hello.extend(frame(1, SUBSCRIBE, [1, 1, 2, 3]));
        }
        c.write_all(&hello).unwrap();
        // The echo proves the gate passed the bytes through.
        let mut back = vec![0u8; hello.len()];
        c.read_exact(&mut back).unwrap();
        assert_eq!(back, hello);
        c
    }

    /// Waits until `cond` holds: a state, not a time (a minute times the
    /// patience, a watchdog).
    fn until(what: &str, cond: impl Fn() -> bool) {
        anguilla_testkit::wait_until(what, Duration::from_secs(60), cond);
    }

    #[test]
    fn one_viewer_over_the_limit_is_refused_until_a_place_is_free() {
        let limits = Limits {
            max_clients: 16,
            subscribe_timeout: None,
            read_timeout: None,
        };
        let gate = Gate::start("127.0.0.1:0".parse().unwrap(), echo_server(), limits).unwrap();
        let at = gate.local_addr();
        let mut open: Vec<_> = (0..16).map(|_| viewer(at, true)).collect();
        // The 17th: a 503 that names the limit, then the end.
        let mut extra = TcpStream::connect(at).unwrap();
        let mut reply = String::new();
        extra.read_to_string(&mut reply).unwrap();
        assert!(reply.starts_with("HTTP/1.1 503"), "{reply}");
        assert!(reply.contains("16 viewers are connected already ([foxglove] max-clients)"));
        assert_eq!(gate.counts().refused.load(Ordering::SeqCst), 1);
        // A flood of connections changes nothing for those inside.
        for _ in 0..200 {
            let mut c = TcpStream::connect(at).unwrap();
            let _ = c.read_to_end(&mut Vec::new());
        }
        assert_eq!(gate.counts().refused.load(Ordering::SeqCst), 201);
        for c in &mut open {
            c.write_all(b"still here").unwrap();
            let mut b = [0u8; 10];
            c.read_exact(&mut b).unwrap();
            assert_eq!(&b, b"still here");
        }
        // One leaves: its place is taken by the next one.
        drop(open.pop());
        until("the gate saw the viewer leave", || {
            gate.counts().open.load(Ordering::SeqCst) == 15
        });
        open.push(viewer(at, false));
        assert_eq!(gate.counts().open.load(Ordering::SeqCst), 16);
        assert_eq!(gate.counts().admitted.load(Ordering::SeqCst), 17);
        drop(open);
        until("every viewer's threads ended", || {
            gate.counts().open.load(Ordering::SeqCst) == 0
        });
        gate.stop();
    }

    #[test]
    fn a_viewer_that_subscribes_to_nothing_is_closed_and_one_that_does_stays() {
        let limits = Limits {
            max_clients: 4,
            subscribe_timeout: Some(Duration::from_millis(300)),
            read_timeout: None,
        };
        let gate = Gate::start("127.0.0.1:0".parse().unwrap(), echo_server(), limits).unwrap();
        let at = gate.local_addr();
        let mut watcher = viewer(at, true);
        // One upgrades and then says nothing; one never even upgrades.
        let mut idle = TcpStream::connect(at).unwrap();
        idle.write_all(UPGRADE).unwrap();
        let silent = TcpStream::connect(at).unwrap();
        // The gate closes both: each reads to the end of its stream.
        for mut c in [idle, silent] {
            c.read_to_end(&mut Vec::new()).unwrap();
        }
        until("two idle closes counted", || {
            gate.counts().idle_closed.load(Ordering::SeqCst) == 2
        });
        // The subscriber outlived them, and still passes bytes.
        watcher.write_all(b"ping").unwrap();
        let mut b = [0u8; 4];
        watcher.read_exact(&mut b).unwrap();
        assert_eq!(&b, b"ping");
        until("the idle ones' threads ended", || {
            gate.counts().open.load(Ordering::SeqCst) == 1
        });
        gate.stop();
    }
    /// A server that sends without end, as the Foxglove server sends
    /// states every period, and takes whatever it is sent.
    fn streaming_server() -> SocketAddr {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let a = l.local_addr().unwrap();
        std::thread::spawn(move || {
            for c in l.incoming().flatten() {
                let mut r = c.try_clone().unwrap();
                std::thread::spawn(move || {
                    let _ = io::copy(&mut r, &mut io::sink());
                });
                std::thread::spawn(move || {
                    let mut w = c;
                    let chunk = [0x5Au8; 16 * 1024];
                    while w.write_all(&chunk).is_ok() {}
                });
            }
        });
        a
    }

    /// A viewer that upgrades and subscribes; what it reads is its own
    /// business.
    fn subscriber(gate: SocketAddr) -> TcpStream {
        let mut c = TcpStream::connect(gate).unwrap();
        let mut hello = UPGRADE.to_vec();
        hello.extend(frame(1, SUBSCRIBE, [1, 1, 2, 3]));
        c.write_all(&hello).unwrap();
        c
    }

    /// The attack of issue 45: viewers that subscribe and never read held
    /// every place for ever (the server's bytes piled up in the gate's
    /// sockets). The gate closes a viewer that takes nothing for
    /// `read_timeout`, so a new one gets in, and one that reads stays.
    #[test]
    fn viewers_that_do_not_read_are_closed_and_free_their_places() {
        let limits = Limits {
            max_clients: 3,
            subscribe_timeout: None,
            // Long beside a loaded machine's scheduling gaps: the reading
            // viewer's thread, descheduled for 300 ms beside a build, was
            // once closed as stalled.
            read_timeout: Some(Duration::from_secs(2)),
        };
        let gate = Gate::start("127.0.0.1:0".parse().unwrap(), streaming_server(), limits).unwrap();
        let at = gate.local_addr();
        // One reads all along, counting what it gets.
        let got = Arc::new(AtomicU64::new(0));
        let mut reading = subscriber(at);
        let g = got.clone();
        let reader = std::thread::spawn(move || {
            let mut b = [0u8; 64 * 1024];
            while let Ok(n) = reading.read(&mut b) {
                if n == 0 {
                    return;
                }
                g.fetch_add(n as u64, Ordering::SeqCst);
            }
        });
        // Two subscribe and never read: every place is taken.
        let stalled: Vec<_> = (0..2).map(|_| subscriber(at)).collect();
        until("three viewers in", || {
            gate.counts().open.load(Ordering::SeqCst) == 3
        });
        // The gate closes both (each on its own clock: wait for the
        // second, a new viewer can get in after the first); a new viewer
        // gets in and is served.
        until("both stalled viewers closed", || {
            gate.counts().stalled_closed.load(Ordering::SeqCst) >= 2
        });
        until("a new viewer admitted and served", || {
            let mut c = subscriber(at);
            let mut b = [0u8; 16];
            c.read_exact(&mut b).is_ok() && b == [0x5A; 16]
        });
        // The reader was never closed: it still gets bytes.
        let before = got.load(Ordering::SeqCst);
        until("the reader still served", || {
            got.load(Ordering::SeqCst) > before
        });
        assert!(!reader.is_finished(), "the reading viewer was closed");
        drop(stalled);
        gate.stop();
    }
}
