//! One joint axis of a vertebra: motor, gearbox, servo loop and sensors.
//!
//! The servo is a position loop with velocity and torque feedforward,
//! `τ_cmd = kp (θ* − θ) + kd (ω* − ω) + τ_ff`, saturated in torque and
//! slowed near the speed limit; the motor's torque follows `τ_cmd` through a
//! first-order lag (the current loop); the joint obeys
//! `J θ̈ = τ + τ_stop − τ_load − b ω`, where `τ_load` is the torque the
//! swimming body demands at this joint and `τ_stop` the joint's mechanical
//! end stops' (a stiff spring and damper beyond `±travel`, pushing back
//! only: a limp joint under a steady load comes to rest there instead of
//! folding the body through itself). The encoder quantizes and may add noise. An
//! *ideal* axis follows its setpoint exactly (used to check the plant
//! against the model with perfect servos).

use crate::rng::Rng;

/// Parameters of one axis; defaults describe a small waterproof servo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorParams {
    /// Position gain (N·m/rad).
    pub kp: f64,
    /// Velocity gain (N·m·s/rad).
    pub kd: f64,
    /// Torque saturation (N·m).
    pub torque_limit: f64,
    /// No-load speed (rad/s): available torque falls linearly to zero there.
    pub speed_limit: f64,
    /// Time constant of the torque (current) loop (s).
    pub torque_lag: f64,
    /// Reflected inertia of motor and gearbox (kg·m²).
    pub inertia: f64,
    /// Viscous friction (N·m·s/rad).
    pub damping: f64,
    /// Encoder resolution (rad per count).
    pub encoder_resolution: f64,
    /// Standard deviation of encoder noise (rad).
    pub encoder_noise: f64,
    /// Follow setpoints exactly, with no dynamics.
    pub ideal: bool,
    /// The joint's mechanical end stops, at `±travel` (rad; infinite:
    /// none). Beyond the daemon's largest angle limit (`limits.angle`,
    /// 1.5 rad at most), so that only a joint nobody servos reaches them.
    pub travel: f64,
    /// Stiffness of an end stop (N·m/rad).
    pub stop_stiffness: f64,
    /// Damping of an end stop (N·m·s/rad), while in contact.
    pub stop_damping: f64,
}

impl ActuatorParams {
    /// The torque the end stops put on the joint at angle `theta` (rad)
    /// and velocity `omega` (rad/s): zero within `±travel`; beyond, the
    /// stop's spring and damper, pushing the joint back only (a stop does
    /// not pull a joint leaving it).
    pub fn stop_torque(&self, theta: f64, omega: f64) -> f64 {
        let over = if theta > self.travel {
            theta - self.travel
        } else if theta < -self.travel {
            theta + self.travel
        } else {
            return 0.0;
        };
        let t = -self.stop_stiffness * over - self.stop_damping * omega;
        if over > 0.0 { t.min(0.0) } else { t.max(0.0) }
    }
}

impl Default for ActuatorParams {
    fn default() -> Self {
        Self {
            kp: 40.0,
            kd: 1.2,
            torque_limit: 4.0,
            speed_limit: 8.0,
            torque_lag: 0.002,
            inertia: 0.02,
            damping: 0.05,
            encoder_resolution: 2.0 * core::f64::consts::PI / 4096.0,
            encoder_noise: 0.0,
            ideal: false,
            // a quarter turn either way; stiff against the servo (five
            // times its kp: a 0.5 N·m load sinks 2.5 mrad into it) and
            // damped critically for the reflected inertia alone, more
            // softly with the body's
            travel: core::f64::consts::FRAC_PI_2,
            stop_stiffness: 200.0,
            stop_damping: 4.0,
        }
    }
}

/// What the swimming body asks of an axis until the next physics step
/// (the simulated robot's plant sets it once a step: `Plant::coupled_loads`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Load {
    /// The torque the body demands at the joint now (N·m).
    pub torque: f64,
    /// How much of a change of the axis's own net torque (motor less
    /// friction) the body takes up at once (0..1; the body's implicit
    /// coupling's diagonal; 0: none).
    pub gain: f64,
    /// How fast the demand changes otherwise (N·m/s): the body's motion and
    /// the other axes' torques, followed within the step instead of held.
    pub rate: f64,
}

/// What the axis is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drive {
    /// Zero torque.
    Limp,
    /// Windings shorted: strong viscous braking, no position control.
    Brake,
    /// Servo to a setpoint (position rad, velocity rad/s, torque N·m).
    Servo {
        /// Position (rad).
        position: f64,
        /// Velocity feedforward (rad/s).
        velocity: f64,
        /// Torque feedforward (N·m).
        torque: f64,
    },
}

/// Faults that can be injected into an axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisFaults {
    /// The joint is jammed: it does not move, whatever the torque.
    pub stuck: bool,
    /// Torque saturates at this lower value (N·m), if set.
    pub torque_cap: Option<f64>,
    /// Extra encoder noise (rad, standard deviation).
    pub extra_noise: f64,
    /// One reading offset by this much (rad), then cleared.
    pub spike: f64,
    /// An external torque on the joint (N·m), added to the body's load: a
    /// snag. The drive supplies it; what it takes of the motor's torque
    /// does not reach the body (the robot passes it to the body's coupling
    /// with the friction).
    pub snag: f64,
}

/// The state of one axis.
#[derive(Debug, Clone)]
pub struct Actuator {
    params: ActuatorParams,
    /// Joint angle (rad).
    theta: f64,
    /// Joint velocity (rad/s).
    omega: f64,
    /// Joint acceleration over the last step (rad/s²).
    alpha: f64,
    /// Motor torque (N·m).
    tau: f64,
    faults: AxisFaults,
    saturated: bool,
    /// The body's load ([`Actuator::set_load`]).
    load: Load,
    /// The net torque the load was computed with.
    load_ref: f64,
    /// Seconds since the load was set.
    load_age: f64,
}

impl Actuator {
    /// An axis at rest at angle 0.
    pub fn new(params: ActuatorParams) -> Self {
        Self {
            params,
            theta: 0.0,
            omega: 0.0,
            alpha: 0.0,
            tau: 0.0,
            faults: AxisFaults::default(),
            saturated: false,
            load: Load::default(),
            load_ref: 0.0,
            load_age: 0.0,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }

    /// Mutable access to the injected faults.
    pub fn faults_mut(&mut self) -> &mut AxisFaults {
        &mut self.faults
    }

    /// True angle (rad), velocity (rad/s), acceleration (rad/s²).
    pub fn kinematics(&self) -> (f64, f64, f64) {
        (self.theta, self.omega, self.alpha)
    }

    /// Motor torque (N·m).
    pub fn torque(&self) -> f64 {
        self.tau
    }

    /// Whether the torque hit its limit during the last step.
    pub fn saturated(&self) -> bool {
        self.saturated
    }

    /// What the encoder reads now (quantized, with noise and spikes).
    pub fn measure(&mut self, rng: &mut Rng) -> f64 {
        let p = &self.params;
        let sigma = p.encoder_noise + self.faults.extra_noise;
        let noise = if sigma > 0.0 {
            sigma * rng.normal()
        } else {
            0.0
        };
        let spike = core::mem::take(&mut self.faults.spike);
        let raw = self.theta + noise + spike;
        if p.encoder_resolution > 0.0 {
            (raw / p.encoder_resolution).round() * p.encoder_resolution
        } else {
            raw
        }
    }

    /// The body's load from now on, computed with the axis's net torque
    /// (motor less friction) as it is now. The simulated robot's plant
    /// computes it once per physics step; within the step (the servo's
    /// steps are finer) it takes up `gain` of the axis's own torque's
    /// changes at once and follows `rate` otherwise, instead of being
    /// held. A gain outside 0..1 is clamped; a torque, gain or rate that
    /// is not finite is taken as 0 (the plant zeroes its loads when the
    /// model fails, and sets the next ones afresh).
    pub fn set_load(&mut self, load: Load) {
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        self.load = Load {
            torque: finite(load.torque),
            gain: finite(load.gain).clamp(0.0, 1.0),
            rate: finite(load.rate),
        };
        self.load_ref = self.tau + self.params.stop_torque(self.theta, self.omega)
            - self.params.damping * self.omega;
        self.load_age = 0.0;
    }

    /// The body's load as last set.
    pub fn load(&self) -> Load {
        self.load
    }

    /// Advances by `dt` seconds under `drive`, against the body's load
    /// ([`Actuator::set_load`]).
    pub fn step(&mut self, dt: f64, drive: Drive) {
        // the load at the step's middle
        let load =
            self.load.torque + self.load.rate * (self.load_age + 0.5 * dt) + self.faults.snag;
        self.load_age += dt;
        let p = self.params;
        let omega0 = self.omega;
        if self.faults.stuck {
            self.omega = 0.0;
            self.alpha = 0.0;
            self.tau = 0.0;
            return;
        }
        if p.ideal {
            match drive {
                Drive::Servo {
                    position,
                    velocity,
                    torque: _,
                } => {
                    self.theta = position;
                    self.omega = velocity;
                    self.tau = load;
                }
                Drive::Limp | Drive::Brake => {
                    self.omega = 0.0;
                    self.tau = 0.0;
                }
            }
            self.alpha = (self.omega - omega0) / dt;
            return;
        }
        if drive == Drive::Limp {
            // Power stage off: no current, no torque, at once.
            self.tau = 0.0;
        }
        let limit = self
            .faults
            .torque_cap
            .unwrap_or(p.torque_limit)
            .min(p.torque_limit);
        let cmd = match drive {
            Drive::Limp => 0.0,
            Drive::Brake => -10.0 * p.kd * self.omega,
            Drive::Servo {
                position,
                velocity,
                torque,
            } => p.kp * (position - self.theta) + p.kd * (velocity - self.omega) + torque,
        };
        // Torque-speed curve: the torque available in the direction of
        // motion falls to zero at the no-load speed.
        let speed_frac = (self.omega.abs() / p.speed_limit).min(1.0);
        let avail = if cmd * self.omega > 0.0 {
            limit * (1.0 - speed_frac)
        } else {
            limit
        };
        let sat = cmd.clamp(-avail, avail);
        self.saturated = sat != cmd;
        // First-order lag, exact for a constant command over dt.
        let k = if drive == Drive::Limp {
            1.0
        } else if p.torque_lag > 0.0 {
            1.0 - (-dt / p.torque_lag).exp()
        } else {
            1.0
        };
        self.tau += k * (sat - self.tau);
        let net = self.tau + p.stop_torque(self.theta, self.omega) - p.damping * self.omega;
        let load = load + self.load.gain * (net - self.load_ref);
        let acc = (net - load) / p.inertia;
        // Semi-implicit Euler.
        self.omega += acc * dt;
        self.theta += self.omega * dt;
        self.alpha = (self.omega - omega0) / dt;
    }

    /// Sets the state directly (used when a simulation starts from a pose).
    pub fn set_state(&mut self, theta: f64, omega: f64) {
        self.theta = theta;
        self.omega = omega;
        self.alpha = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(a: &mut Actuator, drive: Drive, load: f64, seconds: f64) {
        let dt = 2.5e-4;
        let l = a.load();
        a.set_load(Load { torque: load, ..l });
        for _ in 0..(seconds / dt) as usize {
            a.step(dt, drive);
        }
    }

    #[test]
    fn servo_settles_on_its_setpoint() {
        let mut a = Actuator::new(ActuatorParams::default());
        let sp = Drive::Servo {
            position: 0.3,
            velocity: 0.0,
            torque: 0.0,
        };
        run(&mut a, sp, 0.0, 1.0);
        let (th, om, _) = a.kinematics();
        assert!((th - 0.3).abs() < 1e-3, "{th}");
        assert!(om.abs() < 1e-2);
    }

    #[test]
    fn torque_feedforward_cancels_a_known_load() {
        let p = ActuatorParams::default();
        let sp = |ff| Drive::Servo {
            position: 0.0,
            velocity: 0.0,
            torque: ff,
        };
        let mut without = Actuator::new(p);
        run(&mut without, sp(0.0), 1.0, 1.0);
        let mut with = Actuator::new(p);
        run(&mut with, sp(1.0), 1.0, 1.0);
        // Without feedforward the error is load/kp = 25 mrad.
        assert!((without.kinematics().0 + 1.0 / p.kp).abs() < 1e-3);
        assert!(with.kinematics().0.abs() < 1e-4);
    }

    #[test]
    fn saturation_and_limp() {
        let p = ActuatorParams::default();
        let mut a = Actuator::new(p);
        a.faults_mut().torque_cap = Some(0.5);
        // A load beyond the cap drags the joint away.
        run(
            &mut a,
            Drive::Servo {
                position: 0.0,
                velocity: 0.0,
                torque: 0.0,
            },
            1.0,
            0.2,
        );
        assert!(a.saturated());
        assert!(a.kinematics().0 < -0.05);
        let mut l = Actuator::new(p);
        run(&mut l, Drive::Limp, 0.2, 0.1);
        assert!(l.torque().abs() < 1e-12);
        assert!(l.kinematics().1 < 0.0, "a limp joint yields to its load");
    }

    /// The reflected inertia alone: no servo, no lag, no friction.
    fn bare() -> ActuatorParams {
        ActuatorParams {
            kp: 0.0,
            kd: 0.0,
            torque_lag: 0.0,
            damping: 0.0,
            ..ActuatorParams::default()
        }
    }

    #[test]
    fn a_coupled_load_takes_up_its_share_of_the_axis_torque() {
        // no servo, no lag, no friction: a pure torque of 1 N·m on the
        // reflected inertia alone accelerates it at 1/J; with half of the
        // torque's change taken up by the body's load (its coupling's
        // diagonal 0.5), at half that
        let p = bare();
        let push = Drive::Servo {
            position: 0.0,
            velocity: 0.0,
            torque: 1.0,
        };
        let mut held = Actuator::new(p);
        run(&mut held, push, 0.0, 0.1);
        let mut coupled = Actuator::new(p);
        coupled.set_load(Load {
            gain: 0.5,
            ..Load::default()
        });
        run(&mut coupled, push, 0.0, 0.1);
        let rate = |a: &Actuator| a.kinematics().1;
        assert!(
            (rate(&held) - 0.1 / p.inertia).abs() < 1e-6,
            "{}",
            rate(&held)
        );
        assert!(
            (rate(&coupled) - 0.05 / p.inertia).abs() < 1e-6,
            "{}",
            rate(&coupled)
        );
        // a gain beyond 0..1 (or not finite) is clamped: never a load that
        // pushes with the motor
        let mut odd = Actuator::new(p);
        odd.set_load(Load {
            gain: f64::NAN,
            rate: f64::INFINITY,
            ..Load::default()
        });
        run(&mut odd, push, 0.0, 0.1);
        assert!((rate(&odd) - rate(&held)).abs() < 1e-9);
    }

    #[test]
    fn a_load_is_followed_along_its_rate_within_the_step() {
        // a load rising at 2 N·m/s from zero on the bare inertia: after T
        // the axis turns back at -r T² / (2 J), as if the load had been
        // set every servo step (held, it would not move at all)
        let p = bare();
        let (r, t) = (2.0, 0.002);
        let mut a = Actuator::new(p);
        a.set_load(Load {
            rate: r,
            ..Load::default()
        });
        for _ in 0..8 {
            a.step(t / 8.0, Drive::Limp);
        }
        let want = -r * t * t / (2.0 * p.inertia);
        let got = a.kinematics().1;
        assert!((got - want).abs() < 1e-9 * want.abs(), "{got} {want}");
        // set again: the ramp starts again from the new torque
        a.set_load(Load::default());
        a.step(t / 8.0, Drive::Limp);
        assert!((a.kinematics().1 - got).abs() < 1e-12);
    }

    #[test]
    fn a_limp_joint_under_a_load_rests_on_its_end_stop() {
        // a steady 0.5 N·m on a limp axis (a snag on a disabled joint):
        // without end stops it turned on without bound (-6.33 rad after
        // 1 s, at -9.18 rad/s towards the friction's terminal 10 rad/s);
        // it rests on the stop, sunk load / stiffness into it
        let p = ActuatorParams::default();
        let mut a = Actuator::new(p);
        run(&mut a, Drive::Limp, 0.5, 1.0);
        let (th, om, _) = a.kinematics();
        let rest = -p.travel - 0.5 / p.stop_stiffness;
        assert!((th - rest).abs() < 1e-3, "{th} (rest {rest})");
        assert!(om.abs() < 1e-3, "{om}");
        // the servo brings it back from there, the stop letting go
        let back = Drive::Servo {
            position: 0.0,
            velocity: 0.0,
            torque: 0.0,
        };
        run(&mut a, back, 0.0, 1.0);
        assert!(a.kinematics().0.abs() < 1e-3, "{:?}", a.kinematics());
        // a stop pushes back only: none within the travel, none pulling a
        // joint that leaves it
        assert_eq!(p.stop_torque(p.travel - 0.1, 5.0), 0.0);
        assert_eq!(p.stop_torque(p.travel + 1e-4, -5.0), 0.0);
        assert!(p.stop_torque(p.travel + 0.01, 0.0) < 0.0);
        assert!(p.stop_torque(-p.travel - 0.01, 0.0) > 0.0);
    }

    #[test]
    fn stuck_joint_does_not_move() {
        let mut a = Actuator::new(ActuatorParams::default());
        a.faults_mut().stuck = true;
        run(
            &mut a,
            Drive::Servo {
                position: 1.0,
                velocity: 0.0,
                torque: 0.0,
            },
            0.0,
            0.5,
        );
        assert_eq!(a.kinematics().0, 0.0);
    }

    #[test]
    fn encoder_quantizes_and_spikes_once() {
        let mut a = Actuator::new(ActuatorParams::default());
        a.set_state(0.1234567, 0.0);
        let mut rng = Rng::new(1);
        let res = ActuatorParams::default().encoder_resolution;
        let m = a.measure(&mut rng);
        assert!((m - 0.1234567).abs() <= res / 2.0 + 1e-12);
        assert!(((m / res).round() * res - m).abs() < 1e-12);
        a.faults_mut().spike = 0.5;
        assert!((a.measure(&mut rng) - 0.6234567).abs() <= res);
        assert!((a.measure(&mut rng) - 0.1234567).abs() <= res);
    }
}
