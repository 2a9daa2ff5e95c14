//! Encoding and decoding allocate nothing: a counting global allocator
//! watches one control period's worth of encode/decode calls.

use anguilla_protocol::message::*;

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

#[test]
fn a_period_of_encoding_and_decoding_allocates_nothing() {
    let setpoints = [[AxisSetpoint {
        position: 0.3,
        velocity: 1.0,
        torque: -0.5,
    }; 2]; 12];
    let nodes = NodeSet::first(12);
    let mut decoded = 0usize;
    let ((), calls) = anguilla_testkit::count(|| {
        for variant in [Variant::Classic, Variant::Fd] {
            encode_setpoints(
                variant,
                42,
                anguilla_protocol::message::from_node_one(&setpoints),
                |f| {
                    if decode(&f, variant, nodes).is_ok() {
                        decoded += 1;
                    }
                },
            )
            .unwrap();
            let sync = Message::Sync { counter: 42 }.encode(variant).unwrap();
            decoded += decode(&sync, variant, nodes).is_ok() as usize;
            for n in 1..=12 {
                let fb = Message::Feedback(Feedback {
                    node: NodeId::new(n).unwrap(),
                    enabled: true,
                    fault: false,
                    axes: [AxisFeedback::default(); 2],
                })
                .encode(variant)
                .unwrap();
                decoded += decode(&fb, variant, nodes).is_ok() as usize;
            }
            // Errors are Copy values too.
            let bad = anguilla_protocol::Frame::new_standard(0x7FF, &[]).unwrap();
            assert!(decode(&bad, variant, nodes).is_err());
        }
    });
    assert_eq!(decoded, 12 + 1 + 12 + 2 + 1 + 12);
    assert_eq!(calls, 0, "encode/decode called the allocator");
    let (v, calls) = anguilla_testkit::count(|| std::hint::black_box(vec![1u8; 16]));
    assert!(calls > 0 && v.len() == 16, "the counter counts");
}

#[test]
fn head_sensor_samples_encode_and_decode_without_allocating() {
    let node = NodeId::new(DEFAULT_HEAD_SENSOR_ID).unwrap();
    let h = HeadSample {
        node,
        sample: 3,
        quaternion: [1.0, 0.0, 0.0, 0.0],
        rates: [0.1, 0.2, 0.3],
        accel: [0.0, 0.0, 9.81],
        pressure: 110_000,
        temperature: 10.0,
        status: SensorStatus(SensorStatus::ALL),
        errors: SensorErrors(0),
    };
    let nodes = NodeSet::empty().with(node);
    let mut decoded = 0usize;
    let ((), calls) = anguilla_testkit::count(|| {
        for variant in [Variant::Classic, Variant::Fd] {
            encode_head_sample(variant, &h, |f| {
                decoded += decode(&f, variant, nodes).is_ok() as usize;
            })
            .unwrap();
        }
    });
    assert_eq!(decoded, 4 + 1);
    assert_eq!(calls, 0, "head sample encode/decode called the allocator");
}

#[test]
fn odrive_encoding_and_decoding_allocates_nothing() {
    use anguilla_protocol::odrive::{self, Body, Cmd, InputPos};
    let mut decoded = 0usize;
    let ((), calls) = anguilla_testkit::count(|| {
        for n in 0..=63 {
            let node = odrive::NodeId::new(n).unwrap();
            for body in [
                Body::SetInputPos(InputPos {
                    input_pos: 0.3,
                    vel_ff: 1.0,
                    torque_ff: -0.5,
                }),
                Body::Request(Cmd::GetEncoderEstimates),
                Body::Estop,
            ] {
                let f = odrive::Message { node, body }.encode().unwrap();
                decoded += odrive::decode(&f).is_ok() as usize;
            }
        }
        // Errors are Copy values too, on both sides.
        let bad = anguilla_protocol::Frame::new_standard(0x023, &[0; 8]).unwrap();
        assert!(odrive::decode(&bad).is_err());
        let too_fast = odrive::Message {
            node: odrive::NodeId::new(1).unwrap(),
            body: Body::SetInputPos(InputPos {
                input_pos: 0.0,
                vel_ff: 100.0,
                torque_ff: 0.0,
            }),
        };
        assert!(too_fast.encode().is_err());
    });
    assert_eq!(decoded, 64 * 3);
    assert_eq!(calls, 0, "odrive encode/decode called the allocator");
}

#[test]
fn canopen_encoding_and_decoding_allocates_nothing() {
    use anguilla_protocol::canopen::{
        self, AbortCode, Message, Object, SdoData, SdoRequest, SdoResponse, cia402,
    };
    let mut decoded = 0usize;
    let ((), calls) = anguilla_testkit::count(|| {
        for n in 1..=127 {
            let node = canopen::NodeId::new(n).unwrap();
            let object = Object::new(cia402::TARGET_POSITION, 0);
            for m in [
                Message::SdoRequest {
                    node,
                    sdo: SdoRequest::Download {
                        object,
                        data: SdoData::new(&(n as i32).to_le_bytes()).unwrap(),
                    },
                },
                Message::SdoResponse {
                    node,
                    sdo: SdoResponse::Abort {
                        object,
                        code: AbortCode::from_raw(0x0609_0030),
                    },
                },
                Message::Sync { counter: None },
            ] {
                decoded += canopen::decode(&m.encode()).is_ok() as usize;
            }
            let state = cia402::DriveState::from_statusword(0x0237).unwrap();
            decoded += state.next_toward_enabled().is_some() as usize;
        }
        // Errors are Copy values too, on both sides.
        let bad = anguilla_protocol::Frame::new_standard(0x100, &[0; 6]).unwrap();
        assert!(canopen::decode(&bad).is_err());
        assert!(SdoData::new(&[0; 5]).is_err());
        assert!(canopen::NodeId::new(0).is_err());
    });
    assert_eq!(decoded, 127 * 4);
    assert_eq!(calls, 0, "canopen encode/decode called the allocator");
}
