//! The controller's snapshot, filled once a period (step 7 of
//! [`Controller::run_period`](super::Controller::run_period)): mode,
//! faults, gait, bus, the sensors, and per joint the setpoints, the
//! drives' reports and the torque residual.

use anguilla_drivers::Bus;
use anguilla_ipc::vocabulary::SwimParams;
use anguilla_ipc::{GaitSnapshot, JointSnapshot, MAX_JOINTS, Mode};
use anguilla_protocol::time::Nanos;

use super::Controller;

impl Controller {
    pub(super) fn fill_snapshot(
        &mut self,
        now: Nanos,
        bus: &dyn Bus,
        bus_state: u8,
        target: &SwimParams,
        actual: [f64; 4],
        ff_dropped: bool,
    ) {
        let s = &mut self.snapshot;
        s.sequence += 1;
        s.time_ns = now.saturating_sub(self.started).as_nanos();
        s.mode = self.sup.mode() as u8;
        s.cause = self.sup.cause().code();
        s.feedforward_dropped = ff_dropped as u8;
        let faults = self.sup.faults();
        s.fault_kinds = faults.kinds;
        s.fault_nodes = faults.nodes;
        s.set_holder(self.sup.holder());
        s.predicted_head_speed = self.report.forward_speed as f32;
        s.predicted_turn_rate = self.report.turn_rate as f32;
        s.gait_target = GaitSnapshot::from(*target);
        s.gait_actual = GaitSnapshot {
            amplitude: actual[0] as f32,
            frequency: actual[1] as f32,
            turn: actual[2] as f32,
            pitch: actual[3] as f32,
        };
        let c = bus.counters();
        s.bus.tx_frames = c.tx;
        s.bus.rx_frames = c.rx;
        s.bus.tx_dropped = c.tx_dropped;
        s.bus.malformed = self.drives.counters().malformed;
        s.bus.errors = c.errors;
        s.bus.rx_overruns = c.rx_overruns;
        s.bus.bus_off_count = c.bus_off_count as u32;
        // The state the supervisor acted on this period.
        s.bus.state = bus_state;
        s.clamped_setpoints = self.counters.clamped;
        s.refused_commands = self.counters.refused;
        s.records_lost = self.tap_dropped;
        s.operator_silent_stops = self.sup.operator_silent_count();
        self.sensors.fill(&mut s.sensors);
        if let Some(nav) = self.sensors.nav() {
            nav.fill(&mut s.nav);
        }
        s.nav.hold = self.hold.bits();
        s.nav.heading_target_deg = self.hold.heading.unwrap_or(0.0) as f32;
        s.nav.depth_target_m = self.hold.depth.unwrap_or(0.0) as f32;
        s.nav.hold_exit = self.hold_exit.map_or(0, |h| h as u8);
        [s.nav.heading_hold, s.nav.depth_hold] = self.hold_states.map(|h| h as u8);
        self.guidance.fill(&mut s.guide);
        let hb_timeout = Nanos::from_secs_f64(self.cfg.control.heartbeat_timeout);
        // The torque residual is judged while swimming on the model's
        // feed-forward, with drives that measure torque.
        let judge =
            self.sup.mode() == Mode::Swimming && !ff_dropped && self.drives.measures_torque();
        let k = self.residual.gain(self.dt);
        for j in 0..self.joints.min(MAX_JOINTS) {
            let e = self.drives.joint(j);
            let js = &mut s.joints[j];
            let sp = &self.setpoints[j];
            js.commanded_pitch = sp[0].position;
            js.commanded_yaw = sp[1].position;
            js.commanded_pitch_velocity = sp[0].velocity;
            js.commanded_yaw_velocity = sp[1].velocity;
            js.predicted_pitch_torque = self.torque_ff[j][0] as f32;
            js.predicted_yaw_torque = self.torque_ff[j][1] as f32;
            if let Some(fb) = e.feedback {
                js.measured_pitch = fb[0].position;
                js.measured_yaw = fb[1].position;
                js.measured_pitch_velocity = fb[0].velocity;
                js.measured_yaw_velocity = fb[1].velocity;
                js.measured_pitch_torque = fb[0].torque;
                js.measured_yaw_torque = fb[1].torque;
            }
            js.node_state = e.state.map_or(JointSnapshot::NO_NODE_STATE, |s| s as u8);
            js.node_alive =
                e.last_heard
                    .is_some_and(|t| now.saturating_sub(t) <= hb_timeout) as u8;
            js.node_errors = e.errors;
            for axis in 0..2 {
                let measured = e
                    .feedback
                    .filter(|_| judge)
                    .map(|fb| fb[axis].torque as f64);
                self.residual
                    .update(now, k, j, axis, measured, self.torque_ff[j][axis]);
            }
            js.pitch_torque_residual = self.residual.residual(j, 0) as f32;
            js.yaw_torque_residual = self.residual.residual(j, 1) as f32;
            use anguilla_ipc::residual_bits as rb;
            js.residual_alarm = [(0, rb::PITCH, rb::PITCH_BELOW), (1, rb::YAW, rb::YAW_BELOW)]
                .into_iter()
                .map(|(axis, on, below)| match self.residual.alarm(j, axis) {
                    0 => 0,
                    a if a < 0 => on | below,
                    _ => on,
                })
                .fold(0, |bits, b| bits | b);
        }
    }
}
