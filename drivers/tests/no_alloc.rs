//! The control period's bus calls allocate nothing after setup: a counting
//! global allocator (counting only on the test's thread) watches `send`,
//! `try_recv`, `drain`, `state` and `counters` (copper-rs style).

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::slcan::codec::Bitrate;
use anguilla_drivers::slcan::emulator::{EmulatorConfig, SlcanEmulator};
use anguilla_drivers::slcan::{SlcanBus, SlcanConfig};
use anguilla_drivers::{Bus, Frame, ManualClock};

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

/// Allocator calls made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> u64 {
    anguilla_testkit::count(f).1
}

/// One control period: send a setpoint, drain feedback, read state.
fn period(tx: &mut dyn Bus, rx: &mut dyn Bus, i: u32, sum: &mut u64) {
    let f = Frame::new_standard(0x100 + (i % 16) as u16, &i.to_le_bytes()).unwrap();
    tx.send(&f).unwrap();
    rx.drain(&mut |r| *sum += u64::from(r.frame.data()[0]))
        .unwrap();
    let _ = tx.try_recv().unwrap();
    let _ = (rx.state(), rx.counters(), tx.counters());
}

#[test]
fn control_period_allocates_nothing() {
    // The counting allocator sanity check: it does see allocations.
    assert!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 64]))) > 0);

    // In-process bus, no wire time.
    let bus = MemBus::builder("no-alloc").capacity(64).build();
    let (mut a, mut b) = (bus.participant(), bus.participant());
    let mut sum = 0;
    period(&mut a, &mut b, 0, &mut sum);
    let n = allocations_in(|| {
        for i in 0..1000 {
            period(&mut a, &mut b, i, &mut sum);
        }
    });
    assert_eq!(n, 0, "mem bus: {n} allocations in 1000 periods");
    assert!(sum > 0);

    // In-process bus with wire time on a manual clock.
    let clock = ManualClock::new();
    let bus = MemBus::builder("no-alloc-wire")
        .bitrate(1_000_000)
        .clock(Arc::new(clock.clone()))
        .capacity(64)
        .build();
    let (mut a, mut b) = (bus.participant(), bus.participant());
    let n = allocations_in(|| {
        for i in 0..1000 {
            period(&mut a, &mut b, i, &mut sum);
            clock.advance(Duration::from_millis(1));
        }
    });
    assert_eq!(n, 0, "mem bus with wire time: {n} allocations");
    assert_eq!(b.counters().rx, 999, "all but the last frame delivered");

    // SLCAN driver over a pty (the emulator thread is not counted).
    let bus = MemBus::builder("no-alloc-slcan").build();
    let mut peer = bus.participant();
    let emu =
        SlcanEmulator::on_pty(Box::new(bus.participant()), EmulatorConfig::default()).unwrap();
    let mut c = SlcanConfig::new(emu.path().unwrap(), Bitrate::B1M);
    c.status_interval = Some(Duration::from_millis(1));
    let mut drv = SlcanBus::open(&c).unwrap();
    period(&mut drv, &mut peer, 0, &mut sum);
    let n = allocations_in(|| {
        for i in 0..200 {
            period(&mut drv, &mut peer, i, &mut sum);
            period(&mut peer, &mut drv, i, &mut sum);
        }
    });
    assert_eq!(n, 0, "SLCAN driver: {n} allocations");
    // Also a blocking receive with a frame waiting.
    let t0 = anguilla_testkit::Deadline::new(Duration::from_secs(5));
    let n = allocations_in(|| {
        peer.send(&Frame::new_standard(0x7, &[7]).unwrap()).unwrap();
        while drv.recv(Duration::from_millis(10)).unwrap().is_none() {
            assert!(!t0.passed());
        }
    });
    assert_eq!(n, 0, "SLCAN recv: {n} allocations");
    drop(drv);
    drop(emu);
}

/// SocketCAN: the periods while the interface is down (bus-off) and the
/// automatic reconnection once it is up again allocate nothing. Needs a
/// vcan interface (`ANGUILLA_VCAN`, default vcan0) and root to set it down
/// and up: `scripts/vcan-vm` runs it in its VM.
#[test]
#[ignore = "needs a vcan interface (SocketCAN): scripts/vcan-vm runs it"]
fn socketcan_bus_off_and_recovery_allocate_nothing() {
    use anguilla_drivers::BusState;
    use anguilla_drivers::socketcan::{SocketCanBus, SocketCanConfig};
    let dev = std::env::var("ANGUILLA_VCAN").unwrap_or_else(|_| "vcan0".to_owned());
    let mut bus = match SocketCanBus::open(&SocketCanConfig::new(&dev)) {
        Ok(b) => b,
        Err(e) => panic!(
            "this test cannot run here: socketcan:{dev} cannot be opened ({e}; scripts/vcan-vm \
             runs it for real)"
        ),
    };
    anguilla_testkit::require(anguilla_testkit::is_root(), || {
        format!("setting {dev} down and up needs root")
    });
    let link = |how: &str| {
        let st = std::process::Command::new("ip")
            .args(["link", "set", &dev, how])
            .status()
            .expect("ip runs");
        assert!(st.success(), "ip link set {dev} {how}");
    };
    let f = Frame::new_standard(0x123, &[1, 2]).unwrap();
    bus.send(&f).unwrap();
    link("down");
    let mut sum = 0u64;
    let mut period = |bus: &mut SocketCanBus| {
        let _ = bus.send(&f);
        let _ = bus.drain(&mut |r| sum += u64::from(r.frame.data()[0]));
        let _ = bus.try_recv();
        let _ = bus.flush_tx();
        sum += bus.counters().tx + bus.state() as u64;
    };
    // The first send or read sees ENETDOWN: bus-off.
    let t0 = anguilla_testkit::Deadline::new(Duration::from_secs(5));
    while bus.state() != BusState::BusOff {
        period(&mut bus);
        assert!(!t0.passed(), "no bus-off while {dev} is down");
    }
    let n = allocations_in(|| {
        // A hundred periods, each waiting on the bus as a daemon would
        // (a bus-off `recv` parks until its timeout).
        for _ in 0..100 {
            period(&mut bus);
            let _ = bus.recv(Duration::from_millis(1));
        }
    });
    link("up");
    assert_eq!(n, 0, "{n} allocations while {dev} is down");
    assert_eq!(
        bus.counters().bus_off_count,
        1,
        "one bus-off for one interface down"
    );
    let t0 = anguilla_testkit::Deadline::new(Duration::from_secs(5));
    let n = allocations_in(|| {
        while bus.state() != BusState::ErrorActive || bus.send(&f).is_err() {
            period(&mut bus);
            assert!(!t0.passed(), "no recovery");
        }
    });
    assert_eq!(n, 0, "{n} allocations while reconnecting");
    assert_eq!(bus.counters().reopens, 1);
}
