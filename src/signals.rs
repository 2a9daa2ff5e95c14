//! The one stop request of every long-running command (`run`, `sim`,
//! `dump`, `teleop`, `joy`, `monitor`, `ctl`): SIGINT, SIGTERM and SIGHUP
//! each set a flag the command's loop polls and then stop it the way it
//! stops on its own (the daemon smoothly, actuators disabled, the recording
//! ended). SIGHUP is not a reload: there is no configuration reload; restart
//! to apply one.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);
/// The last stop signal's number (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(sig: libc::c_int) {
    // Inside a call into iceoryx2 that may block (making a node, opening
    // the services), nothing polls the flag: end now, as the default
    // action would (anguilla_ipc::guard::bounded).
    if anguilla_ipc::guard::opening() {
        // SAFETY: _exit is async-signal-safe.
        unsafe { libc::_exit(128 + sig) };
    }
    anguilla_ipc::guard::stop_requested(sig);
    SIGNAL.store(sig, Ordering::SeqCst);
    REQUESTED.store(true, Ordering::SeqCst);
}

/// A stop signal's name.
pub fn name(sig: i32) -> &'static str {
    match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        libc::SIGHUP => "SIGHUP",
        _ => "a signal",
    }
}

/// The stop signal received, if any (its number).
pub fn received() -> Option<i32> {
    Some(SIGNAL.load(Ordering::SeqCst)).filter(|&s| s != 0)
}

/// Installs the handler for SIGINT, SIGTERM and SIGHUP.
pub fn install() {
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: the handler only loads and stores atomics and may call
    // _exit (async-signal-safe).
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

/// A `running` test for a long-running command: no stop signal yet, and
/// less than `duration` seconds (if any) since this call.
#[cfg(any(feature = "remote", feature = "foxglove"))]
pub fn running_for(duration: Option<f64>) -> impl Fn() -> bool {
    let start = std::time::Instant::now();
    move || !requested() && duration.is_none_or(|d| start.elapsed().as_secs_f64() < d)
}

/// Calls `open` until it succeeds: again every half second (absolute
/// deadlines; a stop signal cuts the wait) while its error is one `waiting`
/// accepts (no daemon yet) and `running` holds, saying once on stderr that
/// `tool` waits. Any other error, or a stop, returns the error.
#[cfg(any(feature = "remote", feature = "foxglove"))]
pub fn open_when_up<T, E: std::fmt::Display>(
    tool: &str,
    running: &dyn Fn() -> bool,
    mut open: impl FnMut() -> Result<T, E>,
    waiting: impl Fn(&E) -> bool,
) -> Result<T, E> {
    let mut next = anguilla_daemon::rt::monotonic_ns();
    let mut said = false;
    loop {
        match open() {
            Ok(v) => return Ok(v),
            Err(e) if running() && waiting(&e) => {
                if !said {
                    eprintln!("{tool}: waiting for the daemon ({e})");
                    said = true;
                }
                next += 500_000_000;
                sleep_until_ns(next);
            }
            Err(e) => return Err(e),
        }
    }
}
