//! `[realtime]`: what the loop thread asks of the OS.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, range};

/// `[realtime]`: what the loop thread asks of the OS.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RealtimeConfig {
    /// SCHED_FIFO priority (1..=99); 0 keeps the normal scheduler.
    pub fifo_priority: u8,
    /// CPU to pin the loop thread to; -1 for none.
    pub cpu: i32,
    /// Lock the process's memory (mlockall).
    pub lock_memory: bool,
}

impl Default for RealtimeConfig {
    fn default() -> Self {
        Self {
            fifo_priority: 0,
            cpu: -1,
            lock_memory: false,
        }
    }
}

impl RealtimeConfig {
    /// Checks `[realtime]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let rt = self;
        range(
            "realtime.fifo-priority",
            rt.fifo_priority as f64,
            0.0,
            99.0,
            "0 ..= 99",
        )?;
        range(
            "realtime.cpu",
            rt.cpu as f64,
            -1.0,
            1023.0,
            "-1 (none) ..= 1023",
        )?;
        Ok(())
    }
}

/// `[realtime]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &RealtimeConfig, w: &mut dyn FnMut(String)) {
    w("[realtime]".into());
    w("# SCHED_FIFO priority of the loop thread (0: normal scheduler), its CPU (-1: any),".into());
    w("# and mlockall. When the system refuses, the daemon warns and runs anyway.".into());
    w("# Above 1, the iceoryx2 threads and the built-in simulated robot run one lower.".into());
    w(format!("fifo-priority = {}", d.fifo_priority));
    w(format!("cpu = {}", d.cpu));
    w(format!("lock-memory = {}", d.lock_memory));
    w(String::new());
}
