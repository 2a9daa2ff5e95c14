//! A test rig: the controller and twelve simulated vertebra nodes (or the
//! joints of the configured drive family) on one in-process bus, stepped in
//! lockstep on simulated time (no body plant: the joints see no load).
//! Faster than real time and deterministic.

use anguilla_daemon::config::Config;
use anguilla_daemon::control::Controller;
use anguilla_drivers::Bus;
use anguilla_drivers::mem::{MemBus, MemParticipant};
use anguilla_ipc::vocabulary::{Command, Nanos};
use anguilla_ipc::{CommandReply, CommandRequest, Envelope};
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::NodeId;
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::device::JointDevice;
use anguilla_sim::node::{NodeConfig, VertebraNode};
use anguilla_sim::robot::{RobotConfig, joint_device};

/// A bus (behind a `Box` or a `&mut`) that asks `hook` before every send:
/// the hook may stall, or refuse the frame with an error (a stalled
/// adapter, an interface gone down); everything else is `inner`'s.
#[allow(dead_code)] // each test file uses part of the rig
pub struct Hooked<B, F> {
    pub inner: B,
    pub hook: F,
}

impl<B, F> Bus for Hooked<B, F>
where
    B: std::ops::DerefMut + Send,
    B::Target: Bus,
    F: FnMut(&Frame) -> anguilla_drivers::Result<()> + Send,
{
    fn send(&mut self, frame: &Frame) -> anguilla_drivers::Result<()> {
        (self.hook)(frame)?;
        self.inner.send(frame)
    }
    fn recv(
        &mut self,
        timeout: std::time::Duration,
    ) -> anguilla_drivers::Result<Option<anguilla_drivers::Received>> {
        self.inner.recv(timeout)
    }
    fn state(&self) -> anguilla_drivers::BusState {
        self.inner.state()
    }
    fn counters(&self) -> anguilla_drivers::BusCounters {
        self.inner.counters()
    }
    fn capabilities(&self) -> anguilla_drivers::Capabilities {
        self.inner.capabilities()
    }
    fn flush_tx(&mut self) -> anguilla_drivers::Result<()> {
        self.inner.flush_tx()
    }
    fn reopen(&mut self) -> anguilla_drivers::OpenResult<()> {
        self.inner.reopen()
    }
    fn spec(&self) -> &str {
        "hooked"
    }
}

#[allow(dead_code)] // each test file uses part of the rig
pub struct Rig {
    pub ctl: Controller,
    pub host: MemParticipant,
    pub bus: MemBus,
    /// anguilla's vertebra nodes (empty for a bought drive family).
    pub nodes: Vec<VertebraNode>,
    /// A bought family's joints (empty for anguilla).
    pub joints: Vec<Box<dyn JointDevice>>,
    node_port: MemParticipant,
    /// The joint (index) whose frames [`Rig::nodes_step`] keeps in
    /// `captured`, if any.
    pub capture: Option<usize>,
    /// The frames the captured joint sent in the last [`Rig::nodes_step`].
    pub captured: Vec<Frame>,
    pub now: Nanos,
    seqs: [u32; 8],
    out: Vec<Frame>,
}

#[allow(dead_code)] // each test file uses part of the rig
impl Rig {
    pub fn new(name: &str, cfg: &Config) -> Self {
        let bus = MemBus::builder(name).capacity(4096).build();
        let host = bus.participant();
        let node_port = bus.participant();
        let ctl = Controller::new(cfg, Nanos::ZERO).expect("controller");
        let variant = cfg.bus.variant();
        let family = cfg.robot.drive;
        let joints = if family.drive_per_axis() {
            let rc = RobotConfig {
                drive: family,
                node_ids: cfg.node_ids(),
                axis_ids: cfg.axis_ids(),
                boot_time: std::time::Duration::from_millis(20),
                ..RobotConfig::with_joints(cfg.robot.joints)
            };
            (0..cfg.robot.joints)
                .map(|j| joint_device(&rc, j, j as u64, Nanos::ZERO).expect("joint"))
                .collect()
        } else {
            Vec::new()
        };
        let nodes = cfg
            .node_ids()
            .into_iter()
            .enumerate()
            .map(|(i, id)| {
                VertebraNode::new(
                    NodeConfig {
                        id: NodeId::new(id).unwrap(),
                        variant,
                        axes: [ActuatorParams::default(); 2],
                        boot_time: Nanos::from_millis(20),
                        seed: i as u64,
                    },
                    Nanos::ZERO,
                )
            })
            .filter(|_| !family.drive_per_axis())
            .collect();
        Self {
            ctl,
            host,
            bus,
            nodes,
            joints,
            node_port,
            capture: None,
            captured: Vec::with_capacity(16),
            now: Nanos::ZERO,
            seqs: [0; 8],
            out: Vec::with_capacity(1024),
        }
    }

    /// The nodes' half of a period: they hear the controller's frames and
    /// live until the next period.
    pub fn nodes_step(&mut self) {
        let now = self.now;
        let (nodes, joints) = (&mut self.nodes, &mut self.joints);
        let (out, capture, captured) = (&mut self.out, self.capture, &mut self.captured);
        captured.clear();
        let mut keep = |k: usize, f: Frame, out: &mut Vec<Frame>| {
            if capture == Some(k) {
                captured.push(f);
            }
            out.push(f);
        };
        let _ = self.node_port.drain(&mut |r| {
            for (k, n) in nodes.iter_mut().enumerate() {
                n.receive(now, &r.frame, &mut |f| keep(k, f, out));
            }
            for (k, j) in joints.iter_mut().enumerate() {
                j.receive(now, &r.frame, &mut |f| keep(k, f, out));
            }
        });
        self.now += self.ctl.period_ns();
        for (k, n) in self.nodes.iter_mut().enumerate() {
            n.advance(self.now, &mut |f| keep(k, f, out));
        }
        for (k, j) in self.joints.iter_mut().enumerate() {
            j.advance(self.now, &mut |f| keep(k, f, out));
        }
        for f in self.out.drain(..) {
            let _ = self.node_port.send(&f);
        }
    }

    /// One control period.
    pub fn step(&mut self) {
        self.ctl.run_period(self.now, &mut self.host);
        self.nodes_step();
    }

    pub fn run_for(&mut self, seconds: f64) {
        let periods = (seconds * 1e9 / self.ctl.period_ns().as_nanos() as f64).ceil() as usize;
        for _ in 0..periods {
            self.step();
        }
    }

    /// Sends `cmd` from client `client` (1..=7) and returns the reply.
    pub fn command(&mut self, client: u64, cmd: Command) -> CommandReply {
        self.seqs[client as usize] += 1;
        let env = Envelope {
            origin: client as u128,
            node: client as u128,
            request: CommandRequest::new(cmd, self.seqs[client as usize]),
        };
        self.ctl.command(self.now, &env)
    }
}
