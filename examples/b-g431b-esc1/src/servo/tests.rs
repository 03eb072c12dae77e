//! The decoder's rules, each on a scripted pulse train polled every 1 ms as the firmware
//! polls it: in range, out of range, lost, re-armed at zero only, jitter, slew.

use super::*;

/// Full scale in 0.5 s (a slew the tests can see within a few hundred polls).
const SLEW: f32 = 2.0;
/// The firmware's poll period \[µs].
const POLL_US: u32 = 1000;

fn decoder() -> ServoDecoder {
    ServoDecoder::new(ServoConfig::standard(SLEW))
}

/// A pulse train polled every [`POLL_US`]: at most one capture per poll (every valid period
/// is longer than a poll), delivered at the poll after its rising edge.
struct Train {
    t_us: u64,
    next_edge_us: u64,
}

impl Train {
    fn new() -> Self {
        Self {
            t_us: 0,
            next_edge_us: 0,
        }
    }

    /// Runs `d` for `dur_us` on pulses of `width(k)` µs every `period_us` (k: the pulse's
    /// index); the last output.
    fn run(
        &mut self,
        d: &mut ServoDecoder,
        period_us: u32,
        dur_us: u64,
        mut width: impl FnMut(u64) -> u32,
    ) -> ServoOutput {
        let end = self.t_us + dur_us;
        let mut out = d.output();
        let mut k = 0;
        while self.t_us < end {
            self.t_us += u64::from(POLL_US);
            let c = if self.t_us >= self.next_edge_us {
                self.next_edge_us = self.t_us + u64::from(period_us);
                k += 1;
                Some(Capture {
                    period_us,
                    width_us: width(k),
                })
            } else {
                None
            };
            out = d.update(c, POLL_US);
        }
        out
    }

    /// No pulse for `dur_us`.
    fn silence(&mut self, d: &mut ServoDecoder, dur_us: u64) -> ServoOutput {
        let mut out = d.output();
        for _ in 0..dur_us / u64::from(POLL_US) {
            self.t_us += u64::from(POLL_US);
            out = d.update(None, POLL_US);
        }
        self.next_edge_us = self.t_us;
        out
    }
}

/// Armed by 1 s of zero throttle at 50 Hz (50 pulses).
fn armed() -> (ServoDecoder, Train) {
    let mut d = decoder();
    let mut tr = Train::new();
    let out = tr.run(&mut d, 20_000, 1_000_000, |_| 1000);
    assert!(out.armed && out.present && !out.enable);
    (d, tr)
}

/// The standard settings by their formulas: the frame rates ±10 %, 5 frames at 50 Hz,
/// 5 % of the span.
#[test]
fn standard_settings() {
    let c = ServoConfig::standard(SLEW);
    assert_eq!(c.period_min_us, 1855); // 1e6 / 490 / 1.1
    assert_eq!(c.period_max_us, 22_000); // 1e6 / 50 · 1.1
    assert_eq!(c.timeout_us, 100_000);
    assert_eq!(c.zero_band_us, 50);
    assert!(c.zero_band_us >= 25);
}

/// The mapping: zero up to 1050 µs, continuous from there (no step), 1 at 2000 µs and
/// above, monotonic.
#[test]
fn mapping() {
    let c = ServoConfig::standard(SLEW);
    assert_eq!(c.throttle_of(800), 0.0);
    assert_eq!(c.throttle_of(1000), 0.0);
    assert_eq!(c.throttle_of(1050), 0.0);
    assert!(c.throttle_of(1051) > 0.0 && c.throttle_of(1051) < 0.002);
    assert!((c.throttle_of(1525) - 0.5).abs() < 1e-6);
    assert_eq!(c.throttle_of(2000), 1.0);
    assert_eq!(c.throttle_of(2200), 1.0);
    let mut last = 0.0;
    for w in 800..=2200 {
        let th = c.throttle_of(w);
        assert!(th >= last);
        last = th;
    }
}

/// In range, at 50 Hz and at 490 Hz: armed at zero, a 1525 µs pulse commands half
/// throttle, reached through the slew, and enables the drive.
#[test]
fn in_range() {
    for period_us in [20_000, 2040] {
        let mut d = decoder();
        let mut tr = Train::new();
        let out = tr.run(&mut d, period_us, 1_000_000, |_| 1000);
        assert!(out.armed, "armed at {period_us} µs");
        let out = tr.run(&mut d, period_us, 400_000, |_| 1525);
        assert!((out.throttle - 0.5).abs() < 1e-6, "{out:?}");
        assert!(out.enable && out.present);
        assert!((out.speed_rpm(560.0, 400.0) - 280.0).abs() < 1e-3);
        assert_eq!((d.rejected_width, d.rejected_period, d.losses), (0, 0, 0));
    }
}

/// The slew: from zero to full throttle the command rises by `slew_per_s` per second (one
/// poll's step each poll), and comes down the same way.
#[test]
fn slew_limited() {
    let (mut d, mut tr) = armed();
    let out = tr.run(&mut d, 20_000, 100_000, |_| 2000);
    // 100 polls of 1 ms at 2 /s.
    assert!((out.throttle - 0.2).abs() < 1e-4, "{out:?}");
    let out = tr.run(&mut d, 20_000, 500_000, |_| 2000);
    assert_eq!(out.throttle, 1.0);
    let out = tr.run(&mut d, 20_000, 250_000, |_| 1000);
    assert!((out.throttle - 0.5).abs() < 1e-4, "{out:?}");
    assert!(out.enable);
    let out = tr.run(&mut d, 20_000, 300_000, |_| 1000);
    assert_eq!(out.throttle, 0.0);
    assert!(out.armed && !out.enable);
}

/// A slew set while armed (a new motor over the link) takes over at the next poll, the
/// throttle reached so far kept: 100 polls at 2 /s, then 100 at 1 /s.
#[test]
fn slew_changed() {
    let (mut d, mut tr) = armed();
    tr.run(&mut d, 20_000, 100_000, |_| 2000);
    d.set_slew_per_s(SLEW / 2.0);
    assert_eq!(d.config().slew_per_s, SLEW / 2.0);
    let out = tr.run(&mut d, 20_000, 100_000, |_| 2000);
    assert!((out.throttle - 0.3).abs() < 1e-4, "{out:?}");
    assert!(out.armed && out.enable);
}

/// Out of range: widths of 700 and 2300 µs and periods of 1 ms (1 kHz) and 30 ms are
/// rejected and counted, and change nothing: the command holds while valid pulses resume
/// within the timeout.
#[test]
fn out_of_range() {
    let (mut d, mut tr) = armed();
    let held = tr.run(&mut d, 20_000, 600_000, |_| 1525).throttle;
    assert!((held - 0.5).abs() < 1e-6);
    let out = tr.run(
        &mut d,
        20_000,
        60_000,
        |k| if k % 2 == 0 { 700 } else { 2300 },
    );
    assert_eq!(out.throttle, held);
    assert!(out.armed && out.enable);
    assert_eq!(d.rejected_width, 3);
    // A 1 kHz frame: shorter than 1855 µs.
    let c = Capture {
        period_us: 1000,
        width_us: 900,
    };
    assert_eq!(d.check(c), Err(Reject::Period));
    let out = d.update(Some(c), POLL_US);
    let c = Capture {
        period_us: 30_000,
        width_us: 1500,
    };
    assert_eq!(d.check(c), Err(Reject::Period));
    d.update(Some(c), POLL_US);
    // A period not longer than its pulse.
    let c = Capture {
        period_us: 1900,
        width_us: 1900,
    };
    assert_eq!(d.check(c), Err(Reject::Period));
    assert_eq!(d.rejected_period, 2);
    assert_eq!(out.throttle, held);
    assert_eq!(d.losses, 0);
}

/// Only rejected pulses for longer than the timeout are a loss: they do not feed the
/// loss timer.
#[test]
fn rejected_pulses_are_no_signal() {
    let (mut d, mut tr) = armed();
    tr.run(&mut d, 20_000, 600_000, |_| 1525);
    // The last valid pulse came at most one frame (20 ms) before.
    let out = tr.run(&mut d, 20_000, 70_000, |_| 2300);
    assert!(out.armed, "within the timeout");
    let out = tr.run(&mut d, 20_000, 40_000, |_| 2300);
    assert!(!out.armed && !out.enable && !out.present);
    assert_eq!(out.throttle, 0.0);
    assert_eq!(d.losses, 1);
}

/// Lost: no pulse for 100 ms holds the command (a frame is 20 ms); past it the throttle
/// drops to zero at once (no slew), the decoder disarms, the drive is disabled, the loss
/// counted once.
#[test]
fn lost() {
    let (mut d, mut tr) = armed();
    let before = tr.run(&mut d, 20_000, 600_000, |_| 2000);
    assert_eq!(before.throttle, 1.0);
    // The last pulse came at most one frame ago: silence up to the timeout holds.
    let out = tr.silence(&mut d, 80_000);
    assert!(out.armed && out.enable && out.throttle == 1.0);
    let out = tr.silence(&mut d, 40_000);
    assert_eq!(out.throttle, 0.0);
    assert!(!out.armed && !out.enable && !out.present);
    assert_eq!(out.enable_change(&before), Some(false));
    let out = tr.silence(&mut d, 1_000_000);
    assert!(!out.armed);
    assert_eq!(d.losses, 1);
}

/// Re-armed at zero only: a signal returning at full throttle after a loss, or present at
/// power-up above zero, never enables; 49 zero pulses do not arm, the 50th does; a pulse
/// above zero or out of range between them restarts the count.
#[test]
fn rearm_at_zero_only() {
    let (mut d, mut tr) = armed();
    tr.run(&mut d, 20_000, 600_000, |_| 2000);
    tr.silence(&mut d, 200_000);
    let out = tr.run(&mut d, 20_000, 2_000_000, |_| 2000);
    assert!(out.present && !out.armed && !out.enable);
    assert_eq!(out.throttle, 0.0);
    assert_eq!(
        out.speed_rpm(560.0, 400.0),
        400.0,
        "the button's command stands"
    );

    let mut d = decoder();
    let mut tr = Train::new();
    let out = tr.run(&mut d, 20_000, 49 * 20_000, |_| 1000);
    assert!(!out.armed, "49 pulses");
    let out = tr.run(&mut d, 20_000, 20_000, |_| 1000);
    assert!(out.armed, "the 50th");

    let mut d = decoder();
    let mut tr = Train::new();
    let out = tr.run(
        &mut d,
        20_000,
        1_000_000,
        |k| if k == 30 { 1200 } else { 1000 },
    );
    assert!(!out.armed, "a pulse above zero restarts the count");
    let out = tr.run(
        &mut d,
        20_000,
        1_000_000,
        |k| if k == 30 { 2300 } else { 1000 },
    );
    assert!(!out.armed, "an out-of-range pulse restarts the count");
    let out = tr.run(&mut d, 20_000, 1_000_000, |_| 1000);
    assert!(out.armed);
}

/// Jitter: ±4 µs on the width (a deterministic pattern, as a receiver's and the capture's
/// quantisation) keeps zero throttle exactly zero (the decoder arms), and around half
/// throttle moves the command by at most its width's share, 4/950 of full scale.
#[test]
fn jitter() {
    // A fixed pseudo-random walk in -4..=4 (LCG, seeded).
    let mut s = 12345u32;
    let mut jit = move || {
        s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
        (s >> 16) % 9
    };
    let mut d = decoder();
    let mut tr = Train::new();
    let out = tr.run(&mut d, 20_000, 1_000_000, |_| 1040 + jit() - 4);
    assert!(out.armed && out.throttle == 0.0 && !out.enable);
    tr.run(&mut d, 20_000, 600_000, |_| 1525);
    let c = *d.config();
    let (lo, hi) = (c.throttle_of(1521), c.throttle_of(1529));
    for _ in 0..200 {
        let out = tr.run(&mut d, 20_000, 20_000, |_| 1525 + jit() - 4);
        assert!(
            out.throttle >= lo - 1e-6 && out.throttle <= hi + 1e-6,
            "{out:?}"
        );
        assert!(out.enable);
    }
    assert!(hi - lo <= 8.0 / 950.0 + 1e-6);
}

/// The enable edges the firmware writes: none while nothing changes (the button's enable
/// stands), `true` when armed above zero, `false` at the arming (at zero) and at a loss.
#[test]
fn enable_edges() {
    let idle = ServoOutput::default();
    assert_eq!(idle.enable_change(&idle), None);
    let armed_zero = ServoOutput {
        armed: true,
        present: true,
        ..idle
    };
    assert_eq!(armed_zero.enable_change(&idle), Some(false));
    let running = ServoOutput {
        enable: true,
        throttle: 0.3,
        ..armed_zero
    };
    assert_eq!(running.enable_change(&armed_zero), Some(true));
    assert_eq!(running.enable_change(&running), None);
    assert_eq!(idle.enable_change(&running), Some(false));
}
