//! The simulated CiA 402 joint (two drives) driven directly with frames
//! built by the protocol's CANopen codec, as the daemon's master will
//! (docs/drives.md), on simulated time: no daemon, no bus, no wall clock.

use anguilla_protocol::Frame;
use anguilla_protocol::canopen::cia402::{self, Command, DriveState};
use anguilla_protocol::canopen::{
    AbortCode, Message, NmtCommand, NmtState, NodeId, Object, Pdo, PdoData, SdoData, SdoRequest,
    SdoResponse, SegmentData, decode,
};
use anguilla_protocol::frame::Id;
use anguilla_protocol::message::{ErrorBits, NodeState};
use anguilla_protocol::time::Nanos;
use anguilla_sim::actuator::Load;
use anguilla_sim::cia402::{self as sim, Cia402Joint, Cia402JointConfig, RAD_PER_INCREMENT};
use anguilla_sim::device::JointDevice;
use proptest::prelude::*;

const MS: Nanos = Nanos::from_millis(1);
const PITCH: u8 = 1;
const YAW: u8 = 2;
const MASTER: u8 = 127;
/// The control period of these tests (µs), as `[control]` would give.
const PERIOD_US: u32 = 2000;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

struct Bench {
    joint: Cia402Joint,
    now: Nanos,
    out: Vec<Frame>,
    /// When `period` last sent the master's heartbeat.
    master_heartbeat: Option<Nanos>,
}

impl Bench {
    /// Joint 0 (drives 1 and 2), powered at 0, not yet booted.
    fn cold() -> Self {
        Bench {
            joint: Cia402Joint::new(Cia402JointConfig::for_joint(0, 11), Nanos::ZERO),
            now: Nanos::ZERO,
            out: Vec::new(),
            master_heartbeat: None,
        }
    }

    /// Booted: both drives pre-operational, the boot-ups drained.
    fn booted() -> Self {
        let mut b = Self::cold();
        b.wait(30 * MS);
        b.out.clear();
        b
    }

    fn frame(&mut self, f: &Frame) {
        let out = &mut self.out;
        self.joint.receive(self.now, f, &mut |f| out.push(f));
    }

    fn send(&mut self, m: Message) {
        self.frame(&m.encode());
    }

    fn wait(&mut self, dt: Nanos) {
        self.now += dt;
        let out = &mut self.out;
        self.joint.advance(self.now, &mut |f| out.push(f));
    }

    fn take(&mut self) -> Vec<Frame> {
        std::mem::take(&mut self.out)
    }

    fn decoded(&mut self) -> Vec<Message> {
        self.take().iter().filter_map(|f| decode(f).ok()).collect()
    }

    fn nmt(&mut self, command: NmtCommand, to: Option<u8>) {
        self.send(Message::Nmt {
            command,
            node: to.map(node),
        });
    }

    fn sync(&mut self) {
        self.send(Message::Sync { counter: None });
    }

    /// The one SDO response of node `n` to a request.
    fn sdo(&mut self, n: u8, sdo: SdoRequest) -> SdoResponse {
        self.out.clear();
        self.send(Message::SdoRequest { node: node(n), sdo });
        let answers: Vec<SdoResponse> = self
            .decoded()
            .into_iter()
            .filter_map(|m| match m {
                Message::SdoResponse { node: from, sdo } if from == node(n) => Some(sdo),
                _ => None,
            })
            .collect();
        assert_eq!(answers.len(), 1, "one answer to {sdo:?}: {answers:?}");
        answers[0]
    }

    fn write(&mut self, n: u8, index: u16, sub: u8, bytes: &[u8]) -> SdoResponse {
        self.sdo(
            n,
            SdoRequest::Download {
                object: Object::new(index, sub),
                data: SdoData::new(bytes).unwrap(),
            },
        )
    }

    /// A write that must be acknowledged.
    fn set(&mut self, n: u8, index: u16, sub: u8, bytes: &[u8]) {
        let r = self.write(n, index, sub, bytes);
        assert_eq!(
            r,
            SdoResponse::DownloadAck {
                object: Object::new(index, sub)
            },
            "node {n} writing 0x{index:04X}:{sub:02X}"
        );
    }

    fn read(&mut self, n: u8, index: u16, sub: u8) -> SdoResponse {
        self.sdo(
            n,
            SdoRequest::Upload {
                object: Object::new(index, sub),
            },
        )
    }

    /// An expedited read that must succeed: the value zero-extended.
    fn get(&mut self, n: u8, index: u16, sub: u8) -> u32 {
        match self.read(n, index, sub) {
            SdoResponse::Upload { data, .. } => data.as_u32(),
            other => panic!("node {n} reading 0x{index:04X}:{sub:02X}: {other:?}"),
        }
    }

    /// The raw 8 bytes node `n` answers to a raw SDO request.
    fn raw_sdo(&mut self, n: u8, d: [u8; 8]) -> [u8; 8] {
        self.out.clear();
        self.frame(&Frame::new_standard(0x600 + u16::from(n), &d).unwrap());
        let answers: Vec<[u8; 8]> = self
            .take()
            .iter()
            .filter(|f| f.id() == Id::standard(0x580 + u16::from(n)).unwrap())
            .map(|f| f.data().try_into().unwrap())
            .collect();
        assert_eq!(answers.len(), 1, "one answer to {d:02X?}");
        answers[0]
    }

    /// A segmented upload (CiA 301): the bytes, or the abort code.
    fn upload_segmented(&mut self, n: u8, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        let size = match self.read(n, index, sub) {
            SdoResponse::UploadSegmented { size, .. } => size.expect("size indicated"),
            SdoResponse::Abort { code, .. } => return Err(code),
            other => panic!("expected a segmented upload, got {other:?}"),
        };
        let mut got = Vec::new();
        let mut toggle = false;
        loop {
            match self.sdo(n, SdoRequest::UploadSegment { toggle }) {
                SdoResponse::UploadSegment {
                    toggle: t,
                    data,
                    last,
                } => {
                    assert_eq!(t, toggle, "the toggle of the request answered");
                    got.extend_from_slice(data.bytes());
                    if last {
                        break;
                    }
                }
                SdoResponse::Abort { code, .. } => return Err(code),
                other => panic!("expected an upload segment, got {other:?}"),
            }
            toggle = !toggle;
        }
        assert_eq!(got.len(), size as usize, "indicated size");
        Ok(got)
    }

    /// A segmented download (CiA 301) of `data`, size indicated.
    fn download_segmented(
        &mut self,
        n: u8,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<(), AbortCode> {
        let object = Object::new(index, sub);
        match self.sdo(
            n,
            SdoRequest::DownloadSegmented {
                object,
                size: Some(data.len() as u32),
            },
        ) {
            SdoResponse::DownloadAck { object: o } => assert_eq!(o, object),
            SdoResponse::Abort { code, .. } => return Err(code),
            other => panic!("expected the initiate download response, got {other:?}"),
        }
        let mut toggle = false;
        let chunks: Vec<&[u8]> = data.chunks(SegmentData::MAX).collect();
        for (k, chunk) in chunks.iter().enumerate() {
            let segment = SdoRequest::DownloadSegment {
                toggle,
                data: SegmentData::new(chunk).unwrap(),
                last: k + 1 == chunks.len(),
            };
            match self.sdo(n, segment) {
                SdoResponse::DownloadSegmentAck { toggle: t } => assert_eq!(t, toggle),
                SdoResponse::Abort { code, .. } => return Err(code),
                other => panic!("expected a segment response, got {other:?}"),
            }
            toggle = !toggle;
        }
        Ok(())
    }

    /// Steps 1-5 of docs/drives.md's start-up for drive `n`, every SDO
    /// acknowledged.
    fn configure(&mut self, n: u8) {
        let id = u32::from(n);
        // 1.
        assert_eq!(self.get(n, 0x1000, 0) & 0xFFFF, 0x0192, "a CiA 402 device");
        let name = self.upload_segmented(n, 0x1008, 0).unwrap();
        assert_eq!(name, b"anguilla simulated CiA 402 axis");
        assert_eq!(self.get(n, cia402::RATED_TORQUE, 0), 500);
        // 2. RPDO1.
        self.set(n, 0x1400, 1, &(0x8000_0200 + id).to_le_bytes());
        self.set(n, 0x1400, 2, &[1]);
        self.set(n, 0x1600, 0, &[0]);
        self.set(n, 0x1600, 1, &0x6040_0010u32.to_le_bytes());
        self.set(n, 0x1600, 2, &0x607A_0020u32.to_le_bytes());
        self.set(n, 0x1600, 3, &0x60B2_0010u32.to_le_bytes());
        self.set(n, 0x1600, 0, &[3]);
        self.set(n, 0x1400, 1, &(0x200 + id).to_le_bytes());
        // 3. TPDO1.
        self.set(n, 0x1800, 1, &(0x8000_0180 + id).to_le_bytes());
        self.set(n, 0x1800, 2, &[1]);
        self.set(n, 0x1A00, 0, &[0]);
        self.set(n, 0x1A00, 1, &0x6041_0010u32.to_le_bytes());
        self.set(n, 0x1A00, 2, &0x6064_0020u32.to_le_bytes());
        self.set(n, 0x1A00, 3, &0x6077_0010u32.to_le_bytes());
        self.set(n, 0x1A00, 0, &[3]);
        self.set(n, 0x1800, 1, &(0x180 + id).to_le_bytes());
        // 4.
        self.set(n, 0x1006, 0, &PERIOD_US.to_le_bytes());
        self.set(n, 0x60C2, 1, &[(PERIOD_US / 1000) as u8]);
        self.set(n, 0x60C2, 2, &[(-3i8) as u8]);
        self.set(n, cia402::MODES_OF_OPERATION, 0, &[8]);
        assert_eq!(self.get(n, cia402::MODES_OF_OPERATION_DISPLAY, 0), 8);
        // 5.
        self.set(n, 0x1017, 0, &100u16.to_le_bytes());
        self.set(n, 0x1016, 1, &(u32::from(MASTER) << 16 | 100).to_le_bytes());
    }

    /// Both drives configured and started.
    fn operational() -> Self {
        let mut b = Self::booted();
        for n in [PITCH, YAW] {
            b.configure(n);
        }
        b.nmt(NmtCommand::Start, None);
        b.out.clear();
        b
    }

    /// One control period: RPDO1 to each drive (controlword, target
    /// increments, torque offset ‰), SYNC, the master's heartbeat every
    /// 50 periods, then wait a period. Returns each drive's TPDO1
    /// (statusword, position actual, torque actual).
    fn period(&mut self, rpdo: [(u16, i32, i16); 2]) -> [Option<(u16, i32, i16)>; 2] {
        for (n, (cw, target, torque)) in [PITCH, YAW].into_iter().zip(rpdo) {
            let mut d = [0u8; 8];
            d[0..2].copy_from_slice(&cw.to_le_bytes());
            d[2..6].copy_from_slice(&target.to_le_bytes());
            d[6..8].copy_from_slice(&torque.to_le_bytes());
            self.send(Message::Rpdo {
                node: node(n),
                pdo: Pdo::One,
                data: PdoData::new(&d).unwrap(),
            });
        }
        self.sync();
        if (self.now.as_nanos() / (2 * MS).as_nanos()).is_multiple_of(50) {
            self.send(Message::Heartbeat {
                node: node(MASTER),
                state: NmtState::Operational,
            });
            self.master_heartbeat = Some(self.now);
        }
        let mut tpdo = [None; 2];
        for m in self.decoded() {
            if let Message::Tpdo {
                node: from,
                pdo: Pdo::One,
                data,
            } = m
            {
                let d = data.bytes();
                assert_eq!(d.len(), 8, "TPDO1 as mapped");
                let i = usize::from(from.get() - 1);
                tpdo[i] = Some((
                    u16::from_le_bytes([d[0], d[1]]),
                    i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
                    i16::from_le_bytes([d[6], d[7]]),
                ));
            }
        }
        self.wait(Nanos::from_nanos(u64::from(PERIOD_US) * 1000));
        tpdo
    }

    /// The master's enabling procedure (docs/drives.md) until both drives
    /// report Operation enabled; targets are the actual positions.
    fn enable(&mut self) -> [i32; 2] {
        let mut status = [(0u16, 0i32, 0i16); 2];
        let mut previous_cw = [0u16; 2];
        for _ in 0..20 {
            let mut rpdo = [(0, 0, 0); 2];
            for i in 0..2 {
                let state = DriveState::from_statusword(status[i].0).unwrap();
                let cmd = state
                    .next_toward_enabled()
                    .unwrap_or(Command::DisableVoltage);
                let mut cw = cmd.word();
                if cmd == Command::FaultReset && previous_cw[i] & 0x80 != 0 {
                    cw = 0; // a rising edge needs bit 7 clear first
                }
                previous_cw[i] = cw;
                rpdo[i] = (cw, status[i].1, 0);
            }
            let t = self.period(rpdo);
            for i in 0..2 {
                status[i] = t[i].expect("TPDO1 on every SYNC");
            }
            if status
                .iter()
                .all(|s| DriveState::from_statusword(s.0) == Ok(DriveState::OperationEnabled))
            {
                return [status[0].1, status[1].1];
            }
        }
        panic!("not enabled: {status:04X?}");
    }

    fn emcys(&mut self) -> Vec<(u8, u16, u8)> {
        self.decoded()
            .into_iter()
            .filter_map(|m| match m {
                Message::Emcy { node, emcy } => Some((node.get(), emcy.code, emcy.register)),
                _ => None,
            })
            .collect()
    }
}

fn abort(index: u16, sub: u8, code: AbortCode) -> SdoResponse {
    SdoResponse::Abort {
        object: Object::new(index, sub),
        code,
    }
}

#[test]
fn boots_into_pre_operational_with_a_boot_up_message() {
    let mut b = Bench::cold();
    b.wait(19 * MS);
    assert!(b.out.is_empty(), "silent while booting");
    assert_eq!(b.joint.state(), NodeState::Boot);
    assert_eq!(b.joint.axis(0).nmt_state(), None);
    b.wait(2 * MS);
    let frames = b.take();
    let ids: Vec<(u32, Vec<u8>)> = frames
        .iter()
        .map(|f| (f.id().raw(), f.data().to_vec()))
        .collect();
    assert_eq!(ids, vec![(0x701, vec![0x00]), (0x702, vec![0x00])]);
    for a in 0..2 {
        assert_eq!(b.joint.axis(a).nmt_state(), Some(NmtState::PreOperational));
        assert_eq!(b.joint.axis(a).drive_state(), DriveState::SwitchOnDisabled);
        // Switch on disabled (0x40) and remote (bit 9).
        assert_eq!(b.joint.axis(a).statusword(), 0x0240);
    }
    assert_eq!(b.joint.state(), NodeState::Disabled);
    // No heartbeat producer by default (0x1017 = 0), no PDO before start.
    b.wait(500 * MS);
    b.sync();
    assert!(b.out.is_empty(), "{:?}", b.out);
}

#[test]
fn the_start_up_sequence_of_the_contract_then_tpdo1_on_sync() {
    let mut b = Bench::booted();
    for n in [PITCH, YAW] {
        b.configure(n);
    }
    // PDOs do not flow before NMT start.
    b.sync();
    assert!(b.take().is_empty());
    b.nmt(NmtCommand::Start, Some(PITCH));
    assert_eq!(b.joint.axis(0).nmt_state(), Some(NmtState::Operational));
    assert_eq!(b.joint.axis(1).nmt_state(), Some(NmtState::PreOperational));
    b.nmt(NmtCommand::Start, None);
    b.out.clear();
    // Shutdown with target 0: applied at the SYNC, reported by TPDO1.
    let t = b.period([(0x06, 0, 0), (0x06, 0, 0)]);
    for (i, tpdo) in t.iter().enumerate() {
        // Ready to switch on 0x21, voltage enabled bit 4, remote bit 9;
        // the joint at rest at 0: position and torque 0.
        assert_eq!(*tpdo, Some((0x0231, 0, 0)), "drive {}", i + 1);
    }
    // The exact bytes on 0x181.
    b.send(Message::Rpdo {
        node: node(PITCH),
        pdo: Pdo::One,
        data: PdoData::new(&[0x06, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
    });
    b.sync();
    let f = b
        .take()
        .into_iter()
        .find(|f| f.id().raw() == 0x181)
        .unwrap();
    assert_eq!(f.data(), &[0x31, 0x02, 0, 0, 0, 0, 0, 0]);
    // The producer heartbeat (0x1017 = 100 ms) says operational.
    b.wait(250 * MS);
    let states: Vec<_> = b
        .decoded()
        .into_iter()
        .filter_map(|m| match m {
            Message::Heartbeat { node, state } if node.get() == PITCH => Some(state),
            _ => None,
        })
        .collect();
    assert_eq!(states, vec![NmtState::Operational; 2]);
}

#[test]
fn sdo_aborts_name_each_error() {
    let mut b = Bench::booted();
    let n = PITCH;
    assert_eq!(
        b.read(n, 0x2FFF, 0),
        abort(0x2FFF, 0, AbortCode::ObjectDoesNotExist)
    );
    assert_eq!(
        b.read(n, 0x1018, 9),
        abort(0x1018, 9, AbortCode::SubIndexDoesNotExist)
    );
    assert_eq!(
        b.write(n, 0x6041, 0, &[0, 0]),
        abort(0x6041, 0, AbortCode::WriteReadOnly)
    );
    assert_eq!(
        b.write(n, 0x1008, 0, b"x"),
        abort(0x1008, 0, AbortCode::WriteReadOnly),
        "const"
    );
    assert_eq!(
        b.read(n, 0x2001, 0),
        abort(0x2001, 0, AbortCode::ReadWriteOnly)
    );
    assert_eq!(
        b.write(n, 0x6040, 0, &[6, 0, 0, 0]),
        abort(0x6040, 0, AbortCode::LengthTooHigh)
    );
    assert_eq!(
        b.write(n, 0x1017, 0, &[100]),
        abort(0x1017, 0, AbortCode::LengthTooLow)
    );
    assert_eq!(
        b.write(n, 0x6060, 0, &[3]),
        abort(0x6060, 0, AbortCode::InvalidValue),
        "only CSP (8) or none (0)"
    );
    assert_eq!(
        b.write(n, 0x1400, 2, &[250]),
        abort(0x1400, 2, AbortCode::InvalidValue),
        "transmission type 241..=253"
    );
    // RPDO1 exists by default (0x201): its COB-ID cannot change, nor its
    // mapping.
    assert_eq!(
        b.write(n, 0x1400, 1, &0x301u32.to_le_bytes()),
        abort(0x1400, 1, AbortCode::InvalidValue)
    );
    assert_eq!(
        b.write(n, 0x1600, 0, &[0]),
        abort(0x1600, 0, AbortCode::ParameterIncompatible)
    );
    b.set(n, 0x1400, 1, &0x8000_0201u32.to_le_bytes());
    // Entries only while the count is 0.
    assert_eq!(
        b.write(n, 0x1600, 1, &0x6040_0010u32.to_le_bytes()),
        abort(0x1600, 1, AbortCode::ParameterIncompatible)
    );
    b.set(n, 0x1600, 0, &[0]);
    for (entry, why) in [
        (0x6041_0010u32, "read-only statusword in an RPDO"),
        (0x6076_0020, "rated torque is not mappable"),
        (0x6040_0020, "wrong length"),
        (0x7000_0010, "no such object"),
    ] {
        assert_eq!(
            b.write(n, 0x1600, 1, &entry.to_le_bytes()),
            abort(0x1600, 1, AbortCode::NotMappable),
            "{why}"
        );
    }
    for sub in 1..=3 {
        b.set(n, 0x1600, sub, &0x607A_0020u32.to_le_bytes());
    }
    assert_eq!(
        b.write(n, 0x1600, 0, &[3]),
        abort(0x1600, 0, AbortCode::PdoLengthExceeded),
        "96 bits"
    );
    assert_eq!(
        b.write(n, 0x1600, 0, &[4]),
        abort(0x1600, 0, AbortCode::ParameterIncompatible),
        "entry 4 is empty"
    );
    assert_eq!(
        b.write(n, 0x1600, 0, &[9]),
        abort(0x1600, 0, AbortCode::ValueTooHigh)
    );
    b.set(n, 0x1600, 0, &[2]);
    // In operational the count cannot change, even of a disabled PDO.
    b.nmt(NmtCommand::Start, Some(n));
    assert_eq!(
        b.write(n, 0x1600, 0, &[1]),
        abort(0x1600, 0, AbortCode::DeviceState)
    );
    // A segment out of turn, a toggle not alternated, an unknown
    // command specifier (block download).
    let d = b.raw_sdo(n, [0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
        AbortCode::InvalidCommandSpecifier.raw()
    );
    assert!(matches!(
        b.read(n, 0x1008, 0),
        SdoResponse::UploadSegmented { .. }
    ));
    let d = b.raw_sdo(n, [0x70, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(d[0], 0x80);
    assert_eq!(
        u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
        AbortCode::ToggleBitNotAlternated.raw()
    );
    let d = b.raw_sdo(n, [0xC6, 0x00, 0x10, 0, 0, 0, 0, 0]);
    assert_eq!(
        d,
        [0x80, 0x00, 0x10, 0, 0x01, 0x00, 0x04, 0x05],
        "0x0504_0001 for 0x1000:00"
    );
    // The other drive saw none of it.
    assert_eq!(b.get(YAW, 0x1400, 1), 0x202);
}

#[test]
fn segmented_upload_and_download() {
    let mut b = Bench::booted();
    let name = b.upload_segmented(YAW, 0x1008, 0).unwrap();
    assert_eq!(
        String::from_utf8(name).unwrap(),
        "anguilla simulated CiA 402 axis"
    );
    // The axis label 0x2000 is a writable string: 17 bytes in 3 segments.
    b.download_segmented(YAW, 0x2000, 0, b"tail fin, yaw 7/8")
        .unwrap();
    assert_eq!(
        b.upload_segmented(YAW, 0x2000, 0).unwrap(),
        b"tail fin, yaw 7/8"
    );
    assert_eq!(
        b.joint.axis(1).value(0x2000, 0).unwrap(),
        b"tail fin, yaw 7/8"
    );
    // Exactly 7 bytes: one segment.
    b.download_segmented(YAW, 0x2000, 0, b"7 bytes").unwrap();
    assert_eq!(b.upload_segmented(YAW, 0x2000, 0).unwrap(), b"7 bytes");
    // Too long for the string, to a const string, to nothing.
    assert_eq!(
        b.download_segmented(YAW, 0x2000, 0, &[b'x'; 40]),
        Err(AbortCode::LengthTooHigh)
    );
    assert_eq!(
        b.download_segmented(YAW, 0x1008, 0, b"renamed!"),
        Err(AbortCode::WriteReadOnly)
    );
    assert_eq!(
        b.download_segmented(YAW, 0x2100, 0, b"nothing."),
        Err(AbortCode::ObjectDoesNotExist)
    );
    // A segment whose toggle does not alternate aborts the transfer.
    let d = b.raw_sdo(YAW, [0x21, 0x00, 0x20, 0, 14, 0, 0, 0]);
    assert_eq!(d[0], 0x60);
    let d = b.raw_sdo(YAW, [0x00, b'a', b'b', b'c', b'd', b'e', b'f', b'g']);
    assert_eq!(d[0], 0x20);
    let d = b.raw_sdo(YAW, [0x01, b'h', b'i', b'j', b'k', b'l', b'm', b'n']);
    assert_eq!(
        d,
        [0x80, 0x00, 0x20, 0, 0x00, 0x00, 0x03, 0x05],
        "0x0503_0000"
    );
    assert_eq!(b.upload_segmented(YAW, 0x2000, 0).unwrap(), b"7 bytes");
    // The client's abort ends an upload: the next segment request is out
    // of turn.
    assert!(matches!(
        b.read(YAW, 0x1008, 0),
        SdoResponse::UploadSegmented { .. }
    ));
    b.send(Message::SdoRequest {
        node: node(YAW),
        sdo: SdoRequest::Abort {
            object: Object::new(0x1008, 0),
            code: AbortCode::Timeout,
        },
    });
    assert!(b.take().is_empty(), "no answer to an abort");
    let d = b.raw_sdo(YAW, [0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(d[0], 0x80);
}

#[test]
fn rpdo_controlwords_reach_operation_enabled_and_csp_moves_the_joint() {
    let mut b = Bench::operational();
    let start = b.enable();
    assert_eq!(start, [0, 0]);
    assert_eq!(b.joint.state(), NodeState::Enabled);
    for a in 0..2 {
        // Operation enabled 0x27, voltage, remote, CSP following (bit 12).
        assert_eq!(b.joint.axis(a).statusword(), 0x1237);
    }
    // Pitch to +0.3 rad, yaw to −0.2 rad, for 0.5 s.
    let target = |rad: f64| (rad / RAD_PER_INCREMENT).round() as i32;
    let mut last = [None; 2];
    for _ in 0..250 {
        last = b.period([(0x0F, target(0.3), 0), (0x0F, target(-0.2), 0)]);
    }
    // The actuator (kp 40 N·m/rad, no load) settles well within 0.5 s;
    // 0.005 rad is 3 encoder counts of the default 4096-count encoder.
    let (th0, w0, _) = b.joint.kinematics(0);
    let (th1, _, _) = b.joint.kinematics(1);
    assert!((th0 - 0.3).abs() < 0.005, "pitch at {th0}");
    assert!(w0.abs() < 0.05, "and at rest: {w0}");
    assert!((th1 + 0.2).abs() < 0.005, "yaw at {th1}");
    // TPDO1 reports the measured position in increments (the encoder
    // quantizes to 16 increments).
    let (sw, pos, _) = last[0].unwrap();
    assert_eq!(
        DriveState::from_statusword(sw),
        Ok(DriveState::OperationEnabled)
    );
    assert!(
        (f64::from(pos) * RAD_PER_INCREMENT - th0).abs() < 0.002,
        "{pos}"
    );
    // A torque offset of 200 ‰ of 500 mN·m is 0.1 N·m of feedforward;
    // against a 0.2 N·m load the joint rests where kp (θ* − θ) + 0.1 =
    // 0.2, i.e. 0.1 / 40 = 0.0025 rad short of the target, the motor
    // giving 0.2 N·m = 400 ‰. Settled after 0.5 s (ωn 45 rad/s, ζ 0.67):
    // 0.0003 rad is 2 % of the 0.0025 rad offset, ±2 ‰ the rounding and
    // the settling residue.
    b.joint.set_load([
        Load {
            torque: 0.2,
            ..Load::default()
        },
        Load::default(),
    ]);
    for _ in 0..250 {
        last = b.period([(0x0F, target(0.3), 200), (0x0F, target(-0.2), 0)]);
    }
    let (th0, _, _) = b.joint.kinematics(0);
    assert!((th0 - 0.2975).abs() < 0.0003, "pitch at {th0}");
    assert!((b.joint.motor_torque(0) - 0.2).abs() < 0.001);
    let (_, _, permille) = last[0].unwrap();
    assert!(
        (i32::from(permille) - 400).abs() <= 2,
        "torque actual {permille} ‰"
    );
    // Disable voltage: limp, Switch on disabled.
    b.period([(0x00, 0, 0), (0x00, 0, 0)]);
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::SwitchOnDisabled);
    assert_eq!(b.joint.state(), NodeState::Disabled);
    b.wait(MS);
    assert_eq!(b.joint.motor_torque(0), 0.0);
}

#[test]
fn sdo_controlwords_act_at_once_and_csp_needs_mode_8() {
    let mut b = Bench::booted();
    let n = PITCH;
    for cw in [0x06u16, 0x07, 0x0F] {
        b.set(n, 0x6040, 0, &cw.to_le_bytes());
    }
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::OperationEnabled);
    // Mode 0: no CSP, bit 12 clear, the actuator limp.
    assert_eq!(b.get(n, 0x6041, 0), 0x0237);
    b.set(n, 0x6060, 0, &[8]);
    assert_eq!(b.get(n, 0x6041, 0), 0x1237);
    // Disable operation (0x07) → Switched on; Shutdown → Ready.
    b.set(n, 0x6040, 0, &0x07u16.to_le_bytes());
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::SwitchedOn);
    b.set(n, 0x6040, 0, &0x06u16.to_le_bytes());
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::ReadyToSwitchOn);
    // Enable operation from Ready to switch on: switch on + enable.
    b.set(n, 0x6040, 0, &0x0Fu16.to_le_bytes());
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::OperationEnabled);
    // The yaw drive never left Switch on disabled: the joint is Disabled.
    assert_eq!(b.joint.state(), NodeState::Disabled);
}

#[test]
fn quick_stop_holds_then_switch_on_disabled() {
    let mut b = Bench::operational();
    b.enable();
    let target = (0.5 / RAD_PER_INCREMENT) as i32;
    for _ in 0..20 {
        b.period([(0x0F, target, 0), (0x0F, 0, 0)]);
    }
    let (moving_at, w, _) = b.joint.kinematics(0);
    assert!(w > 0.5, "moving: {w}");
    // E-stop: Quick stop in every RPDO.
    let t = b.period([(0x02, 0, 0), (0x02, 0, 0)]);
    assert_eq!(b.joint.state(), NodeState::EStop);
    assert_eq!(
        DriveState::from_statusword(t[0].unwrap().0),
        Ok(DriveState::QuickStopActive)
    );
    // The yaw axis was at rest: stopped at once.
    let mut states = Vec::new();
    for _ in 0..100 {
        let t = b.period([(0x02, 0, 0), (0x02, 0, 0)]);
        states.push(DriveState::from_statusword(t[0].unwrap().0).unwrap());
    }
    assert_eq!(states.last(), Some(&DriveState::SwitchOnDisabled));
    assert_eq!(b.joint.axis(1).drive_state(), DriveState::SwitchOnDisabled);
    // It held near where the quick stop found it: braked at the 4 N·m
    // limit (200 rad/s² on 0.02 kg·m²), a joint at the 8 rad/s no-load
    // speed stops within 8² / 400 = 0.16 rad.
    let (th, _, _) = b.joint.kinematics(0);
    assert!((th - moving_at).abs() < 0.2, "{th} vs {moving_at}");
    assert_eq!(b.joint.state(), NodeState::Disabled);
    // Quick stop keeps it there; Shutdown restarts the enabling.
    b.period([(0x02, 0, 0), (0x02, 0, 0)]);
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::SwitchOnDisabled);
    b.enable();
}

#[test]
fn an_injected_fault_sends_emcy_and_fault_reset_sends_emcy_0000() {
    let mut b = Bench::operational();
    b.enable();
    let out = &mut b.out;
    b.joint
        .inject_fault(ErrorBits::OVER_TEMPERATURE, b.now, &mut |f| out.push(f));
    assert_eq!(
        b.emcys(),
        vec![(PITCH, 0x4210, 0x09), (YAW, 0x4210, 0x09)],
        "temperature, error register generic + temperature"
    );
    b.wait(MS);
    assert_eq!(b.joint.state(), NodeState::Fault);
    assert_eq!(b.get(PITCH, 0x1001, 0), 0x09);
    let t = b.period([(0x0F, 0, 0), (0x0F, 0, 0)]);
    assert_eq!(
        DriveState::from_statusword(t[0].unwrap().0),
        Ok(DriveState::Fault)
    );
    // Fault reset while the cause persists: still Fault.
    b.period([(0x80, 0, 0), (0x80, 0, 0)]);
    b.period([(0x00, 0, 0), (0x00, 0, 0)]);
    assert_eq!(b.joint.state(), NodeState::Fault);
    b.joint.clear_injected_fault();
    b.out.clear();
    b.period([(0x80, 0, 0), (0x80, 0, 0)]);
    assert_eq!(b.joint.state(), NodeState::Disabled);
    // Bit 7 held high is no new edge; the EMCYs went out at the reset.
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::SwitchOnDisabled);
    b.out.clear();
    let mut b2 = Bench::operational();
    b2.enable();
    let out = &mut b2.out;
    b2.joint
        .inject_fault(ErrorBits::WATCHDOG, b2.now, &mut |f| out.push(f));
    assert_eq!(b2.emcys(), vec![(PITCH, 0x1000, 0x01), (YAW, 0x1000, 0x01)]);
    b2.joint.clear_injected_fault();
    b2.period([(0x00, 0, 0), (0x00, 0, 0)]);
    b2.out.clear();
    b2.send(Message::Rpdo {
        node: node(PITCH),
        pdo: Pdo::One,
        data: PdoData::new(&[0x80, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
    });
    b2.sync();
    assert_eq!(b2.emcys(), vec![(PITCH, 0x0000, 0x00)], "error reset");
    assert_eq!(b2.get(PITCH, 0x1001, 0), 0);
    assert_eq!(b2.joint.axis(1).drive_state(), DriveState::Fault);
    b2.enable();
    assert_eq!(b2.joint.state(), NodeState::Enabled);
}

#[test]
fn the_sync_watchdog_faults_a_drive_whose_master_died() {
    let mut b = Bench::operational();
    b.enable();
    b.out.clear();
    // No more SYNC after the one 2 ms ago: 3 × 2 ms is under the 100 ms
    // floor, so 100 ms after it, Fault with EMCY 0x8700.
    b.wait(97 * MS);
    assert_eq!(b.joint.state(), NodeState::Enabled, "100 ms are tolerated");
    b.wait(2 * MS);
    assert_eq!(b.joint.state(), NodeState::Fault);
    assert_eq!(b.emcys(), vec![(PITCH, 0x8700, 0x11), (YAW, 0x8700, 0x11)]);
    assert_eq!(b.joint.counters().watchdog_expiries, 2);
    b.wait(MS);
    assert_eq!(b.joint.motor_torque(0), 0.0, "limp in Fault");
    // No watchdog outside Operation enabled, nor with 0x1006 = 0.
    let mut b = Bench::booted();
    b.set(PITCH, 0x6040, 0, &0x06u16.to_le_bytes());
    b.wait(100 * MS);
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::ReadyToSwitchOn);
    b.set(PITCH, 0x6040, 0, &0x0Fu16.to_le_bytes());
    b.wait(100 * MS);
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::OperationEnabled);
}

#[test]
fn the_heartbeat_consumer_faults_with_emcy_8130() {
    let mut b = Bench::operational();
    b.enable();
    // `period` sends the master's heartbeat every 100 ms: no fault.
    for _ in 0..200 {
        b.period([(0x0F, 0, 0), (0x0F, 0, 0)]);
    }
    assert_eq!(b.joint.state(), NodeState::Enabled);
    b.out.clear();
    // The master's heartbeat stops (SYNC and RPDOs go on).
    let mut periods = 0;
    while b.joint.state() == NodeState::Enabled && periods < 200 {
        for (n, cw) in [(PITCH, 0x0Fu16), (YAW, 0x0F)] {
            let mut d = [0u8; 8];
            d[0..2].copy_from_slice(&cw.to_le_bytes());
            b.send(Message::Rpdo {
                node: node(n),
                pdo: Pdo::One,
                data: PdoData::new(&d).unwrap(),
            });
        }
        b.sync();
        b.wait(2 * MS);
        periods += 1;
    }
    // Consumer time 100 ms: the fault comes in the 2 ms period after
    // 100 ms have passed since the last heartbeat.
    let silence = b.now.saturating_sub(b.master_heartbeat.unwrap());
    assert!(
        silence > 100 * MS && silence <= 102 * MS,
        "fault after {silence} ns ({periods} periods)"
    );
    assert_eq!(b.joint.state(), NodeState::Fault);
    assert_eq!(b.emcys(), vec![(PITCH, 0x8130, 0x11), (YAW, 0x8130, 0x11)]);
}

#[test]
fn short_rpdos_are_ignored_counted_and_reported() {
    let mut b = Bench::operational();
    b.send(Message::Rpdo {
        node: node(PITCH),
        pdo: Pdo::One,
        data: PdoData::new(&[0x06, 0, 0, 0]).unwrap(),
    });
    assert_eq!(b.emcys(), vec![(PITCH, 0x8210, 0x11)]);
    assert_eq!(b.joint.counters().bad_frames, 1);
    b.sync();
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::SwitchOnDisabled);
    assert_eq!(b.joint.counters().applied, 0);
    // A longer one is used (its first bytes).
    b.send(Message::Rpdo {
        node: node(PITCH),
        pdo: Pdo::One,
        data: PdoData::new(&[0x06, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
    });
    b.sync();
    assert_eq!(b.joint.axis(0).drive_state(), DriveState::ReadyToSwitchOn);
    assert_eq!(b.joint.counters().applied, 1);
}

#[test]
fn pdos_follow_the_mapping_in_the_dictionary() {
    let mut b = Bench::booted();
    let n = YAW;
    // RPDO2 on a COB-ID of our choosing, applied at once (type 255):
    // controlword only.
    b.set(n, 0x1601, 1, &0x6040_0010u32.to_le_bytes());
    b.set(n, 0x1601, 0, &[1]);
    b.set(n, 0x1401, 2, &[255]);
    b.set(n, 0x1401, 1, &0x0000_0412u32.to_le_bytes());
    // TPDO2 every 3rd SYNC: modes display and statusword.
    b.set(n, 0x1A01, 1, &0x6061_0008u32.to_le_bytes());
    b.set(n, 0x1A01, 2, &0x6041_0010u32.to_le_bytes());
    b.set(n, 0x1A01, 0, &[2]);
    b.set(n, 0x1801, 2, &[3]);
    b.set(n, 0x1801, 1, &0x0000_0392u32.to_le_bytes());
    b.set(n, 0x1800, 1, &0x8000_0182u32.to_le_bytes());
    b.nmt(NmtCommand::Start, Some(n));
    b.frame(&Frame::new_standard(0x412, &[0x06, 0x00]).unwrap());
    assert_eq!(b.joint.axis(1).drive_state(), DriveState::ReadyToSwitchOn);
    let mut seen = Vec::new();
    for k in 0..9 {
        b.out.clear();
        b.sync();
        for f in b.take() {
            seen.push((k, f.id().raw(), f.data().to_vec()));
        }
    }
    let expected: Vec<_> = [2, 5, 8]
        .into_iter()
        .map(|k| (k, 0x392, vec![0x00, 0x31, 0x02]))
        .collect();
    assert_eq!(seen, expected);
}

#[test]
fn nmt_stop_pre_operational_and_resets() {
    let mut b = Bench::operational();
    // Stopped: heartbeats only; no SDO, no PDO, no SYNC.
    b.nmt(NmtCommand::Stop, Some(PITCH));
    b.out.clear();
    b.send(Message::SdoRequest {
        node: node(PITCH),
        sdo: SdoRequest::Upload {
            object: Object::new(0x1000, 0),
        },
    });
    b.sync();
    b.wait(150 * MS);
    let from_pitch: Vec<_> = b
        .decoded()
        .into_iter()
        .filter(|m| match m {
            Message::Heartbeat { node, .. }
            | Message::SdoResponse { node, .. }
            | Message::Tpdo { node, .. }
            | Message::Emcy { node, .. } => node.get() == PITCH,
            _ => false,
        })
        .collect();
    assert_eq!(
        from_pitch,
        vec![Message::Heartbeat {
            node: node(PITCH),
            state: NmtState::Stopped
        }]
    );
    b.nmt(NmtCommand::EnterPreOperational, Some(PITCH));
    assert_eq!(b.get(PITCH, 0x1000, 0), 0x0002_0192);
    // Reset communication: 0x1000-0x1FFF back to defaults, boot-up at
    // once, the drive's own objects kept.
    b.out.clear();
    b.nmt(NmtCommand::ResetCommunication, Some(PITCH));
    let boot: Vec<_> = b
        .take()
        .iter()
        .map(|f| (f.id().raw(), f.data().to_vec()))
        .collect();
    assert_eq!(boot, vec![(0x701, vec![0])]);
    assert_eq!(b.get(PITCH, 0x1017, 0), 0);
    assert_eq!(b.get(PITCH, 0x1A00, 0), 2, "default mapping");
    assert_eq!(b.get(PITCH, 0x6060, 0), 8, "kept");
    // Reset node: everything back to defaults, boot-up after the boot time.
    b.nmt(NmtCommand::ResetNode, Some(YAW));
    assert_eq!(b.joint.state(), NodeState::Boot);
    b.wait(25 * MS);
    assert_eq!(b.joint.axis(1).nmt_state(), Some(NmtState::PreOperational));
    assert_eq!(b.get(YAW, 0x6060, 0), 0);
    assert_eq!(b.get(YAW, 0x1016, 1), 0);
    // Node ids elsewhere are not ours.
    b.nmt(NmtCommand::Start, Some(3));
    assert_eq!(b.joint.axis(1).nmt_state(), Some(NmtState::PreOperational));
}

#[test]
fn leaving_operational_switches_the_power_stage_off() {
    let mut b = Bench::operational();
    b.enable();
    b.nmt(NmtCommand::EnterPreOperational, None);
    assert_eq!(b.joint.state(), NodeState::Disabled);
    b.wait(MS);
    assert_eq!(b.joint.motor_torque(0), 0.0);
}

#[test]
fn a_silent_drive_says_nothing_and_hears_nothing() {
    let mut b = Bench::cold();
    b.joint.set_silent(true);
    b.wait(100 * MS);
    assert!(b.out.is_empty(), "not even its boot-up");
    b.joint.set_silent(false);
    b.wait(MS);
    assert_eq!(b.take().len(), 2, "boot-ups once heard again");
    b = Bench::operational();
    b.enable();
    b.joint.set_silent(true);
    b.period([(0x00, 0, 0), (0x00, 0, 0)]);
    b.wait(300 * MS);
    b.send(Message::SdoRequest {
        node: node(PITCH),
        sdo: SdoRequest::Upload {
            object: Object::new(0x1000, 0),
        },
    });
    assert!(b.out.is_empty(), "{:?}", b.out);
    assert_eq!(b.joint.state(), NodeState::Enabled, "and hears nothing");
    // Reboot (fault injection): boots again, configuration lost.
    b.joint.set_silent(false);
    b.joint.reboot(b.now);
    assert_eq!(b.joint.state(), NodeState::Boot);
    b.wait(25 * MS);
    assert_eq!(b.get(PITCH, 0x1017, 0), 0);
    assert_eq!(b.joint.state(), NodeState::Disabled);
}

#[test]
fn configurations_are_validated_and_the_joint_is_a_joint_device() {
    use anguilla_sim::cia402::Cia402ConfigError;
    let mut cfg = Cia402JointConfig::for_joint(3, 0);
    assert_eq!(cfg.ids, [7, 8], "docs/drives.md: pitch 2j + 1, yaw 2j + 2");
    assert!(Cia402Joint::try_new(cfg, Nanos::ZERO).is_ok());
    cfg.ids = [7, 128];
    let e = Cia402Joint::try_new(cfg, Nanos::ZERO).unwrap_err();
    assert_eq!(e, Cia402ConfigError::NodeId { axis: 1, id: 128 });
    assert_eq!(
        e.to_string(),
        "CiA 402 node id 128 of axis 1 is out of range (expected 1..=127)"
    );
    cfg.ids = [9, 9];
    assert_eq!(cfg.validate(), Err(Cia402ConfigError::SameIds(9)));
    // An invalid id built anyway gives a drive that never talks.
    cfg.ids = [0, 9];
    let mut joint: Box<dyn JointDevice> = Box::new(Cia402Joint::new(cfg, Nanos::ZERO));
    let mut out = Vec::new();
    joint.advance(Nanos::from_millis(100), &mut |f| out.push(f.id().raw()));
    assert_eq!(out, vec![0x709]);
    assert_eq!(joint.state(), NodeState::Boot);
}

#[test]
fn the_eds_in_the_repository_is_the_generated_one() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/eds/anguilla-sim-cia402.eds");
    let generated = sim::eds();
    if std::env::var_os("ANGUILLA_WRITE_EDS").is_some() {
        std::fs::write(path, &generated).unwrap();
    }
    let stored = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        stored == generated,
        "{path} is not what anguilla_sim::cia402::eds() generates from the object dictionary; \
         regenerate it with `ANGUILLA_WRITE_EDS=1 cargo test -p anguilla-sim --test cia402 eds`"
    );
    // Every object of the table has its section.
    for o in sim::od::OBJECTS {
        assert!(generated.contains(&format!("\n[{:04X}]\n", o.index)));
    }
}

fn ids() -> impl Strategy<Value = u16> {
    prop_oneof![
        0u16..0x800,
        (
            prop::sample::select(vec![
                0x000u16, 0x080, 0x180, 0x200, 0x300, 0x400, 0x580, 0x600, 0x700
            ]),
            0u16..4
        )
            .prop_map(|(base, n)| base + n),
    ]
}

/// Any frame: random ids and bytes, and 8-byte SDO requests to the
/// drives naming entries of their dictionary (any command byte, sub-index
/// 0..=9, any data), which random bytes would rarely hit.
fn frames() -> impl Strategy<Value = (u16, Vec<u8>, u8)> {
    let indices: Vec<u16> = sim::od::OBJECTS.iter().map(|o| o.index).collect();
    prop_oneof![
        (ids(), proptest::collection::vec(any::<u8>(), 0..=8), 0u8..4),
        (
            0x601u16..=0x602,
            any::<u8>(),
            prop::sample::select(indices),
            0u8..10,
            any::<[u8; 4]>()
        )
            .prop_map(|(id, cmd, index, sub, data)| {
                let [lo, hi] = index.to_le_bytes();
                (
                    id,
                    vec![cmd, lo, hi, sub, data[0], data[1], data[2], data[3]],
                    0,
                )
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn garbage_frames_never_panic(frames in proptest::collection::vec(frames(), 0..300)) {
        let mut b = Bench::operational();
        b.enable();
        for (id, data, kind) in frames {
            let f = match kind {
                0 | 1 => Frame::new_standard(id, &data).unwrap(),
                2 => Frame::new(Id::extended(u32::from(id) << 7).unwrap(), &data).unwrap(),
                _ => Frame::new_remote(Id::standard(id).unwrap(), data.len() as u8).unwrap(),
            };
            b.frame(&f);
            b.wait(Nanos::from_nanos(300_000));
        }
        b.out.clear();
        // Whatever happened, a reset brings both drives back.
        b.nmt(NmtCommand::ResetNode, None);
        b.wait(25 * MS);
        prop_assert_eq!(b.get(PITCH, 0x1000, 0), 0x0002_0192);
        prop_assert_eq!(b.get(YAW, 0x1018, 4), 2);
    }
}
