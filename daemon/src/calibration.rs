//! The calibration swim (`anguilla ctl calibrate-swim`, docs/calibration.md):
//! a minute of gaits that excites every coefficient `anguilla calibrate`
//! fits — forward at three frequencies and two amplitudes (lateral drag,
//! skin friction, the nose's drag over a range of speeds), turns both ways
//! (lateral drag again, from another motion), a dive and a climb (vertical
//! drag), and glides with no undulation (the drag alone decelerating the
//! body: skin friction, the nose's drag and added mass).

use anguilla_ipc::vocabulary::SwimParams;

/// One leg: a gait held for a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    /// What it excites, for the operator's screen.
    pub what: &'static str,
    /// How long it is held (s).
    pub seconds: f64,
    /// The gait.
    pub gait: SwimParams,
}

const fn leg(
    what: &'static str,
    seconds: f64,
    amplitude: f64,
    frequency: f64,
    turn: f64,
    pitch: f64,
) -> Leg {
    Leg {
        what,
        seconds,
        gait: SwimParams {
            amplitude,
            frequency,
            turn,
            pitch,
        },
    }
}

/// The legs, in order (59 s). Curvatures are within the default
/// `[gait]` limits (`max-turn` 2, `max-pitch` 1 per metre).
pub const LEGS: [Leg; 10] = [
    leg("forward, 0.6 Hz", 8.0, 1.0, 0.6, 0.0, 0.0),
    leg("forward, 1.2 Hz", 7.0, 1.0, 1.2, 0.0, 0.0),
    leg("glide", 4.0, 0.0, 1.2, 0.0, 0.0),
    leg("forward, half amplitude, 1.0 Hz", 6.0, 0.5, 1.0, 0.0, 0.0),
    leg("turn left", 6.0, 1.0, 1.0, 1.5, 0.0),
    leg("turn right", 6.0, 1.0, 1.0, -1.5, 0.0),
    leg("dive", 5.0, 1.0, 1.0, 0.0, 0.8),
    leg("climb", 5.0, 1.0, 1.0, 0.0, -0.8),
    leg("forward, 1.5 Hz", 7.0, 0.8, 1.5, 0.0, 0.0),
    leg("glide", 5.0, 0.0, 1.5, 0.0, 0.0),
];

/// How far the swim climbs above its start (m): after the climb the
/// straightened body swims on upwards through the 1.5 Hz leg. Open water,
/// no hold: 2.44 m on the paper's body, 2.93 m on one with 30 % more
/// lateral and 30 % less vertical drag (`tests/calibrate.rs`,
/// `the_swim_climbs_less_than_its_documented_climb`).
pub const CLIMB: f64 = 3.0;

/// The shallowest start `ctl calibrate-swim` begins the swim at unless told
/// otherwise (m below the surface): [`CLIMB`] and half a metre. A shallower
/// start surfaces the body mid-swim, whose out-of-water motion the fit does
/// not model (it refuses the torques that come with it).
pub const MIN_START_DEPTH: f64 = 3.5;
const _: () = assert!(MIN_START_DEPTH > CLIMB);

/// The whole swim's duration (s).
pub fn duration() -> f64 {
    LEGS.iter().map(|l| l.seconds).sum()
}
