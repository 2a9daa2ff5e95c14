//! The bus conformance suite: every test of the [`Bus`] contract, written
//! once as a generic function over a [`BusFactory`] and instantiated per
//! bus by [`conformance_tests!`] (in-process bus, SLCAN over a pty,
//! SocketCAN on vcan) — the iceoryx2 conformance-test pattern.
#![allow(dead_code)]

use std::any::Any;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anguilla_drivers::{Bus, BusState, Frame, LinkError, Received, TimestampBase};
use anguilla_protocol::frame::Id;

/// Generous bound for a frame to cross any bus under test, on a loaded
/// 2-core machine, stretched by `ANGUILLA_TEST_PATIENCE`
/// (anguilla_testkit); only ever a failure bound, never a speed claim.
pub fn patience() -> Duration {
    anguilla_testkit::patient(Duration::from_secs(5))
}
/// Watchdog for a whole test (times the patience too).
pub fn watchdog_limit() -> Duration {
    anguilla_testkit::patient(Duration::from_secs(60))
}

/// See [`Pair::force_state_a`].
pub type ForceState = Box<dyn Fn(BusState)>;

/// See [`Pair::quiesce`].
pub type Quiesce = Box<dyn Fn(&dyn Bus)>;

/// Two nodes on one fresh bus, and what keeps the bus alive.
pub struct Pair {
    /// First node.
    pub a: Box<dyn Bus>,
    /// Second node.
    pub b: Box<dyn Bus>,
    /// Forces node `a`'s controller state, if this bus can simulate it.
    pub force_state_a: Option<ForceState>,
    /// Returns once every frame sent so far by the node given (`a`) has
    /// reached the other node's side (waiting on a condition, with a timeout).
    pub quiesce: Quiesce,
    /// Dropped after the nodes (emulators, locks, pty handles).
    pub keep: Vec<Box<dyn Any>>,
}

/// Makes fresh pairs of nodes of one kind of bus.
pub trait BusFactory {
    /// A fresh bus with two nodes, or `None` (after printing why) when this
    /// machine cannot run the bus: the test then fails.
    fn pair(&self) -> Option<Pair>;
}

/// Runs `f` on a thread and fails if it takes longer than [`watchdog_limit()`].
pub fn watchdog<F: FnOnce() + Send + 'static>(name: &str, f: F) {
    let (tx, rx) = mpsc::channel();
    let t = std::thread::spawn(move || {
        f();
        let _ = tx.send(());
    });
    match rx.recv_timeout(watchdog_limit()) {
        Ok(()) => t.join().unwrap(),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            // The test panicked: re-raise its panic.
            if let Err(p) = t.join() {
                std::panic::resume_unwind(p)
            }
        }
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{name}: watchdog expired after {:?}", watchdog_limit())
        }
    }
}

/// Instantiates every conformance test for a factory expression.
#[macro_export]
/// Attributes after the factory (`conformance_tests!(F, #[ignore = "why"])`)
/// go on every test.
macro_rules! conformance_tests {
    ($factory:expr $(, #[$attr:meta])* $(,)?) => {
        $crate::conformance_tests!(@each [$(#[$attr])*] $factory;
            roundtrip_classic, roundtrip_fd, ordering_preserved, recv_timeout_returns_none,
            drain_on_empty_bus_returns_at_once, counters_increase, reopen_discards_old_frames,
            bus_off_reported_and_recovered, error_passive_reported, no_loopback_to_sender);
    };
    (@each $attrs:tt $factory:expr; $($name:ident),*) => {
        $( $crate::conformance_tests!(@one $attrs $factory; $name); )*
    };
    (@one [$(#[$attr:meta])*] $factory:expr; $name:ident) => {
        #[test]
        $(#[$attr])*
        fn $name() {
            conformance::watchdog(stringify!($name), || {
                // No pair: this machine cannot run the bus, and the test
                // fails saying so (never `ok` without running).
                let pair = conformance::BusFactory::pair(&$factory)
                    .expect("this test cannot run here: the bus factory made no pair");
                conformance::$name(pair);
            });
        }
    };
}

fn std_id(raw: u16) -> Id {
    Id::standard(raw).unwrap()
}

/// Polls `cond` until it holds, failing after [`patience`].
pub fn wait_until(what: &str, mut cond: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !cond() {
        assert!(t0.elapsed() < patience(), "condition never held: {what}");
        std::thread::yield_now();
    }
}

/// Receives one frame within [`patience`] or fails.
pub fn expect_frame(bus: &mut dyn Bus, what: &str) -> Received {
    let t0 = Instant::now();
    while t0.elapsed() < patience() {
        if let Some(r) = bus.recv(Duration::from_millis(100)).unwrap() {
            return r;
        }
    }
    panic!("{}: no frame within {:?} ({what})", bus.spec(), patience());
}

fn check_timestamp(bus: &dyn Bus, r: &Received) {
    match bus.capabilities().timestamps {
        TimestampBase::None => assert!(r.timestamp.is_none()),
        TimestampBase::AdapterMillis => {
            assert!(r.timestamp.unwrap() < Duration::from_secs(60));
        }
        TimestampBase::BusClock | TimestampBase::UnixEpoch => {
            assert!(r.timestamp.is_some(), "{}: missing timestamp", bus.spec())
        }
    }
}

/// Standard, extended, remote, empty and full frames arrive unchanged.
pub fn roundtrip_classic(mut p: Pair) {
    let frames = [
        Frame::new(std_id(0x123), &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
        Frame::new(std_id(0x7FF), &[0xFF; 8]).unwrap(),
        Frame::new(std_id(0x000), &[]).unwrap(),
        Frame::new(
            Id::extended(0x1FFF_FFFF).unwrap(),
            &[1, 2, 3, 4, 5, 6, 7, 8],
        )
        .unwrap(),
        Frame::new(Id::extended(0x0000_0001).unwrap(), &[0x55]).unwrap(),
        Frame::new_remote(std_id(0x321), 8).unwrap(),
        Frame::new_remote(Id::extended(0x0ABC_DEF0).unwrap(), 0).unwrap(),
    ];
    for f in &frames {
        p.a.send(f).unwrap();
        let r = expect_frame(p.b.as_mut(), "roundtrip");
        assert_eq!(r.frame, *f, "{}", p.a.spec());
        check_timestamp(p.b.as_ref(), &r);
    }
}

/// CAN FD frames of every length class arrive unchanged; a bus that does
/// not carry them (its capabilities say so) refuses one as unsupported and
/// sends nothing.
pub fn roundtrip_fd(mut p: Pair) {
    if !p.a.capabilities().fd {
        let data: Vec<u8> = (0..64u8).collect();
        let f = Frame::new_fd(std_id(0x10), &data[..12], false).unwrap();
        let r = p.a.send(&f);
        assert!(
            matches!(r, Err(LinkError::Unsupported(_))),
            "{}: a classic bus took an FD frame: {r:?}",
            p.a.spec()
        );
        assert!(
            p.b.recv(Duration::from_millis(50)).unwrap().is_none(),
            "{}: the refused FD frame arrived",
            p.a.spec()
        );
        return;
    }
    let data: Vec<u8> = (0..64u8).collect();
    for (len, brs, id) in [
        (12, false, std_id(0x10)),
        (64, true, std_id(0x11)),
        (8, true, Id::extended(0x1234_5678).unwrap()),
        (0, false, std_id(0x12)),
    ] {
        let f = Frame::new_fd(id, &data[..len], brs).unwrap();
        match p.a.send(&f) {
            Err(LinkError::Unsupported(what)) => {
                panic!("{}: an FD bus refuses {what}", p.a.spec())
            }
            r => r.unwrap(),
        }
        assert_eq!(expect_frame(p.b.as_mut(), "fd").frame, f);
    }
}

/// A burst from one node arrives complete and in order.
pub fn ordering_preserved(mut p: Pair) {
    const N: u16 = 64;
    for i in 0..N {
        p.a.send(&Frame::new(std_id(0x100 + (i % 7)), &i.to_le_bytes()).unwrap())
            .unwrap();
    }
    for i in 0..N {
        let r = expect_frame(p.b.as_mut(), "burst");
        assert_eq!(r.frame.data(), i.to_le_bytes(), "frame {i} out of order");
    }
}

/// A receive timeout is `Ok(None)`, after (about) the timeout.
pub fn recv_timeout_returns_none(mut p: Pair) {
    let timeout = Duration::from_millis(50);
    let t0 = Instant::now();
    assert!(p.b.recv(timeout).unwrap().is_none());
    // Lower bound only; 1 ms of slack for millisecond-granular poll(2).
    assert!(
        t0.elapsed() + Duration::from_millis(1) >= timeout,
        "{:?}",
        t0.elapsed()
    );
}

/// `drain` and `try_recv` on a quiet bus return nothing (the watchdog
/// catches a blocking implementation).
pub fn drain_on_empty_bus_returns_at_once(mut p: Pair) {
    let mut n = 0;
    assert_eq!(p.b.drain(&mut |_| n += 1).unwrap(), 0);
    assert_eq!(n, 0);
    assert!(p.b.try_recv().unwrap().is_none());
}

/// Counters count what was sent and received.
pub fn counters_increase(mut p: Pair) {
    let (tx0, rx0) = (p.a.counters().tx, p.b.counters().rx);
    for i in 0..3u8 {
        p.a.send(&Frame::new(std_id(0x42), &[i]).unwrap()).unwrap();
    }
    let mut got = 0;
    while got < 3 {
        expect_frame(p.b.as_mut(), "counters");
        got += 1;
    }
    assert_eq!(p.a.counters().tx, tx0 + 3);
    assert_eq!(p.b.counters().rx, rx0 + 3);
}

/// Frames waiting for a node when it reopens are never delivered after.
pub fn reopen_discards_old_frames(mut p: Pair) {
    let first = Frame::new(std_id(0x201), &[1]).unwrap();
    let stale = Frame::new(std_id(0x202), &[2]).unwrap();
    let fresh = Frame::new(std_id(0x203), &[3]).unwrap();
    p.a.send(&first).unwrap();
    p.a.send(&stale).unwrap();
    assert_eq!(expect_frame(p.b.as_mut(), "first").frame, first);
    // `stale` is now waiting in b's receive path (queue, pty, socket).
    (p.quiesce)(p.a.as_ref());
    p.b.reopen().unwrap();
    assert_eq!(p.b.state(), BusState::ErrorActive);
    p.a.send(&fresh).unwrap();
    assert_eq!(
        expect_frame(p.b.as_mut(), "after reopen").frame,
        fresh,
        "{}: a frame from before the reopen came after it",
        p.b.spec()
    );
    assert!(p.b.counters().reopens >= 1);
}

/// A node forced bus-off reports it, and works again after reopening.
pub fn bus_off_reported_and_recovered(mut p: Pair) {
    let Some(force) = p.force_state_a.take() else {
        panic!(
            "{} cannot simulate bus-off: leave this test out of its instantiation \
             (conformance_tests!(@each ...), naming the tests it runs)",
            p.a.spec()
        );
    };
    force(BusState::BusOff);
    let t0 = Instant::now();
    while p.a.counters().bus_off_count == 0 {
        assert!(
            t0.elapsed() < patience(),
            "{}: bus-off not reported",
            p.a.spec()
        );
        let _ = p.a.recv(Duration::from_millis(10));
    }
    p.a.reopen().unwrap();
    let f = Frame::new(std_id(0x0AA), &[0xAA]).unwrap();
    p.a.send(&f).unwrap();
    assert_eq!(expect_frame(p.b.as_mut(), "after recovery").frame, f);
    assert_ne!(p.a.state(), BusState::BusOff);
}

/// Error-passive is reported, and so is the return to error-active.
pub fn error_passive_reported(mut p: Pair) {
    let Some(force) = p.force_state_a.take() else {
        panic!(
            "{} cannot simulate error-passive: leave this test out of its instantiation \
             (conformance_tests!(@each ...), naming the tests it runs)",
            p.a.spec()
        );
    };
    for state in [BusState::ErrorPassive, BusState::ErrorActive] {
        force(state);
        let t0 = Instant::now();
        while p.a.state() != state {
            assert!(
                t0.elapsed() < patience(),
                "{}: {state:?} not reported",
                p.a.spec()
            );
            let _ = p.a.recv(Duration::from_millis(10));
        }
    }
    // An error-passive node still sends.
    let f = Frame::new(std_id(0x0AB), &[0xAB]).unwrap();
    force(BusState::ErrorPassive);
    p.a.send(&f).unwrap();
    assert_eq!(
        expect_frame(p.b.as_mut(), "from an error-passive node").frame,
        f
    );
}

/// Without echo, a sender does not receive its own frames.
pub fn no_loopback_to_sender(mut p: Pair) {
    let mine = Frame::new(std_id(0x300), &[9]).unwrap();
    let theirs = Frame::new(std_id(0x301), &[8]).unwrap();
    p.a.send(&mine).unwrap();
    assert_eq!(expect_frame(p.b.as_mut(), "mine").frame, mine);
    p.b.send(&theirs).unwrap();
    // The first frame `a` sees is `b`'s, not its own.
    assert_eq!(expect_frame(p.a.as_mut(), "theirs").frame, theirs);
}
