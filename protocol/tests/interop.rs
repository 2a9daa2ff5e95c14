//! Sample candump logs of a few control periods, and the signal values the
//! Rust codec reads from them, for checking third-party tools:
//! `protocol/tools/check_dbc.py` decodes the logs with Python cantools and
//! the committed DBC files and compares every value with
//! `tests/data/sample*.json`. This test keeps the committed samples equal to
//! what the codec produces (regenerate with `ANGUILLA_BLESS=1 cargo test`).
//! `sample_odrive.*` does the same for ODrive CANSimple axes and
//! `protocol/odrive.dbc`, `sample_mit.*` for MIT-mode drives and
//! `protocol/mit.dbc`.

use std::fmt::Write as _;

use anguilla_protocol::candump::{Interface, LogEntry, Timestamp, Writer};
use anguilla_protocol::message::*;
use anguilla_protocol::odrive;
use anguilla_protocol::signal::Mux;

const NODES: u8 = 12;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn messages(variant: Variant) -> Vec<Message> {
    let mut out = vec![
        Message::Command {
            target: Target::All,
            command: Command::ClearFaults,
        },
        Message::ConfigWrite {
            node: node(1),
            param: ConfigParam::WatchdogTimeout { ms: 40 },
        },
        Message::ConfigAck {
            node: node(1),
            param: ConfigParam::WatchdogTimeout { ms: 40 },
            result: ConfigResult::Accepted,
        },
        Message::ConfigWrite {
            node: node(2),
            param: ConfigParam::PositionLimits {
                axis: Axis::Yaw,
                min: -1.2,
                max: 1.1,
            },
        },
        Message::ConfigAck {
            node: node(2),
            param: ConfigParam::TorqueLimit {
                axis: Axis::Pitch,
                max: 2.5,
            },
            result: ConfigResult::OutOfRange,
        },
        Message::ConfigWrite {
            node: node(3),
            param: ConfigParam::SafeAction(SafeAction::Hold),
        },
        Message::Command {
            target: Target::Node(node(3)),
            command: Command::Enable,
        },
    ];
    for cycle in 0u16..3 {
        let phase = cycle as f32 * 0.4;
        let sp: Vec<[AxisSetpoint; 2]> = (0..NODES)
            .map(|k| {
                let a = (k as f32 * 0.5 + phase).sin();
                [
                    AxisSetpoint {
                        position: 0.1 * a,
                        velocity: -0.3 * a,
                        torque: 0.05,
                    },
                    AxisSetpoint {
                        position: 1.1 * a,
                        velocity: 6.0 * a,
                        torque: -2.0 * a,
                    },
                ]
            })
            .collect();
        encode_setpoints(variant, cycle, from_node_one(&sp), |f| {
            out.push(decode(&f, variant, NodeSet::first(NODES)).unwrap())
        })
        .unwrap();
        out.push(Message::Sync { counter: cycle });
        for k in 0..NODES {
            let s = sp[k as usize];
            out.push(Message::Feedback(Feedback {
                node: node(k + 1),
                enabled: true,
                fault: k == 5,
                axes: [0, 1].map(|a| AxisFeedback {
                    position: s[a].position * 0.98,
                    velocity: s[a].velocity,
                    torque: s[a].torque * 1.1,
                    limited: a == 1 && k == 2,
                }),
            }));
        }
    }
    out.push(Message::Heartbeat(Heartbeat {
        node: node(4),
        state: NodeState::Fault,
        errors: ErrorBits(ErrorBits::WATCHDOG | ErrorBits::SYNC_MISSED),
        counter: 17,
        missed_syncs: 3,
        temperature: 41,
    }));
    // A head sensor (id 63, as in the DBC files) sample: a fusion IMU
    // pitched nose-down a little, 2 m deep.
    let head = HeadSample {
        node: node(DEFAULT_HEAD_SENSOR_ID),
        sample: 200,
        quaternion: [0.9962, 0.0, 0.0872, 0.0],
        rates: [0.05, -0.31, 1.25],
        accel: [-1.71, 0.02, 9.66],
        pressure: 120_938,
        temperature: 14.37,
        status: SensorStatus(SensorStatus::ALL),
        errors: SensorErrors(SensorErrors::OVERRUN),
    };
    out.push(Message::Heartbeat(Heartbeat {
        node: node(DEFAULT_HEAD_SENSOR_ID),
        state: NodeState::Enabled,
        errors: ErrorBits(0),
        counter: 9,
        missed_syncs: 0,
        temperature: 14,
    }));
    encode_head_sample(variant, &head, |f| {
        out.push(decode(&f, variant, NodeSet::all()).unwrap());
    })
    .unwrap();
    out.push(Message::EStop(Target::All));
    out
}

/// The candump log and the expected values (JSON lines: id and signals).
fn sample(variant: Variant) -> (String, String) {
    let mut log = Writer::new(Vec::new());
    let mut json = String::new();
    let iface = Interface::new("can0").unwrap();
    for (i, m) in messages(variant).iter().enumerate() {
        let frame = m.encode(variant).unwrap();
        let entry = LogEntry::new(
            Timestamp {
                secs: 1_700_000_000,
                micros: 1000 * i as u32,
            },
            iface,
            frame,
        );
        log.write(&entry).unwrap();
        let def = definitions(variant)
            .iter()
            .find(|d| d.function == m.function())
            .unwrap();
        let data = frame.data();
        let param = def
            .signals
            .iter()
            .find(|s| s.mux == Mux::Switch)
            .map(|s| s.get(data) as u8);
        write!(json, "{{\"id\": {}, \"signals\": {{", frame.id().raw()).unwrap();
        let mut first = true;
        for s in def.signals {
            if let (Mux::When(v), Some(p)) = (s.mux, param)
                && v != p
            {
                continue;
            }
            if !first {
                json.push_str(", ");
            }
            first = false;
            write!(json, "\"{}\": {}", s.dbc_name(), s.to_physical(s.get(data))).unwrap();
        }
        json.push_str("}}\n");
    }
    (String::from_utf8(log.into_inner().unwrap()).unwrap(), json)
}

#[test]
fn committed_samples_are_current() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    for (variant, stem) in [(Variant::Classic, "sample"), (Variant::Fd, "sample_fd")] {
        let (log, json) = sample(variant);
        let log_path = format!("{dir}/{stem}.log");
        let json_path = format!("{dir}/{stem}.json");
        if std::env::var_os("ANGUILLA_BLESS").is_some() {
            std::fs::create_dir_all(dir).unwrap();
            std::fs::write(&log_path, &log).unwrap();
            std::fs::write(&json_path, &json).unwrap();
        }
        let old_log = std::fs::read_to_string(&log_path).unwrap_or_default();
        let old_json = std::fs::read_to_string(&json_path).unwrap_or_default();
        assert!(
            old_log == log && old_json == json,
            "{stem}.log/.json are stale: run `ANGUILLA_BLESS=1 cargo test -p anguilla-protocol --test interop`"
        );
    }
}

/// A bring-up and a few control periods of four ODrive axes (ids 1..=4 of
/// the committed DBC's 1..=24), every message type, negative feedforwards,
/// and a heartbeat with a non-zero axis error.
fn odrive_messages() -> Vec<odrive::Message> {
    use odrive::{AxisState, Body, ControlMode, Heartbeat, InputMode, Message};
    let axis = |n: u8| odrive::NodeId::new(n).unwrap();
    // Feedforwards on the codec's 0.001 grid, so that they decode back equal.
    let ff = |x: f32| odrive::ff_value((x * odrive::FF_COUNTS_PER_UNIT).round() as i16);
    let mut out = Vec::new();
    for n in 1..=4 {
        out.push(Message {
            node: axis(n),
            body: Body::ClearErrors { identify: false },
        });
        out.push(Message {
            node: axis(n),
            body: Body::SetControllerMode {
                control_mode: ControlMode::PositionControl,
                input_mode: InputMode::Passthrough,
            },
        });
        out.push(Message {
            node: axis(n),
            body: Body::SetAxisState(AxisState::ClosedLoopControl),
        });
    }
    for cycle in 0..3 {
        for n in 1..=4u8 {
            let a = (n as f32 * 0.7 + cycle as f32 * 0.4).sin();
            out.push(Message {
                node: axis(n),
                body: Body::SetInputPos(odrive::InputPos {
                    input_pos: 2.5 * a,
                    vel_ff: ff(-3.21 * a),
                    torque_ff: ff(0.4 * a - 0.1),
                }),
            });
        }
        for n in 1..=4u8 {
            let a = (n as f32 * 0.7 + cycle as f32 * 0.4).sin();
            out.push(Message {
                node: axis(n),
                body: Body::EncoderEstimates(odrive::EncoderEstimates {
                    pos: 2.5 * a * 0.99,
                    vel: -3.21 * a,
                }),
            });
        }
        out.push(Message {
            node: axis(1 + cycle),
            body: Body::Heartbeat(Heartbeat {
                axis_error: 0,
                axis_state: AxisState::ClosedLoopControl,
                procedure_result: 0,
                trajectory_done: cycle == 1,
            }),
        });
    }
    // Axis 3's watchdog expired: WATCHDOG_TIMER_EXPIRED, back to IDLE.
    out.push(Message {
        node: axis(3),
        body: Body::Heartbeat(Heartbeat {
            axis_error: 0x0100_0000,
            axis_state: AxisState::Idle,
            procedure_result: 1,
            trajectory_done: false,
        }),
    });
    out.push(Message {
        node: axis(3),
        body: Body::Estop,
    });
    out.push(Message {
        node: axis(3),
        body: Body::ClearErrors { identify: true },
    });
    out
}

/// The ODrive candump log and the expected values. Each value is what the
/// codec decoded, written so that it reads back as the number a DBC reader
/// computes: a float field as its exact f32 (in f64 digits), a scaled
/// count as the f32's shortest digits, which are `count × 0.001` (the codec's
/// feedforward is the f32 nearest that product; `odrive::dbc` tests this
/// for every count).
fn odrive_sample() -> (String, String) {
    use odrive::dbc::{Encoding, Value, fields, values};
    let mut log = Writer::new(Vec::new());
    let mut json = String::new();
    let iface = Interface::new("can0").unwrap();
    for (i, m) in odrive_messages().iter().enumerate() {
        let frame = m.encode().unwrap();
        let entry = LogEntry::new(
            Timestamp {
                secs: 1_700_000_000,
                micros: 1000 * i as u32,
            },
            iface,
            frame,
        );
        log.write(&entry).unwrap();
        let decoded = odrive::decode(&frame).unwrap();
        assert_eq!(&decoded, m);
        let vals = values(&decoded.body).unwrap();
        write!(json, "{{\"id\": {}, \"signals\": {{", frame.id().raw()).unwrap();
        for (k, (field, (name, v))) in fields(m.body.cmd()).iter().zip(vals).enumerate() {
            assert_eq!(field.name, name);
            if k > 0 {
                json.push_str(", ");
            }
            match v {
                Value::Int(i) => write!(json, "\"{name}\": {i}"),
                Value::F32(x) if field.encoding == Encoding::Float32 => {
                    write!(json, "\"{name}\": {}", f64::from(x))
                }
                Value::F32(x) => write!(json, "\"{name}\": {x}"),
            }
            .unwrap();
        }
        json.push_str("}}\n");
    }
    (String::from_utf8(log.into_inner().unwrap()).unwrap(), json)
}

#[test]
fn committed_odrive_sample_is_current() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    let (log, json) = odrive_sample();
    let log_path = format!("{dir}/sample_odrive.log");
    let json_path = format!("{dir}/sample_odrive.json");
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(&log_path, &log).unwrap();
        std::fs::write(&json_path, &json).unwrap();
    }
    let old_log = std::fs::read_to_string(&log_path).unwrap_or_default();
    let old_json = std::fs::read_to_string(&json_path).unwrap_or_default();
    assert!(
        old_log == log && old_json == json,
        "sample_odrive.log/.json are stale: run `ANGUILLA_BLESS=1 cargo test -p anguilla-protocol --test interop`"
    );
}

/// MIT-mode drives 1 and 2 through a session: enter, hold, a command with
/// every field off its ends, replies of both lengths, an error, exit. The
/// special commands carry no signals (a DBC cannot tell them from a
/// Command; its comment says so), so the JSON lists none for them.
fn mit_messages() -> Vec<anguilla_protocol::mit::Message> {
    use anguilla_protocol::mit::{Body, Command, Message, NodeId, Reply, Status};
    let drive = |n: u8| NodeId::new(n).unwrap();
    let cmd = |n, position, velocity, kp, kd, torque| Message {
        node: drive(n),
        body: Body::Command(Command {
            position,
            velocity,
            kp,
            kd,
            torque,
        }),
    };
    let reply = |n, position, velocity, torque, status| Message {
        node: drive(n),
        body: Body::Reply(Reply {
            position,
            velocity,
            torque,
            status,
        }),
    };
    let ok = Some(Status {
        temperature: 31,
        error: 0,
    });
    vec![
        Message {
            node: drive(1),
            body: Body::EnterMotorMode,
        },
        reply(1, 0.01, 0.0, 0.0, ok),
        cmd(1, 0.25, -1.5, 40.0, 1.2, 0.8),
        reply(1, 0.2493, -1.48, 0.79, ok),
        cmd(2, -3.0, 10.0, 500.0, 0.0, -18.0),
        reply(2, -2.99, 9.9, -17.5, None),
        reply(
            2,
            -2.99,
            0.0,
            0.0,
            Some(Status {
                temperature: -7,
                error: 2,
            }),
        ),
        Message {
            node: drive(2),
            body: Body::ExitMotorMode,
        },
        Message {
            node: drive(1),
            body: Body::SetZero,
        },
    ]
}

/// The MIT-mode candump log and the values a DBC reader computes from it
/// (`mit::dbc_values`, which the unit tests hold to the codec).
fn mit_sample() -> (String, String) {
    use anguilla_protocol::mit::{DEFAULT_RANGES, dbc_values, decode};
    let mut log = Writer::new(Vec::new());
    let mut json = String::new();
    let iface = Interface::new("can0").unwrap();
    for (i, m) in mit_messages().iter().enumerate() {
        let frame = m.encode(&DEFAULT_RANGES).unwrap();
        let entry = LogEntry::new(
            Timestamp {
                secs: 1_700_000_000,
                micros: 1000 * i as u32,
            },
            iface,
            frame,
        );
        log.write(&entry).unwrap();
        assert_eq!(decode(&frame, &DEFAULT_RANGES).unwrap().node, m.node);
        write!(json, "{{\"id\": {}, \"signals\": {{", frame.id().raw()).unwrap();
        for (k, (name, v)) in dbc_values(&frame, &DEFAULT_RANGES).iter().enumerate() {
            if k > 0 {
                json.push_str(", ");
            }
            write!(json, "\"{name}\": {v:?}").unwrap();
        }
        json.push_str("}}\n");
    }
    (String::from_utf8(log.into_inner().unwrap()).unwrap(), json)
}

#[test]
fn committed_mit_sample_is_current() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    let (log, json) = mit_sample();
    let log_path = format!("{dir}/sample_mit.log");
    let json_path = format!("{dir}/sample_mit.json");
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(&log_path, &log).unwrap();
        std::fs::write(&json_path, &json).unwrap();
    }
    let old_log = std::fs::read_to_string(&log_path).unwrap_or_default();
    let old_json = std::fs::read_to_string(&json_path).unwrap_or_default();
    assert!(
        old_log == log && old_json == json,
        "sample_mit.log/.json are stale: run `ANGUILLA_BLESS=1 cargo test -p anguilla-protocol --test interop`"
    );
}
