//! The conformance suite on the in-process bus, with and without wire time.

mod conformance;

use std::sync::atomic::{AtomicU32, Ordering};

use anguilla_drivers::mem::MemBus;
use conformance::{BusFactory, Pair};

static N: AtomicU32 = AtomicU32::new(0);

fn pair(bitrate: Option<u32>) -> Option<Pair> {
    let name = format!("conformance-{}", N.fetch_add(1, Ordering::Relaxed));
    let mut b = MemBus::builder(&name);
    if let Some(bps) = bitrate {
        b = b.bitrate(bps).data_bitrate(5_000_000);
    }
    let bus = b.build();
    let a = bus.participant();
    let id = a.id();
    let handle = bus.clone();
    Some(Pair {
        quiesce: Box::new(move |_| {
            conformance::wait_until("mem bus idle", || handle.frames_in_flight() == 0)
        }),
        a: Box::new(a),
        b: Box::new(bus.participant()),
        force_state_a: Some(Box::new(move |st| bus.force_state(id, st))),
        keep: Vec::new(),
    })
}

mod instant {
    use super::*;
    struct Mem;
    impl BusFactory for Mem {
        fn pair(&self) -> Option<Pair> {
            pair(None)
        }
    }
    use super::conformance;
    crate::conformance_tests!(Mem);
}

mod wire_time {
    use super::*;
    struct MemWire;
    impl BusFactory for MemWire {
        fn pair(&self) -> Option<Pair> {
            pair(Some(1_000_000))
        }
    }
    use super::conformance;
    crate::conformance_tests!(MemWire);
}
