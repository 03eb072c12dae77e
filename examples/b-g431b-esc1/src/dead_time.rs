//! TIM1's dead-time generator (RM0440, TIMx_BDTR.DTG\[7:0] and TIMx_CR1.CKD): the dead time
//! as a number of `t_DTS` steps, `t_DTS = 2^CKD / f_CK_INT`, in four ranges of the DTG byte:
//!
//! | DTG\[7:5] | dead time                       | step           | span (steps)  |
//! |-----------|---------------------------------|----------------|---------------|
//! | `0xx`     | `DTG[7:0] × t_DTS`              | `t_DTS`        | 0..127        |
//! | `10x`     | `(64 + DTG[5:0]) × 2·t_DTS`     | `2·t_DTS`      | 128..254      |
//! | `110`     | `(32 + DTG[4:0]) × 8·t_DTS`     | `8·t_DTS`      | 256..504      |
//! | `111`     | `(32 + DTG[4:0]) × 16·t_DTS`    | `16·t_DTS`     | 512..1008     |

/// The dead time of `dtg` in `t_DTS` steps (the table of the module's doc).
pub const fn dtg_steps(dtg: u8) -> u32 {
    let d = dtg as u32;
    if d & 0x80 == 0 {
        d
    } else if d & 0xC0 == 0x80 {
        (64 + (d & 0x3F)) * 2
    } else if d & 0xE0 == 0xC0 {
        (32 + (d & 0x1F)) * 8
    } else {
        (32 + (d & 0x1F)) * 16
    }
}

/// The DTG byte of the shortest dead time of at least `steps` `t_DTS` steps (never less
/// than asked: the rounding is up, in the range's own step); `None` above 1008 steps.
pub const fn dtg_for_steps(steps: u32) -> Option<u8> {
    if steps <= 127 {
        Some(steps as u8)
    } else if steps <= 254 {
        Some(0x80 | (steps.div_ceil(2) - 64) as u8)
    } else if steps <= 504 {
        Some(0xC0 | (steps.div_ceil(8) - 32) as u8)
    } else if steps <= 1008 {
        Some(0xE0 | (steps.div_ceil(16) - 32) as u8)
    } else {
        None
    }
}

/// A dead time as TIM1 makes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeadTime {
    /// TIMx_BDTR.DTG\[7:0].
    pub dtg: u8,
    /// TIMx_CR1.CKD\[1:0]: `t_DTS = 2^CKD` timer clocks (0, 1 or 2).
    pub ckd: u8,
    /// The dead time in timer-clock (`f_CK_INT`) periods.
    pub clocks: u32,
    /// The dead time \[ns] (`clocks / f_CK_INT`).
    pub ns: f32,
}

impl DeadTime {
    /// The dead time `dtg`, `ckd` make at a timer clock of `timer_hz`.
    pub const fn decode(dtg: u8, ckd: u8, timer_hz: u32) -> Self {
        let clocks = dtg_steps(dtg) << ckd;
        Self {
            dtg,
            ckd,
            clocks,
            ns: clocks as f32 * 1e9 / timer_hz as f32,
        }
    }

    /// The shortest dead time of at least `ns` at a timer clock of `timer_hz`, over the three
    /// `t_DTS` (CKD 0, 1, 2; the finest on a tie); `None` beyond 1008 steps of 4 clocks.
    pub const fn at_least(ns: u32, timer_hz: u32) -> Option<Self> {
        // Timer clocks, rounded up (u64: ns × Hz exceeds u32).
        let clocks = (ns as u64 * timer_hz as u64).div_ceil(1_000_000_000) as u32;
        let mut best: Option<Self> = None;
        let mut ckd = 0;
        while ckd <= 2 {
            if let Some(dtg) = dtg_for_steps(clocks.div_ceil(1 << ckd)) {
                let d = Self::decode(dtg, ckd, timer_hz);
                best = match best {
                    Some(b) if b.clocks <= d.clocks => Some(b),
                    _ => Some(d),
                };
            }
            ckd += 1;
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: u32 = 170_000_000;

    /// RM0440's formulas, one value in each range: the first and last code of each.
    #[test]
    fn steps_in_each_range() {
        assert_eq!(dtg_steps(0x00), 0);
        assert_eq!(dtg_steps(0x7F), 127);
        assert_eq!(dtg_steps(0x80), 128);
        assert_eq!(dtg_steps(0xBF), 254);
        assert_eq!(dtg_steps(0xC0), 256);
        assert_eq!(dtg_steps(0xDF), 504);
        assert_eq!(dtg_steps(0xE0), 512);
        assert_eq!(dtg_steps(0xFF), 1008);
    }

    /// Every DTG code and CKD round-trips: its dead time encodes back to the same code.
    #[test]
    fn round_trip() {
        for ckd in 0..=2u8 {
            for dtg in 0..=255u8 {
                assert_eq!(dtg_for_steps(dtg_steps(dtg)), Some(dtg), "dtg {dtg:#x}");
                let d = DeadTime::decode(dtg, ckd, F);
                let ns = d.clocks as u64 * 1_000_000_000 / F as u64;
                // The same time back (maybe by another CKD, as finely or finer).
                let back = DeadTime::at_least(ns as u32, F).expect("encodable");
                assert_eq!(back.clocks, d.clocks, "{dtg:#x}/{ckd}: {back:?} vs {d:?}");
                assert!(back.ckd <= ckd);
            }
        }
    }

    /// Never shorter than asked, and at most one step (of the range used) longer.
    #[test]
    fn rounds_up_within_a_step() {
        for ns in (0..=23_000).step_by(7) {
            let d = DeadTime::at_least(ns, F).expect("within 23.7 us");
            assert!(d.ns >= ns as f32 - 1e-3, "{ns} ns -> {d:?}");
            let step_ns = (16u32 << d.ckd) as f32 * 1e9 / F as f32;
            assert!(d.ns <= ns as f32 + step_ns, "{ns} ns -> {d:?}");
        }
        assert!(DeadTime::at_least(24_000, F).is_none());
    }

    /// The values of this board: 500 ns and 800 ns at 170 MHz.
    #[test]
    fn board_values() {
        let d = DeadTime::at_least(500, F).unwrap();
        assert_eq!((d.dtg, d.ckd, d.clocks), (85, 0, 85));
        assert!((d.ns - 500.0).abs() < 0.01);
        let d = DeadTime::at_least(800, F).unwrap();
        // 136 clocks: range 2, (64 + 4) × 2.
        assert_eq!((d.dtg, d.ckd, d.clocks), (0x84, 0, 136));
        assert!((d.ns - 800.0).abs() < 0.01);
    }
}
