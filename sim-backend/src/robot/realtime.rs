//! The robot paced to a clock: in the caller's thread, or on its own.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anguilla_drivers::{Bus, Clock};

use crate::node::Nanos;

use super::{MAX_CATCH_UP, RunningSim, SimRobot, Status};

impl SimRobot {
    /// Runs in real time on `clock` until `stop` is set, waiting on the bus
    /// between ticks; calls `observe` after every step.
    pub fn run_realtime(
        &mut self,
        clock: &dyn Clock,
        stop: &AtomicBool,
        mut observe: impl FnMut(&SimRobot),
    ) {
        // Simulated time is the clock's minus what has slipped.
        while !stop.load(Ordering::Acquire) {
            let mut now = clock.now().saturating_sub(self.stats.slipped);
            let behind = now.saturating_sub(self.time());
            if behind > MAX_CATCH_UP {
                self.stats.slipped += behind - MAX_CATCH_UP;
                now = self.time() + MAX_CATCH_UP;
                // Frames stamped before the slip (taken in during the
                // stall) are due now, not a stall's length from now.
                let cap = Nanos::from(now);
                for p in &mut self.pending {
                    p.0 = p.0.min(cap);
                }
            }
            let slip = self.stats.slipped;
            let sim_now = || clock.now().saturating_sub(slip);
            self.step_until(now);
            observe(self);
            let next = Duration::from(self.time + self.tick);
            match self.bus.recv(next.saturating_sub(sim_now())) {
                Ok(Some(r)) => self.accept(r, sim_now()),
                Ok(None) => {}
                Err(_) => {
                    self.stats.recv_errors += 1;
                    // A failing bus (e.g. an unplugged adapter): do not spin.
                    let left = next.saturating_sub(sim_now());
                    std::thread::sleep(left.min(Duration::from_millis(10)));
                }
            }
        }
    }

    /// Runs the robot in real time on its own thread (fails only if the
    /// thread cannot be created).
    pub fn spawn(mut self, clock: Arc<dyn Clock>) -> std::io::Result<RunningSim> {
        let stop = Arc::new(AtomicBool::new(false));
        let truth = Arc::new(Mutex::new(self.truth()));
        let status = Arc::new(Mutex::new(Status::default()));
        let (s, t, st) = (stop.clone(), truth.clone(), status.clone());
        let live = self.live.clone();
        // 1 MiB, not Rust's 2 MiB: in the daemon's process (the built-in
        // robot), a locked daemon locks every thread's whole stack.
        let thread = std::thread::Builder::new()
            .name("anguilla-sim".into())
            .stack_size(1 << 20)
            .spawn(move || {
                let mut last = u64::MAX;
                self.run_realtime(clock.as_ref(), &s, |r| {
                    if r.stats.ticks != last {
                        last = r.stats.ticks;
                        if let Ok(mut g) = t.lock() {
                            r.truth_into(&mut g);
                        }
                        if let Ok(mut g) = st.lock() {
                            *g = Status {
                                states: r.state_counts(),
                                stats: r.stats,
                            };
                        }
                    }
                });
                self
            })?;
        Ok(RunningSim {
            stop,
            truth,
            status,
            live,
            thread: Some(thread),
        })
    }
}
