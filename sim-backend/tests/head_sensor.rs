//! The simulated head sensor against the simulated body's truth: frame
//! conventions, noise and bias, rate and latency, scripted faults,
//! determinism.

mod common;

use std::time::Duration;

use anguilla_protocol::message::{
    self, AxisSetpoint, HeadSample, Message, NodeSet, SensorStatus, Variant,
};
use anguilla_sim::sensor::{GRAVITY, SensorConfig};
use anguilla_sim::{RobotConfig, Truth};
use common::{Host, MS};

const SENSOR: u8 = 20;
const JOINTS: usize = 6;

/// A noiseless, unbiased sensor: what is left is quantization.
fn exact() -> SensorConfig {
    SensorConfig {
        gyro_noise: 0.0,
        accel_noise: 0.0,
        attitude_noise: 0.0,
        pressure_noise: 0.0,
        gyro_bias_walk: 0.0,
        accel_bias_walk: 0.0,
        ..SensorConfig::typical(SENSOR)
    }
}

fn host(sensor: SensorConfig, variant: Variant) -> Host {
    Host::new(RobotConfig {
        variant,
        head_sensor: Some(sensor),
        ..RobotConfig::with_joints(JOINTS)
    })
}

/// Swims a wave in pitch and yaw for `seconds`, recording the truth every
/// millisecond (ticks are 2 ms: the truth at a sample's time is the state
/// the sample was taken from).
fn undulate(h: &mut Host, seconds: f64) -> Vec<(Duration, Truth)> {
    h.enable_all();
    let mut truths = vec![(h.now(), h.robot.truth())];
    let periods = (seconds * 100.0).round() as usize;
    for k in 0..periods {
        let phase = k as f32 * 0.01 * std::f32::consts::TAU;
        let sp: Vec<[AxisSetpoint; 2]> = (0..JOINTS)
            .map(|j| {
                let s = (phase - 0.6 * j as f32).sin();
                let at = |position| AxisSetpoint {
                    position,
                    velocity: 0.0,
                    torque: 0.0,
                };
                [at(0.25 * s), at(0.5 * s)]
            })
            .collect();
        h.cycle(&sp, MS);
        truths.push((h.now(), h.robot.truth()));
        for _ in 0..9 {
            h.run(MS);
            truths.push((h.now(), h.robot.truth()));
        }
    }
    truths
}

/// The head samples heard (CAN FD: one frame each), with their times.
fn fd_samples(h: &Host) -> Vec<(Duration, HeadSample)> {
    h.heard
        .iter()
        .filter_map(
            |(t, f)| match message::decode(f, Variant::Fd, NodeSet::all()) {
                Ok(Message::HeadSample(s)) => Some((*t, s)),
                _ => None,
            },
        )
        .collect()
}

/// `v` rotated by unit quaternion `q` (`[w, x, y, z]`), written out here
/// independently of the sensor's code.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let u = [x, y, z];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let t = cross(u, v).map(|c| 2.0 * c);
    let c = cross(u, t);
    [0, 1, 2].map(|i| v[i] + w * t[i] + c[i])
}

fn conj(q: [f64; 4]) -> [f64; 4] {
    [q[0], -q[1], -q[2], -q[3]]
}

fn f64s<const N: usize>(a: [f32; N]) -> [f64; N] {
    a.map(f64::from)
}

fn truth_at(truths: &[(Duration, Truth)], t: Duration) -> &Truth {
    &truths
        .iter()
        .find(|(at, _)| *at == t)
        .unwrap_or_else(|| panic!("no truth at {t:?}"))
        .1
}

#[test]
fn samples_are_the_truth_in_the_head_frame_within_quantization() {
    let mut h = host(exact(), Variant::Fd);
    let truths = undulate(&mut h, 2.0);
    let samples = fd_samples(&h);
    assert!(samples.len() >= 190, "{} samples", samples.len());
    let (mut max_yaw_rate, mut checked) = (0.0f64, 0);
    let mut count = 0u32;
    for (i, (_, s)) in samples.iter().enumerate() {
        // Sample k was taken at k × 10 ms (latency 0); the counter wraps.
        let k = i as u32;
        assert_eq!(s.sample, k as u8);
        count += 1;
        let t = Duration::from_millis(10 * u64::from(k));
        let Some(prev) = k.checked_sub(1) else {
            continue;
        };
        let t0 = Duration::from_millis(10 * u64::from(prev));
        if t0 < truths[0].0 {
            continue; // before the truth's recording began (enabling)
        }
        let tr = truth_at(&truths, t);
        let tr0 = truth_at(&truths, t0);
        let q = f64s(s.quaternion);
        assert!(s.status.has(SensorStatus::ATTITUDE | SensorStatus::IMU));
        // Attitude: the head's x axis (forward) is the model's −t1, its z
        // axis the model's t3, in the world. Quantization 1/32767 per
        // component: 1e-4.
        let fwd = rotate(q, [1.0, 0.0, 0.0]);
        let t1 = rotate(tr.orientation, [1.0, 0.0, 0.0]);
        let up = rotate(q, [0.0, 0.0, 1.0]);
        let t3 = rotate(tr.orientation, [0.0, 0.0, 1.0]);
        for i in 0..3 {
            assert!(
                (fwd[i] + t1[i]).abs() < 1e-4,
                "forward {fwd:?} vs -t1 {t1:?}"
            );
            assert!((up[i] - t3[i]).abs() < 1e-4, "up {up:?} vs t3 {t3:?}");
        }
        // Rates: the world angular velocity in the head frame; 2 mrad/s a
        // count, half a count plus the attitude's 1e-4 (rad) times |ω|, with
        // a fifth's margin (the enabling's jolt spins the head at up to 17
        // rad/s in roll).
        let w = rotate(conj(q), tr.angular_velocity);
        let tol = 1.0e-3 + 1.2e-4 * w.iter().map(|x| x * x).sum::<f64>().sqrt();
        for i in 0..3 {
            assert!(
                (f64::from(s.rates[i]) - w[i]).abs() < tol,
                "rate {i}: {:?} vs {w:?}",
                s.rates
            );
        }
        max_yaw_rate = max_yaw_rate.max(w[2].abs());
        // Accelerations: specific force, the velocity's finite difference
        // over the sample period plus g up, in the head frame; 5 mm/s² a
        // count.
        let a = [0, 1, 2].map(|i| (tr.velocity[i] - tr0.velocity[i]) / 0.01);
        let f = rotate(conj(q), [a[0], a[1], a[2] + GRAVITY]);
        for i in 0..3 {
            assert!(
                (f64::from(s.accel[i]) - f[i]).abs() < 4e-3,
                "accel {i}: {:?} vs {f:?}",
                s.accel
            );
        }
        // Depth: (p − p0) / (ρ g) below the origin's 1 m, 1 Pa a count.
        let c = exact();
        let depth = (f64::from(s.pressure) - c.surface_pressure) / (c.water_density * GRAVITY);
        assert!(
            (depth - (c.origin_depth - tr.position[2])).abs() < 1e-4,
            "depth {depth} vs z {}",
            tr.position[2]
        );
        assert!((s.temperature - 15.0).abs() < 0.006);
        checked += 1;
    }
    assert!(checked > 150, "{checked} of {count}");
    // The comparison is not vacuous: the head did turn.
    assert!(max_yaw_rate > 0.05, "max yaw rate {max_yaw_rate}");
}

#[test]
fn noise_and_bias_have_the_configured_size() {
    let bias = [0.02, -0.01, 0.005];
    let sigma = 0.01;
    let cfg = SensorConfig {
        gyro_noise: sigma,
        gyro_bias: bias,
        ..exact()
    };
    let mut h = host(cfg, Variant::Fd);
    // The body at rest (nodes never enabled): true rates are zero.
    h.run(Duration::from_secs(3));
    assert!(
        h.robot
            .truth()
            .angular_velocity
            .iter()
            .all(|w| w.abs() < 1e-9)
    );
    let samples = fd_samples(&h);
    let n = samples.len() as f64;
    assert!(n >= 299.0, "{n}");
    for (i, b) in bias.iter().enumerate() {
        let xs: Vec<f64> = samples.iter().map(|(_, s)| f64::from(s.rates[i])).collect();
        let mean = xs.iter().sum::<f64>() / n;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        // Mean: the bias within 4 standard errors (σ/√300 = 0.6 mrad/s)
        // plus the 1 mrad/s of rounding. Std dev: σ within 15 % (its
        // standard error is 4 %; quantization adds 0.6 mrad/s in
        // quadrature: 2 %).
        assert!((mean - b).abs() < 0.0035, "axis {i}: mean {mean}");
        assert!((sd / sigma - 1.0).abs() < 0.15, "axis {i}: sd {sd}");
    }
}

#[test]
fn rate_latency_and_heartbeats_are_as_configured() {
    let cfg = SensorConfig {
        rate_hz: 200,
        latency_samples: 3,
        ..exact()
    };
    let mut h = host(cfg, Variant::Classic);
    h.run(Duration::from_secs(1));
    let mut depth = Vec::new();
    let mut ids = Vec::new();
    let mut heartbeats = 0;
    for (t, f) in &h.heard {
        match message::decode(f, Variant::Classic, NodeSet::all()) {
            Ok(Message::HeadDepth(d)) => depth.push((*t, d.sample)),
            Ok(Message::Heartbeat(hb)) if hb.node.get() == SENSOR => heartbeats += 1,
            _ => {}
        }
        if (0x240..0x340).contains(&f.id().raw()) {
            ids.push(f.id().raw());
        }
    }
    // Samples at 0, 5, ..., 1000 ms; each sent three samples (15 ms)
    // later: 198 within the first second, the first at 15 ms.
    assert_eq!(depth.len(), 198, "{:?}", &depth[..3]);
    for (t, k) in &depth {
        let due = Duration::from_millis(5 * (u64::from(*k) + 3));
        // Heard within the millisecond step that sent it.
        assert!(*t >= due && *t <= due + MS, "sample {k} at {t:?}");
    }
    // Four classic frames per sample (a fusion IMU), in order.
    assert_eq!(ids.len(), 4 * 198);
    assert_eq!(&ids[..4], &[0x254, 0x294, 0x2D4, 0x314]);
    // A heartbeat every 100 ms from 0: 0, 100, ..., 1000 ms.
    assert_eq!(heartbeats, 11);
}

#[test]
fn a_raw_imu_sends_no_attitude() {
    let mut h = host(
        SensorConfig {
            fusion: false,
            ..exact()
        },
        Variant::Classic,
    );
    h.run(100 * MS);
    let msgs = h.messages_since(Duration::ZERO);
    assert!(msgs.iter().any(|m| matches!(m, Message::HeadRates(_))));
    assert!(!msgs.iter().any(|m| matches!(m, Message::HeadAttitude(_))));
    let Some(Message::HeadDepth(d)) = msgs.iter().find(|m| matches!(m, Message::HeadDepth(_)))
    else {
        panic!("no depth frame");
    };
    assert!(!d.status.has(SensorStatus::ATTITUDE) && d.status.accuracy() == 0);
}

#[test]
fn scripted_faults_silence_freeze_and_bias_the_sensor() {
    let cfg = SensorConfig {
        gyro_noise: 0.002,
        ..exact()
    };
    let mut h = host(cfg, Variant::Fd);
    h.robot
        .load_scenario(
            "0.3 sensor silent 0.2\n0.7 sensor stuck\n0.9 sensor ok\n1.0 sensor bias-jump -0.5\n",
        )
        .unwrap();
    h.run(Duration::from_millis(1500));
    let samples = fd_samples(&h);
    let at = |ms: u64| Duration::from_millis(ms);
    // Silent 0.3..0.5 s: nothing, heartbeats included; the counter kept
    // counting, so the gap shows.
    assert!(samples.iter().all(|(t, _)| *t <= at(300) || *t >= at(500)));
    let sensor_frames = h
        .heard
        .iter()
        .filter(|(t, f)| *t > at(300) && *t < at(500) && f.id().raw() & 0x3F == u32::from(SENSOR))
        .count();
    assert_eq!(sensor_frames, 0);
    let after = samples.iter().find(|(t, _)| *t >= at(500)).unwrap().1;
    assert_eq!(after.sample, 50);
    // Stuck 0.7..0.9 s: the same values, a counting counter.
    let stuck: Vec<_> = samples
        .iter()
        .filter(|(t, _)| *t > at(700) && *t < at(900))
        .map(|(_, s)| *s)
        .collect();
    assert!(stuck.len() >= 18);
    for w in stuck.windows(2) {
        assert_eq!(w[1].rates, w[0].rates);
        assert_eq!(w[1].sample, w[0].sample.wrapping_add(1));
    }
    let fresh: Vec<_> = samples
        .iter()
        .filter(|(t, _)| *t > at(900) && *t < at(1000))
        .map(|(_, s)| s.rates)
        .collect();
    assert!(fresh.windows(2).any(|w| w[0] != w[1]), "still stuck");
    // Bias jump at 1.0 s: rates (truly zero: the body is at rest) step by
    // −0.5 rad/s; within 5 mrad/s (noise 2 mrad/s, mean of 10).
    let mean = |from: u64, to: u64| {
        let xs: Vec<f64> = samples
            .iter()
            .filter(|(t, _)| *t > at(from) && *t < at(to))
            .map(|(_, s)| f64::from(s.rates[2]))
            .collect();
        xs.iter().sum::<f64>() / xs.len() as f64
    };
    assert!(mean(900, 1000).abs() < 0.005);
    assert!((mean(1100, 1500) + 0.5).abs() < 0.005);
    assert!((h.robot.head_sensor().unwrap().gyro_bias()[2] + 0.5).abs() < 1e-12);
}

#[test]
fn sensor_faults_need_a_sensor_and_ids_must_not_clash() {
    let mut h = Host::new(RobotConfig::with_joints(JOINTS));
    let e = h.robot.load_scenario("1 sensor stuck\n").unwrap_err();
    assert!(e.to_string().contains("no head sensor"), "{e}");
    let cfg = RobotConfig {
        head_sensor: Some(SensorConfig::typical(3)),
        ..RobotConfig::with_joints(JOINTS)
    };
    let e = cfg.validate().unwrap_err();
    assert!(e.to_string().contains("head_sensor.id"), "{e}");
    // Without a sensor nothing is sent on its ids.
    h.run(100 * MS);
    assert!(h.heard.iter().all(|(_, f)| f.id().raw() < 0x240));
}

#[test]
fn the_same_seed_gives_the_same_samples() {
    let run = |seed| {
        let mut h = Host::new(RobotConfig {
            seed,
            variant: Variant::Fd,
            head_sensor: Some(SensorConfig::typical(SENSOR)),
            ..RobotConfig::with_joints(JOINTS)
        });
        h.run(300 * MS);
        fd_samples(&h)
            .into_iter()
            .map(|(_, s)| s)
            .collect::<Vec<_>>()
    };
    let a = run(7);
    assert_eq!(a.len(), 31); // 0, 10, ..., 300 ms
    assert_eq!(a, run(7));
    assert_ne!(a, run(8));
}
