//! The whole file's tests: the printed files, and the other processes'
//! sections read and checked.

use super::*;

/// `c` without the other sections the daemon keeps unread, to compare
/// with a configuration made in code.
fn daemon_part(c: &Config) -> daemon::Config {
    let mut d = c.daemon.clone();
    d.other_sections.clear();
    d
}

#[test]
fn the_printed_default_parses_back_to_the_default() {
    let parsed = Config::from_toml(&default_toml(), "default").unwrap();
    assert_eq!(parsed.link, LinkConfig::default());
    assert_eq!(parsed.foxglove, FoxgloveConfig::default());
    assert_eq!(daemon_part(&parsed), daemon::Config::default());
    Config::default().validate().unwrap();
}

#[test]
fn the_robots_file_parses_back() {
    let parsed = Config::from_toml(&robot_toml(), "robot").unwrap();
    let robot = robot_config();
    assert_eq!(daemon_part(&parsed), robot.daemon);
    assert_eq!(
        (&parsed.link, &parsed.foxglove),
        (&robot.link, &robot.foxglove)
    );
}

#[test]
fn the_other_sections_are_the_daemons_list() {
    // What the daemon passes over unread is what this module reads: the
    // default file's sections beyond the daemon's own.
    let whole: toml::Table = toml::from_str(&default_toml()).unwrap();
    let own: toml::Table =
        toml::from_str(&daemon::sections_toml(&daemon::Config::default())).unwrap();
    let others: Vec<&str> = whole
        .keys()
        .filter(|k| !own.contains_key(*k))
        .map(String::as_str)
        .collect();
    let mut listed = daemon::OTHER_SECTIONS.to_vec();
    listed.sort();
    assert_eq!(others, listed);
}

#[test]
fn deploy_config_is_the_robots_file() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/deploy/anguilla.toml");
    anguilla_testkit::generated_file(Path::new(path), &robot_toml());
}

#[test]
fn docs_configuration_shows_the_default() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/configuration.md");
    let block = format!("```toml\n{}```\n", default_toml());
    anguilla_testkit::generated_block(Path::new(path), "config", &block);
}

#[test]
fn the_link_and_foxglove_sections_are_read() {
    let text = "[control]\nrate-hz = 100.0\n\n[link]\nstate-rate = 25.0\nros2 = true\n\
                ros2-rates = { imu = 50.0 }\n\n[foxglove]\nmax-clients = 4\nread-timeout = 0\n";
    let c = Config::from_toml(text, "t").unwrap();
    assert_eq!(c.daemon.control.rate_hz, 100.0);
    assert_eq!(c.link.state_rate, 25.0);
    assert!(c.link.ros2);
    assert_eq!(c.link.ros2_rates.get("imu"), Some(&50.0));
    assert_eq!(c.link.max_clients, LinkConfig::default().max_clients);
    assert_eq!(c.foxglove.max_clients, 4);
    assert_eq!(c.foxglove.read_timeout, 0.0);
    let never = Config::from_toml("[foxglove]\nsubscribe-timeout = 0\n", "t").unwrap();
    assert_eq!(never.foxglove.subscribe_timeout, 0.0);
}

#[test]
fn bad_link_and_foxglove_values_name_the_key() {
    for (toml, key) in [
        ("[foxglove]\nmax-clients = 0", "'foxglove.max-clients' = 0"),
        (
            "[foxglove]\nsubscribe-timeout = 0.5",
            "'foxglove.subscribe-timeout' = 0.5",
        ),
        (
            "[foxglove]\nsubscribe-timeout = -1",
            "'foxglove.subscribe-timeout' = -1",
        ),
        (
            "[foxglove]\nread-timeout = 0.5",
            "'foxglove.read-timeout' = 0.5",
        ),
        (
            "[foxglove]\nread-timeout = 7200",
            "'foxglove.read-timeout' = 7200",
        ),
        ("[link]\nstate-rate = 0.0", "'link.state-rate' = 0"),
        ("[link]\nlisten = []", "'link.listen' = []"),
        (
            "[link]\ninbound = [\"drive\"]",
            "'link.inbound' = \"drive\"",
        ),
    ] {
        let e = Config::from_toml(&format!("{toml}\n"), "t").unwrap_err();
        assert!(e.to_string().contains(key), "{toml}: {e}");
    }
    // Unknown keys and wrong types: toml's message, with the file and line.
    let e = Config::from_toml("[link]\nlisten-on = []\n", "site.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("site.toml") && e.contains("line 2") && e.contains("unknown field `listen-on`"),
        "{e}"
    );
    let e = Config::from_toml("[foxglove]\nmax-clients = \"many\"\n", "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 2") && e.contains("max-clients") && e.contains("invalid type"),
        "{e}"
    );
    // The daemon's sections are checked beside them.
    let e = Config::from_toml("[link]\nstate-rate = 25.0\n[robot]\njoints = 0\n", "t")
        .unwrap_err()
        .to_string();
    assert!(e.contains("'robot.joints' = 0"), "{e}");
}

#[test]
fn a_missing_file_names_the_path() {
    let e = Config::load(Path::new("/nonexistent/anguilla.toml")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/anguilla.toml"), "{e}");
}

#[test]
fn a_recording_made_when_the_daemon_read_every_section_still_replays() {
    // Before the daemon left `[link]` and `[foxglove]` to their processes,
    // a session's config.toml was the whole configuration serialized in
    // this order, and session.log holds that text's hash: replay compares
    // it with the daemon's `to_toml` of the file read back.
    #[derive(serde::Serialize)]
    struct Before<'a> {
        #[serde(flatten)]
        daemon: &'a daemon::Config,
        foxglove: &'a FoxgloveConfig,
        link: &'a LinkConfig,
    }
    let mut whole = Config::default();
    whole.daemon.control.rate_hz = 100.0;
    whole.link.ros2_rates.insert("imu".into(), 50.0);
    whole.link.listen.push("tls/0.0.0.0:7447".into());
    whole.foxglove.read_timeout = 0.0;
    let recorded = toml::to_string(&Before {
        daemon: &whole.daemon,
        foxglove: &whole.foxglove,
        link: &whole.link,
    })
    .unwrap();
    let read = daemon::Config::from_toml(&recorded, "config.toml").unwrap();
    assert_eq!(read.to_toml(), recorded);
    let back = Config::from_toml(&recorded, "config.toml").unwrap();
    assert_eq!((&back.link, &back.foxglove), (&whole.link, &whole.foxglove));
}

/// ROS 2 position fixes go to the daemon's `[sensor.usbl]`: without one,
/// or with a serial source, the file is refused naming what it needs; a
/// `udp:` source bound to every address is reached on the loopback.
#[test]
fn ros2_position_fixes_need_a_udp_position_sensor() {
    let base = "[link]\nros2 = true\nros2-pose = true\n";
    let e = Config::from_toml(base, "t").unwrap_err().to_string();
    assert!(
        e.contains("needs [sensor.usbl]") && e.contains("no [sensor.usbl]"),
        "{e}"
    );
    let serial = format!(
        "[sensor]\nnode = 20\n[sensor.usbl]\nsource = \"serial:/dev/ttyUSB0:115200\"\n{base}"
    );
    let e = Config::from_toml(&serial, "t").unwrap_err().to_string();
    assert!(e.contains("source = \"serial:/dev/ttyUSB0:115200\""), "{e}");
    let udp = format!("[sensor]\nnode = 20\n[sensor.usbl]\nsource = \"udp:0.0.0.0:14660\"\n{base}");
    let c = Config::from_toml(&udp, "t").unwrap();
    assert_eq!(
        c.pose_fix_target().unwrap(),
        std::net::SocketAddr::from(([127, 0, 0, 1], 14660))
    );
}
