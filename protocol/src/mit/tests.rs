use super::*;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn command(position: f32, velocity: f32, kp: f32, kd: f32, torque: f32) -> Body {
    Body::Command(Command {
        position,
        velocity,
        kp,
        kd,
        torque,
    })
}

/// Half a count of each field: the most a round trip may move a value.
fn half_count(f: Field) -> f32 {
    let (min, max) = f.range(&DEFAULT_RANGES);
    (max - min) / ((1u32 << f.bits()) - 1) as f32 / 2.0 * 1.001
}

#[test]
fn commands_round_trip_within_half_a_count_and_hit_both_ends() {
    let r = DEFAULT_RANGES;
    for (p, v, kp, kd, t) in [
        (0.0, 0.0, 0.0, 0.0, 0.0),
        (1.234, -5.5, 42.0, 0.8, 3.3),
        (-12.5, -65.0, 0.0, 0.0, -18.0),
        (12.5, 65.0, 500.0, 4.9, 18.0),
        (0.3, 0.1, 80.0, 1.0, -0.25),
    ] {
        let m = Message {
            node: node(7),
            body: command(p, v, kp, kd, t),
        };
        let f = m.encode(&r).unwrap();
        assert_eq!(f.id().raw(), 7);
        assert_eq!(f.len(), 8);
        let back = decode(&f, &r).unwrap();
        assert_eq!(back.node, node(7));
        let Body::Command(c) = back.body else {
            panic!("{back:?}")
        };
        for (field, want, got) in [
            (Field::Position, p, c.position),
            (Field::Velocity, v, c.velocity),
            (Field::Kp, kp, c.kp),
            (Field::Kd, kd, c.kd),
            (Field::Torque, t, c.torque),
        ] {
            assert!(
                (want - got).abs() <= half_count(field),
                "{field:?}: {want} came back {got}"
            );
        }
    }
    // Both ends are exact.
    let f = Message {
        node: node(1),
        body: command(-12.5, -65.0, 0.0, 0.0, -18.0),
    }
    .encode(&r)
    .unwrap();
    assert_eq!(f.data(), &[0, 0, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn the_bit_layout_is_the_firmwares() {
    // Every field at a distinct count, read back from the bytes by hand:
    // p 16 bits, v 12, kp 12, kd 12, t 12, big-endian, nibble-packed.
    let r = Ranges {
        position: 32767.5,
        velocity: 2047.5,
        kp: 4095.0,
        kd: 4095.0,
        torque: 2047.5,
    };
    // With these ranges a count is 1.0 and count c is c - half the span.
    let f = Message {
        node: node(3),
        body: command(
            0x1234 as f32 - 32767.5,
            0x567 as f32 - 2047.5,
            0x89A as f32,
            0xBCD as f32,
            0xEF0 as f32 - 2047.5,
        ),
    }
    .encode(&r)
    .unwrap();
    assert_eq!(f.to_string(), "003#123456789ABCDEF0");
    let reply = Message {
        node: node(3),
        body: Body::Reply(Reply {
            position: 0x1234 as f32 - 32767.5,
            velocity: 0x567 as f32 - 2047.5,
            torque: 0x89A as f32 - 2047.5,
            status: Some(Status {
                temperature: -5,
                error: error_code::OVER_CURRENT,
            }),
        }),
    }
    .encode(&r)
    .unwrap();
    assert_eq!(reply.to_string(), "000#031234567 89AFB02".replace(' ', ""));
    assert_eq!(decode(&reply, &r).unwrap().node, node(3));
}

#[test]
fn special_commands_and_replies_of_both_lengths_decode() {
    let r = DEFAULT_RANGES;
    for (body, last) in [
        (Body::EnterMotorMode, "FC"),
        (Body::ExitMotorMode, "FD"),
        (Body::SetZero, "FE"),
    ] {
        let m = Message {
            node: node(9),
            body,
        };
        let f = m.encode(&r).unwrap();
        assert_eq!(f.to_string(), format!("009#FFFFFFFFFFFFFF{last}"));
        assert_eq!(decode(&f, &r).unwrap(), m);
    }
    let six = Frame::new_standard(0, &[5, 0x80, 0x00, 0x80, 0x08, 0x00]).unwrap();
    let m = decode(&six, &r).unwrap();
    assert_eq!(m.node, node(5));
    let Body::Reply(rep) = m.body else {
        panic!("{m:?}")
    };
    assert_eq!(rep.status, None);
    assert!(rep.position.abs() < 1e-3 && rep.velocity.abs() < 0.02 && rep.torque.abs() < 0.005);
    let back = Message {
        node: node(5),
        body: Body::Reply(rep),
    }
    .encode(&r)
    .unwrap();
    assert_eq!(back, six, "a 6-byte reply re-encodes as 6 bytes");
}

#[test]
fn a_command_that_packs_to_a_special_is_refused() {
    let r = DEFAULT_RANGES;
    // Every field at its maximum: FF FF FF FF FF FF FF FF is no special...
    let top = command(12.5, 65.0, 500.0, 5.0, 18.0);
    let f = Message {
        node: node(1),
        body: top,
    }
    .encode(&r)
    .unwrap();
    assert_eq!(f.data(), &[0xFF; 8]);
    // ...but a torque three counts lower is Enter motor mode.
    let step = 36.0 / 4095.0;
    let enter = command(12.5, 65.0, 500.0, 5.0, 18.0 - 3.0 * step);
    let e = Message {
        node: node(1),
        body: enter,
    }
    .encode(&r)
    .unwrap_err();
    assert_eq!(e, EncodeError::Reserved);
    assert!(e.to_string().contains("special command"), "{e}");
}

#[test]
fn bad_values_and_frames_are_named() {
    let r = DEFAULT_RANGES;
    let enc = |body| {
        Message {
            node: node(1),
            body,
        }
        .encode(&r)
        .unwrap_err()
    };
    let e = enc(command(13.0, 0.0, 0.0, 0.0, 0.0));
    assert!(
        e.to_string().contains("Command.position 13") && e.to_string().contains("-12.5..=12.5"),
        "{e}"
    );
    let e = enc(command(0.0, 0.0, -1.0, 0.0, 0.0));
    assert!(e.to_string().contains("kp -1"), "{e}");
    let e = enc(command(0.0, f32::NAN, 0.0, 0.0, 0.0));
    assert!(e.to_string().contains("velocity is NaN"), "{e}");
    assert_eq!(NodeId::new(0), Err(EncodeError::NodeOutOfRange(0)));
    assert_eq!(NodeId::new(128), Err(EncodeError::NodeOutOfRange(128)));

    let dec = |f: Frame| decode(&f, &r).unwrap_err().to_string();
    assert!(dec(Frame::new_standard(1, &[0; 7]).unwrap()).contains("Command of 7 bytes"));
    assert!(dec(Frame::new_standard(0, &[1; 7]).unwrap()).contains("6 or 8"));
    assert!(dec(Frame::new_standard(0, &[0; 6]).unwrap()).contains("drive id 0"));
    assert!(dec(Frame::new_standard(0x80, &[0; 8]).unwrap()).contains("id 0x080"));
    let ext = Frame::new(crate::frame::Id::extended(1).unwrap(), &[0; 8]).unwrap();
    assert!(dec(ext).contains("extended"));
    assert_eq!(node_of(0), None);
    assert_eq!(node_of(0x7F), Some(0x7F));
    assert_eq!(node_of(0x80), None);
}

#[test]
fn ranges_are_checked() {
    assert!(DEFAULT_RANGES.validate().is_ok());
    let bad = Ranges {
        kd: 0.0,
        ..DEFAULT_RANGES
    };
    let e = bad.validate().unwrap_err();
    assert!(e.contains("kd range 0"), "{e}");
}

/// What a DBC reader computes from the bytes is what the codec decoded
/// (to an f32's precision), for every signal of commands and replies.
#[test]
fn dbc_values_agree_with_the_codec() {
    let r = DEFAULT_RANGES;
    let m = Message {
        node: node(2),
        body: command(1.0, -2.0, 30.0, 0.5, 4.0),
    };
    let f = m.encode(&r).unwrap();
    let Body::Command(c) = decode(&f, &r).unwrap().body else {
        unreachable!()
    };
    let vals = dbc_values(&f, &r);
    let want = [c.position, c.velocity, c.kp, c.kd, c.torque];
    assert_eq!(vals.len(), 5);
    for ((name, v), w) in vals.iter().zip(want) {
        assert!(
            (v - f64::from(w)).abs() < 1e-5 * v.abs().max(1.0),
            "{name}: {v} {w}"
        );
    }
    let text = dbc(&[2, 1]).unwrap();
    assert!(text.contains("BU_: Master Drive1 Drive2\n"), "{text}");
    assert!(text.contains("BO_ 2 Drive2_Command: 8 Master"), "{text}");
    assert!(text.contains("BO_ 0 Reply: 8 Drive1"), "{text}");
    assert!(dbc(&[0]).is_err());
}

#[test]
fn the_budget_counts_a_command_and_a_reply_per_axis_and_period() {
    let lines = traffic(24);
    assert_eq!(lines.len(), 2);
    for l in &lines {
        assert_eq!(l.bytes, 8);
        assert_eq!(l.cadence, Cadence::PerPeriod(24));
        // 8-byte classic frames: 135 worst-case bits each.
        assert_eq!(l.bits.nominal, 24 * 135);
    }
}

/// `protocol/mit.dbc` is the DBC of the default robot's drives (ids
/// 1..=24); `ANGUILLA_BLESS=1` rewrites it.
#[test]
fn committed_dbc_is_the_generated_one() {
    let ids: Vec<u8> = (0..crate::dbc::DEFAULT_NODES as usize)
        .flat_map(|j| crate::Family::Mit.default_ids(j))
        .collect();
    let text = dbc(&ids).unwrap();
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/mit.dbc");
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(path, &text).unwrap();
    }
    assert!(
        std::fs::read_to_string(path).unwrap_or_default() == text,
        "protocol/mit.dbc is stale: `ANGUILLA_BLESS=1 cargo test -p anguilla-protocol` or \
         `anguilla protocol dbc --drive mit --out protocol/mit.dbc`"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]

    /// Any command with every field in its range round-trips within half a
    /// count of each field (and the f32 rounding) (or is refused as a special command's bytes,
    /// which only the fields' maxima pack to), on any drive id.
    #[test]
    fn every_command_in_range_round_trips(
        n in 1u8..=MAX_NODE_ID,
        p in -12.5f32..=12.5, v in -65.0f32..=65.0, kp in 0.0f32..=500.0,
        kd in 0.0f32..=5.0, t in -18.0f32..=18.0,
    ) {
        let r = DEFAULT_RANGES;
        let m = Message { node: node(n), body: command(p, v, kp, kd, t) };
        let f = match m.encode(&r) {
            Ok(f) => f,
            Err(EncodeError::Reserved) => return Ok(()),
            Err(e) => panic!("{m:?}: {e}"),
        };
        proptest::prop_assert_eq!(f.id().as_standard(), Some(u16::from(n)));
        let Body::Command(c) = decode(&f, &r).unwrap().body else {
            panic!("{m:?} did not decode as a command")
        };
        for (field, sent, got) in [
            (Field::Position, p, c.position),
            (Field::Velocity, v, c.velocity),
            (Field::Kp, kp, c.kp),
            (Field::Kd, kd, c.kd),
            (Field::Torque, t, c.torque),
        ] {
            // Half a count, plus the f32 arithmetic's rounding over the
            // field's span (a few ulps: 2e-5 rad of a position's 25).
            let (min, max) = field.range(&r);
            let slack = 8.0 * f32::EPSILON * (max - min);
            proptest::prop_assert!(
                (sent - got).abs() <= half_count(field) + slack,
                "{} {} -> {}", field.name(), sent, got
            );
        }
    }

    /// Decoding outside bytes never panics, and what decodes re-encodes to
    /// a frame that decodes to the same message.
    #[test]
    fn any_frame_decodes_or_errs(
        id in 0u16..=0x7FF,
        d in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..=8),
        rtr in proptest::prelude::any::<bool>(),
    ) {
        let r = DEFAULT_RANGES;
        let f = if rtr {
            Frame::new_remote(crate::frame::Id::standard(id).unwrap(), d.len() as u8).unwrap()
        } else {
            Frame::new_standard(id, &d).unwrap()
        };
        if let Ok(m) = decode(&f, &r) {
            proptest::prop_assert_eq!(decode(&m.encode(&r).unwrap(), &r).unwrap(), m);
        }
    }
}
