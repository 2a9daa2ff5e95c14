//! The configuration's tests: defaults, errors, the printed file.

use super::*;

#[test]
fn the_builtin_robot_gets_a_sensor_on_the_first_free_id() {
    let mut c = Config::default();
    assert_eq!(c.fit_builtin_sensor(), Some(13));
    assert_eq!(c.sensor.node, 13);
    c.validate().unwrap();
    // Set: kept. Joints on 1..=12 but not 3: the sensor takes 3.
    assert_eq!(c.fit_builtin_sensor(), None);
    let mut c = Config::default();
    c.robot.node_ids = vec![1, 2, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13];
    assert_eq!(c.fit_builtin_sensor(), Some(3));
    // A bought family: no anguilla head sensor.
    let mut c = Config::default();
    c.robot.drive = anguilla_protocol::Family::Cia402;
    assert_eq!(c.fit_builtin_sensor(), None);
    assert_eq!(c.sensor.node, 0);
}

#[test]
fn the_builtin_robot_relaxes_only_default_timeouts() {
    let mut c = Config::default();
    c.control.command_timeout = 0.4;
    let changed = c.relax_for_builtin();
    assert_eq!(c.control.command_timeout, 0.4, "set in the file: kept");
    assert_eq!(c.control.heartbeat_timeout, BUILTIN_TIMEOUT);
    assert_eq!(c.control.node_watchdog, 1.0);
    let rate = c.control_rate().unwrap();
    assert_eq!(
        c.control.feedback_timeout,
        (BUILTIN_TIMEOUT * rate).ceil() as u32
    );
    assert_eq!(c.sensor.timeout, BUILTIN_TIMEOUT);
    assert_eq!(changed.len(), 4, "{changed:?}");
    assert!(!changed.iter().any(|k| k.contains("command-timeout")));
    c.validate().unwrap();
}

#[test]
fn the_printed_default_parses_back_to_the_default() {
    let parsed = Config::from_toml(&sections_toml(&Config::default()), "default").unwrap();
    assert_eq!(parsed, Config::default());
    Config::default().validate().unwrap();
}

#[test]
fn the_robots_file_parses_back_and_only_its_bus_stops_the_daemon() {
    let robot = super::robot_config();
    let parsed = Config::from_toml(&sections_toml(&robot), "robot").unwrap();
    assert_eq!(parsed, robot);
    // Everything but the unset bus checks: the tools read the file at once.
    robot.validate().unwrap();
    assert_eq!(robot.bus.spec, super::BUS_UNSET);
    assert!(robot.realtime.lock_memory && robot.realtime.fifo_priority == 80);
    assert!(robot.recording.max_total > 0.0 && robot.recording.keep_days > 0.0);
    assert!(robot.recording.min_free > 0.0);
}

#[test]
fn a_written_configuration_reads_back() {
    let mut c = Config::default();
    c.robot.joints = 3;
    c.robot.node_ids = vec![4, 5, 6];
    c.bus.fd = true;
    c.control.rate_hz = 250.0;
    let back = Config::from_toml(&c.to_toml(), "written").unwrap();
    assert_eq!(back, c);
}

#[test]
fn empty_file_is_the_default() {
    assert_eq!(Config::from_toml("", "t").unwrap(), Config::default());
}

#[test]
fn unknown_keys_and_wrong_types_name_the_key() {
    let e = Config::from_toml("[control]\nrate = 100\n", "t").unwrap_err();
    assert!(e.to_string().contains("unknown field `rate`"), "{e}");
    let e = Config::from_toml("[robot]\njoints = \"twelve\"\n", "t").unwrap_err();
    assert!(e.to_string().contains("joints"), "{e}");
    let e = Config::from_toml("[nonsense]\n", "t").unwrap_err();
    assert!(e.to_string().contains("nonsense"), "{e}");
}

#[test]
fn other_processes_sections_are_kept_unread_and_an_unknown_one_is_refused() {
    // Keys and values the daemon knows nothing of: not its to check.
    let text = "[control]\nrate-hz = 100.0\n\n[link]\nlisten = [\"local\"]\nno-such-key = 5\n\
                \n[foxglove]\nmax-clients = \"many\"\n";
    let c = Config::from_toml(text, "t").unwrap();
    assert_eq!(c.control.rate_hz, 100.0);
    assert_eq!(
        c.other_sections["link"]["no-such-key"].as_integer(),
        Some(5)
    );
    assert_eq!(
        c.other_sections["foxglove"]["max-clients"].as_str(),
        Some("many")
    );
    assert_eq!(c.other_sections.len(), 2);
    // A recording's config.toml keeps them, and reads back the same.
    let back = Config::from_toml(&c.to_toml(), "recorded").unwrap();
    assert_eq!(back, c);
    assert_eq!(back.to_toml(), c.to_toml());
    // Any other section is refused, by name and line, with the accepted
    // ones (the other processes' among them).
    let e = Config::from_toml("[control]\nrate-hz = 100.0\n[linc]\nlisten = []\n", "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 3") && e.contains("unknown field `linc`, expected one of `robot`"),
        "{e}"
    );
    assert!(e.contains("`monitor`, `foxglove`, `link`"), "{e}");
    // The daemon's own sections are still checked beside them.
    let e = Config::from_toml("[link]\nx = 1\n[control]\nrate = 100\n", "t").unwrap_err();
    assert!(e.to_string().contains("unknown field `rate`"), "{e}");
}

#[test]
fn out_of_range_values_name_the_key_and_the_range() {
    let e = Config::from_toml("[control]\ncommand-timeout = -1.0\n", "t").unwrap_err();
    assert_eq!(
        e.to_string(),
        "configuration key 'control.command-timeout' = -1 is out of range (expected 0.02 ..= 10 s)"
    );
    let e = Config::from_toml("[robot]\njoints = 3\nnode-ids = [1, 2, 2]\n", "t").unwrap_err();
    assert!(e.to_string().contains("distinct ids"), "{e}");
    let e = Config::from_toml("[robot]\njoints = 3\nnode-ids = [1, 2]\n", "t").unwrap_err();
    assert!(e.to_string().contains("one id per joint"), "{e}");
    let e = Config::from_toml("[bus]\nmax-load = 1.5\n", "t").unwrap_err();
    assert!(e.to_string().contains("bus.max-load"), "{e}");
    let e = Config::from_toml("[ipc]\nprefix = \"a b\"\n", "t").unwrap_err();
    assert!(e.to_string().contains("ipc.prefix"), "{e}");
}

#[test]
fn check_and_run_agree_on_the_derived_rate_and_load() {
    // Each was accepted by `config check`, then refused by `run`, or
    // ran a bus past saturation.
    let err = |t: &str| Config::from_toml(t, "t").unwrap_err().to_string();
    let e = err("[control]\nrate-hz = 15\n");
    assert!(
        e.contains("'control.rate-hz' = 15") && e.contains("20 ..= 5000"),
        "{e}"
    );
    let e = err("[robot]\njoints = 32\n[control]\nrate-hz = 1000\n");
    assert!(
        e.contains("control.rate-hz = 1000 puts 875 % load on the bus")
            && e.contains("bus.max-load = 0.6")
            && e.contains("at most 64.6 Hz"),
        "{e}"
    );
    let e = err("[robot]\njoints = 32\n[bus]\nmax-load = 0.05\n");
    assert!(
        e.contains("finds no rate") && e.contains("at least 20 Hz"),
        "{e}"
    );
    // Every accepted configuration has a rate the model takes.
    for t in [
        "",
        "[robot]\njoints = 32\n",
        "[bus]\nfd = true\n",
        "[control]\nrate-hz = 20\n",
    ] {
        let c = Config::from_toml(t, "t").unwrap();
        let rate = c.control_rate().unwrap();
        assert!(1.0 / rate <= anguilla_model::MAX_DT, "{t}: {rate} Hz");
    }
}

#[test]
fn the_amplitude_polynomial_takes_exactly_three_numbers() {
    for (t, want) in [
        (
            "[1, 2, 3, 4]",
            "expected exactly three numbers [a0, a1, a2], got 4",
        ),
        (
            "[1, 2]",
            "expected exactly three numbers [a0, a1, a2], got 2",
        ),
        ("[1, 2, 3, \"junk\"]", "invalid type: string \"junk\""),
    ] {
        let e = Config::from_toml(&format!("[gait]\namplitude-polynomial = {t}\n"), "t")
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{t}: {e}");
    }
    let c = Config::from_toml("[gait]\namplitude-polynomial = [1, 0, 2]\n", "t").unwrap();
    assert_eq!(c.gait.amplitude_polynomial, [1.0, 0.0, 2.0]);
}

#[test]
fn huge_numbers_print_short() {
    assert_eq!(fmt_number(1e300), "1e300");
    assert_eq!(fmt_number(1e-300), "1e-300");
    assert_eq!(fmt_number(176.8), "176.8");
    let e = Config::from_toml("[gait]\nwavelength = 1e300\n", "t").unwrap_err();
    assert!(e.to_string().contains("= 1e300 is out of range"), "{e}");
}

#[test]
fn an_unknown_drive_family_is_named_with_the_accepted_ones() {
    let e = Config::from_toml("[robot]\ndrive = \"canopen\"\n", "test")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown drive family \"canopen\" (expected one of \"anguilla\", \"cia402\"")
            && e.contains("drive"),
        "{e}"
    );
    let c = Config::from_toml("[robot]\ndrive = \"odrive\"\njoints = 4\n", "test").unwrap();
    assert_eq!(c.robot.drive, anguilla_protocol::Family::Odrive);
    assert!(c.to_toml().contains("drive = \"odrive\""));
}

#[test]
fn a_cia402_eds_is_checked_for_what_the_master_needs() {
    let sim = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../sim-backend/eds/anguilla-sim-cia402.eds"
    );
    let text = |eds: &str, drive: &str| {
        format!("[robot]\njoints = 2\ndrive = \"{drive}\"\neds = {eds:?}\n")
    };
    Config::from_toml(&text(sim, "cia402"), "test").unwrap();
    // The simulated drive lists 125..=1000 kbit/s, not 100.
    let e = Config::from_toml(
        &(text(sim, "cia402")
            + "[bus]\nbitrate = 100000\nmax-load = 0.95\n[control]\nrate-hz = 20.0\n"),
        "test",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("bit rate 100 kbit/s"), "{e}");
    // A drive without a mappable torque offset.
    let path = std::env::temp_dir().join(format!("anguilla-eds-{}.eds", std::process::id()));
    let bad = std::fs::read_to_string(sim).unwrap().replace(
        "[60B2]\nParameterName=Torque offset\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nDefaultValue=0\nPDOMapping=1",
        "[60B2]\nParameterName=Torque offset\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nDefaultValue=0\nPDOMapping=0",
    );
    std::fs::write(&path, bad).unwrap();
    let e = Config::from_toml(&text(path.to_str().unwrap(), "cia402"), "test")
        .unwrap_err()
        .to_string();
    let _ = std::fs::remove_file(&path);
    assert!(
        e.contains("0x60B2:00 torque offset (not PDO-mappable"),
        "{e}"
    );
    let e = Config::from_toml(&text("/nonexistent.eds", "cia402"), "test")
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent.eds"), "{e}");
    let e = Config::from_toml(&text(sim, "odrive"), "test")
        .unwrap_err()
        .to_string();
    assert!(e.contains("robot.eds"), "{e}");
}

#[test]
fn node_ids_default_to_one_through_joints() {
    let c = Config::from_toml("[robot]\njoints = 4\n", "t").unwrap();
    assert_eq!(c.node_ids(), vec![1, 2, 3, 4]);
    let c = Config::from_toml("[robot]\njoints = 2\nnode-ids = [9, 4]\n", "t").unwrap();
    assert_eq!(c.node_ids(), vec![9, 4]);
}

#[test]
fn a_missing_file_names_the_path() {
    let e = Config::load(Path::new("/nonexistent/anguilla.toml")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/anguilla.toml"), "{e}");
}

/// The position's fix times: named when out of range, and a fix cannot be
/// lost before it is stale.
#[test]
fn fix_times_are_checked() {
    let e = Config::from_toml("[autopilot]\nfix-stale = 0\n", "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("autopilot.fix-stale") && e.contains("0.1 ..= 600 s"),
        "{e}"
    );
    let e = Config::from_toml("[autopilot]\nfix-stale = 10\nfix-lost = 5\n", "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("autopilot.fix-lost = 5.0 s is before fix-stale = 10.0 s"),
        "{e}"
    );
    let c = Config::from_toml("[autopilot]\nfix-stale = 2\nfix-lost = 2\n", "t").unwrap();
    assert_eq!((c.autopilot.fix_stale, c.autopilot.fix_lost), (2.0, 2.0));
}

/// An off-bus sensor's latency must fit the estimate's history and arrive
/// before the fix is stale.
#[test]
fn off_bus_latencies_are_checked_against_the_history_and_fix_stale() {
    let base = "[sensor]\nnode = 20\n\n[sensor.usbl]\nsource = \"udp:127.0.0.1:14660\"\n";
    let e = Config::from_toml(&format!("{base}latency = 9\n"), "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sensor.usbl.latency = 9.0 s: the estimate keeps"),
        "{e}"
    );
    let e = Config::from_toml(
        &format!("[autopilot]\nfix-stale = 0.2\n\n{base}latency = 0.3\n"),
        "t",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("is not below autopilot.fix-stale = 0.2 s"),
        "{e}"
    );
    Config::from_toml(&format!("{base}latency = 0.3\n"), "t").expect("the default latency");
    // A DVL gives no position: a latency past fix-stale is its own matter.
    let dvl =
        "[autopilot]\nfix-stale = 0.2\n\n[sensor]\nnode = 20\n\n[sensor.dvl]\nlatency = 0.3\n";
    Config::from_toml(dvl, "t").expect("a DVL's latency is not a fix's");
    let e = Config::from_toml(&dvl.replace("latency = 0.3", "latency = 9"), "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sensor.dvl.latency = 9.0 s: the estimate keeps"),
        "{e}"
    );
}

/// Every kind off the bus goes through the one list: each needs the head
/// sensor, named by its section; a replay drops them all; the default
/// file shows them all.
#[test]
fn every_off_bus_kind_is_in_the_one_list() {
    use anguilla_ipc::SensorKind;
    let every = SensorConfig::default().with_every_off_bus();
    let kinds: Vec<_> = every.off_bus().map(|s| s.kind()).collect();
    assert_eq!(kinds, [SensorKind::Usbl, SensorKind::Dvl]);
    // Every kind of the vocabulary but the two on the bus is off it.
    let on_bus = [SensorKind::HeadNav, SensorKind::TailImu];
    let off: Vec<_> = SensorKind::ALL
        .into_iter()
        .filter(|k| !on_bus.contains(k))
        .collect();
    assert_eq!(
        kinds, off,
        "a sensor kind missing from SensorConfig::off_bus"
    );
    assert_eq!(every.without_off_bus().off_bus().count(), 0);
    for kind in kinds {
        let name = kind.name();
        let e = Config::from_toml(&format!("[sensor.{name}]\n"), "t")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!(
                "[sensor.{name}] needs the head sensor (sensor.node)"
            )),
            "{e}"
        );
        assert!(
            super::sections_toml(&Config::default()).contains(&format!("# [sensor.{name}]\n")),
            "the default file lists [sensor.{name}]"
        );
    }
    let gives: Vec<_> = every.off_bus().map(|s| s.gives_position()).collect();
    assert_eq!(
        gives,
        [true, false],
        "the USBL fixes the position, the DVL does not"
    );
}
