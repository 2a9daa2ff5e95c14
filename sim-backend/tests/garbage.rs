//! Whatever arrives on the bus (standard or extended ids, data, remote or
//! CAN FD frames, any bytes), the robot never panics, and each node counts
//! exactly the frames addressed to it that do not decode (its `bad_frames`,
//! the firmware's `BAD_FRAME`), as the node contract of `protocol/README.md`
//! says: the expected count is worked out here from the protocol's
//! definitions table, not from the node's code.

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::{Bus, Clock, ManualClock};
use anguilla_protocol::Frame;
use anguilla_protocol::frame::Id;
use anguilla_protocol::message::{self, FIRST_UNUSED_ID, Function, NodeId, NodeSet, Variant};
use anguilla_sim::{RobotConfig, SimRobot};
use proptest::prelude::*;

/// Whether node `me` (classic CAN) must count `frame` as a bad frame
/// (protocol/README.md, "Invalid and unknown frames" and "E-stop"): a data
/// frame on an identifier the protocol uses for a message to the nodes,
/// addressed to every node or to `me`, that does not decode. Any frame on
/// 0x000 or on `me`'s own E-stop id is an E-stop, whatever it holds;
/// extended ids, remote frames, ids the protocol does not use and frames for
/// other nodes are ignored. "Addressed to" is the protocol's
/// [`message::addressed_to`], made from the definitions table and
/// unit-tested there against the README's identifiers.
fn is_bad_frame_for(me: u8, frame: &Frame) -> bool {
    let me = NodeId::new(me).unwrap();
    if message::estop_target(frame.id()).is_some_and(|t| t.includes(me)) || frame.is_remote() {
        return false;
    }
    message::addressed_to(Variant::Classic, frame.id(), me)
        && message::decode(frame, Variant::Classic, NodeSet::all()).is_err()
}

/// Identifiers: anywhere, or near the nodes' own (each function's, or the
/// first unused ones, with low bits 0..=4), where a random id rarely falls.
fn ids() -> impl Strategy<Value = u16> {
    prop_oneof![
        0u16..0x800,
        (0..=Function::ALL.len(), 0u8..5).prop_map(|(f, low)| match Function::ALL.get(f) {
            Some(f) => f.id(low),
            None => FIRST_UNUSED_ID + u16::from(low),
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn arbitrary_frames_never_panic_and_bad_frames_are_counted_as_specified(
        frames in proptest::collection::vec(
            (ids(), any::<bool>(), proptest::collection::vec(any::<u8>(), 0..=12), 0u8..3),
            0..200,
        )
    ) {
        const JOINTS: u8 = 3;
        let clock = ManualClock::new();
        let bus = MemBus::builder("sim-garbage").clock(Arc::new(clock.clone())).build();
        let mut host = bus.participant();
        let mut robot = SimRobot::on_mem(
            RobotConfig::with_joints(JOINTS as usize),
            bus.participant(),
            Duration::ZERO,
        )
        .unwrap();
        let mut expected = [0u64; JOINTS as usize];
        let mut sent = 0u64;
        for (i, (id, extended, data, kind)) in frames.iter().enumerate() {
            let id = if *extended {
                Id::extended(u32::from(*id) << 7 | 0x5A).unwrap()
            } else {
                Id::standard(*id).unwrap()
            };
            // kind: 0 classic data, 1 remote, 2 CAN FD.
            let f = match kind {
                0 => Frame::new(id, data),
                1 => Frame::new_remote(id, data.len().min(8) as u8),
                _ => Frame::new_fd(id, data, data.len() % 2 == 0),
            };
            if let Ok(f) = f {
                host.send(&f).unwrap();
                sent += 1;
                for (k, e) in expected.iter_mut().enumerate() {
                    *e += u64::from(is_bad_frame_for(k as u8 + 1, &f));
                }
            }
            if i % 4 == 0 {
                clock.advance(Duration::from_millis(1));
                robot.step_until(clock.now());
            }
        }
        clock.advance(Duration::from_millis(5));
        robot.step_until(clock.now());
        prop_assert_eq!(robot.stats().frames_in, sent, "every frame reached the robot");
        let counted: Vec<u64> = robot.nodes().iter().map(|n| n.counters().bad_frames).collect();
        prop_assert_eq!(counted, expected.to_vec(), "bad frames of nodes 1, 2, 3");
        prop_assert_eq!(robot.stats().model_errors, 0);
    }
}
