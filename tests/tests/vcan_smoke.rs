//! Raw SocketCAN on a vcan interface, without any anguilla code: proves the
//! kernel, the interface and the test setup work before the bus tests run.
//!
//! The interface comes from `ANGUILLA_VCAN` (default `vcan0`); give it
//! `mtu 72` for the CAN FD test. `ANGUILLA_VCAN_CLASSIC` may name a second,
//! classic-only vcan (MTU 16). The tests are `#[ignore]`d (run them with
//! `-- --include-ignored`; scripts/vcan-vm does). Run without kernel CAN,
//! the interface or the tools it needs, a test fails naming what is missing
//! (anguilla_testkit::require): an ignored test that is run never reports
//! `ok` without running.

use std::ffi::CString;
use std::io;
use std::mem::size_of;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::time::Duration;

/// `struct sockaddr_can` (the address union is unused by CAN_RAW).
#[repr(C)]
struct SockaddrCan {
    can_family: libc::sa_family_t,
    can_ifindex: libc::c_int,
    can_addr: [u32; 4],
}

/// `struct can_frame` (16 bytes, `CAN_MTU`).
#[repr(C)]
#[derive(Clone, Copy)]
struct CanFrame {
    can_id: u32,
    len: u8,
    pad: u8,
    res0: u8,
    len8_dlc: u8,
    data: [u8; 8],
}

/// `struct canfd_frame` (72 bytes, `CANFD_MTU`).
#[repr(C)]
#[derive(Clone, Copy)]
struct CanFdFrame {
    can_id: u32,
    len: u8,
    flags: u8,
    res0: u8,
    res1: u8,
    data: [u8; 64],
}

impl CanFdFrame {
    fn new(can_id: u32, payload: &[u8], flags: u8) -> CanFdFrame {
        let mut f = CanFdFrame {
            can_id,
            len: payload.len() as u8,
            flags,
            res0: 0,
            res1: 0,
            data: [0; 64],
        };
        f.data[..payload.len()].copy_from_slice(payload);
        f
    }
}

const CAN_MTU: usize = size_of::<CanFrame>();
const CANFD_MTU: usize = size_of::<CanFdFrame>();

fn interface() -> String {
    std::env::var("ANGUILLA_VCAN").unwrap_or_else(|_| "vcan0".to_owned())
}

/// Fails the test: what it needs is missing here.
fn cannot_run(why: &str) {
    anguilla_testkit::require(false, || {
        format!("{why} (scripts/vcan-vm runs this test for real)")
    });
}

fn check(ret: libc::c_int) -> io::Result<()> {
    if ret < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(())
    }
}

/// A raw CAN socket bound to one interface.
struct RawCan {
    fd: OwnedFd,
}

impl RawCan {
    /// Opens and binds a socket, or gives the reason it cannot.
    fn open(ifname: &str, fd_frames: bool) -> Result<RawCan, String> {
        // SAFETY: plain socket(2) call; the descriptor is owned right away.
        let raw = unsafe { libc::socket(libc::PF_CAN, libc::SOCK_RAW, libc::CAN_RAW) };
        if raw < 0 {
            let e = io::Error::last_os_error();
            return Err(if e.raw_os_error() == Some(libc::EAFNOSUPPORT) {
                format!(
                    "socket(AF_CAN, SOCK_RAW, CAN_RAW) failed: AF_CAN not supported by this kernel (EAFNOSUPPORT): {e}"
                )
            } else {
                format!("socket(AF_CAN, SOCK_RAW, CAN_RAW) failed: {e}")
            });
        }
        // SAFETY: `raw` is a fresh descriptor nobody else owns.
        let sock = RawCan {
            fd: unsafe { OwnedFd::from_raw_fd(raw) },
        };
        let name = CString::new(ifname).map_err(|e| e.to_string())?;
        // SAFETY: `name` is a valid NUL-terminated string.
        let index = unsafe { libc::if_nametoindex(name.as_ptr()) };
        if index == 0 {
            return Err(format!(
                "no interface {ifname}: {}",
                io::Error::last_os_error()
            ));
        }
        if fd_frames {
            let on: libc::c_int = 1;
            // SAFETY: the option value is a c_int of the given size.
            check(unsafe {
                libc::setsockopt(
                    sock.fd.as_raw_fd(),
                    libc::SOL_CAN_RAW,
                    libc::CAN_RAW_FD_FRAMES,
                    (&raw const on).cast(),
                    size_of::<libc::c_int>() as libc::socklen_t,
                )
            })
            .map_err(|e| format!("CAN_RAW_FD_FRAMES: {e}"))?;
        }
        sock.set_timeout(Duration::from_secs(2))
            .map_err(|e| format!("SO_RCVTIMEO: {e}"))?;
        let addr = SockaddrCan {
            can_family: libc::AF_CAN as libc::sa_family_t,
            can_ifindex: index as libc::c_int,
            can_addr: [0; 4],
        };
        // SAFETY: `addr` is a sockaddr_can of the given size.
        check(unsafe {
            libc::bind(
                sock.fd.as_raw_fd(),
                (&raw const addr).cast(),
                size_of::<SockaddrCan>() as libc::socklen_t,
            )
        })
        .map_err(|e| format!("bind to {ifname}: {e}"))?;
        Ok(sock)
    }

    fn set_timeout(&self, d: Duration) -> io::Result<()> {
        let tv = libc::timeval {
            tv_sec: d.as_secs() as libc::time_t,
            tv_usec: d.subsec_micros() as libc::suseconds_t,
        };
        // SAFETY: the option value is a timeval of the given size.
        check(unsafe {
            libc::setsockopt(
                self.fd.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVTIMEO,
                (&raw const tv).cast(),
                size_of::<libc::timeval>() as libc::socklen_t,
            )
        })
    }

    fn send<T: Copy>(&self, frame: &T) -> io::Result<usize> {
        // SAFETY: `frame` is a plain repr(C) frame of size_of::<T>() bytes.
        let n = unsafe {
            libc::write(
                self.fd.as_raw_fd(),
                (frame as *const T).cast(),
                size_of::<T>(),
            )
        };
        usize::try_from(n).map_err(|_| io::Error::last_os_error())
    }

    /// Receives one frame (classic or FD) into a 72-byte buffer; gives the
    /// number of bytes read (`CAN_MTU` or `CANFD_MTU`) and the frame.
    fn recv(&self) -> io::Result<(usize, CanFdFrame)> {
        let mut frame = CanFdFrame::new(0, &[], 0);
        // SAFETY: the buffer is a writable CanFdFrame of CANFD_MTU bytes.
        let n = unsafe { libc::read(self.fd.as_raw_fd(), (&raw mut frame).cast(), CANFD_MTU) };
        let n = usize::try_from(n).map_err(|_| io::Error::last_os_error())?;
        Ok((n, frame))
    }
}

fn mtu(ifname: &str) -> Option<usize> {
    std::fs::read_to_string(format!("/sys/class/net/{ifname}/mtu"))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// Two sockets on the interface (the test fails naming why not).
fn pair(ifname: &str, fd_frames: bool) -> Option<(RawCan, RawCan)> {
    let open = || RawCan::open(ifname, fd_frames);
    match open().and_then(|a| Ok((a, open()?))) {
        Ok(p) => Some(p),
        Err(e) => {
            cannot_run(&e);
            None
        }
    }
}

#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn classic_frames_cross_between_sockets() {
    let ifname = interface();
    let Some((a, b)) = pair(&ifname, false) else {
        return;
    };
    let frames: [(u32, &[u8]); 3] = [
        (0x123, &[0xDE, 0xAD, 0xBE, 0xEF]),
        (libc::CAN_EFF_FLAG | 0x1abc_def0, &[1, 2, 3, 4, 5, 6, 7, 8]),
        (0x7ff, &[]),
    ];
    for (id, payload) in frames {
        let mut f = CanFrame {
            can_id: id,
            len: payload.len() as u8,
            pad: 0,
            res0: 0,
            len8_dlc: 0,
            data: [0; 8],
        };
        f.data[..payload.len()].copy_from_slice(payload);
        assert_eq!(a.send(&f).expect("send"), CAN_MTU);
        let (n, got) = b.recv().expect("no frame on the second socket within 2 s");
        assert_eq!(n, CAN_MTU, "a classic frame");
        assert_eq!(got.can_id, id);
        assert_eq!(&got.data[..usize::from(got.len)], payload);
    }
    // The sender does not get its own frames back (CAN_RAW_RECV_OWN_MSGS is
    // off by default).
    a.set_timeout(Duration::from_millis(200))
        .expect("SO_RCVTIMEO");
    let own = a.recv();
    assert!(
        own.is_err(),
        "the sender received {:?} bytes",
        own.map(|f| f.0)
    );
}

#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn fd_frames_cross_between_sockets() {
    let ifname = interface();
    let Some((a, b)) = pair(&ifname, true) else {
        return;
    };
    if let Some(m) = mtu(&ifname).filter(|&m| m != CANFD_MTU) {
        // An FD-incapable interface is a setup choice, not a missing kernel.
        cannot_run(&format!(
            "{ifname} has MTU {m}, not {CANFD_MTU} (no CAN FD)"
        ));
        return;
    }
    let payload: Vec<u8> = (0..64).collect();
    let f = CanFdFrame::new(0x456, &payload, libc::CANFD_BRS as u8);
    assert_eq!(a.send(&f).expect("send FD"), CANFD_MTU);
    let (n, got) = b.recv().expect("no FD frame within 2 s");
    assert_eq!(n, CANFD_MTU, "an FD frame");
    assert_eq!(got.can_id, 0x456);
    assert_eq!(got.len, 64);
    assert_eq!(got.data[..], payload[..]);
    assert_ne!(got.flags & libc::CANFD_BRS as u8, 0, "BRS kept");
}

#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn classic_only_interface_carries_no_fd_frames() {
    let Ok(ifname) = std::env::var("ANGUILLA_VCAN_CLASSIC") else {
        cannot_run("ANGUILLA_VCAN_CLASSIC names no classic-only vcan");
        return;
    };
    let Some((a, b)) = pair(&ifname, true) else {
        return;
    };
    assert_eq!(
        mtu(&ifname),
        Some(CAN_MTU),
        "{ifname} should be classic-only"
    );
    // Classic frames pass, even between FD-enabled sockets.
    let classic = CanFrame {
        can_id: 0x321,
        len: 2,
        pad: 0,
        res0: 0,
        len8_dlc: 0,
        data: [0xAB, 0xCD, 0, 0, 0, 0, 0, 0],
    };
    assert_eq!(a.send(&classic).expect("send classic"), CAN_MTU);
    let (n, got) = b.recv().expect("no classic frame within 2 s");
    assert_eq!((n, got.can_id, got.len), (CAN_MTU, 0x321, 2));
    // An FD frame does not fit the MTU: the kernel refuses it.
    let err = a
        .send(&CanFdFrame::new(0x1, &[0; 12], 0))
        .expect_err("an FD frame on an MTU-16 interface");
    assert_eq!(err.raw_os_error(), Some(libc::EINVAL), "{err}");
}

/// The pseudo-terminal master of an emulated SLCAN adapter, and the slave's
/// path for slcand.
fn open_pty() -> io::Result<(OwnedFd, String)> {
    // SAFETY: plain posix_openpt(3); the descriptor is owned right away.
    let raw = unsafe { libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY) };
    if raw < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: `raw` is a fresh descriptor nobody else owns.
    let master = unsafe { OwnedFd::from_raw_fd(raw) };
    let mut name = [0 as libc::c_char; 64];
    // SAFETY: `master` is a pty master; `name` is writable for its length.
    unsafe {
        check(libc::grantpt(master.as_raw_fd()))?;
        check(libc::unlockpt(master.as_raw_fd()))?;
        let r = libc::ptsname_r(master.as_raw_fd(), name.as_mut_ptr(), name.len());
        if r != 0 {
            return Err(io::Error::from_raw_os_error(r));
        }
    }
    // SAFETY: ptsname_r wrote a NUL-terminated string.
    let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) };
    Ok((master, path.to_string_lossy().into_owned()))
}

/// Reads from the pty master until `want` appears or 3 s pass.
fn read_until(master: &OwnedFd, want: &str) -> String {
    let mut seen = Vec::new();
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(3));
    while !String::from_utf8_lossy(&seen).contains(want) {
        let left = deadline.remaining();
        if left.is_zero() {
            break;
        }
        let mut pfd = libc::pollfd {
            fd: master.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        if unsafe { libc::poll(&mut pfd, 1, left.as_millis() as libc::c_int) } <= 0 {
            continue;
        }
        let mut buf = [0u8; 256];
        // SAFETY: `buf` is writable for its length.
        let n = unsafe { libc::read(master.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if n > 0 {
            seen.extend_from_slice(&buf[..n as usize]);
        }
    }
    String::from_utf8_lossy(&seen).into_owned()
}

/// Kills slcand when the test ends, whatever happens.
struct Child(std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The kernel's slcan driver behind `slcand`, with an SLCAN adapter emulated
/// on a pseudo-terminal: a frame sent on the slcan interface comes out of
/// the serial line as `t...`, and a `t...` line written to it arrives as a
/// frame. Needs root, slcand (can-utils), `ip` and the slcan module.
#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn slcand_attaches_a_serial_adapter() {
    // SAFETY: getuid has no preconditions.
    if unsafe { libc::getuid() } != 0 {
        cannot_run("slcand needs root");
        return;
    }
    if std::process::Command::new("slcand")
        .arg("-h")
        .output()
        .is_err()
    {
        cannot_run("slcand (can-utils) is not installed");
        return;
    }
    // Kernel CAN at all? (Binding to `lo` fails later, but socket() first.)
    if let Err(e) = RawCan::open("lo", false)
        && e.contains("EAFNOSUPPORT")
    {
        cannot_run(&e);
        return;
    }
    let (master, slave) = open_pty().expect("pseudo-terminal");
    let ifname = "aslcan0";
    let slcand = std::process::Command::new("slcand")
        .args(["-F", "-o", "-c", "-s8", &slave, ifname])
        .spawn()
        .expect("start slcand");
    let _slcand = Child(slcand);
    // slcand sends close, speed and open to the adapter, then attaches.
    let init = read_until(&master, "O\r");
    assert!(init.contains("S8\r") && init.contains("O\r"), "{init:?}");
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(3));
    while !std::path::Path::new(&format!("/sys/class/net/{ifname}")).exists() {
        if deadline.passed() {
            cannot_run(&format!("slcand created no {ifname} (no slcan module?)"));
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // slcand creates slcanN and renames it: under a slow (emulated) CPU the
    // new name can show in sysfs a moment before `ip` finds the device
    // ("SIOCGIFFLAGS: No such device"), so retry for a while.
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(3));
    loop {
        let up = std::process::Command::new("ip")
            .args(["link", "set", ifname, "up"])
            .output()
            .expect("run ip");
        if up.status.success() {
            break;
        }
        assert!(
            !deadline.passed(),
            "ip link set {ifname} up: {}: {}",
            up.status,
            String::from_utf8_lossy(&up.stderr)
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let sock = RawCan::open(ifname, false).expect("socket on the slcan interface");

    let f = CanFrame {
        can_id: 0x123,
        len: 4,
        pad: 0,
        res0: 0,
        len8_dlc: 0,
        data: [0xDE, 0xAD, 0xBE, 0xEF, 0, 0, 0, 0],
    };
    assert_eq!(sock.send(&f).expect("send on slcan"), CAN_MTU);
    let line = read_until(&master, "t1234DEADBEEF\r");
    assert!(line.contains("t1234DEADBEEF\r"), "adapter got {line:?}");

    let frame = b"t3212ABCD\r";
    // SAFETY: `frame` is readable for its length.
    let n = unsafe { libc::write(master.as_raw_fd(), frame.as_ptr().cast(), frame.len()) };
    assert_eq!(n, frame.len() as isize);
    let (n, got) = sock.recv().expect("no frame from the adapter within 2 s");
    assert_eq!((n, got.can_id, got.len), (CAN_MTU, 0x321, 2));
    assert_eq!(&got.data[..2], &[0xAB, 0xCD]);
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
}

/// can-utils' log round trip, which anguilla's log tests build on: frames
/// logged by `candump -l` come back on the bus through `canplayer -I`; and
/// the log, a standard, an extended and a remote frame, reads in anguilla's
/// candump reader.
#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn candump_log_replays_with_canplayer_and_reads_in_anguilla() {
    use anguilla_protocol::candump::Reader;
    use anguilla_protocol::frame::{Id, Kind};
    let ifname = interface();
    if !on_path("candump") || !on_path("canplayer") {
        cannot_run("candump/canplayer (can-utils) are not installed");
        return;
    }
    let Some((tx, rx)) = pair(&ifname, false) else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("vcan-smoke-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    // -l: log to candump-<date>.log in the current directory; -n 3: stop
    // after three frames; -T: give up after 5 s.
    let mut cmd = std::process::Command::new("candump");
    cmd.args(["-l", "-n", "3", "-T", "5000", &ifname])
        .current_dir(&dir);
    let mut candump = Child(anguilla_system_tests::process::spawn_listening(
        &mut cmd, &ifname,
    ));
    const EFF: u32 = 0x8000_0000;
    const RTR: u32 = 0x4000_0000;
    let frames: [(u32, [u8; 8], u8); 3] = [
        (0x2a1, [1, 2, 3, 0, 0, 0, 0, 0], 3),
        (EFF | 0x1234_5678, [0xCA, 0xFE, 0, 0, 0, 0, 0, 0], 2),
        (RTR | 0x2a3, [0; 8], 4),
    ];
    for (id, data, len) in frames {
        let f = CanFrame {
            can_id: id,
            len,
            pad: 0,
            res0: 0,
            len8_dlc: 0,
            data,
        };
        tx.send(&f).expect("send");
    }
    let status = candump.0.wait().expect("wait for candump");
    assert!(status.success(), "candump: {status}");
    let log = std::fs::read_dir(&dir)
        .expect("read temp dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "log"))
        .expect("candump -l wrote no log");
    let text = std::fs::read_to_string(&log).expect("read the log");
    assert!(text.contains(&format!("{ifname} 2A1#010203")), "{text}");
    assert!(text.contains(&format!("{ifname} 12345678#CAFE")), "{text}");
    assert!(text.contains(&format!("{ifname} 2A3#R4")), "{text}");
    let entries: Vec<_> = Reader::new(text.as_bytes())
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}: {text}"));
    let got: Vec<_> = entries
        .iter()
        .map(|e| {
            let f = e.frame().expect("a frame");
            (f.id(), f.kind(), f.data().to_vec())
        })
        .collect();
    assert_eq!(
        got,
        [
            (Id::standard_literal(0x2a1), Kind::Data, vec![1, 2, 3]),
            (
                Id::extended_literal(0x1234_5678),
                Kind::Data,
                vec![0xCA, 0xFE]
            ),
            (Id::standard_literal(0x2a3), Kind::Remote { dlc: 4 }, vec![]),
        ]
    );

    // Drain what rx saw live, then replay the log and see it again.
    for _ in 0..3 {
        rx.recv().expect("live frame");
    }
    let replay = std::process::Command::new("canplayer")
        .arg("-I")
        .arg(&log)
        .status()
        .expect("run canplayer");
    assert!(replay.success(), "canplayer: {replay}");
    for (id, data, len) in frames {
        let (_, got) = rx.recv().expect("no replayed frame within 2 s");
        assert_eq!((got.can_id, got.len), (id, len));
        assert_eq!(got.data[..usize::from(len)], data[..usize::from(len)]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
