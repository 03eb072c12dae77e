#!/usr/bin/env bash
# Cargo runner for the link firmware (examples/qemu-m4f, bin qemu-link) on the emulated
# Cortex-M4F: QEMU mps2-an386 with UART0 on a host TCP socket (a server: the host tool or
# scripts/link_e2e.py connects to it; QEMU does not wait for it), the defmt log on
# semihosting stdout decoded by defmt-print, and the configuration flash kept in
# qemu-link-flash.bin in the state directory (QEMU's working directory; semihosting file
# operations). Runs until QEMU is killed or the firmware exits.
#   QEMU_LINK_PORT  the TCP port of UART0 (default 5555, on 127.0.0.1)
#   QEMU_LINK_DIR   the state directory (default target/qemu-link), created if absent
# `-display none -monitor none` rather than -nographic: with -nographic and a -serial of its
# own QEMU puts its monitor on stdio, into the defmt stream.
set -euo pipefail
elf="$(realpath "$1")"
port="${QEMU_LINK_PORT:-5555}"
dir="${QEMU_LINK_DIR:-target/qemu-link}"
mkdir -p "$dir"
cd "$dir"
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -display none -monitor none \
    -serial "tcp:127.0.0.1:${port},server=on,wait=off" \
    -semihosting-config enable=on,target=native -kernel "$elf" \
    | defmt-print -e "$elf"
