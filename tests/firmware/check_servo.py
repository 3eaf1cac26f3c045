#!/usr/bin/python3
"""servo.elf's link service (docs/protocol.md) over QEMU's TCP serial.

Starts QEMU with the board's UART on a TCP server socket (the way the host
tool connects to an emulated board), then speaks the binary protocol with
its own COBS and CRC-32 (zlib's, IEEE 802.3) -- independent of the C++ codec:

  1. boot: the first byte is a 0x00 delimiter, nothing else before frames
  2. hello (board, protocol version, 100 kHz, 4 recorder channels), status
     (running: tick count grows, disarmed, reference controller swapped in)
  3. hostile input: random bytes, bad CRC, truncated, oversize, unknown
     type, NaN parameter, limits change while armed, StartExcitation sizes
     that wrap 32 bits (multisine lines to 2^31, a PRBS period beyond
     2^32 - 1) -- each counted or
     answered with an error naming the field; the device keeps running and
     the limits read back unchanged
  4. a run: trajectory + recorder (r, y, e, u), StartWave with flags arm
     loop | arm recorder | restart stage; 0.2 s of log blocks; their
     block_seq and ticks have no gaps, no recorder overrun, the first frame
     is the wave's tick 0 from rest (y = 0), the stage follows the wave
  5. throughput of the log stream: bytes per virtual second (ticks / rate)
     and per wall second

    check_servo.py <servo.elf> <machine> [--replay host_servo_replay] [--seconds S]
    check_servo.py <servo.elf> <machine> --profile-test

--replay: the recorded frames are replayed by host_servo_replay (the
simulator's loop kernel) and must be equal bit for bit. --profile-test
instead boots twice, with a valid emulation profile (50 kHz, other full
scales, written here from the documented layout) and a corrupted one
(reference stage, board fault, the reason on the semihosting console).

Exit status 0 only if every check passed.
"""
import math
import os
import random
import socket
import struct
import subprocess
import sys
import threading
import time
import zlib

PROFILE_ADDRESS = 0x003FFC00  # common/piezoloop/emulation_profile.hpp
VERSION = 7

T_HELLO, T_STATUS, T_GET, T_SET, T_ARM, T_DISARM = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
T_START_WAVE, T_STOP_WAVE, T_REC_ARM, T_REC_STOP = 0x08, 0x09, 0x0D, 0x0E
T_START_EXCITATION = 0x0F
R_ACK, R_HELLO, R_STATUS, R_PARAMS, R_ERROR, R_LOG = 0x80, 0x81, 0x82, 0x83, 0xFF, 0xC0
G_LIMITS, G_TRAJECTORY, G_RECORDER = 4, 5, 6
ERR_MALFORMED, ERR_INVALID, ERR_ARMED = 3, 4, 5


def cobs_encode(data):
    out = bytearray()
    block = bytearray()
    for b in data:
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out.append(255)
                out += block
                block = bytearray()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(data):
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            return None
        out += data[i + 1:i + code]
        i += code
        if code < 255 and i < len(data):
            out.append(0)
    return bytes(out)


def frame(msg_type, seq, body=b"", version=VERSION):
    payload = struct.pack("<BBH", msg_type, version, seq) + body
    return cobs_encode(payload + struct.pack("<I", zlib.crc32(payload))) + b"\x00"


class Link:
    """Frames from the socket, decoded by a reader thread."""

    def __init__(self, sock):
        self.sock = sock
        self.lock = threading.Condition()
        self.replies = {}
        self.logs = []
        self.log_bytes = 0
        self.garbage = 0
        self.first_byte = None
        self.seq = 0
        self.closed = False
        threading.Thread(target=self._reader, daemon=True).start()

    def _reader(self):
        buf = bytearray()
        while True:
            try:
                chunk = self.sock.recv(65536)
            except OSError:
                chunk = b""
            if not chunk:
                with self.lock:
                    self.closed = True
                    self.lock.notify_all()
                return
            if self.first_byte is None:
                self.first_byte = chunk[0]
            buf += chunk
            while True:
                z = buf.find(0)
                if z < 0:
                    break
                enc = bytes(buf[:z])
                del buf[:z + 1]
                if not enc:
                    continue
                raw = cobs_decode(enc)
                if raw is None or len(raw) < 8 or zlib.crc32(raw[:-4]) != struct.unpack("<I", raw[-4:])[0]:
                    self.garbage += 1
                    continue
                t, v, seq = struct.unpack("<BBH", raw[:4])
                body = raw[4:-4]
                with self.lock:
                    if t == R_LOG:
                        self.logs.append(body)
                        self.log_bytes += len(enc) + 1
                    else:
                        self.replies[seq] = (t, body)
                    self.lock.notify_all()

    def send_raw(self, data):
        self.sock.sendall(data)

    def request(self, msg_type, body=b"", timeout=10.0, version=VERSION):
        self.seq = (self.seq + 1) & 0xFFFF
        seq = self.seq
        self.sock.sendall(frame(msg_type, seq, body, version))
        deadline = time.time() + timeout
        with self.lock:
            while seq not in self.replies:
                left = deadline - time.time()
                if left <= 0 or self.closed:
                    raise TimeoutError(f"no reply to type 0x{msg_type:02x} seq {seq}")
                self.lock.wait(left)
            return self.replies.pop(seq)


def text(b):
    return b.split(b"\0", 1)[0].decode("ascii", "replace")


HELLO_FMT = "<B16s16s32sfIBfffffHHBIBBHII"  # then axis_count and 5 f32 per axis


def parse_hello(b):
    n = struct.calcsize(HELLO_FMT)
    f = struct.unpack(HELLO_FMT, b[:n])
    axes = b[n]
    return dict(protocol=f[0], board=text(f[1]), version=text(f[2]), serial=text(f[3]), rate=f[4], caps=f[5],
                fmt=f[6], hard_min=f[7], hard_max=f[8], pos_fs=f[10], volt_fs=f[11], rec_channels=f[14],
                rec_capacity=f[15], exc_capacity=f[20], axes=axes, size_ok=len(b) == n + 1 + 20 * axes)


STATUS_FMT = "<7B3I3IffI" + "IHIII" + "10I" + "3f" + "BII" + "B16s32sh96s"  # ... excitation, storage block
STORAGE_STATES = ["absent", "empty", "applied", "ignored_corrupt", "ignored_other_firmware", "ignored_rejected",
                  "ignored_read_failed"]


def parse_status(b):
    n = struct.calcsize(STATUS_FMT)
    f = struct.unpack(STATUS_FMT, b[:n])  # then the axes block (axis_count and 41 bytes per axis)
    names = ["armed", "tripped", "trip_reason", "wave_running", "streaming", "swap_pending", "recorder_state",
             "faults", "tick_count", "swaps", "overruns", "time_min", "time_max", "time_mean", "counter_Hz",
             "board_faults", "setpoint_underruns", "setpoint_free", "setpoint_next_seq", "recorder_overruns",
             "log_blocks", "frames_ok", "bad_cobs", "bad_crc", "truncated", "oversize", "unknown_type",
             "bad_version", "bad_length", "bad_value", "error_replies", "r_um", "y_um", "u_V",
             "excitation_running", "excitation_ticks", "excitation_clipped", "storage", "storage_group", "storage_field", "storage_index", "storage_message"]
    d = dict(zip(names, f))
    d["storage"] = STORAGE_STATES[d["storage"]] if d["storage"] < len(STORAGE_STATES) else d["storage"]
    for k in ("storage_group", "storage_field", "storage_message"):
        d[k] = text(d[k])
    return d


def parse_error(b):
    f = struct.unpack("<BB16s32sh96s", b)
    return dict(request=f[0], code=f[1], group=text(f[2]), field=text(f[3]), index=f[4], message=text(f[5]))


def parse_log(b):
    seq, first, stride, overruns, nch, fmt, nfr, flags = struct.unpack("<IIIIBBBB", b[:20])
    channels = list(b[20:28])
    n = nch * nfr
    kind = "f" if fmt == 0 else "i"
    samples = struct.unpack(f"<{n}{kind}", b[28:28 + 4 * n])
    return dict(seq=seq, first=first, stride=stride, overruns=overruns, nch=nch, fmt=fmt, frames=nfr, flags=flags,
                channels=channels, samples=samples, raw=b[28:28 + 4 * n])


def limits_body(u_min, u_max, slew, trip):
    return struct.pack("<BBffff", G_LIMITS, 0, u_min, u_max, slew, trip)  # group, axis 0, the limits


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def qemu_command(elf, machine, port, profile=None):
    qemu = os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")
    cpu = {"mps2-an500": ["-cpu", "cortex-m7"], "mps2-an385": ["-cpu", "cortex-m3"]}.get(machine, [])
    cmd = [qemu, "-M", machine, *cpu, "-nographic", "-monitor", "none", "-icount", "shift=0,sleep=off",
           "-semihosting", "-kernel", elf, "-serial", f"tcp:127.0.0.1:{port},server=on,wait=on"]
    if profile:
        cmd += ["-device", f"loader,file={profile},addr=0x{PROFILE_ADDRESS:x}"]
    return cmd


def connect(port, proc, timeout=10.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"QEMU exited with {proc.returncode}")
        try:
            return socket.create_connection(("127.0.0.1", port), timeout=2.0)
        except OSError:
            time.sleep(0.05)
    raise TimeoutError("QEMU's serial socket did not open")


def profile_blob(rate, pos_fs, volt_fs, stage_rate=None, corrupt=False):
    """An emulation profile per the layout in common/piezoloop/emulation_profile.hpp,
    written independently of the C++ encoder: a linear stage (1.5 um/V), a
    5 kHz amplifier, a 16-bit DAC, a sensor with a 20 kHz bandwidth and
    seeded noise (2 nm rms), an 18-bit ADC."""
    body = struct.pack("<Iff", rate, pos_fs, volt_fs)
    body += struct.pack("<f", float(rate if stage_rate is None else stage_rate))
    body += struct.pack("<iff", 16, -12.0, 12.0)                              # dac
    body += struct.pack("<6f", 1.0, -12.0, 12.0, -15.0, 15.0, 5000.0)         # amplifier
    body += struct.pack("<B", 0)                                              # hysteresis none
    body += struct.pack("<fffB", 1.0, 0.0, 1.0, 0) + struct.pack("<32f", *([0.0] * 32))  # pi
    body += struct.pack("<6f", *([0.0] * 6))                                  # dahl
    body += struct.pack("<fB", 1.5, 0)                                        # linear gain, sections
    body += struct.pack("<30d", *([1.0, 0.0, 0.0, 0.0, 0.0] * 6))             # dynamics (unused)
    body += struct.pack("<fffI", 1.0, 20000.0, 0.002, 7)                      # sensor
    body += struct.pack("<iff", 18, -100.0, 100.0)                            # adc
    body += struct.pack("<fffB", 0.0, 0.0, 50.0, 0) + struct.pack("<8f", *([0.0] * 8))  # offset, gain error, mains
    body += struct.pack("<4f", 0.0, 0.0, 0.0, 0.0)                            # creep, drift
    body += struct.pack("<B", 0) + struct.pack("<16f", *([0.0] * 16))         # output map
    assert len(body) == 617
    crc = zlib.crc32(body) ^ (1 if corrupt else 0)
    return struct.pack("<IHHII", 0x4D455A50, 3, 0, len(body), crc) + body


def session(elf, machine, profile, body):
    """One QEMU run: body(link, check) against the board; returns (failures, QEMU's own output)."""
    port = free_port()
    cmd = qemu_command(elf, machine, port, profile)
    print("qemu:", " ".join(cmd))
    log_path = f"/tmp/check_servo_{os.getpid()}_{port}.log"
    with open(log_path, "w") as qlog:
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=qlog, stderr=subprocess.STDOUT)
    failed = []

    def check(ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            failed.append(what)
        return ok

    try:
        sock = connect(port, proc)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.settimeout(None)
        body(Link(sock), check)
    except Exception as e:  # noqa: BLE001 -- any failure is a test failure
        check(False, f"exception: {type(e).__name__}: {e}")
    finally:
        proc.kill()
        proc.wait()
        with open(log_path) as f:
            out = f.read()
        os.unlink(log_path)
        if out.strip():
            print("QEMU output (semihosting console):", out.strip())
    return failed, out


def recorded_run(link, check, rate, amplitude, offset, freq, seconds):
    """Trajectory + recorder (r, y, e, u), StartWave flags 7, `seconds` of log
    blocks; checks the stream and returns (logs, log bytes, wall seconds)."""
    traj = struct.pack("<BBBfffIfffH", G_TRAJECTORY, 0, 0, amplitude, offset, freq, 0, 0.0, 0.1, 0.5, 0)
    check(link.request(T_SET, traj)[0] == R_ACK, f"trajectory set (sine {amplitude} um, {freq} Hz, offset {offset} um)")
    rec = struct.pack("<BBB8s8sIBBBBfII", G_RECORDER, 0, 4, bytes([0, 1, 2, 3, 0, 0, 0, 0]), bytes(8), 1, 1, 0, 0, 0,
                      0.0, 0, 0)
    check(link.request(T_SET, rec)[0] == R_ACK, "recorder set (r, y, e, u, every tick, continuous)")
    with link.lock:
        link.logs.clear()
        link.log_bytes = 0
    st = parse_status(link.request(T_STATUS)[1])
    t, b = link.request(T_START_WAVE, bytes([0, 0x07]))  # axis 0, flags 7
    check(t == R_ACK, f"StartWave flags 7 (arm loop, arm recorder, restart stage): {hex(t)}")
    t_start = time.time()
    target = int(seconds * rate)
    while time.time() - t_start < 60:
        time.sleep(0.02)
        with link.lock:
            span = None
            if link.logs:
                a, z = parse_log(link.logs[0]), parse_log(link.logs[-1])
                span = z["first"] + z["frames"] - a["first"]
        if span is not None and span >= target:
            break
    wall = time.time() - t_start
    check(link.request(T_REC_STOP)[0] == R_ACK, "recorder stop")
    check(link.request(T_DISARM)[0] == R_ACK, "disarm")
    time.sleep(0.05)
    with link.lock:
        logs = [parse_log(x) for x in link.logs]
        nbytes = link.log_bytes
    check(len(logs) > 10, f"{len(logs)} log blocks")
    check(all(l["seq"] == i for i, l in enumerate(logs)), "log block_seq 0, 1, 2, ... without gaps")
    check(all(logs[i + 1]["first"] == logs[i]["first"] + logs[i]["frames"] for i in range(len(logs) - 1)),
          "ticks contiguous across blocks (no dropped frames)")
    check(all(l["overruns"] == 0 for l in logs), "no recorder overrun")
    check(bool(logs) and logs[0]["first"] > st["tick_count"], "first frame after the request")
    return logs, nbytes, wall


def run_replay(replay, check, q31, logs, rate, amplitude, offset, freq, profile=None):
    frames_path = f"/tmp/check_servo_frames_{os.getpid()}.bin"
    with open(frames_path, "wb") as f:
        for l in logs:
            f.write(l["raw"])
    cmd = [replay, "q31" if q31 else "float", frames_path, repr(rate), repr(amplitude), repr(offset), repr(freq)]
    if profile:
        cmd.append(profile)
    r = subprocess.run(cmd, capture_output=True, text=True)
    os.unlink(frames_path)
    print(r.stdout.strip(), r.stderr.strip())
    check(r.returncode == 0, "every recorded frame equals the simulator's loop kernel bit for bit")


def profile_checks(elf, machine, replay):
    failed = []
    tmp = f"/tmp/check_servo_profile_{os.getpid()}.bin"

    def valid(link, check):
        h = parse_hello(link.request(T_HELLO)[1])
        print("hello:", h)
        check(h["rate"] == 50000.0 and h["pos_fs"] == 80.0 and h["volt_fs"] == 20.0,
              "profile: loop rate 50 kHz, full scales 80 um / 20 V")
        check(h["hard_min"] == -10.0 and h["hard_max"] == 10.0, "hard limits stay the board's")
        st = parse_status(link.request(T_STATUS)[1])
        check(st["board_faults"] == 0 and not st["faults"] & 0x100, "no profile fault")
        check(not st["swap_pending"] and st["swaps"] == 0, "no controller staged (the host configures it)")
        time.sleep(0.05)
        st2 = parse_status(link.request(T_STATUS)[1])
        check(st2["tick_count"] > st["tick_count"] and st2["overruns"] == 0, "running at 50 kHz, no overruns")
        # A PID loop around the profile's stage (the controller host_servo_replay assumes).
        check(link.request(T_SET, limits_body(-10.0, 10.0, 2e5, 0.0))[0] == R_ACK, "limits set")
        # group 2 (feedback), kind 2 (PID), sos_count 0, kMaxControllerSections = 4 sections, PID.
        fb = struct.pack("<BBBB", 2, 0, 2, 0) + struct.pack("<20d", *([1.0, 0.0, 0.0, 0.0, 0.0] * 4)) + \
            struct.pack("<6f", 0.5, 3000.0, 0.0, 5000.0, -10.0, 10.0)
        t, b = link.request(T_SET, fb)
        check(t == R_ACK, f"feedback PID set {parse_error(b) if t == R_ERROR else ''}")
        time.sleep(0.02)
        logs, _, _ = recorded_run(link, check, 50000.0, 3.0, 0.5, 200.0, 0.1)
        fs = 80.0 / 2**31 if machine == "mps2-an385" else 1.0
        ys = [l["samples"][i * 4 + 1] * fs for l in logs[len(logs) // 2:] for i in range(l["frames"])]
        check(max(ys) - min(ys) > 4.0, f"the PID loop follows the wave (y from {min(ys):.3f} to {max(ys):.3f} um)")
        if replay:
            run_replay(replay, check, machine == "mps2-an385", logs, 50000.0, 3.0, 0.5, 200.0, tmp)

    def invalid(link, check):
        h = parse_hello(link.request(T_HELLO)[1])
        check(h["rate"] == 100000.0 and h["pos_fs"] == 50.0, "invalid profile: the reference at 100 kHz")
        st = parse_status(link.request(T_STATUS)[1])
        check(st["board_faults"] == 1 and st["faults"] & 0x100, "status: board fault 0 (profile invalid)")
        check(st["swaps"] == 1, "reference controller in place")

    for name, blob, fn, note in [("valid", profile_blob(50000, 80.0, 20.0), valid, "profile loaded"),
                                 ("invalid", profile_blob(50000, 80.0, 20.0, corrupt=True), invalid, "crc")]:
        with open(tmp, "wb") as f:
            f.write(blob)
        print(f"--- {name} profile")
        fails, out = session(elf, machine, tmp, fn)
        if note not in out:
            fails.append(f"{name}: semihosting console says '{note}'")
            print(f"FAIL {name}: semihosting console says '{note}'")
        failed += fails
    os.unlink(tmp)
    return failed


def main():
    args = sys.argv[1:]
    replay = None
    seconds = 0.2
    profile_test = "--profile-test" in args
    if profile_test:
        args.remove("--profile-test")
    if "--replay" in args:
        i = args.index("--replay")
        replay = args[i + 1]
        del args[i:i + 2]
    if "--seconds" in args:
        i = args.index("--seconds")
        seconds = float(args[i + 1])
        del args[i:i + 2]
    if len(args) != 2:
        print(__doc__)
        return 2
    elf, machine = args
    if not os.path.isfile(elf):
        print(f"no firmware image {elf}: build the firmware preset first")
        return 2
    if profile_test:
        failed = profile_checks(elf, machine, replay)
    else:
        failed, _ = session(elf, machine, None, lambda link, check: run_checks(link, check, machine, seconds, replay))
    print(f"{0 if failed else 1} passed, {len(failed)} failed")
    return 1 if failed else 0


def run_checks(link, check, machine, seconds, replay=None):
    q31 = machine == "mps2-an385"
    # 1-2: boot, hello, status.
    t, b = link.request(T_HELLO)
    check(t == R_HELLO, "hello answered")
    h = parse_hello(b)
    print("hello:", h)
    check(link.first_byte == 0, f"first byte on the UART is the 0x00 delimiter (got {link.first_byte})")
    board = {"mps2-an500": "qemu-m7", "mps2-an385": "qemu-m3"}.get(machine)
    check(h["protocol"] == VERSION and (board is None or h["board"] == board), f"protocol {VERSION}, board name")
    check(h["rec_channels"] == 4 and h["fmt"] == (1 if q31 else 0), "4 recorder channels, sample format")
    check(h["axes"] == 1 and h["size_ok"], "one axis, the hello's axes block")
    rate = h["rate"]
    s0 = parse_status(link.request(T_STATUS)[1])
    time.sleep(0.05)
    s1 = parse_status(link.request(T_STATUS)[1])
    print("status:", s1)
    check(s1["tick_count"] > s0["tick_count"], "the loop runs (tick count grows)")
    check(not s1["armed"] and not s1["tripped"], "starts disarmed, not tripped")
    check(s1["overruns"] == 0 and s1["time_max"] > 0, "tick stats: no overruns, timing measured")
    check(s1["storage"] == "absent" and not h["caps"] & (1 << 8),
          "no --storage on the semihosting command line: no parameter storage")

    # 3: hostile input.
    c0 = s1
    rng = random.Random(2026)
    link.send_raw(bytes(rng.randrange(256) for _ in range(3000)) + b"\x00")
    good = frame(T_STATUS, 999)
    bad = bytearray(good)
    bad[3] ^= 0x01
    link.send_raw(bytes(bad))                                  # bad CRC
    link.send_raw(cobs_encode(b"\x02\x01") + b"\x00")          # truncated
    link.send_raw(bytes([0x55] * 700) + b"\x00")               # oversize
    t, b = link.request(0x40)                                   # unknown type
    e = parse_error(b) if t == R_ERROR else {}
    check(t == R_ERROR and e.get("code") == 1, f"unknown type -> error unknown_type: {e}")
    t, b = link.request(T_STATUS, version=VERSION + 1)
    check(t == R_ERROR and parse_error(b)["code"] == 2, "wrong header version -> error bad_version")
    t, b = link.request(T_GET, bytes([G_LIMITS, 0]))
    limits_before = b
    t, b = link.request(T_SET, limits_body(-10.0, math.nan, 2e5, 0.0))
    e = parse_error(b) if t == R_ERROR else {}
    check(t == R_ERROR and e.get("code") == ERR_INVALID and e.get("field") == "u_max_V",
          f"NaN limit -> invalid_param naming u_max_V: {e}")
    t, b = link.request(T_START_WAVE, bytes([0, 0x10]))
    e = parse_error(b) if t == R_ERROR else {}
    check(t == R_ERROR and e.get("code") == ERR_MALFORMED and e.get("field") == "flags",
          f"StartWave unknown flag bit -> malformed naming flags: {e}")
    check(link.request(T_ARM)[0] == R_ACK, "arm")
    t, b = link.request(T_SET, limits_body(-5.0, 5.0, 2e5, 0.0))
    e = parse_error(b) if t == R_ERROR else {}
    check(t == R_ERROR and e.get("code") == ERR_ARMED, f"limits change while armed -> error armed: {e}")
    check(link.request(T_DISARM)[0] == R_ACK, "disarm")
    # StartExcitation sizes that wrap 32 bits are refused at once, and the
    # board stays on the link: a multisine of N = 1000 with lines up to
    # 2^31 (+ 300: above Nyquist) -- 2 k2 wraps below N -- and a PRBS whose
    # period (2^24 - 1) x 257 exceeds 2^32 - 1. Flags: arm loop; point:
    # the reference (0.1 um).
    def excitation(signal, n, k2, order, hold):
        return struct.pack("<BBBBffIIIffBII", 0, 1, signal, 1, 0.1, 0.0, n, 1, k2, 0.0, 0.0, order, hold, 1)
    for body, field in ((excitation(0, 1000, 0x80000000, 10, 1), "last_bin"),
                        (excitation(0, 1000, 0x80000000 + 300, 10, 1), "last_bin"),
                        (excitation(2, 0, 1, 24, 257), "prbs_hold")):
        t, b = link.request(T_START_EXCITATION, body)
        e = parse_error(b) if t == R_ERROR else {}
        check(t == R_ERROR and e.get("code") == ERR_INVALID and e.get("field") == field,
              f"StartExcitation with sizes that wrap -> invalid_param naming {field}: {t} {e}")
    s_exc = parse_status(link.request(T_STATUS, timeout=2.0)[1])
    check(not s_exc["armed"] and not s_exc["excitation_running"], "the refused excitations started nothing")
    t, b = link.request(T_GET, bytes([G_LIMITS, 0]))
    check(b == limits_before, "limits read back unchanged")
    s2 = parse_status(link.request(T_STATUS)[1])
    check(s2["bad_crc"] > c0["bad_crc"] and s2["oversize"] > c0["oversize"] and s2["truncated"] > c0["truncated"]
          and s2["unknown_type"] > c0["unknown_type"] and s2["bad_version"] > c0["bad_version"],
          "hostile frames counted: bad_crc {bad_crc} oversize {oversize} truncated {truncated} "
          "unknown_type {unknown_type} bad_cobs {bad_cobs}".format(**s2))
    check(s2["tick_count"] > s1["tick_count"] and s2["overruns"] == 0, "still running, no overruns")
    check(link.garbage == 0, f"every byte from the device is part of a good frame ({link.garbage} bad)")

    # 4: a run with the log stream. Let the disarmed output settle at 0 V.
    time.sleep(0.05)
    freq = 100.0
    logs, nbytes, wall = recorded_run(link, check, rate, 5.0, 1.0, freq, seconds)
    st_end = parse_status(link.request(T_STATUS)[1])
    check(all(l["nch"] == 4 and l["channels"][:4] == [0, 1, 2, 3] for l in logs), "blocks carry r, y, e, u")
    if logs:
        frames = sum(l["frames"] for l in logs)
        first = logs[0]
        fs = h["pos_fs"] / 2**31 if q31 else 1.0
        r0, y0 = first["samples"][0] * fs, first["samples"][1] * fs
        # The wave starts at its offset, 1 um, the restarted stage at 0: its
        # first ticks are the approach, which leaves 0 at rest (the first
        # step 1 um * 10 / N^3, N = 375 ticks of 500 um/s at 100 kHz).
        check(0.0 < r0 < 1e-6 and y0 == 0.0, f"first frame: the approach's first sample from the restarted stage "
              f"(r = {r0}), y = {y0}")
        rs = [l["samples"][i * 4] * fs for l in logs for i in range(l["frames"])]
        k1 = next((k for k, r in enumerate(rs) if abs(r - 1.0) < 1e-6), len(rs))
        check(k1 < 1000 and all(abs(b - a) <= 10.0 * h["pos_fs"] / rate * (1 + 1e-6) for a, b in zip(rs[:k1], rs[1:k1 + 1])),
              f"the approach reaches the wave's first point (1 um, tick {k1}) within the speed bound")
        # Over the last 10 ms (one period of the wave): y spans most of r's 10 um.
        tail = [l for l in logs if l["first"] >= logs[-1]["first"] - int(rate / freq)]
        ys = [l["samples"][i * 4 + 1] * fs for l in tail for i in range(l["frames"])]
        check(max(ys) - min(ys) > 8.0, f"the stage follows the wave (y from {min(ys):.3f} to {max(ys):.3f} um)")
        virt = frames / rate
        print(f"log stream: {frames} frames, {nbytes} bytes in {virt:.3f} s virtual ({nbytes / virt:.0f} B/s), "
              f"{wall:.3f} s wall ({nbytes / wall:.0f} B/s); tick insn min/mean/max "
              f"{st_end['time_min']}/{st_end['time_mean']:.1f}/{st_end['time_max']}, overruns {st_end['overruns']}")
    if replay and logs:
        run_replay(replay, check, q31, logs, rate, 5.0, 1.0, freq)
    st3 = parse_status(link.request(T_STATUS)[1])
    check(st3["overruns"] == 0, f"no tick overruns ({st3['overruns']})")
    check(st3["recorder_overruns"] == 0, "status: no recorder overruns")


if __name__ == "__main__":
    sys.exit(main())
