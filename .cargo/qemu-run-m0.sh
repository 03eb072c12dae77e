#!/usr/bin/env bash
# Cargo runner for the emulated Cortex-M0: QEMU microbit (nRF51822) with semihosting, the defmt
# frames on its stdout decoded by defmt-print. Exits with QEMU's exit code (the firmware's
# verdict).
set -euo pipefail
elf="$1"
qemu-system-arm -machine microbit -cpu cortex-m0 -nographic \
    -semihosting-config enable=on,target=native -kernel "$elf" \
    | defmt-print -e "$elf"
