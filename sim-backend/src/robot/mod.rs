//! The whole simulated robot: each joint's drives on a bus, the body as
//! their load, and a fault scenario.
//!
//! The robot sees a joint's drives only through [`JointDevice`] (one
//! vertebra node, or two bought drives of another family).
//! [`SimRobot::step_until`] is the deterministic core: it takes every frame
//! received from the bus up to a time, in order, hands it to every joint's
//! drives, runs them and the physics in fixed ticks, gives each actuator the
//! torque the body demands at its joint, and sends the drives' frames.
//! [`SimRobot::run_realtime`] and [`SimRobot::spawn`] pace it to a clock.
//!
//! Joint `j` (1 = nearest the head) is node `node_ids[j - 1]`; axis 0 is
//! pitch and axis 1 yaw; the angles are those of the model's
//! [`JointState`](anguilla_model::JointState) (the universal joint at
//! `X = j / (n + 1)`), so a host sending the model's joint angles as
//! setpoints makes the plant reproduce the model's motion.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use anguilla_drivers::mem::{MemBus, MemParticipant, ParticipantId};
use anguilla_drivers::{Bus, Frame, Received, TimestampBase};
use anguilla_model::{Current, HeadState};
use anguilla_protocol::Family;
use anguilla_protocol::message::NodeState;

use crate::actuator::Load;
use crate::device::JointDevice;
use crate::node::Nanos;
use crate::plant::{JointInput, Plant, PlantConfig};
use crate::rng::Rng;
use crate::scenario::{Action, NodeFault, Scenario};
use crate::sensor::{HeadSensor, HeadTruth};

pub use crate::error::{Result, SimError};

mod config;
mod faults;
mod realtime;

pub use config::*;

/// The simulation's ground truth (never sent on the bus).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth {
    /// Simulated time.
    pub time: Duration,
    /// Nose position (m, earth frame).
    pub position: [f64; 3],
    /// Head orientation, unit quaternion `[w, x, y, z]` (head frame to earth).
    pub orientation: [f64; 4],
    /// Nose velocity (m/s, earth frame).
    pub velocity: [f64; 3],
    /// Head angular velocity (rad/s, earth frame).
    pub angular_velocity: [f64; 3],
    /// Forward speed `−V1` at the head (m/s; positive head first).
    pub forward_speed: f64,
    /// Yaw of the head axis `t1` about the vertical (rad): it points from
    /// the head to the tail (the paper's convention), and swings with
    /// every tail beat.
    pub yaw: f64,
    /// The body's heading in the operator's convention (rad, `(−π, π]`,
    /// counter-clockwise from the world's x): the direction from the body
    /// shape's centroid to the nose, as the daemon estimates it.
    pub heading: f64,
    /// Depth of the nose below the surface (m): the head sensor's origin
    /// depth (1 m without a sensor) minus the model's z (up).
    pub depth: f64,
    /// True joint angles `[pitch, yaw]` (rad), joint 1 first.
    pub joints: Vec<[f64; 2]>,
}

/// Counters of the simulation itself.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimStats {
    /// Frames taken off the bus.
    pub frames_in: u64,
    /// Frames sent by the nodes.
    pub frames_out: u64,
    /// Sends the bus refused (bus-off, full queue).
    pub send_errors: u64,
    /// Receive errors of the bus.
    pub recv_errors: u64,
    /// Physics steps.
    pub ticks: u64,
    /// Physics steps the model refused (non-finite state): loads zeroed.
    pub model_errors: u64,
    /// Flood frames sent or injected.
    pub flood_frames: u64,
    /// Scenario events applied.
    pub events: u64,
    /// Physics steps that ended with the nose at the water's surface
    /// (put back on it: [`crate::plant::Plant::surface`]).
    pub surfaced: u64,
    /// Real time the simulation gave up to keep pace
    /// ([`SimRobot::run_realtime`] catches up at most
    /// [`MAX_CATCH_UP`] at once): non-zero when the machine is too slow
    /// for the physics step and model size.
    pub slipped: Duration,
}

/// The longest stretch of simulated time [`SimRobot::run_realtime`] runs
/// at once to catch up with its clock. A robot that falls further behind
/// (a machine too slow for its physics step) lets its time slip instead of
/// spiralling: running ever longer batches would hold every node's frames
/// back for the whole batch.
pub const MAX_CATCH_UP: Duration = Duration::from_millis(50);

#[derive(Debug, Clone, Copy)]
enum Undo {
    Speak(usize),
    BusOn,
}

/// A sender of heartbeats for a node's id that is not the node
/// (`node N spoof`, `node N twin`).
#[derive(Debug, Clone, Copy)]
struct Impostor {
    /// The node's index in the robot.
    k: usize,
    /// The node whose state it reports.
    mirror: usize,
    next: Nanos,
    every: Nanos,
    counter: u8,
}

#[derive(Debug, Clone, Copy)]
struct Flood {
    left: u64,
    ticks_left: u64,
}

/// The simulated robot.
pub struct SimRobot {
    cfg: RobotConfig,
    nodes: Vec<Box<dyn JointDevice>>,
    plant: Plant,
    rng: Rng,
    bus: Box<dyn Bus>,
    mem: Option<(MemBus, ParticipantId)>,
    stamps: TimestampBase,
    /// Time of the last tick (ns since the clock's origin).
    time: Nanos,
    start: Nanos,
    tick: Nanos,
    pending: VecDeque<(Nanos, Frame)>,
    out: Vec<Frame>,
    inputs: Vec<JointInput>,
    tau: Vec<[f64; 2]>,
    friction: Vec<[f64; 2]>,
    node_loads: Vec<[Load; 2]>,
    scenario: Scenario,
    next_event: usize,
    undo: Vec<(Nanos, Undo)>,
    flood: Option<Flood>,
    impostors: Vec<Impostor>,
    /// Actions a test or tool asked for now ([`RunningSim::inject`]).
    live: Arc<Mutex<Vec<Action>>>,
    /// Node ids (0..=127) taken by the robot's drives (bought families).
    drive_ids_used: [bool; 128],
    /// The head sensor, if the robot has one.
    sensor: Option<HeadSensor>,
    /// The tail IMU, if the robot has one.
    tail_sensor: Option<HeadSensor>,
    stats: SimStats,
}

impl std::fmt::Debug for SimRobot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimRobot")
            .field("bus", &self.bus.spec())
            .field("nodes", &self.cfg.node_ids)
            .field("time", &self.time)
            .finish_non_exhaustive()
    }
}

impl SimRobot {
    /// A robot on `bus`, powered on at `start` (the bus clock's time; zero
    /// for a fresh clock). Bus faults of scenarios are refused on this bus:
    /// use [`SimRobot::on_mem`] for them.
    pub fn new(cfg: RobotConfig, bus: Box<dyn Bus>, start: Duration) -> Result<Self> {
        Self::build(cfg, bus, None, start)
    }

    /// A robot on an in-process bus, with its fault hooks for scenarios.
    pub fn on_mem(cfg: RobotConfig, participant: MemParticipant, start: Duration) -> Result<Self> {
        let mem = (participant.bus(), participant.id());
        Self::build(cfg, Box::new(participant), Some(mem), start)
    }

    fn build(
        cfg: RobotConfig,
        bus: Box<dyn Bus>,
        mem: Option<(MemBus, ParticipantId)>,
        start: Duration,
    ) -> Result<Self> {
        cfg.validate()?;
        let n = cfg.node_ids.len();
        let plant = Plant::new(PlantConfig {
            joints: n,
            dt: cfg.tick.as_secs_f64(),
            nodes: cfg.model_nodes,
            v_init: cfg.v_init,
            rate_loads: !cfg.actuator.ideal,
            current: cfg.current,
            body: cfg.body.clone(),
            ..PlantConfig::default()
        })?;
        let mut plant = plant;
        if !cfg.actuator.ideal {
            plant.couple_servos(&vec![[cfg.actuator.inertia; 2]; n])?;
        }
        let start = Nanos::from(start);
        let mut rng = Rng::new(cfg.seed);
        let nodes = (0..n)
            .map(|j| joint_device(&cfg, j, rng.next_u64(), start))
            .collect::<Result<Vec<_>>>()?;
        let sensor = match cfg.head_sensor {
            Some(s) => Some(
                HeadSensor::new(s, cfg.variant, rng.next_u64(), start)
                    .map_err(|(field, reason)| SimError::Config { field, reason })?,
            ),
            None => None,
        };
        // After the head sensor's: a robot without a tail IMU draws the
        // same seeds as before there was one.
        let tail_sensor = match cfg.tail_sensor {
            Some(s) => Some(
                HeadSensor::new(s, cfg.variant, rng.next_u64(), start)
                    .map_err(|(field, reason)| SimError::Config { field, reason })?,
            ),
            None => None,
        };
        let stamps = bus.capabilities().timestamps;
        let mut drive_ids_used = [false; 128];
        for j in 0..n {
            for id in cfg.drive_ids(j) {
                drive_ids_used[usize::from(id & 0x7F)] = true;
            }
        }
        Ok(Self {
            tick: Nanos::from(cfg.tick),
            nodes,
            plant,
            rng,
            bus,
            mem,
            stamps,
            time: start,
            start,
            pending: VecDeque::with_capacity(4096),
            out: Vec::with_capacity(256),
            inputs: vec![JointInput::default(); n],
            tau: vec![[0.0; 2]; n],
            friction: vec![[0.0; 2]; n],
            node_loads: vec![[Load::default(); 2]; n],
            scenario: Scenario::default(),
            next_event: 0,
            undo: Vec::new(),
            flood: None,
            impostors: Vec::new(),
            live: Arc::new(Mutex::new(Vec::new())),
            drive_ids_used,
            sensor,
            tail_sensor,
            stats: SimStats::default(),
            cfg,
        })
    }

    /// Loads a fault scenario (times from the robot's start). Fails if it
    /// scripts bus faults and the robot is not on the in-process bus.
    pub fn set_scenario(&mut self, scenario: Scenario) -> Result<()> {
        if self.mem.is_none()
            && let Some(e) = scenario.first_mem_only()
        {
            return Err(SimError::BusFaultNeedsMemBus {
                line: e.line,
                bus: self.bus.spec().to_owned(),
            });
        }
        if self.cfg.drive != Family::Anguilla
            && let Some(e) = scenario.events.iter().find(|e| {
                matches!(
                    e.action,
                    Action::Node {
                        fault: NodeFault::Twin,
                        ..
                    }
                )
            })
        {
            return Err(SimError::Config {
                field: "scenario",
                reason: format!(
                    "line {} scripts a twin node: anguilla nodes only (their heartbeats carry \
                     the counter that tells two senders apart), and this robot's drives are {}",
                    e.line, self.cfg.drive
                ),
            });
        }
        // A real vertebra is not the simulator's to fault.
        let observed = |id: u8| self.cfg.observed.contains(&id);
        if let Some((e, id)) = scenario.events.iter().find_map(|e| match e.action {
            Action::Node { id, .. } if observed(id) => Some((e, id)),
            Action::Joint { joint, .. } => joint
                .checked_sub(1)
                .and_then(|j| self.cfg.node_ids.get(j).copied())
                .filter(|&id| observed(id))
                .map(|id| (e, id)),
            _ => None,
        }) {
            return Err(SimError::Config {
                field: "scenario",
                reason: format!(
                    "line {} scripts a fault of node {id}, a real vertebra on the bus \
                     (--skip): the simulator cannot fault it",
                    e.line
                ),
            });
        }
        if self.sensor.is_none()
            && let Some(e) = scenario.first_sensor_fault()
        {
            return Err(SimError::Config {
                field: "scenario",
                reason: format!(
                    "line {} scripts a head sensor fault and the robot has no head sensor",
                    e.line
                ),
            });
        }
        self.scenario = scenario;
        self.next_event = 0;
        Ok(())
    }

    /// Parses and loads a scenario file's text.
    pub fn load_scenario(&mut self, text: &str) -> Result<()> {
        let s = Scenario::parse(text, &self.cfg.node_ids)?;
        self.set_scenario(s)
    }

    /// The configuration.
    pub fn config(&self) -> &RobotConfig {
        &self.cfg
    }

    /// Time of the last tick.
    pub fn time(&self) -> Duration {
        Duration::from(self.time)
    }

    /// The joints' drives, joint 1 first.
    pub fn nodes(&self) -> &[Box<dyn JointDevice>] {
        &self.nodes
    }

    /// The joints' drives, for tests that inject faults directly.
    pub fn nodes_mut(&mut self) -> &mut [Box<dyn JointDevice>] {
        &mut self.nodes
    }

    /// The drives of the joint with id `id` in [`RobotConfig::node_ids`]
    /// (the vertebra node's bus id; the joint number for bought drives).
    pub fn node(&self, id: u8) -> Option<&dyn JointDevice> {
        let i = self.cfg.node_ids.iter().position(|&x| x == id)?;
        self.nodes.get(i).map(|b| b.as_ref())
    }

    /// Counters of the simulation.
    pub fn stats(&self) -> SimStats {
        self.stats
    }

    /// The bus the robot is on.
    pub fn bus(&self) -> &dyn Bus {
        self.bus.as_ref()
    }

    /// The in-process bus, if the robot is on one.
    pub fn mem_bus(&self) -> Option<&MemBus> {
        self.mem.as_ref().map(|(b, _)| b)
    }

    /// How many nodes are in each state:
    /// `[Boot, Disabled, Enabled, Fault, EStop]`.
    pub fn state_counts(&self) -> [usize; 5] {
        let mut c = [0; 5];
        for n in &self.nodes {
            let i = match n.state() {
                NodeState::Boot => 0,
                NodeState::Disabled => 1,
                NodeState::Enabled => 2,
                NodeState::Fault => 3,
                NodeState::EStop => 4,
            };
            c[i] += 1;
        }
        c
    }

    /// The ground truth now.
    pub fn truth(&self) -> Truth {
        let mut t = Truth::default();
        self.truth_into(&mut t);
        t
    }

    /// Writes the ground truth into `t` (reusing its joint buffer).
    pub fn truth_into(&self, t: &mut Truth) {
        let h: &HeadState = self.plant.head();
        let q = h.orientation.quaternion();
        t.time = Duration::from(self.time);
        t.position = [h.position.x, h.position.y, h.position.z];
        t.orientation = [q.w, q.i, q.j, q.k];
        t.velocity = [h.velocity.x, h.velocity.y, h.velocity.z];
        t.angular_velocity = [h.omega.x, h.omega.y, h.omega.z];
        t.forward_speed = -h.v1();
        t.yaw = h.yaw();
        let forward = h.orientation * anguilla_model::body_axis(self.plant.shape());
        t.heading = if forward.x.hypot(forward.y) > 1e-12 {
            forward.y.atan2(forward.x)
        } else {
            h.yaw() + std::f64::consts::PI
        };
        let origin_depth = self
            .sensor
            .as_ref()
            .map_or(crate::sensor::DEFAULT_ORIGIN_DEPTH, |s| {
                s.config().origin_depth
            });
        t.depth = origin_depth - h.position.z;
        t.joints.clear();
        t.joints.extend(
            self.nodes
                .iter()
                .map(|n| [n.kinematics(0).0, n.kinematics(1).0]),
        );
    }

    /// The head sensor, if the robot has one.
    pub fn head_sensor(&self) -> Option<&HeadSensor> {
        self.sensor.as_ref()
    }

    /// The loads `[pitch, yaw]` (N·m) the body puts on each joint now.
    pub fn loads(&self) -> &[[f64; 2]] {
        self.plant.loads()
    }

    /// Puts the head at the origin at rest, keeping the joints as they are
    /// (a test's initial condition, e.g. to start a gait the way the model's
    /// own runs do).
    pub fn reset_head(&mut self) {
        let t = self.plant.head().t;
        let mut h = HeadState::launch(self.cfg.v_init);
        h.t = t;
        self.plant.reset_head(h);
    }

    /// Sets the water's current (earth frame) from the next physics step on,
    /// as a scenario's `water current` event does.
    pub fn set_current(&mut self, current: Current) {
        self.plant.set_current(current);
    }

    /// The water's current now.
    pub fn current(&self) -> Current {
        self.plant.current()
    }

    /// Hands over a frame received outside [`step_until`](Self::step_until)
    /// (by a runner waiting on the bus), stamped at `at`.
    pub fn accept(&mut self, r: Received, at: Duration) {
        let ts = self.stamp(&r, Nanos::from(at));
        self.pending.push_back((ts, r.frame));
        self.stats.frames_in += 1;
    }

    fn stamp(&self, r: &Received, now: Nanos) -> Nanos {
        let ts = match (self.stamps, r.timestamp) {
            (TimestampBase::BusClock, Some(t)) => Nanos::from(t),
            _ => now,
        };
        let floor = self
            .pending
            .back()
            .map_or(self.time, |p| p.0.max(self.time));
        ts.clamp(floor, now.max(floor))
    }

    /// Runs the simulation up to `now` (the bus clock's time): handles every
    /// frame received up to then in order, advances the nodes and the
    /// physics in ticks, applies due scenario events and sends the nodes'
    /// frames. Never blocks.
    pub fn step_until(&mut self, now: Duration) {
        let now = Nanos::from(now);
        // Take everything the bus has.
        {
            let (pending, stamps, time, stats) =
                (&mut self.pending, self.stamps, self.time, &mut self.stats);
            let mut floor = pending.back().map_or(time, |p| p.0.max(time));
            let r = self.bus.drain(&mut |r: Received| {
                let ts = match (stamps, r.timestamp) {
                    (TimestampBase::BusClock, Some(t)) => Nanos::from(t),
                    _ => now,
                };
                let ts = ts.clamp(floor, now.max(floor));
                floor = ts;
                pending.push_back((ts, r.frame));
                stats.frames_in += 1;
            });
            if r.is_err() {
                self.stats.recv_errors += 1;
            }
        }
        loop {
            let next_tick = self.time + self.tick;
            match self.pending.front().copied() {
                Some((ts, frame)) if ts < next_tick && ts <= now => {
                    self.pending.pop_front();
                    self.apply_events(ts);
                    let out = &mut self.out;
                    for node in &mut self.nodes {
                        node.receive(ts, &frame, &mut |f| out.push(f));
                    }
                    self.flush();
                }
                _ if next_tick <= now => self.tick_to(next_tick),
                _ => break,
            }
        }
    }

    fn tick_to(&mut self, t: Nanos) {
        self.apply_events(t);
        let out = &mut self.out;
        for (node, inp) in self.nodes.iter_mut().zip(self.inputs.iter_mut()) {
            node.advance(t, &mut |f| out.push(f));
            let (p, pr, _) = node.kinematics(0);
            let (y, yr, _) = node.kinematics(1);
            *inp = JointInput {
                angle: [p, y],
                rate: [pr, yr],
            };
        }
        // The water's surface: the part of the body above it is neither
        // buoyed nor dragged, and the nose's depth is never below 0.
        let origin_depth = self
            .sensor
            .as_ref()
            .map_or(crate::sensor::DEFAULT_ORIGIN_DEPTH, |s| {
                s.config().origin_depth
            });
        self.plant
            .set_water_surface(self.cfg.surface.then_some(origin_depth));
        match self.plant.step(&self.inputs) {
            Ok(_) => {}
            Err(_) => self.stats.model_errors += 1,
        }
        if self.cfg.surface && self.plant.surface(origin_depth) {
            self.stats.surfaced += 1;
        }
        if let Some(sensor) = &mut self.sensor {
            let h: &HeadState = self.plant.head();
            let q = h.orientation.quaternion();
            let truth = HeadTruth {
                position: [h.position.x, h.position.y, h.position.z],
                orientation: [q.w, q.i, q.j, q.k],
                velocity: [h.velocity.x, h.velocity.y, h.velocity.z],
                angular_velocity: [h.omega.x, h.omega.y, h.omega.z],
            };
            let out = &mut self.out;
            sensor.advance(t, &truth, &mut |f| out.push(f));
        }
        if let Some(sensor) = &mut self.tail_sensor {
            let truth = self.plant.tail();
            let out = &mut self.out;
            sensor.advance(t, &truth, &mut |f| out.push(f));
        }
        // Ideal servos report the full load; servos with dynamics get the
        // load coupled implicitly to their torques (`Plant::coupled_loads`).
        // What a snag takes of the motor's torque never reaches the body:
        // it is lost with the friction (the body's reaction to the rest
        // only; without it the snag's share would drive the body and load
        // every other joint through the coupling). An end stop's torque
        // drives the body as the motor's does (a joint resting on its stop
        // under a snag passes the body nothing of it: the stop takes it).
        let p = self.cfg.actuator;
        let b = p.damping;
        for ((node, tau), fr) in self
            .nodes
            .iter_mut()
            .zip(&mut self.tau)
            .zip(&mut self.friction)
        {
            *tau = [node.motor_torque(0), node.motor_torque(1)];
            *fr = [0, 1].map(|a| {
                let (theta, omega, _) = node.kinematics(a);
                b * omega + node.axis_faults_mut(a).snag - p.stop_torque(theta, omega)
            });
        }
        self.plant
            .coupled_loads(&self.tau, &self.friction, &mut self.node_loads);
        for (node, load) in self.nodes.iter_mut().zip(&self.node_loads) {
            node.set_load(*load);
        }
        self.flood_tick();
        self.impostors_tick(t);
        self.time = t;
        self.stats.ticks += 1;
        self.flush();
    }

    fn flush(&mut self) {
        for f in self.out.drain(..) {
            self.stats.frames_out += 1;
            if self.bus.send(&f).is_err() {
                self.stats.send_errors += 1;
            }
        }
    }
}

/// A summary of the running robot for status displays.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Status {
    /// Nodes per state: `[Boot, Disabled, Enabled, Fault, EStop]`.
    pub states: [usize; 5],
    /// Simulation counters.
    pub stats: SimStats,
}

/// A robot running in real time on its own thread ([`SimRobot::spawn`]).
#[derive(Debug)]
pub struct RunningSim {
    stop: Arc<AtomicBool>,
    truth: Arc<Mutex<Truth>>,
    status: Arc<Mutex<Status>>,
    live: Arc<Mutex<Vec<Action>>>,
    thread: Option<JoinHandle<SimRobot>>,
}

impl RunningSim {
    /// Runs the robot's thread at SCHED_FIFO `priority` (1..=99).
    ///
    /// A daemon loop at a real-time priority that shares an in-process bus
    /// with this thread waits on the bus's lock while this thread holds it;
    /// at the normal scheduler, any busy process can then preempt this
    /// thread inside the lock and stall the loop (priority inversion,
    /// measured at up to 1.5 ms on a loaded 2-core machine). Below the
    /// loop's priority it is not preempted by ordinary processes.
    pub fn set_fifo_priority(&self, priority: u8) -> std::io::Result<()> {
        use std::os::unix::thread::JoinHandleExt;
        let Some(thread) = &self.thread else {
            return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
        };
        let param = libc::sched_param {
            sched_priority: i32::from(priority),
        };
        // SAFETY: the thread is alive (joined only by `stop`, which takes
        // `self`), and `param` is a valid sched_param.
        let r =
            unsafe { libc::pthread_setschedparam(thread.as_pthread_t(), libc::SCHED_FIFO, &param) };
        if r == 0 {
            Ok(())
        } else {
            Err(std::io::Error::from_raw_os_error(r))
        }
    }

    /// Applies a scenario action at the robot's next tick (as a scenario
    /// line timed "now" would).
    pub fn inject(&self, action: Action) {
        if let Ok(mut g) = self.live.lock() {
            g.push(action);
        }
    }

    /// The ground truth at the last tick.
    pub fn truth(&self) -> Truth {
        self.truth.lock().map(|g| g.clone()).unwrap_or_default()
    }

    /// [`RunningSim::truth`] for another thread (a simulated sensor off
    /// the bus).
    pub fn truth_reader(&self) -> impl Fn() -> Truth + Send + 'static {
        let t = self.truth.clone();
        move || t.lock().map(|g| g.clone()).unwrap_or_default()
    }

    /// Node states and counters at the last tick.
    pub fn status(&self) -> Status {
        self.status.lock().map(|g| *g).unwrap_or_default()
    }

    /// A flag that stops the robot when set.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Stops the robot and gives it back (`None` if its thread panicked).
    pub fn stop(mut self) -> Option<SimRobot> {
        self.stop.store(true, Ordering::Release);
        self.thread.take().and_then(|t| t.join().ok())
    }
}

impl Drop for RunningSim {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_drivers::Clock;

    #[test]
    fn a_robot_far_behind_its_clock_catches_up_a_bounded_stretch_and_slips_the_rest() {
        let clock = anguilla_drivers::ManualClock::new();
        let bus = MemBus::builder("robot-slip-test")
            .clock(Arc::new(clock.clone()))
            .build();
        let mut robot = SimRobot::on_mem(
            RobotConfig::with_joints(2),
            bus.participant(),
            Duration::ZERO,
        )
        .unwrap();
        let stop = AtomicBool::new(false);
        // One second late (a stalled process, a machine slower than the
        // physics): one step runs MAX_CATCH_UP of it.
        clock.advance(Duration::from_secs(1));
        robot.run_realtime(&clock, &stop, |_| stop.store(true, Ordering::Release));
        assert_eq!(robot.time(), MAX_CATCH_UP);
        assert_eq!(robot.stats().slipped, Duration::from_secs(1) - MAX_CATCH_UP);
        // A frame taken in during a second stall (stamped on the clock
        // before the slip) is handled in the next step, not a stall later.
        clock.advance(Duration::from_secs(1));
        let f = Frame::new_standard(0x7F0, &[1]).unwrap();
        robot.accept(
            Received {
                frame: f,
                timestamp: None,
            },
            clock.now() - robot.stats().slipped,
        );
        stop.store(false, Ordering::Release);
        robot.run_realtime(&clock, &stop, |_| stop.store(true, Ordering::Release));
        assert_eq!(robot.time(), MAX_CATCH_UP * 2);
        assert!(
            robot.pending.is_empty(),
            "the frame waits for {:?}",
            robot.pending
        );
        assert_eq!(
            robot.stats().slipped,
            Duration::from_secs(2) - MAX_CATCH_UP * 2
        );
        // On time again: it follows the clock minus the slip, no more slip.
        clock.advance(Duration::from_millis(20));
        stop.store(false, Ordering::Release);
        robot.run_realtime(&clock, &stop, |_| stop.store(true, Ordering::Release));
        assert_eq!(robot.time(), MAX_CATCH_UP * 2 + Duration::from_millis(20));
        assert_eq!(
            robot.stats().slipped,
            Duration::from_secs(2) - MAX_CATCH_UP * 2
        );
    }

    #[test]
    fn bad_configurations_name_the_setting() {
        let bus = MemBus::builder("robot-config-test").build();
        let mut cfg = RobotConfig::with_joints(3);
        cfg.node_ids = vec![1, 2, 2];
        let e = SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO).unwrap_err();
        assert!(
            e.to_string().contains("node_ids") && e.to_string().contains("twice"),
            "{e}"
        );
        let mut cfg = RobotConfig::with_joints(3);
        cfg.node_ids = vec![1, 64];
        let e = SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO).unwrap_err();
        assert!(e.to_string().contains("1..=63"), "{e}");
        let mut cfg = RobotConfig::with_joints(3);
        cfg.tick = Duration::from_millis(50);
        let e = SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO).unwrap_err();
        assert!(e.to_string().contains("tick"), "{e}");
        let e = crate::open_robot(RobotConfig::with_joints(3), "nonsense").unwrap_err();
        assert!(e.to_string().contains("bus"), "{e}");
    }

    #[test]
    fn bad_drive_ids_name_the_joint_the_axis_and_the_range() {
        let bus = MemBus::builder("robot-drive-ids-test").build();
        let build = |cfg: RobotConfig| {
            SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO)
                .unwrap_err()
                .to_string()
        };
        let odrive = |n| RobotConfig {
            drive: Family::Odrive,
            ..RobotConfig::with_joints(n)
        };
        let e = build(RobotConfig {
            axis_ids: vec![[1, 2]],
            ..RobotConfig::with_joints(1)
        });
        assert!(e.contains("axis_ids") && e.contains("anguilla"), "{e}");
        let e = build(RobotConfig {
            axis_ids: vec![[1, 2], [3, 1]],
            ..odrive(2)
        });
        assert!(e.contains("id 1 appears twice (joint 2 yaw)"), "{e}");
        let e = build(RobotConfig {
            axis_ids: vec![[1, 64]],
            ..odrive(1)
        });
        assert!(
            e.contains("joint 1 yaw id 64 outside odrive's 0..=63"),
            "{e}"
        );
        let e = build(RobotConfig {
            axis_ids: vec![[1, 2]],
            ..odrive(2)
        });
        assert!(e.contains("1 pairs of ids for 2 joints"), "{e}");
        // 32 joints do not fit the default ids 2j+1, 2j+2 in 0..=63.
        let e = build(odrive(32));
        assert!(
            e.contains("joint 32 pitch id 63") || e.contains("joint 32 yaw id 64"),
            "{e}"
        );
        let e = build(RobotConfig {
            node_ids: vec![2, 3],
            ..odrive(2)
        });
        assert!(e.contains("numbered 1..=2"), "{e}");
        let e = build(RobotConfig {
            drive: Family::Cia402,
            axis_ids: vec![[1, 2], [0, 3]],
            ..RobotConfig::with_joints(2)
        });
        assert!(
            e.contains("joint 2 pitch id 0 outside cia402's 1..=127"),
            "{e}"
        );
        // The defaults: anguilla [id, id], bought families 2j+1, 2j+2.
        assert_eq!(RobotConfig::with_joints(3).drive_ids(2), [3, 3]);
        assert_eq!(odrive(3).drive_ids(2), [5, 6]);
    }
}
