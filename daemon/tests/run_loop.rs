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

/// The control period of the test (100 Hz) and the stall of the adapter:
/// ten periods.
const PERIOD: Duration = Duration::from_millis(10);
const STALL: Duration = Duration::from_millis(100);

#[test]
fn an_overrun_is_counted_and_skipped_not_caught_up() {
    let bus = MemBus::builder("run-loop-overrun").capacity(8192).build();
    let mut listener = bus.participant();
    let stall = Arc::new(AtomicU32::new(0));
    let mut cfg = Config::default();
    cfg.control.rate_hz = 1.0 / PERIOD.as_secs_f64();
    cfg.ipc.prefix = format!("anguilla-test/overrun-{}", std::process::id());
    let stop = Arc::new(AtomicBool::new(false));
    let running = run::spawn(
        cfg,
        // Its send blocks once for STALL when asked (a stalled adapter).
        Box::new(Hooked {
            inner: Box::new(bus.participant()),
            hook: {
                let stall = stall.clone();
                move |_: &Frame| {
                    if stall.swap(0, Ordering::SeqCst) > 0 {
                        std::thread::sleep(STALL);
                    }
                    Ok(())
                }
            },
        }),
        stop.clone(),
    )
    .expect("daemon starts");
    // Every SYNC's counter and the time the loop sent it (the in-process
    // bus stamps a frame on its clock when it is sent, whenever this thread
    // gets to read it); stall once after a few.
    let mut syncs: Vec<(u16, Duration)> = Vec::new();
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(20));
    while syncs.len() < 100 && !deadline.passed() {
        if let Ok(Some(r)) = listener.recv(Duration::from_millis(100))
            && let Ok(Message::Sync { counter }) =
                message::decode(&r.frame, Variant::Classic, NodeSet::all())
        {
            syncs.push((counter, r.timestamp.expect("the mem bus stamps frames")));
            if syncs.len() == 20 {
                stall.store(1, Ordering::SeqCst);
            }
        }
    }
    running.request_stop();
    let report = running.join().expect("clean stop");
    assert!(syncs.len() >= 100, "only {} SYNCs in 20 s", syncs.len());
    assert!(report.overruns >= 1, "the stall is an overrun");
    // One SYNC per executed period: the counters are consecutive (a burst
    // would give consecutive counters too: the timing below tells them
    // apart).
    for w in syncs.windows(2) {
        assert_eq!(w[1].0, w[0].0.wrapping_add(1), "{w:?}");
    }
    // The stall: the longest gap between two SYNCs, at least STALL long
    // (the SYNC before the stalled send went out before it, the next after).
    let (k, gap) = syncs
        .windows(2)
        .map(|w| w[1].1 - w[0].1)
        .enumerate()
        .max_by_key(|&(_, g)| g)
        .unwrap();
    assert!(
        gap >= STALL,
        "the longest SYNC gap {gap:?} is shorter than the stall"
    );
    let t_s = syncs[k + 1].1; // the stalled period's SYNC
    let after: Vec<Duration> = syncs[k + 1..]
        .windows(2)
        .take(8)
        .map(|w| w[1].1 - w[0].1)
        .collect();
    eprintln!("stall gap {gap:?}, then SYNC gaps {after:?} (period {PERIOD:?})");
    // Skipped, not burst. The period after the stalled one wakes late and
    // runs at once; the loop puts it on the deadline grid (a multiple of
    // PERIOD from the start) within one period before its wake-up, and
    // every later period at least one PERIOD after the one before. No
    // period runs before its deadline, whatever the machine's load, so the
    // SYNCs sent in the 2.5 periods after t_s have deadlines in
    // (t_s - PERIOD, t_s + 2.5 PERIOD]: 4 at most (3 when the loop keeps
    // time). Catching up by bursting would send the ten missed periods'
    // SYNCs back to back there, 12 or so.
    let window = t_s + PERIOD * 5 / 2;
    let soon = syncs
        .iter()
        .filter(|&&(_, t)| t > t_s && t <= window)
        .count();
    assert!(
        soon <= 4,
        "{soon} SYNCs within 2.5 periods of the stall's end: missed periods were sent late \
         (gaps after the stall {after:?})"
    );
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
