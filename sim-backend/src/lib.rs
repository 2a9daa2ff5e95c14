//! The simulated anguilla robot.
//!
//! Everything in anguilla is developed and tested against this simulated
//! robot, which behaves on the bus as the real one will:
//!
//! - [`device`]: what a joint's drives are to the robot ([`device::JointDevice`]),
//!   whatever family they are (docs/drives.md);
//! - [`node`]: vertebra actuator nodes implementing the firmware contract of
//!   `protocol/README.md`, each driving two [`actuator`]s (pitch and yaw);
//! - [`cia402`]: a joint of two bought CANopen CiA 402 drives (object
//!   dictionary, NMT, SDO, PDOs, the drive state machine, cyclic
//!   synchronous position) as `docs/drives.md` specifies, and its EDS;
//! - [`device`]: the [`device::JointDevice`] trait every joint's drives
//!   implement;
//! - [`odrive`]: a joint of two ODrive axes speaking CANSimple (firmware 0.6);
//! - [`mit`]: a joint of two MIT-mode actuators (CubeMars AK, T-Motor);
//! - [`plant`]: the swimming body (the Boyer et al. model driven by the
//!   joints' achieved motion), which gives each actuator its load;
//! - [`robot`]: the whole robot on a bus ([`SimRobot`]): deterministic
//!   stepping on any clock, a real-time runner, and the ground truth;
//! - [`builtin`]: the robot `anguilla run` drives without a bus (and the
//!   system tests drive too), on an in-process bus in real time;
//! - [`sensor`]: the optional head sensor (IMU and pressure) beside the
//!   joints, sampled from the body's true head state;
//! - [`offbus`]: the sensors off the bus (a USBL's noisy fixes of the true
//!   position, a DVL's velocity over ground while it has bottom lock),
//!   sent over UDP;
//! - [`observed`]: a joint played by a real vertebra on the same bus,
//!   whose measured motion the body swims with (`anguilla sim --skip`);
//! - [`scenario`]: the fault-injection scenario language;
//! - [`serve`]: a robot served on a bus or behind emulated SLCAN adapters
//!   until told to stop, with its scenario, sensors off the bus and ground-truth record
//!   (what `anguilla sim` runs once its options are checked);
//! - [`rng`]: the deterministic random source of sensor noise and faults.
//!
//! In process, `anguilla run` starts [`builtin::Builtin`], which puts the
//! robot on an in-process bus and runs it with [`SimRobot::spawn`] on the
//! bus's clock; `anguilla sim` opens any bus with [`open_robot`]
//! ([`serve::serve`]);
//! tests drive [`SimRobot::step_until`] on a
//! [`ManualClock`](anguilla_drivers::ManualClock), faster than real time and
//! deterministically:
//!
//! ```
//! use std::sync::Arc;
//! use std::time::Duration;
//! use anguilla_drivers::{Bus, ManualClock, mem::MemBus};
//! use anguilla_sim::{RobotConfig, SimRobot};
//!
//! let clock = ManualClock::new();
//! let bus = MemBus::builder("sim-doc").clock(Arc::new(clock.clone())).build();
//! let mut host = bus.participant();
//! let mut robot = SimRobot::on_mem(RobotConfig::with_joints(4), bus.participant(), clock_now(&clock)).unwrap();
//! robot.load_scenario("0.05 node 2 silent").unwrap();
//! for _ in 0..100 {
//!     clock.advance(Duration::from_millis(1));
//!     robot.step_until(clock_now(&clock));
//! }
//! // Every node booted and sent heartbeats; the host heard them.
//! let mut heard = 0;
//! host.drain(&mut |_| heard += 1).unwrap();
//! assert!(heard >= 4);
//! assert!(robot.truth().forward_speed.abs() < 1e-9, "a robot at rest");
//! # fn clock_now(c: &ManualClock) -> Duration { anguilla_drivers::Clock::now(c) }
//! ```
#![warn(missing_docs)]

pub mod actuator;
pub mod builtin;
pub mod cia402;
pub mod device;
pub mod error;
pub mod mit;
pub mod node;
pub mod observed;
pub mod odrive;
pub mod offbus;
pub mod plant;
pub mod rng;
pub mod robot;
pub mod scenario;
pub mod sensor;
pub mod serve;

pub use robot::{
    MAX_CATCH_UP, Result, RobotConfig, RunningSim, SimError, SimRobot, SimStats, Status,
    TICK_RANGE, Truth,
};
pub use scenario::{Scenario, ScenarioError};

use anguilla_drivers::{Bus, BusSpec, mem::MemBus};

/// Opens the bus of `spec` for a robot: on `mem:NAME` the robot gets the
/// in-process bus's fault hooks (all scenario faults); on other buses only
/// node and joint faults and floods.
pub fn open_robot(cfg: RobotConfig, spec: &str) -> Result<SimRobot> {
    let parsed = BusSpec::parse(spec).map_err(|e| SimError::Config {
        field: "bus",
        reason: e.to_string(),
    })?;
    match parsed {
        BusSpec::Mem(mc) => {
            let bus = MemBus::open_or_create(&mc);
            let now = bus.clock().now();
            SimRobot::on_mem(cfg, bus.participant(), now)
        }
        other => {
            let bus: Box<dyn Bus> = other.open()?;
            SimRobot::new(cfg, bus, std::time::Duration::ZERO)
        }
    }
}
