//! The speed command as the running modes take it: limited to the rated speed and slewed at
//! the configured acceleration once a millisecond (the open loop's frequency ramp, the
//! sensorless speed reference).

use crate::math::clamp;

/// The command's limit and slew.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Ramp {
    /// The speed command is limited to ± this \[rpm] (the rated speed).
    pub(super) max_rpm: f32,
    /// The slew per slot cycle (the speed loop's period) \[rpm].
    pub(super) step_rpm: f32,
}

impl Ramp {
    /// The user's command `cmd_rpm` within the ratings \[rpm].
    #[inline(always)]
    pub(super) fn command(&self, cmd_rpm: f32) -> f32 {
        clamp(cmd_rpm, -self.max_rpm, self.max_rpm)
    }

    /// `x` \[rpm] moved toward `target` \[rpm] by at most one slot cycle's step.
    #[inline(always)]
    pub(super) fn slew(&self, x: f32, target: f32) -> f32 {
        x + clamp(target - x, -self.step_rpm, self.step_rpm)
    }
}
