//! `pmsm-sim cycles`: the core's cycle counts on the emulated Cortex-M4F and the firmware's
//! size, as a table or JSON.

use pmsm_host_sim::table;
use std::fmt::Write as _;

#[derive(clap::Args)]
pub struct CyclesArgs {
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// The emulated core: `m4f` (the board's, the default) or `m0` (Cortex-M0, no FPU: the
    /// Cortex-M0+ timing table, the CPU share of a 64 MHz part at 4 kHz; issue #30).
    #[arg(long, default_value = "m4f", value_parser = ["m4f", "m0"])]
    core: String,
}

/// The measured calls, in the table's order, with their labels: the drive's cases, then the
/// identification's and the blocks'.
fn rows(r: &pmsm_host_sim::analysis::cycles::CyclesReport) -> Vec<(&'static str, u64)> {
    let mut rows = r.drive.rows().to_vec();
    rows.extend([
        (
            "step, start by injection (salient motor)",
            r.step_inject_cycles_est,
        ),
        ("1 kHz task, start by injection", r.tick_inject_cycles_est),
        (
            "step, offset calibration (PWM off)",
            r.step_calibrate_cycles_est,
        ),
        (
            "step, identification: resistance",
            r.step_identify_resistance_cycles_est,
        ),
        (
            "step, identification: inductance",
            r.step_identify_inductance_cycles_est,
        ),
        (
            "step, identification: flux (I/f spin)",
            r.step_identify_flux_cycles_est,
        ),
        (
            "step, identification: J and B (torque steps)",
            r.step_identify_mechanics_cycles_est,
        ),
        (
            "1 kHz task, calibration and identification",
            r.tick_identify_cycles_est,
        ),
        (
            "after the 1 kHz task: the model's check, the speed loop's checks' ends",
            r.background_cycles_est,
        ),
        ("sliding torque observer update", r.sliding_cycles_est),
        ("flux observer + PLL update", r.flux_cycles_est),
        ("FOC current loop + SVPWM", r.foc_svpwm_cycles_est),
    ]);
    rows
}

/// `cycles`: the table (or JSON).
pub fn cycles(args: CyclesArgs) -> anyhow::Result<String> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or_else(|| anyhow::anyhow!("no workspace root"))?;
    if args.core == "m0" {
        return cycles_m0(root, args.json);
    }
    let r = pmsm_host_sim::analysis::cycles::measure(root)?;
    let mut out = String::new();
    if args.json {
        outln!(out, "{}", serde_json::to_string(&r)?);
        return Ok(out);
    }
    outln!(
        out,
        "Cortex-M4F (QEMU mps2-an386, one trace line per instruction), cycles at zero wait states:"
    );
    let mut t = table(&["measured call", "cycles est"], &[1]);
    for (what, c) in rows(&r) {
        t.add_row([what.to_string(), c.to_string()]);
    }
    outln!(out, "{t}");
    outln!(
        out,
        "sliding-primary step: {} instructions",
        r.step_instructions
    );
    outln!(
        out,
        "board firmware: flash {} bytes, static RAM {} bytes, control path in CCM SRAM {} bytes",
        r.flash_bytes,
        r.ram_bytes,
        r.ramfunc_bytes
    );
    outln!(
        out,
        "f64 soft-float routines linked: {:?}",
        r.f64_soft_float_symbols
    );
    outln!(
        out,
        "At each control rate the board offers (the bench on the Sinano motor, update delay one PWM period, 50 µs):"
    );
    let mut t = table(
        &[
            "rate (Hz)",
            "worst step",
            "worst 1 kHz task",
            "CPU share of 170 MHz",
        ],
        &[0, 1, 2, 3],
    );
    for x in &r.rates {
        t.add_row([
            x.rate_hz.to_string(),
            x.step_max_cycles_est.to_string(),
            x.tick_max_cycles_est.to_string(),
            format!("{:.1} %", x.cpu_share_pct),
        ]);
    }
    outln!(out, "{t}");
    if let Some(top) = r.rates.iter().max_by_key(|x| x.rate_hz) {
        outln!(
            out,
            "CPU share at the highest rate, {} Hz: {:.1} % (budget 15 %)",
            top.rate_hz,
            top.cpu_share_pct
        );
    }
    Ok(out)
}

/// `cycles --core m0`: the bench on the emulated Cortex-M0 (table or JSON).
fn cycles_m0(root: &std::path::Path, json: bool) -> anyhow::Result<String> {
    let r = pmsm_host_sim::analysis::cycles_m0::measure_m0(root)?;
    let mut out = String::new();
    if json {
        outln!(out, "{}", serde_json::to_string(&r)?);
        return Ok(out);
    }
    outln!(
        out,
        "Cortex-M0 (QEMU microbit, thumbv6m: the f32 core in software floating point), Cortex-M0+ cycles:"
    );
    let mut t = table(&["measured call", "cycles est"], &[1]);
    for (what, c) in r.drive.rows().into_iter().chain([
        (
            "fixed point: sin/cos, Clarke, Park, inverse Park",
            r.fixed_frames_cycles_est,
        ),
        (
            "fixed point: flux observer eq (9) + unit vector",
            r.fixed_flux_cycles_est,
        ),
        ("fixed point: current loop", r.fixed_current_cycles_est),
        (
            "fixed point: PLL (Sec V iii) + speed in per unit",
            r.fixed_pll_cycles_est,
        ),
        (
            "fixed point: SVPWM (worst: cut beyond the hexagon)",
            r.fixed_svpwm_cycles_est,
        ),
        (
            "fixed point: sliding torque observer (20)-(22), (34), (35)",
            r.fixed_sliding_cycles_est,
        ),
        (
            "fixed point: the step (sensorless, both observers, PLL in the task)",
            r.fixed_step_cycles_est,
        ),
        (
            "fixed point: the step with the PLL in it",
            r.fixed_step_pll_cycles_est,
        ),
        (
            "fixed point: the step with the PLL in it, voltage at its limit",
            r.fixed_step_limited_cycles_est,
        ),
        ("fixed point: the 1 kHz task", r.fixed_tick_cycles_est),
    ]) {
        t.add_row([what.to_string(), c.to_string()]);
    }
    outln!(out, "{t}");
    outln!(
        out,
        "CPU share of a 64 MHz part at 4 kHz: the fixed-point step and task {:.1} % (issue #30's budget: 30 %); the f32 core in software floating point {:.1} %",
        r.fixed_cpu_share_pct,
        r.cpu_share_pct
    );
    outln!(
        out,
        "the emulated M0 drive image (cargo emu-m0): flash {} bytes, static RAM {} bytes",
        r.image_flash_bytes,
        r.image_ram_bytes
    );
    Ok(out)
}
