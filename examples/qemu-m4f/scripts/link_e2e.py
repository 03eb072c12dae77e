#!/usr/bin/env python3
"""The link firmware (bin qemu-link) end to end under QEMU: the UART on a TCP socket, the
configuration flash in a host file, kept across a reset and a restart of QEMU.

Starts .cargo/qemu-link.sh (QEMU mps2-an386, UART0 on 127.0.0.1:<free port>, the flash image
in a fresh temporary directory), talks to the stand-in link (examples/qemu-m4f/src/bin/
qemu-link/placeholder.rs: frames ended by 0x00), and checks:
  - an echo comes back byte for byte; an overlong frame is refused (`!long`);
  - with an erased flash there is no record and the drive refuses to run;
  - a saved record reads back; after QEMU is killed (SIGKILL: a power cut) and restarted it
    reads back unchanged and the drive runs (the plant at 1000 rpm within 2 %);
  - a second record survives a system reset (SYSRESETREQ) and wins over the first;
  - a bit flipped in the newest record's payload in the file: the older record wins;
    flipped in both: no record, the drive refuses to run;
  - a record of another format version (written here with zlib's CRC-32, the store's
    CRC_32_ISO_HDLC): named `format_version`, the drive refuses to run.
Prints "link_e2e: N passed, M failed" and exits 1 on a failure.

Usage: python3 examples/qemu-m4f/scripts/link_e2e.py   (from the repository root; builds
the firmware first unless --no-build)
"""
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import zlib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
ELF = os.path.join(ROOT, "examples/qemu-m4f/target/thumbv7em-none-eabihf/release/qemu-link")
RUNNER = os.path.join(ROOT, ".cargo/qemu-link.sh")
FLASH = "qemu-link-flash.bin"
PAGE, SIZE, HEADER, WRITE = 2048, 4096, 16, 8
MAGIC = b"PMS1"
CONFIG_VERSION = 1
TIMEOUT_S = 20.0

passed, failed = 0, 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
        print(f"ok   {name}")
    else:
        failed += 1
        print(f"FAIL {name} {detail}")


def span(n):
    return (HEADER + n + WRITE - 1) // WRITE * WRITE


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Emu:
    """One run of QEMU with the link firmware; its log in <dir>/log-<n>.txt."""

    runs = 0

    def __init__(self, state_dir, port):
        Emu.runs += 1
        self.log_path = os.path.join(state_dir, f"log-{Emu.runs}.txt")
        env = dict(os.environ, QEMU_LINK_DIR=state_dir, QEMU_LINK_PORT=str(port))
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen([RUNNER, ELF], env=env, stdout=self.log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.time() + TIMEOUT_S
        while True:
            try:
                self.sock = socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT_S)
                break
            except OSError:
                if time.time() > deadline or self.proc.poll() is not None:
                    raise RuntimeError(f"QEMU did not listen on {port}: {self.text()}")
                time.sleep(0.05)
        self.rx = b""

    def request(self, body):
        self.sock.sendall(body + b"\0")
        while b"\0" not in self.rx:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise RuntimeError("the link closed")
            self.rx += chunk
        frame, _, self.rx = self.rx.partition(b"\0")
        return frame

    def text(self):
        self.log.flush()
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def wait_log(self, needle):
        deadline = time.time() + TIMEOUT_S
        while needle not in self.text():
            if time.time() > deadline:
                return False
            time.sleep(0.05)
        return True

    def kill(self):
        """SIGKILL to QEMU and defmt-print: the power cut."""
        try:
            self.sock.close()
        finally:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            self.log.close()
            # QEMU is not the runner's child we waited for: wait until the whole group is
            # gone, so that the next run's connection cannot reach a dying QEMU.
            deadline = time.time() + TIMEOUT_S
            while time.time() < deadline:
                try:
                    os.killpg(self.proc.pid, 0)
                except ProcessLookupError:
                    break
                time.sleep(0.02)


def flip(state_dir, at, bit=0):
    path = os.path.join(state_dir, FLASH)
    with open(path, "r+b") as f:
        f.seek(at)
        b = f.read(1)[0]
        f.seek(at)
        f.write(bytes([b ^ (1 << bit)]))


def record(version, seq, payload):
    head = MAGIC + struct.pack("<HHI", version, len(payload), seq)
    crc = zlib.crc32(head + payload) & 0xFFFFFFFF
    body = head + struct.pack("<I", crc) + payload
    return body + b"\xff" * (span(len(payload)) - len(body))


def main():
    if "--no-build" not in sys.argv:
        subprocess.run(["cargo", "build", "--release", "--manifest-path",
                        "examples/qemu-m4f/Cargo.toml", "--bin", "qemu-link",
                        "--target", "thumbv7em-none-eabihf"], cwd=ROOT, check=True)
    state = tempfile.mkdtemp(prefix="qemu-link-")
    port = free_port()
    first = bytes(range(1, 256)) + b"settings v1"  # no 0x00 in a stand-in frame
    second = b"settings v2: a second record"

    emu = Emu(state, port)
    try:
        echo = bytes(range(1, 256)) * 2
        check("echo of 510 bytes", emu.request(b"E" + echo) == b"E" + echo)
        check("overlong frame refused", emu.request(b"E" + b"x" * 600) == b"!long")
        check("erased flash: no record", emu.request(b"L") == b"N")
        check("erased flash: drive refused",
              emu.wait_log("drive refused") and emu.request(b"T") == b"Toff", emu.text())
        check("save", emu.request(b"S" + first) == b"S1")
        check("read back", emu.request(b"L") == b"L" + first)
    finally:
        emu.kill()

    emu = Emu(state, port)
    try:
        check("after a QEMU restart: the record unchanged", emu.request(b"L") == b"L" + first)
        check("after a QEMU restart: drive running", emu.wait_log("drive running"), emu.text())
        speed = None
        deadline = time.time() + 60.0
        while time.time() < deadline:
            t = emu.request(b"T")
            if t.startswith(b"Trun ") and b"fault" not in t:
                speed = int(t.split()[1])
                if abs(speed - 1000) <= 20:
                    break
            time.sleep(0.5)
        check("the drive reaches 1000 rpm (within 2 %)", speed is not None and abs(speed - 1000) <= 20,
              f"last status {t!r}")
        check("second save", emu.request(b"S" + second) == b"S2")
        emu.sock.sendall(b"R\0")
        check("after a reset: drive running again",
              emu.wait_log("record 2, ") and emu.request(b"L") == b"L" + second, emu.text())
    finally:
        emu.kill()

    # The newest record (the second, after the first in page 0) with a payload bit flipped.
    flip(state, span(len(first)) + HEADER + 3)
    emu = Emu(state, port)
    try:
        check("newest record corrupt: the older wins",
              emu.request(b"L") == b"L" + first and emu.wait_log("1 bad records skipped"),
              emu.text())
    finally:
        emu.kill()

    flip(state, HEADER + 7, 5)
    emu = Emu(state, port)
    try:
        check("every record corrupt: none", emu.request(b"L") == b"N")
        check("every record corrupt: drive refused",
              emu.wait_log("drive refused") and emu.request(b"T") == b"Toff", emu.text())
    finally:
        emu.kill()

    with open(os.path.join(state, FLASH), "wb") as f:
        img = record(CONFIG_VERSION + 1, 7, b"settings of another format")
        f.write(img + b"\xff" * (SIZE - len(img)))
    emu = Emu(state, port)
    try:
        check("another format version: named", emu.request(b"L") == b"!format_version")
        check("another format version: drive refused",
              emu.wait_log("format_version; the drive will not run")
              and emu.request(b"T") == b"Toff", emu.text())
    finally:
        emu.kill()

    if failed == 0:
        shutil.rmtree(state, ignore_errors=True)
    else:
        print(f"logs and flash image kept in {state}")
    print(f"link_e2e: {passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
