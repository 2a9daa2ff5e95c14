//! The head sensor's messages: HeadAttitude, HeadRates, HeadAccel and
//! HeadDepth on classic CAN, one HeadSample on CAN FD, and
//! [`encode_head_sample`], which sends a sample as the bus allows.

use super::error::{DecodeError, EncodeError};
use super::field::{Incoming, put};
use super::sensor::{HeadAttitude, HeadDepth, HeadSample, HeadVector, SensorErrors, SensorStatus};
use super::types::Message;
use super::variant::Variant;
use super::{classic, fd};
use crate::frame::Frame;
use crate::signal::Signal;

/// HeadAttitude (classic): sample counter and quaternion.
pub(super) fn encode_head_attitude(buf: &mut [u8], a: &HeadAttitude) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, a.sample as i64);
    for (s, q) in classic::HEAD_QUATERNION.iter().zip(a.quaternion) {
        put(buf, s, q as f64)?;
    }
    Ok(a.node.0)
}

pub(super) fn decode_head_attitude(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let mut quaternion = [0.0; 4];
    for (q, s) in quaternion.iter_mut().zip(&classic::HEAD_QUATERNION) {
        *q = rx.get(s)?;
    }
    Ok(Message::HeadAttitude(HeadAttitude {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        quaternion,
    }))
}

/// HeadRates / HeadAccel (classic): sample counter and three components.
pub(super) fn encode_head_vector(
    buf: &mut [u8],
    signals: &[Signal; 3],
    v: &HeadVector,
) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, v.sample as i64);
    for (s, x) in signals.iter().zip(v.xyz) {
        put(buf, s, x as f64)?;
    }
    Ok(v.node.0)
}

pub(super) fn decode_head_vector(
    rx: &Incoming,
    signals: &[Signal; 3],
) -> Result<HeadVector, DecodeError> {
    let node = rx.node()?;
    let mut xyz = [0.0; 3];
    for (x, s) in xyz.iter_mut().zip(signals) {
        *x = rx.get(s)?;
    }
    Ok(HeadVector {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        xyz,
    })
}

/// The pressure, temperature, status and errors of a head sample, placed
/// by `sig` = (pressure, temperature, status, errors).
pub(super) fn put_head_depth(
    buf: &mut [u8],
    sig: [&Signal; 4],
    pressure: u32,
    temperature: f32,
    status: SensorStatus,
    errors: SensorErrors,
) -> Result<(), EncodeError> {
    put(buf, sig[0], pressure as f64)?;
    put(buf, sig[1], temperature as f64)?;
    put(buf, sig[2], status.0 as f64)?;
    put(buf, sig[3], errors.0 as f64)
}

/// The mirror of [`put_head_depth`].
pub(super) fn get_head_depth(
    rx: &Incoming,
    sig: [&Signal; 4],
) -> Result<(u32, f32, SensorStatus, SensorErrors), DecodeError> {
    Ok((
        rx.get_raw(sig[0])? as u32,
        rx.get(sig[1])?,
        SensorStatus(rx.get_raw(sig[2])? as u8),
        SensorErrors(rx.get_raw(sig[3])? as u8),
    ))
}

pub(super) const CLASSIC_DEPTH: [&Signal; 4] = [
    &classic::HEAD_PRESSURE,
    &classic::HEAD_TEMPERATURE,
    &classic::HEAD_STATUS,
    &classic::HEAD_ERRORS,
];
pub(super) const FD_DEPTH: [&Signal; 4] = [
    &fd::HEAD_PRESSURE,
    &fd::HEAD_TEMPERATURE,
    &fd::HEAD_STATUS,
    &fd::HEAD_ERRORS,
];

/// HeadDepth (classic): sample counter, pressure, temperature, status,
/// errors.
pub(super) fn encode_head_depth(buf: &mut [u8], d: &HeadDepth) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, d.sample as i64);
    put_head_depth(
        buf,
        CLASSIC_DEPTH,
        d.pressure,
        d.temperature,
        d.status,
        d.errors,
    )?;
    Ok(d.node.0)
}

pub(super) fn decode_head_depth(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let (pressure, temperature, status, errors) = get_head_depth(rx, CLASSIC_DEPTH)?;
    Ok(Message::HeadDepth(HeadDepth {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        pressure,
        temperature,
        status,
        errors,
    }))
}

/// HeadSample (CAN FD): the whole sample in one frame.
pub(super) fn encode_head_sample_fd(buf: &mut [u8], h: &HeadSample) -> Result<u8, EncodeError> {
    fd::HEAD_SAMPLE.put(buf, h.sample as i64);
    put_head_depth(buf, FD_DEPTH, h.pressure, h.temperature, h.status, h.errors)?;
    for (s, q) in fd::HEAD_QUATERNION.iter().zip(h.quaternion) {
        put(buf, s, q as f64)?;
    }
    for (s, x) in fd::HEAD_RATES.iter().zip(h.rates) {
        put(buf, s, x as f64)?;
    }
    for (s, x) in fd::HEAD_ACCEL.iter().zip(h.accel) {
        put(buf, s, x as f64)?;
    }
    Ok(h.node.0)
}

pub(super) fn decode_head_sample_fd(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    rx.reserved_zero(rx.def.signals.iter())?;
    let (pressure, temperature, status, errors) = get_head_depth(rx, FD_DEPTH)?;
    let mut quaternion = [0.0; 4];
    for (q, s) in quaternion.iter_mut().zip(&fd::HEAD_QUATERNION) {
        *q = rx.get(s)?;
    }
    let (mut rates, mut accel) = ([0.0; 3], [0.0; 3]);
    for (x, s) in rates.iter_mut().zip(&fd::HEAD_RATES) {
        *x = rx.get(s)?;
    }
    for (x, s) in accel.iter_mut().zip(&fd::HEAD_ACCEL) {
        *x = rx.get(s)?;
    }
    Ok(Message::HeadSample(HeadSample {
        node,
        sample: fd::HEAD_SAMPLE.get(rx.data) as u8,
        quaternion,
        rates,
        accel,
        pressure,
        temperature,
        status,
        errors,
    }))
}

/// Encodes one head-sensor sample for `variant` and hands each frame to
/// `send`, without allocating: on CAN FD one [`HeadSample`] frame; on
/// classic CAN [`HeadAttitude`] (only when the status has
/// [`SensorStatus::ATTITUDE`]: a raw 6-axis IMU sends none), then
/// HeadRates, HeadAccel and last [`HeadDepth`], all with the same sample
/// counter. Nothing is sent if any field is out of range.
pub fn encode_head_sample(
    variant: Variant,
    h: &HeadSample,
    mut send: impl FnMut(Frame),
) -> Result<(), EncodeError> {
    match variant {
        Variant::Fd => send(Message::HeadSample(*h).encode(variant)?),
        Variant::Classic => {
            let (node, sample) = (h.node, h.sample);
            let attitude = Message::HeadAttitude(HeadAttitude {
                node,
                sample,
                quaternion: h.quaternion,
            });
            let frames = [
                attitude.encode(variant)?,
                Message::HeadRates(HeadVector {
                    node,
                    sample,
                    xyz: h.rates,
                })
                .encode(variant)?,
                Message::HeadAccel(HeadVector {
                    node,
                    sample,
                    xyz: h.accel,
                })
                .encode(variant)?,
                Message::HeadDepth(HeadDepth {
                    node,
                    sample,
                    pressure: h.pressure,
                    temperature: h.temperature,
                    status: h.status,
                    errors: h.errors,
                })
                .encode(variant)?,
            ];
            let skip = usize::from(!h.status.has(SensorStatus::ATTITUDE));
            for f in &frames[skip..] {
                send(*f);
            }
        }
    }
    Ok(())
}
