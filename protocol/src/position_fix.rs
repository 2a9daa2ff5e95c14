//! The sentences of sensors that are not on the CAN bus: how a position
//! sensor (a USBL's topside unit, a motion-capture bridge) hands the daemon
//! a fix, and a DVL its velocity over ground, over UDP (one sentence a
//! datagram) or a serial line (one a line).
//!
//! ```text
//! $ANFIX,<x>,<y>,<sigma>[,<age>]*HH
//! $ANVEL,<vx>,<vy>,<sigma>*HH
//! ```
//!
//! - `x`, `y`: where the robot's nose is (m), in the estimate's local
//!   frame: x and y level, z up, the origin where the estimate started (a
//!   sensor whose frame differs is moved by `[sensor.usbl] offset`);
//! - `vx`, `vy`: the robot's velocity over ground (m/s), in the same frame
//!   (a DVL with its own heading reference, its earth-referenced output,
//!   turned by `[sensor.dvl] rotation`); a DVL without bottom lock sends
//!   none;
//! - `sigma`: the fix's horizontal standard deviation (m), or the
//!   velocity's per axis (m/s), > 0;
//! - `age` (optional): how old the fix was when the sentence was sent (s,
//!   0 ..= 60): a bridge that knows each fix's own time stamp (the ROS 2
//!   node's `pose_fix`, a motion-capture system's) says it, a sensor with a
//!   constant delay leaves it out;
//! - `HH`: the NMEA 0183 checksum, two hexadecimal digits: the XOR of the
//!   bytes between `$` and `*`.
//!
//! A trailing `\r\n` (or `\n`) is allowed. The time of the fix is its
//! arrival less the sensor's configured latency (`[sensor.usbl] latency`:
//! the sensor's constant delay, or a bridge's transport) less its `age`.
//!
//! ```
//! use anguilla_protocol::position_fix::{Fix, parse};
//! let f = Fix { x: 1.5, y: -2.25, sigma: 0.5, age: 0.0 };
//! let line = f.sentence();
//! assert_eq!(line, "$ANFIX,1.5,-2.25,0.5*43\r\n");
//! assert_eq!(parse(line.as_bytes()), Ok(f));
//! let aged = Fix { age: 0.125, ..f };
//! assert_eq!(parse(aged.sentence().as_bytes()), Ok(aged));
//! ```

use std::fmt;

/// The position fix's start, up to its first field.
pub const TALKER: &str = "$ANFIX";
/// The velocity's start, up to its first field.
pub const VELOCITY_TALKER: &str = "$ANVEL";
/// The longest sentence accepted (bytes, line end included).
pub const MAX_LEN: usize = 96;

/// One position fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fix {
    /// x (m), local frame.
    pub x: f64,
    /// y (m), local frame.
    pub y: f64,
    /// Horizontal standard deviation (m).
    pub sigma: f64,
    /// How old the fix was when sent (s; 0: not said, the sensor's
    /// configured latency alone applies).
    pub age: f64,
}

/// The oldest `age` a fix may say (s).
pub const MAX_AGE: f64 = 60.0;

impl Fix {
    /// The sentence, checksum and `\r\n` included (the age only when > 0).
    pub fn sentence(&self) -> String {
        let fields = [self.x, self.y, self.sigma, self.age];
        sentence(TALKER, &fields[..if self.age > 0.0 { 4 } else { 3 }])
    }
}

/// One velocity over ground (a DVL's, bottom-locked).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Velocity {
    /// x (m/s), local frame.
    pub vx: f64,
    /// y (m/s), local frame.
    pub vy: f64,
    /// Standard deviation per axis (m/s).
    pub sigma: f64,
}

impl Velocity {
    /// The sentence, checksum and `\r\n` included.
    pub fn sentence(&self) -> String {
        sentence(VELOCITY_TALKER, &[self.vx, self.vy, self.sigma])
    }
}

fn sentence(talker: &str, fields: &[f64]) -> String {
    let mut body = talker[1..].to_string();
    for v in fields {
        body.push_str(&format!(",{v}"));
    }
    format!("${body}*{:02X}\r\n", checksum(body.as_bytes()))
}

/// Why a sentence is not a fix.
#[derive(Debug, Clone, PartialEq)]
pub enum FixError {
    /// Longer than [`MAX_LEN`] bytes.
    TooLong(usize),
    /// Not the sentence expected (`$ANFIX,` or `$ANVEL,`).
    NotAFix(&'static str),
    /// No `*HH` checksum at the end.
    NoChecksum,
    /// The checksum does not match the sentence.
    Checksum {
        /// What the sentence says.
        sent: u8,
        /// What its bytes give.
        computed: u8,
    },
    /// Not the number of fields expected: three (`$ANFIX` also four).
    Fields(usize),
    /// A field that is not a finite number (or a sigma that is not > 0,
    /// an age not in 0 ..= [`MAX_AGE`]).
    Field {
        /// `x`, `y`, `sigma` or `age`.
        name: &'static str,
        /// The field as sent (lossy UTF-8, cut at 24 bytes).
        text: String,
    },
}

impl fmt::Display for FixError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FixError::TooLong(n) => write!(f, "sentence of {n} bytes (at most {MAX_LEN})"),
            FixError::NotAFix(talker) => {
                write!(f, "not a {talker} sentence (expected \"{talker},\")")
            }
            FixError::NoChecksum => write!(f, "no checksum (expected \"*HH\" at the end)"),
            FixError::Checksum { sent, computed } => write!(
                f,
                "checksum {sent:02X} does not match the sentence's {computed:02X}"
            ),
            FixError::Fields(n) => write!(
                f,
                "{n} fields (expected 3: x or vx, y or vy, sigma; a fix may add a 4th, its age)"
            ),
            FixError::Field { name, text } => {
                let what = match *name {
                    "sigma" => "a number > 0",
                    "age" => "seconds, 0 ..= 60",
                    _ => "a finite number",
                };
                write!(f, "{name} = \"{text}\" (expected {what})")
            }
        }
    }
}

impl std::error::Error for FixError {}

/// The NMEA 0183 checksum of `bytes` (XOR of every byte).
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |a, b| a ^ b)
}

/// Reads one position fix (one datagram, or one line of a serial stream).
pub fn parse(line: &[u8]) -> Result<Fix, FixError> {
    let [x, y, sigma, age] = fields(line, TALKER, ["x", "y", "sigma", "age"])?;
    Ok(Fix { x, y, sigma, age })
}

/// Reads one velocity over ground.
pub fn parse_velocity(line: &[u8]) -> Result<Velocity, FixError> {
    let [vx, vy, sigma, _] = fields(line, VELOCITY_TALKER, ["vx", "vy", "sigma", ""])?;
    Ok(Velocity { vx, vy, sigma })
}

/// The numbers of a `talker` sentence, named `names` in errors: three,
/// and a fourth (0 when absent) where `names[3]` is not empty.
fn fields(
    line: &[u8],
    talker: &'static str,
    names: [&'static str; 4],
) -> Result<[f64; 4], FixError> {
    if line.len() > MAX_LEN {
        return Err(FixError::TooLong(line.len()));
    }
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let Some(rest) = line.strip_prefix(talker.as_bytes()) else {
        return Err(FixError::NotAFix(talker));
    };
    if rest.first() != Some(&b',') {
        return Err(FixError::NotAFix(talker));
    }
    let star = line.len().checked_sub(3).filter(|&i| line[i] == b'*');
    let Some(star) = star else {
        return Err(FixError::NoChecksum);
    };
    let hex = std::str::from_utf8(&line[star + 1..]).ok();
    let Some(sent) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) else {
        return Err(FixError::NoChecksum);
    };
    let body = &line[1..star];
    let computed = checksum(body);
    if sent != computed {
        return Err(FixError::Checksum { sent, computed });
    }
    let fields = &body[talker.len()..];
    let n = fields.split(|&b| b == b',').count();
    if !(n == 3 || (n == 4 && !names[3].is_empty())) {
        return Err(FixError::Fields(n));
    }
    let mut it = fields.split(|&b| b == b',');
    let mut next = |name: &'static str| {
        let raw = it.next().unwrap_or_default();
        let v = std::str::from_utf8(raw)
            .ok()
            .and_then(|t| t.parse::<f64>().ok())
            .filter(|v| {
                v.is_finite()
                    && match name {
                        "sigma" => *v > 0.0,
                        "age" => (0.0..=MAX_AGE).contains(v),
                        _ => true,
                    }
            });
        v.ok_or_else(|| FixError::Field {
            name,
            text: String::from_utf8_lossy(&raw[..raw.len().min(24)]).into_owned(),
        })
    };
    let three = [next(names[0])?, next(names[1])?, next(names[2])?];
    let fourth = if n == 4 { next(names[3])? } else { 0.0 };
    Ok([three[0], three[1], three[2], fourth])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_bad_sentence_is_named() {
        let cases: [(&[u8], &str); 10] = [
            (b"$GPGGA,1,2*00", "not a $ANFIX sentence"),
            (b"$ANFIX,1,2,3", "no checksum"),
            (b"$ANFIX,1,2,3*00", "checksum 00 does not match"),
            (b"$ANFIX,1,2*", "no checksum"),
            (b"$ANFIX,1,2*5B", "2 fields"),
            (b"$ANFIX,1,nan,3*17", "y = \"nan\""),
            (b"$ANFIX,1,2,0*47", "sigma = \"0\" (expected a number > 0)"),
            (
                b"$ANFIX,1,2,3,-1*74",
                "age = \"-1\" (expected seconds, 0 ..= 60)",
            ),
            (b"$ANFIX,1,2,3,61*6F", "age = \"61\""),
            (b"$ANFIX,1,2,3,4,5*45", "5 fields"),
        ];
        for (line, want) in cases {
            let e = match parse(line) {
                Err(e) => e.to_string(),
                Ok(f) => panic!("{:?} read as {f:?}", String::from_utf8_lossy(line)),
            };
            let body = line.strip_prefix(b"$").unwrap_or(line);
            let body = body.split(|&b| b == b'*').next().unwrap_or_default();
            assert!(
                e.contains(want),
                "{:?} (checksum {:02X}): {e}",
                String::from_utf8_lossy(line),
                checksum(body)
            );
        }
        assert!(matches!(parse(&[b'$'; 200]), Err(FixError::TooLong(200))));
    }

    proptest! {
        #[test]
        fn any_bytes_are_a_fix_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
            let _ = parse(&bytes);
        }

        #[test]
        fn a_fix_reads_back(x in -1e4..1e4f64, y in -1e4..1e4f64, sigma in 1e-3..1e3f64, age in 0.0..60.0f64) {
            let f = Fix { x, y, sigma, age };
            prop_assert_eq!(parse(f.sentence().as_bytes()), Ok(f));
        }

        #[test]
        fn a_velocity_reads_back(vx in -10.0..10.0f64, vy in -10.0..10.0f64, sigma in 1e-4..1.0f64) {
            let v = Velocity { vx, vy, sigma };
            prop_assert_eq!(parse_velocity(v.sentence().as_bytes()), Ok(v));
            // A velocity has no age.
            let aged = format!("ANVEL,{vx},{vy},{sigma},1");
            let aged = format!("${aged}*{:02X}", checksum(aged.as_bytes()));
            prop_assert_eq!(parse_velocity(aged.as_bytes()), Err(FixError::Fields(4)));
            // Neither sentence is taken for the other.
            prop_assert_eq!(parse(v.sentence().as_bytes()), Err(FixError::NotAFix(TALKER)));
        }

        #[test]
        fn any_bytes_are_a_velocity_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
            let _ = parse_velocity(&bytes);
        }
    }
}
