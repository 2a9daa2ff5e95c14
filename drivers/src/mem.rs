//! The in-process bus: any number of participants in one process.
//!
//! A [`MemBus`] is one simulated CAN bus; every [`MemParticipant`] is a node
//! on it and implements [`Bus`]. A frame sent by one participant is received
//! by all the others (and by the sender too if `echo` is on). Named buses are
//! kept in a process-wide registry so that [`crate::open`]`("mem:NAME")`
//! called twice gives two nodes of the same bus.
//!
//! **Wire time.** With a bit rate set, frames take their worst-case bit time
//! on the bus's [`Clock`] — the protocol's
//! [`anguilla_protocol::budget::worst_case_bits`], bit
//! stuffing and interframe space included, the same figure the bus budget
//! counts — one at a time; when the
//! bus frees, the pending frame with the lowest
//! [`arbitration_key`](anguilla_protocol::Id::arbitration_key) wins, as on a
//! real bus (each node sends its own frames in order). Time is read from the
//! clock whenever a participant sends or polls, so on a [`ManualClock`] the
//! bus moves only as fast as the test advances the clock. Receive timeouts
//! are always real time, so a test can never hang on a stopped clock.
//!
//! **Fault hooks** on [`MemBus`]: drop the next n frames or a seeded random
//! fraction, delay every frame, corrupt the data of the next n frames, force a
//! participant error-passive or bus-off, inject frames from an outside node.
//!
//! **Bounds.** Every receive and transmit queue holds at most `capacity`
//! frames, allocated up front: a full receive queue drops the new frame and
//! counts an overrun, a full transmit queue refuses the frame. `send`,
//! `try_recv` and `drain` never allocate.
//!
//! [`ManualClock`]: crate::ManualClock

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Condvar, LazyLock, Mutex, MutexGuard, Weak};
use std::time::{Duration, Instant};

use anguilla_protocol::budget::worst_case_bits;
use anguilla_protocol::frame::Kind;

use crate::{
    Bus, BusCounters, BusState, Capabilities, Clock, Frame, LinkError, MonotonicClock, OpenResult,
    Received, Result, TimestampBase,
};

/// Default queue capacity (frames) of each participant.
pub const DEFAULT_CAPACITY: usize = 1024;

/// Options of an in-process bus (`mem:NAME?bitrate=..&echo=..&capacity=..`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemConfig {
    /// The bus name in the process registry.
    pub name: String,
    /// Nominal bit rate for wire-time simulation; `None`: frames take no time.
    pub bitrate: Option<u32>,
    /// Data-phase bit rate of CAN FD frames with BRS (default: `bitrate`).
    pub data_bitrate: Option<u32>,
    /// Whether senders receive their own frames.
    pub echo: bool,
    /// Capacity of each participant's receive and transmit queues.
    pub capacity: usize,
}

impl MemConfig {
    /// Defaults: no wire time, no echo, [`DEFAULT_CAPACITY`].
    pub fn new(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            bitrate: None,
            data_bitrate: None,
            echo: false,
            capacity: DEFAULT_CAPACITY,
        }
    }
}

/// Identifies a participant of a [`MemBus`] (for fault hooks).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ParticipantId(usize);

/// What the fault hooks have done so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaultStats {
    /// Frames lost on the wire by `drop_next` / `drop_fraction`.
    pub dropped: u64,
    /// Frames whose data was corrupted.
    pub corrupted: u64,
    /// Frames injected.
    pub injected: u64,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    frame: Frame,
    submitted: Duration,
    seq: u64,
}

#[derive(Debug)]
struct Slot {
    alive: bool,
    rx: VecDeque<Received>,
    tx: VecDeque<Pending>,
    state: BusState,
    counters: BusCounters,
}

#[derive(Debug, Default)]
struct Faults {
    drop_next: u64,
    /// Probability of a drop, scaled to `u32::MAX`.
    drop_threshold: u32,
    corrupt_next: u64,
    delay: Duration,
    rng: u64,
    stats: FaultStats,
}

impl Faults {
    /// xorshift64*: a small, seeded, reproducible generator.
    fn next_u32(&mut self) -> u32 {
        let mut x = self.rng;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.rng = x;
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 32) as u32
    }
}

struct Inner {
    slots: Vec<Slot>,
    faults: Faults,
    bus_free_at: Duration,
    next_seq: u64,
}

struct Core {
    config: MemConfig,
    clock: Arc<dyn Clock>,
    inner: Mutex<Inner>,
    cv: Condvar,
}

static REGISTRY: LazyLock<Mutex<HashMap<String, Weak<Core>>>> =
    LazyLock::new(|| Mutex::new(HashMap::new()));

/// One in-process CAN bus. Clones are handles to the same bus.
#[derive(Clone)]
pub struct MemBus {
    core: Arc<Core>,
}

impl std::fmt::Debug for MemBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MemBus")
            .field("config", &self.core.config)
            .finish_non_exhaustive()
    }
}

/// Builds a [`MemBus`] with a chosen clock and options.
pub struct MemBusBuilder {
    config: MemConfig,
    clock: Arc<dyn Clock>,
}

impl MemBusBuilder {
    /// Wire-time simulation at this nominal bit rate (bit/s).
    pub fn bitrate(mut self, bps: u32) -> Self {
        self.config.bitrate = Some(bps.max(1));
        self
    }
    /// Data-phase bit rate of CAN FD frames with BRS.
    pub fn data_bitrate(mut self, bps: u32) -> Self {
        self.config.data_bitrate = Some(bps.max(1));
        self
    }
    /// Whether senders receive their own frames.
    pub fn echo(mut self, on: bool) -> Self {
        self.config.echo = on;
        self
    }
    /// Capacity of each participant's queues (at least 1).
    pub fn capacity(mut self, frames: usize) -> Self {
        self.config.capacity = frames.max(1);
        self
    }
    /// The clock for wire time and timestamps (default: [`MonotonicClock`]).
    pub fn clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.clock = clock;
        self
    }
    /// Makes a bus that only the returned handle (and its clones) can join.
    pub fn build(self) -> MemBus {
        MemBus {
            core: Arc::new(Core {
                config: self.config,
                clock: self.clock,
                inner: Mutex::new(Inner {
                    slots: Vec::new(),
                    faults: Faults {
                        rng: 0x9E37_79B9_7F4A_7C15,
                        ..Faults::default()
                    },
                    bus_free_at: Duration::ZERO,
                    next_seq: 0,
                }),
                cv: Condvar::new(),
            }),
        }
    }
    /// Makes the bus and registers it under its name (replacing any bus of
    /// that name), so that `open("mem:NAME")` joins it.
    pub fn register(self) -> MemBus {
        let name = self.config.name.clone();
        let bus = self.build();
        lock_registry().insert(name, Arc::downgrade(&bus.core));
        bus
    }
}

fn lock_registry() -> MutexGuard<'static, HashMap<String, Weak<Core>>> {
    // A panic elsewhere while holding the registry leaves valid data.
    REGISTRY.lock().unwrap_or_else(|p| p.into_inner())
}

fn bits_time(bits: u64, bps: u32) -> Duration {
    Duration::from_nanos(bits.saturating_mul(1_000_000_000) / u64::from(bps.max(1)))
}

impl Core {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn wire_time(&self, frame: &Frame) -> Duration {
        match self.config.bitrate {
            None => Duration::ZERO,
            Some(bps) => {
                let bits = worst_case_bits(frame);
                bits_time(bits.nominal.into(), bps)
                    + bits_time(bits.data.into(), self.config.data_bitrate.unwrap_or(bps))
            }
        }
    }

    fn deliver(&self, inner: &mut Inner, from: Option<usize>, mut frame: Frame, at: Duration) {
        let f = &mut inner.faults;
        if f.drop_next > 0 {
            f.drop_next -= 1;
            f.stats.dropped += 1;
            return;
        }
        if f.drop_threshold > 0 && f.next_u32() < f.drop_threshold {
            f.stats.dropped += 1;
            return;
        }
        if f.corrupt_next > 0 && !frame.is_empty() {
            f.corrupt_next -= 1;
            f.stats.corrupted += 1;
            let bit = f.next_u32() as usize % (frame.len() * 8);
            let mut data = [0u8; anguilla_protocol::frame::MAX_FD_LEN];
            data[..frame.len()].copy_from_slice(frame.data());
            data[bit / 8] ^= 1 << (bit % 8);
            frame = rebuild(&frame, &data[..frame.len()]);
        }
        let cap = self.config.capacity;
        for (i, slot) in inner.slots.iter_mut().enumerate() {
            // A bus-off controller is off the bus: it hears nothing either.
            if !slot.alive
                || slot.state == BusState::BusOff
                || (Some(i) == from && !self.config.echo)
            {
                continue;
            }
            if slot.rx.len() >= cap {
                slot.counters.rx_overruns += 1;
            } else {
                slot.rx.push_back(Received {
                    frame,
                    timestamp: Some(at),
                });
            }
        }
    }

    /// Moves frames whose wire time has passed from transmit queues to
    /// receive queues; returns when the next frame will finish, if one is
    /// pending.
    fn advance(&self, inner: &mut Inner) -> Option<Duration> {
        let now = self.clock.now();
        let mut delivered = false;
        let next = loop {
            // The contenders are the oldest frame of each node.
            let mut earliest: Option<Duration> = None;
            for s in inner.slots.iter() {
                if let Some(p) = s.tx.front() {
                    earliest = Some(earliest.map_or(p.submitted, |e| e.min(p.submitted)));
                }
            }
            let Some(earliest) = earliest else { break None };
            let start = inner.bus_free_at.max(earliest);
            if start > now {
                break Some(start);
            }
            let mut winner: Option<(usize, u64, u64)> = None;
            for (i, s) in inner.slots.iter().enumerate() {
                if let Some(p) = s.tx.front()
                    && p.submitted <= start
                {
                    let key = (p.frame.id().arbitration_key(), p.seq);
                    if winner.is_none_or(|(_, k, q)| key < (k, q)) {
                        winner = Some((i, key.0, key.1));
                    }
                }
            }
            let Some((w, _, _)) = winner else { break None };
            let frame = inner.slots[w].tx.front().map(|p| p.frame);
            let Some(frame) = frame else { break None };
            let end = start + self.wire_time(&frame) + inner.faults.delay;
            if end > now {
                break Some(end);
            }
            inner.slots[w].tx.pop_front();
            inner.bus_free_at = end;
            self.deliver(inner, Some(w), frame, end);
            delivered = true;
        };
        if delivered {
            self.cv.notify_all();
        }
        next
    }
}

fn rebuild(frame: &Frame, data: &[u8]) -> Frame {
    let built = match frame.kind() {
        Kind::Fd { brs, esi } => Frame::new_fd(frame.id(), data, brs).map(|f| f.with_esi(esi)),
        _ => Frame::new(frame.id(), data),
    };
    built.unwrap_or(*frame)
}

impl MemBus {
    /// A builder for a bus named `name` (the name shows in specs and errors).
    pub fn builder(name: &str) -> MemBusBuilder {
        MemBusBuilder {
            config: MemConfig::new(name),
            clock: Arc::new(MonotonicClock::new()),
        }
    }

    /// The registered bus of this name, or a new one with these options on a
    /// [`MonotonicClock`] (options are ignored if the bus already exists).
    pub fn open_or_create(config: &MemConfig) -> MemBus {
        let mut reg = lock_registry();
        if let Some(core) = reg.get(&config.name).and_then(Weak::upgrade) {
            return MemBus { core };
        }
        let b = MemBusBuilder {
            config: config.clone(),
            clock: Arc::new(MonotonicClock::new()),
        };
        let bus = b.build();
        reg.insert(config.name.clone(), Arc::downgrade(&bus.core));
        bus
    }

    /// The bus options.
    pub fn config(&self) -> &MemConfig {
        &self.core.config
    }

    /// The bus clock.
    pub fn clock(&self) -> Arc<dyn Clock> {
        self.core.clock.clone()
    }

    /// Joins the bus as a new node (allocates its queues).
    pub fn participant(&self) -> MemParticipant {
        let cap = self.core.config.capacity;
        let slot = Slot {
            alive: true,
            rx: VecDeque::with_capacity(cap),
            tx: VecDeque::with_capacity(cap),
            state: BusState::ErrorActive,
            counters: BusCounters::default(),
        };
        let mut inner = self.core.lock();
        let idx = match inner.slots.iter().position(|s| !s.alive) {
            Some(i) => {
                inner.slots[i] = slot;
                i
            }
            None => {
                inner.slots.push(slot);
                inner.slots.len() - 1
            }
        };
        MemParticipant {
            core: self.core.clone(),
            idx,
            spec: format!("mem:{}", self.core.config.name),
        }
    }

    /// Number of nodes on the bus.
    pub fn participants(&self) -> usize {
        self.core.lock().slots.iter().filter(|s| s.alive).count()
    }

    /// Frames sent but not yet delivered (on the wire or waiting for it).
    pub fn frames_in_flight(&self) -> usize {
        let mut inner = self.core.lock();
        self.core.advance(&mut inner);
        inner.slots.iter().map(|s| s.tx.len()).sum()
    }

    /// Loses the next `n` frames on the wire (senders believe they were sent).
    pub fn drop_next(&self, n: u64) {
        self.core.lock().faults.drop_next = n;
    }

    /// Loses each frame with probability `fraction` (0..=1), drawn from a
    /// generator seeded with `seed` (reproducible).
    pub fn drop_fraction(&self, fraction: f64, seed: u64) {
        let mut inner = self.core.lock();
        inner.faults.drop_threshold = (fraction.clamp(0.0, 1.0) * f64::from(u32::MAX)) as u32;
        inner.faults.rng = seed | 1;
    }

    /// Makes every frame occupy the wire `delay` longer (a slow bus).
    pub fn set_delay(&self, delay: Duration) {
        self.core.lock().faults.delay = delay;
    }

    /// Flips one data bit (chosen by the seeded generator) in each of the
    /// next `n` frames that carry data; frames without data pass unchanged.
    pub fn corrupt_next(&self, n: u64) {
        self.core.lock().faults.corrupt_next = n;
    }

    /// Clears every fault hook (drops, delay, corruption).
    pub fn clear_faults(&self) {
        let mut inner = self.core.lock();
        let stats = inner.faults.stats;
        let rng = inner.faults.rng;
        inner.faults = Faults {
            stats,
            rng,
            ..Faults::default()
        };
    }

    /// What the fault hooks have done.
    pub fn fault_stats(&self) -> FaultStats {
        self.core.lock().faults.stats
    }

    /// Forces a node's controller state. Going bus-off discards the node's
    /// queued frames (counted as `tx_dropped`) and makes its `send` fail with
    /// [`LinkError::BusOff`] until it reopens or is forced error-active.
    pub fn force_state(&self, id: ParticipantId, state: BusState) {
        let mut inner = self.core.lock();
        if let Some(slot) = inner.slots.get_mut(id.0).filter(|s| s.alive) {
            if state == BusState::BusOff && slot.state != BusState::BusOff {
                slot.counters.bus_off_count += 1;
                slot.counters.tx_dropped += slot.tx.len() as u64;
                slot.tx.clear();
            }
            slot.state = state;
        }
        self.core.cv.notify_all();
    }

    /// Delivers `frame` to every node now, as if sent by a node outside the
    /// process (fault hooks apply).
    pub fn inject(&self, frame: &Frame) {
        let mut inner = self.core.lock();
        inner.faults.stats.injected += 1;
        let now = self.core.clock.now();
        self.core.deliver(&mut inner, None, *frame, now);
        self.core.cv.notify_all();
    }
}

/// One node on a [`MemBus`]; implements [`Bus`]. Leaves the bus on drop.
pub struct MemParticipant {
    core: Arc<Core>,
    idx: usize,
    spec: String,
}

impl std::fmt::Debug for MemParticipant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MemParticipant({} #{})", self.spec, self.idx)
    }
}

impl MemParticipant {
    /// This node's id, for the fault hooks of [`MemBus`].
    pub fn id(&self) -> ParticipantId {
        ParticipantId(self.idx)
    }

    /// A handle to the bus this node is on.
    pub fn bus(&self) -> MemBus {
        MemBus {
            core: self.core.clone(),
        }
    }

    fn pop(&self, inner: &mut Inner) -> Option<Received> {
        let slot = &mut inner.slots[self.idx];
        let r = slot.rx.pop_front()?;
        slot.counters.rx += 1;
        Some(r)
    }
}

impl Drop for MemParticipant {
    fn drop(&mut self) {
        let mut inner = self.core.lock();
        let slot = &mut inner.slots[self.idx];
        slot.alive = false;
        slot.rx.clear();
        slot.tx.clear();
    }
}

impl Bus for MemParticipant {
    fn send(&mut self, frame: &Frame) -> Result<()> {
        let now = self.core.clock.now();
        let cap = self.core.config.capacity;
        let mut inner = self.core.lock();
        let seq = inner.next_seq;
        let slot = &mut inner.slots[self.idx];
        if slot.state == BusState::BusOff {
            return Err(LinkError::BusOff);
        }
        if slot.tx.len() >= cap {
            slot.counters.tx_dropped += 1;
            return Err(LinkError::TxQueueFull);
        }
        slot.counters.tx += 1;
        slot.tx.push_back(Pending {
            frame: *frame,
            submitted: now,
            seq,
        });
        inner.next_seq += 1;
        self.core.advance(&mut inner);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Received>> {
        let deadline = Instant::now().checked_add(timeout);
        let mut inner = self.core.lock();
        loop {
            let next = self.core.advance(&mut inner);
            if let Some(r) = self.pop(&mut inner) {
                return Ok(Some(r));
            }
            let left = match deadline {
                Some(d) => d.saturating_duration_since(Instant::now()),
                None => Duration::from_secs(3600),
            };
            if left.is_zero() {
                return Ok(None);
            }
            // On a real-time clock, wake when the frame on the wire ends.
            let wait = match next {
                Some(t) if self.core.clock.is_real_time() => {
                    left.min(t.saturating_sub(self.core.clock.now()) + Duration::from_micros(50))
                }
                _ => left,
            };
            inner = self
                .core
                .cv
                .wait_timeout(inner, wait)
                .unwrap_or_else(|p| p.into_inner())
                .0;
        }
    }

    fn try_recv(&mut self) -> Result<Option<Received>> {
        let mut inner = self.core.lock();
        self.core.advance(&mut inner);
        Ok(self.pop(&mut inner))
    }

    fn drain(&mut self, f: &mut dyn FnMut(Received)) -> Result<usize> {
        let mut n = 0;
        loop {
            // The lock is not held while `f` runs: it may send on this bus.
            let r = {
                let mut inner = self.core.lock();
                self.core.advance(&mut inner);
                self.pop(&mut inner)
            };
            match r {
                Some(r) => {
                    f(r);
                    n += 1;
                }
                None => return Ok(n),
            }
        }
    }

    fn state(&self) -> BusState {
        self.core.lock().slots[self.idx].state
    }

    fn counters(&self) -> BusCounters {
        self.core.lock().slots[self.idx].counters
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            fd: true,
            remote: true,
            timestamps: TimestampBase::BusClock,
            simulated_faults: true,
        }
    }

    fn flush_tx(&mut self) -> Result<()> {
        let mut inner = self.core.lock();
        let slot = &mut inner.slots[self.idx];
        slot.counters.tx_dropped += slot.tx.len() as u64;
        slot.tx.clear();
        Ok(())
    }

    fn reopen(&mut self) -> OpenResult<()> {
        let mut inner = self.core.lock();
        let slot = &mut inner.slots[self.idx];
        slot.counters.tx_dropped += slot.tx.len() as u64;
        slot.tx.clear();
        slot.rx.clear();
        slot.state = BusState::ErrorActive;
        slot.counters.reopens += 1;
        Ok(())
    }

    fn spec(&self) -> &str {
        &self.spec
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ManualClock;
    use anguilla_protocol::frame::Id;

    fn std_frame(id: u16, data: &[u8]) -> Frame {
        Frame::new_standard(id, data).unwrap()
    }

    /// The wire time is the protocol's worst-case figure, the one the bus
    /// budget counts (protocol/README.md, "Bus budget"): 135 bits for 8
    /// bytes on a standard id; 34 nominal + 678 data-phase bits for a
    /// 64-byte CAN FD frame with BRS (the README's SetpointGroup line: the
    /// CRC-21 field is 4 + 21 + 7 fixed stuff bits).
    #[test]
    fn wire_time_is_the_protocols_worst_case_bit_count() {
        let clock = ManualClock::new();
        let bus = MemBus::builder("bits")
            .bitrate(1_000_000)
            .data_bitrate(4_000_000)
            .clock(Arc::new(clock.clone()))
            .build();
        let mut a = bus.participant();
        let mut rx = bus.participant();
        let classic = std_frame(0x123, &[0; 8]);
        let fd = Frame::new_fd(Id::standard(0x100).unwrap(), &[0; 64], true).unwrap();
        let ext = Frame::new_fd(Id::extended(0x1234_5678).unwrap(), &[0; 12], true).unwrap();
        for f in [classic, fd, ext] {
            let bits = worst_case_bits(&f);
            let expected =
                bits_time(bits.nominal.into(), 1_000_000) + bits_time(bits.data.into(), 4_000_000);
            let t0 = clock.now();
            a.send(&f).unwrap();
            clock.advance(Duration::from_millis(1));
            let r = rx.try_recv().unwrap().unwrap();
            assert_eq!(r.timestamp.unwrap() - t0, expected, "{f}");
        }
        assert_eq!(worst_case_bits(&classic).nominal, 135);
        let b = worst_case_bits(&fd);
        assert_eq!((b.nominal, b.data), (34, 678));
    }

    #[test]
    fn wire_time_and_arbitration_on_a_manual_clock() {
        let clock = ManualClock::new();
        let bus = MemBus::builder("arb")
            .bitrate(1_000_000)
            .clock(Arc::new(clock.clone()))
            .build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        let mut rx = bus.participant();
        // a sends first (it wins the idle bus), then while it is on the
        // wire b queues 0x100 and a queues 0x300: 0x100 must go next.
        a.send(&std_frame(0x200, &[0; 8])).unwrap();
        clock.advance(Duration::from_micros(10));
        a.send(&std_frame(0x300, &[0; 8])).unwrap();
        b.send(&std_frame(0x100, &[0; 8])).unwrap();
        assert!(rx.try_recv().unwrap().is_none(), "frame still on the wire");
        clock.advance(Duration::from_millis(1));
        let mut got = Vec::new();
        rx.drain(&mut |r| got.push((r.frame.id().raw(), r.timestamp.unwrap())))
            .unwrap();
        let ids: Vec<u32> = got.iter().map(|g| g.0).collect();
        assert_eq!(ids, vec![0x200, 0x100, 0x300]);
        // 135 bits at 1 Mbit/s: back to back, 135 µs apart.
        assert_eq!(got[0].1, Duration::from_micros(135));
        assert_eq!(got[1].1, Duration::from_micros(270));
        assert_eq!(got[2].1, Duration::from_micros(405));
    }

    #[test]
    fn fault_hooks_drop_corrupt_and_bus_off() {
        let bus = MemBus::builder("faults").build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        bus.drop_next(2);
        for i in 0..4u8 {
            a.send(&std_frame(0x10, &[i])).unwrap();
        }
        let mut got = Vec::new();
        b.drain(&mut |r| got.push(r.frame.data()[0])).unwrap();
        assert_eq!(got, vec![2, 3]);
        bus.corrupt_next(1);
        a.send(&std_frame(0x10, &[0, 0])).unwrap();
        let r = b.try_recv().unwrap().unwrap();
        assert_eq!(
            r.frame.data().iter().map(|x| x.count_ones()).sum::<u32>(),
            1
        );
        bus.force_state(a.id(), BusState::BusOff);
        assert_eq!(a.state(), BusState::BusOff);
        assert!(matches!(a.send(&std_frame(1, &[])), Err(LinkError::BusOff)));
        b.send(&std_frame(2, &[])).unwrap();
        assert!(
            a.try_recv().unwrap().is_none(),
            "a bus-off node hears nothing"
        );
        a.reopen().unwrap();
        a.send(&std_frame(1, &[])).unwrap();
        assert_eq!(a.counters().bus_off_count, 1);
        assert_eq!(bus.fault_stats().dropped, 2);
    }

    #[test]
    fn seeded_drop_fraction_is_reproducible() {
        let run = |seed| {
            let bus = MemBus::builder("frac").build();
            let mut a = bus.participant();
            let mut b = bus.participant();
            bus.drop_fraction(0.5, seed);
            for i in 0..200u8 {
                a.send(&std_frame(0x10, &[i])).unwrap();
            }
            let mut got = Vec::new();
            b.drain(&mut |r| got.push(r.frame.data()[0])).unwrap();
            got
        };
        let x = run(7);
        assert_eq!(x, run(7));
        // 200 draws at p = 0.5: 60..140 holds with probability > 1 - 1e-8.
        assert!((60..140).contains(&x.len()), "{}", x.len());
    }

    #[test]
    fn inject_reaches_everyone_and_delay_holds_frames_on_the_wire() {
        let clock = ManualClock::new();
        let bus = MemBus::builder("inject")
            .clock(Arc::new(clock.clone()))
            .build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        let f = std_frame(0x77, &[7]);
        bus.inject(&f);
        assert_eq!(a.try_recv().unwrap().unwrap().frame, f);
        assert_eq!(b.try_recv().unwrap().unwrap().frame, f);
        bus.set_delay(Duration::from_millis(3));
        a.send(&f).unwrap();
        clock.advance(Duration::from_millis(2));
        assert!(b.try_recv().unwrap().is_none());
        assert_eq!(bus.frames_in_flight(), 1);
        clock.advance(Duration::from_millis(1));
        let r = b.try_recv().unwrap().unwrap();
        assert_eq!(r.timestamp, Some(Duration::from_millis(3)));
        bus.clear_faults();
        a.send(&f).unwrap();
        assert!(b.try_recv().unwrap().is_some());
    }

    #[test]
    fn bus_off_purges_queued_frames_and_they_never_arrive() {
        let clock = ManualClock::new();
        let bus = MemBus::builder("purge")
            .bitrate(125_000)
            .clock(Arc::new(clock.clone()))
            .build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        for i in 0..5u8 {
            a.send(&std_frame(0x10, &[i])).unwrap();
        }
        bus.force_state(a.id(), BusState::BusOff);
        assert_eq!(a.counters().tx_dropped, 5);
        clock.advance(Duration::from_secs(1));
        assert!(
            b.try_recv().unwrap().is_none(),
            "a stale frame was sent late"
        );
        a.flush_tx().unwrap();
        a.reopen().unwrap();
        a.send(&std_frame(0x10, &[9])).unwrap();
        clock.advance(Duration::from_secs(1));
        assert_eq!(b.try_recv().unwrap().unwrap().frame.data(), &[9]);
    }

    #[test]
    fn a_saturated_bus_carries_the_frames_the_bit_time_allows() {
        // PEERS.md: 8-byte standard frames at 1 Mbit/s take 135 bits with
        // worst-case stuffing, so one simulated second carries
        // floor(1e6 / 135) = 7407 of them, and no more.
        let clock = ManualClock::new();
        let bus = MemBus::builder("saturated")
            .bitrate(1_000_000)
            .capacity(10_000)
            .clock(Arc::new(clock.clone()))
            .build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        for i in 0..10_000u16 {
            a.send(&std_frame(0x100, &[i as u8; 8])).unwrap();
        }
        clock.advance(Duration::from_secs(1));
        let n = b.drain(&mut |_| {}).unwrap();
        assert_eq!(n, 7407);
        assert_eq!(bus.frames_in_flight(), 10_000 - 7407);
    }

    #[test]
    fn echo_delivers_to_the_sender_too() {
        let bus = MemBus::builder("echo").echo(true).build();
        let mut a = bus.participant();
        let mut b = bus.participant();
        let f = std_frame(0x5, &[5]);
        a.send(&f).unwrap();
        assert_eq!(a.try_recv().unwrap().unwrap().frame, f);
        assert_eq!(b.try_recv().unwrap().unwrap().frame, f);
    }

    #[test]
    fn full_receive_queue_drops_and_counts() {
        let bus = MemBus::builder("full").capacity(4).build();
        let mut a = bus.participant();
        let b = bus.participant();
        for i in 0..10u8 {
            a.send(&std_frame(0x10, &[i])).unwrap();
        }
        assert_eq!(b.counters().rx_overruns, 6);
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        #[derive(Debug, Clone)]
        struct Send {
            node: usize,
            at_us: u64,
            id: u16,
            len: usize,
        }

        fn sends() -> impl Strategy<Value = Vec<Send>> {
            proptest::collection::vec(
                (0usize..3, 0u64..3000, 0u16..=0x7FF, 0usize..=8).prop_map(
                    |(node, at_us, id, len)| Send {
                        node,
                        at_us,
                        id,
                        len,
                    },
                ),
                1..40,
            )
        }

        proptest! {
            /// The simulated wire against its specification: work-conserving
            /// (never idle while a frame waits), one frame at a time for its
            /// full bit time, each node's frames in order, and when the bus
            /// frees, the lowest id among the nodes' oldest waiting frames wins.
            #[test]
            fn wire_is_work_conserving_serial_ordered_and_arbitrated(mut plan in sends()) {
                plan.sort_by_key(|s| s.at_us);
                let clock = ManualClock::new();
                let bus = MemBus::builder("prop")
                    .bitrate(500_000)
                    .clock(Arc::new(clock.clone()))
                    .build();
                let mut nodes: Vec<MemParticipant> = (0..3).map(|_| bus.participant()).collect();
                let mut rx = bus.participant();
                for (seq, s) in plan.iter().enumerate() {
                    clock.advance_to(Duration::from_micros(s.at_us));
                    let mut data = [0u8; 8];
                    data[..2].copy_from_slice(&(seq as u16).to_le_bytes());
                    let f = Frame::new_standard(s.id, &data[..s.len.max(2)]).unwrap();
                    nodes[s.node].send(&f).unwrap();
                }
                clock.advance(Duration::from_secs(1));
                let mut got = Vec::new();
                rx.drain(&mut |r| {
                    let seq = u16::from_le_bytes([r.frame.data()[0], r.frame.data()[1]]) as usize;
                    got.push((seq, r.timestamp.unwrap()));
                })
                .unwrap();
                prop_assert_eq!(got.len(), plan.len());
                let wire = |seq: usize| {
                    let f = Frame::new_standard(plan[seq].id, &[0; 8][..plan[seq].len.max(2)]).unwrap();
                    bits_time(worst_case_bits(&f).nominal.into(), 500_000)
                };
                let submit = |seq: usize| Duration::from_micros(plan[seq].at_us);
                let mut delivered = vec![false; plan.len()];
                let mut free_at = Duration::ZERO;
                for &(seq, end) in &got {
                    let start = end - wire(seq);
                    // Work-conserving: starts when the bus frees or the
                    // first waiting frame arrives, whichever is later.
                    let first_waiting = (0..plan.len())
                        .filter(|&j| !delivered[j])
                        .map(submit)
                        .min()
                        .unwrap();
                    prop_assert_eq!(start, free_at.max(first_waiting));
                    // Each node's oldest undelivered frame contends.
                    let mut heads = [None::<usize>; 3];
                    for j in 0..plan.len() {
                        let n = plan[j].node;
                        if !delivered[j] && heads[n].is_none() {
                            heads[n] = Some(j);
                        }
                    }
                    prop_assert_eq!(heads[plan[seq].node], Some(seq), "node order broken");
                    for j in heads.into_iter().flatten() {
                        if j != seq && submit(j) <= start {
                            prop_assert!(
                                (plan[seq].id, seq) < (plan[j].id, j),
                                "0x{:X} won over 0x{:X}", plan[seq].id, plan[j].id
                            );
                        }
                    }
                    delivered[seq] = true;
                    free_at = end;
                }
            }
        }
    }
}
