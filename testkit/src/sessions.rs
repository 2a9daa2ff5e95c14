//! Recorded sessions written by hand, for the tests of what reads them.

use std::path::Path;

/// A `session.mcap` at `path` of `seconds` of 2 joints sampled at 50 Hz,
/// holding still (`amplitude` 0: the daemon enabled but never swimming)
/// or swimming at 1 Hz with `amplitude` (rad) on the yaw axes.
pub fn joints_session(path: &Path, seconds: f64, amplitude: f64) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(file)
        .unwrap();
    let ch = w
        .add_channel(0, "/anguilla/joints", "json", &Default::default())
        .unwrap();
    for i in 0..(seconds * 50.0) as u64 {
        let ph = std::f64::consts::TAU * i as f64 * 0.02;
        let data = format!(
            "{{\"measured_pitch\": [0.0, 0.001], \"measured_yaw\": [{}, {}], \
             \"measured_pitch_velocity\": [0.0, 0.0], \"measured_yaw_velocity\": [{}, {}], \
             \"measured_pitch_torque\": [0.0, 0.0], \"measured_yaw_torque\": [0.01, 0.02]}}",
            amplitude * ph.sin(),
            amplitude * (ph - 1.0).sin(),
            amplitude * ph.cos(),
            amplitude * (ph - 1.0).cos(),
        );
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: i as u32,
            log_time: 1_000_000_000 + i * 20_000_000,
            publish_time: 1_000_000_000 + i * 20_000_000,
        };
        w.write_to_known_channel(&header, data.as_bytes()).unwrap();
    }
    w.finish().unwrap();
}
