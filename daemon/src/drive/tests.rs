//! The bought families' masters against scripted drives: every frame they
//! send is captured and checked against `docs/drives.md`.

use std::time::Duration;

use anguilla_drivers::{Bus, BusCounters, BusState, Capabilities, Received, TimestampBase};
use anguilla_protocol::canopen::{
    self, AbortCode, Emcy, Message as Co, NmtCommand, NmtState, NodeId as CoNode, Object, Pdo,
    PdoData, SdoData, SdoRequest, SdoResponse, SegmentData,
};
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{AxisSetpoint, NodeSet, NodeState};
use anguilla_protocol::odrive::{self, AxisState, Body, Message as Od, NodeId as OdNode};

use super::{Drives, Out, Period};
use crate::config::{AxisConfig, Config};
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::{Mode, Nanos};
use anguilla_protocol::Family;

/// A bus that keeps what is sent.
#[derive(Default)]
struct Capture(Vec<Frame>);

impl Bus for Capture {
    fn send(&mut self, frame: &Frame) -> anguilla_drivers::Result<()> {
        self.0.push(*frame);
        Ok(())
    }
    fn recv(&mut self, _: Duration) -> anguilla_drivers::Result<Option<Received>> {
        Ok(None)
    }
    fn state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            fd: false,
            remote: true,
            timestamps: TimestampBase::None,
            simulated_faults: false,
        }
    }
    fn flush_tx(&mut self) -> anguilla_drivers::Result<()> {
        Ok(())
    }
    fn reopen(&mut self) -> anguilla_drivers::OpenResult<()> {
        Ok(())
    }
    fn spec(&self) -> &str {
        "capture"
    }
}

const MS: Nanos = Nanos::from_millis(1);

const LIMITS: super::report::Liveness = super::report::Liveness {
    heartbeat_timeout: Nanos::from_millis(350),
    feedback_periods: 20,
};

struct Rig<D: Drives + ?Sized = dyn Drives> {
    drives: Box<D>,
    bus: Capture,
    tx_errors: u64,
    dropped: u64,
    setpoints: Vec<[AxisSetpoint; 2]>,
}

impl Rig {
    fn new(cfg: &Config) -> Rig {
        Rig::of(super::build(cfg, Nanos::ZERO, 10 * MS).unwrap(), cfg)
    }
}

impl Rig<super::cia402::Master> {
    fn master(cfg: &Config) -> Self {
        let m = super::cia402::Master::new(cfg, Nanos::ZERO, 10 * MS).unwrap();
        Rig::of(Box::new(m), cfg)
    }
}

impl<D: Drives + ?Sized> Rig<D> {
    fn of(drives: Box<D>, cfg: &Config) -> Self {
        Rig {
            drives,
            bus: Capture::default(),
            tx_errors: 0,
            dropped: 0,
            setpoints: vec![[AxisSetpoint::default(); 2]; cfg.robot.joints],
        }
    }

    /// One period; returns the frames sent.
    fn period(&mut self, now: Nanos, drive: Drive, mode: Mode, entering: bool) -> Vec<Frame> {
        let tap = None;
        let mut out = Out {
            bus: &mut self.bus,
            tap: &tap,
            tap_dropped: &mut self.dropped,
            tx_errors: &mut self.tx_errors,
            now,
        };
        self.drives.period(
            &Period {
                now,
                drive,
                mode,
                entering,
                bus_off: false,
                counter: 0,
                setpoints: &self.setpoints,
                skip: NodeSet::empty(),
            },
            &mut out,
        );
        std::mem::take(&mut self.bus.0)
    }

    fn with_out(&mut self, f: impl FnOnce(&mut D, &mut Out<'_>)) -> Vec<Frame> {
        let tap = None;
        let mut out = Out {
            bus: &mut self.bus,
            tap: &tap,
            tap_dropped: &mut self.dropped,
            tx_errors: &mut self.tx_errors,
            now: Nanos::ZERO,
        };
        f(&mut self.drives, &mut out);
        std::mem::take(&mut self.bus.0)
    }
}

fn cfg(drive: Family, joints: usize) -> Config {
    let mut c = Config::default();
    c.robot.drive = drive;
    c.robot.joints = joints;
    c.validate().unwrap();
    c
}

fn co(frames: &[Frame]) -> Vec<Co> {
    frames.iter().map(|f| canopen::decode(f).unwrap()).collect()
}

fn co_node(n: u8) -> CoNode {
    CoNode::new(n).unwrap()
}

/// A scripted CiA 402 drive: answers the master's SDOs from a table,
/// with `abort` or silence at chosen entries.
struct Scripted {
    node: CoNode,
    name: &'static [u8],
    abort: Option<(Object, AbortCode)>,
    silent: Option<Object>,
    device_type: u32,
    mode_display: i8,
    writes: Vec<(Object, Vec<u8>)>,
    upload: Option<(usize, bool)>,
}

impl Scripted {
    fn new(node: u8) -> Self {
        Scripted {
            node: co_node(node),
            name: b"scripted CiA 402 drive",
            abort: None,
            silent: None,
            device_type: 0x0002_0192,
            mode_display: 8,
            writes: Vec::new(),
            upload: None,
        }
    }

    /// The answer to one request of the master's, if any.
    fn answer(&mut self, m: &Co) -> Option<Frame> {
        let Co::SdoRequest { node, sdo } = *m else {
            return None;
        };
        if node != self.node {
            return None;
        }
        let resp = |sdo| Some(Co::SdoResponse { node, sdo }.encode());
        let object = match sdo {
            SdoRequest::Download { object, .. } | SdoRequest::Upload { object } => Some(object),
            _ => None,
        };
        if let Some(o) = object {
            if self.silent == Some(o) {
                return None;
            }
            if let Some((a, code)) = self.abort
                && a == o
            {
                return resp(SdoResponse::Abort { object: o, code });
            }
        }
        match sdo {
            SdoRequest::Download { object, data } => {
                self.writes.push((object, data.bytes().to_vec()));
                resp(SdoResponse::DownloadAck { object })
            }
            SdoRequest::Upload { object } => {
                let v = |b: &[u8]| SdoData::new(b).unwrap();
                match (object.index, object.sub) {
                    (0x1000, 0) => resp(SdoResponse::Upload {
                        object,
                        data: v(&self.device_type.to_le_bytes()),
                    }),
                    (0x1008, 0) => {
                        self.upload = Some((0, false));
                        resp(SdoResponse::UploadSegmented {
                            object,
                            size: Some(self.name.len() as u32),
                        })
                    }
                    (0x6076, 0) => resp(SdoResponse::Upload {
                        object,
                        data: v(&500u32.to_le_bytes()),
                    }),
                    (0x6061, 0) => resp(SdoResponse::Upload {
                        object,
                        data: v(&[self.mode_display as u8]),
                    }),
                    _ => resp(SdoResponse::Abort {
                        object,
                        code: AbortCode::ObjectDoesNotExist,
                    }),
                }
            }
            SdoRequest::UploadSegment { toggle } => {
                let (at, t) = self.upload?;
                assert_eq!(toggle, t, "the master alternates the toggle bit");
                let end = (at + 7).min(self.name.len());
                let last = end == self.name.len();
                self.upload = (!last).then_some((end, !t));
                resp(SdoResponse::UploadSegment {
                    toggle,
                    data: SegmentData::new(&self.name[at..end]).unwrap(),
                    last,
                })
            }
            _ => None,
        }
    }
}

fn feed<D: Drives + ?Sized>(rig: &mut Rig<D>, now: Nanos, frames: &[Frame]) {
    for f in frames {
        rig.drives.ingest(now, f);
    }
}

fn boot_up(node: u8) -> Frame {
    Co::Heartbeat {
        node: co_node(node),
        state: NmtState::BootUp,
    }
    .encode()
}

/// Runs the master with scripted drives for `periods` periods from `t`;
/// returns every frame it sent.
fn run<D: Drives + ?Sized>(
    rig: &mut Rig<D>,
    drives: &mut [Scripted],
    t: &mut Nanos,
    periods: usize,
) -> Vec<Co> {
    let mut all = Vec::new();
    for _ in 0..periods {
        *t += 10 * MS;
        let sent = rig.period(*t, Drive::Disabled, Mode::Idle, false);
        let msgs = co(&sent);
        let answers: Vec<Frame> = msgs
            .iter()
            .flat_map(|m| {
                drives
                    .iter_mut()
                    .filter_map(|d| d.answer(m))
                    .collect::<Vec<_>>()
            })
            .collect();
        feed(rig, *t, &answers);
        all.extend(msgs);
    }
    all
}

#[test]
fn cia402_configuration_follows_the_contract() {
    let c = cfg(Family::Cia402, 1);
    let mut rig = Rig::new(&c);
    let mut t = Nanos::ZERO;
    // First period: Reset communication to each drive (1 and 2), SYNC,
    // the master's heartbeat.
    let first = co(&rig.period(t, Drive::Disabled, Mode::Idle, true));
    assert_eq!(
        &first[..2],
        &[
            Co::Nmt {
                command: NmtCommand::ResetCommunication,
                node: Some(co_node(1))
            },
            Co::Nmt {
                command: NmtCommand::ResetCommunication,
                node: Some(co_node(2))
            }
        ]
    );
    assert!(first.contains(&Co::Sync { counter: None }));
    assert!(first.contains(&Co::Heartbeat {
        node: co_node(127),
        state: NmtState::Operational
    }));
    feed(&mut rig, t, &[boot_up(1), boot_up(2)]);
    let mut drives = [Scripted::new(1), Scripted::new(2)];
    let sent = run(&mut rig, &mut drives, &mut t, 60);
    // Every write of the contract, in its order, to drive 2.
    let w = |i, s, v: &[u8]| (Object::new(i, s), v.to_vec());
    let expect = vec![
        w(0x1400, 1, &0x8000_0202u32.to_le_bytes()),
        w(0x1400, 2, &[1]),
        w(0x1600, 0, &[0]),
        w(0x1600, 1, &0x6040_0010u32.to_le_bytes()),
        w(0x1600, 2, &0x607A_0020u32.to_le_bytes()),
        w(0x1600, 3, &0x60B2_0010u32.to_le_bytes()),
        w(0x1600, 0, &[3]),
        w(0x1400, 1, &0x202u32.to_le_bytes()),
        w(0x1800, 1, &0x8000_0182u32.to_le_bytes()),
        w(0x1800, 2, &[1]),
        w(0x1A00, 0, &[0]),
        w(0x1A00, 1, &0x6041_0010u32.to_le_bytes()),
        w(0x1A00, 2, &0x6064_0020u32.to_le_bytes()),
        w(0x1A00, 3, &0x6077_0010u32.to_le_bytes()),
        w(0x1A00, 0, &[3]),
        w(0x1800, 1, &0x182u32.to_le_bytes()),
        w(0x1006, 0, &10_000u32.to_le_bytes()),
        w(0x60C2, 1, &[10]),
        w(0x60C2, 2, &[(-3i8) as u8]),
        w(0x6060, 0, &[8]),
        w(0x1017, 0, &100u16.to_le_bytes()),
        // Consumer: master 127, 350 ms (control.heartbeat-timeout).
        w(0x1016, 1, &(127u32 << 16 | 350).to_le_bytes()),
    ];
    assert_eq!(drives[1].writes, expect);
    assert!(sent.contains(&Co::Nmt {
        command: NmtCommand::Start,
        node: Some(co_node(2))
    }));
    // Configured drives are reported once their statusword arrives.
    let hb = |n| {
        Co::Heartbeat {
            node: co_node(n),
            state: NmtState::Operational,
        }
        .encode()
    };
    feed(&mut rig, t, &[hb(1), hb(2)]);
    // Statusword Switch on disabled from both: the joint is Disabled.
    let tpdo = |n: u8, status: u16, pos: i32| {
        let mut d = [0u8; 8];
        d[0..2].copy_from_slice(&status.to_le_bytes());
        d[2..6].copy_from_slice(&pos.to_le_bytes());
        Co::Tpdo {
            node: co_node(n),
            pdo: Pdo::One,
            data: PdoData::new(&d).unwrap(),
        }
        .encode()
    };
    feed(&mut rig, t, &[tpdo(1, 0x0250, 0), tpdo(2, 0x0250, 16384)]);
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Disabled));
    let fb = rig.drives.joint(0).feedback.unwrap();
    assert!((fb[1].position - std::f32::consts::FRAC_PI_2).abs() < 1e-5);
    // Enabling: Shutdown (0x06) from Switch on disabled, target = actual.
    t += 10 * MS;
    let en = co(&rig.period(t, Drive::Enable, Mode::Enabling, true));
    let rpdo = |m: &Co, n: u8| match *m {
        Co::Rpdo { node, data, .. } if node == co_node(n) => Some(data.bytes().to_vec()),
        _ => None,
    };
    let r2 = en.iter().find_map(|m| rpdo(m, 2)).unwrap();
    assert_eq!(&r2[0..2], &[0x06, 0]);
    assert_eq!(&r2[2..6], &16384i32.to_le_bytes());
    // Ready to switch on → Switch on; Switched on → Enable operation.
    feed(&mut rig, t, &[tpdo(2, 0x0231, 16384)]);
    let en = co(&rig.period(t + 10 * MS, Drive::Enable, Mode::Enabling, false));
    assert_eq!(
        &en.iter().find_map(|m| rpdo(m, 2)).unwrap()[0..2],
        &[0x07, 0]
    );
    feed(&mut rig, t, &[tpdo(2, 0x0233, 16384)]);
    let en = co(&rig.period(t + 20 * MS, Drive::Enable, Mode::Enabling, false));
    assert_eq!(
        &en.iter().find_map(|m| rpdo(m, 2)).unwrap()[0..2],
        &[0x0F, 0]
    );
    // Setpoints: 0.5 rad = 5215 increments; 0.2 N·m = 400 ‰ of 500 mN·m.
    rig.setpoints[0][1] = AxisSetpoint {
        position: 0.5,
        velocity: 0.0,
        torque: 0.2,
    };
    let sp = co(&rig.period(t + 30 * MS, Drive::Setpoints, Mode::Ready, true));
    let r2 = sp.iter().find_map(|m| rpdo(m, 2)).unwrap();
    assert_eq!(&r2[0..2], &[0x0F, 0]);
    assert_eq!(i32::from_le_bytes(r2[2..6].try_into().unwrap()), 5215);
    assert_eq!(i16::from_le_bytes(r2[6..8].try_into().unwrap()), 400);
    assert!(sp.contains(&Co::Sync { counter: None }));
    // E-stop: quick stop to both at once, then SYNC.
    let es = co(&rig.with_out(|d, out| d.estop(out)));
    assert_eq!(
        &es.iter().find_map(|m| rpdo(m, 1)).unwrap()[0..2],
        &[0x02, 0]
    );
    assert_eq!(es.last(), Some(&Co::Sync { counter: None }));
    // An EMCY faults the report with its code.
    feed(
        &mut rig,
        t,
        &[
            Co::Emcy {
                node: co_node(1),
                emcy: Emcy {
                    code: 0x4210,
                    register: 0x09,
                    manufacturer: [0; 5],
                },
            }
            .encode(),
            tpdo(1, 0x0218, 0),
        ],
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Fault));
    assert_eq!(rig.drives.joint(0).errors, 0x4210_0900);
    // The operator's clear: one Fault reset (0x80) in the next RPDO.
    rig.with_out(|d, out| d.clear_faults(out));
    feed(&mut rig, t, &[tpdo(1, 0x0218, 0)]);
    let r = co(&rig.period(t + 40 * MS, Drive::Disabled, Mode::Idle, true));
    assert_eq!(
        &r.iter().find_map(|m| rpdo(m, 1)).unwrap()[0..2],
        &[0x80, 0]
    );
    let r = co(&rig.period(t + 50 * MS, Drive::Disabled, Mode::Idle, false));
    assert_eq!(
        &r.iter().find_map(|m| rpdo(m, 1)).unwrap()[0..2],
        &[0x06, 0]
    );
}

#[test]
fn cia402_reads_the_name_by_segments_and_names_each_failure() {
    let c = cfg(Family::Cia402, 1);
    // Happy path: the name arrives in 4 segments.
    let mut rig = Rig::master(&c);
    let mut t = Nanos::ZERO;
    rig.period(t, Drive::Disabled, Mode::Idle, true);
    feed(&mut rig, t, &[boot_up(1), boot_up(2)]);
    let mut drives = [Scripted::new(1), Scripted::new(2)];
    run(&mut rig, &mut drives, &mut t, 3);
    // Stale answers (a late one to a request already sent again, a segment
    // out of sequence) are ignored: the configuration goes on.
    let stale = |sdo| {
        Co::SdoResponse {
            node: co_node(2),
            sdo,
        }
        .encode()
    };
    feed(
        &mut rig,
        t,
        &[
            stale(SdoResponse::DownloadAck {
                object: Object::new(0x1234, 5),
            }),
            stale(SdoResponse::UploadSegment {
                toggle: true,
                data: SegmentData::new(b"junk").unwrap(),
                last: true,
            }),
        ],
    );
    run(&mut rig, &mut drives, &mut t, 40);
    assert!(rig.drives.configured());
    assert_eq!(rig.drives.device_name(0, 0), Some("scripted CiA 402 drive"));
    // An abort, a wrong device, mode 8 refused, silence: each fails its
    // drive with the reason, and the joint reports Fault with the step.
    for (script, want) in [
        (
            Scripted {
                abort: Some((Object::new(0x1600, 3), AbortCode::NotMappable)),
                ..Scripted::new(2)
            },
            "SDO to 0x1600:03 aborted: 0x06040041 object cannot be mapped to the PDO",
        ),
        (
            Scripted {
                device_type: 0x0000_0191,
                ..Scripted::new(2)
            },
            "0x1000:00 = 0x191 is not what anguilla needs",
        ),
        (
            Scripted {
                mode_display: 1,
                ..Scripted::new(2)
            },
            "0x6061:00 = 0x1 is not what anguilla needs",
        ),
        (
            Scripted {
                silent: Some(Object::new(0x6076, 0)),
                ..Scripted::new(2)
            },
            "SDO to 0x6076:00 not answered (3 tries)",
        ),
    ] {
        let mut rig = Rig::master(&c);
        let mut t = Nanos::ZERO;
        rig.period(t, Drive::Disabled, Mode::Idle, true);
        feed(&mut rig, t, &[boot_up(1), boot_up(2)]);
        let mut drives = [Scripted::new(1), script];
        // Three tries of control.heartbeat-timeout (0.35 s) for the silent one.
        let sent = run(&mut rig, &mut drives, &mut t, 150);
        let (_, why) = rig.drives.config_failure(0, 1).expect("drive 2 failed");
        assert_eq!(why.to_string(), want);
        // The log is told once: drive 1 started, drive 2 failed.
        let notices: Vec<String> = std::iter::from_fn(|| rig.drives.take_notice())
            .map(|n| n.to_string())
            .collect();
        assert_eq!(notices.len(), 2, "{notices:?}");
        assert_eq!(
            notices[0],
            "joint 1 pitch drive (node 1) configured and started"
        );
        assert!(
            notices[1].starts_with("joint 1 yaw drive (node 2): configuration step ")
                && notices[1].ends_with(&format!("failed: {want}")),
            "{notices:?}"
        );
        assert!(rig.drives.take_notice().is_none());
        assert!(rig.drives.config_failure(0, 0).is_none());
        let j = rig.drives.joint(0);
        assert_eq!(j.state, Some(NodeState::Fault), "{want}");
        assert_eq!(j.errors & 0xFFFF_0000, super::cia402::CONFIG_FAILED);
        // Drive 2 is never started.
        assert!(!sent.contains(&Co::Nmt {
            command: NmtCommand::Start,
            node: Some(co_node(2))
        }));
        if want.contains("not answered") {
            let tries = sent
                .iter()
                .filter(|m| {
                    matches!(m, Co::SdoRequest { node, sdo: SdoRequest::Upload { object } }
                        if *node == co_node(2) && object.index == 0x6076)
                })
                .count();
            assert_eq!(tries, 3);
            assert!(sent.iter().any(|m| matches!(
                m,
                Co::SdoRequest {
                    sdo: SdoRequest::Abort {
                        code: AbortCode::Timeout,
                        ..
                    },
                    ..
                }
            )));
        }
    }
}

#[test]
fn cia402_takes_an_nmt_stop_from_another_sender_as_an_estop() {
    let mut rig = Rig::new(&cfg(Family::Cia402, 2));
    let nmt = |command, node| Co::Nmt { command, node }.encode();
    rig.drives.ingest(MS, &nmt(NmtCommand::Start, None));
    assert!(!rig.drives.take_bus_estop());
    rig.drives
        .ingest(MS, &nmt(NmtCommand::Stop, Some(co_node(9))));
    assert!(!rig.drives.take_bus_estop(), "node 9 is not ours");
    rig.drives
        .ingest(MS, &nmt(NmtCommand::Stop, Some(co_node(3))));
    assert!(rig.drives.take_bus_estop());
    rig.drives.ingest(MS, &nmt(NmtCommand::Stop, None));
    assert!(rig.drives.take_bus_estop());
    rig.drives
        .ingest(MS, &Frame::new_standard(0x000, &[1]).unwrap());
    assert_eq!(rig.drives.counters().malformed, 1);
}

fn od(frames: &[Frame]) -> Vec<Od> {
    frames.iter().map(|f| odrive::decode(f).unwrap()).collect()
}

fn od_hb(node: u8, state: AxisState, error: u32) -> Frame {
    Od {
        node: OdNode::new(node).unwrap(),
        body: Body::Heartbeat(odrive::Heartbeat {
            axis_error: error,
            axis_state: state,
            procedure_result: 0,
            trajectory_done: false,
        }),
    }
    .encode()
    .unwrap()
}

#[test]
fn odrive_enables_follows_setpoints_through_the_gear_and_stops() {
    let mut c = cfg(Family::Odrive, 1);
    // Yaw geared 10:1, reversed, offset 0.1 rad.
    c.robot.axes = vec![
        AxisConfig::default(),
        AxisConfig {
            node: Some(7),
            direction: Some(-1),
            offset: Some(0.1),
            gear: Some(10.0),
            ..AxisConfig::default()
        },
    ];
    c.validate().unwrap();
    let mut rig = Rig::new(&c);
    let t = Nanos::ZERO;
    feed(
        &mut rig,
        t,
        &[od_hb(1, AxisState::Idle, 0), od_hb(7, AxisState::Idle, 0)],
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Disabled));
    let en = od(&rig.period(t, Drive::Enable, Mode::Enabling, true));
    let to7: Vec<Body> = en
        .iter()
        .filter(|m| m.node.get() == 7)
        .map(|m| m.body)
        .collect();
    assert_eq!(
        to7,
        vec![
            Body::SetControllerMode {
                control_mode: odrive::ControlMode::PositionControl,
                input_mode: odrive::InputMode::Passthrough
            },
            Body::SetAxisState(AxisState::ClosedLoopControl)
        ]
    );
    feed(
        &mut rig,
        t,
        &[
            od_hb(1, AxisState::ClosedLoopControl, 0),
            od_hb(7, AxisState::ClosedLoopControl, 0),
        ],
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Enabled));
    // 0.1 + π/5 rad at the joint = −1 motor turn; 1 rad/s = −10/2π turns/s;
    // 1 N·m at the joint = −0.1 N·m at the motor.
    rig.setpoints[0][1] = AxisSetpoint {
        position: 0.1 + std::f32::consts::PI / 5.0,
        velocity: 1.0,
        torque: 1.0,
    };
    let sp = od(&rig.period(t + 10 * MS, Drive::Setpoints, Mode::Ready, true));
    let Some(Body::SetInputPos(p)) = sp.iter().find(|m| m.node.get() == 7).map(|m| m.body) else {
        panic!("no setpoint to axis 7: {sp:?}");
    };
    assert!((p.input_pos + 1.0).abs() < 1e-5, "{p:?}");
    assert!(
        (p.vel_ff + 10.0 / std::f32::consts::TAU).abs() < 1e-3,
        "{p:?}"
    );
    assert!((p.torque_ff + 0.1).abs() < 1e-3, "{p:?}");
    // No SYNC: CANSimple setpoints apply on arrival.
    assert_eq!(sp.len(), 2);
    let es = od(&rig.with_out(|d, out| d.estop(out)));
    assert!(es.iter().all(|m| m.body == Body::Estop) && es.len() == 2);
    feed(
        &mut rig,
        t,
        &[od_hb(7, AxisState::Idle, super::odrive::ESTOP_REQUESTED)],
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::EStop));
    feed(&mut rig, t, &[od_hb(1, AxisState::Idle, 0x0100_0000)]);
    assert_eq!(
        rig.drives.joint(0).state,
        Some(NodeState::EStop),
        "EStop outranks Fault"
    );
    assert_eq!(rig.drives.joint(0).errors, 0x0100_0000);
    // Someone else's Estop to axis 7 is a bus E-stop.
    rig.drives.ingest(
        t,
        &Od {
            node: OdNode::new(7).unwrap(),
            body: Body::Estop,
        }
        .encode()
        .unwrap(),
    );
    assert!(rig.drives.take_bus_estop());
}

#[test]
fn a_joint_is_lost_when_either_drive_falls_silent() {
    let mut rig = Rig::new(&cfg(Family::Odrive, 2));
    for n in 1..=4 {
        rig.drives
            .ingest(Nanos::ZERO, &od_hb(n, AxisState::Idle, 0));
    }
    for n in [1, 2, 3] {
        rig.drives.ingest(300 * MS, &od_hb(n, AxisState::Idle, 0));
    }
    let r = rig.drives.observe(400 * MS, &LIMITS);
    let two = anguilla_protocol::message::NodeId::new(2).unwrap();
    assert_eq!(
        r.lost,
        NodeSet::empty().with(two),
        "drive 4 is joint 2's yaw"
    );
    assert!(!r.all_enabled);
}

/// Runs the master `rig` and the simulated joint `joint` together, frame
/// for frame, for `periods` control periods of 10 ms; `drive`/`mode` as
/// the supervisor would decide.
fn co_run<D: Drives + ?Sized>(
    rig: &mut Rig<D>,
    joint: &mut dyn anguilla_sim::device::JointDevice,
    t: &mut Nanos,
    periods: usize,
    drive: Drive,
    mode: Mode,
) {
    co_run_keeping(rig, joint, t, periods, drive, mode, &|_| true);
}

/// [`co_run`], with only the joint's frames that `keep` keeps reaching
/// the master.
fn co_run_keeping<D: Drives + ?Sized>(
    rig: &mut Rig<D>,
    joint: &mut dyn anguilla_sim::device::JointDevice,
    t: &mut Nanos,
    periods: usize,
    drive: Drive,
    mode: Mode,
    keep: &dyn Fn(&Frame) -> bool,
) {
    for i in 0..periods {
        *t += 10 * MS;
        let mut back = Vec::new();
        joint.advance(*t, &mut |f| back.push(f));
        back.retain(|f| keep(f));
        feed(rig, *t, &back);
        back.clear();
        for f in rig.period(*t, drive, mode, i == 0) {
            joint.receive(*t, &f, &mut |o| back.push(o));
        }
        back.retain(|f| keep(f));
        feed(rig, *t, &back);
    }
}

/// A dead joint is never masked: a joint whose drives stop sending feedback
/// (anguilla Feedback, CiA 402 TPDO1, ODrive encoder estimates) while
/// their heartbeats go on is silent after the configured number of
/// periods, in every family; never before, and never while it answers.
#[test]
fn a_joint_without_feedback_is_silent_whatever_its_heartbeats_say_in_every_family() {
    use anguilla_protocol::message::NodeId;
    for family in [Family::Anguilla, Family::Cia402, Family::Odrive] {
        let c = cfg(family, 1);
        let mut rig = Rig::new(&c);
        let mut rc = anguilla_sim::robot::RobotConfig::with_joints(1);
        rc.drive = family;
        let mut joint = anguilla_sim::robot::joint_device(&rc, 0, 1, Nanos::ZERO).unwrap();
        let mut t = Nanos::ZERO;
        co_run(
            &mut rig,
            &mut *joint,
            &mut t,
            60,
            Drive::Disabled,
            Mode::Idle,
        );
        // Enable until the joint reports it (an anguilla node's watchdog
        // faults it if no setpoint follows for 100 ms).
        for _ in 0..30 {
            if rig.drives.joint(0).state == Some(NodeState::Enabled) {
                break;
            }
            co_run(
                &mut rig,
                &mut *joint,
                &mut t,
                1,
                Drive::Enable,
                Mode::Enabling,
            );
        }
        assert_eq!(
            rig.drives.joint(0).state,
            Some(NodeState::Enabled),
            "{family}"
        );
        co_run(
            &mut rig,
            &mut *joint,
            &mut t,
            50,
            Drive::Setpoints,
            Mode::Ready,
        );
        let r = rig.drives.observe(t, &LIMITS);
        assert!(r.silent.is_empty() && r.lost.is_empty(), "{family}: {r:?}");
        // Each family's feedback, as its protocol decodes it.
        let is_feedback = |f: &Frame| match family {
            Family::Anguilla => matches!(
                anguilla_protocol::message::decode(
                    f,
                    anguilla_protocol::message::Variant::Classic,
                    NodeSet::all()
                ),
                Ok(anguilla_protocol::message::Message::Feedback(_))
            ),
            Family::Cia402 => matches!(canopen::decode(f), Ok(Co::Tpdo { pdo: Pdo::One, .. })),
            _ => matches!(
                odrive::decode(f),
                Ok(Od {
                    body: Body::EncoderEstimates(_),
                    ..
                })
            ),
        };
        let mut silent_after = None;
        for k in 1..=LIMITS.feedback_periods + 5 {
            co_run_keeping(
                &mut rig,
                &mut *joint,
                &mut t,
                1,
                Drive::Setpoints,
                Mode::Swimming,
                &|f| !is_feedback(f),
            );
            let r = rig.drives.observe(t, &LIMITS);
            assert!(r.lost.is_empty(), "{family}: the heartbeats go on");
            if silent_after.is_none() && !r.silent.is_empty() {
                assert_eq!(r.silent, NodeSet::empty().with(NodeId::new(1).unwrap()));
                silent_after = Some(k);
            }
        }
        // Anguilla and CiA 402 answer the SYNC of the same period; an ODrive
        // axis sends its estimates on its own 10 ms clock, one period
        // earlier here: so 20 or 21 periods without feedback, not fewer.
        let k = silent_after.unwrap_or_else(|| panic!("{family}: never silent"));
        assert!(
            (LIMITS.feedback_periods..=LIMITS.feedback_periods + 1).contains(&k),
            "{family}: silent after {k} periods"
        );
        co_run(
            &mut rig,
            &mut *joint,
            &mut t,
            2,
            Drive::Setpoints,
            Mode::Swimming,
        );
        assert!(rig.drives.observe(t, &LIMITS).silent.is_empty(), "{family}");
    }
}

#[test]
fn the_cia402_master_drives_the_simulated_cia402_drive() {
    use anguilla_sim::cia402::{Cia402Joint, Cia402JointConfig};
    use anguilla_sim::device::JointDevice;
    let c = cfg(Family::Cia402, 1);
    let mut rig = Rig::master(&c);
    let mut joint = Cia402Joint::new(Cia402JointConfig::for_joint(0, 1), Nanos::ZERO);
    let mut t = Nanos::ZERO;
    // Boot, configuration by SDO, start: both drives configured, the
    // joint Disabled (switch on disabled → ready to switch on).
    co_run(
        &mut rig,
        &mut joint,
        &mut t,
        60,
        Drive::Disabled,
        Mode::Idle,
    );
    assert!(
        rig.drives.configured(),
        "{:?}",
        rig.drives.config_failure(0, 0)
    );
    assert_eq!(
        rig.drives.device_name(0, 0),
        Some("anguilla simulated CiA 402 axis")
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Disabled));
    // Enable: the controlword walk reaches Operation enabled on both.
    co_run(
        &mut rig,
        &mut joint,
        &mut t,
        10,
        Drive::Enable,
        Mode::Enabling,
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Enabled));
    // Setpoints: the joint goes where it is sent, and the master sees it.
    rig.setpoints[0] = [
        AxisSetpoint {
            position: -0.2,
            velocity: 0.0,
            torque: 0.0,
        },
        AxisSetpoint {
            position: 0.3,
            velocity: 0.0,
            torque: 0.05,
        },
    ];
    co_run(
        &mut rig,
        &mut joint,
        &mut t,
        100,
        Drive::Setpoints,
        Mode::Ready,
    );
    let (yaw, _, _) = joint.kinematics(1);
    let (pitch, _, _) = joint.kinematics(0);
    assert!((yaw - 0.3).abs() < 0.01, "yaw {yaw}");
    assert!((pitch + 0.2).abs() < 0.01, "pitch {pitch}");
    let fb = rig.drives.joint(0).feedback.unwrap();
    assert!((fb[1].position - 0.3).abs() < 0.01, "{fb:?}");
    // E-stop: quick stop, then the drives end in Switch on disabled.
    rig.with_out(|d, out| d.estop(out))
        .iter()
        .for_each(|f| joint.receive(t, f, &mut |_| {}));
    co_run(
        &mut rig,
        &mut joint,
        &mut t,
        30,
        Drive::Disabled,
        Mode::EStop,
    );
    assert_ne!(rig.drives.joint(0).state, Some(NodeState::Enabled));
    assert!(
        joint.motor_torque(1).abs() < 1e-9,
        "power off after the quick stop"
    );
    // An injected fault: EMCY into the report; the operator's clear resets it.
    let mut emcy = Vec::new();
    joint.inject_fault(0x0020, t, &mut |f| emcy.push(f));
    feed(&mut rig, t, &emcy);
    co_run(
        &mut rig,
        &mut joint,
        &mut t,
        3,
        Drive::Disabled,
        Mode::Fault,
    );
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Fault));
    assert_ne!(rig.drives.joint(0).errors, 0);
    joint.clear_injected_fault();
    rig.with_out(|d, out| d.clear_faults(out));
    co_run(&mut rig, &mut joint, &mut t, 5, Drive::Disabled, Mode::Idle);
    assert_eq!(rig.drives.joint(0).state, Some(NodeState::Disabled));
    assert_eq!(rig.drives.joint(0).errors, 0);
}

/// An anguilla node's heartbeat, classic CAN.
fn anguilla_hb(node: u8, state: NodeState, counter: u8) -> Frame {
    use anguilla_protocol::message::{ErrorBits, Heartbeat, Message, NodeId, Variant};
    Message::Heartbeat(Heartbeat {
        node: NodeId::new(node).unwrap(),
        state,
        errors: ErrorBits::default(),
        counter,
        missed_syncs: 0,
        temperature: 20,
    })
    .encode(Variant::Classic)
    .unwrap()
}

/// The nodes each Enable command in `frames` reaches.
fn enables(frames: &[Frame]) -> Vec<u8> {
    use anguilla_protocol::message::{Command as NodeCommand, Message, Target, Variant, decode};
    frames
        .iter()
        .filter_map(|f| match decode(f, Variant::Classic, NodeSet::all()) {
            Ok(Message::Command {
                target,
                command: NodeCommand::Enable,
            }) => Some(match target {
                Target::Node(n) => n.get(),
                Target::All => 0,
            }),
            _ => None,
        })
        .collect()
}

/// A loaded node sends the heartbeat it had queued (Disabled) after the
/// Enable left the host; Enable is sent again only to a node that says
/// Disabled in a second heartbeat since, never to one that has just
/// enabled (which would refuse it with BAD_FRAME: a false "undecodable
/// frame" warning on every joint of a loaded robot, seen in the VM).
#[test]
fn enable_is_sent_again_only_to_a_node_that_stays_disabled() {
    let mut rig = Rig::new(&cfg(Family::Anguilla, 2));
    let sent = rig.period(Nanos::ZERO, Drive::Enable, Mode::Enabling, true);
    assert_eq!(enables(&sent), vec![0], "one Enable to every node");
    // Both nodes' heartbeats, sent before they read it: Disabled.
    feed(
        &mut rig,
        50 * MS,
        &[
            anguilla_hb(1, NodeState::Disabled, 1),
            anguilla_hb(2, NodeState::Disabled, 1),
        ],
    );
    let sent = rig.period(110 * MS, Drive::Enable, Mode::Enabling, false);
    assert_eq!(enables(&sent), Vec::<u8>::new(), "one late heartbeat each");
    // Node 1 enabled; node 2 missed the Enable and says Disabled again.
    feed(
        &mut rig,
        150 * MS,
        &[
            anguilla_hb(1, NodeState::Enabled, 2),
            anguilla_hb(2, NodeState::Disabled, 2),
        ],
    );
    let sent = rig.period(220 * MS, Drive::Enable, Mode::Enabling, false);
    assert_eq!(enables(&sent), vec![2], "node 2 only");
    // Node 2's next heartbeat (still the one before it read the new
    // Enable): not sent again yet.
    feed(
        &mut rig,
        250 * MS,
        &[anguilla_hb(2, NodeState::Disabled, 3)],
    );
    let sent = rig.period(330 * MS, Drive::Enable, Mode::Enabling, false);
    assert_eq!(enables(&sent), Vec::<u8>::new());
}
