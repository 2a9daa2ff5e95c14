//! The two error families of a bus: opening it, and using it.
//!
//! [`OpenError`] comes from [`open`](crate::open), the drivers' constructors
//! and [`Bus::reopen`](crate::Bus::reopen): set-up time, where a message may
//! own strings (the spec, the device path, the adapter's answer).
//! [`LinkError`] comes from [`Bus::send`](crate::Bus::send),
//! [`recv`](crate::Bus::recv), [`try_recv`](crate::Bus::try_recv),
//! [`drain`](crate::Bus::drain) and [`flush_tx`](crate::Bus::flush_tx),
//! which the daemon calls every control period: it is a small `Copy` value
//! that never allocates. It does not repeat the spec: the caller has it
//! ([`Bus::spec`](crate::Bus::spec)) and names it in its messages.

use std::fmt;
use std::io;

/// A crate result; the error defaults to the control period's [`LinkError`].
pub type Result<T, E = LinkError> = std::result::Result<T, E>;

/// The result of opening or reopening a bus.
pub type OpenResult<T> = std::result::Result<T, OpenError>;

/// The accepted bus spec forms ([`BusSpec`](crate::BusSpec)), for error
/// messages.
pub const ACCEPTED_FORMS: &str = "socketcan:IFACE[?fd=0|1&timestamps=0|1], \
slcan:PATH@BITRATE[?baud=N&timestamps=0|1&listen=0|1&fd=0|1&recover=0|1&status_ms=N], \
mem:NAME[?bitrate=N&echo=0|1&capacity=N]";

/// A bus spec string that did not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bad bus spec '{spec}': {reason} (accepted: {ACCEPTED_FORMS})")]
pub struct SpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong with it.
    pub reason: String,
}

/// What went wrong opening (or reopening) a bus. Every variant names the
/// spec.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The bus spec string did not parse.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// The device went away while it was being set up.
    #[error("{spec}: disconnected ({reason})")]
    Disconnected {
        /// The bus spec or device path.
        spec: String,
        /// What was observed.
        reason: LostReason,
    },
    /// The kernel has no SocketCAN support (`socket(AF_CAN)` gave EAFNOSUPPORT).
    #[error(
        "{spec}: this kernel has no CAN support (socket(AF_CAN) failed with EAFNOSUPPORT); load the can and can_raw modules"
    )]
    NoKernelCan {
        /// The bus spec.
        spec: String,
    },
    /// The named network interface does not exist.
    #[error("{spec}: no CAN interface named '{interface}' (see `ip link show`)")]
    MissingInterface {
        /// The bus spec.
        spec: String,
        /// The interface name.
        interface: String,
    },
    /// The serial device does not exist.
    #[error("{spec}: no serial device at {path}")]
    MissingDevice {
        /// The bus spec.
        spec: String,
        /// The device path.
        path: String,
    },
    /// Access to the device or interface was refused.
    #[error("{spec}: permission denied on {path} (is the user in the dialout group?)")]
    PermissionDenied {
        /// The bus spec.
        spec: String,
        /// The device path or interface.
        path: String,
    },
    /// An SLCAN adapter answered BEL (error) to a command.
    #[error("{spec}: the adapter rejected '{command}' (answered BEL)")]
    AdapterRejected {
        /// The bus spec.
        spec: String,
        /// The command, without its carriage return.
        command: String,
    },
    /// An SLCAN adapter did not answer a command in time.
    #[error("{spec}: the adapter did not answer '{command}' within {timeout_ms} ms")]
    AdapterTimeout {
        /// The bus spec.
        spec: String,
        /// The command.
        command: String,
        /// How long we waited.
        timeout_ms: u64,
    },
    /// An SLCAN adapter answered with bytes that are not SLCAN.
    #[error("{spec}: garbage from the adapter in answer to '{command}': {detail}")]
    AdapterGarbage {
        /// The bus spec.
        spec: String,
        /// The command that was answered.
        command: String,
        /// What was received (escaped).
        detail: String,
    },
    /// Any other I/O error, with the spec or path it happened on.
    #[error("{spec}: {source}")]
    Io {
        /// The bus spec or device path.
        spec: String,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
}

impl OpenError {
    /// Wraps an I/O error, naming the spec.
    pub fn io(spec: &str, source: io::Error) -> Self {
        OpenError::Io {
            spec: spec.to_owned(),
            source,
        }
    }
}

/// What went wrong sending or receiving: `Copy`, no heap data, so the
/// control period can meet it without allocating. The spec is the caller's
/// to add ([`Bus::spec`](crate::Bus::spec)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LinkError {
    /// The node is bus-off: nothing can be sent until it recovers.
    #[error("bus-off: the controller left the bus after too many errors")]
    BusOff,
    /// The transmit queue is full; the frame was dropped and counted.
    #[error("transmit queue full: frame dropped")]
    TxQueueFull,
    /// The bus cannot carry this frame (e.g. CAN FD on a classic bus).
    #[error("this bus cannot send {0}")]
    Unsupported(Unsendable),
    /// The bus or device went away (adapter unplugged): the driver
    /// reconnects by itself where it can ([`BusState::Gone`](crate::BusState::Gone)).
    #[error("disconnected ({0})")]
    Disconnected(LostReason),
    /// Any other I/O error.
    #[error("{0}")]
    Io(IoCause),
}

impl LinkError {
    /// An I/O error, kept as its kind and OS error number (no allocation).
    pub fn io(e: &io::Error) -> Self {
        LinkError::Io(IoCause::of(e))
    }
}

/// What a bus cannot send ([`LinkError::Unsupported`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unsendable {
    /// Any frame: the bus was opened listen-only.
    ListenOnly,
    /// CAN FD frames on an SLCAN adapter opened without `?fd=1`.
    FdNotEnabled,
    /// CAN FD frames on a SocketCAN bus opened without `?fd=1` or on an
    /// interface whose MTU is not 72.
    FdNotEnabledOrMtu,
    /// CAN FD frames on an interface that refused them (MTU 16).
    FdOnClassicInterface,
    /// A frame with this identifier.
    Identifier,
    /// A classic frame with this data length.
    DataLength,
    /// A remote frame with this DLC.
    RemoteDlc,
    /// A CAN FD frame with this data length.
    FdDataLength,
}

impl Unsendable {
    /// What cannot be sent, in words.
    pub const fn describe(self) -> &'static str {
        match self {
            Unsendable::ListenOnly => "frames in listen-only mode",
            Unsendable::FdNotEnabled => "CAN FD frames (open with ?fd=1)",
            Unsendable::FdNotEnabledOrMtu => {
                "CAN FD frames (open with ?fd=1 an interface with mtu 72)"
            }
            Unsendable::FdOnClassicInterface => "CAN FD frames on this interface (MTU 16)",
            Unsendable::Identifier => "this identifier",
            Unsendable::DataLength => "this data length",
            Unsendable::RemoteDlc => "this remote DLC",
            Unsendable::FdDataLength => "this FD data length",
        }
    }
}

impl fmt::Display for Unsendable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.describe())
    }
}

/// Why a device was lost ([`LinkError::Disconnected`],
/// [`OpenError::Disconnected`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LostReason {
    /// End of file on the serial port (the adapter was unplugged).
    EndOfFile,
    /// The port is closed and the driver is reconnecting with back-off.
    Reconnecting,
    /// An I/O error on the device.
    Io(IoCause),
}

impl fmt::Display for LostReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LostReason::EndOfFile => f.write_str("end of file on the serial port"),
            LostReason::Reconnecting => f.write_str("serial port closed, reconnecting"),
            LostReason::Io(c) => c.fmt(f),
        }
    }
}

/// An I/O error reduced to what is `Copy`: its kind and, when the OS gave
/// one, its error number (displayed as the OS describes it, as
/// [`io::Error`] does).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IoCause {
    kind: io::ErrorKind,
    os: Option<i32>,
}

impl IoCause {
    /// The kind and OS error number of `e`; a message `e` may carry is not
    /// kept.
    pub fn of(e: &io::Error) -> Self {
        IoCause {
            kind: e.kind(),
            os: e.raw_os_error(),
        }
    }

    /// The error's kind.
    pub fn kind(self) -> io::ErrorKind {
        self.kind
    }

    /// The OS error number, if the OS reported the error.
    pub fn raw_os_error(self) -> Option<i32> {
        self.os
    }
}

impl From<&io::Error> for IoCause {
    fn from(e: &io::Error) -> Self {
        IoCause::of(e)
    }
}

impl fmt::Display for IoCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.os {
            // Same text as the `io::Error` it came from, e.g.
            // "Input/output error (os error 5)".
            Some(code) => io::Error::from_raw_os_error(code).fmt(f),
            None => self.kind.fmt(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_copy<T: Copy + Send + Sync + 'static>() {}

    #[test]
    fn the_loop_facing_error_is_small_and_copy() {
        assert_copy::<LinkError>();
        assert_copy::<LostReason>();
        assert_copy::<IoCause>();
        // Two machine words at most: it is returned every control period.
        assert!(
            std::mem::size_of::<LinkError>() <= 16,
            "{}",
            std::mem::size_of::<LinkError>()
        );
        assert!(std::mem::size_of::<Result<()>>() <= 16);
    }

    #[test]
    fn link_errors_read_as_before() {
        assert_eq!(
            LinkError::Unsupported(Unsendable::ListenOnly).to_string(),
            "this bus cannot send frames in listen-only mode"
        );
        assert_eq!(
            LinkError::Disconnected(LostReason::EndOfFile).to_string(),
            "disconnected (end of file on the serial port)"
        );
        let eio = io::Error::from_raw_os_error(5);
        assert_eq!(
            LinkError::Disconnected(LostReason::Io(IoCause::of(&eio))).to_string(),
            format!("disconnected ({eio})")
        );
        assert_eq!(LinkError::io(&eio).to_string(), eio.to_string());
        let custom = io::Error::new(io::ErrorKind::BrokenPipe, "gone");
        let c = IoCause::of(&custom);
        assert_eq!(
            (c.kind(), c.raw_os_error()),
            (io::ErrorKind::BrokenPipe, None)
        );
        assert_eq!(c.to_string(), io::ErrorKind::BrokenPipe.to_string());
    }
}
