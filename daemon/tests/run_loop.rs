//! The real-time loop thread: overruns are counted and skipped, never caught
//! up by bursting frames; a stop request ends the loop with the actuators
//! disabled.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_daemon::run;
use anguilla_drivers::Bus;
use anguilla_drivers::mem::MemBus;
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{self, Message, NodeSet, Variant};

mod rig;
use rig::Hooked;

#[test]
fn an_overrun_is_counted_and_skipped_not_caught_up() {
    let bus = MemBus::builder("run-loop-overrun").capacity(8192).build();
    let mut listener = bus.participant();
    let stall = Arc::new(AtomicU32::new(0));
    let mut cfg = Config::default();
    cfg.control.rate_hz = 200.0;
    cfg.ipc.prefix = format!("anguilla-test/overrun-{}", std::process::id());
    let stop = Arc::new(AtomicBool::new(false));
    let running = run::spawn(
        cfg,
        // Its send blocks once for 30 ms when asked (a stalled adapter).
        Box::new(Hooked {
            inner: Box::new(bus.participant()),
            hook: {
                let stall = stall.clone();
                move |_: &Frame| {
                    if stall.swap(0, Ordering::SeqCst) > 0 {
                        std::thread::sleep(Duration::from_millis(30));
                    }
                    Ok(())
                }
            },
        }),
        stop.clone(),
    )
    .expect("daemon starts");
    // Count SYNCs as they come; stall once after a few.
    let mut syncs = 0u64;
    let mut max_gap = 0u16;
    let mut last: Option<u16> = None;
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while syncs < 100 && std::time::Instant::now() < deadline {
        if let Ok(Some(r)) = listener.recv(Duration::from_millis(100))
            && let Ok(Message::Sync { counter }) =
                message::decode(&r.frame, Variant::Classic, NodeSet::all())
        {
            syncs += 1;
            if let Some(p) = last {
                max_gap = max_gap.max(counter.wrapping_sub(p));
            }
            last = Some(counter);
            if syncs == 20 {
                stall.store(1, Ordering::SeqCst);
            }
        }
    }
    running.request_stop();
    let report = running.join().expect("clean stop");
    assert!(syncs >= 100, "only {syncs} SYNCs in 20 s");
    assert!(report.overruns >= 1, "the 30 ms stall is an overrun");
    // One SYNC per executed period, counters consecutive: the periods
    // missed during the stall were skipped, not sent late in a burst.
    assert_eq!(max_gap, 1);
    // The last frames were the shutdown's Disable.
    let mut disabled = false;
    while let Ok(Some(r)) = listener.try_recv() {
        if let Ok(Message::Command { command, .. }) =
            message::decode(&r.frame, Variant::Classic, NodeSet::all())
        {
            disabled |= command == message::Command::Disable;
        }
    }
    assert!(disabled, "shutdown disables the actuators");
}
