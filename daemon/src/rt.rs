//! Real-time setup of the loop thread and absolute-deadline sleeping.
//!
//! Everything here is optional and asked for in the configuration: a
//! SCHED_FIFO priority, a CPU affinity and `mlockall`. When the system
//! refuses one (no CAP_SYS_NICE, an `RLIMIT_RTPRIO` of 0, a CPU that does
//! not exist), the setup says which and why in a [`RtWarning`], and the loop
//! runs anyway: a warning, not a failure.

use core::fmt;

/// What the loop thread should ask of the system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RtRequest {
    /// SCHED_FIFO priority 1..=99, or `None` to stay SCHED_OTHER.
    pub fifo_priority: Option<u8>,
    /// CPU to pin the loop thread to.
    pub cpu: Option<usize>,
    /// Lock all current and future pages in memory.
    pub lock_memory: bool,
}

/// One request the system refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtWarning {
    /// What was asked ("SCHED_FIFO priority", "CPU affinity", "mlockall").
    pub what: &'static str,
    /// The OS error number.
    pub errno: i32,
    /// What to do about it.
    pub hint: &'static str,
}

impl fmt::Display for RtWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let err = std::io::Error::from_raw_os_error(self.errno);
        write!(f, "{} refused ({err}); {}", self.what, self.hint)
    }
}

fn errno() -> i32 {
    std::io::Error::last_os_error().raw_os_error().unwrap_or(0)
}

/// What a process that will lock its memory (`req.lock_memory`) does
/// before it starts its threads: one malloc arena for all of them.
/// glibc gives each new thread an arena of its own, each reserving 64 MiB
/// of address space; `mlockall` counts every reserved page as locked
/// (`VmLck`), though none of it is touched, so a daemon of 8 threads
/// showed 627 MB locked for 39 MB resident. The loop allocates nothing,
/// so the arenas' lock is never its wait. Harmless when threads exist
/// already: arenas made before stay, no new one is made.
pub fn prepare(req: &RtRequest) {
    if req.lock_memory {
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        // SAFETY: mallopt takes two integers; M_ARENA_MAX is a valid option.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 1);
        }
    }
}

/// The memory this process has locked (`VmLck` of /proc/self/status), in
/// bytes; `None` where it cannot be read.
pub fn locked_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmLck:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Applies `req` to the calling thread; returns what was refused (at most
/// one warning per request).
pub fn apply(req: &RtRequest) -> Vec<RtWarning> {
    let mut warnings = Vec::new();
    if req.lock_memory {
        // SAFETY: mlockall takes flags only.
        let r = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        if r != 0 {
            warnings.push(RtWarning {
                what: "mlockall",
                errno: errno(),
                hint: "raise RLIMIT_MEMLOCK (LimitMEMLOCK=infinity in the systemd unit) or run with CAP_IPC_LOCK",
            });
        }
    }
    if let Some(cpu) = req.cpu {
        // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it.
        let r = unsafe {
            let mut set: libc::cpu_set_t = core::mem::zeroed();
            if cpu < libc::CPU_SETSIZE as usize {
                libc::CPU_SET(cpu, &mut set);
                libc::sched_setaffinity(0, core::mem::size_of::<libc::cpu_set_t>(), &set)
            } else {
                -1
            }
        };
        if r != 0 {
            warnings.push(RtWarning {
                what: "CPU affinity",
                errno: if cpu >= libc::CPU_SETSIZE as usize {
                    libc::EINVAL
                } else {
                    errno()
                },
                hint: "name a CPU that exists and is allowed to this process (see `nproc`, cgroups cpusets)",
            });
        }
    }
    if let Some(prio) = req.fifo_priority {
        let param = libc::sched_param {
            sched_priority: prio.clamp(1, 99) as i32,
        };
        // SAFETY: param is a valid sched_param for the calling thread (0).
        let r = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
        if r != 0 {
            warnings.push(RtWarning {
                what: "SCHED_FIFO priority",
                errno: errno(),
                hint: "grant CAP_SYS_NICE or raise RLIMIT_RTPRIO (LimitRTPRIO=99 in the systemd unit); running SCHED_OTHER",
            });
        }
    }
    warnings
}

/// CLOCK_MONOTONIC now, in nanoseconds.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: ts is a valid out-pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (absolute, with
/// `TIMER_ABSTIME`: the sleep does not drift with the work done before it).
/// Returns at once if the deadline has passed; resumes after signals.
pub fn sleep_until_ns(deadline_ns: u64) {
    sleep_until_ns_unless(deadline_ns, || false);
}

/// [`sleep_until_ns`], but a signal handler that makes `stop` true ends
/// the sleep (`clock_nanosleep` is never restarted after a handler);
/// returns `stop()`. A signal landing between the check and the sleep is
/// seen at the deadline.
pub fn sleep_until_ns_unless(deadline_ns: u64, stop: impl Fn() -> bool) -> bool {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    while !stop() {
        // SAFETY: ts is valid; the remaining-time pointer may be null with TIMER_ABSTIME.
        let r = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                core::ptr::null_mut(),
            )
        };
        if r != libc::EINTR {
            break;
        }
    }
    stop()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absolute_sleep_reaches_its_deadline() {
        let start = monotonic_ns();
        let deadline = start + 2_000_000;
        sleep_until_ns(deadline);
        assert!(monotonic_ns() >= deadline);
        // A deadline in the past returns at once (no sleep to a wrapped time).
        sleep_until_ns(start);
    }

    #[test]
    fn refusals_are_warnings_that_name_the_request() {
        // A CPU that cannot exist is refused on any machine.
        let w = apply(&RtRequest {
            cpu: Some(1 << 20),
            ..Default::default()
        });
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].what, "CPU affinity");
        assert!(w[0].to_string().starts_with("CPU affinity refused ("));
        // Nothing asked, nothing refused.
        assert!(apply(&RtRequest::default()).is_empty());
    }

    #[test]
    fn locked_memory_is_read_from_the_kernel() {
        // Nothing locked yet in a test process: VmLck exists and is a
        // number, 0 unless something locked.
        let before = locked_bytes().expect("VmLck in /proc/self/status");
        let page = vec![1u8; 4096];
        // SAFETY: the range is the Vec's own memory.
        let r = unsafe { libc::mlock(page.as_ptr().cast(), page.len()) };
        // One page: within every default RLIMIT_MEMLOCK (64 kB and up).
        anguilla_testkit::require(r == 0, || {
            format!(
                "mlock of one page refused ({}): raise RLIMIT_MEMLOCK",
                std::io::Error::last_os_error()
            )
        });
        assert!(locked_bytes().unwrap() > before);
        // SAFETY: as above.
        unsafe { libc::munlock(page.as_ptr().cast(), page.len()) };
    }
}
