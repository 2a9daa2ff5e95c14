//! The conformance suite on SocketCAN, on a virtual CAN interface.
//!
//! Needs a kernel with CAN and a vcan interface (name from `ANGUILLA_VCAN`,
//! default `vcan0`; for the FD tests give it `mtu 72`):
//!
//! ```sh
//! sudo modprobe vcan && sudo ip link add dev vcan0 type vcan
//! sudo ip link set vcan0 mtu 72 && sudo ip link set up vcan0
//! cargo test -p anguilla-drivers --test conformance_socketcan
//! ```
//!
//! Without them every test prints why it skips and passes. Tests share the
//! interface, so they take turns (a process-wide lock).

mod conformance;

use std::cell::Cell;
use std::sync::Mutex;

use anguilla_drivers::socketcan::{SocketCanBus, SocketCanConfig};
use anguilla_drivers::{Bus, BusError};
use conformance::{BusFactory, Pair};

static VCAN_LOCK: Mutex<()> = Mutex::new(());

fn interface() -> String {
    std::env::var("ANGUILLA_VCAN").unwrap_or_else(|_| "vcan0".to_owned())
}

/// Opens the test interface, or prints why not and returns `None`.
fn open_vcan() -> Option<SocketCanBus> {
    let mut c = SocketCanConfig::new(&interface());
    c.fd = true;
    match SocketCanBus::open(&c) {
        Ok(b) => Some(b),
        Err(e @ (BusError::NoKernelCan { .. } | BusError::MissingInterface { .. })) => {
            eprintln!("skipping: {e} (set ANGUILLA_VCAN to a vcan interface to run)");
            None
        }
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

crate::conformance_tests!(Vcan);

#[test]
fn open_errors_name_the_spec_and_the_cause() {
    let spec = "socketcan:anguillanope0";
    let e = anguilla_drivers::open(spec)
        .err()
        .expect("no such interface");
    let msg = e.to_string();
    assert!(msg.contains(spec), "{msg}");
    match e {
        BusError::NoKernelCan { .. } => assert!(msg.contains("EAFNOSUPPORT"), "{msg}"),
        BusError::MissingInterface { .. } => assert!(msg.contains("anguillanope0"), "{msg}"),
        other => panic!("unexpected error {other:?}"),
    }
}
