//! The second line: what the joints do, not what their drives say.
//!
//! Every family's liveness rests on the drives' own word (heartbeats,
//! states, feedback frames arriving). A copier that replays a dead joint's
//! last feedback frame after each SYNC, with heartbeats whose counter
//! advances, passes all of it; so does a half-dead node whose CAN task
//! answers while its control task is gone, and an MIT drive that left
//! motor mode on its own (the protocol cannot say so). What none of them
//! can fake is a joint that follows its setpoints. So, per joint and axis,
//! while the drives follow setpoints (Ready, Swimming, Stopping):
//!
//! - **Tracking error.** |measured − commanded| beyond [`TRACKING_BAND`]
//!   on every fresh feedback for [`TRACKING_TIME`] is a fault. The
//!   commanded angle is the setpoint of the period the feedback answers
//!   (the last one sent).
//! - **Frozen feedback.** Feedback that arrives fresh (a new frame, not the
//!   last one kept) and is the same, bit for bit (position, velocity,
//!   torque), for [`FROZEN_TIME`] while the setpoints moved the axis by
//!   [`FROZEN_TRAVEL`] or more is a fault. A real joint commanded to move
//!   never answers the same three numbers twice that long; a replayed
//!   frame always does.
//!
//! Periods without fresh feedback change nothing here: silence is the
//! liveness check's (`control.feedback-timeout`), so a dead joint is named
//! "no feedback", not "frozen". The monitor judges only periods that
//! follow a period of setpoints; any other period resets it.
//!
//! The thresholds come from the healthy built-in robot (`tests/tests/
//! liveness.rs`, `healthy_tracking_error_of_every_family`): see
//! [`TRACKING_BAND`]. Nothing here allocates after [`Tracking::new`].

use anguilla_ipc::vocabulary::Nanos;
use anguilla_protocol::message::{AxisFeedback, AxisSetpoint, NodeId, NodeSet};

/// The largest |measured − commanded| angle (rad) a healthy joint shows:
/// beyond it for [`TRACKING_TIME`], a fault. The healthy built-in robot
/// (the swimming body's loads, each family's servo), swimming at full
/// amplitude at the largest frequency (2 Hz), turn (±2 /m) and pitch (±1
/// /m) its configuration accepts, measured at most (the single worst
/// fresh sample, `healthy_tracking_error_of_every_family`): anguilla
/// 0.050 rad, CiA 402 0.182 (its position comes from the TPDO sampled at
/// the SYNC before: a period more of lag), ODrive 0.066, MIT 0.062. The
/// band is 1.65 times the worst of them, and must also hold for
/// [`TRACKING_TIME`] without a fresh sample back inside it, which a
/// healthy joint's lag (its error peaks once per half cycle) never does.
/// A joint limp or jammed where its setpoints swing or bend it by more
/// than this is caught; one that barely moves is caught by the frozen
/// check if its feedback is a copy, and otherwise not (a limit).
pub const TRACKING_BAND: f64 = 0.3;

/// How long the tracking error must stay beyond [`TRACKING_BAND`] (ns):
/// longer than a healthy joint's lag can hold an error (its peaks last a
/// fraction of a half cycle), short enough that a jammed joint at a 1 Hz
/// gait swinging 0.15 rad beyond the band stays out that long each cycle.
pub const TRACKING_TIME: Nanos = Nanos::from_millis(250);

/// How long fresh feedback must stay the same, bit for bit, while the
/// setpoints move ([`FROZEN_TRAVEL`]) before it is a fault (ns).
pub const FROZEN_TIME: Nanos = Nanos::from_millis(200);

/// How far (rad, summed over the periods) the setpoints must move an axis
/// while its feedback stays the same for it to count as frozen: 100 times
/// the anguilla protocol's position step (1/2000 rad), so a joint held
/// still, or moved less than its encoder resolves, never counts.
pub const FROZEN_TRAVEL: f64 = 0.05;

/// One axis's watch.
#[derive(Debug, Clone, Copy, Default)]
struct Axis {
    /// Since when the error is beyond the band (fresh feedback only).
    over_since: Option<Nanos>,
    /// The last fresh feedback, bit for bit.
    last: Option<[u32; 3]>,
    /// When it was first seen.
    same_since: Nanos,
    /// How far the setpoints moved the axis since.
    travel: f64,
    /// The last judged setpoint.
    last_command: Option<f32>,
}

/// What one period of the monitor found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TrackingReport {
    /// Joints (report ids) beyond the tracking band for the tracking time.
    pub tracking: NodeSet,
    /// Joints whose fresh feedback stayed the same while commanded to move.
    pub frozen: NodeSet,
}

/// One joint's inputs for a period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointSample {
    /// The setpoints of the period the feedback answers, `[pitch, yaw]`.
    pub commanded: [AxisSetpoint; 2],
    /// The drives' latest feedback, `[pitch, yaw]`.
    pub feedback: Option<[AxisFeedback; 2]>,
    /// Periods since each axis's feedback arrived (0: fresh).
    pub feedback_age: [u32; 2],
}

/// Every joint's watch.
#[derive(Debug, Clone)]
pub struct Tracking {
    axes: Vec<[Axis; 2]>,
    worst: f64,
}

fn bits(f: &AxisFeedback) -> [u32; 3] {
    [
        f.position.to_bits(),
        f.velocity.to_bits(),
        f.torque.to_bits(),
    ]
}

impl Tracking {
    /// The watch of `joints` joints.
    pub fn new(joints: usize) -> Self {
        Self {
            axes: vec![[Axis::default(); 2]; joints],
            worst: 0.0,
        }
    }

    /// The largest tracking error (rad) seen on fresh feedback in a judged
    /// period since the start (the figure [`TRACKING_BAND`] is set from).
    pub fn worst(&self) -> f64 {
        self.worst
    }

    /// Forgets every axis's watch (a period not judged).
    pub fn rest(&mut self) {
        for a in self.axes.iter_mut().flatten() {
            *a = Axis::default();
        }
    }

    /// One judged period at `now`: `joint(j)` is joint `j`'s sample; the
    /// joints' report ids are `j + 1` for the bought families and `ids`
    /// in joint order for anguilla (`id(j)`).
    pub fn judge(
        &mut self,
        now: Nanos,
        joint: impl Fn(usize) -> JointSample,
        id: impl Fn(usize) -> Option<NodeId>,
    ) -> TrackingReport {
        let mut r = TrackingReport::default();
        for (j, axes) in self.axes.iter_mut().enumerate() {
            let s = joint(j);
            for (ax, a) in axes.iter_mut().enumerate() {
                let cmd = s.commanded[ax].position;
                a.travel += a.last_command.map_or(0.0, |c| f64::from((cmd - c).abs()));
                a.last_command = Some(cmd);
                let Some(fb) = s.feedback.map(|f| f[ax]) else {
                    continue;
                };
                if s.feedback_age[ax] != 0 {
                    continue;
                }
                let error = f64::from((fb.position - cmd).abs());
                self.worst = self.worst.max(error);
                if error > TRACKING_BAND {
                    a.over_since.get_or_insert(now);
                } else {
                    a.over_since = None;
                }
                let b = bits(&fb);
                if a.last != Some(b) {
                    a.last = Some(b);
                    a.same_since = now;
                    a.travel = 0.0;
                }
                let Some(id) = id(j) else { continue };
                if a.over_since
                    .is_some_and(|t| now.saturating_sub(t) >= TRACKING_TIME)
                {
                    r.tracking = r.tracking.with(id);
                }
                if now.saturating_sub(a.same_since) >= FROZEN_TIME && a.travel >= FROZEN_TRAVEL {
                    r.frozen = r.frozen.with(id);
                }
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = Nanos::from_millis(1);

    fn id(j: usize) -> Option<NodeId> {
        NodeId::new(j as u8 + 1).ok()
    }

    fn sample(cmd: f32, measured: f32, age: u32) -> JointSample {
        let sp = AxisSetpoint {
            position: cmd,
            ..Default::default()
        };
        let fb = AxisFeedback {
            position: measured,
            ..Default::default()
        };
        JointSample {
            commanded: [sp; 2],
            feedback: Some([fb; 2]),
            feedback_age: [age; 2],
        }
    }

    /// A joint swinging ±0.3 rad at 1 Hz (10 ms periods) that follows 40 ms
    /// late; `fb` says what joint 2 measures at time `t` (s) of the swing.
    fn run(fb: impl Fn(f64) -> (f32, u32), seconds: f64) -> (TrackingReport, f64) {
        let mut t = Tracking::new(2);
        let mut last = TrackingReport::default();
        for k in 0..(seconds * 100.0) as u64 {
            let s = k as f64 * 0.01;
            let cmd = |s: f64| (0.3 * (std::f64::consts::TAU * s).sin()) as f32;
            let (m, age) = fb(s);
            last = t.judge(
                k * 10 * MS,
                |j| {
                    if j == 1 {
                        sample(cmd(s), m, age)
                    } else {
                        sample(cmd(s), cmd(s - 0.04), 0)
                    }
                },
                id,
            );
            if last != TrackingReport::default() {
                break;
            }
        }
        (last, t.worst())
    }

    #[test]
    fn a_joint_that_follows_late_is_no_fault() {
        let (r, worst) = run(
            |s| ((0.3 * (std::f64::consts::TAU * (s - 0.04)).sin()) as f32, 0),
            5.0,
        );
        assert_eq!(r, TrackingReport::default());
        // 0.3 × 2π × 0.04 = 0.075 rad at most.
        assert!(worst > 0.05 && worst < 0.08, "{worst}");
    }

    #[test]
    fn a_limp_joint_beyond_the_band_is_a_tracking_fault_naming_it() {
        // Hangs near -0.3 rad (its encoder still reads: not frozen), up to
        // 0.6 rad from the command, beyond 0.3 rad for 0.5 s each cycle.
        let (r, _) = run(|s| ((-0.3 + 1e-3 * (37.0 * s).sin()) as f32, 0), 5.0);
        assert_eq!(r.tracking, NodeSet::empty().with(NodeId::new(2).unwrap()));
    }

    #[test]
    fn a_copied_frame_is_frozen_even_within_the_band() {
        // The joint died near zero; its last frame replayed on each SYNC.
        let (r, _) = run(
            |s| {
                if s < 1.0 {
                    ((0.3 * (std::f64::consts::TAU * (s - 0.04)).sin()) as f32, 0)
                } else {
                    (0.01, 0)
                }
            },
            5.0,
        );
        assert_eq!(r.frozen, NodeSet::empty().with(NodeId::new(2).unwrap()));
        assert!(r.tracking.is_empty(), "within the band");
    }

    #[test]
    fn silence_is_not_frozen_and_a_still_joint_is_not_either() {
        // No fresh feedback after 1 s: neutral (the liveness check's).
        let follow = |s: f64| (0.3 * (std::f64::consts::TAU * (s - 0.04)).sin()) as f32;
        let (r, _) = run(|s| if s < 1.0 { (follow(s), 0) } else { (0.01, 1) }, 5.0);
        assert_eq!(r, TrackingReport::default());
        // Commanded still: the same feedback for ever is no fault.
        let mut t = Tracking::new(1);
        for k in 0..500u64 {
            let r = t.judge(k * 10 * MS, |_| sample(0.1, 0.1, 0), id);
            assert_eq!(r, TrackingReport::default());
        }
    }
}
