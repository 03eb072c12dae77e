#!/usr/bin/env python3
"""The no-panic proof proves something: a panic planted in each branch of the drive's step
fails its link.

For every place below, a copy of the repository gets `if core::hint::black_box(false) {
panic!() }` as the first statement of that function (a panic the optimiser cannot remove
unless the function itself is unreachable from the proof binary), and `no-panic` is built;
the link must fail on the undefined symbol its panic handler calls. A place whose plant still
links is a branch the proof does not cover (as the flux-primary angle selection was before
every observer pairing was built): the script exits 1 naming it.

Usage: python3 examples/qemu-m4f/scripts/planted_panics.py   (from the repository root)
"""
import os
import shutil
import subprocess
import sys
import tempfile

# (file, the function's signature up to its opening brace, which occurrence, what it is)
PLACES = [
    ("src/observer/sliding.rs", "fn update(&self, st: &mut SlidingState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {", 2, "SlidingObserver as an Observer: update"),
    ("src/observer/sliding.rs", "fn sin_cos_output(&self, st: &SlidingState, frame: SinCos, lead: SinCos) -> SinCos {", 1, "SlidingObserver: the controller's angle (sliding primary)"),
    ("src/observer/sliding.rs", "fn residual(&self, st: &SlidingState) -> f32 {", 1, "SlidingObserver: residual"),
    ("src/observer/mod.rs", "fn sin_cos_output(&self, _st: &Self::State, frame: SinCos, lead: SinCos) -> SinCos {", 1, "Observer default: the controller's angle (flux primary)"),
    ("src/observer/flux_speed.rs", "fn update(&self, st: &mut FluxPllState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {", 1, "FluxPll: update"),
    ("src/observer/flux_speed.rs", "fn read_out(&self, st: &mut FluxPllState, part: ReadOut) {", 1, "FluxPll: angle and PLL read-outs"),
    ("src/observer/flux_speed.rs", "fn residual(&self, st: &FluxPllState) -> f32 {", 1, "FluxPll: residual"),
    ("src/observer/flux_speed.rs", "fn update(&self, st: &mut FluxIiState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {", 1, "FluxIi: update"),
    ("src/observer/flux_speed.rs", "fn read_out(&self, st: &mut FluxIiState, part: ReadOut) {", 1, "FluxIi: I&I speed and load read-outs"),
    ("src/drive/align.rs", "pub(super) fn step(&self, a: &mut Align, i_ab: AlphaBeta, v_ab: AlphaBeta) -> (Request, bool) {", 1, "mode Align (and the sums of its R measurement)"),
    ("src/drive/align.rs", "pub(super) fn resistance(&self, a: &Align) -> Measured {", 1, "Align: the measured resistance"),
    ("src/drive/adaptation.rs", "pub(super) fn observer_input(", 1, "adaptation: the observers' inputs through the model"),
    ("src/drive/adaptation.rs", "pub(super) fn take_resistance(", 1, "adaptation: R taken"),
    ("src/drive/adaptation.rs", "fn track(", 1, "adaptation: psi_f or R tracked (after the 1 kHz task)"),
    ("src/pi.rs", "pub fn update_within(", 1, "PI within moving limits (the speed loop's anti-windup)"),
    ("src/drive/catch.rs", "pub(super) fn step(&self, c: &mut Catch, v_ab: AlphaBeta) -> Seen {", 1, "mode Catch (the back-EMF)"),
    ("src/drive/observers.rs", "pub(super) fn seed_caught(", 1, "mode Catch: the seed"),
    ("src/drive/catch.rs", "pub(super) fn tick(", 1, "mode Catch (1 kHz task)"),
    ("src/drive/catch_zero.rs", "pub(super) fn watch(&self, w: &mut Watch, i_ab: AlphaBeta, v_ab: AlphaBeta) -> AlphaBeta {", 1, "the back-EMF's watch (mode Catch without terminal sensing, mode Align)"),
    ("src/drive/catch_zero.rs", "pub(super) fn probe(", 1, "mode Catch without terminal sensing (the deadbeat zero-current loop)"),
    ("src/drive/mod.rs", "fn caught_probe(", 1, "mode Catch without terminal sensing: the seed, or closed loop at once"),
    ("src/drive/catch_zero.rs", "pub(super) fn tick(", 1, "mode Catch without terminal sensing (1 kHz task)"),
    ("src/drive/open_loop.rs", "pub(super) fn step(&self, ol: &mut OpenLoop) -> Request {", 1, "mode OpenLoop"),
    ("src/drive/open_loop.rs", "pub(super) fn tick(", 1, "mode OpenLoop (1 kHz task)"),
    ("src/drive/open_loop.rs", "fn handover(&self, ol: &OpenLoop, d: Driving) -> Entry {", 1, "OpenLoop: the hand-over"),
    ("src/drive/open_loop.rs", "pub(super) fn at(&self, foc: &Foc, frame: SinCos, omega_m: f32, i_q_a: f32) -> OpenLoop {", 1, "OpenLoop: entered at the hand-back"),
    ("src/drive/sensorless.rs", "pub(super) fn enter(&self, foc: &Foc, e: Entry) -> Sensorless {", 1, "Sensorless: entered"),
    ("src/drive/sensorless.rs", "pub(super) fn step(", 1, "mode Sensorless"),
    ("src/drive/sensorless.rs", "pub(super) fn tick(", 1, "mode Sensorless (1 kHz task)"),
    ("src/drive/supervision.rs", "pub(super) fn check(", 1, "supervision: health check"),
    ("src/drive/sensorless.rs", "pub(super) fn stalled(", 1, "Sensorless: stall"),
    ("src/drive/protection.rs", "pub(super) fn check_input(", 1, "protection: input checks"),
    ("src/drive/mod.rs", "fn observe(&self, st: &mut StateOf<P, M>, i_ab: AlphaBeta, v: AlphaBeta) -> bool {", 1, "Drive::observe"),
    ("src/drive/mod.rs", "fn control(", 1, "Drive::control"),
    ("src/drive/mod.rs", "pub fn tick(", 1, "Drive::tick, the 1 kHz task"),
    ("src/drive/state.rs", "pub(super) fn task_stalled(&mut self, schedule: &Schedule) -> bool {", 1, "the task-stall count (steps since the 1 kHz task)"),
    ("src/drive/plausibility.rs", "pub(super) fn implausible(&self, count: &mut u8, i_abc: Abc) -> bool {", 1, "the current sensors' phase-sum check"),
    ("src/drive/observers.rs", "pub(super) fn supervise(", 1, "Drive::supervise"),
    ("src/load_observer.rs", "pub fn update(", 1, "the speed loop's load-torque observer"),
    ("src/foc/mod.rs", "pub fn run(", 1, "Foc::run, the one FOC call site"),
    ("src/foc/mod.rs", "pub fn speed_step_scaled(", 1, "Foc::speed_step_scaled, the speed loop"),
    ("src/drive/speed_gain.rs", "pub(super) fn check(", 1, "the speed loop's oscillation check"),
    ("src/drive/mod.rs", "pub fn background(", 1, "Drive::background, after the 1 kHz task"),
    ("src/drive/speed_gain.rs", "fn block_end(&self, s: &mut State) {", 1, "the speed loop's inertia measurement (a block's end)"),
    ("src/drive/speed_gain.rs", "fn interval_end(&self, s: &mut State) {", 1, "the speed loop's oscillation check (an interval's end)"),
    ("src/drive/identify/mod.rs", "pub(super) fn commissioning(", 1, "modes Idle (offsets' watch), Calibrate, Identify: the step"),
    ("src/drive/identify/mod.rs", "pub(super) fn calibrate(", 1, "mode Calibrate (offsets)"),
    ("src/drive/identify/mod.rs", "pub(super) fn identify_control(", 1, "mode Identify: the step"),
    ("src/drive/identify/mod.rs", "pub(super) fn identify_tick(", 1, "mode Identify (1 kHz task)"),
    ("src/drive/identify/resistance.rs", "pub(in crate::drive) fn step(", 1, "identification: resistance"),
    ("src/drive/identify/resistance.rs", "pub(in crate::drive) fn tick(", 1, "identification: resistance (1 kHz task)"),
    ("src/drive/identify/inductance.rs", "pub(in crate::drive) fn step(", 1, "identification: inductance"),
    ("src/drive/identify/inductance.rs", "pub(in crate::drive) fn tick(", 1, "identification: inductance (1 kHz task)"),
    ("src/drive/identify/flux.rs", "pub(in crate::drive) fn step(", 1, "identification: flux spin"),
    ("src/drive/identify/flux.rs", "pub(in crate::drive) fn tick(", 1, "identification: flux spin (1 kHz task)"),
    ("src/drive/identify/mechanics.rs", "pub(in crate::drive) fn step(", 1, "identification: torque steps"),
    ("src/drive/identify/mechanics.rs", "pub(in crate::drive) fn tick(", 1, "identification: torque steps (1 kHz task)"),
]
PLANT = '        if core::hint::black_box(false) { panic!("planted") }\n'
UNDEFINED = "the_drive_step_can_panic"


def build(root, target_dir):
    return subprocess.run(
        ["cargo", "build", "--release", "--manifest-path", "examples/qemu-m4f/Cargo.toml",
         "--bin", "no-panic", "--target", "thumbv7em-none-eabihf"],
        cwd=root, capture_output=True, text=True,
        env=dict(os.environ, CARGO_TARGET_DIR=target_dir))


def main():
    files = subprocess.run(["git", "ls-files"], capture_output=True, text=True, check=True).stdout.split()
    with tempfile.TemporaryDirectory() as tmp:
        root = os.path.join(tmp, "repo")
        for f in files:
            if os.path.isfile(f):
                os.makedirs(os.path.join(root, os.path.dirname(f)), exist_ok=True)
                shutil.copy2(f, os.path.join(root, f))
        target = os.path.join(tmp, "target")
        r = build(root, target)
        if r.returncode != 0:
            sys.exit("no-panic does not link unplanted:\n" + r.stderr[-3000:])
        missed = []
        for path, signature, which, what in PLACES:
            full = os.path.join(root, path)
            original = open(full).read()
            at = -1
            for _ in range(which):
                at = original.find(signature, at + 1)
                if at < 0:
                    sys.exit(f"{path}: signature not found (update this script): {signature}")
            brace = original.index("{\n", at) + 2
            open(full, "w").write(original[:brace] + PLANT + original[brace:])
            r = build(root, target)
            open(full, "w").write(original)
            if r.returncode != 0 and UNDEFINED in r.stderr:
                print(f"link fails, panic found: {what} ({path})", flush=True)
            elif r.returncode != 0:
                sys.exit(f"{what}: the build failed for another reason:\n{r.stderr[-3000:]}")
            else:
                print(f"LINKS, panic NOT found: {what} ({path})", flush=True)
                missed.append(what)
        if missed:
            sys.exit(f"the no-panic proof misses {len(missed)} of {len(PLACES)} places: {missed}")
        print(f"every one of {len(PLACES)} planted panics fails the link")


if __name__ == "__main__":
    main()
