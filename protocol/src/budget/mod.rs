//! Bus-load arithmetic with worst-case bit stuffing.
//!
//! # Frame lengths on the wire
//!
//! **Classic CAN**, base format (11-bit id), `n` data bytes: SOF (1), id
//! (11), RTR (1), IDE (1), r0 (1), DLC (4), data (8n), CRC (15) are subject
//! to bit stuffing: `S = 34 + 8n` bits (extended format: `54 + 8n`). A
//! stuff bit follows every five equal bits; the worst case is a stuff bit
//! after the first five bits and then after every four (the stuff bit
//! itself starts the next run), `floor((S - 1) / 4)` stuff bits. Then CRC
//! delimiter (1), ACK slot and delimiter (2), EOF (7) and the 3-bit
//! interframe space are never stuffed: 13 bits. An 8-byte frame is
//! `98 + 24 + 13 = 135` bit times; 111 without stuffing.
//!
//! **CAN FD** (ISO 11898-1:2015), base format: the arbitration phase SOF, id
//! (11), RRS, IDE, FDF, res, BRS is 17 bits at the nominal rate (36 in the
//! extended format). With bit-rate switching, ESI (1), DLC (4) and data (8n)
//! follow at the data rate; dynamic stuffing runs from SOF to the end of
//! the data, `floor((17 + 5 + 8n - 1) / 4)` stuff bits in the worst case,
//! of which at most `floor((17 - 1) / 4) = 4` fall in the arbitration phase
//! (we count 4 there, the rest at the data rate: an upper bound on time).
//! The CRC field uses fixed stuffing: stuff count (4) + CRC-17 + 6 fixed
//! stuff bits = 27 bits for up to 16 data bytes, stuff count + CRC-21 + 7
//! fixed stuff bits = 32 above, at the data rate. CRC delimiter, ACK (2),
//! EOF (7) and IFS (3) are counted at the nominal rate (13 bits; the switch
//! back happens inside the CRC delimiter, so this slightly overestimates).
//! Without BRS every bit is at the nominal rate.

use crate::message::{HEAD_SENSOR_RATE_HZ, NodeSet, Variant};

mod line;

pub use line::{
    Bitrates, BudgetError, BudgetLine, Cadence, FrameBits, control_traffic, head_sensor_traffic,
    worst_case_bits,
};

/// The IMUs on an anguilla bus (the head sensor, a tail IMU): each sends
/// the head-sensor protocol's samples at `rate_hz` and a heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Imus {
    /// Samples per second of each.
    pub rate_hz: u16,
    /// How many (1..).
    pub count: u8,
}

impl Imus {
    /// One IMU (the head sensor) at `rate_hz`.
    pub const fn one(rate_hz: u16) -> Self {
        Self { rate_hz, count: 1 }
    }
}

/// Whose cyclic traffic a budget counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Traffic {
    /// anguilla vertebra nodes with these ids (one per joint), and the
    /// IMUs (head sensor, tail IMU) if the robot has any
    /// ([`head_sensor_traffic`] each).
    Anguilla(NodeSet, Option<Imus>),
    /// A family's drives (bought ones: one per axis, classic CAN): what
    /// they and their master send is the family's answer
    /// ([`Family::drive_traffic`](crate::Family::drive_traffic)).
    Drives {
        /// The family.
        family: crate::Family,
        /// Drives (2 per joint).
        axes: u32,
    },
}

impl Traffic {
    /// The traffic of the joints `nodes`: anguilla's nodes by id, a
    /// bought family's two drives per joint.
    pub fn of_family(family: crate::Family, nodes: NodeSet) -> Traffic {
        if family.drive_per_axis() {
            Traffic::Drives {
                family,
                axes: 2 * nodes.len() as u32,
            }
        } else {
            Traffic::Anguilla(nodes, None)
        }
    }

    /// Joints the traffic serves.
    pub fn joints(self) -> u32 {
        match self {
            Traffic::Anguilla(n, _) => n.len() as u32,
            Traffic::Drives { axes, .. } => axes / 2,
        }
    }

    /// The cyclic traffic, line by line, computed by encoding the frames.
    pub fn lines(self, variant: Variant) -> Vec<BudgetLine> {
        match self {
            Traffic::Anguilla(nodes, sensor) => {
                let mut lines = control_traffic(variant, nodes).to_vec();
                if let Some(imus) = sensor {
                    // `count` sensors' per-second lines: each frame as often
                    // again.
                    let k = f64::from(imus.count);
                    lines.extend(head_sensor_traffic(variant, imus.rate_hz).into_iter().map(
                        |mut l| {
                            if let Cadence::PerSecond(c) = l.cadence {
                                l.cadence = Cadence::PerSecond(c * k);
                            }
                            l
                        },
                    ));
                }
                lines
            }
            Traffic::Drives { family, axes } => family.drive_traffic(axes, variant),
        }
    }
}

/// Bus load of the cyclic traffic.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Variant the traffic is encoded for.
    pub variant: Variant,
    /// Bit rates.
    pub rates: Bitrates,
    /// Whose traffic.
    pub traffic: Traffic,
    /// Control rate, Hz.
    pub rate: f64,
    /// The traffic, line by line.
    pub lines: Vec<BudgetLine>,
    /// Worst-case bus time per control period, seconds (heartbeats
    /// amortized).
    pub busy_per_period: f64,
    /// Fraction of bus time used (1.0 = saturated).
    pub load: f64,
}

fn check_nodes(nodes: NodeSet) -> Result<NodeSet, BudgetError> {
    if nodes.is_empty() {
        Err(BudgetError::Joints(0))
    } else {
        Ok(nodes)
    }
}

/// Ids 1..=`joints`: the nodes of a robot of `joints` vertebrae numbered
/// from 1 (an error outside 1..=63).
pub fn first_nodes(joints: u32) -> Result<NodeSet, BudgetError> {
    if (1..=crate::message::MAX_NODE_ID as u32).contains(&joints) {
        Ok(NodeSet::first(joints as u8))
    } else {
        Err(BudgetError::Joints(joints))
    }
}

/// The worst-case bus load of the nodes `nodes` at control rate `rate` Hz.
/// The variant follows from `rates` (a data rate means CAN FD).
pub fn budget(nodes: NodeSet, rate: f64, rates: Bitrates) -> Result<Budget, BudgetError> {
    budget_of(Traffic::Anguilla(check_nodes(nodes)?, None), rate, rates)
}

fn check_traffic(t: Traffic, rates: Bitrates) -> Result<Bitrates, BudgetError> {
    let rates = rates.validate()?;
    match t {
        Traffic::Anguilla(n, sensor) => {
            check_nodes(n)?;
            if let Some(imus) = sensor
                && !(HEAD_SENSOR_RATE_HZ.0..=HEAD_SENSOR_RATE_HZ.1).contains(&imus.rate_hz)
            {
                return Err(BudgetError::HeadSensorRate(imus.rate_hz));
            }
        }
        Traffic::Drives { family, axes } => {
            if axes == 0 {
                return Err(BudgetError::Joints(0));
            }
            if rates.data.is_some() && !family.speaks_fd() {
                return Err(BudgetError::ClassicOnly);
            }
        }
    }
    Ok(rates)
}

/// The worst-case bus load of `traffic` at control rate `rate` Hz.
pub fn budget_of(traffic: Traffic, rate: f64, rates: Bitrates) -> Result<Budget, BudgetError> {
    let rates = check_traffic(traffic, rates)?;
    if !(rate.is_finite() && rate > 0.0 && rate <= 20_000.0) {
        return Err(BudgetError::Rate(rate));
    }
    let variant = rates.variant();
    let lines = traffic.lines(variant);
    let busy: f64 = lines.iter().map(|l| l.busy_per_second(rates, rate)).sum();
    Ok(Budget {
        variant,
        rates,
        traffic,
        rate,
        lines,
        busy_per_period: busy / rate,
        load: busy,
    })
}

/// The highest control rate, Hz, at which the cyclic traffic of the nodes
/// `nodes` stays within `max_load` (a fraction, e.g. 0.6) of the bus.
pub fn max_rate(nodes: NodeSet, rates: Bitrates, max_load: f64) -> Result<f64, BudgetError> {
    max_rate_of(
        Traffic::Anguilla(check_nodes(nodes)?, None),
        rates,
        max_load,
    )
}

/// The highest control rate, Hz, at which `traffic` stays within
/// `max_load` of the bus (0 when the per-second traffic alone exceeds it).
pub fn max_rate_of(traffic: Traffic, rates: Bitrates, max_load: f64) -> Result<f64, BudgetError> {
    let rates = check_traffic(traffic, rates)?;
    if !(max_load > 0.0 && max_load <= 1.0) {
        return Err(BudgetError::Load(max_load));
    }
    let lines = traffic.lines(rates.variant());
    // load(rate) = fixed + rate * per_period
    let fixed: f64 = lines
        .iter()
        .filter(|l| matches!(l.cadence, Cadence::PerSecond(_)))
        .map(|l| l.busy_per_second(rates, 1.0))
        .sum();
    let per_period: f64 = lines
        .iter()
        .filter(|l| matches!(l.cadence, Cadence::PerPeriod(_)))
        .map(|l| l.bits.seconds(rates))
        .sum();
    Ok(((max_load - fixed) / per_period).max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Frame;
    use crate::frame::Id;
    use crate::message::NodeId;

    const CLASSIC_1M: Bitrates = Bitrates {
        nominal: 1_000_000,
        data: None,
    };
    const FD_1_5M: Bitrates = Bitrates {
        nominal: 1_000_000,
        data: Some(5_000_000),
    };

    #[test]
    fn classic_frame_lengths_match_the_textbook() {
        let f = Frame::new_standard(0x123, &[0; 8]).unwrap();
        // 111 bits unstuffed incl. IFS, 24 worst-case stuff bits.
        assert_eq!(
            worst_case_bits(&f),
            FrameBits {
                nominal: 135,
                data: 0
            }
        );
        let e = Frame::new(Id::extended_literal(1), &[0; 8]).unwrap();
        assert_eq!(worst_case_bits(&e).nominal, 118 + 13 + 29);
        let empty = Frame::new_standard(0, &[]).unwrap();
        assert_eq!(worst_case_bits(&empty).nominal, 34 + 8 + 13);
    }

    /// On CAN FD the setpoint frames follow the ids: six nodes 1..=6 share
    /// one group frame, six nodes 1, 7, .., 31 need six. Counting the nodes
    /// only (as the budget did) under-counts sparse ids and lets the
    /// automatic rate overload the bus.
    #[test]
    fn sparse_ids_on_fd_count_every_group_frame() {
        let ids = |v: &[u8]| NodeSet::of(v.iter().map(|&i| NodeId::new(i).unwrap()));
        let dense = ids(&[1, 2, 3, 4, 5, 6]);
        let sparse = ids(&[1, 7, 13, 19, 25, 31]);
        let frames = |n| match control_traffic(Variant::Fd, n)[0].cadence {
            Cadence::PerPeriod(c) => c,
            Cadence::PerSecond(_) => unreachable!("setpoints are per period"),
        };
        assert_eq!((frames(dense), frames(sparse)), (1, 6));
        let (d, s) = (
            max_rate(dense, FD_1_5M, 0.6).unwrap(),
            max_rate(sparse, FD_1_5M, 0.6).unwrap(),
        );
        assert!(s < d * 0.8, "sparse {s} Hz vs dense {d} Hz");
        assert!((budget(sparse, s, FD_1_5M).unwrap().load - 0.6).abs() < 1e-9);
        // Classic CAN: one frame per node wherever the ids are.
        let c = |n| control_traffic(Variant::Classic, n)[0].cadence;
        assert_eq!(c(dense), c(sparse));
    }

    #[test]
    fn fd_frame_lengths() {
        let f = Frame::new_fd(Id::standard_literal(0x100), &[0; 64], true).unwrap();
        let b = worst_case_bits(&f);
        assert_eq!(b.nominal, 17 + 4 + 13);
        // 5 + 512 data bits, 129 stuff bits in the data phase, 32 CRC field.
        assert_eq!(b.data, 5 + 512 + (533 / 4 - 4) + 32);
        let slow = Frame::new_fd(Id::standard_literal(0x100), &[0; 64], false).unwrap();
        assert_eq!(worst_case_bits(&slow).nominal, b.nominal + b.data);
    }

    #[test]
    fn goals_are_met() {
        let c = budget(NodeSet::first(12), 100.0, CLASSIC_1M).unwrap();
        assert!(c.load <= 0.60, "classic load {}", c.load);
        let f = budget(NodeSet::first(12), 500.0, FD_1_5M).unwrap();
        assert!(f.load <= 0.60, "fd load {}", f.load);
        assert!(max_rate(NodeSet::first(12), CLASSIC_1M, 0.6).unwrap() >= 100.0);
        assert!(max_rate(NodeSet::first(12), FD_1_5M, 0.6).unwrap() >= 500.0);
    }

    #[test]
    fn max_rate_is_where_the_load_hits_the_limit() {
        for rates in [CLASSIC_1M, FD_1_5M] {
            for joints in [1, 6, 12, 13, 30] {
                let r = max_rate(NodeSet::first(joints), rates, 0.6).unwrap();
                let b = budget(NodeSet::first(joints), r, rates).unwrap();
                // Linear in the rate: equal up to float rounding.
                assert!((b.load - 0.6).abs() < 1e-9, "{joints} {r} {}", b.load);
            }
        }
    }

    /// The figure: 24 CiA 402 axes at 1 Mbit/s classic need 49
    /// frames a period (24 RPDOs, SYNC, 24 TPDOs).
    #[test]
    fn cia402_and_odrive_traffic() {
        let co = Traffic::Drives {
            family: crate::Family::Cia402,
            axes: 24,
        };
        let b = budget_of(co, 100.0, CLASSIC_1M).unwrap();
        let per_period: f64 = b
            .lines
            .iter()
            .filter(|l| matches!(l.cadence, Cadence::PerPeriod(_)))
            .map(|l| l.frames_per_period(100.0))
            .sum();
        assert_eq!(per_period, 49.0);
        // 48 eight-byte PDOs (135 bits) and an empty SYNC (55 bits) a
        // period; 25 heartbeats (1 byte, 65 bits) every 100 ms.
        let expect = (48.0 * 135.0 + 55.0) * 100.0 + 250.0 * 65.0;
        assert!((b.load * 1e6 - expect).abs() < 1e-6, "{}", b.load);
        let r = max_rate_of(co, CLASSIC_1M, 0.6).unwrap();
        assert!((budget_of(co, r, CLASSIC_1M).unwrap().load - 0.6).abs() < 1e-9);
        // ODrive: only the setpoints scale with the rate; the encoder
        // estimates at 100 Hz per axis are paid whatever the rate.
        let od = Traffic::Drives {
            family: crate::Family::Odrive,
            axes: 24,
        };
        let b = budget_of(od, 100.0, CLASSIC_1M).unwrap();
        let expect = 24.0 * 135.0 * 100.0 + 24.0 * 110.0 * 135.0;
        assert!((b.load * 1e6 - expect).abs() < 1e-6, "{}", b.load);
        // 40 axes' estimates and heartbeats alone take 59.4 % of 1 Mbit/s.
        let r = max_rate_of(
            Traffic::Drives {
                family: crate::Family::Odrive,
                axes: 40,
            },
            CLASSIC_1M,
            0.6,
        )
        .unwrap();
        assert!(r < 5.0, "{r}");
        assert_eq!(budget_of(co, 100.0, FD_1_5M), Err(BudgetError::ClassicOnly));
        assert!(
            budget_of(
                Traffic::Drives {
                    family: crate::Family::Cia402,
                    axes: 0
                },
                100.0,
                CLASSIC_1M
            )
            .is_err()
        );
    }

    #[test]
    fn a_head_sensor_counts_only_when_present() {
        let nodes = NodeSet::first(12);
        let without = budget_of(Traffic::Anguilla(nodes, None), 100.0, CLASSIC_1M).unwrap();
        // Unchanged: README's 34.5 % for 12 joints at 100 Hz.
        assert_eq!(
            without.lines,
            control_traffic(Variant::Classic, nodes).to_vec()
        );
        assert_eq!(budget(nodes, 100.0, CLASSIC_1M).unwrap(), without);
        let with = budget_of(
            Traffic::Anguilla(nodes, Some(Imus::one(100))),
            100.0,
            CLASSIC_1M,
        )
        .unwrap();
        let names: Vec<_> = with.lines[4..].iter().map(|l| l.name).collect();
        assert_eq!(
            names,
            [
                "HeadAttitude",
                "HeadRates",
                "HeadAccel",
                "HeadDepth",
                "Heartbeat (head sensor)"
            ]
        );
        // Per sample 135 + 125 + 125 + 135 bits (8, 7, 7, 8 bytes), 100
        // samples/s, plus 10 heartbeats of 115 bits: 53 150 bit/s.
        let added = with.load - without.load;
        assert!((added * 1e6 - 53_150.0).abs() < 1e-6, "{added}");
        // A tail IMU as well: twice that.
        let two = Some(Imus {
            rate_hz: 100,
            count: 2,
        });
        let both = budget_of(Traffic::Anguilla(nodes, two), 100.0, CLASSIC_1M).unwrap();
        assert!(((both.load - without.load) * 1e6 - 106_300.0).abs() < 1e-6);
        // CAN FD: one 32-byte frame per sample; at 200 Hz.
        let fd = head_sensor_traffic(Variant::Fd, 200);
        assert_eq!((fd[0].name, fd[0].bytes), ("HeadSample", 32));
        assert_eq!(fd[0].cadence, Cadence::PerSecond(200.0));
        // The per-second lines lower the highest control rate.
        let r0 = max_rate_of(Traffic::Anguilla(nodes, None), CLASSIC_1M, 0.6).unwrap();
        let r1 = max_rate_of(
            Traffic::Anguilla(nodes, Some(Imus::one(100))),
            CLASSIC_1M,
            0.6,
        )
        .unwrap();
        assert!(r1 < r0, "{r1} {r0}");
        for hz in [99, 201] {
            assert_eq!(
                budget_of(
                    Traffic::Anguilla(nodes, Some(Imus::one(hz))),
                    100.0,
                    CLASSIC_1M
                ),
                Err(BudgetError::HeadSensorRate(hz))
            );
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(budget(NodeSet::empty(), 100.0, CLASSIC_1M).is_err());
        assert!(budget(NodeSet::first(12), 0.0, CLASSIC_1M).is_err());
        assert!(budget(NodeSet::first(12), f64::NAN, CLASSIC_1M).is_err());
        let absurd = Bitrates {
            nominal: 5_000_000,
            data: None,
        };
        assert_eq!(
            budget(NodeSet::first(12), 100.0, absurd),
            Err(BudgetError::NominalRate(5_000_000))
        );
        let slow_data = Bitrates {
            nominal: 1_000_000,
            data: Some(500_000),
        };
        assert!(budget(NodeSet::first(12), 100.0, slow_data).is_err());
    }
}
