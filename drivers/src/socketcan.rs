//! Linux SocketCAN, classic and FD (`socketcan:can0`, `socketcan:vcan0?fd=1`).
//!
//! One raw `CAN_RAW` socket ([`socketcan::CanFdSocket`], which carries
//! classic frames too), non-blocking; `recv` waits with `poll(2)`. Error
//! frames are enabled and decoded into [`BusState`]: `CAN_ERR_BUSOFF` →
//! bus-off, controller `RX/TX_PASSIVE` → error-passive, `ACTIVE` or
//! `CAN_ERR_RESTARTED` → error-active. Kernel receive timestamps
//! (`SO_TIMESTAMPNS`, time since the Unix epoch) are on by default.
//!
//! **Bus-off.** The socket is closed at once, which discards every frame
//! still queued in it: setpoints queued before the fault are never sent late
//! (frames already handed to the device queue are the kernel's; the CAN
//! layer drops them when the controller goes bus-off). `send` then fails
//! with [`LinkError::BusOff`] while the driver reopens the socket with
//! exponential back-off (20 ms doubling to 2 s), once the interface is up
//! and has its carrier back (`/sys/class/net/IF/flags` and `carrier`; an
//! interface set down counts as one bus-off until it is up again). Restarting the controller
//! itself is the kernel's job (`ip link set can0 type can restart-ms 100`):
//! restarting it from here would need `CAP_NET_ADMIN` and netlink, which
//! the daemon does not hold. A write that fails with `ENETDOWN` is treated
//! as still bus-off. Frames already in the interface's qdisc (up to
//! `txqueuelen`) are out of a user-space driver's reach: keep it short
//! (`ip link set can0 txqueuelen 4`) so that nothing stale survives a
//! restart.
//!
//! Receive overruns count the controller's (`CAN_ERR_CRTL_RX_OVERFLOW`) and
//! the frames the kernel dropped because the socket's receive queue was full
//! (`SO_MEMINFO`), which nothing else would show.
//!
//! `send`, `try_recv`, `drain` and `counters` do not allocate.

use std::io;
use std::os::fd::AsFd;
use std::time::{Duration, Instant, UNIX_EPOCH};

use anguilla_protocol::frame::controller::{
    ACTIVE as CAN_ERR_CRTL_ACTIVE, RX_OVERFLOW as CAN_ERR_CRTL_RX_OVERFLOW,
    RX_PASSIVE as CAN_ERR_CRTL_RX_PASSIVE, TX_PASSIVE as CAN_ERR_CRTL_TX_PASSIVE,
};
use anguilla_protocol::frame::error_class::{
    BUSOFF as CAN_ERR_BUSOFF, CRTL as CAN_ERR_CRTL, RESTARTED as CAN_ERR_RESTARTED,
};
use anguilla_protocol::frame::{Id, Kind};
use socketcan::{
    CanAnyFrame, CanDataFrame, CanFdFrame, CanFdSocket, CanRemoteFrame, EmbeddedFrame, ExtendedId,
    Socket, SocketOptions, StandardId,
};

use crate::backoff::Backoff;
use crate::{
    Bus, BusCounters, BusState, Capabilities, Frame, LinkError, LostReason, OpenError, OpenResult,
    Received, Result, TimestampBase, Unsendable,
};

/// Options of a SocketCAN bus.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SocketCanConfig {
    /// The spec string, for messages.
    pub spec: String,
    /// Interface name (`can0`, `vcan0`).
    pub interface: String,
    /// Allow CAN FD frames (the interface MTU must be 72).
    pub fd: bool,
    /// Ask the kernel for receive timestamps.
    pub timestamps: bool,
}

impl SocketCanConfig {
    /// Classic CAN, with timestamps.
    pub fn new(interface: &str) -> Self {
        Self {
            spec: format!("socketcan:{interface}"),
            interface: interface.to_owned(),
            fd: false,
            timestamps: true,
        }
    }
}

/// A SocketCAN interface; implements [`Bus`].
#[derive(Debug)]
pub struct SocketCanBus {
    config: SocketCanConfig,
    sock: Option<CanFdSocket>,
    timestamps: bool,
    fd: bool,
    state: BusState,
    counters: BusCounters,
    backoff: Backoff,
    /// `/sys/class/net/IF/{flags,carrier}`, made once: checking them
    /// while bus-off allocates nothing.
    link: LinkFiles,
    /// Frames the kernel dropped on sockets already closed.
    drops_closed: u64,
}

/// Whether this kernel has SocketCAN (`socket(AF_CAN, SOCK_RAW, CAN_RAW)`).
pub fn kernel_has_can() -> bool {
    probe_kernel().is_ok()
}

fn probe_kernel() -> std::result::Result<(), nix::Error> {
    use nix::sys::socket::{AddressFamily, SockFlag, SockProtocol, SockType, socket};
    socket(
        AddressFamily::Can,
        SockType::Raw,
        SockFlag::SOCK_CLOEXEC,
        SockProtocol::CanRaw,
    )
    .map(drop)
}

impl SocketCanBus {
    /// Opens the interface. Errors name the spec: no kernel CAN support,
    /// missing interface, permission denied.
    pub fn open(config: &SocketCanConfig) -> OpenResult<Self> {
        let mut bus = SocketCanBus {
            config: config.clone(),
            sock: None,
            timestamps: false,
            fd: false,
            state: BusState::ErrorActive,
            counters: BusCounters::default(),
            backoff: Backoff::new(),
            link: LinkFiles::new(&config.interface),
            drops_closed: 0,
        };
        bus.connect()?;
        Ok(bus)
    }

    fn map_open_error(&self, e: io::Error) -> OpenError {
        let c = &self.config;
        match e.raw_os_error() {
            Some(libc_errno::EAFNOSUPPORT) => OpenError::NoKernelCan {
                spec: c.spec.clone(),
            },
            Some(libc_errno::ENODEV) => OpenError::MissingInterface {
                spec: c.spec.clone(),
                interface: c.interface.clone(),
            },
            Some(libc_errno::EPERM | libc_errno::EACCES) => OpenError::PermissionDenied {
                spec: c.spec.clone(),
                path: c.interface.clone(),
            },
            _ => OpenError::io(&c.spec, e),
        }
    }

    fn connect(&mut self) -> OpenResult<()> {
        self.connect_raw().map_err(|e| self.map_open_error(e))
    }

    /// Opens the socket; allocates nothing (automatic recovery runs inside
    /// the control period), errors are the OS's.
    fn connect_raw(&mut self) -> io::Result<()> {
        self.close();
        probe_kernel().map_err(|e| io::Error::from_raw_os_error(e as i32))?;
        let sock = CanFdSocket::open(&self.config.interface)?;
        sock.set_nonblocking(true)?;
        sock.set_error_filter_accept_all()?;
        self.timestamps = self.config.timestamps && sock.set_recv_timestamp(true).is_ok();
        // FD needs the interface MTU of a CAN FD frame (72); when sysfs
        // cannot tell, trust the caller and let the kernel refuse.
        self.fd = self.config.fd && self.link.mtu().is_none_or(|m| m == 72);
        self.sock = Some(sock);
        self.state = BusState::ErrorActive;
        Ok(())
    }

    fn enter_bus_off(&mut self) {
        if self.state != BusState::BusOff {
            self.counters.bus_off_count += 1;
        }
        self.state = BusState::BusOff;
        // Closing the socket discards what is still queued in it.
        self.close();
    }

    /// Closes the socket, keeping the count of frames the kernel dropped
    /// on it.
    fn close(&mut self) {
        if let Some(sock) = self.sock.take() {
            self.drops_closed += socket_drops(&sock);
        }
    }

    /// While bus-off, reopens the socket when the back-off allows and the
    /// interface has its carrier back (the controller left bus-off).
    fn recover(&mut self) -> bool {
        if self.sock.is_some() {
            return true;
        }
        // An interface that is down (`ip link set can0 down`) or has no
        // carrier would accept a new socket and fail its first write again:
        // wait for it instead of counting one more bus-off per back-off,
        // and without spending back-off delay (the first attempt once it
        // is back is at once).
        if self.state == BusState::BusOff && self.link.ready() == Some(false) {
            return false;
        }
        if !self.backoff.due() {
            return false;
        }
        if self.connect_raw().is_ok() {
            self.counters.reopens += 1;
            self.backoff.recovered();
            return true;
        }
        false
    }

    fn on_error_frame(&mut self, class: u32, data: &[u8]) {
        self.counters.errors += 1;
        if class & CAN_ERR_BUSOFF != 0 {
            self.enter_bus_off();
            return;
        }
        if class & CAN_ERR_RESTARTED != 0 {
            self.state = BusState::ErrorActive;
        }
        if class & CAN_ERR_CRTL != 0 {
            let ctrl = data.get(1).copied().unwrap_or(0);
            if ctrl & CAN_ERR_CRTL_RX_OVERFLOW != 0 {
                self.counters.rx_overruns += 1;
            }
            if ctrl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE) != 0 {
                self.state = BusState::ErrorPassive;
            } else if ctrl & CAN_ERR_CRTL_ACTIVE != 0 {
                self.state = BusState::ErrorActive;
            }
        }
    }

    /// Reads one frame if the socket has one; error frames update the state.
    fn read_one(&mut self) -> Result<Option<Received>> {
        loop {
            let Some(sock) = self.sock.as_ref() else {
                return Ok(None);
            };
            let res = if self.timestamps {
                sock.read_frame_with_timestamp()
                    .map(|(f, t)| (f, t.duration_since(UNIX_EPOCH).ok()))
            } else {
                sock.read_frame().map(|f| (f, None))
            };
            let (raw, timestamp) = match res {
                Ok(x) => x,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
                    ) =>
                {
                    return Ok(None);
                }
                Err(e) if e.kind() == io::ErrorKind::InvalidData && self.timestamps => {
                    // A frame came without its timestamp: stop asking.
                    self.counters.errors += 1;
                    self.timestamps = false;
                    continue;
                }
                Err(e) if e.raw_os_error() == Some(libc_errno::ENETDOWN) => {
                    self.enter_bus_off();
                    return Ok(None);
                }
                Err(e) => {
                    self.close();
                    return Err(LinkError::Disconnected(LostReason::Io((&e).into())));
                }
            };
            let frame = match raw {
                CanAnyFrame::Error(ef) => {
                    self.on_error_frame(ef.error_bits(), ef.data());
                    continue;
                }
                CanAnyFrame::Normal(f) => from_classic(&f, f.data()),
                CanAnyFrame::Remote(f) => {
                    to_id(&f).and_then(|id| Frame::new_remote(id, f.dlc() as u8).ok())
                }
                CanAnyFrame::Fd(f) => to_id(&f).and_then(|id| {
                    Frame::new_fd(id, f.data(), f.is_brs())
                        .ok()
                        .map(|fr| fr.with_esi(f.is_esi()))
                }),
            };
            match frame {
                Some(frame) => {
                    self.counters.rx += 1;
                    return Ok(Some(Received { frame, timestamp }));
                }
                // The kernel validates frames; count anything odd anyway.
                None => self.counters.errors += 1,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detached() -> SocketCanBus {
        SocketCanBus {
            config: SocketCanConfig::new("vcan0"),
            sock: None,
            timestamps: false,
            fd: false,
            state: BusState::ErrorActive,
            counters: BusCounters::default(),
            backoff: Backoff::new(),
            link: LinkFiles::new("vcan0"),
            drops_closed: 0,
        }
    }

    #[test]
    fn an_interface_set_down_or_without_carrier_is_not_ready() {
        let dir = std::env::temp_dir().join(format!("anguilla-link-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = LinkFiles::in_dir(&dir);
        assert_eq!(link.ready(), None, "sysfs cannot tell");
        // `ip link set vcan0 down`: IFF_UP clear, carrier unreadable.
        std::fs::write(&link.flags, "0x80\n").unwrap();
        assert_eq!(link.ready(), Some(false));
        std::fs::write(&link.flags, "0xc1\n").unwrap();
        assert_eq!(link.ready(), None, "up, carrier unknown");
        std::fs::write(&link.carrier, "0\n").unwrap();
        assert_eq!(link.ready(), Some(false), "bus-off controller");
        std::fs::write(&link.carrier, "1\n").unwrap();
        assert_eq!(link.ready(), Some(true));
        assert_eq!(link.mtu(), None);
        std::fs::write(&link.mtu, "72\n").unwrap();
        assert_eq!(link.mtu(), Some(72));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_bus_off_bus_on_a_down_interface_stays_closed_through_flush_and_send() {
        let dir = std::env::temp_dir().join(format!("anguilla-down-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("flags"), "0x80\n").unwrap(); // IFF_UP clear
        let mut b = detached();
        b.link = LinkFiles::in_dir(&dir);
        b.on_error_frame(CAN_ERR_BUSOFF, &[0; 8]);
        // An E-stop flushes first: nothing is queued in a closed socket,
        // and nothing is reopened on a down interface.
        assert!(b.flush_tx().is_ok());
        assert!(b.sock.is_none());
        let f = Frame::new_standard(0x000, &[]).unwrap();
        assert!(matches!(b.send(&f), Err(LinkError::BusOff)));
        assert_eq!(b.state(), BusState::BusOff);
        assert_eq!(b.counters().bus_off_count, 1);
        assert_eq!(b.counters().reopens, 0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn error_frames_drive_the_bus_state() {
        let mut b = detached();
        b.on_error_frame(
            CAN_ERR_CRTL,
            &[0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0],
        );
        assert_eq!(b.state(), BusState::ErrorPassive);
        b.on_error_frame(CAN_ERR_CRTL, &[0, CAN_ERR_CRTL_ACTIVE, 0, 0, 0, 0, 0, 0]);
        assert_eq!(b.state(), BusState::ErrorActive);
        b.on_error_frame(CAN_ERR_BUSOFF, &[0; 8]);
        assert_eq!(b.state(), BusState::BusOff);
        assert_eq!(b.counters().bus_off_count, 1);
        b.on_error_frame(CAN_ERR_BUSOFF, &[0; 8]);
        assert_eq!(b.counters().bus_off_count, 1, "one bus-off, reported twice");
        b.on_error_frame(CAN_ERR_RESTARTED, &[0; 8]);
        assert_eq!(b.state(), BusState::ErrorActive);
        b.on_error_frame(
            CAN_ERR_CRTL,
            &[0, CAN_ERR_CRTL_RX_OVERFLOW, 0, 0, 0, 0, 0, 0],
        );
        assert_eq!(b.counters().rx_overruns, 1);
        assert_eq!(b.counters().errors, 6);
    }

    #[test]
    fn open_errors_are_mapped_and_name_the_spec() {
        let b = detached();
        for (errno, needle) in [
            (libc_errno::EAFNOSUPPORT, "no CAN support"),
            (libc_errno::ENODEV, "no CAN interface named 'vcan0'"),
            (libc_errno::EACCES, "permission denied on vcan0"),
            (libc_errno::EPERM, "permission denied on vcan0"),
        ] {
            let msg = b
                .map_open_error(io::Error::from_raw_os_error(errno))
                .to_string();
            assert!(
                msg.contains("socketcan:vcan0") && msg.contains(needle),
                "{msg}"
            );
        }
    }

    #[test]
    fn bus_off_refuses_to_send_until_recovered() {
        let mut b = detached();
        b.on_error_frame(CAN_ERR_BUSOFF, &[0; 8]);
        let f = Frame::new_standard(0x10, &[1]).unwrap();
        // Recovery needs a kernel with CAN; here (or while the back-off
        // runs) the frame is refused, never queued.
        if !kernel_has_can() {
            assert!(matches!(b.send(&f), Err(LinkError::BusOff)));
            assert_eq!(b.counters().tx, 0);
        }
        let fd = Frame::new_fd(Id::standard(1).unwrap(), &[0; 12], false).unwrap();
        assert!(matches!(b.send(&fd), Err(LinkError::Unsupported(_))));
    }
}

/// Frames the kernel dropped on `sock` because its receive queue was full
/// (`SO_MEMINFO`'s `SK_MEMINFO_DROPS`; 0 where the kernel cannot tell).
fn socket_drops(sock: &CanFdSocket) -> u64 {
    use std::os::fd::AsRawFd;
    const SK_MEMINFO_DROPS: usize = 8;
    let mut info = [0u32; 9]; // SK_MEMINFO_VARS
    let mut len = std::mem::size_of_val(&info) as libc::socklen_t;
    // SAFETY: `info` is writable for `len` bytes and the fd is open.
    let r = unsafe {
        libc::getsockopt(
            sock.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_MEMINFO,
            info.as_mut_ptr().cast(),
            &mut len,
        )
    };
    if r == 0 && len as usize > SK_MEMINFO_DROPS * 4 {
        u64::from(info[SK_MEMINFO_DROPS])
    } else {
        0
    }
}

/// The sysfs files telling whether an interface can carry frames.
#[derive(Debug)]
struct LinkFiles {
    flags: std::path::PathBuf,
    carrier: std::path::PathBuf,
    mtu: std::path::PathBuf,
}

impl LinkFiles {
    fn new(interface: &str) -> Self {
        Self::in_dir(&std::path::Path::new("/sys/class/net").join(interface))
    }

    fn in_dir(dir: &std::path::Path) -> Self {
        Self {
            flags: dir.join("flags"),
            carrier: dir.join("carrier"),
            mtu: dir.join("mtu"),
        }
    }

    /// The interface's MTU (16: classic CAN, 72: CAN FD).
    fn mtu(&self) -> Option<u32> {
        let mut buf = [0u8; 16];
        read_small(&self.mtu, &mut buf)?.parse().ok()
    }

    /// Whether the interface is up with a carrier (`None`: sysfs cannot
    /// tell). A CAN controller that went bus-off has no carrier until it
    /// restarts; an interface set down has `IFF_UP` clear (and no readable
    /// carrier).
    fn ready(&self) -> Option<bool> {
        const IFF_UP: u32 = 0x1;
        let mut buf = [0u8; 32];
        if let Some(text) = read_small(&self.flags, &mut buf)
            && let Some(hex) = text.strip_prefix("0x")
            && let Ok(flags) = u32::from_str_radix(hex, 16)
            && flags & IFF_UP == 0
        {
            return Some(false);
        }
        match read_small(&self.carrier, &mut buf)? {
            "1" => Some(true),
            "0" => Some(false),
            _ => None,
        }
    }
}

/// Reads a short sysfs file into `buf` without allocating (the path fits
/// std's on-stack C-string buffer), trimmed.
fn read_small<'a>(path: &std::path::Path, buf: &'a mut [u8]) -> Option<&'a str> {
    use std::io::Read;
    let n = std::fs::File::open(path).ok()?.read(buf).ok()?;
    std::str::from_utf8(&buf[..n]).ok().map(str::trim)
}

fn to_id<F: socketcan::Frame>(f: &F) -> Option<Id> {
    if f.is_extended() {
        Id::extended(f.raw_id()).ok()
    } else {
        Id::standard(f.raw_id() as u16).ok()
    }
}

fn from_classic<F: socketcan::Frame>(f: &F, data: &[u8]) -> Option<Frame> {
    to_id(f).and_then(|id| Frame::new(id, data).ok())
}

fn sc_id(id: Id) -> Option<socketcan::Id> {
    match id {
        Id::Standard(r) => StandardId::new(r.as_raw()).map(socketcan::Id::Standard),
        Id::Extended(r) => ExtendedId::new(r.as_raw()).map(socketcan::Id::Extended),
    }
}

/// Plain errno values (Linux), to avoid a direct `libc` dependency.
mod libc_errno {
    pub const EPERM: i32 = 1;
    pub const EACCES: i32 = 13;
    pub const ENODEV: i32 = 19;
    pub const EAFNOSUPPORT: i32 = 97;
    pub const ENETDOWN: i32 = 100;
    pub const ENOBUFS: i32 = 105;
    pub const EINVAL: i32 = 22;
}

impl Bus for SocketCanBus {
    fn send(&mut self, frame: &Frame) -> Result<()> {
        if frame.is_fd() && !self.fd {
            return Err(LinkError::Unsupported(Unsendable::FdNotEnabledOrMtu));
        }
        if !self.recover() {
            return Err(LinkError::BusOff);
        }
        let Some(id) = sc_id(frame.id()) else {
            return Err(LinkError::Unsupported(Unsendable::Identifier));
        };
        let Some(sock) = self.sock.as_ref() else {
            return Err(LinkError::BusOff);
        };
        let res = match frame.kind() {
            Kind::Data => match CanDataFrame::new(id, frame.data()) {
                Some(f) => sock.write_frame(&f),
                None => return Err(LinkError::Unsupported(Unsendable::DataLength)),
            },
            Kind::Remote { dlc } => match CanRemoteFrame::new_remote(id, dlc as usize) {
                Some(f) => sock.write_frame(&f),
                None => return Err(LinkError::Unsupported(Unsendable::RemoteDlc)),
            },
            Kind::Fd { brs, esi } => match CanFdFrame::new(id, frame.data()) {
                Some(mut f) => {
                    f.set_brs(brs);
                    f.set_esi(esi);
                    sock.write_frame(&f)
                }
                None => return Err(LinkError::Unsupported(Unsendable::FdDataLength)),
            },
        };
        match res {
            Ok(()) => {
                self.counters.tx += 1;
                Ok(())
            }
            Err(e) => match e.raw_os_error() {
                Some(libc_errno::ENOBUFS) => {
                    self.counters.tx_dropped += 1;
                    Err(LinkError::TxQueueFull)
                }
                _ if e.kind() == io::ErrorKind::WouldBlock => {
                    self.counters.tx_dropped += 1;
                    Err(LinkError::TxQueueFull)
                }
                Some(libc_errno::ENETDOWN) => {
                    self.enter_bus_off();
                    Err(LinkError::BusOff)
                }
                Some(libc_errno::EINVAL) if frame.is_fd() => {
                    Err(LinkError::Unsupported(Unsendable::FdOnClassicInterface))
                }
                _ => Err(LinkError::io(&e)),
            },
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Received>> {
        use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(r) = self.read_one()? {
                return Ok(Some(r));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            if !self.recover() {
                std::thread::park_timeout(left.min(Backoff::MIN));
                continue;
            }
            let Some(sock) = self.sock.as_ref() else {
                continue;
            };
            // Round up so that a sub-millisecond wait is not a busy loop.
            let ms = left.as_micros().div_ceil(1000).min(i32::MAX as u128) as i32;
            let mut fds = [PollFd::new(sock.as_fd(), PollFlags::POLLIN)];
            match poll(
                &mut fds,
                PollTimeout::try_from(ms).unwrap_or(PollTimeout::MAX),
            ) {
                Ok(_) | Err(nix::Error::EINTR) => {}
                Err(e) => return Err(LinkError::io(&e.into())),
            }
        }
    }

    fn try_recv(&mut self) -> Result<Option<Received>> {
        if self.sock.is_none() {
            self.recover();
        }
        self.read_one()
    }

    fn state(&self) -> BusState {
        self.state
    }

    fn counters(&self) -> BusCounters {
        // Frames the kernel dropped because this socket's receive queue was
        // full are receive overruns too (one getsockopt, no allocation).
        let open = self.sock.as_ref().map_or(0, socket_drops);
        BusCounters {
            rx_overruns: self.counters.rx_overruns + self.drops_closed + open,
            ..self.counters
        }
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            fd: self.fd,
            remote: true,
            timestamps: if self.timestamps {
                TimestampBase::UnixEpoch
            } else {
                TimestampBase::None
            },
            simulated_faults: false,
        }
    }

    /// Closes and reopens the socket: frames still queued in it are dropped.
    /// While bus-off the socket is already closed (nothing is queued) and
    /// reopening is recovery's job, which waits for the interface.
    fn flush_tx(&mut self) -> Result<()> {
        if self.sock.is_none() && self.state == BusState::BusOff {
            return Ok(());
        }
        // `connect_raw` allocates nothing; its error is the OS's.
        self.connect_raw().map_err(|e| LinkError::io(&e))
    }

    fn reopen(&mut self) -> OpenResult<()> {
        self.counters.reopens += 1;
        self.connect()?;
        self.backoff.reset();
        Ok(())
    }

    fn spec(&self) -> &str {
        &self.config.spec
    }
}
