//! `[link]`: remote operation over Zenoh (`anguilla link`, its own
//! process). The section is the link crate's ([`anguilla_link::config`]);
//! here are its errors as the configuration's and its part of the
//! commented default file.

use anguilla_daemon::config::{ConfigError, fmt_f};
use anguilla_link::config::LinkConfig;

/// The link's error as the configuration's, its key and range kept.
pub(super) fn error(e: anguilla_link::config::ConfigError) -> ConfigError {
    use anguilla_link::config::ConfigError as L;
    match e {
        L::Range {
            key,
            value,
            expected,
        } => ConfigError::Range {
            key,
            value,
            expected,
        },
        L::Derived(text) => ConfigError::Derived(text),
    }
}

/// `[link]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &LinkConfig, w: &mut dyn FnMut(String)) {
    w("[link]".into());
    w("# Remote operation over Zenoh: `anguilla link` (its own process; the daemon".into());
    w("# ignores this section; docs/remote.md). Endpoints it listens on: \"local\",".into());
    w("# a Unix socket in /tmp/anguilla/<prefix>/link/ (mode 0770: the link's user and".into());
    w("# group, the operators, only); \"tls/HOST:PORT\" with the robot's CA, certificate".into());
    w("# and key (`anguilla link certs` makes them); plain \"tcp/...\" on loopback only,".into());
    w("# and only with insecure-loopback = true (every local user can reach it).".into());
    w(format!("listen = {:?}", d.listen));
    w(format!("insecure-loopback = {}", d.insecure_loopback));
    w("# Most states a second on the link (Hz); mode, cause or holder changes go at once.".into());
    w(format!("state-rate = {}", fmt_f(d.state_rate)));
    w("# Most remote clients with a session at once; a silent one is closed after".into());
    w("# idle-timeout (s).".into());
    w(format!("max-clients = {}", d.max_clients));
    w(format!("idle-timeout = {}", fmt_f(d.idle_timeout)));
    w("# TLS with mutual authentication: PEM files (paths relative to the working".into());
    w("# directory); empty: none.".into());
    w("ca = \"\"".into());
    w("cert = \"\"".into());
    w("key = \"\"".into());
    w("# The allowlist: what remote clients may send (\"command\", \"estop\"), and".into());
    w("# what the link publishes (\"state\"). A watch-only link: inbound = [\"estop\"].".into());
    w(format!("inbound = {:?}", d.inbound));
    w(format!("outbound = {:?}", d.outbound));
    w("# The robot as a ROS 2 node on rmw_zenoh's wire (no ROS on the robot;".into());
    w("# docs/ros2.md): ROS_DOMAIN_ID, the node's namespace and name, the distribution".into());
    w("# (\"jazzy\", also for Kilted and later, or \"humble\"), and the most messages a".into());
    w("# second (Hz) of every topic, or of those ros2-rates names (joint_states, imu,".into());
    w("# pressure, feedforward, torque_residual, diagnostics, tf, cross_track_error,".into());
    w("# current).".into());
    w(format!("ros2 = {}", d.ros2));
    w(format!("ros2-domain = {}", d.ros2_domain));
    w(format!("ros2-namespace = {:?}", d.ros2_namespace));
    w(format!("ros2-node = {:?}", d.ros2_node));
    w(format!("ros2-distro = {:?}", d.ros2_distro));
    w(format!("ros2-rate = {}", fmt_f(d.ros2_rate)));
    w(format!(
        "ros2-rates = {{ {} }}",
        d.ros2_rates
            .iter()
            .map(|(k, v)| format!("{k} = {}", fmt_f(*v)))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    w("# Driving from ROS 2 (cmd_vel, ~/take_control, ~/enable, ~/estop...; the".into());
    w("# inbound allowlist applies): the fastest cmd_vel may ask for (m/s; linear.x".into());
    w("# swims through the model's steady speed: faster is clamped and reported)".into());
    w("# and the undulation frequency (Hz).".into());
    w(format!("ros2-max-speed = {}", fmt_f(d.ros2_max_speed)));
    w(format!("ros2-frequency = {}", fmt_f(d.ros2_frequency)));
    w("# Position fixes from ROS 2 (a tank's motion capture, docs/ros2.md): pose_fix".into());
    w("# (PoseStamped) and odom_fix (Odometry) in ros2-pose-frame go to the daemon's".into());
    w("# [sensor.usbl] (its udp: source), aged by their stamps; ros2-pose-sigma (m) is".into());
    w("# their standard deviation when the message gives none.".into());
    w(format!("ros2-pose = {}", d.ros2_pose));
    w(format!("ros2-pose-frame = {:?}", d.ros2_pose_frame));
    w(format!("ros2-pose-sigma = {}", fmt_f(d.ros2_pose_sigma)));
}
