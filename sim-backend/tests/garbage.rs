//! Whatever arrives on the bus, the robot never panics: frames the nodes
//! cannot decode are counted as the firmware would.

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::{Bus, Clock, ManualClock};
use anguilla_protocol::Frame;
use anguilla_protocol::frame::Id;
use anguilla_sim::{RobotConfig, SimRobot};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn arbitrary_frames_never_panic(
        frames in proptest::collection::vec(
            (0u16..0x800, proptest::collection::vec(any::<u8>(), 0..=8), any::<bool>()),
            0..200,
        )
    ) {
        let clock = ManualClock::new();
        let bus = MemBus::builder("sim-garbage").clock(Arc::new(clock.clone())).build();
        let mut host = bus.participant();
        let mut robot =
            SimRobot::on_mem(RobotConfig::with_joints(3), bus.participant(), Duration::ZERO).unwrap();
        for (i, (id, data, remote)) in frames.iter().enumerate() {
            let f = if *remote {
                Frame::new_remote(Id::Standard(*id), data.len() as u8)
            } else {
                Frame::new_standard(*id, data)
            };
            if let Ok(f) = f {
                host.send(&f).unwrap();
            }
            if i % 4 == 0 {
                clock.advance(Duration::from_millis(1));
                robot.step_until(clock.now());
            }
        }
        clock.advance(Duration::from_millis(5));
        robot.step_until(clock.now());
        prop_assert_eq!(robot.stats().model_errors, 0);
    }
}
