//! Property tests of every encode/decode pair, of the decoder on arbitrary
//! frames, and of the codec against the generated DBC text.

use anguilla_protocol::dbc;
use anguilla_protocol::frame::{FD_LENGTHS, Frame, Id};
use anguilla_protocol::message::*;
use proptest::prelude::*;

const NODES: u8 = 12;

/// The head sensor's id in these tests: the one the DBC files list.
fn sensor() -> NodeId {
    NodeId::new(DEFAULT_HEAD_SENSOR_ID).unwrap()
}

/// The ids the tests decode with: the vertebrae and the head sensor.
fn accepted() -> NodeSet {
    NodeSet::first(NODES).with(sensor())
}

fn head_sample() -> impl Strategy<Value = HeadSample> {
    let q = -1f32..=1.0;
    let r = -RATE_LIMIT as f32..=RATE_LIMIT as f32;
    let a = -ACCEL_LIMIT as f32..=ACCEL_LIMIT as f32;
    (
        any::<u8>(),
        [q.clone(), q.clone(), q.clone(), q],
        [r.clone(), r.clone(), r],
        [a.clone(), a.clone(), a],
        0..=common::PRESSURE_MAX,
        -40f32..=85.0,
        0..=SensorStatus::ALL,
        0..=SensorErrors::ALL,
    )
        .prop_map(
            |(sample, quaternion, rates, accel, pressure, temperature, st, er)| HeadSample {
                node: sensor(),
                sample,
                quaternion,
                rates,
                accel,
                pressure,
                temperature,
                status: SensorStatus(st),
                errors: SensorErrors(er),
            },
        )
}

fn node() -> impl Strategy<Value = NodeId> {
    (1..=NODES).prop_map(|n| NodeId::new(n).unwrap())
}

fn target() -> impl Strategy<Value = Target> {
    prop_oneof![Just(Target::All), node().prop_map(Target::Node)]
}

fn axis_sp() -> impl Strategy<Value = AxisSetpoint> {
    (-1.5f32..=1.5, -10f32..=10.0, -5f32..=5.0).prop_map(|(position, velocity, torque)| {
        AxisSetpoint {
            position,
            velocity,
            torque,
        }
    })
}

fn axis_fb() -> impl Strategy<Value = AxisFeedback> {
    (axis_sp(), any::<bool>()).prop_map(|(s, limited)| AxisFeedback {
        position: s.position,
        velocity: s.velocity,
        torque: s.torque,
        limited,
    })
}

fn axis() -> impl Strategy<Value = Axis> {
    prop_oneof![Just(Axis::Pitch), Just(Axis::Yaw)]
}

fn param() -> impl Strategy<Value = ConfigParam> {
    prop_oneof![
        (2u16..=1000).prop_map(|ms| ConfigParam::WatchdogTimeout { ms }),
        prop_oneof![
            Just(SafeAction::Hold),
            Just(SafeAction::Limp),
            Just(SafeAction::Brake)
        ]
        .prop_map(ConfigParam::SafeAction),
        (axis(), -1.5f32..=1.5, -1.5f32..=1.5).prop_map(|(axis, a, b)| {
            ConfigParam::PositionLimits {
                axis,
                min: a.min(b),
                max: a.max(b),
            }
        }),
        (axis(), 0f32..=10.0).prop_map(|(axis, max)| ConfigParam::VelocityLimit { axis, max }),
        (axis(), 0f32..=5.0).prop_map(|(axis, max)| ConfigParam::TorqueLimit { axis, max }),
    ]
}

fn state() -> impl Strategy<Value = NodeState> {
    prop_oneof![
        Just(NodeState::Boot),
        Just(NodeState::Disabled),
        Just(NodeState::Enabled),
        Just(NodeState::Fault),
        Just(NodeState::EStop),
    ]
}

/// Messages valid in both variants.
fn common_message() -> impl Strategy<Value = Message> {
    prop_oneof![
        target().prop_map(Message::EStop),
        any::<u16>().prop_map(|counter| Message::Sync { counter }),
        (
            target(),
            prop_oneof![
                Just(Command::Enable),
                Just(Command::Disable),
                Just(Command::ClearFaults)
            ]
        )
            .prop_map(|(target, command)| Message::Command { target, command }),
        (node(), any::<bool>(), any::<bool>(), axis_fb(), axis_fb()).prop_map(
            |(node, enabled, fault, a, b)| Message::Feedback(Feedback {
                node,
                enabled,
                fault,
                axes: [a, b],
            })
        ),
        (
            node(),
            state(),
            0..=ErrorBits::ALL,
            any::<u8>(),
            any::<u8>(),
            -40i8..=125
        )
            .prop_map(|(node, state, e, counter, missed_syncs, temperature)| {
                Message::Heartbeat(Heartbeat {
                    node,
                    state,
                    errors: ErrorBits(e),
                    counter,
                    missed_syncs,
                    temperature,
                })
            }),
        (node(), param()).prop_map(|(node, param)| Message::ConfigWrite { node, param }),
        (
            node(),
            param(),
            prop_oneof![
                Just(ConfigResult::Accepted),
                Just(ConfigResult::OutOfRange),
                Just(ConfigResult::NotDisabled)
            ]
        )
            .prop_map(|(node, param, result)| Message::ConfigAck {
                node,
                param,
                result
            }),
    ]
}

fn classic_message() -> impl Strategy<Value = Message> {
    prop_oneof![
        common_message(),
        head_sample().prop_map(|h| Message::HeadAttitude(HeadAttitude {
            node: h.node,
            sample: h.sample,
            quaternion: h.quaternion,
        })),
        head_sample().prop_map(|h| Message::HeadRates(HeadVector {
            node: h.node,
            sample: h.sample,
            xyz: h.rates,
        })),
        head_sample().prop_map(|h| Message::HeadAccel(HeadVector {
            node: h.node,
            sample: h.sample,
            xyz: h.accel,
        })),
        head_sample().prop_map(|h| Message::HeadDepth(HeadDepth {
            node: h.node,
            sample: h.sample,
            pressure: h.pressure,
            temperature: h.temperature,
            status: h.status,
            errors: h.errors,
        })),
        (node(), 0u8..16, axis_sp(), axis_sp()).prop_map(|(node, cycle, a, b)| {
            Message::Setpoint(Setpoint {
                node,
                cycle,
                axes: [a, b],
            })
        }),
    ]
}

fn fd_message() -> impl Strategy<Value = Message> {
    let slots = prop::array::uniform6(prop::option::of(
        (axis_sp(), axis_sp()).prop_map(|(a, b)| [a, b]),
    ))
    .prop_filter("at least one slot", |s| s.iter().any(Option::is_some));
    prop_oneof![
        common_message(),
        head_sample().prop_map(Message::HeadSample),
        (0u8..2, any::<u8>(), slots).prop_map(|(group, cycle, slots)| {
            Message::SetpointGroup(SetpointGroup {
                group,
                cycle,
                slots,
            })
        }),
    ]
}

/// Field-wise comparison with the quantization step of `variant` as tolerance
/// (half a count, plus f32 rounding).
fn assert_close(a: &Message, b: &Message, variant: Variant) -> Result<(), TestCaseError> {
    let (pf, vf, tf) = match variant {
        Variant::Classic => (
            classic::POSITION_FACTOR,
            classic::VELOCITY_FACTOR,
            classic::TORQUE_FACTOR,
        ),
        Variant::Fd => (fd::POSITION_FACTOR, fd::VELOCITY_FACTOR, fd::TORQUE_FACTOR),
    };
    let close = |x: f32, y: f32, f: f64| ((x - y).abs() as f64) <= f / 2.0 + 1e-5;
    let sp = |x: &AxisSetpoint, y: &AxisSetpoint| {
        close(x.position, y.position, pf)
            && close(x.velocity, y.velocity, vf)
            && close(x.torque, y.torque, tf)
    };
    // Head sensor: half a count of each field's scale.
    let (qf, rf, af, tpf) = match variant {
        Variant::Classic => (
            classic::HEAD_QUATERNION[0].factor,
            classic::HEAD_RATES[0].factor,
            classic::HEAD_ACCEL[0].factor,
            classic::HEAD_TEMPERATURE.factor,
        ),
        Variant::Fd => (
            fd::HEAD_QUATERNION[0].factor,
            fd::HEAD_RATES[0].factor,
            fd::HEAD_ACCEL[0].factor,
            fd::HEAD_TEMPERATURE.factor,
        ),
    };
    let all = |x: &[f32], y: &[f32], f: f64| x.iter().zip(y).all(|(p, q)| close(*p, *q, f));
    let ok = match (a, b) {
        (Message::HeadAttitude(x), Message::HeadAttitude(y)) => {
            x.node == y.node && x.sample == y.sample && all(&x.quaternion, &y.quaternion, qf)
        }
        (Message::HeadRates(x), Message::HeadRates(y)) => {
            x.node == y.node && x.sample == y.sample && all(&x.xyz, &y.xyz, rf)
        }
        (Message::HeadAccel(x), Message::HeadAccel(y)) => {
            x.node == y.node && x.sample == y.sample && all(&x.xyz, &y.xyz, af)
        }
        (Message::HeadDepth(x), Message::HeadDepth(y)) => {
            x.node == y.node
                && x.sample == y.sample
                && x.pressure == y.pressure
                && close(x.temperature, y.temperature, tpf)
                && x.status == y.status
                && x.errors == y.errors
        }
        (Message::HeadSample(x), Message::HeadSample(y)) => {
            x.node == y.node
                && x.sample == y.sample
                && all(&x.quaternion, &y.quaternion, qf)
                && all(&x.rates, &y.rates, rf)
                && all(&x.accel, &y.accel, af)
                && x.pressure == y.pressure
                && close(x.temperature, y.temperature, tpf)
                && x.status == y.status
                && x.errors == y.errors
        }
        (Message::Setpoint(x), Message::Setpoint(y)) => {
            x.node == y.node
                && x.cycle == y.cycle
                && x.axes.iter().zip(&y.axes).all(|(p, q)| sp(p, q))
        }
        (Message::SetpointGroup(x), Message::SetpointGroup(y)) => {
            x.group == y.group
                && x.cycle == y.cycle
                && x.slots.iter().zip(&y.slots).all(|(p, q)| match (p, q) {
                    (None, None) => true,
                    (Some(p), Some(q)) => sp(&p[0], &q[0]) && sp(&p[1], &q[1]),
                    _ => false,
                })
        }
        (Message::Feedback(x), Message::Feedback(y)) => {
            x.node == y.node
                && x.enabled == y.enabled
                && x.fault == y.fault
                && x.axes.iter().zip(&y.axes).all(|(p, q)| {
                    p.limited == q.limited
                        && close(p.position, q.position, pf)
                        && close(p.velocity, q.velocity, vf)
                        && close(p.torque, q.torque, tf)
                })
        }
        (
            Message::ConfigWrite { node: n, param: p },
            Message::ConfigWrite { node: m, param: q },
        )
        | (
            Message::ConfigAck {
                node: n, param: p, ..
            },
            Message::ConfigAck {
                node: m, param: q, ..
            },
        ) => {
            n == m
                && match (p, q) {
                    (
                        ConfigParam::PositionLimits { axis, min, max },
                        ConfigParam::PositionLimits {
                            axis: a2,
                            min: n2,
                            max: x2,
                        },
                    ) => axis == a2 && close(*min, *n2, 1e-4) && close(*max, *x2, 1e-4),
                    (
                        ConfigParam::VelocityLimit { axis, max },
                        ConfigParam::VelocityLimit { axis: a2, max: m2 },
                    )
                    | (
                        ConfigParam::TorqueLimit { axis, max },
                        ConfigParam::TorqueLimit { axis: a2, max: m2 },
                    ) => axis == a2 && close(*max, *m2, 1e-3),
                    _ => p == q,
                }
                && match (a, b) {
                    (
                        Message::ConfigAck { result: r, .. },
                        Message::ConfigAck { result: s, .. },
                    ) => r == s,
                    _ => true,
                }
        }
        _ => a == b,
    };
    prop_assert!(ok, "{a:?} != {b:?}");
    Ok(())
}

fn roundtrip(m: Message, variant: Variant) -> Result<(), TestCaseError> {
    let f = m.encode(variant).unwrap();
    prop_assert!(f.id().raw() <= 0x7FF && !f.id().is_extended());
    prop_assert_eq!(f.is_fd(), variant == Variant::Fd);
    let back = decode(&f, variant, accepted()).unwrap();
    assert_close(&m, &back, variant)?;
    // Decoding is exact: re-encoding the decoded message gives the same frame.
    prop_assert_eq!(back.encode(variant).unwrap(), f);
    // Unknown nodes are rejected (every message but SYNC and broadcasts
    // names a node).
    let other = decode(&f, variant, NodeSet::empty());
    match m {
        Message::Sync { .. } | Message::EStop(Target::All) => prop_assert!(other.is_ok()),
        Message::Command {
            target: Target::All,
            ..
        } => prop_assert!(other.is_ok()),
        _ => prop_assert!(
            matches!(other, Err(DecodeError::UnknownNode { .. })),
            "{other:?}"
        ),
    }
    // The other variant does not accept it.
    let wrong = if variant == Variant::Classic {
        Variant::Fd
    } else {
        Variant::Classic
    };
    prop_assert!(decode(&f, wrong, NodeSet::all()).is_err());
    Ok(())
}

/// One signal line of a DBC file, parsed independently of the codec.
#[derive(Debug)]
struct DbcSignal {
    name: String,
    mux: Option<u8>,
    start: usize,
    len: usize,
    signed: bool,
    factor: f64,
    min: f64,
    max: f64,
}

fn dbc_message(text: &str, id: u16) -> (usize, Vec<DbcSignal>) {
    let mut lines = text
        .lines()
        .skip_while(|l| !l.starts_with(&format!("BO_ {id} ")));
    let head = lines.next().unwrap_or_else(|| panic!("id {id} not in DBC"));
    let len: usize = head.split_whitespace().nth(3).unwrap().parse().unwrap();
    let sigs = lines
        .take_while(|l| l.starts_with(" SG_ "))
        .map(|l| {
            let (left, right) = l.split_once(" : ").unwrap();
            let mut w = left.split_whitespace().skip(1);
            let name = w.next().unwrap().to_string();
            let mux = w
                .next()
                .and_then(|m| m.strip_prefix('m'))
                .map(|v| v.parse().unwrap());
            let (layout, rest) = right.split_once(' ').unwrap();
            let (start, rest2) = layout.split_once('|').unwrap();
            let (len, enc) = rest2.split_once('@').unwrap();
            let scale = rest.split_once('(').unwrap().1.split_once(')').unwrap().0;
            let range = rest.split_once('[').unwrap().1.split_once(']').unwrap().0;
            let (min, max) = range.split_once('|').unwrap();
            DbcSignal {
                name,
                mux,
                start: start.parse().unwrap(),
                len: len.parse().unwrap(),
                signed: enc == "1-",
                factor: scale.split_once(',').unwrap().0.parse().unwrap(),
                min: min.parse().unwrap(),
                max: max.parse().unwrap(),
            }
        })
        .collect();
    (len, sigs)
}

/// Physical value of a DBC signal in `data`, by a bit loop independent of
/// the crate's `Signal::get`.
fn dbc_value(s: &DbcSignal, data: &[u8]) -> f64 {
    let mut raw: i64 = 0;
    for i in (0..s.len).rev() {
        let pos = s.start + i;
        raw = raw << 1 | ((data[pos / 8] >> (pos % 8)) & 1) as i64;
    }
    if s.signed && raw >= 1 << (s.len - 1) {
        raw -= 1 << s.len;
    }
    raw as f64 * s.factor
}

/// The value the message should show for a DBC signal name.
fn expected(m: &Message, name: &str) -> Option<f64> {
    let axis_idx = |n: &str| if n.starts_with("Pitch") { 0 } else { 1 };
    match m {
        Message::Sync { counter } => Some(*counter as f64),
        Message::Setpoint(s) => {
            let a = &s.axes[axis_idx(name)];
            Some(match name {
                "Cycle" => s.cycle as f64,
                n if n.ends_with("Position") => a.position as f64,
                n if n.ends_with("Velocity") => a.velocity as f64,
                _ => a.torque as f64,
            })
        }
        Message::SetpointGroup(g) => {
            if name == "Cycle" {
                return Some(g.cycle as f64);
            }
            if name == "SlotMask" {
                let m: u8 = g
                    .slots
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (s.is_some() as u8) << i)
                    .sum();
                return Some(m as f64);
            }
            let (slot, field) = name.strip_prefix('S')?.split_once('_')?;
            let slot: usize = slot.parse().ok()?;
            let a = g.slots[slot]?[axis_idx(field)];
            Some(if field.ends_with("Position") {
                a.position as f64
            } else if field.ends_with("Velocity") {
                a.velocity as f64
            } else {
                a.torque as f64
            })
        }
        Message::Feedback(f) => Some(match name {
            "Enabled" => f.enabled as u8 as f64,
            "Fault" => f.fault as u8 as f64,
            "PitchLimited" => f.axes[0].limited as u8 as f64,
            "YawLimited" => f.axes[1].limited as u8 as f64,
            n => {
                let a = &f.axes[axis_idx(n)];
                if n.ends_with("Position") {
                    a.position as f64
                } else if n.ends_with("Velocity") {
                    a.velocity as f64
                } else {
                    a.torque as f64
                }
            }
        }),
        Message::Heartbeat(h) => Some(match name {
            "State" => h.state as u8 as f64,
            "Errors" => h.errors.0 as f64,
            "Counter" => h.counter as f64,
            "MissedSyncs" => h.missed_syncs as f64,
            _ => h.temperature as f64,
        }),
        Message::HeadAttitude(h) => quat_field(&h.quaternion, name).or(Some(h.sample as f64)),
        Message::HeadRates(h) | Message::HeadAccel(h) => Some(match name {
            "Sample" => h.sample as f64,
            n if n.ends_with('X') => h.xyz[0] as f64,
            n if n.ends_with('Y') => h.xyz[1] as f64,
            _ => h.xyz[2] as f64,
        }),
        Message::HeadDepth(h) => depth_field(
            h.sample,
            h.pressure,
            h.temperature,
            h.status,
            h.errors,
            name,
        ),
        Message::HeadSample(h) => {
            let xyz = |v: &[f32; 3]| match name.chars().last() {
                Some('X') => Some(v[0] as f64),
                Some('Y') => Some(v[1] as f64),
                Some('Z') => Some(v[2] as f64),
                _ => None,
            };
            if name.starts_with("Quat") {
                quat_field(&h.quaternion, name)
            } else if name.starts_with("Rate") {
                xyz(&h.rates)
            } else if name.starts_with("Accel") {
                xyz(&h.accel)
            } else {
                depth_field(
                    h.sample,
                    h.pressure,
                    h.temperature,
                    h.status,
                    h.errors,
                    name,
                )
            }
        }
        _ => None,
    }
}

fn quat_field(q: &[f32; 4], name: &str) -> Option<f64> {
    Some(match name {
        "QuatW" => q[0],
        "QuatX" => q[1],
        "QuatY" => q[2],
        "QuatZ" => q[3],
        _ => return None,
    } as f64)
}

fn depth_field(
    sample: u8,
    pressure: u32,
    temperature: f32,
    status: SensorStatus,
    errors: SensorErrors,
    name: &str,
) -> Option<f64> {
    Some(match name {
        "Sample" => sample as f64,
        "Pressure" => pressure as f64,
        "WaterTemperature" => temperature as f64,
        "Status" => status.0 as f64,
        "Errors" => errors.0 as f64,
        _ => return None,
    })
}

fn check_against_dbc(m: Message, variant: Variant, text: &str) -> Result<(), TestCaseError> {
    let f = m.encode(variant).unwrap();
    let (len, sigs) = dbc_message(text, f.id().raw() as u16);
    // A setpoint group may be shorter than the DBC's full 64 bytes.
    prop_assert!(f.len() <= len);
    let mut data = [0u8; 64];
    data[..f.len()].copy_from_slice(f.data());
    let decoded = decode(&f, variant, accepted()).unwrap();
    for s in sigs.iter().filter(|s| s.mux.is_none()) {
        let Some(want) = expected(&decoded, &s.name) else {
            continue;
        };
        let got = dbc_value(s, &data);
        // The codec's values are f32 (relative precision 6e-8): 1e-6 of the
        // value, at least 1e-6 absolute (head accelerations reach 160).
        prop_assert!(
            (got - want).abs() < 1e-6 * want.abs().max(1.0),
            "{} {}: dbc {got} codec {want}",
            f,
            s.name
        );
        prop_assert!(
            got >= s.min - 1e-9 && got <= s.max + 1e-9,
            "{} outside DBC range",
            s.name
        );
    }
    Ok(())
}

proptest! {
    #[test]
    fn classic_roundtrip(m in classic_message()) {
        roundtrip(m, Variant::Classic)?;
    }

    #[test]
    fn fd_roundtrip(m in fd_message()) {
        roundtrip(m, Variant::Fd)?;
    }

    #[test]
    fn classic_codec_agrees_with_dbc(m in classic_message()) {
        thread_local!(static TEXT: String = dbc::generate(Variant::Classic, NODES));
        TEXT.with(|t| check_against_dbc(m, Variant::Classic, t))?;
    }

    #[test]
    fn fd_codec_agrees_with_dbc(m in fd_message()) {
        thread_local!(static TEXT: String = dbc::generate(Variant::Fd, NODES));
        TEXT.with(|t| check_against_dbc(m, Variant::Fd, t))?;
    }

    /// Any frame: decoding returns a value or an error, never panics, and
    /// whatever decodes re-encodes to the same identifier and bytes.
    #[test]
    fn arbitrary_frames_decode_or_error(
        id in prop_oneof![0u32..0x3C0, 0u32..0x800, 0u32..0x2000_0000],
        extended: bool,
        kind in 0u8..3,
        data in prop::collection::vec(any::<u8>(), 64),
        len_idx in 0usize..16,
        classic_len in 0usize..=8,
    ) {
        let id = if extended { Id::extended(id).unwrap() } else { Id::standard((id & 0x7FF) as u16).unwrap() };
        let frame = match kind {
            0 => Frame::new(id, &data[..classic_len]).unwrap(),
            1 => Frame::new_remote(id, classic_len as u8).unwrap(),
            _ => Frame::new_fd(id, &data[..FD_LENGTHS[len_idx] as usize], true).unwrap(),
        };
        for variant in [Variant::Classic, Variant::Fd] {
            if let Ok(m) = decode(&frame, variant, NodeSet::all()) {
                let again = m.encode(variant).unwrap();
                prop_assert_eq!(again.id(), frame.id());
                prop_assert_eq!(again.data(), frame.data());
            }
        }
    }

    /// Values beyond a signal's range by more than half a count do not
    /// encode (within half a count they round to the limit: the classic
    /// velocity is 8 bits, 10/127 rad/s a count, so 10.001 rad/s is 127).
    #[test]
    fn out_of_range_values_do_not_encode(node in node(), over in 1.01f32..100.0, neg: bool) {
        let v = if neg { -over } else { over };
        let sp = |position, velocity, torque| Message::Setpoint(Setpoint {
            node, cycle: 0, axes: [AxisSetpoint { position, velocity, torque }; 2],
        });
        let e = sp(v * 1.5, 0.0, 0.0).encode(Variant::Classic);
        prop_assert!(matches!(e, Err(EncodeError::ValueOutOfRange { signal: "PitchPosition", .. })), "{e:?}");
        prop_assert!(sp(0.0, v * 10.0, 0.0).encode(Variant::Classic).is_err());
        prop_assert!(sp(0.0, 0.0, v * 5.0).encode(Variant::Classic).is_err());
    }
}

#[test]
fn ids_follow_the_priority_order() {
    let n = NodeId::new(3).unwrap();
    let id = |m: Message, v| m.encode(v).unwrap().id().raw();
    let c = Variant::Classic;
    assert_eq!(id(Message::EStop(Target::All), c), 0x000);
    assert_eq!(id(Message::EStop(Target::Node(n)), c), 0x003);
    assert_eq!(id(Message::Sync { counter: 1 }, c), 0x040);
    assert_eq!(
        id(
            Message::Command {
                target: Target::Node(n),
                command: Command::Enable
            },
            c
        ),
        0x083
    );
    let sp = Setpoint {
        node: n,
        cycle: 0,
        axes: [AxisSetpoint::default(); 2],
    };
    assert_eq!(id(Message::Setpoint(sp), c), 0x0C3);
    // Every E-stop id beats SYNC, SYNC beats every other message.
    for n in 0..=63 {
        assert!(Function::EStop.id(n) < Function::Sync.id(0));
    }
    for f in &Function::ALL[2..] {
        assert!(f.id(0) > Function::Sync.id(63));
    }
}

#[test]
fn decode_errors_say_what_was_wrong() {
    let nodes = NodeSet::first(12);
    let c = Variant::Classic;
    let f = |id: u16, d: &[u8]| Frame::new_standard(id, d).unwrap();
    assert_eq!(
        decode(&f(0x7FF, &[]), c, nodes),
        Err(DecodeError::UnknownId(0x7FF))
    );
    assert_eq!(
        decode(&f(0x041, &[0, 0]), c, nodes),
        Err(DecodeError::UnknownId(0x041))
    );
    assert_eq!(
        decode(&f(0x040, &[0]), c, nodes),
        Err(DecodeError::WrongLength {
            message: "Sync",
            len: 1,
            expected: 2
        })
    );
    assert_eq!(
        decode(&f(0x0CD, &[0; 8]), c, nodes),
        Err(DecodeError::UnknownNode {
            message: "Setpoint",
            node: 13
        })
    );
    assert_eq!(
        decode(&f(0x100, &[0; 8]), c, nodes),
        Err(DecodeError::UnknownId(0x100)),
        "setpoint groups are CAN FD only"
    );
    // Position raw 0x1FFF = 8191 counts = 1.638 rad > 1.5.
    let e = decode(&f(0x0C1, &[0xF0, 0xFF, 1, 0, 0, 0, 0, 0]), c, nodes).unwrap_err();
    assert!(
        matches!(
            e,
            DecodeError::ValueOutOfRange {
                signal: "PitchPosition",
                raw: 8191,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("expected -7500..=7500"), "{e}");
    assert_eq!(
        decode(&f(0x081, &[9]), c, nodes).unwrap_err().to_string(),
        "Command.Command raw value 9 is out of range (expected 1..=3)"
    );
    // Reserved bits of the FD feedback must be zero.
    let mut d = [0u8; 12];
    d[0] = 0x10;
    let fd = Frame::new_fd(Id::standard_literal(0x141), &d, true).unwrap();
    assert_eq!(
        decode(&fd, Variant::Fd, nodes),
        Err(DecodeError::ReservedBits {
            message: "Feedback",
            byte: 0
        })
    );
    let remote = Frame::new_remote(Id::standard_literal(0x040), 2).unwrap();
    assert_eq!(
        decode(&remote, c, nodes),
        Err(DecodeError::RemoteFrame(0x040))
    );
}

#[test]
fn setpoint_frames_for_a_period() {
    let sp = [[AxisSetpoint {
        position: 0.5,
        velocity: -1.0,
        torque: 0.25,
    }; 2]; 13];
    let mut frames = Vec::new();
    encode_setpoints(Variant::Classic, 0x1234, from_node_one(&sp), |f| {
        frames.push(f)
    })
    .unwrap();
    assert_eq!(frames.len(), 13);
    let mut fd_frames = Vec::new();
    encode_setpoints(Variant::Fd, 0x1234, from_node_one(&sp), |f| {
        fd_frames.push(f)
    })
    .unwrap();
    assert_eq!(
        fd_frames.iter().map(Frame::len).collect::<Vec<_>>(),
        [64, 64, 12]
    );
    for (i, f) in frames.iter().enumerate() {
        let node = NodeId::new(i as u8 + 1).unwrap();
        let Ok(Message::Setpoint(s)) = decode(f, Variant::Classic, NodeSet::all()) else {
            panic!("{f}")
        };
        assert_eq!((s.node, s.cycle), (node, 0x4));
        let (g, _) = SetpointGroup::locate(node);
        let Ok(Message::SetpointGroup(grp)) =
            decode(&fd_frames[g as usize], Variant::Fd, NodeSet::all())
        else {
            panic!()
        };
        assert_eq!(grp.cycle, 0x34);
        let axes = grp.for_node(node).unwrap();
        assert!((axes[1].position - 0.5).abs() < 1e-4);
    }
}

/// CAN FD groups follow the ids, not their count: nodes 1, 7 and 13 are in
/// groups 0, 1 and 2, one frame each, each slot where its id puts it; a
/// node left out of the iterator gets no slot.
#[test]
fn sparse_ids_take_the_group_frames_of_their_ids() {
    let at = |p: f32| {
        [AxisSetpoint {
            position: p,
            velocity: 0.0,
            torque: 0.0,
        }; 2]
    };
    let id = |n| NodeId::new(n).unwrap();
    let mut frames = Vec::new();
    let sp = [(id(1), at(0.1)), (id(7), at(0.7)), (id(13), at(1.3))];
    encode_setpoints(Variant::Fd, 5, sp, |f| frames.push(f)).unwrap();
    assert_eq!(frames.len(), 3);
    for (f, (node, axes)) in frames.iter().zip(sp) {
        let Ok(Message::SetpointGroup(g)) = decode(f, Variant::Fd, NodeSet::all()) else {
            panic!("{f}")
        };
        assert_eq!(g.group, SetpointGroup::locate(node).0);
        let got = g.for_node(node).unwrap();
        assert!((got[0].position - axes[0].position).abs() < 1e-4);
        assert_eq!(g.slots.iter().filter(|s| s.is_some()).count(), 1);
    }
    let mut classic = Vec::new();
    encode_setpoints(Variant::Classic, 5, sp, |f| classic.push(f)).unwrap();
    assert_eq!(classic.len(), 3);
    assert_eq!(classic[2].id().raw(), 0x0C0 + 13);
}

/// Head sensor frames worked out by hand from protocol/README.md's tables.
#[test]
fn head_sensor_frames_match_hand_derived_bytes() {
    let c = Variant::Classic;
    let s = sensor();
    let bytes = |m: Message, v| {
        let f = m.encode(v).unwrap();
        (f.id().raw(), f.data().to_vec())
    };
    // Attitude: w = 1 is 8191 = 0x1FFF in bits 8..=21.
    let att = |sample, quaternion| {
        Message::HeadAttitude(HeadAttitude {
            node: s,
            sample,
            quaternion,
        })
    };
    assert_eq!(
        bytes(att(5, [1.0, 0.0, 0.0, 0.0]), c),
        (0x27F, vec![0x05, 0xFF, 0x1F, 0, 0, 0, 0, 0])
    );
    // z = -1 is -8191 = 0b10_0000_0000_0001 (14 bits) in bits 50..=63.
    assert_eq!(
        bytes(att(0, [0.0, 0.0, 0.0, -1.0]), c),
        (0x27F, vec![0, 0, 0, 0, 0, 0, 0x04, 0x80])
    );
    // Rates: 1 rad/s = 500, -2 mrad/s = -1, 35 rad/s = 17500 = 0x445C.
    let rates = Message::HeadRates(HeadVector {
        node: s,
        sample: 1,
        xyz: [1.0, -0.002, 35.0],
    });
    assert_eq!(
        bytes(rates, c),
        (0x2BF, vec![0x01, 0xF4, 0x01, 0xFF, 0xFF, 0x5C, 0x44])
    );
    // Depth: 101 325 Pa = 0x018BCD, 15.5 °C = 1550 = 0x060E.
    let depth = Message::HeadDepth(HeadDepth {
        node: s,
        sample: 2,
        pressure: 101_325,
        temperature: 15.5,
        status: SensorStatus(SensorStatus::ALL),
        errors: SensorErrors(SensorErrors::IMU),
    });
    assert_eq!(
        bytes(depth, c),
        (0x33F, vec![0x02, 0xCD, 0x8B, 0x01, 0x0E, 0x06, 0x3F, 0x01])
    );
    // FD: one 32-byte frame; w = 1 is 32767 = 0x7FFF, -1 °C = -100,
    // 9.81 m/s² on z = 1962 = 0x07AA in bits 208..=223.
    let fd_sample = HeadSample {
        node: s,
        sample: 7,
        quaternion: [1.0, 0.0, 0.0, 0.0],
        rates: [0.0; 3],
        accel: [0.0, 0.0, 9.81],
        pressure: 101_325,
        temperature: -1.0,
        status: SensorStatus(SensorStatus::ATTITUDE | 3),
        errors: SensorErrors(0),
    };
    let mut want = vec![0u8; 32];
    want[..10].copy_from_slice(&[0x07, 0x07, 0x00, 0xCD, 0x8B, 0x01, 0x9C, 0xFF, 0xFF, 0x7F]);
    want[26] = 0xAA;
    want[27] = 0x07;
    assert_eq!(
        bytes(Message::HeadSample(fd_sample), Variant::Fd),
        (0x37F, want)
    );
}

#[test]
fn a_head_sample_takes_four_classic_frames_or_one_fd_frame() {
    let mut h = HeadSample {
        node: sensor(),
        sample: 9,
        quaternion: [0.5, 0.5, -0.5, 0.5],
        rates: [0.1, -0.2, 0.3],
        accel: [0.0, 0.0, 9.81],
        pressure: 120_000,
        temperature: 12.0,
        status: SensorStatus(SensorStatus::ALL),
        errors: SensorErrors(0),
    };
    let ids = |h: &HeadSample, v| {
        let mut out = Vec::new();
        encode_head_sample(v, h, |f| {
            assert!(matches!(
                decode(&f, v, accepted()),
                Ok(Message::HeadAttitude(HeadAttitude { sample: 9, .. })
                    | Message::HeadRates(HeadVector { sample: 9, .. })
                    | Message::HeadAccel(HeadVector { sample: 9, .. })
                    | Message::HeadDepth(HeadDepth { sample: 9, .. })
                    | Message::HeadSample(HeadSample { sample: 9, .. }))
            ));
            out.push(f.id().raw());
        })
        .unwrap();
        out
    };
    assert_eq!(ids(&h, Variant::Classic), [0x27F, 0x2BF, 0x2FF, 0x33F]);
    assert_eq!(ids(&h, Variant::Fd), [0x37F]);
    // A raw 6-axis IMU: no attitude frame.
    h.status = SensorStatus(SensorStatus::IMU | SensorStatus::PRESSURE);
    assert_eq!(ids(&h, Variant::Classic), [0x2BF, 0x2FF, 0x33F]);
    // Out of range: an error naming the field, and nothing sent.
    h.rates[1] = 40.0;
    let mut sent = 0;
    let e = encode_head_sample(Variant::Classic, &h, |_| sent += 1).unwrap_err();
    assert!(
        matches!(
            e,
            EncodeError::ValueOutOfRange {
                signal: "RateY",
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(sent, 0);
    h.rates[1] = 0.0;
    h.pressure = 1 << 24;
    let e = Message::HeadSample(h).encode(Variant::Fd).unwrap_err();
    assert!(e.to_string().contains("Pressure"), "{e}");
}

#[test]
fn head_sensor_decode_errors_name_the_field() {
    let c = Variant::Classic;
    // QuatW raw -8192 (0x2000 in 14 bits) is outside ±8191.
    let f = Frame::new_standard(0x27F, &[0, 0x00, 0x20, 0, 0, 0, 0, 0]).unwrap();
    let e = decode(&f, c, accepted()).unwrap_err();
    assert!(
        matches!(
            e,
            DecodeError::ValueOutOfRange {
                message: "HeadAttitude",
                signal: "QuatW",
                ..
            }
        ),
        "{e}"
    );
    // Status bit 6 is not defined.
    let f = Frame::new_standard(0x33F, &[0, 0, 0, 0, 0, 0, 0x40, 0]).unwrap();
    let e = decode(&f, c, accepted()).unwrap_err();
    assert!(e.to_string().contains("HeadDepth.Status"), "{e}");
    // A sensor not in the accepted set, as the daemon sees it today.
    let f = Frame::new_standard(0x2BF, &[0; 7]).unwrap();
    assert!(matches!(
        decode(&f, c, NodeSet::first(NODES)),
        Err(DecodeError::UnknownNode {
            message: "HeadRates",
            node: 63
        })
    ));
    // FD: the reserved tail of a HeadSample must be zero.
    let mut data = [0u8; 32];
    data[30] = 1;
    let f = Frame::new_fd(Id::standard_literal(0x37F), &data, true).unwrap();
    assert!(matches!(
        decode(&f, Variant::Fd, accepted()),
        Err(DecodeError::ReservedBits {
            message: "HeadSample",
            byte: 30
        })
    ));
}
