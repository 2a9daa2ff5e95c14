//! Byte-exact vectors, every decode error, round trips.
//!
//! The expected bytes are written out by hand from the field positions of
//! ODrive's `odrive-cansimple-0.6.10.dbc` (start bit / length per signal,
//! Intel byte order) and IEEE 754 bit patterns worked by hand (1.0 =
//! 0x3F80_0000, 0.5 = 0x3F00_0000, −2.5 = 0xC020_0000); the ids from the
//! rule `node << 5 | cmd` of `docs/can-protocol.rst`, whose worked example
//! (`0x01 << 5 | 0x0C = 0x2C`) is the Set_Input_Pos vector's id. None is
//! produced by this codec first and pasted back.

use super::*;
use proptest::prelude::*;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn msg(n: u8, body: Body) -> Message {
    Message {
        node: node(n),
        body,
    }
}

/// Encodes, checks the `cansend` text, and checks it decodes back.
fn vector(m: Message, expected: &str) {
    let f = m.encode().unwrap();
    assert_eq!(f.to_string(), expected, "{m:?}");
    assert_eq!(decode(&f).unwrap(), m, "{expected}");
}

fn data(id: u16, d: &[u8]) -> Frame {
    Frame::new_standard(id, d).unwrap()
}

#[test]
fn the_id_is_node_shifted_five_bits_or_cmd() {
    // docs/can-protocol.rst: "0x01 << 5 | 0x0C = 0x2C".
    assert_eq!(arbitration_id(node(1), Cmd::SetInputPos).as_raw(), 0x2C);
    assert_eq!(arbitration_id(node(63), Cmd::ClearErrors).as_raw(), 0x7F8);
    assert_eq!(arbitration_id(node(0), Cmd::Heartbeat).as_raw(), 0x001);
    assert_eq!(split_id(0x7F8), (63, 0x18));
    assert_eq!(NodeId::new(64), Err(EncodeError::NodeOutOfRange(64)));
    assert_eq!(
        NodeId::new(64).unwrap_err().to_string(),
        "ODrive node id 64 is out of range (expected 0..=63)"
    );
    for c in Cmd::ALL {
        assert_eq!(Cmd::from_id(c.id()), Some(c));
        assert!(c.id() <= MAX_CMD_ID && c.min_len() <= c.dbc_len());
    }
    assert_eq!(Cmd::from_id(0x03), None);
}

#[test]
fn heartbeat_vector() {
    // Axis_Error bits 0..32 = 0x0100_0000 (WATCHDOG_TIMER_EXPIRED),
    // Axis_State bits 32..40 = 8, Procedure_Result bits 40..48 = 0,
    // Trajectory_Done_Flag bit 48 = 1, byte 7 unused; node 3: id 0x61.
    vector(
        msg(
            3,
            Body::Heartbeat(Heartbeat {
                axis_error: 0x0100_0000,
                axis_state: AxisState::ClosedLoopControl,
                procedure_result: 0,
                trajectory_done: true,
            }),
        ),
        "061#0000000108000100",
    );
    // Other bits of byte 6 and byte 7 are not fields: ignored; a 7-byte
    // heartbeat carries every field.
    let f = data(0x61, &[0, 0, 0, 0, 1, 1, 0xFE, 0xAA]);
    let Body::Heartbeat(h) = decode(&f).unwrap().body else {
        panic!("not a heartbeat")
    };
    assert_eq!(
        (h.axis_state, h.procedure_result, h.trajectory_done),
        (AxisState::Idle, 1, false)
    );
    assert!(decode(&data(0x61, &[0, 0, 0, 0, 1, 1, 1])).is_ok());
}

#[test]
fn estop_vector() {
    // No payload; node 5: 5 << 5 | 2 = 0xA2.
    vector(msg(5, Body::Estop), "0A2#");
}

#[test]
fn set_axis_state_vectors() {
    // Axis_Requested_State bits 0..32, message length 8 in the DBC.
    vector(
        msg(0, Body::SetAxisState(AxisState::ClosedLoopControl)),
        "007#0800000000000000",
    );
    // 63 << 5 | 7 = 0x7E7.
    vector(
        msg(63, Body::SetAxisState(AxisState::Idle)),
        "7E7#0100000000000000",
    );
    // The 4-byte form ODrive's Python examples send (struct '<I') decodes.
    assert_eq!(
        decode(&data(0x007, &[8, 0, 0, 0])).unwrap(),
        msg(0, Body::SetAxisState(AxisState::ClosedLoopControl))
    );
}

#[test]
fn encoder_estimates_vector_and_request() {
    // Pos_Estimate f32 bits 0..32 = 1.0, Vel_Estimate bits 32..64 = -2.5;
    // node 1: 1 << 5 | 9 = 0x29.
    vector(
        msg(
            1,
            Body::EncoderEstimates(EncoderEstimates {
                pos: 1.0,
                vel: -2.5,
            }),
        ),
        "029#0000803F000020C0",
    );
    // The request: a remote frame on the same id, DLC of the answer.
    vector(msg(1, Body::Request(Cmd::GetEncoderEstimates)), "029#R8");
    vector(msg(3, Body::Request(Cmd::Heartbeat)), "061#R8");
}

#[test]
fn set_controller_mode_vector() {
    // Control_Mode bits 0..32 = 3 (POSITION_CONTROL), Input_Mode bits
    // 32..64 = 1 (PASSTHROUGH); node 2: 2 << 5 | 0x0B = 0x4B.
    vector(
        msg(
            2,
            Body::SetControllerMode {
                control_mode: ControlMode::PositionControl,
                input_mode: InputMode::Passthrough,
            },
        ),
        "04B#0300000001000000",
    );
}

#[test]
fn set_input_pos_vectors() {
    // Input_Pos f32 bits 0..32 = 1.0; Vel_FF i16 bits 32..48 factor 0.001:
    // 0.5 -> 500 = 0x01F4; Torque_FF i16 bits 48..64: -0.25 -> -250 =
    // 0xFF06. Node 1: the rst's worked example id 0x2C.
    vector(
        msg(
            1,
            Body::SetInputPos(InputPos {
                input_pos: 1.0,
                vel_ff: 0.5,
                torque_ff: -0.25,
            }),
        ),
        "02C#0000803FF40106FF",
    );
    // The ends of the i16: 32.767 -> 0x7FFF, -32.768 -> 0x8000.
    vector(
        msg(
            1,
            Body::SetInputPos(InputPos {
                input_pos: 0.0,
                vel_ff: FF_MAX,
                torque_ff: FF_MIN,
            }),
        ),
        "02C#00000000FF7F0080",
    );
    // Rounded to the nearest count: 0.0014 -> 1, -0.0016 -> -2 (0xFFFE).
    let f = msg(
        1,
        Body::SetInputPos(InputPos {
            input_pos: 0.0,
            vel_ff: 0.0014,
            torque_ff: -0.0016,
        }),
    )
    .encode()
    .unwrap();
    assert_eq!(f.to_string(), "02C#000000000100FEFF");
}

#[test]
fn clear_errors_vectors() {
    // Identify bits 0..8, message length 1 (0.6.10); 63 << 5 | 0x18 = 0x7F8.
    vector(msg(63, Body::ClearErrors { identify: false }), "7F8#00");
    vector(msg(63, Body::ClearErrors { identify: true }), "7F8#01");
    // The empty Clear_Errors of firmware 0.5.x and early 0.6 DBCs.
    assert_eq!(
        decode(&data(0x7F8, &[])).unwrap(),
        msg(63, Body::ClearErrors { identify: false })
    );
}

fn pos(input_pos: f32, vel_ff: f32, torque_ff: f32) -> Result<Frame, EncodeError> {
    msg(
        1,
        Body::SetInputPos(InputPos {
            input_pos,
            vel_ff,
            torque_ff,
        }),
    )
    .encode()
}

#[test]
fn feedforwards_that_do_not_fit_an_i16_are_encode_errors() {
    let e = pos(0.0, 32.768, 0.0).unwrap_err();
    assert_eq!(
        e,
        EncodeError::FeedforwardOutOfRange {
            message: "Set_Input_Pos",
            field: "vel_ff",
            value: 32.768
        }
    );
    assert_eq!(
        e.to_string(),
        "Set_Input_Pos.vel_ff 32.768 does not fit an i16 at 0.001 per count \
         (expected -32.768..=32.767)"
    );
    assert!(matches!(
        pos(0.0, 0.0, -32.769),
        Err(EncodeError::FeedforwardOutOfRange {
            field: "torque_ff",
            ..
        })
    ));
    assert!(matches!(
        pos(0.0, 0.0, 1e9),
        Err(EncodeError::FeedforwardOutOfRange {
            field: "torque_ff",
            ..
        })
    ));
}

#[test]
fn nan_and_infinity_are_encode_errors() {
    for (p, v, t, field) in [
        (f32::NAN, 0.0, 0.0, "input_pos"),
        (f32::INFINITY, 0.0, 0.0, "input_pos"),
        (0.0, f32::NAN, 0.0, "vel_ff"),
        (0.0, 0.0, f32::NEG_INFINITY, "torque_ff"),
    ] {
        match pos(p, v, t) {
            Err(EncodeError::NotFinite {
                message, field: f, ..
            }) => {
                assert_eq!((message, f), ("Set_Input_Pos", field))
            }
            other => panic!("{field}: {other:?}"),
        }
    }
    let e = msg(
        1,
        Body::EncoderEstimates(EncoderEstimates {
            pos: 0.0,
            vel: f32::NAN,
        }),
    )
    .encode()
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "Get_Encoder_Estimates.vel is NaN (expected a finite number)"
    );
}

#[test]
fn only_heartbeat_and_encoder_estimates_are_requested() {
    assert_eq!(
        msg(1, Body::Request(Cmd::SetInputPos)).encode(),
        Err(EncodeError::NotRequestable(Cmd::SetInputPos))
    );
}

#[test]
fn every_decode_error() {
    let ext = Frame::new(Id::extended(0x2C).unwrap(), &[]).unwrap();
    assert_eq!(decode(&ext), Err(DecodeError::ExtendedId(0x2C)));

    let fd = Frame::new_fd(Id::standard(0x2C).unwrap(), &[0; 8], false).unwrap();
    assert_eq!(decode(&fd), Err(DecodeError::FdFrame(0x2C)));

    // Command 0x03 (Get_Error) is not implemented; 0x00 neither.
    assert_eq!(
        decode(&data(0x23, &[0; 8])),
        Err(DecodeError::UnknownCmd { id: 0x23, cmd: 3 })
    );
    assert_eq!(
        decode(&data(0x000, &[])),
        Err(DecodeError::UnknownCmd { id: 0, cmd: 0 })
    );

    let rtr = Frame::new_remote(Id::standard(0x2C).unwrap(), 8).unwrap();
    assert_eq!(
        decode(&rtr),
        Err(DecodeError::NotRequestable(Cmd::SetInputPos))
    );

    let e = decode(&data(0x2C, &[0; 7])).unwrap_err();
    assert_eq!(
        e,
        DecodeError::TooShort {
            message: "Set_Input_Pos",
            len: 7,
            min: 8
        }
    );
    assert_eq!(e.to_string(), "Set_Input_Pos of 7 bytes (expected 8..=8)");
    assert!(matches!(
        decode(&data(0x61, &[0; 6])),
        Err(DecodeError::TooShort { min: 7, .. })
    ));
    assert!(matches!(
        decode(&data(0x07, &[8, 0, 0])),
        Err(DecodeError::TooShort { min: 4, .. })
    ));
    assert!(matches!(
        decode(&data(0x29, &[0; 4])),
        Err(DecodeError::TooShort { min: 8, .. })
    ));
    assert!(matches!(
        decode(&data(0x4B, &[3, 0, 0, 0])),
        Err(DecodeError::TooShort { .. })
    ));

    let unknown = |f: Frame| match decode(&f) {
        Err(DecodeError::UnknownValue {
            field, raw, max, ..
        }) => (field, raw, max),
        other => panic!("{f}: {other:?}"),
    };
    assert_eq!(
        unknown(data(0x61, &[0, 0, 0, 0, 15, 0, 0, 0])),
        ("axis_state", 15, 14)
    );
    assert_eq!(unknown(data(0x07, &[0, 1, 0, 0])), ("axis_state", 256, 14));
    assert_eq!(
        unknown(data(0x4B, &[4, 0, 0, 0, 1, 0, 0, 0])),
        ("control_mode", 4, 3)
    );
    assert_eq!(
        unknown(data(0x4B, &[3, 0, 0, 0, 9, 0, 0, 0])),
        ("input_mode", 9, 8)
    );
    assert_eq!(unknown(data(0x7F8, &[2])), ("identify", 2, 1));
    assert_eq!(
        decode(&data(0x07, &[99, 0, 0, 0])).unwrap_err().to_string(),
        "Set_Axis_State.axis_state value 99 is unknown (expected 0..=14)"
    );

    // NaN / infinity in a float field (0x7FC0_0000 quiet NaN, 0x7F80_0000 +inf).
    let e = decode(&data(0x29, &[0, 0, 0xC0, 0x7F, 0, 0, 0, 0])).unwrap_err();
    assert_eq!(
        e,
        DecodeError::NotFinite {
            message: "Get_Encoder_Estimates",
            field: "pos",
            raw: 0x7FC0_0000
        }
    );
    assert_eq!(
        e.to_string(),
        "Get_Encoder_Estimates.pos is not finite (raw 0x7FC00000; expected a finite f32)"
    );
    assert!(matches!(
        decode(&data(0x29, &[0, 0, 0, 0, 0, 0, 0x80, 0x7F])),
        Err(DecodeError::NotFinite { field: "vel", .. })
    ));
    assert!(matches!(
        decode(&data(0x2C, &[0, 0, 0x80, 0xFF, 0, 0, 0, 0])),
        Err(DecodeError::NotFinite {
            field: "input_pos",
            ..
        })
    ));
}

fn finite_f32() -> impl Strategy<Value = f32> {
    prop::num::f32::NORMAL | prop::num::f32::ZERO | prop::num::f32::SUBNORMAL
}

fn body() -> impl Strategy<Value = Body> {
    let state = prop::sample::select(AxisState::ALL);
    prop_oneof![
        (any::<u32>(), state.clone(), any::<u8>(), any::<bool>()).prop_map(|(e, s, r, t)| {
            Body::Heartbeat(Heartbeat {
                axis_error: e,
                axis_state: s,
                procedure_result: r,
                trajectory_done: t,
            })
        }),
        Just(Body::Estop),
        state.prop_map(Body::SetAxisState),
        (finite_f32(), finite_f32())
            .prop_map(|(pos, vel)| Body::EncoderEstimates(EncoderEstimates { pos, vel })),
        (
            prop::sample::select(ControlMode::ALL),
            prop::sample::select(InputMode::ALL)
        )
            .prop_map(|(control_mode, input_mode)| Body::SetControllerMode {
                control_mode,
                input_mode
            }),
        // Feedforwards on the 0.001 grid, so the round trip is exact.
        (finite_f32(), any::<i16>(), any::<i16>()).prop_map(|(p, v, t)| {
            Body::SetInputPos(InputPos {
                input_pos: p,
                vel_ff: ff_value(v),
                torque_ff: ff_value(t),
            })
        }),
        any::<bool>().prop_map(|identify| Body::ClearErrors { identify }),
        prop::sample::select(vec![Cmd::Heartbeat, Cmd::GetEncoderEstimates])
            .prop_map(Body::Request),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn every_message_round_trips(n in 0u8..=63, b in body()) {
        let m = msg(n, b);
        let f = m.encode().unwrap();
        prop_assert_eq!(f.id().as_standard(), Some(((n as u16) << 5) | b.cmd() as u16));
        prop_assert_eq!(decode(&f).unwrap(), m);
    }

    /// Any in-range feedforward comes back within half a count (0.0005) —
    /// plus the f32 rounding of a value near 32.768 (ulp 4e-6).
    #[test]
    fn feedforwards_come_back_within_half_a_count(
        v in FF_MIN..=FF_MAX - 0.0005, t in FF_MIN..=FF_MAX - 0.0005,
    ) {
        let Body::SetInputPos(p) = decode(&pos(0.0, v, t).unwrap()).unwrap().body else {
            panic!("not Set_Input_Pos")
        };
        prop_assert!((p.vel_ff - v).abs() <= 0.0005 + 1e-5, "{} -> {}", v, p.vel_ff);
        prop_assert!((p.torque_ff - t).abs() <= 0.0005 + 1e-5, "{} -> {}", t, p.torque_ff);
    }

    /// Decoding outside bytes never panics, and what decodes re-encodes to
    /// a frame that decodes to the same message.
    #[test]
    fn any_frame_decodes_or_errs(id in 0u16..=0x7FF, d in prop::collection::vec(any::<u8>(), 0..=8), rtr in any::<bool>()) {
        let f = if rtr {
            Frame::new_remote(Id::standard(id).unwrap(), d.len() as u8).unwrap()
        } else {
            data(id, &d)
        };
        if let Ok(m) = decode(&f) {
            prop_assert_eq!(decode(&m.encode().unwrap()).unwrap(), m);
        }
    }
}
