//! `pmsm-sim cycles`: deterministic per-call instruction counts of the core on the emulated
//! Cortex-M4F, Cortex-M4 cycle estimates, and the board firmware's flash and static RAM.
//!
//! Method: the bench binary (`examples/qemu-m4f/src/bin/bench.rs`) calls each measured
//! function between two marker functions; each is a function of its own (`Drive::step` inlined
//! into one, as in the board firmware's interrupt), so its register saves are counted. QEMU
//! (`mps2-an386`) runs it one instruction per translation block (`-singlestep` before QEMU
//! 8.1, `-accel tcg,one-insn-per-tb=on` after) with `-d exec,nochain`, which logs one line per executed instruction with its PC
//! and symbol; the instructions between a begin and an end marker are the call's (the
//! marker call's own `bl` included). Each is weighted with the Cortex-M4 timing table
//! (ARM DDI 0439 sec 3.3): ALU, MUL, most VFP 1; loads and stores 2 (LDRD/STRD 3); LDM,
//! STM, PUSH, POP 1 + n (+2 when POP loads PC); taken branches 3, not taken 1; TBB/TBH 6
//! (their minimum); VMLA/VMLS/VFMA family 3; VDIV/VSQRT 14; VLDR/VSTR 2, VPUSH/VPOP/VLDM/
//! VSTM 1 + n; SDIV/UDIV 12 (their worst case). Not modelled, both ways: the pipelining of
//! neighbouring LDR/STR (one cycle less each) and 1-cycle `STR Rx,[Ry,#imm]`, which make the
//! estimate high; flash wait states and bus contention, which make it low (the estimates
//! are for code running at zero wait states, e.g. from RAM/CCM).

use anyhow::{bail, Context};
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

pub use super::rate_cycles::{rate_cycles, RateCycles, BOARD_RATES_HZ};

/// The bench's cases of the drive's step and 1 kHz task, worst over each case's runs, on
/// either core (cycles in its timing table). The names are the JSON keys CI checks.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DriveCases {
    /// Worst sensorless step over an electrical turn, both observers live, sliding observer
    /// primary, 48 V bus. The bench's currents do not follow the voltage, so in the later
    /// steps the current loop cuts its vector to the limit.
    pub step_cycles_est: u64,
    /// Worst step over a turn when the flux observer feeds the controller (`Primary::Flux`).
    pub step_flux_primary_cycles_est: u64,
    /// Worst step over a turn in open loop (start-up; both observers running).
    pub step_open_loop_cycles_est: u64,
    /// Worst step over a turn with the voltage at its limit (sliding observer primary).
    pub step_saturated_cycles_est: u64,
    /// Worst sensorless step (sliding observer primary) of four runs whose angles cross ±π
    /// (the wraps of eq (22), the PLL and the angle comparisons take their other branch).
    pub step_seam_cycles_est: u64,
    /// Worst sensorless step on a salient motor (the Sinano's with `L_q/L_d = 2`: the flux
    /// observer's active flux, the MTPA), either primary.
    pub step_salient_cycles_est: u64,
    /// Worst 1 kHz task (`Drive::tick`: read-outs, speed loop, supervision, mode decisions)
    /// of the sensorless runs with the sliding observer primary (the board's main loop runs it
    /// once a millisecond, outside the step's interrupt).
    pub tick_cycles_est: u64,
    /// Worst 1 kHz task with the flux observer primary.
    pub tick_flux_primary_cycles_est: u64,
    /// Worst 1 kHz task in open loop.
    pub tick_open_loop_cycles_est: u64,
    /// Worst 1 kHz task on that salient motor, either primary.
    pub tick_salient_cycles_est: u64,
}

impl DriveCases {
    /// The cases from the bench's sections (`worst` gives a section's worst cycles).
    pub(super) fn from_sections(
        worst: impl Fn(&str) -> anyhow::Result<u64>,
    ) -> anyhow::Result<Self> {
        Ok(Self {
            step_cycles_est: worst("step")?,
            step_flux_primary_cycles_est: worst("step_flux_primary")?,
            step_open_loop_cycles_est: worst("step_open_loop")?,
            step_saturated_cycles_est: worst("step_saturated")?,
            step_seam_cycles_est: worst("step_seam")?,
            step_salient_cycles_est: worst("step_salient")?,
            tick_cycles_est: worst("tick")?,
            tick_flux_primary_cycles_est: worst("tick_flux_primary")?,
            tick_open_loop_cycles_est: worst("tick_open_loop")?,
            tick_salient_cycles_est: worst("tick_salient")?,
        })
    }

    /// The worst step and the worst task of every case.
    pub fn worst(&self) -> (u64, u64) {
        let steps = [
            self.step_cycles_est,
            self.step_flux_primary_cycles_est,
            self.step_open_loop_cycles_est,
            self.step_saturated_cycles_est,
            self.step_seam_cycles_est,
            self.step_salient_cycles_est,
        ];
        let ticks = [
            self.tick_cycles_est,
            self.tick_flux_primary_cycles_est,
            self.tick_open_loop_cycles_est,
            self.tick_salient_cycles_est,
        ];
        (
            steps.into_iter().max().unwrap_or(0),
            ticks.into_iter().max().unwrap_or(0),
        )
    }

    /// The table's rows: label and cycles, in the order the report prints them.
    pub fn rows(&self) -> [(&'static str, u64); 10] {
        [
            (
                "step, both observers, sliding primary (worst over a turn)",
                self.step_cycles_est,
            ),
            ("  worst of four runs across ±π", self.step_seam_cycles_est),
            (
                "step, flux observer primary",
                self.step_flux_primary_cycles_est,
            ),
            ("step, open loop (start-up)", self.step_open_loop_cycles_est),
            ("step, voltage at its limit", self.step_saturated_cycles_est),
            (
                "step, salient motor (L_q/L_d 2), either primary",
                self.step_salient_cycles_est,
            ),
            (
                "1 kHz task (Drive::tick), sliding primary",
                self.tick_cycles_est,
            ),
            (
                "1 kHz task, flux primary",
                self.tick_flux_primary_cycles_est,
            ),
            ("1 kHz task, open loop", self.tick_open_loop_cycles_est),
            ("1 kHz task, salient motor", self.tick_salient_cycles_est),
        ]
    }
}

/// The answer of `pmsm-sim cycles`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CyclesReport {
    /// Instructions of the drive's costliest sensorless step (both observers live, sliding
    /// observer primary, 48 V bus): the worst over an electrical turn and of the steps at the
    /// ±π seam. The bench's currents do not follow the
    /// voltage, so in the later steps the current loop cuts its vector to the limit.
    pub step_instructions: u64,
    /// The drive's step and 1 kHz task cases.
    #[serde(flatten)]
    pub drive: DriveCases,
    /// Worst step of the start through high-frequency injection on that salient motor (feature
    /// `injection`, flux primary; the bench is built with it, the board images are not).
    pub step_inject_cycles_est: u64,
    /// Worst 1 kHz task of that start.
    pub tick_inject_cycles_est: u64,
    /// Worst step of the offset calibration (PWM off, every enable from idle).
    pub step_calibrate_cycles_est: u64,
    /// Worst step of each identification measurement (no observers run): resistance,
    /// inductance, the flux's spin, the torque steps.
    pub step_identify_resistance_cycles_est: u64,
    /// See `step_identify_resistance_cycles_est`.
    pub step_identify_inductance_cycles_est: u64,
    /// See `step_identify_resistance_cycles_est`.
    pub step_identify_flux_cycles_est: u64,
    /// See `step_identify_resistance_cycles_est`.
    pub step_identify_mechanics_cycles_est: u64,
    /// Worst 1 kHz task of the calibration and the identification's measurements.
    pub tick_identify_cycles_est: u64,
    /// [`Drive::background`](pmsm_sensorless::drive::Drive::background), the 1 kHz task's
    /// slower work after it, at its costliest (`adaptation.rs`: ψ_f measured inside the
    /// dead-time band, after every task that kept an operating point; `speed_gain.rs`: a
    /// block's end with the slow check's interval and a raise, and the fast check's interval
    /// with a halving, once every 16 and 100 tasks at most). It counts with the task in the
    /// CPU share (`rate_cycles`).
    pub background_cycles_est: u64,
    /// Cycle estimate of one sliding torque observer update.
    pub sliding_cycles_est: u64,
    /// Cycle estimate of one flux observer update plus its PLL.
    pub flux_cycles_est: u64,
    /// Cycle estimate of one current-loop step with SVPWM.
    pub foc_svpwm_cycles_est: u64,
    /// Board firmware: flash image (vector table, code, read-only data, the .data and
    /// .ramfunc images) \[bytes].
    pub flash_bytes: u64,
    /// Board firmware: static RAM (.data, .bss, .uninit; the stack is not counted) \[bytes].
    pub ram_bytes: u64,
    /// Board firmware: the control path copied to CCM SRAM (`.ramfunc`, 10 KiB there) \[bytes].
    pub ramfunc_bytes: u64,
    /// f64 soft-float routines linked into the board firmware or the bench (should be none).
    pub f64_soft_float_symbols: Vec<String>,
    /// The bench at each control rate the board offers ([`BOARD_RATES_HZ`]), with the
    /// board's update delay: the worst step and tick and the CPU share.
    pub rates: Vec<RateCycles>,
}

/// The emulated core a bench runs on: its Rust target, the example workspace that builds the
/// bench for it, QEMU's machine and CPU, and its timing table.
pub(super) struct Core {
    pub(super) target: &'static str,
    pub(super) manifest: &'static str,
    pub(super) machine: &'static str,
    pub(super) cpu: &'static str,
    pub(super) cycles: fn(&Insn, bool) -> u64,
}

/// The Cortex-M4F: the board's core (QEMU mps2-an386), the Cortex-M4 timing table.
pub(super) const M4F: Core = Core {
    target: "thumbv7em-none-eabihf",
    manifest: "examples/qemu-m4f/Cargo.toml",
    machine: "mps2-an386",
    cpu: "cortex-m4",
    cycles,
};

/// One instruction of the disassembly.
pub(super) struct Insn {
    pub(super) mnemonic: String,
    pub(super) operands: String,
}

pub(super) fn run(cmd: &mut Command, what: &str) -> anyhow::Result<String> {
    let out = cmd
        .output()
        .with_context(|| format!("{what}: could not start {:?}", cmd.get_program()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        bail!("{what} failed ({}): {last}", out.status);
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// A tool of the `llvm-tools` rustup component (installed by rust-toolchain.toml).
pub(super) fn llvm_tool(root: &Path, name: &str) -> anyhow::Result<PathBuf> {
    let sysroot = run(
        Command::new("rustc")
            .arg("--print")
            .arg("sysroot")
            .current_dir(root),
        "rustc --print sysroot",
    )?;
    let host = run(
        Command::new("rustc")
            .arg("--print")
            .arg("host-tuple")
            .current_dir(root),
        "rustc --print host-tuple",
    )?;
    let path = PathBuf::from(sysroot.trim())
        .join("lib/rustlib")
        .join(host.trim())
        .join("bin")
        .join(name);
    if !path.exists() {
        bail!(
            "{} not found: `rustup component add llvm-tools`",
            path.display()
        );
    }
    Ok(path)
}

fn cargo_build(
    root: &Path,
    target: &str,
    args: &[&str],
    what: &str,
    rate: Option<u32>,
) -> anyhow::Result<()> {
    let mut cmd = Command::new("cargo");
    cmd.args(["build", "--release", "--target", target])
        .args(args)
        .current_dir(root);
    match rate {
        Some(r) => cmd.env(BENCH_RATE_ENV, r.to_string()),
        None => cmd.env_remove(BENCH_RATE_ENV),
    };
    run(&mut cmd, what).map(|_| ())
}

/// The bench's control rate, read when it is built (`option_env!`): unset, the
/// configuration's (4 kHz on the Sinano motor, no update delay).
const BENCH_RATE_ENV: &str = "PMSM_BENCH_RATE_HZ";

/// `cargo metadata` of `manifest`'s workspace (JSON, no dependencies).
fn metadata(root: &Path, manifest: &Path) -> Command {
    let mut cmd = Command::new("cargo");
    cmd.args([
        "metadata",
        "--format-version",
        "1",
        "--no-deps",
        "--manifest-path",
    ])
    .arg(manifest)
    .current_dir(root);
    cmd
}

/// Where cargo puts the builds of `manifest`'s workspace: `cargo metadata`'s
/// `target_directory`, which follows `CARGO_TARGET_DIR` and `build.target-dir`.
fn target_dir(root: &Path, manifest: &Path) -> anyhow::Result<PathBuf> {
    let text = run(&mut metadata(root, manifest), "cargo metadata")?;
    let v: serde_json::Value = serde_json::from_str(&text).context("cargo metadata's JSON")?;
    v["target_directory"]
        .as_str()
        .map(PathBuf::from)
        .context("cargo metadata gave no target_directory")
}

/// Builds binary `bin` of `manifest` for `target` and returns its path.
pub(super) fn build_thumb(
    root: &Path,
    target: &str,
    manifest: &Path,
    bin: &str,
    what: &str,
    rate: Option<u32>,
) -> anyhow::Result<PathBuf> {
    let manifest_arg = manifest.to_string_lossy();
    cargo_build(
        root,
        target,
        &["--manifest-path", &manifest_arg, "--bin", bin],
        what,
        rate,
    )?;
    let elf = target_dir(root, manifest)?
        .join(target)
        .join("release")
        .join(bin);
    if !elf.exists() {
        bail!("{what}: cargo built, but {} is not there", elf.display());
    }
    Ok(elf)
}

/// QEMU's flags for one translation block per instruction, so that `-d exec` logs every
/// instruction: `-singlestep` up to QEMU 8.0, `-accel tcg,one-insn-per-tb=on` from 8.1 (9.0
/// removed `-singlestep`). `version` is what `qemu-system-arm --version` prints.
pub fn one_insn_per_tb_flags(version: &str) -> anyhow::Result<&'static [&'static str]> {
    let numbers = version
        .split_whitespace()
        .skip_while(|w| *w != "version")
        .nth(1)
        .with_context(|| format!("no version in {version:?}"))?;
    let mut parts = numbers
        .split(['.', '(', '+', '-'])
        .map(|p| p.parse::<u32>());
    let (Some(Ok(major)), Some(Ok(minor))) = (parts.next(), parts.next()) else {
        bail!("unreadable QEMU version {numbers:?}");
    };
    Ok(if (major, minor) >= (8, 1) {
        &["-accel", "tcg,one-insn-per-tb=on"]
    } else {
        &["-singlestep"]
    })
}

/// PC → instruction, from `llvm-objdump -d`.
fn disassemble(objdump: &Path, elf: &Path) -> anyhow::Result<HashMap<u32, Insn>> {
    let text = run(
        Command::new(objdump)
            .args(["-d", "--no-show-raw-insn"])
            .arg(elf),
        "llvm-objdump",
    )?;
    let mut map = HashMap::new();
    for line in text.lines() {
        let Some((addr, rest)) = line.split_once(':') else {
            continue;
        };
        let Ok(pc) = u32::from_str_radix(addr.trim(), 16) else {
            continue;
        };
        let mut parts = rest.trim().splitn(2, char::is_whitespace);
        let mnemonic = parts.next().unwrap_or("").to_ascii_lowercase();
        if mnemonic.is_empty() || mnemonic.starts_with('<') {
            continue;
        }
        let operands = parts.next().unwrap_or("").trim().to_ascii_lowercase();
        map.insert(pc, Insn { mnemonic, operands });
    }
    Ok(map)
}

/// Number of registers in a `{r4-r7, lr}` or `{s16-s23}` list.
pub(super) fn register_count(operands: &str) -> u64 {
    let Some(start) = operands.find('{') else {
        return 1;
    };
    let end = operands[start..]
        .find('}')
        .map_or(operands.len(), |e| start + e);
    operands[start + 1..end]
        .split(',')
        .map(|r| {
            let r = r.trim();
            match r.split_once('-') {
                Some((a, b)) => {
                    let num = |s: &str| {
                        s.trim_start_matches(|c: char| c.is_alphabetic())
                            .parse::<u64>()
                            .ok()
                    };
                    match (num(a), num(b)) {
                        (Some(x), Some(y)) if y >= x => y - x + 1,
                        _ => 1,
                    }
                }
                None => 1,
            }
        })
        .sum()
}

const CONDITIONS: [&str; 14] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt",
];

/// Whether a mnemonic (without width suffix) is a branch.
pub(super) fn is_branch(m: &str) -> bool {
    let base = m.split('.').next().unwrap_or(m);
    matches!(
        base,
        "b" | "bl" | "bx" | "blx" | "cbz" | "cbnz" | "tbb" | "tbh"
    ) || (base.len() == 3 && base.starts_with('b') && CONDITIONS.contains(&&base[1..]))
        || matches!(base, "bgt" | "ble" | "bal")
}

/// Cortex-M4 cycles of one executed instruction (`taken`: control went elsewhere than the
/// next instruction).
fn cycles(insn: &Insn, taken: bool) -> u64 {
    let m = insn.mnemonic.as_str();
    let base = m.split('.').next().unwrap_or(m);
    if base == "tbb" || base == "tbh" {
        // A table load, an add and a pipeline reload: "at least six cycles".
        return 6;
    }
    if is_branch(m) {
        return if taken { 3 } else { 1 };
    }
    if let Some(v) = base.strip_prefix('v') {
        return match v {
            _ if ["mla", "mls", "nmla", "nmls", "fma", "fms", "fnma", "fnms"]
                .iter()
                .any(|p| v.starts_with(p)) =>
            {
                3
            }
            _ if v.starts_with("div") || v.starts_with("sqrt") => 14,
            _ if v.starts_with("ldr") || v.starts_with("str") => 2,
            _ if v.starts_with("push")
                || v.starts_with("pop")
                || v.starts_with("ldm")
                || v.starts_with("stm") =>
            {
                1 + register_count(&insn.operands)
            }
            _ => 1,
        };
    }
    if base == "push" || base.starts_with("stm") {
        return 1 + register_count(&insn.operands);
    }
    if base == "pop" || base.starts_with("ldm") {
        let pc = insn.operands.contains("pc");
        return 1 + register_count(&insn.operands) + if pc { 2 } else { 0 };
    }
    if base.starts_with("ldrd") || base.starts_with("strd") {
        return 3;
    }
    if base.starts_with("ldr") || base.starts_with("str") {
        return 2;
    }
    if base.starts_with("sdiv") || base.starts_with("udiv") {
        return 12;
    }
    1
}

/// (PC, symbol) of each traced instruction.
fn read_trace(text: &str) -> Vec<(u32, &str)> {
    text.lines()
        .filter_map(|l| {
            let open = l.find('[')?;
            let close = l[open..].find(']')? + open;
            let pc = l[open + 1..close].split('/').nth(1)?;
            let pc = u32::from_str_radix(pc, 16).ok()?;
            let sym = l[close + 1..].trim();
            Some((pc, sym))
        })
        .collect()
}

/// For each measured section: (instructions, cycles) of every occurrence.
fn sections(
    trace: &[(u32, &str)],
    insns: &HashMap<u32, Insn>,
    cycles: fn(&Insn, bool) -> u64,
) -> anyhow::Result<HashMap<String, Vec<(u64, u64)>>> {
    let mut out: HashMap<String, Vec<(u64, u64)>> = HashMap::new();
    let mut current: Option<(String, u64, u64)> = None;
    for (k, &(pc, sym)) in trace.iter().enumerate() {
        if let Some(name) = sym.strip_prefix("bench_begin_") {
            current = Some((name.to_string(), 0, 0));
            continue;
        }
        if let Some(name) = sym.strip_prefix("bench_end_") {
            if let Some((open, n, c)) = current.take() {
                if open == name {
                    out.entry(open).or_default().push((n, c));
                }
            }
            continue;
        }
        if let Some((_, n, c)) = current.as_mut() {
            let insn = insns
                .get(&pc)
                .with_context(|| format!("no disassembly for traced pc {pc:#x} ({sym})"))?;
            let next = trace.get(k + 1).map(|x| x.0);
            let taken = next.is_some_and(|x| x != pc.wrapping_add(2) && x != pc.wrapping_add(4));
            *n += 1;
            *c += cycles(insn, taken);
        }
    }
    Ok(out)
}

/// Sizes from `llvm-size -A`: (flash, static RAM, code in RAM).
pub(super) fn sizes(size_tool: &Path, elf: &Path) -> anyhow::Result<(u64, u64, u64)> {
    let text = run(Command::new(size_tool).arg("-A").arg(elf), "llvm-size")?;
    let (mut flash, mut ram, mut ramfunc) = (0, 0, 0);
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let [name, size, _addr] = f[..] else { continue };
        let Ok(size) = size.parse::<u64>() else {
            continue;
        };
        match name {
            ".vector_table" | ".text" | ".rodata" => flash += size,
            ".data" => {
                flash += size;
                ram += size;
            }
            ".ramfunc" => {
                flash += size;
                ramfunc += size;
            }
            ".bss" | ".uninit" => ram += size,
            _ => {}
        }
    }
    Ok((flash, ram, ramfunc))
}

/// f64 soft-float routines among an ELF's symbols.
fn soft_float_symbols(nm: &Path, elf: &Path) -> anyhow::Result<Vec<String>> {
    let text = run(Command::new(nm).arg(elf), "llvm-nm")?;
    let bad = [
        "__aeabi_d",
        "__aeabi_f2d",
        "__aeabi_i2d",
        "__aeabi_ui2d",
        "__aeabi_l2d",
        "__adddf3",
        "__subdf3",
        "__muldf3",
        "__divdf3",
        "__extendsfdf2",
        "__truncdfsf2",
    ];
    let mut found: Vec<String> = text
        .lines()
        .filter_map(|l| l.split_whitespace().last())
        .filter(|s| bad.iter().any(|b| s.starts_with(b)))
        .map(str::to_string)
        .collect();
    found.sort();
    found.dedup();
    Ok(found)
}

/// (instructions, cycles) of each measured call, by section name.
pub(super) type Sections = HashMap<String, Vec<(u64, u64)>>;

/// The worst (instructions, cycles) per section of the bench built for `rate` (None: its
/// default), run under QEMU; and the bench's ELF.
pub(super) fn bench_sections(
    root: &Path,
    core: &Core,
    rate: Option<u32>,
) -> anyhow::Result<(Sections, PathBuf)> {
    let bench = build_thumb(
        root,
        core.target,
        &root.join(core.manifest),
        "bench",
        &format!("building the bench ({})", core.target),
        rate,
    )?;
    let version = run(
        Command::new("qemu-system-arm").arg("--version"),
        "qemu-system-arm --version (apt-get install qemu-system-arm)",
    )?;
    let dir = std::env::temp_dir().join(format!("pmsm-cycles-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let trace_path = dir.join("trace.log");
    run(
        Command::new("qemu-system-arm")
            .args(["-machine", core.machine, "-cpu", core.cpu, "-nographic"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(one_insn_per_tb_flags(&version)?)
            .args(["-d", "exec,nochain", "-D"])
            .arg(&trace_path)
            .arg("-kernel")
            .arg(&bench),
        &format!("qemu-system-arm running {}", bench.display()),
    )?;
    let trace_text = std::fs::read_to_string(&trace_path)
        .with_context(|| format!("reading {}", trace_path.display()))?;
    let _ = std::fs::remove_dir_all(&dir);
    let insns = disassemble(&llvm_tool(root, "llvm-objdump")?, &bench)?;
    let found = sections(&read_trace(&trace_text), &insns, core.cycles)?;
    Ok((found, bench))
}

/// Builds the bench and the board firmware, runs the bench under QEMU, and measures; then the
/// bench again at each of [`BOARD_RATES_HZ`].
pub fn measure(root: &Path) -> anyhow::Result<CyclesReport> {
    let mut rates = Vec::new();
    for r in BOARD_RATES_HZ {
        let (found, _) = bench_sections(root, &M4F, Some(r))?;
        rates.push(rate_cycles(&found, r));
    }
    let (found, bench) = bench_sections(root, &M4F, None)?;
    let board = build_thumb(
        root,
        M4F.target,
        &root.join("examples/b-g431b-esc1/image/Cargo.toml"),
        "b-g431b-esc1",
        "building the board firmware (thumbv7em)",
        None,
    )?;
    let worst = |name: &str| -> anyhow::Result<(u64, u64)> {
        let v = found
            .get(name)
            .filter(|v| !v.is_empty())
            .with_context(|| format!("section {name} not found in the trace"))?;
        Ok(v.iter().fold((0, 0), |a, &(n, c)| (a.0.max(n), a.1.max(c))))
    };
    // The instructions of the costliest sensorless step, at the seam or not.
    let step_instructions = [worst("step")?, worst("step_seam")?]
        .into_iter()
        .max_by_key(|s| s.1)
        .map_or(0, |s| s.0);
    let drive = DriveCases::from_sections(|name| Ok(worst(name)?.1))?;
    let (flash_bytes, ram_bytes, ramfunc_bytes) = sizes(&llvm_tool(root, "llvm-size")?, &board)?;
    let nm = llvm_tool(root, "llvm-nm")?;
    let mut f64_soft_float_symbols = soft_float_symbols(&nm, &board)?;
    f64_soft_float_symbols.extend(soft_float_symbols(&nm, &bench)?);
    f64_soft_float_symbols.sort();
    f64_soft_float_symbols.dedup();
    Ok(CyclesReport {
        step_instructions,
        drive,
        step_inject_cycles_est: worst("step_inject")?.1,
        tick_inject_cycles_est: worst("tick_inject")?.1,
        step_calibrate_cycles_est: worst("step_calibrate")?.1,
        step_identify_resistance_cycles_est: worst("step_identify_resistance")?.1,
        step_identify_inductance_cycles_est: worst("step_identify_inductance")?.1,
        step_identify_flux_cycles_est: worst("step_identify_flux")?.1,
        step_identify_mechanics_cycles_est: worst("step_identify_mechanics")?.1,
        tick_identify_cycles_est: worst("tick_identify")?.1,
        background_cycles_est: worst("background")?.1,
        sliding_cycles_est: worst("sliding")?.1,
        flux_cycles_est: worst("flux_pll")?.1,
        foc_svpwm_cycles_est: worst("foc_svpwm")?.1,
        flash_bytes,
        ram_bytes,
        ramfunc_bytes,
        f64_soft_float_symbols,
        rates,
    })
}

#[cfg(test)]
#[path = "cycles_tests.rs"]
mod tests;
