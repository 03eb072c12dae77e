#!/usr/bin/env python3
"""The link firmware (bin qemu-link) end to end under QEMU, driven by the host tool
(`pmsm-tool --tcp`) as a user would (issue #28): the link (pmsm-link's server) on UART0 on a TCP
socket, the settings in the emulated flash (a host file), the drive on the simulator's plant
(the Sinano motor of Horng & Chin's Table 1 on a 48 V bus).

Starts .cargo/qemu-link.sh (QEMU mps2-an386, UART0 on 127.0.0.1:<free port>, the flash image in
a fresh temporary directory) and checks:
  1. an erased flash: not configured, the drive refuses to run (`run` refused);
  2. a motor set (`config load-motor`, the Sinano's file) and a setting changed, saved; after
     QEMU is killed (SIGKILL: a power cut) and restarted, `config get` prints the same;
     and a restart over the link (`pmsm-tool restart`, a system reset of the emulated chip)
     brings the saved settings back and drops an unsaved change;
  3. bad input over the real UART changes nothing (settings, flash file): a frame with a
     wrong checksum, a frame that is no COBS, an unknown message, an overlong frame (each
     answered with its named error), a value out of range (refused, the field named), a
     setting locked while running written while running (refused, named);
  4. three speed commands, each recorded after its transient: every speed within 2 %, the
     drive's (recorded over the link) and the plant's (logged by the firmware);
  5. a fault shown and cleared through the link (the over-voltage trip set under the bus);
  6. the identification over the link from a motor of guessed parameters (its pole pairs and
     ratings right), saved (`identify --out F --save`): F loads with
     `pmsm-sim gains --motor-file F`, its R, L, ψ_f, J within host-sim/tests/identify.rs's
     bounds of the plant's motor (3, 5, 3, 10 %), kept across a power cycle;
  7. the flash at boot: the newest record with a bad CRC (the older wins), every record bad
     (not configured), a record of another format version, a record of the right version and
     CRC that is no settings (refused by the decoding): the drive refuses to run.
Prints the figures, "link_e2e: N passed, M failed", exits 1 on a failure.

Usage: python3 examples/qemu-m4f/scripts/link_e2e.py   (from anywhere; builds the firmware,
pmsm-tool and pmsm-sim first unless --no-build)
"""
import csv
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import tomllib
import re
import zlib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
ELF = os.path.join(ROOT, "examples/qemu-m4f/target/thumbv7em-none-eabihf/release/qemu-link")
RUNNER = os.path.join(ROOT, ".cargo/qemu-link.sh")
TOOL = os.path.join(ROOT, "target/release/pmsm-tool")
SIM = os.path.join(ROOT, "target/release/pmsm-sim")
FLASH = "qemu-link-flash.bin"
PAGE, SIZE, HEADER, WRITE = 2048, 4096, 16, 8
MAGIC = b"PMS1"
CONFIG_VERSION = 2  # config.rs
TIMEOUT_S = 20.0
# The plant's motor (pmsm_sensorless::motor::HORNG_SINANO), as a motor file.
SINANO = """name = "sinano"
pole_pairs = 4
r_ohm = 2.5
l_h = 5.97e-3
flux_wb = 5.795e-2
j_kgm2 = 6.45e-5
b_nms = 8.06e-5
torque_convention = "papers"
[ratings]
bus_v = 48.0
current_a = 3.0
torque_nm = 0.695
speed_rpm = 1000.0
power_w = 73.0
"""
# The same motor as its user knows it before the identification: its pole pairs and ratings,
# the parameters guessed (R 1.5x, L 0.6x, J 3x, no friction): the identification uses only the
# pole pairs and ratings.
GUESSED = (SINANO.replace('name = "sinano"', 'name = "sinano-guessed"')
           .replace("r_ohm = 2.5", "r_ohm = 3.75").replace("l_h = 5.97e-3", "l_h = 3.6e-3")
           .replace("j_kgm2 = 6.45e-5", "j_kgm2 = 1.9e-4").replace("b_nms = 8.06e-5", "b_nms = 0.0"))
BUS_V = 48.0
# host-sim/tests/identify.rs's bounds [%].
ID_BOUNDS = {"r_ohm": 3.0, "l_h": 5.0, "flux_wb": 3.0, "j_kgm2": 10.0}

passed, failed = 0, 0
figures = []


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
        print(f"ok   {name}")
    else:
        failed += 1
        print(f"FAIL {name} {detail}")
    return ok


def span(n):
    return (HEADER + n + WRITE - 1) // WRITE * WRITE


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --- the wire, for the bad frames (link/README.md: COBS(postcard(msg) ‖ CRC-16/KERMIT LE) ‖ 0)

def kermit(data):
    """CRC-16/KERMIT (poly 0x1021 reflected, init 0)."""
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


def cobs(raw):
    out, block = bytearray(), bytearray()
    for b in raw:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def uncobs(enc):
    out, i = bytearray(), 0
    while i < len(enc):
        code = enc[i]
        if code == 0:
            raise ValueError("zero in COBS")
        out += enc[i + 1:i + code]
        i += code
        if code < 255 and i < len(enc):
            out.append(0)
    return bytes(out)


def frame(payload, bad_crc=False):
    crc = kermit(payload) ^ (0x0100 if bad_crc else 0)
    return cobs(payload + struct.pack("<H", crc)) + b"\0"


def varint(n):
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        out.append(b | (0x80 if n else 0))
        if not n:
            return bytes(out)


# Request and DeviceMsg variant indices (link/src/msg.rs).
REQ_GET_SETTINGS = 1
DEV_RESPONSE, DEV_EVENT, DEV_FRAME_ERROR = 0, 1, 2
LINK_ERRORS = ["rejected", "busy_while_running", "unknown_message", "bad_checksum",
               "malformed", "too_long", "version_mismatch", "not_configured", "refused",
               "storage"]


class Raw:
    """A raw connection to the UART: frames out, the device's messages back (events skipped)."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT_S)
        self.rx = b""

    def answer(self, data):
        self.sock.sendall(data)
        deadline = time.time() + TIMEOUT_S
        while time.time() < deadline:
            while b"\0" not in self.rx:
                chunk = self.sock.recv(4096)
                if not chunk:
                    raise RuntimeError("the link closed")
                self.rx += chunk
            enc, _, self.rx = self.rx.partition(b"\0")
            raw = uncobs(enc)
            msg = raw[:-2]
            if kermit(msg) != struct.unpack("<H", raw[-2:])[0]:
                raise RuntimeError(f"bad CRC from the device: {raw!r}")
            if msg[:1] != bytes([DEV_EVENT]):
                return msg
        raise RuntimeError("no answer")

    def close(self):
        self.sock.close()


def link_error(msg):
    """('frame', name) for a FrameError, ('response', seq, name) for an error response."""
    if msg[0] == DEV_FRAME_ERROR:
        return ("frame", LINK_ERRORS[msg[1]])
    if msg[0] == DEV_RESPONSE and msg[2] == 1:  # Result::Err
        return ("response", msg[1], LINK_ERRORS[msg[3]])
    return ("other", msg)


# --- QEMU and the tool

class Emu:
    """One run of QEMU with the link firmware; its log in <dir>/log-<n>.txt."""

    runs = 0

    def __init__(self, state_dir, port):
        Emu.runs += 1
        self.port = port
        self.log_path = os.path.join(state_dir, f"log-{Emu.runs}.txt")
        env = dict(os.environ, QEMU_LINK_DIR=state_dir, QEMU_LINK_PORT=str(port))
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen([RUNNER, ELF], env=env, stdout=self.log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.time() + TIMEOUT_S
        while not self.wait_log("link on UART0", 0.05):
            if time.time() > deadline or self.proc.poll() is not None:
                raise RuntimeError(f"the firmware did not start: {self.text()}")

    def tool(self, *args, timeout_s=2.0):
        """pmsm-tool's exit code, stdout, stderr."""
        r = subprocess.run([TOOL, "--tcp", f"127.0.0.1:{self.port}", "--timeout",
                            str(timeout_s), *args], capture_output=True, text=True,
                           timeout=300)
        return r.returncode, r.stdout, r.stderr

    def text(self):
        self.log.flush()
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def wait_log(self, needle, timeout_s=TIMEOUT_S):
        deadline = time.time() + timeout_s
        while needle not in self.text():
            if time.time() > deadline:
                return False
            time.sleep(0.05)
        return True

    def kill(self):
        """SIGKILL to QEMU and defmt-print: the power cut."""
        os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
        self.log.close()
        # QEMU is not the runner's child we waited for: wait until the whole group is gone,
        # so that the next run's connection cannot reach a dying QEMU.
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


def flash_bytes(state_dir):
    with open(os.path.join(state_dir, FLASH), "rb") as f:
        return f.read()


def records(img):
    """(offset, length, seq) of each record header in page 0 (the store appends there)."""
    out, at = [], 0
    while at + HEADER <= PAGE and img[at:at + 4] == MAGIC:
        _, n, seq = struct.unpack("<HHI", img[at + 4:at + 12])
        out.append((at, n, seq))
        at += span(n)
    return out


def record(version, seq, payload):
    head = MAGIC + struct.pack("<HHI", version, len(payload), seq)
    crc = zlib.crc32(head + payload) & 0xFFFFFFFF
    body = head + struct.pack("<I", crc) + payload
    return body + b"\xff" * (span(len(payload)) - len(body))


def write_flash(state_dir, img):
    with open(os.path.join(state_dir, FLASH), "wb") as f:
        f.write(img + b"\xff" * (SIZE - len(img)))


def not_configured(emu, what):
    code, _, err = emu.tool("config", "get")
    check(f"{what}: not configured (config get refused)", code == 6 and "configur" in err,
          f"{code} {err}")
    check(f"{what}: the drive refuses to run", emu.wait_log("drive refused"), emu.text())


def plant_rpm(text):
    """The plant's speeds [rpm] the firmware logged (once per emulated second)."""
    return [float(m) for m in re.findall(r"plant (-?[0-9.e+-]+) rpm", text)]


def speeds(path):
    with open(path) as f:
        return [(row["mode"], float(row["speed_rpm"])) for row in csv.DictReader(f)]


def main():
    t_start = time.time()
    if "--no-build" not in sys.argv:
        subprocess.run(["cargo", "build", "--release", "--manifest-path",
                        "examples/qemu-m4f/Cargo.toml", "--bin", "qemu-link",
                        "--target", "thumbv7em-none-eabihf"], cwd=ROOT, check=True)
        subprocess.run(["cargo", "build", "--release", "-p", "pmsm-tool", "-p",
                        "pmsm-host-sim", "--bin", "pmsm-tool", "--bin", "pmsm-sim"],
                       cwd=ROOT, check=True)
    state = tempfile.mkdtemp(prefix="qemu-link-")
    port = free_port()
    motor_file = os.path.join(state, "sinano.toml")
    with open(motor_file, "w") as f:
        f.write(SINANO)

    # 1-3: an erased flash; a motor set, saved; bad input.
    emu = Emu(state, port)
    try:
        not_configured(emu, "erased flash")
        code, _, err = emu.tool("run", "--speed-rpm", "300", "--seconds", "0.2")
        check("erased flash: run refused (not configured)", code == 6, f"{code} {err}")
        code, out, err = emu.tool("config", "load-motor", motor_file)
        check("config load-motor", code == 0, err)
        code, out, err = emu.tool("config", "get", "limits.i_max_a")
        i_max = 0.9 * float(out.split("=")[1])
        code, _, err = emu.tool("config", "set", "limits.i_max_a", f"{i_max}")
        check("config set limits.i_max_a (0.9 of its default)", code == 0, err)
        code, saved_text, err = emu.tool("config", "get")
        check("config get: every setting",
              code == 0 and "r_ohm = 2.5" in saved_text and f"limits.i_max_a = " in saved_text,
              err + saved_text)
        code, _, err = emu.tool("config", "save")
        check("config save", code == 0, err)
        img = flash_bytes(state)

        raw = Raw(port)
        good = varint(7) + bytes([REQ_GET_SETTINGS])
        a = link_error(raw.answer(frame(good, bad_crc=True)))
        check("wrong checksum: answered bad_checksum", a == ("frame", "bad_checksum"), a)
        a = link_error(raw.answer(b"\x05\x01\0"))
        check("corrupt frame (no COBS): answered malformed", a == ("frame", "malformed"), a)
        a = link_error(raw.answer(frame(varint(9) + bytes([99]))))
        check("unknown message: answered unknown_message under its number",
              a == ("response", 9, "unknown_message"), a)
        a = link_error(raw.answer(b"\x01" * 400 + b"\0"))
        check("overlong frame: answered too_long", a == ("frame", "too_long"), a)
        raw.close()
        code, _, err = emu.tool("config", "set", "limits.i_max_a", "1e6")
        check("a value out of range refused, the field named",
              code == 6 and "limits.i_max_a" in err, f"{code} {err}")
        print(f"     ({err.strip()})")
        code, text, err = emu.tool("config", "get")
        check("bad input changed no setting", code == 0 and text == saved_text, err)
        check("bad input wrote nothing to flash", flash_bytes(state) == img)

        # A restart over the link (a system reset of the emulated chip, QEMU kept): an unsaved
        # change is gone, the saved settings come back from the flash.
        code, _, err = emu.tool("config", "set", "limits.i_max_a", f"{1.05 * i_max}")
        check("an unsaved change before the restart", code == 0, err)
        boots = emu.text().count("link on UART0")
        code, out, err = emu.tool("restart", "--limit", "20")
        check("restart over the link: answered, the device back, configured",
              code == 0 and "configured from its store" in out, f"{code} {out} {err}")
        check("restart: the firmware restarted (the chip reset, not a new QEMU)",
              "restart asked over the link" in emu.text()
              and emu.text().count("link on UART0") == boots + 1, emu.text()[-2000:])
        code, text, err = emu.tool("config", "get")
        check("after the restart: the saved settings, the unsaved change gone",
              code == 0 and text == saved_text, err + text)
    finally:
        emu.kill()

    # 2 (cont.), 3 (locked while running), 4, 5: after a power cut.
    emu = Emu(state, port)
    try:
        check("after a power cycle: drive configured", emu.wait_log("drive configured"),
              emu.text())
        code, text, err = emu.tool("config", "get")
        check("after a power cycle: config get unchanged", code == 0 and text == saved_text,
              err + text)
        for rpm in [300.0, 600.0, -450.0]:
            # The transient: the ramp (rated speed in a second) and the speed loop's settling.
            code, _, err = emu.tool("run", "--speed-rpm", f"{rpm}", "--seconds", "1.5",
                                    "--keep", timeout_s=10.0)
            logged = len(plant_rpm(emu.text()))
            out_csv = os.path.join(state, f"run-{rpm:+.0f}.csv")
            code2, _, err2 = emu.tool("record", "--out", out_csv, "--rate-hz", "100",
                                      "--seconds", "1.0", timeout_s=10.0)
            rec = speeds(out_csv) if code2 == 0 else []
            v = [s for _, s in rec]
            # The plant's own speed (the truth), logged during the record.
            truth = plant_rpm(emu.text())[logged:]
            ok = (code == 0 and len(rec) >= 100 and all(m == "Sensorless" for m, _ in rec)
                  and all(abs(s - rpm) / abs(rpm) < 0.02 for s in v + truth) and truth)
            if v:
                worst = max(abs(s - rpm) / abs(rpm) for s in v) * 100
                figures.append(f"speed {rpm:+.0f} rpm: {len(v)} records over 1 s after 1.5 s, "
                               f"mean {sum(v) / len(v):+.3f}, min {min(v):+.3f}, max "
                               f"{max(v):+.3f} rpm, worst error {worst:.3f} %; the plant "
                               + ", ".join(f"{t:+.2f}" for t in truth) + " rpm")
            check(f"run at {rpm:+.0f} rpm, recorded: every speed within 2 %", ok,
                  f"{code} {err} {code2} {err2} {v[:5]} {truth}")
        code, _, err = emu.tool("config", "set", "r_ohm", "3.0")
        check("a locked setting written while running refused, named",
              code == 6 and "r_ohm" in err, f"{code} {err}")
        print(f"     ({err.strip()})")
        code, _, err = emu.tool("run", "--speed-rpm", "0", "--seconds", "0.1", timeout_s=10.0)
        check("stopped", code == 0, err)
        code, text, err = emu.tool("config", "get")
        check("the locked write changed nothing", code == 0 and text == saved_text, err)

        code, out, _ = emu.tool("fault")
        check("no fault", code == 0 and out.strip() == "no fault", out)
        code, _, err = emu.tool("config", "set", "limits.bus_max_v", f"{0.9 * BUS_V}")
        check("over-voltage trip set under the 48 V bus", code == 0, err)
        time.sleep(0.2)
        code, out, _ = emu.tool("fault")
        check("the fault shown: bus_overvoltage", out.strip() == "bus_overvoltage", out)
        code, out, _ = emu.tool("fault", "clear")
        check("cleared while its cause remains: latched again",
              out.strip() == "bus_overvoltage", out)
        code, _, err = emu.tool("config", "set", "limits.bus_max_v", f"{1.25 * BUS_V}")
        code, out, _ = emu.tool("fault", "clear")
        check("the trip back at its default, cleared: no fault", out.strip() == "no fault", out)
    finally:
        emu.kill()

    # 6: the identification over the link, saved, kept across a power cycle.
    emu = Emu(state, port)
    try:
        ident = os.path.join(state, "identified.toml")
        guessed = os.path.join(state, "sinano-guessed.toml")
        with open(guessed, "w") as f:
            f.write(GUESSED)
        code, _, err = emu.tool("config", "load-motor", guessed)
        check("a motor of guessed parameters loaded (not saved)", code == 0, err)
        t0 = time.time()
        code, out, err = emu.tool("identify", "--out", ident, "--name", "sinano-identified",
                                  "--save", "--limit", "100", timeout_s=10.0)
        t_id = time.time() - t0
        check("identify --out --save", code == 0 and "saved" in out, f"{code} {out} {err}")
        if code == 0:
            r = subprocess.run([SIM, "gains", "--motor-file", ident, "--json"],
                               capture_output=True, text=True)
            check("the identified motor file loads with pmsm-sim", r.returncode == 0, r.stderr)
            with open(ident, "rb") as f:
                got = tomllib.load(f)
            truth = tomllib.loads(SINANO)
            errs = {k: 100 * (got[k] - truth[k]) / truth[k] for k in ID_BOUNDS}
            figures.append(f"identified over the link ({t_id:.1f} s wall): " + ", ".join(
                f"{k} {got[k]:.4g} ({errs[k]:+.2f} %)" for k in ID_BOUNDS)
                + f", b_nms {got['b_nms']:.3g} (truth {truth['b_nms']:.3g})")
            check("identified within 3/5/3/10 % (R, L, flux, J) of the plant's motor",
                  all(abs(errs[k]) < ID_BOUNDS[k] for k in ID_BOUNDS), errs)
        code, id_text, err = emu.tool("config", "get")
    finally:
        emu.kill()
    emu = Emu(state, port)
    try:
        code, text, err = emu.tool("config", "get")
        check("the identified motor kept across a power cycle",
              code == 0 and text == id_text and text != saved_text, err)
    finally:
        emu.kill()

    # 7: the flash at boot. Page 0 holds the first save, then the identified motor's.
    recs = records(flash_bytes(state))
    check("two records in page 0", len(recs) == 2, recs)
    flip(state, recs[-1][0] + HEADER + 3)
    emu = Emu(state, port)
    try:
        code, text, err = emu.tool("config", "get")
        check("newest record corrupt: the older wins",
              code == 0 and text == saved_text and emu.wait_log("1 bad records skipped"),
              emu.text())
    finally:
        emu.kill()
    flip(state, recs[0][0] + HEADER + 7, 5)
    emu = Emu(state, port)
    try:
        not_configured(emu, "every record corrupt")
    finally:
        emu.kill()
    write_flash(state, record(CONFIG_VERSION + 1, 7, b"settings of another format"))
    emu = Emu(state, port)
    try:
        check("another format version: named",
              emu.wait_log("format_version; the drive will not run"), emu.text())
        not_configured(emu, "another format version")
    finally:
        emu.kill()
    write_flash(state, record(CONFIG_VERSION, 8, b"\x07no settings"))
    emu = Emu(state, port)
    try:
        check("a good record that is no settings: refused at decoding",
              emu.wait_log("configuration refused"), emu.text())
        not_configured(emu, "no settings")
    finally:
        emu.kill()

    print("figures:")
    for f in figures:
        print(f"  {f}")
    if failed == 0:
        shutil.rmtree(state, ignore_errors=True)
    else:
        print(f"logs and flash image kept in {state}")
    print(f"link_e2e: {passed} passed, {failed} failed in {time.time() - t_start:.0f} s")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
