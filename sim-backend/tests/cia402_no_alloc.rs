//! In steady state the simulated CiA 402 joint allocates nothing: its
//! `receive` and `advance` (SDO, PDOs, SYNC, heartbeats, the servo) run on
//! preallocated state, so an in-process robot of CiA 402 drives does not
//! disturb the daemon's allocation-free control period.

use anguilla_protocol::Frame;
use anguilla_protocol::canopen::{
    Message, NmtCommand, NmtState, NodeId, Object, Pdo, PdoData, SdoData, SdoRequest, cia402,
};
use anguilla_protocol::time::Nanos;
use anguilla_sim::cia402::{Cia402Joint, Cia402JointConfig};
use anguilla_sim::device::JointDevice;

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

const PERIOD: Nanos = Nanos::from_millis(2);

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// Frames a master sends in one period `k`: each drive's RPDO1 (default
/// mapping: controlword, target position), SYNC, and every 50 periods
/// the master's heartbeat and an SDO read of the statusword, or a
/// segmented upload of the device name 0x1008 (31 bytes, 5 segments).
fn master_frames(k: u32, statusword: [u16; 2], out: &mut [Frame; 9]) -> usize {
    let mut n = 0;
    for (i, sw) in statusword.iter().enumerate() {
        let cw = cia402::DriveState::from_statusword(*sw)
            .ok()
            .and_then(|s| s.next_toward_enabled())
            .map_or(0, |c| c.word());
        let target = ((k as f64 * 0.01).sin() * 3000.0) as i32;
        let mut d = [0u8; 6];
        d[0..2].copy_from_slice(&cw.to_le_bytes());
        d[2..6].copy_from_slice(&target.to_le_bytes());
        out[n] = Message::Rpdo {
            node: node(i as u8 + 1),
            pdo: Pdo::One,
            data: PdoData::new(&d).unwrap(),
        }
        .encode();
        n += 1;
    }
    out[n] = Message::Sync { counter: None }.encode();
    n += 1;
    if k.is_multiple_of(50) {
        out[n] = Message::Heartbeat {
            node: node(127),
            state: NmtState::Operational,
        }
        .encode();
        out[n + 1] = Message::SdoRequest {
            node: node(1),
            sdo: SdoRequest::Upload {
                object: Object::new(cia402::STATUSWORD, 0),
            },
        }
        .encode();
        n += 2;
    }
    if k % 50 == 25 {
        out[n] = Message::SdoRequest {
            node: node(2),
            sdo: SdoRequest::Upload {
                object: Object::new(0x1008, 0),
            },
        }
        .encode();
        n += 1;
        for toggle in [0u8, 1, 0, 1, 0] {
            out[n] = Message::SdoRequest {
                node: node(2),
                sdo: SdoRequest::UploadSegment {
                    toggle: toggle == 1,
                },
            }
            .encode();
            n += 1;
        }
    }
    n
}

#[test]
fn a_cia402_joint_allocates_nothing_in_steady_state() {
    let mut joint = Cia402Joint::new(Cia402JointConfig::for_joint(0, 3), Nanos::ZERO);
    let mut now = Nanos::from_millis(30);
    let mut sent = 0u64;
    joint.advance(now, &mut |_| sent += 1);
    // Configuration by SDO (expedited): cycle period, CSP, heartbeats.
    for n in [1u8, 2] {
        for (index, sub, data) in [
            (
                cia402::COMMUNICATION_CYCLE_PERIOD,
                0,
                &2000u32.to_le_bytes()[..],
            ),
            (cia402::MODES_OF_OPERATION, 0, &[8u8][..]),
            (cia402::HEARTBEAT_PRODUCER, 0, &100u16.to_le_bytes()[..]),
            (
                cia402::HEARTBEAT_CONSUMER,
                1,
                &(127u32 << 16 | 200).to_le_bytes()[..],
            ),
        ] {
            let f = Message::SdoRequest {
                node: node(n),
                sdo: SdoRequest::Download {
                    object: Object::new(index, sub),
                    data: SdoData::new(data).unwrap(),
                },
            }
            .encode();
            joint.receive(now, &f, &mut |_| sent += 1);
        }
    }
    let start = Message::Nmt {
        command: NmtCommand::Start,
        node: None,
    }
    .encode();
    joint.receive(now, &start, &mut |_| {});
    let mut statusword = [0u16; 2];
    let mut frames = [Message::Sync { counter: None }.encode(); 9];
    let mut segments = 0u32;
    let mut cycle = |k: u32, joint: &mut Cia402Joint, now: &mut Nanos, sw: &mut [u16; 2]| {
        let n = master_frames(k, *sw, &mut frames);
        for f in &frames[..n] {
            joint.receive(*now, f, &mut |f: Frame| {
                if f.id().raw() == 0x582 && f.data()[0] & 0xE0 == 0 {
                    segments += 1;
                }
                if let Some(i) = [0x181u32, 0x182].iter().position(|&id| id == f.id().raw()) {
                    sw[i] = u16::from_le_bytes([f.data()[0], f.data()[1]]);
                }
            });
        }
        *now += PERIOD;
        joint.advance(*now, &mut |_| {});
    };
    // Warm up: enable, then swim.
    for k in 0..50 {
        cycle(k, &mut joint, &mut now, &mut statusword);
    }
    assert_eq!(
        joint.state(),
        anguilla_protocol::message::NodeState::Enabled
    );
    let ((), calls) = anguilla_testkit::count(|| {
        for k in 50..550 {
            cycle(k, &mut joint, &mut now, &mut statusword);
        }
    });
    assert_eq!(
        calls, 0,
        "{calls} allocator calls in 500 SYNC periods (1 s)"
    );
    assert_eq!(
        joint.state(),
        anguilla_protocol::message::NodeState::Enabled
    );
    assert!(sent > 0);
    assert_eq!(segments, 11 * 5, "the device name in 5 segments, 11 times");
}
