//! Test-only helpers shared by the anguilla crates (a dev-dependency,
//! never linked into the daemon): the counting allocator behind every
//! "allocates nothing" test.
//!
//! A test binary installs [`CountingAlloc`] as its global allocator, then
//! either counts the allocator calls of a closure on the calling thread
//! ([`count`]) or those of another thread, named by its kernel id, while it
//! runs ([`watch_thread`], [`watched_calls`]):
//!
//! ```text
//! #[global_allocator]
//! static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;
//!
//! let (_, calls) = anguilla_testkit::count(|| controller.run_period(now, &mut bus));
//! assert_eq!(calls, 0);
//! ```
//!
//! Allocations, reallocations and frees all count: each is an allocator call
//! that may take a lock or a page fault in a real-time period.
//!
//! Every deadline a test sets on a condition is stretched by the
//! machine's patience ([`patience`], `ANGUILLA_TEST_PATIENCE`): wait with
//! [`poll_until`] or [`wait_until`], or bound a loop of your own with a
//! [`Deadline`]; a test that passes waits no longer:
//!
//! ```
//! use std::time::Duration;
//! let mut n = 0;
//! anguilla_testkit::wait_until("the counter at 3", Duration::from_secs(5), || {
//!     n += 1;
//!     n == 3
//! });
//! ```
//!
//! With the feature `lockstep`, the module `lockstep` is the daemon's
//! controller and the simulated robot on one manual clock (the daemon's
//! tests and benches). With the feature `sessions`, the module `sessions`
//! writes recorded sessions by hand.
#![warn(missing_docs)]

#[cfg(feature = "lockstep")]
pub mod guided;
#[cfg(feature = "lockstep")]
pub mod lockstep;
#[cfg(feature = "sessions")]
pub mod sessions;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicI32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How much longer than on a quiet machine a condition may take:
/// `ANGUILLA_TEST_PATIENCE` (1 ..= 20, default 1; CI's run under
/// stress-ng sets 3). Every test deadline of every crate is scaled by it
/// ([`patient`], [`Deadline`], [`poll_until`], [`wait_until`]); a test
/// that passes waits no longer.
pub fn patience() -> f64 {
    std::env::var("ANGUILLA_TEST_PATIENCE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|p| p.is_finite())
        .map_or(1.0, |p| p.clamp(1.0, 20.0))
}

/// `limit` stretched by [`patience`]: the deadline of a condition that
/// takes at most `limit` on a quiet machine.
pub fn patient(limit: Duration) -> Duration {
    limit.mul_f64(patience())
}

/// A deadline [`patient`]`(limit)` from its making, for a loop of one's
/// own (a watchdog, a receive loop).
#[derive(Debug, Clone, Copy)]
pub struct Deadline {
    end: Instant,
    limit: Duration,
}

impl Deadline {
    /// The deadline `patient(limit)` from now.
    pub fn new(limit: Duration) -> Self {
        let limit = patient(limit);
        Self {
            end: Instant::now() + limit,
            limit,
        }
    }

    /// Whether it has passed.
    pub fn passed(&self) -> bool {
        Instant::now() >= self.end
    }

    /// The time left (zero once passed).
    pub fn remaining(&self) -> Duration {
        self.end.saturating_duration_since(Instant::now())
    }

    /// The stretched limit (for messages).
    pub fn limit(&self) -> Duration {
        self.limit
    }
}

/// Polls `f` until it gives a value, for at most [`patient`]`(timeout)`;
/// panics naming `what` otherwise. The first polls come 1 ms apart, then
/// twice as far each time up to 50 ms: a condition that holds at once
/// costs nothing, one that takes seconds little CPU.
pub fn poll_until<T>(what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let deadline = Deadline::new(timeout);
    let mut pause = Duration::from_millis(1);
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(
            !deadline.passed(),
            "{what}: not within {:?}",
            deadline.limit()
        );
        std::thread::sleep(pause.min(deadline.remaining()));
        pause = (pause * 2).min(Duration::from_millis(50));
    }
}

/// [`poll_until`] for a condition without a value.
pub fn wait_until(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    poll_until(what, timeout, || f().then_some(()))
}

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static HERE: Cell<u64> = const { Cell::new(0) };
}

/// The thread whose calls [`watched_calls`] counts (0: none).
static WATCHED: AtomicI32 = AtomicI32::new(0);
static WATCHED_CALLS: AtomicU64 = AtomicU64::new(0);

/// The system allocator, counting its calls (see the crate docs).
pub struct CountingAlloc;

impl CountingAlloc {
    fn note(&self) {
        // try_with: a thread's locals may be gone while it exits.
        let _ = ARMED.try_with(|armed| {
            if armed.get() {
                let _ = HERE.try_with(|n| n.set(n.get() + 1));
            }
        });
        let watched = WATCHED.load(Ordering::Relaxed);
        // gettid is a plain system call: it does not allocate.
        if watched != 0 && watched == unsafe { libc::gettid() } {
            WATCHED_CALLS.fetch_add(1, Ordering::Relaxed);
        }
    }
}

// SAFETY: every call is forwarded unchanged to the system allocator; the
// counting touches only atomics and const-initialized thread-locals, which
// do not allocate.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        self.note();
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        self.note();
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        self.note();
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Runs `f` and returns its result with the number of allocator calls it
/// made on this thread (other threads do not count).
pub fn count<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let before = HERE.with(Cell::get);
    ARMED.with(|a| a.set(true));
    let r = f();
    ARMED.with(|a| a.set(false));
    (r, HERE.with(Cell::get) - before)
}

/// Starts counting the allocator calls of the thread with kernel id `tid`
/// (from `gettid`, or `/proc/self/task`), from zero; 0 stops counting and
/// leaves the count to read.
pub fn watch_thread(tid: i32) {
    if tid != 0 {
        WATCHED_CALLS.store(0, Ordering::SeqCst);
    }
    WATCHED.store(tid, Ordering::SeqCst);
}

/// The allocator calls of the watched thread since [`watch_thread`].
pub fn watched_calls() -> u64 {
    WATCHED_CALLS.load(Ordering::SeqCst)
}

/// A test that needs what a machine may lack (root, a program, a device)
/// is `#[ignore = "needs ...: who runs it"]`, so plain `cargo test` counts
/// it as ignored with that reason; run anyway (`--ignored`, as CI does for
/// the root tests, or `--include-ignored`), it runs or fails: `require`
/// panics naming what is missing. Never an early `return` that reports
/// `ok` for a test that did not run.
pub fn require(present: bool, missing: impl FnOnce() -> String) {
    assert!(present, "this test cannot run here: {}", missing());
}

/// Whether this process runs as root (effective uid 0).
pub fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

/// Whether `program` is an executable file in a directory of `PATH`.
pub fn on_path(program: &str) -> bool {
    use std::os::unix::fs::PermissionsExt as _;
    std::env::var_os("PATH").is_some_and(|p| {
        std::env::split_paths(&p).any(|d| {
            std::fs::metadata(d.join(program))
                .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        })
    })
}

/// Keeps a generated part of a document current: the text of the file at
/// `path` between `<!-- TAG:begin -->` (and its newline) and `<!--
/// TAG:end -->` must be `generated`. With `ANGUILLA_BLESS` set it is
/// written there instead. Panics naming the file and the tag when the part
/// differs or a marker is missing.
pub fn generated_block(path: &std::path::Path, tag: &str, generated: &str) {
    let shown = path.display();
    let doc = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{shown}: {e}"));
    let (begin, end) = (
        format!("<!-- {tag}:begin -->\n"),
        format!("<!-- {tag}:end -->"),
    );
    let (head, rest) = doc
        .split_once(&begin)
        .unwrap_or_else(|| panic!("{shown} has no `<!-- {tag}:begin -->` line"));
    let (current, tail) = rest
        .split_once(&end)
        .unwrap_or_else(|| panic!("{shown} has no `<!-- {tag}:end -->` after its begin"));
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(path, format!("{head}{begin}{generated}{end}{tail}"))
            .unwrap_or_else(|e| panic!("{shown}: {e}"));
        return;
    }
    assert_eq!(
        current, generated,
        "{shown}'s {tag} is out of date: rerun this test with ANGUILLA_BLESS=1"
    );
}

/// Checks that the whole file at `path` is `generated`; with
/// `ANGUILLA_BLESS` set, writes it instead (a generated file that is
/// committed, such as the Debian package's configuration).
pub fn generated_file(path: &std::path::Path, generated: &str) {
    let shown = path.display();
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(path, generated).unwrap_or_else(|e| panic!("{shown}: {e}"));
        return;
    }
    let current = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{shown}: {e}"));
    assert_eq!(
        current, generated,
        "{shown} is out of date: rerun this test with ANGUILLA_BLESS=1"
    );
}

#[cfg(test)]
mod tests {
    #[global_allocator]
    static GLOBAL: super::CountingAlloc = super::CountingAlloc;

    #[test]
    fn counts_what_the_closure_allocates_on_this_thread_only() {
        let (_, none) = super::count(|| 2 + 2);
        assert_eq!(none, 0);
        let (v, some) = super::count(|| vec![1u8; 100]);
        assert!(some >= 1 && v.len() == 100);
        let (_, freed) = super::count(|| drop(v));
        assert_eq!(freed, 1, "a free is an allocator call too");
        let (_, other) = super::count(|| {
            std::thread::scope(|s| {
                s.spawn(|| vec![0u8; 10]).join().unwrap();
            })
        });
        // Spawning allocates here; the other thread's vector does not count.
        assert!(other >= 1);
    }

    #[test]
    fn counts_a_watched_thread() {
        let (tx, rx) = std::sync::mpsc::channel();
        let (go_tx, go_rx) = std::sync::mpsc::channel::<()>();
        let t = std::thread::spawn(move || {
            tx.send(unsafe { libc::gettid() }).unwrap();
            go_rx.recv().unwrap();
            let v = std::hint::black_box(vec![0u8; 64]);
            v.len()
        });
        let tid = rx.recv().unwrap();
        super::watch_thread(tid);
        go_tx.send(()).unwrap();
        assert_eq!(t.join().unwrap(), 64);
        super::watch_thread(0);
        assert!(super::watched_calls() >= 2, "alloc and free of the vector");
    }
}

#[cfg(test)]
mod patience_tests {
    use super::*;

    /// The one place every crate's deadlines come from: the patience
    /// stretches them, within 1 ..= 20, and a condition that holds ends
    /// the wait at once. (The only test here that sets the variable.)
    #[test]
    fn the_patience_stretches_every_deadline() {
        let limit = Duration::from_millis(100);
        for (set, factor) in [
            (None, 1.0),
            (Some("3"), 3.0),
            (Some("0.5"), 1.0),
            (Some("99"), 20.0),
            (Some("x"), 1.0),
        ] {
            // SAFETY: no other test of this crate reads or writes the
            // environment.
            unsafe {
                match set {
                    Some(v) => std::env::set_var("ANGUILLA_TEST_PATIENCE", v),
                    None => std::env::remove_var("ANGUILLA_TEST_PATIENCE"),
                }
            }
            assert_eq!(patience(), factor, "{set:?}");
            assert_eq!(patient(limit), limit.mul_f64(factor), "{set:?}");
            assert_eq!(Deadline::new(limit).limit(), limit.mul_f64(factor));
        }
        // With patience 20, a 100 ms wait lasts 2 s: the condition turns
        // true after 0.5 s, past the unstretched limit.
        // SAFETY: as above.
        unsafe { std::env::set_var("ANGUILLA_TEST_PATIENCE", "20") };
        let start = Instant::now();
        wait_until("half a second gone", limit, || {
            start.elapsed() >= Duration::from_millis(500)
        });
        let failed = std::panic::catch_unwind(|| {
            // SAFETY: as above.
            unsafe { std::env::set_var("ANGUILLA_TEST_PATIENCE", "1") };
            wait_until("never", Duration::from_millis(20), || false)
        });
        let why = failed.expect_err("a condition that never holds fails");
        let why = why.downcast_ref::<String>().cloned().unwrap_or_default();
        assert!(why.contains("never: not within 20ms"), "{why}");
        // SAFETY: as above.
        unsafe { std::env::remove_var("ANGUILLA_TEST_PATIENCE") };
    }
}
