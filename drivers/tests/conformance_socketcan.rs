//! The conformance suite on SocketCAN, on a virtual CAN interface.
//!
//! Needs a kernel with CAN and a vcan interface (name from `ANGUILLA_VCAN`,
//! default `vcan0`; for the FD tests give it `mtu 72`):
//!
//! ```sh
//! sudo modprobe vcan && sudo ip link add dev vcan0 type vcan
//! sudo ip link set vcan0 mtu 72 && sudo ip link set up vcan0
//! cargo test -p anguilla-drivers --test conformance_socketcan -- --include-ignored
//! ```
//!
//! Those tests are `#[ignore]`d, so `cargo test` counts them as ignored
//! with the reason; `scripts/vcan-vm` runs them with `--include-ignored`
//! (add it to the command above). Run without an interface, each prints
//! why it skips. Tests share the interface, so they take turns (a
//! process-wide lock).

mod conformance;

use std::cell::Cell;
use std::sync::Mutex;

use anguilla_drivers::socketcan::{SocketCanBus, SocketCanConfig};
use anguilla_drivers::{Bus, LinkError, OpenError};
use conformance::{BusFactory, Pair};

static VCAN_LOCK: Mutex<()> = Mutex::new(());

fn interface() -> String {
    std::env::var("ANGUILLA_VCAN").unwrap_or_else(|_| "vcan0".to_owned())
}

/// Opens the test interface (the test fails naming why it cannot).
fn open_vcan() -> Option<SocketCanBus> {
    let mut c = SocketCanConfig::new(&interface());
    c.fd = true;
    match SocketCanBus::open(&c) {
        Ok(b) => Some(b),
        // The tests are ignored (plain `cargo test`); run, they run or fail.
        Err(e @ (OpenError::NoKernelCan { .. } | OpenError::MissingInterface { .. })) => panic!(
            "this test cannot run here: {e} (set ANGUILLA_VCAN to a vcan interface; \
             scripts/vcan-vm runs it for real)"
        ),
        Err(e) => panic!("{e}"),
    }
}

struct Vcan;

impl BusFactory for Vcan {
    fn pair(&self) -> Option<Pair> {
        let guard = VCAN_LOCK.lock().unwrap_or_else(|p| p.into_inner());
        let mut a = open_vcan()?;
        let mut b = open_vcan()?;
        let watcher = std::cell::RefCell::new(open_vcan()?);
        // Frames of an earlier test may still be queued: start clean.
        for bus in [&mut a, &mut b] {
            let _ = bus.drain(&mut |_| {});
        }
        let _ = watcher.borrow_mut().drain(&mut |_| {});
        let seen = Cell::new(0u64);
        Some(Pair {
            a: Box::new(a),
            b: Box::new(b),
            force_state_a: None,
            // A third socket sees every frame in the same kernel delivery
            // pass as `b`: once it has seen all of `a`'s, so has `b`'s queue.
            quiesce: Box::new(move |sender: &dyn Bus| {
                let want = sender.counters().tx;
                conformance::wait_until("watcher socket saw every frame", || {
                    let mut w = watcher.borrow_mut();
                    let _ = w.drain(&mut |_| seen.set(seen.get() + 1));
                    seen.get() >= want
                });
            }),
            keep: vec![Box::new(guard)],
        })
    }
}

// Every test of the suite but bus_off_reported_and_recovered and
// error_passive_reported: a vcan interface has no CAN controller to force
// into bus-off or error-passive (the driver's bus-off on an interface set
// down is tested by no_alloc.rs and tests/tests/vcan_daemon.rs).
crate::conformance_tests!(@each
    [#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]] Vcan;
    roundtrip_classic, roundtrip_fd, ordering_preserved, recv_timeout_returns_none,
    drain_on_empty_bus_returns_at_once, counters_increase, reopen_discards_old_frames,
    no_loopback_to_sender);

#[test]
fn open_errors_name_the_spec_and_the_cause() {
    let spec = "socketcan:anguillanope0";
    let e = anguilla_drivers::open(spec)
        .err()
        .expect("no such interface");
    let msg = e.to_string();
    assert!(msg.contains(spec), "{msg}");
    match e {
        OpenError::NoKernelCan { .. } => assert!(msg.contains("EAFNOSUPPORT"), "{msg}"),
        OpenError::MissingInterface { .. } => assert!(msg.contains("anguillanope0"), "{msg}"),
        other => panic!("unexpected error {other:?}"),
    }
}

/// Frames the kernel drops because a socket's receive queue is full are
/// counted as receive overruns: every frame sent is either received or
/// counted, none is lost unseen.
#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn frames_dropped_by_a_full_socket_queue_are_counted() {
    let _guard = VCAN_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let (Some(mut sender), Some(mut reader)) = (open_vcan(), open_vcan()) else {
        return;
    };
    let _ = reader.drain(&mut |_| {});
    let before = reader.counters();
    // Far more than a default receive buffer holds, sent before reading.
    let frame = anguilla_drivers::Frame::new_standard(0x7F0, &[0xA5; 8]).unwrap();
    let mut sent = 0u64;
    let deadline = anguilla_testkit::Deadline::new(std::time::Duration::from_secs(10));
    while sent < 5000 {
        match sender.send(&frame) {
            Ok(()) => sent += 1,
            // The sender's own queue is full: retry until it has room.
            Err(LinkError::TxQueueFull) => {
                assert!(!deadline.passed(), "sender queue full for 10 s");
                std::thread::yield_now();
            }
            Err(e) => panic!("send: {e}"),
        }
    }
    let mut received = 0u64;
    loop {
        let n = reader.drain(&mut |r| {
            if r.frame.id().raw() == 0x7F0 {
                received += 1;
            }
        });
        if n.unwrap() == 0 {
            break;
        }
    }
    let lost = reader.counters().rx_overruns - before.rx_overruns;
    assert!(
        lost > 0,
        "5000 frames fit the socket's queue? received {received}"
    );
    assert_eq!(
        received + lost,
        sent,
        "received {received}, counted lost {lost}"
    );
}
