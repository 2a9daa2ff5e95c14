//! The bus interface every driver implements ([`Bus`]) and what it
//! reports: received frames, the bus state, counters, capabilities.

use std::time::Duration;

use crate::error::{OpenResult, Result};
use anguilla_protocol::Frame;

/// A frame taken off a bus, with the time it arrived if the bus knows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// The frame.
    pub frame: Frame,
    /// Arrival time; its time base is [`Capabilities::timestamps`].
    pub timestamp: Option<Duration>,
}

/// The fault-confinement state of this node's CAN controller (ISO 11898-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BusState {
    /// Normal operation: error counters below 128.
    #[default]
    ErrorActive,
    /// An error counter reached 128: the node still sends, but only passive
    /// error flags.
    ErrorPassive,
    /// The transmit error counter passed 255: the node is off the bus until
    /// it recovers ([`Bus::reopen`] or the driver's automatic recovery).
    BusOff,
    /// The adapter is gone (unplugged, its device closed): nothing is sent
    /// or received until the driver reconnects it, with back-off, at the
    /// same path.
    Gone,
}

impl BusState {
    /// Every state, in code order.
    pub const ALL: [BusState; 4] = [
        BusState::ErrorActive,
        BusState::ErrorPassive,
        BusState::BusOff,
        BusState::Gone,
    ];

    /// The state's number where it is published and recorded
    /// (`StateSnapshot::bus.state`, `session.log` period lines): 0
    /// error-active, 1 error-passive, 2 bus-off, 3 adapter gone.
    pub const fn code(self) -> u8 {
        match self {
            BusState::ErrorActive => 0,
            BusState::ErrorPassive => 1,
            BusState::BusOff => 2,
            BusState::Gone => 3,
        }
    }

    /// The state of a [`code`](Self::code), if it is one.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(BusState::ErrorActive),
            1 => Some(BusState::ErrorPassive),
            2 => Some(BusState::BusOff),
            3 => Some(BusState::Gone),
            _ => None,
        }
    }
}

/// Monotonic counters of one bus handle since it was opened (they survive
/// [`Bus::reopen`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusCounters {
    /// Frames handed to the bus by [`Bus::send`].
    pub tx: u64,
    /// Frames returned by [`Bus::recv`], [`Bus::try_recv`] or [`Bus::drain`].
    pub rx: u64,
    /// Frames accepted by `send` and later discarded unsent (purge, bus-off,
    /// full queue, adapter refusal).
    pub tx_dropped: u64,
    /// Received frames lost because a receive queue was full.
    pub rx_overruns: u64,
    /// Errors seen: error frames, error replies, garbage on a serial line.
    pub errors: u64,
    /// Times this node went bus-off.
    pub bus_off_count: u64,
    /// Times the bus was reopened (by the caller or by automatic recovery).
    pub reopens: u64,
}

/// What the arrival timestamps of a bus mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimestampBase {
    /// The bus gives no timestamps.
    None,
    /// The bus's [`Clock`](crate::Clock) (in-process bus).
    BusClock,
    /// Time since the Unix epoch, taken by the kernel (SocketCAN).
    UnixEpoch,
    /// The adapter's millisecond counter, which wraps every 60 s (SLCAN `Z1`).
    AdapterMillis,
}

/// What a bus can do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Capabilities {
    /// Whether CAN FD frames can be sent and received.
    pub fd: bool,
    /// Whether remote frames can be sent and received.
    pub remote: bool,
    /// The time base of [`Received::timestamp`].
    pub timestamps: TimestampBase,
    /// Whether the bus can be forced bus-off by a test hook.
    pub simulated_faults: bool,
}

/// A CAN bus as seen by one node.
///
/// Receive timeouts are not errors: [`recv`](Bus::recv) returns `Ok(None)`.
/// [`send`](Bus::send), [`try_recv`](Bus::try_recv) and
/// [`drain`](Bus::drain) never block for long (at most one serial write or
/// one socket write) and do not allocate: the daemon calls them every
/// control period (`tests/no_alloc.rs` checks the in-process bus and SLCAN,
/// and SocketCAN, its automatic reconnection included, in the vcan VM). The
/// exception is an SLCAN adapter that disappeared ([`BusState::Gone`]): its
/// serial port is opened again from scratch, which allocates as setup does.
///
/// Errors come in two families: these calls fail with a `Copy`
/// [`LinkError`](crate::LinkError), which owns nothing (callers add [`spec`](Bus::spec) to
/// their messages); opening and [`reopen`](Bus::reopen) fail with an
/// [`OpenError`](crate::OpenError), which names the spec and the device.
pub trait Bus: Send {
    /// Queues one frame for transmission. Fails with [`LinkError::BusOff`](crate::LinkError::BusOff)
    /// while the node is bus-off: a frame is never held back to be sent late.
    fn send(&mut self, frame: &Frame) -> Result<()>;

    /// Waits up to `timeout` for one frame; `Ok(None)` when none came.
    fn recv(&mut self, timeout: Duration) -> Result<Option<Received>>;

    /// Takes one frame if one is already there, without waiting.
    fn try_recv(&mut self) -> Result<Option<Received>> {
        self.recv(Duration::ZERO)
    }

    /// Hands every frame already received to `f`, without waiting; returns
    /// how many.
    fn drain(&mut self, f: &mut dyn FnMut(Received)) -> Result<usize> {
        let mut n = 0;
        while let Some(r) = self.try_recv()? {
            f(r);
            n += 1;
        }
        Ok(n)
    }

    /// The controller's fault-confinement state as last known.
    fn state(&self) -> BusState;

    /// Counters since the handle was opened.
    fn counters(&self) -> BusCounters;

    /// What the bus supports.
    fn capabilities(&self) -> Capabilities;

    /// Discards every frame accepted by `send` but not yet on the wire, as
    /// far as this driver can reach (see each implementation). Used after a
    /// fault so that stale setpoints are never sent late.
    fn flush_tx(&mut self) -> Result<()>;

    /// Closes and reopens the bus: queued frames in both directions are
    /// discarded, the state returns to error-active if the bus allows it.
    fn reopen(&mut self) -> OpenResult<()>;

    /// The spec this bus was opened from, for messages.
    fn spec(&self) -> &str;
}

impl<B: Bus + ?Sized> Bus for Box<B> {
    fn send(&mut self, frame: &Frame) -> Result<()> {
        (**self).send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<Received>> {
        (**self).recv(timeout)
    }
    fn try_recv(&mut self) -> Result<Option<Received>> {
        (**self).try_recv()
    }
    fn drain(&mut self, f: &mut dyn FnMut(Received)) -> Result<usize> {
        (**self).drain(f)
    }
    fn state(&self) -> BusState {
        (**self).state()
    }
    fn counters(&self) -> BusCounters {
        (**self).counters()
    }
    fn capabilities(&self) -> Capabilities {
        (**self).capabilities()
    }
    fn flush_tx(&mut self) -> Result<()> {
        (**self).flush_tx()
    }
    fn reopen(&mut self) -> OpenResult<()> {
        (**self).reopen()
    }
    fn spec(&self) -> &str {
        (**self).spec()
    }
}
