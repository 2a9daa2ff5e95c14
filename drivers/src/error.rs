//! The error type of every bus operation.

use std::io;

/// A crate result.
pub type Result<T, E = BusError> = std::result::Result<T, E>;

/// What went wrong on a bus. Variants met in the control period
/// ([`BusOff`](BusError::BusOff), [`TxQueueFull`](BusError::TxQueueFull),
/// [`Unsupported`](BusError::Unsupported)) carry no heap data.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// The bus spec string did not parse.
    #[error(transparent)]
    Spec(#[from] crate::SpecError),
    /// The node is bus-off: nothing can be sent until it recovers.
    #[error("bus-off: the controller left the bus after too many errors")]
    BusOff,
    /// The transmit queue is full; the frame was dropped and counted.
    #[error("transmit queue full: frame dropped")]
    TxQueueFull,
    /// The bus cannot carry this kind of frame (e.g. CAN FD on a classic bus).
    #[error("this bus cannot send {0}")]
    Unsupported(&'static str),
    /// The bus or device went away (adapter unplugged, in-process bus closed).
    #[error("{spec}: disconnected ({reason})")]
    Disconnected {
        /// The bus spec or device path.
        spec: String,
        /// What was observed.
        reason: String,
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

impl BusError {
    /// Wraps an I/O error, naming the spec.
    pub fn io(spec: &str, source: io::Error) -> Self {
        BusError::Io {
            spec: spec.to_owned(),
            source,
        }
    }
}
