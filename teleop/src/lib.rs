//! Operator tools: keyboard and gamepad teleoperation and a monitor (not yet built; see issue 6).
#![warn(missing_docs)]
