//! Raw SocketCAN on a vcan interface, without any anguilla code: proves the
//! kernel, the interface and the test setup work before the bus tests run.
//!
//! The interface comes from `ANGUILLA_VCAN` (default `vcan0`); give it
//! `mtu 72` for the CAN FD test. `ANGUILLA_VCAN_CLASSIC` may name a second,
//! classic-only vcan (MTU 16). Without kernel CAN or the interface each test
//! prints why it skips and passes, unless `ANGUILLA_VCAN_REQUIRED=1` (set by
//! `scripts/vcan-vm`), which turns a skip into a failure.

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

fn required() -> bool {
    std::env::var("ANGUILLA_VCAN_REQUIRED").is_ok_and(|v| v == "1")
}

/// Prints why the test skips, or fails it when vcan is required.
fn skip(why: &str) {
    assert!(!required(), "ANGUILLA_VCAN_REQUIRED=1 but {why}");
    eprintln!("skipping: {why} (scripts/vcan-vm runs this test for real)");
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
    /// Opens and binds a socket, or gives the reason to skip.
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

/// Two sockets on the interface, or `None` after printing why not.
fn pair(ifname: &str, fd_frames: bool) -> Option<(RawCan, RawCan)> {
    let open = || RawCan::open(ifname, fd_frames);
    match open().and_then(|a| Ok((a, open()?))) {
        Ok(p) => Some(p),
        Err(e) => {
            skip(&e);
            None
        }
    }
}

#[test]
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
fn fd_frames_cross_between_sockets() {
    let ifname = interface();
    let Some((a, b)) = pair(&ifname, true) else {
        return;
    };
    if let Some(m) = mtu(&ifname).filter(|&m| m != CANFD_MTU) {
        // An FD-incapable interface is a setup choice, not a missing kernel.
        eprintln!("skipping: {ifname} has MTU {m}, not {CANFD_MTU} (no CAN FD)");
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
fn classic_only_interface_carries_no_fd_frames() {
    let Ok(ifname) = std::env::var("ANGUILLA_VCAN_CLASSIC") else {
        eprintln!("skipping: ANGUILLA_VCAN_CLASSIC names no classic-only vcan");
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
