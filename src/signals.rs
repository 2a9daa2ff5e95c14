//! The one stop request of every long-running command (`run`, `sim`,
//! `dump`, `teleop`, `joy`, `monitor`, `ctl`): SIGINT, SIGTERM and SIGHUP
//! each set a flag the command's loop polls and then stop it the way it
//! stops on its own (the daemon smoothly, actuators disabled, the recording
//! ended). SIGHUP is not a reload: there is no configuration reload; restart
//! to apply one.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Installs the handler for SIGINT, SIGTERM and SIGHUP.
pub fn install() {
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: the handler only stores to an atomic (async-signal-safe).
    unsafe {
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
        libc::signal(libc::SIGHUP, handler);
    }
}

/// Whether a stop was requested by a signal.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (absolute, as
/// `anguilla_daemon::rt::monotonic_ns` counts), or until a stop signal
/// arrives and interrupts the sleep. Returns whether a stop was requested.
pub fn sleep_until_ns(deadline_ns: u64) -> bool {
    anguilla_daemon::rt::sleep_until_ns_unless(deadline_ns, requested)
}
