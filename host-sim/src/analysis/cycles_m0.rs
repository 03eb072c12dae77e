//! `pmsm-sim cycles --core m0`: the same bench on an emulated Cortex-M0 (QEMU `microbit`,
//! thumbv6m: no FPU, so the f32 core runs in software floating point), weighted with the
//! Cortex-M0+ timing table, and the CPU share of a 64 MHz part at 4 kHz. Issue #30's budget
//! is for the fixed-point step (step ≤ 3000 cycles, 1 kHz task ≤ 6000, ≤ 30 % of 64 MHz at
//! 4 kHz): the fixed-point step and task (`pmsm_sensorless::fixed::step`) are measured here,
//! beside the f32 core in software floating point, the baseline they replace.
//!
//! Cortex-M0+ timing (ARM DDI 0484C, Cortex-M0+ Technical Reference Manual, sec 3.3, with the
//! single-cycle multiplier): ALU and MULS 1; LDR/STR (all widths) 2; LDM, STM, PUSH 1 + n; POP
//! 1 + n, 3 + n when it loads PC; B, BX, BLX taken 2 (a conditional branch not taken 1); BL 3;
//! DMB, DSB, ISB 3. The M0 that QEMU emulates executes the same Thumb instructions; the table
//! is the M0+'s (its 2-stage pipeline), the part the issue names. No wait states.

use super::cycles::{
    bench_sections, build_thumb, is_branch, llvm_tool, register_count, sizes, Core, DriveCases,
    Insn,
};
use anyhow::Context;
use serde::Serialize;
use std::path::Path;

/// The Cortex-M0 (QEMU microbit, an nRF51822), the Cortex-M0+ timing table.
const M0: Core = Core {
    target: "thumbv6m-none-eabi",
    manifest: "examples/qemu-m0/Cargo.toml",
    machine: "microbit",
    cpu: "cortex-m0",
    cycles,
};

/// The M0 part of issue #30: 64 MHz, the step at 4 kHz.
pub const M0_CLOCK_HZ: f64 = 64.0e6;
/// See [`M0_CLOCK_HZ`].
pub const M0_STEP_RATE_HZ: f64 = 4000.0;

/// Cortex-M0+ cycles of one executed instruction (`taken`: control went elsewhere than the
/// next instruction).
pub(super) fn cycles(insn: &Insn, taken: bool) -> u64 {
    let m = insn.mnemonic.as_str();
    let base = m.split('.').next().unwrap_or(m);
    if base == "bl" {
        return 3;
    }
    if is_branch(m) {
        return if taken { 2 } else { 1 };
    }
    if base == "push" || base.starts_with("stm") {
        return 1 + register_count(&insn.operands);
    }
    if base == "pop" || base.starts_with("ldm") {
        let pc = insn.operands.contains("pc");
        return 1 + register_count(&insn.operands) + if pc { 2 } else { 0 };
    }
    if base.starts_with("ldr") || base.starts_with("str") {
        return 2;
    }
    if matches!(base, "dmb" | "dsb" | "isb") {
        return 3;
    }
    1
}

/// The answer of `pmsm-sim cycles --core m0`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct M0Report {
    /// The drive's step and 1 kHz task cases in the f32 core (software floating point),
    /// Cortex-M0+ cycles.
    #[serde(flatten)]
    pub drive: DriveCases,
    /// The fixed-point blocks (`pmsm_sensorless::fixed`): sin/cos, Clarke, Park and inverse
    /// Park of one step.
    pub fixed_frames_cycles_est: u64,
    /// Ortega's flux observer eq (9) in fixed point, with its unit rotor-flux vector.
    pub fixed_flux_cycles_est: u64,
    /// The current loop in fixed point (PI, decoupling, feed-forward, the radial cut).
    pub fixed_current_cycles_est: u64,
    /// The PLL of Ortega Sec V iii in fixed point (one update and its speed in per unit).
    pub fixed_pll_cycles_est: u64,
    /// SVPWM in fixed point (min–max injection, the FOC's limited form; worst of a vector
    /// inside the circle, one inside the hexagon, one cut).
    pub fixed_svpwm_cycles_est: u64,
    /// Horng & Chin's sliding torque observer in fixed point (one sample).
    pub fixed_sliding_cycles_est: u64,
    /// The fixed-point step (`pmsm_sensorless::fixed::step`, issue #30): the sensorless
    /// running step with both observers, the PLL in the task (the Sinano's drive).
    pub fixed_step_cycles_est: u64,
    /// The fixed-point step with the PLL in it (a motor that turns more than half a turn per
    /// millisecond at 1.5 times its rated speed).
    pub fixed_step_pll_cycles_est: u64,
    /// The fixed-point step with the PLL in it and the voltage at its limit (the bus at its
    /// under-voltage trip: the current loop's radial cut).
    pub fixed_step_limited_cycles_est: u64,
    /// The fixed-point 1 kHz task (PLL, speed loop with its load observer, the monitor's
    /// check).
    pub fixed_tick_cycles_est: u64,
    /// `(worst fixed step × 4 kHz + fixed tick × 1 kHz) / 64 MHz` \[%]: issue #30's budget
    /// (≤ 30 %).
    pub fixed_cpu_share_pct: f64,
    /// The f32 core's `(worst step × 4 kHz + worst tick × 1 kHz) / 64 MHz` \[%] (the baseline).
    pub cpu_share_pct: f64,
    /// The emulated M0 drive image (`cargo emu-m0`): flash and static RAM \[bytes].
    pub image_flash_bytes: u64,
    /// See `image_flash_bytes`.
    pub image_ram_bytes: u64,
}

/// Builds and runs the bench on the emulated Cortex-M0, and sizes the M0 drive image.
pub fn measure_m0(root: &Path) -> anyhow::Result<M0Report> {
    let (found, _) = bench_sections(root, &M0, None)?;
    let worst = |name: &str| -> anyhow::Result<u64> {
        found
            .get(name)
            .filter(|v| !v.is_empty())
            .map(|v| v.iter().map(|&(_, c)| c).max().unwrap_or(0))
            .with_context(|| format!("section {name} not found in the M0 trace"))
    };
    let image = build_thumb(
        root,
        M0.target,
        &root.join(M0.manifest),
        "qemu-m0",
        "building the M0 drive image (thumbv6m)",
        None,
    )?;
    let (image_flash_bytes, image_ram_bytes, _) = sizes(&llvm_tool(root, "llvm-size")?, &image)?;
    let drive = DriveCases::from_sections(worst)?;
    let (step_max, tick_max) = drive.worst();
    let (fixed_step, fixed_step_pll, fixed_step_limited, fixed_tick) = (
        worst("fixed_step")?,
        worst("fixed_step_pll")?,
        worst("fixed_step_limited")?,
        worst("fixed_tick")?,
    );
    let share = |step: u64, tick: u64| {
        100.0 * (step as f64 * M0_STEP_RATE_HZ + tick as f64 * 1000.0) / M0_CLOCK_HZ
    };
    Ok(M0Report {
        drive,
        fixed_frames_cycles_est: worst("fixed_frames")?,
        fixed_flux_cycles_est: worst("fixed_flux")?,
        fixed_current_cycles_est: worst("fixed_current")?,
        fixed_pll_cycles_est: worst("fixed_pll")?,
        fixed_svpwm_cycles_est: worst("fixed_svpwm")?,
        fixed_sliding_cycles_est: worst("fixed_sliding")?,
        fixed_step_cycles_est: fixed_step,
        fixed_step_pll_cycles_est: fixed_step_pll,
        fixed_step_limited_cycles_est: fixed_step_limited,
        fixed_tick_cycles_est: fixed_tick,
        fixed_cpu_share_pct: share(
            fixed_step.max(fixed_step_pll).max(fixed_step_limited),
            fixed_tick,
        ),
        cpu_share_pct: share(step_max, tick_max),
        image_flash_bytes,
        image_ram_bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn insn(m: &str, o: &str) -> Insn {
        Insn {
            mnemonic: m.into(),
            operands: o.into(),
        }
    }

    /// The Cortex-M0+ table (TRM sec 3.3): what differs from the M4's.
    #[test]
    fn m0plus_timing() {
        assert_eq!(cycles(&insn("adds", "r0, r1"), false), 1);
        assert_eq!(cycles(&insn("muls", "r0, r1, r0"), false), 1);
        assert_eq!(cycles(&insn("ldr", "r0, [r1]"), false), 2);
        assert_eq!(cycles(&insn("bl", "0x100"), true), 3);
        assert_eq!(cycles(&insn("bne", "0x100"), true), 2);
        assert_eq!(cycles(&insn("bne", "0x100"), false), 1);
        assert_eq!(cycles(&insn("bx", "lr"), true), 2);
        assert_eq!(cycles(&insn("push", "{r4, r5, r6, r7, lr}"), false), 6);
        assert_eq!(cycles(&insn("pop", "{r4-r7, pc}"), true), 1 + 5 + 2);
    }
}
