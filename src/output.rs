//! Standard output for every command: a write that fails is an error that
//! names standard output, never a panic (`println!` panics). A closed pipe
//! (`anguilla ... | head`) ends the command quietly: [`closed_pipe`] tells
//! `main` so. Status lines of long-running commands (`run`, `sim`) go
//! through [`Status`], which stops printing on the first failure and never
//! stops the work.

use std::io::Write as _;

/// Writes formatted text to standard output and flushes it.
pub fn write_fmt(args: std::fmt::Arguments) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| out.flush())
        .map_err(|e| anyhow::Error::new(e).context("writing to standard output"))
}

/// `print!` that returns an error instead of panicking.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::output::write_fmt(format_args!($($arg)*)) };
}

/// `println!` that returns an error instead of panicking.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => { $crate::output::write_fmt(format_args!("{}\n", format_args!($($arg)*))) };
}

pub use crate::{out, outln};

/// `e` and its causes, each said once: `context: cause: its cause`, but a
/// cause whose text its context already includes (an error that prints
/// its source, then the source itself) is not repeated.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let t = cause.to_string();
        if t.is_empty() || out.contains(&t) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&t);
    }
    out
}

/// Whether `e` is standard output's reader having gone away (EPIPE).
pub fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The status lines of a long-running command: printed while standard
/// output takes them; after a failure, none (said once on stderr).
#[derive(Debug, Default)]
pub struct Status {
    failed: bool,
}

impl Status {
    /// Prints one status line unless an earlier one failed.
    pub fn line(&mut self, args: std::fmt::Arguments) {
        if self.failed {
            return;
        }
        if let Err(e) = write_fmt(format_args!("{args}\n")) {
            self.failed = true;
            if !closed_pipe(&e) {
                let _ = writeln!(
                    std::io::stderr(),
                    "warning: {e:#}; no more status lines (the work goes on)"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An error that prints its source, wrapped: the source once.
    #[test]
    fn each_cause_is_said_once() {
        #[derive(Debug)]
        struct Opening(std::io::Error);
        impl std::fmt::Display for Opening {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "opening /dev/null: {}", self.0)
            }
        }
        impl std::error::Error for Opening {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let io = std::io::Error::from_raw_os_error(libc::ENOTTY);
        let said = io.to_string();
        let e = anyhow::Error::new(Opening(io)).context("opening bus 'slcan:/dev/null'");
        let text = error_text(&e);
        assert_eq!(text.matches(&said).count(), 1, "{text}");
        assert!(
            text.starts_with("opening bus 'slcan:/dev/null': opening /dev/null: "),
            "{text}"
        );
        // Causes that are not repeated are all kept.
        let e = anyhow::anyhow!("root").context("middle").context("top");
        assert_eq!(error_text(&e), "top: middle: root");
    }
}
