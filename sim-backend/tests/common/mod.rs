//! A test host: a ManualClock, a mem bus, the robot and a host participant
//! that records every frame it hears.
#![allow(dead_code)]

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::{MemBus, MemParticipant};
use anguilla_drivers::{Bus, Clock, Frame, ManualClock};
use anguilla_protocol::message::{
    self, AxisSetpoint, Command, Message, NodeId, NodeSet, NodeState, Target, Variant,
};
use anguilla_sim::{RobotConfig, SimRobot};

pub const MS: Duration = Duration::from_millis(1);

pub struct Host {
    pub clock: ManualClock,
    pub bus: MemBus,
    pub host: MemParticipant,
    pub robot: SimRobot,
    /// Every frame the host heard, with the clock time it was taken.
    pub heard: Vec<(Duration, Frame)>,
    pub variant: Variant,
    pub counter: u16,
}

static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

impl Host {
    pub fn new(cfg: RobotConfig) -> Self {
        let clock = ManualClock::new();
        let name = format!(
            "sim-test-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        );
        let bus = MemBus::builder(&name)
            .clock(Arc::new(clock.clone()))
            .build();
        let host = bus.participant();
        let variant = cfg.variant;
        let robot = SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO).unwrap();
        Self {
            clock,
            bus,
            host,
            robot,
            heard: Vec::new(),
            variant,
            counter: 0,
        }
    }

    pub fn now(&self) -> Duration {
        self.clock.now()
    }

    /// Advances time by `d` in 1 ms steps, stepping the robot and collecting
    /// what the host hears.
    pub fn run(&mut self, d: Duration) {
        let end = self.now() + d;
        while self.now() < end {
            let step = (end - self.now()).min(MS);
            self.clock.advance(step);
            self.robot.step_until(self.clock.now());
            self.collect();
        }
    }

    pub fn collect(&mut self) {
        let now = self.clock.now();
        let heard = &mut self.heard;
        self.host
            .drain(&mut |r| heard.push((now, r.frame)))
            .unwrap();
    }

    pub fn send(&mut self, m: Message) {
        let f = m.encode(self.variant).unwrap();
        self.host.send(&f).unwrap();
    }

    pub fn enable_all(&mut self) {
        self.run(30 * MS);
        self.send(Message::Command {
            target: Target::All,
            command: Command::Enable,
        });
        // Wait (in simulated time, bounded) for every node to be Enabled.
        for _ in 0..200 {
            self.run(MS);
            if self.robot.state_counts()[2] == self.robot.nodes().len() {
                return;
            }
        }
        panic!("nodes not enabled: {:?}", self.robot.state_counts());
    }

    /// Sends setpoints for every node then SYNC, and runs one period.
    pub fn cycle(&mut self, setpoints: &[[AxisSetpoint; 2]], period: Duration) {
        self.counter = self.counter.wrapping_add(1);
        let host = &mut self.host;
        message::encode_setpoints(
            self.variant,
            self.counter,
            message::from_node_one(setpoints),
            |f| host.send(&f).unwrap(),
        )
        .unwrap();
        self.send(Message::Sync {
            counter: self.counter,
        });
        self.run(period);
    }

    /// Holds every joint at `angle` (pitch and yaw) for `d` with 10 ms SYNCs.
    pub fn hold(&mut self, angle: f32, d: Duration) {
        let n = self.robot.nodes().len();
        let sp = AxisSetpoint {
            position: angle,
            velocity: 0.0,
            torque: 0.0,
        };
        let end = self.now() + d;
        while self.now() < end {
            self.cycle(&vec![[sp, sp]; n], 10 * MS);
        }
    }

    /// Decoded messages heard since time `from`.
    pub fn messages_since(&self, from: Duration) -> Vec<Message> {
        self.heard
            .iter()
            .filter(|(t, _)| *t > from)
            .filter_map(|(_, f)| message::decode(f, self.variant, NodeSet::all()).ok())
            .collect()
    }

    /// Whether node `id` sent anything (heartbeat or feedback) after `from`.
    pub fn node_spoke_since(&self, id: u8, from: Duration) -> bool {
        let id = NodeId::new(id).unwrap();
        self.messages_since(from).iter().any(|m| match m {
            Message::Heartbeat(h) => h.node == id,
            Message::Feedback(f) => f.node == id,
            _ => false,
        })
    }

    /// The last feedback positions `[pitch, yaw]` of node `id`.
    pub fn last_feedback(&self, id: u8) -> Option<[f32; 2]> {
        let id = NodeId::new(id).unwrap();
        self.messages_since(Duration::ZERO)
            .iter()
            .rev()
            .find_map(|m| match m {
                Message::Feedback(f) if f.node == id => {
                    Some([f.axes[0].position, f.axes[1].position])
                }
                _ => None,
            })
    }

    pub fn state_of(&self, id: u8) -> NodeState {
        self.robot.node(id).unwrap().state()
    }
}
