//! Steps 1 to 5 of [`Controller::run_period`]: the bus drained, the
//! supervisor's decision, the gait's targets followed, the model's step and
//! the setpoints limited (steps 6 and 7, the frames and the snapshot, are
//! [`Controller::run_period`]'s and `snapshot.rs`'s).

use anguilla_drivers::{Bus, BusState};
use anguilla_ipc::vocabulary::{Cause, GuideState, Hold, Mode, Nanos, PositionHealth, SwimParams};
use anguilla_model::{CurvatureSource, GaitParams, HeadState, ModelError, StepReport};
use anguilla_protocol::message::{self, AxisSetpoint, NodeSet};

use super::{Controller, STILL_PERIOD};
use crate::drive::Out;
use crate::nav::Prediction;
use crate::session::Record;
use crate::supervisor::{Directives, Drive, Observations};
use crate::tracking::{JointSample, TrackingReport};

/// Plausibility limits of the model's predictions for a 1 m robot: beyond
/// them the model is taken as diverged (`docs/safety.md`: "model
/// diverged" faults the robot). The fastest anguilliform swimmers manage about 2 body lengths
/// per second; 5 m/s, 20 rad/s and 1000 m/s² / rad/s² are far outside any
/// gait the configuration allows.
const MAX_PLAUSIBLE_SPEED: f64 = 5.0;
const MAX_PLAUSIBLE_TURN_RATE: f64 = 20.0;
const MAX_PLAUSIBLE_ACCEL: f64 = 1000.0;

fn plausible(r: &StepReport) -> bool {
    r.forward_speed.abs() <= MAX_PLAUSIBLE_SPEED
        && r.turn_rate.abs() <= MAX_PLAUSIBLE_TURN_RATE
        && r.v_dot.norm() <= MAX_PLAUSIBLE_ACCEL
        && r.omega_dot.norm() <= MAX_PLAUSIBLE_ACCEL
}

impl Controller {
    /// The gait has come to rest: the amplitude, turn and pitch settled
    /// at 0, the smoothed gait straight, the posture offsets settled
    /// (the supervisor's `gait_at_rest`).
    fn at_rest(&self) -> bool {
        let p = self.gait.params();
        let small = |x: f64| x.abs() < 1e-3;
        self.amplitude.settled()
            && self.amplitude.target() == 0.0
            && self.turn.settled()
            && self.turn.target() == 0.0
            && self.pitch.settled()
            && self.pitch.target() == 0.0
            && p.amplitude.iter().all(|&a| small(a))
            && small(p.kc2)
            && small(p.kc3)
            && self.offsets.iter().flatten().all(|o| o.settled())
    }

    /// Step 1: everything the drives and the head sensor said since the last
    /// period.
    pub(super) fn ingest(&mut self, now: Nanos, bus: &mut dyn Bus) {
        let drives = &mut self.drives;
        let sensors = &mut self.sensors;
        let (tap, dropped) = (&self.tap, &mut self.tap_dropped);
        // A receive error shows in the bus state the next period reads.
        let _ = bus.drain(&mut |r| {
            if !sensors.ingest(now, &r.frame) {
                drives.ingest(now, &r.frame);
            }
            if let Some(t) = tap
                && t.try_send(Record::Rx(now, r.frame)).is_err()
            {
                *dropped += 1;
            }
        });
    }

    /// Step 2: the estimate, from the model's prediction of now (the last
    /// step's) and the newest sample (a hold ends when its sensor fails);
    /// then the supervisor's decision on what the drives report, with the
    /// E-stop and clear-faults it asks for sent at once.
    pub(super) fn supervise(
        &mut self,
        now: Nanos,
        period_state: BusState,
        bus: &mut dyn Bus,
    ) -> Directives {
        // The model's prediction of the head, for the sensors that use it
        // (none configured: not computed).
        if !self.sensors.is_empty() {
            self.sensors
                .step(now, self.dt, &Prediction::of(&self.head, self.ws.shape()));
        }
        if self.sensors.nav().is_some() {
            let health = self.sensors.head_health();
            if self.sup.observe_sensor(now, health) {
                self.hold_exit = Some(health);
            }
        }
        let report = self.drives.observe(now, &self.liveness);
        // The second line: the feedback of the period just answered against
        // the setpoints sent in it, if setpoints were followed.
        let tracked = if self.setpoints_followed {
            let (drives, setpoints, ids) = (&self.drives, &self.setpoints, &self.report_ids);
            self.tracking.judge(
                now,
                |j| {
                    let jr = drives.joint(j);
                    JointSample {
                        commanded: setpoints[j],
                        feedback: jr.feedback,
                        feedback_age: jr.feedback_age,
                    }
                },
                |j| ids.get(j).copied(),
            )
        } else {
            self.tracking.rest();
            TrackingReport::default()
        };
        let configured = self.drives.report_ids();
        let obs = Observations {
            all_enabled: report.all_enabled,
            heartbeat_lost: report.lost,
            feedback_lost: report.silent,
            duplicate_id: report.duplicate,
            all_lost: !configured.is_empty() && report.lost.covers(configured),
            node_fault: report.fault,
            estop_nodes: report.estop,
            booting: report.booting,
            disabled: report.disabled,
            tracking_error: tracked.tracking,
            feedback_frozen: tracked.frozen,
            bus_estop: self.drives.take_bus_estop(),
            foreign_command: self.drives.take_foreign_command(),
            bus_off: period_state == BusState::BusOff,
            bus_gone: period_state == BusState::Gone,
            model_diverged: self.model_failed,
            gait_at_rest: self.at_rest(),
        };
        let d = self.sup.tick(now, &obs);
        self.setpoints_followed = d.drive == Drive::Setpoints
            && matches!(
                self.sup.mode(),
                Mode::Ready | Mode::Swimming | Mode::Stopping
            );
        // In Fault, setpoints go to the nodes still answering only.
        self.setpoint_skip = if self.sup.mode() == Mode::Fault {
            report.lost.union(report.silent)
        } else {
            NodeSet::empty()
        };
        let mut out = out!(self, &mut *bus);
        if d.send_estop {
            self.drives.estop(&mut out);
        }
        if d.send_clear_faults {
            self.drives.clear_faults(&mut out);
            self.model_failed = false;
            self.head = HeadState::launch(0.0);
        }
        d
    }

    /// Step 3, first half: the path. The estimate leaving the geofence
    /// stops any swim; a path followed sets the heading (and depth) held,
    /// ends when the swim does, and stops the swim at its last waypoint
    /// or when the position fix is lost (holding the last heading).
    pub(super) fn guide(&mut self, now: Nanos, d: &mut Directives) {
        let Some(nav) = self.sensors.nav().filter(|n| n.has_estimate()) else {
            self.guidance.end(GuideState::Interrupted);
            return;
        };
        let plane = nav.plane();
        let at = plane.position();
        let swimming = self.sup.mode() == Mode::Swimming;
        if self.guidance.left_fence(at.0, at.1) && swimming {
            self.guidance.end(GuideState::Fence);
            self.sup.stop_for(now, Cause::Fence, d.hold);
            return;
        }
        if !self.guidance.following() {
            return;
        }
        if !swimming {
            self.guidance.end(GuideState::Interrupted);
            return;
        }
        let last = Hold {
            heading: Some(self.guidance.heading()),
            depth: self.guidance.depth().or(d.hold.depth),
        };
        if plane.health() == PositionHealth::Lost {
            self.guidance.end(GuideState::FixLost);
            self.sup.stop_for(now, Cause::FixLost, last);
            d.hold = last;
            return;
        }
        // The speed through the water: the model's, scaled by how far
        // fixes found it off.
        let (current, speed) = (
            plane.current(),
            self.report.forward_speed * plane.speed_scale(),
        );
        match self.guidance.steer(self.dt, at, current, speed) {
            Some(s) => {
                d.hold.heading = Some(s.heading);
                if s.depth.is_some() {
                    d.hold.depth = s.depth;
                }
            }
            None => {
                self.sup.stop_for(now, Cause::PathDone, last);
                d.hold = last;
            }
        }
    }

    /// Step 3: the autopilot's turn and pitch where it holds; the gait
    /// parameters along trapezoidal profiles. Returns the target and where
    /// the profiles are: amplitude, frequency, turn and pitch.
    pub(super) fn follow_targets(&mut self, d: &Directives, mode: Mode) -> (SwimParams, [f64; 4]) {
        let mut target = d.gait_target;
        if let (Some(ap), Some(nav)) = (&mut self.autopilot, self.sensors.nav()) {
            [target.turn, target.pitch] = ap.steer(
                self.dt,
                &d.hold,
                &nav.estimate(),
                self.report.forward_speed,
                [target.turn, target.pitch],
                self.turn.state().position,
                [
                    self.amplitude.state().position,
                    self.frequency.state().position,
                ],
            );
            self.hold_states = ap.judge(
                self.dt,
                &d.hold,
                &nav.estimate(),
                mode == Mode::Swimming && nav.has_estimate(),
            );
        } else {
            self.hold_states = [anguilla_ipc::HoldState::Off; 2];
        }
        self.hold = d.hold;
        let _ = self.amplitude.set_target(target.amplitude);
        if mode == Mode::Swimming {
            let _ = self.frequency.set_target(target.frequency);
        }
        let _ = self.turn.set_target(target.turn);
        let _ = self.pitch.set_target(target.pitch);
        let a = self.amplitude.advance(self.dt).position;
        let f = self.frequency.advance(self.dt).position;
        let kc3 = self.turn.advance(self.dt).position;
        let kc2 = self.pitch.advance(self.dt).position;
        let poly = self.cfg.gait.amplitude_polynomial;
        // Validated at start-up; the followers keep every field finite and
        // the period positive, so this cannot fail.
        let _ = self.gait.set_target(&GaitParams {
            wavelength: self.cfg.gait.wavelength,
            period: if f > 1.0 / STILL_PERIOD {
                1.0 / f
            } else {
                STILL_PERIOD
            },
            amplitude: [poly[0] * a, poly[1] * a, poly[2] * a],
            phase: 0.0,
            // The operator's turn is positive to the left (a positive yaw
            // rate about e3, which points up); a positive K_c3 turns the
            // body to the right (the paper's T1: K_c3 = 2 ends at -88°).
            kc3: -kc3,
            kc2,
        });
        (target, [a, f, kc3, kc2])
    }

    /// Step 4: the model's forward + inverse dynamics step; a failed or
    /// implausible one leaves the gait's angles without dynamics.
    pub(super) fn step_model(&mut self) {
        let step =
            anguilla_model::step_dyn(&self.model, &mut self.ws, &mut self.gait, &mut self.head)
                .and_then(|r| {
                    if plausible(&r) {
                        Ok(r)
                    } else {
                        Err(ModelError::Diverged {
                            quantity: "predicted head motion (beyond plausibility limits)",
                            time: r.t,
                        })
                    }
                });
        match step {
            Ok(r) => self.report = r,
            Err(e) => {
                self.model_failed = true;
                self.last_model_error = Some(e);
                self.counters.model_failures += 1;
                // Joint angles of the gait without dynamics.
                anguilla_model::posture(&self.model, &mut self.ws, &self.gait);
                self.gait.advance(self.dt);
                self.head = HeadState::launch(0.0);
            }
        }
    }

    /// The posture offsets: on entering Ready from Enabling, straighten
    /// from where the joints are.
    pub(super) fn straighten_on_ready(&mut self, mode: Mode) {
        if self.mode_before == Mode::Enabling && mode == Mode::Ready {
            for (j, off) in self.offsets.iter_mut().enumerate() {
                if let Some(fb) = self.drives.joint(j).feedback {
                    for (o, axis) in off.iter_mut().zip(fb) {
                        o.reset(axis.position as f64);
                        let _ = o.set_target(0.0);
                    }
                }
            }
        }
    }

    /// Step 5: every joint's setpoint: the model's angle, rate and feedforward
    /// plus the posture offset, clamped (and counted) to the limits; an
    /// angle no further out than the posture offset is not clamped (a joint
    /// enabled beyond its limit is brought back along the profile).
    pub(super) fn limit_setpoints(&mut self, drop_feedforward: bool) {
        let lim = &self.cfg.limits;
        let m = &self.cfg.model;
        let pmax = lim.angle.min(message::POSITION_LIMIT);
        let vmax = lim.velocity.min(message::VELOCITY_LIMIT);
        let tmax = lim.torque.min(message::TORQUE_LIMIT);
        let mut clamped = 0u64;
        let mut clamp = |v: f64, m: f64| {
            let c = v.clamp(-m, m);
            if c != v {
                clamped += 1;
            }
            c
        };
        for (j, js) in self
            .ws
            .joints()
            .iter()
            .enumerate()
            .take(self.setpoints.len())
        {
            let off = &mut self.offsets[j];
            let o = [off[0].advance(self.dt), off[1].advance(self.dt)];
            // the model's torque and the drives' own terms ([model]
            // drive-*, as `anguilla calibrate` fits them): J θ̈ + b θ̇, and
            // the torque as measured `lag` late, τ(t − lag) ≈ τ − lag τ̇
            let tq = js.actuator_torque();
            let rate = [js.pitch_rate, js.yaw_rate];
            let prev = &mut self.ff_prev[j];
            let mut ff = tq;
            if self.ff_primed {
                for ax in 0..2 {
                    let acc = (rate[ax] - prev[ax]) / self.dt;
                    let tq_rate = (tq[ax] - prev[2 + ax]) / self.dt;
                    ff[ax] +=
                        m.drive_inertia * acc + m.drive_friction * rate[ax] - m.drive_lag * tq_rate;
                }
            }
            *prev = [rate[0], rate[1], tq[0], tq[1]];
            if drop_feedforward || !ff.iter().all(|v| v.is_finite()) {
                ff = [0.0, 0.0];
            }
            self.torque_ff[j] = ff;
            let ang = [js.pitch + o[0].position, js.yaw + o[1].position];
            let vel = [js.pitch_rate + o[0].velocity, js.yaw_rate + o[1].velocity];
            for ax in 0..2 {
                // A joint left limp beyond its limit is held where it was
                // and brought back along its posture offset, never stepped
                // to the limit: the bound widens to where the offset still
                // is (it only moves towards straight; docs/safety.md).
                let bound = pmax.max(o[ax].position.abs()).min(message::POSITION_LIMIT);
                self.setpoints[j][ax] = AxisSetpoint {
                    position: clamp(ang[ax], bound) as f32,
                    velocity: clamp(vel[ax], vmax) as f32,
                    torque: clamp(ff[ax], tmax) as f32,
                };
            }
        }
        self.counters.clamped += clamped;
        self.ff_primed = true;
    }
}
