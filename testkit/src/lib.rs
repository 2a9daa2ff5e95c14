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
//! With the feature `lockstep`, the module `lockstep` is the daemon's
//! controller and the simulated robot on one manual clock (the daemon's
//! tests and benches).
#![warn(missing_docs)]

#[cfg(feature = "lockstep")]
pub mod lockstep;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicI32, AtomicU64, Ordering};

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
