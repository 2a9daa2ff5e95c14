//! Unit tests of the payloads, the layout and a server/client round trip.

use core::time::Duration;

use crate::*;

#[test]
fn requests_roundtrip_and_bad_ones_are_named() {
    let p = SwimParams {
        amplitude: 0.5,
        frequency: 1.25,
        turn: -0.5,
        pitch: 0.25,
    };
    let r = CommandRequest::new(Command::Swim(p), 3);
    assert_eq!(r.command(), Ok(Command::Swim(p)));
    let h = Hold {
        heading: Some(60.0),
        depth: Some(1.5),
    };
    let held = CommandRequest::new(Command::SwimHold(p, h), 4);
    assert_eq!(held.command(), Ok(Command::SwimHold(p, h)));
    let mut forged = held;
    forged.body[4] = 8;
    assert_eq!(
        forged.command().unwrap_err().to_string(),
        "hold bits 0x8 unknown (expected 0..=3: 1 heading, 2 depth)"
    );
    let mut bad = r;
    bad.code = 42;
    assert_eq!(
        bad.command().unwrap_err().to_string(),
        "unknown command code 42 (expected 1..=13)"
    );
    bad = r;
    bad.layout_version = 99;
    assert!(matches!(bad.command(), Err(RequestError::Version(99))));
    // An E-stop is read whatever else the request says.
    let mut e = CommandRequest::new(Command::EStop, 0);
    e.layout_version = 1;
    e.body = [f32::NAN.to_bits(); BODY_WORDS];
    assert_eq!(e.command(), Ok(Command::EStop));
}

/// `CommandKind` is the one table of the commands: each kind once, in the
/// order of their request codes, names distinct and read back; and
/// `Command::ALL` has one command of each kind, in the same order. The
/// encoder, the decoder, refusals and JSON names all come from it.
#[test]
fn the_command_table_has_every_command_once_in_code_order() {
    for (i, k) in CommandKind::ALL.iter().enumerate() {
        assert_eq!(k.code() as usize, i + 1, "{k:?}");
        assert_eq!(CommandKind::from_code(k.code()), Some(*k));
        assert_eq!(CommandKind::from_name(k.name()), Some(*k));
        assert_eq!(Command::ALL[i].kind(), *k);
        assert_eq!(CommandRequest::new(Command::ALL[i], 1).code, k.code());
        // A kind without parameters is its one command; one with
        // parameters has none that stands for it.
        if let Some(bare) = k.bare() {
            assert_eq!(bare, Command::ALL[i], "{k:?}");
        }
    }
    // The commands with parameters: their body is on the wire, read back
    // as sent (not the empty body of the bare ones).
    for cmd in [
        Command::Swim(SwimParams {
            amplitude: 0.5,
            frequency: 1.25,
            turn: -0.25,
            pitch: 0.125,
        }),
        Command::Hold(Hold {
            heading: Some(1.5),
            depth: Some(2.0),
        }),
    ] {
        assert_eq!(cmd.kind().bare(), None, "{cmd:?}");
        let req = CommandRequest::new(cmd, 1);
        assert_ne!(req.body, [0; BODY_WORDS], "{cmd:?}");
        assert_eq!(req.command(), Ok(cmd));
    }
    assert_eq!(Command::ALL.len(), CommandKind::ALL.len());
    assert_eq!(CommandKind::from_code(0), None);
    assert_eq!(
        CommandKind::from_code(CommandKind::ALL.len() as u32 + 1),
        None
    );
    let mut names: Vec<_> = CommandKind::ALL.iter().map(|k| k.name()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), CommandKind::ALL.len(), "{names:?}");
}

/// A body's words are its `#[repr(C)]` fields in order, so the layout
/// documented for C and Python (`SwimBody`, `HoldBody` at the compiler's
/// offsets, overlaid on `CommandRequest.body`) is the one the encoder
/// writes; a command without parameters
/// sends a zero body; and a request stays 40 bytes whatever the command.
#[test]
fn command_bodies_are_laid_out_as_documented() {
    let swim = SwimBody {
        amplitude: 0.5,
        frequency: 1.5,
        turn: -0.25,
        pitch: 0.125,
    };
    let hold = HoldBody {
        hold: 3,
        heading: 270.0,
        depth: 1.75,
    };
    let rows = crate::layout_table();
    let word = |name: &str| {
        let (ty, field) = name.split_once('.').unwrap();
        let r = rows
            .iter()
            .find(|r| r.ty == ty && r.field == field)
            .unwrap();
        assert_eq!(r.size, 4, "{name}");
        r.offset / 4
    };
    let w = swim.to_words();
    assert_eq!(w[word("SwimBody.amplitude")], 0.5f32.to_bits());
    assert_eq!(w[word("SwimBody.frequency")], 1.5f32.to_bits());
    assert_eq!(w[word("SwimBody.turn")], (-0.25f32).to_bits());
    assert_eq!(w[word("SwimBody.pitch")], 0.125f32.to_bits());
    assert_eq!(SwimBody::from_words(&w), swim);
    let w = hold.to_words();
    assert_eq!(w[word("HoldBody.hold")], 3);
    assert_eq!(w[word("HoldBody.heading")], 270.0f32.to_bits());
    assert_eq!(w[word("HoldBody.depth")], 1.75f32.to_bits());
    assert_eq!(HoldBody::from_words(&w), hold);
    assert_eq!(w[3..], [0; BODY_WORDS - 3]);
    for cmd in Command::ALL {
        let r = CommandRequest::new(cmd, 7);
        match cmd.kind() {
            // A waypoint's depth "none" is NaN.
            CommandKind::Swim | CommandKind::Hold | CommandKind::Waypoint => {}
            _ => assert_eq!(r.body, [0; BODY_WORDS], "{cmd:?}"),
        }
        assert_eq!(r.command(), Ok(cmd));
    }
    assert_eq!(core::mem::size_of::<CommandRequest>(), 40);
    // The same words read as HOLD's body are not SWIM's parameters: a
    // request is read by its code alone.
    let mut r = CommandRequest::new(Command::Swim(SwimParams::REST), 1);
    r.code = CommandKind::Hold.code();
    r.body = hold.to_words();
    assert!(matches!(r.command(), Ok(Command::Hold(_))));
}

/// A layout-5 request (recorded in an older session) reads as the same
/// command: SWIM's floats were words 3..7, HOLD's fields words 7..10.
#[test]
fn a_layout_5_request_reads_as_the_same_command() {
    let f = |x: f32| x.to_bits();
    let old = |code: CommandKind, words: [u32; 7]| CommandRequest {
        layout_version: 5,
        code: code.code(),
        sequence: 9,
        body: words,
    };
    let swim = old(
        CommandKind::Swim,
        [f(0.5), f(1.25), f(-0.5), f(0.25), 3, f(90.0), f(2.0)],
    );
    let r = CommandRequest::from_older_layout(swim);
    assert_eq!(r.layout_version, LAYOUT_VERSION);
    assert_eq!(r.sequence, 9);
    assert_eq!(
        r.command(),
        Ok(Command::Swim(SwimParams {
            amplitude: 0.5,
            frequency: 1.25,
            turn: -0.5,
            pitch: 0.25
        }))
    );
    let hold = old(CommandKind::Hold, [f(0.5), 0, 0, 0, 3, f(90.0), f(2.0)]);
    assert_eq!(
        CommandRequest::from_older_layout(hold).command(),
        Ok(Command::Hold(Hold {
            heading: Some(90.0),
            depth: Some(2.0)
        }))
    );
    let stop = old(CommandKind::Stop, [0; 7]);
    assert_eq!(
        CommandRequest::from_older_layout(stop).command(),
        Ok(Command::Stop)
    );
    // Layout 6's request is this layout's: relabelled, the body kept.
    let six = CommandRequest {
        layout_version: 6,
        ..CommandRequest::new(
            Command::Hold(Hold {
                heading: Some(45.0),
                depth: None,
            }),
            4,
        )
    };
    let r = CommandRequest::from_older_layout(six);
    assert_eq!(r.layout_version, LAYOUT_VERSION);
    assert_eq!(
        r.command(),
        Ok(Command::Hold(Hold {
            heading: Some(45.0),
            depth: None
        }))
    );
    // Neither: unchanged (and refused as before).
    let mut other = stop;
    other.layout_version = 4;
    assert_eq!(CommandRequest::from_older_layout(other), other);
}

#[test]
fn node_watch_reports_dead_and_vanished_nodes_once() {
    let mut w = NodeWatch::default();
    w.watch(2);
    w.watch(9);
    w.watch(2);
    assert!(w.update(&[1, 2, 3, 9], &[]).is_empty());
    // 2 vanished (cleaned up by someone else), 9 seen dead; 5 is not watched.
    let mut gone = w.update(&[1, 3], &[9, 5]);
    gone.sort_unstable();
    assert_eq!(gone, vec![(2, false), (9, true)]);
    assert!(w.update(&[1, 3], &[]).is_empty(), "reported once");
}

#[test]
fn reply_reason_is_cut_on_a_character_boundary() {
    let req = CommandRequest::new(Command::Stop, 1);
    let long = "é".repeat(100); // 200 bytes
    let r = CommandReply::refused(&req, Mode::Idle as u8, &long);
    assert!(r.reason().len() <= 120);
    assert!(
        r.reason().ends_with('…'),
        "a cut reason says so: {}",
        r.reason()
    );
    assert!(r.reason().trim_end_matches('…').chars().all(|c| c == 'é'));
    // A long list of nodes is cut visibly, not mid-list in silence.
    let faults = FaultSet {
        kinds: u32::MAX,
        nodes: u64::MAX,
    };
    let r = CommandReply::refused(&req, 5, &Refusal::FaultPersists(faults));
    assert!(
        r.reason().ends_with('…') && r.reason().len() <= 120,
        "{}",
        r.reason()
    );
    let ok = CommandReply::accepted(&req, 2);
    assert_eq!(ok.reason(), "");
    let why = Refusal::NotInControl;
    assert_eq!(
        CommandReply::refused(&req, 0, &why).reason(),
        "take control first"
    );
}

#[test]
fn layout_table_covers_every_byte() {
    // Fields of each type tile it exactly: no hidden padding a C client
    // would have to guess.
    let rows = layout_table();
    for (ty, size) in layout::payload_sizes() {
        let mut end = 0;
        for r in rows.iter().filter(|r| r.ty == ty) {
            assert_eq!(r.offset, end, "{ty}.{} leaves a gap", r.field);
            end = r.offset + r.size;
        }
        assert_eq!(end, size, "{ty} has trailing padding");
    }
}

#[test]
fn docs_match_the_generated_layout() {
    docs_section_is("layout", &layout_markdown());
}

#[test]
fn docs_match_the_generated_estop() {
    docs_section_is("estop", &layout::estop_markdown());
}

#[test]
fn docs_match_the_generated_codes() {
    docs_section_is("codes", &layout::codes_markdown());
}

/// `docs/ipc.md` between `<!-- NAME:begin -->` and `<!-- NAME:end -->` is
/// `generated` (rewritten with ANGUILLA_BLESS=1).
fn docs_section_is(name: &str, generated: &str) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/ipc.md");
    anguilla_testkit::generated_block(std::path::Path::new(path), name, generated);
}

/// A unique prefix per test so parallel tests do not share services.
fn prefix(tag: &str) -> String {
    format!("anguilla-test/{tag}-{}", std::process::id())
}

#[test]
fn server_and_client_talk() {
    let p = prefix("talk");
    // iceoryx2's ipc ports are not Send: the server lives on its thread.
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            let server = StatePublisher::new(&p).unwrap();
            let mut commands = CommandServer::new(&p).unwrap();
            let mut snap = StateSnapshot {
                sequence: 9,
                joint_count: 12,
                ..Default::default()
            };
            snap.joints[3].measured_yaw = 0.25;
            server.publish(&snap).unwrap();
            ready_tx.send(snap).unwrap();
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                // Like the daemon: publish every period.
                server.publish(&snap).unwrap();
                let _ = commands.wait(Duration::from_millis(1));
                // Answers with who sent the request, as the server knows it.
                commands
                    .serve(|env| {
                        let req = &env.request;
                        match req.command() {
                            Ok(Command::TakeControl) => CommandReply::refused(
                                req,
                                1,
                                &format_args!("{:032x} {:032x}", env.origin, env.node),
                            ),
                            Ok(other) => CommandReply::refused(req, 0, &other.name()),
                            Err(e) => CommandReply::refused(req, 0, &e),
                        }
                    })
                    .unwrap();
                std::thread::yield_now();
            }
        });
        // Stop the server however this thread ends (a failed assert
        // included), or the scope would wait for it forever.
        struct StopOnDrop<'a>(&'a std::sync::atomic::AtomicBool);
        impl Drop for StopOnDrop<'_> {
            fn drop(&mut self) {
                self.0.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
        let _guard = StopOnDrop(&stop);
        let snap = ready_rx
            .recv_timeout(Duration::from_secs(10))
            .expect("server up");
        let mut client = Client::new(&p, "test-client").unwrap();
        let mut other = Client::new(&p, "test-other").unwrap();
        assert_eq!(client.provenance_problem(), None, "one process serves both");
        let got = client
            .wait_state(Duration::from_secs(1))
            .unwrap()
            .expect("state");
        assert_eq!(got, snap);
        let r = client
            .request(Command::TakeControl, Duration::from_secs(2))
            .unwrap();
        // The server names the request's origin: this client's own port,
        // whatever the request says; another client is another origin.
        let (origin, node) = r.reason().split_once(' ').unwrap();
        assert_eq!(u128::from_str_radix(origin, 16).unwrap(), client.id());
        assert_ne!(u128::from_str_radix(node, 16).unwrap(), 0, "node known");
        let r2 = other
            .request(Command::TakeControl, Duration::from_secs(2))
            .unwrap();
        let (origin2, _) = r2.reason().split_once(' ').unwrap();
        assert_eq!(u128::from_str_radix(origin2, 16).unwrap(), other.id());
        assert_ne!(client.id(), other.id());
        let r = client
            .request(Command::Stop, Duration::from_secs(2))
            .unwrap();
        assert_eq!(r.accepted, 0);
        assert_eq!(r.reason(), "stop");
        assert_eq!(client.awaiting(), 0);
    });
}

#[test]
fn a_tool_never_creates_the_services() {
    let p = prefix("no-daemon");
    let e = Client::new(&p, "early-tool").err().expect("no daemon yet");
    assert!(matches!(e, IpcError::NoDaemon { .. }), "{e}");
    assert!(e.to_string().contains("no anguilla daemon serves"), "{e}");
    // In words, not iceoryx2's enum names.
    assert!(
        e.to_string()
            .contains(&format!("its service '{p}/state' does not exist")),
        "{e}"
    );
    assert!(!e.to_string().contains("DoesNotExist"), "{e}");
    // Nothing was left behind: the daemon creates them afterwards.
    std::thread::scope(|s| {
        s.spawn(|| {
            let _state = StatePublisher::new(&p).unwrap();
            let _commands = CommandServer::new(&p).unwrap();
            let c = Client::new(&p, "late-tool").unwrap();
            assert_eq!(c.provenance_problem(), None);
        });
    });
}

/// Named fields from two lists, as a JSON object would give them.
struct Named {
    numbers: &'static [(&'static str, f64)],
    flags: &'static [(&'static str, bool)],
}

impl Fields for Named {
    fn command(&self) -> &str {
        "test"
    }
    fn number(&self, key: &str) -> Result<Option<f64>, String> {
        Ok(self
            .numbers
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v))
    }
    fn boolean(&self, key: &str) -> Result<Option<bool>, String> {
        Ok(self.flags.iter().find(|(k, _)| *k == key).map(|(_, v)| *v))
    }
}

/// Every command reads its JSON form in its own module, and what it read
/// goes through its body unchanged; a missing field or a fractional count
/// is named.
#[test]
fn every_command_reads_its_fields_and_round_trips_through_its_body() {
    let all = Named {
        numbers: &[
            ("amplitude", 0.5),
            ("frequency", 1.5),
            ("turn", -0.25),
            ("pitch", 0.125),
            ("heading", 370.0),
            ("depth", 1.5),
            ("index", 2.0),
            ("x", 3.0),
            ("y", -4.0),
            ("count", 3.0),
        ],
        flags: &[("loop", true), ("resume", false)],
    };
    for kind in CommandKind::ALL {
        let cmd = Command::from_fields(kind, &all).expect("read");
        assert_eq!(cmd.kind(), kind);
        let back = CommandRequest::new(cmd, 1).command().expect("decoded");
        assert_eq!(back, cmd, "{kind}");
    }
    let Ok(Command::SwimHold(p, h)) = Command::from_fields(CommandKind::SwimHold, &all) else {
        panic!("a held swim");
    };
    assert_eq!((p.turn, h.heading, h.depth), (-0.25, Some(10.0), Some(1.5)));
    let Ok(Command::Follow(f)) = Command::from_fields(CommandKind::Follow, &all) else {
        panic!("a path");
    };
    assert!(f.looped && !f.from_here && f.count == 3 && f.swim.turn == 0.0);
    let none = Named {
        numbers: &[("count", 2.5)],
        flags: &[],
    };
    let e = Command::from_fields(CommandKind::Swim, &none).expect_err("no gait");
    assert_eq!(e, "test needs a number \"amplitude\"");
    let e = Command::from_fields(CommandKind::Hold, &none).expect("manual");
    assert_eq!(e, Command::Hold(Hold::MANUAL));
    let count = Named {
        numbers: &[("amplitude", 0.5), ("frequency", 1.0), ("count", 2.5)],
        flags: &[],
    };
    let e = Command::from_fields(CommandKind::Follow, &count).expect_err("2.5 waypoints");
    assert!(
        e.contains("\"count\" of test must be a whole number >= 0, not 2.5"),
        "{e}"
    );
}
