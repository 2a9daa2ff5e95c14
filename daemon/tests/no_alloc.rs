//! A control period allocates nothing: a counting global allocator watches
//! every `Controller::run_period` call (and the command path) while the rig
//! swims, turns, dives and stops. The simulated nodes' half of each period
//! is outside the counted region (it is not daemon code).

mod rig;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use anguilla_daemon::config::Config;
use anguilla_daemon::supervisor::{Command, Mode, SwimParams};
use rig::Rig;

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // try_with: the thread-locals may be gone while a thread exits.
        let _ = COUNTING.try_with(|c| {
            if c.get() {
                let _ = COUNT.try_with(|n| n.set(n.get() + 1));
            }
        });
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = COUNTING.try_with(|c| {
            if c.get() {
                let _ = COUNT.try_with(|n| n.set(n.get() + 1));
            }
        });
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn counted<T>(f: impl FnOnce() -> T) -> T {
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    r
}

#[test]
fn a_control_period_allocates_nothing() {
    for fd in [false, true] {
        let mut cfg = Config::default();
        cfg.bus.fd = fd;
        let mut r = Rig::new(if fd { "no-alloc-fd" } else { "no-alloc" }, &cfg);
        // Recording on: the tap's bounded channel must not allocate either.
        let (tap, records) = crossbeam_channel::bounded(1 << 16);
        r.ctl.set_tap(tap);
        // Warm-up outside the count: boot, control, enable.
        r.run_for(0.1);
        r.command(1, Command::TakeControl);
        r.command(1, Command::Enable);
        r.run_for(0.3);
        assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
        COUNT.with(|n| n.set(0));
        let phases = [
            (0.0, 0.0, 1.0),  // swim
            (1.5, 0.0, 1.0),  // turn
            (0.0, 0.8, 1.0),  // dive
            (0.0, 0.0, -1.0), // stop
        ];
        for (turn, pitch, amplitude) in phases {
            let cmd = if amplitude < 0.0 {
                Command::Stop
            } else {
                Command::Swim(SwimParams {
                    amplitude,
                    frequency: 1.0,
                    turn,
                    pitch,
                })
            };
            counted(|| r.command(1, cmd));
            for i in 0..200 {
                counted(|| r.ctl.run_period(r.now, &mut r.host));
                r.nodes_step();
                records.try_iter().for_each(drop);
                if i % 20 == 0 {
                    counted(|| r.command(1, Command::KeepAlive));
                }
            }
        }
        // A refused command formats its reason without allocating too.
        counted(|| r.command(2, Command::Enable));
        assert!(r.ctl.counters().refused >= 1);
        let n = COUNT.with(|n| n.get());
        assert_eq!(n, 0, "{n} allocations in 800 control periods (fd = {fd})");
        assert!(r.ctl.snapshot().sequence > 800);
        assert_eq!(r.ctl.tap_dropped(), 0);
    }
}
