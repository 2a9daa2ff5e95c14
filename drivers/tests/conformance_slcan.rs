//! The conformance suite on SLCAN: two real serial drivers, each talking
//! over a pseudo-terminal to an SLCAN adapter emulator, the two emulators
//! bridged by an in-process bus.

mod conformance;

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::slcan::codec::Bitrate;
use anguilla_drivers::slcan::emulator::{EmulatorConfig, SlcanEmulator};
use anguilla_drivers::slcan::{SlcanBus, SlcanConfig};
use conformance::{BusFactory, Pair};

static N: AtomicU32 = AtomicU32::new(0);

struct Slcan {
    timestamps: bool,
    fd: bool,
}

impl BusFactory for Slcan {
    fn pair(&self) -> Option<Pair> {
        let name = format!("slcan-conformance-{}", N.fetch_add(1, Ordering::Relaxed));
        let bus = MemBus::builder(&name).build();
        let node_a = bus.participant();
        let id_a = node_a.id();
        let emu_config = EmulatorConfig {
            fd: self.fd,
            ..EmulatorConfig::default()
        };
        let emu_a = SlcanEmulator::on_pty(Box::new(node_a), emu_config).unwrap();
        let emu_b = SlcanEmulator::on_pty(Box::new(bus.participant()), emu_config).unwrap();
        let open = |emu: &SlcanEmulator| {
            let mut c = SlcanConfig::new(emu.path().unwrap(), Bitrate::B1M);
            c.timestamps = self.timestamps;
            c.fd = self.fd;
            c.status_interval = Some(Duration::from_millis(10));
            SlcanBus::open(&c).unwrap()
        };
        let a = open(&emu_a);
        let b = open(&emu_b);
        let emu_a = Arc::new(emu_a);
        let emu_b = Arc::new(emu_b);
        let (qa, qb) = (emu_a.clone(), emu_b.clone());
        let handle = bus.clone();
        Some(Pair {
            a: Box::new(a),
            b: Box::new(b),
            force_state_a: Some(Box::new(move |st| handle.force_state(id_a, st))),
            quiesce: Box::new(move |_| {
                // Everything a's adapter put on the bus has been written to
                // b's pty (and the reverse).
                conformance::wait_until("emulators forwarded everything", || {
                    let (sa, sb) = (qa.stats(), qb.stats());
                    let to = |s: &anguilla_drivers::slcan::emulator::EmulatorStats| {
                        s.frames_to_host.load(Ordering::SeqCst) + s.discarded.load(Ordering::SeqCst)
                    };
                    let from = |s: &anguilla_drivers::slcan::emulator::EmulatorStats| {
                        s.frames_from_host.load(Ordering::SeqCst)
                    };
                    to(sb) >= from(sa) && to(sa) >= from(sb)
                });
            }),
            keep: vec![Box::new(emu_a), Box::new(emu_b), Box::new(bus)],
        })
    }
}

mod plain {
    use super::*;
    crate::conformance_tests!(Slcan {
        timestamps: false,
        fd: false
    });
}

mod timestamps {
    use super::*;
    crate::conformance_tests!(Slcan {
        timestamps: true,
        fd: false
    });
}

/// CANable 2.0-style adapters with the slcan FD extension.
mod fd {
    use super::*;
    crate::conformance_tests!(Slcan {
        timestamps: false,
        fd: true
    });
}
