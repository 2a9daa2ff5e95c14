//! The simulated robot that `anguilla run` drives when no bus is named: an
//! in-process bus (with CAN wire time at the configured bit rates) and the
//! simulated robot on it (vertebra nodes and the swimming body), on its own
//! thread in real time.

use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_drivers::Bus;
use anguilla_drivers::mem::MemBus;
use anguilla_sim::robot::{RobotConfig, RunningSim, SimRobot};
use anyhow::Context;

/// The running built-in robot.
pub struct BuiltinSim {
    running: RunningSim,
}

impl BuiltinSim {
    /// The simulation's ground truth, for the status line.
    pub fn truth_line(&self) -> String {
        let t = self.running.truth();
        format!(
            " | simulated robot: speed {:+.3} m/s, yaw {:+.1}°, depth {:+.3} m",
            t.forward_speed,
            t.yaw.to_degrees(),
            t.position[2]
        )
    }

    /// Stops the robot's thread.
    pub fn stop(self) {
        let _ = self.running.stop();
    }
}

/// Creates the in-process bus and the robot; returns the daemon's end of
/// the bus.
pub fn start_builtin(cfg: &Config) -> anyhow::Result<(Box<dyn Bus>, BuiltinSim)> {
    let mut b = MemBus::builder(&format!("anguilla-builtin-{}", std::process::id()))
        .bitrate(cfg.bus.bitrate)
        .capacity(4096);
    if cfg.bus.fd {
        b = b.data_bitrate(cfg.bus.data_bitrate);
    }
    let bus = b.build();
    let host: Box<dyn Bus> = Box::new(bus.participant());
    let rc = RobotConfig {
        node_ids: cfg.node_ids(),
        variant: cfg.bus.variant(),
        boot_time: Duration::from_millis(50),
        ..RobotConfig::with_joints(cfg.robot.joints)
    };
    let clock = bus.clock();
    let robot = SimRobot::on_mem(rc, bus.participant(), clock.now())
        .map_err(|e| anyhow::anyhow!("{e}"))
        .context("building the simulated robot")?;
    let running = robot
        .spawn(clock)
        .context("starting the simulated robot's thread")?;
    // Below a real-time loop, so the loop never waits on the shared bus lock
    // held by a preempted robot thread (see RunningSim::set_fifo_priority).
    if cfg.realtime.fifo_priority > 1 {
        let p = cfg.realtime.fifo_priority - 1;
        if let Err(e) = running.set_fifo_priority(p) {
            tracing::warn!("simulated robot thread: SCHED_FIFO priority {p} refused ({e})");
        }
    }
    Ok((host, BuiltinSim { running }))
}
