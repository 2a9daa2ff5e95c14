//! The fault scenario acting on the robot: impostors, floods, timed
//! actions and their undoing.

use anguilla_drivers::{Bus, BusState, Frame};
use anguilla_protocol::Family;
use anguilla_protocol::frame::MAX_STANDARD_ID;
use anguilla_protocol::message::{ErrorBits, FIRST_UNUSED_ID};

use crate::node::Nanos;
use crate::scenario::{Action, BusFault, JointFault, NodeFault};

use super::{Flood, Impostor, SimRobot, Undo};

impl SimRobot {
    /// Heartbeats that the impostors owe at `t`: the family's heartbeat
    /// for the node's id(s), in the state of the node they mirror.
    pub(super) fn impostors_tick(&mut self, t: Nanos) {
        for i in 0..self.impostors.len() {
            let imp = self.impostors[i];
            if t < imp.next {
                continue;
            }
            let state = self.nodes[imp.mirror].state();
            let out = &mut self.out;
            self.nodes[imp.k].impostor_heartbeat(state, imp.counter, &mut |f| out.push(f));
            let imp = &mut self.impostors[i];
            imp.counter = imp.counter.wrapping_add(1);
            imp.next = (imp.next + imp.every).max(t);
        }
    }

    pub(super) fn flood_tick(&mut self) {
        let Some(mut fl) = self.flood else { return };
        let n = if fl.ticks_left <= 1 {
            fl.left
        } else {
            fl.left.div_ceil(fl.ticks_left)
        };
        for _ in 0..n {
            let Some(id) = self.flood_id() else {
                continue;
            };
            let len = (self.rng.next_u64() % 9) as usize;
            let bytes = self.rng.next_u64().to_le_bytes();
            let Ok(frame) = Frame::new_standard(id, &bytes[..len]) else {
                continue;
            };
            match &self.mem {
                // From outside: every participant hears it, the nodes too.
                Some((bus, _)) => bus.inject(&frame),
                None => {
                    if self.bus.send(&frame).is_err() {
                        self.stats.send_errors += 1;
                    }
                }
            }
            self.stats.flood_frames += 1;
        }
        fl.left -= n;
        fl.ticks_left = fl.ticks_left.saturating_sub(1);
        self.flood = (fl.left > 0).then_some(fl);
    }

    /// A random standard id no drive of this robot listens to: for
    /// anguilla FIRST_UNUSED_ID..=0x7FF (not used by the protocol); for the
    /// bought families any id whose node id (ODrive: bits 5..=10; CANopen:
    /// bits 0..=6, node 0 being NMT/SYNC/TIME and 127 the master) is none
    /// of the robot's drives'. `None` if a few draws find none.
    pub(super) fn flood_id(&mut self) -> Option<u16> {
        match self.cfg.drive {
            Family::Anguilla => {
                let unused = u64::from(MAX_STANDARD_ID - FIRST_UNUSED_ID) + 1;
                Some(FIRST_UNUSED_ID + (self.rng.next_u64() % unused) as u16)
            }
            family => (0..16).find_map(|_| {
                let id = (self.rng.next_u64() % (u64::from(MAX_STANDARD_ID) + 1)) as u16;
                let node = family.node_of(id)?;
                let reserved = family == Family::Cia402 && (node == 0 || node == 127);
                (!reserved && !self.drive_ids_used[usize::from(node & 0x7F)]).then_some(id)
            }),
        }
    }

    pub(super) fn apply_events(&mut self, t: Nanos) {
        // Timed ends of earlier faults.
        let mut i = 0;
        while i < self.undo.len() {
            if self.undo[i].0 <= t {
                let (_, u) = self.undo.swap_remove(i);
                match u {
                    Undo::Speak(k) => self.nodes[k].set_silent(false),
                    Undo::BusOn => {
                        if let Some((bus, id)) = &self.mem {
                            bus.force_state(*id, BusState::ErrorActive);
                        }
                    }
                }
            } else {
                i += 1;
            }
        }
        // Actions injected now (never blocks the tick: taken next time if
        // the injector holds the lock).
        let live = self.live.clone();
        if let Ok(mut g) = live.try_lock() {
            for a in g.drain(..) {
                self.stats.events += 1;
                self.apply(a, t);
            }
        }
        while let Some(e) = self.scenario.events.get(self.next_event).copied() {
            let at = self.start + Nanos::from(e.at);
            if at > t {
                break;
            }
            self.next_event += 1;
            self.stats.events += 1;
            self.apply(e.action, at);
        }
    }

    /// Recomputes the servo-body coupling after a joint jammed or freed.
    pub(super) fn recouple(&mut self) {
        if self.cfg.actuator.ideal {
            return;
        }
        let j = self.cfg.actuator.inertia;
        let inertia: Vec<[f64; 2]> = self
            .nodes
            .iter_mut()
            .map(|n| {
                [0, 1].map(|a| {
                    if n.axis_faults_mut(a).stuck {
                        f64::INFINITY
                    } else {
                        j
                    }
                })
            })
            .collect();
        if self.plant.couple_servos(&inertia).is_err() {
            self.stats.model_errors += 1;
        }
    }

    pub(super) fn apply(&mut self, action: Action, at: Nanos) {
        match action {
            Action::Node { id, fault } => {
                let Some(k) = self.cfg.node_ids.iter().position(|&x| x == id) else {
                    return;
                };
                match fault {
                    NodeFault::Silent(d) => {
                        self.nodes[k].set_silent(true);
                        if let Some(d) = d {
                            self.undo.push((at + Nanos::from(d), Undo::Speak(k)));
                        }
                    }
                    NodeFault::Speak => self.nodes[k].set_silent(false),
                    NodeFault::Reboot => self.nodes[k].reboot(at),
                    NodeFault::Fault => {
                        let out = &mut self.out;
                        self.nodes[k]
                            .inject_fault(ErrorBits::OVER_TEMPERATURE, at, &mut |f| out.push(f));
                    }
                    NodeFault::Clear => self.nodes[k].clear_injected_fault(),
                    NodeFault::Spoof => {
                        self.nodes[k].set_silent(true);
                        let mirror = usize::from(k == 0).min(self.nodes.len() - 1);
                        self.impostors.push(Impostor {
                            k,
                            mirror,
                            next: at,
                            every: Nanos::from_millis(50),
                            counter: 0,
                        });
                    }
                    NodeFault::Twin => self.impostors.push(Impostor {
                        k,
                        mirror: k,
                        next: at,
                        every: Nanos::from_millis(
                            anguilla_protocol::message::HEARTBEAT_PERIOD_MS.into(),
                        ),
                        counter: 128,
                    }),
                }
            }
            Action::Joint { joint, axis, fault } => {
                let Some(node) = self.nodes.get_mut(joint.wrapping_sub(1)) else {
                    return;
                };
                let f = node.axis_faults_mut(axis.index());
                match fault {
                    JointFault::Stuck(s) => {
                        f.stuck = s;
                        self.recouple();
                    }
                    JointFault::TorqueLimit(c) => f.torque_cap = c,
                    JointFault::Noise(s) => f.extra_noise = s,
                    JointFault::Spike(s) => f.spike = s,
                    JointFault::Snag(t) => f.snag = t,
                }
            }
            Action::Water(current) => self.plant.set_current(current),
            Action::Sensor(fault) => {
                if let Some(s) = &mut self.sensor {
                    s.apply(fault, at);
                }
            }
            Action::Bus(BusFault::Flood { count, over }) => {
                let ticks = (Nanos::from(over) / self.tick).max(1);
                self.flood = Some(Flood {
                    left: count,
                    ticks_left: ticks,
                });
            }
            Action::Bus(fault) => {
                let Some((bus, id)) = &self.mem else { return };
                match fault {
                    BusFault::Drop(n) => bus.drop_next(n),
                    BusFault::DropFraction(f) => bus.drop_fraction(f, self.rng.next_u64()),
                    BusFault::Delay(d) => bus.set_delay(d),
                    BusFault::Corrupt(n) => bus.corrupt_next(n),
                    BusFault::BusOff(d) => {
                        bus.force_state(*id, BusState::BusOff);
                        self.undo.push((at + Nanos::from(d), Undo::BusOn));
                    }
                    BusFault::Clear => bus.clear_faults(),
                    BusFault::Flood { .. } => {}
                }
            }
        }
    }
}
