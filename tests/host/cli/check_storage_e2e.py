#!/usr/bin/python3
"""The board's parameter storage end to end on an emulated board:

  piezoloop emulate --board qemu-m7 --scenario configs/ahmad2020.json --storage F
  piezoloop --device ... set --scenario ... --case dahl_ff_K; set link ...; save
  (stop the board, start it again with the same F)
      -> status: storage applied at boot, disarmed; get all = the saved set
  (corrupt one byte of F, start again)
      -> status: storage ignored (corrupt, the CRC named); get all = the
         board's defaults; load refused naming the CRC; save repairs it.

Also: save refused while armed, on a board started without --storage, and
for a set the board's boot would ignore (a fresh board's), the record kept.
Every emulator is stopped with SIGTERM (emulate then stops its QEMU), also
when a check fails.

Usage: check_storage_e2e.py PIEZOLOOP SERVO_ELF CONFIGS_DIR
Exit 77 (skipped) without qemu-system-arm or the image."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

from board_checks import Checks, Emulators, skip_without_qemu

exe, image, configs = sys.argv[1], sys.argv[2], sys.argv[3]
skip_without_qemu(image)

scenario = os.path.join(configs, "ahmad2020.json")
tmp = tempfile.mkdtemp(prefix="check_storage_e2e_")
store = os.path.join(tmp, "board params.bin")  # a space in the path: the firmware takes the rest of its command line
check = Checks()
emulators = Emulators(exe)
stop = Emulators.stop


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=60)


def start(storage=True):
    """An emulated board; returns (process, --device arguments, emulate's JSON line)."""
    args = ["--board", "qemu-m7", "--scenario", scenario, "--image", image]
    return emulators.start(*args, *(["--storage", store] if storage else []))


def status(d):
    r = run(*d, "status")
    return json.loads(r.stdout) if r.returncode == 0 else {}


def get_all(d):
    r = run(*d, "get", "all")
    return json.loads(r.stdout) if r.returncode == 0 else None


try:
    # ---- first boot: empty storage, commission, save -------------------------
    emu, d, info = start()
    check(info.get("storage") == store and info.get("storage_at_boot") == "empty",
          "emulate --storage: a missing file is created, the board boots with empty storage", json.dumps(info))
    s = status(d)
    check("storage" in s.get("hello", {}).get("capabilities", []) and
          s.get("status", {}).get("storage", {}).get("at_boot") == "empty",
          "status: storage capability, nothing stored at boot", json.dumps(s.get("status", {}).get("storage")))
    defaults = get_all(d)
    # A fresh board's set (limits never set) is one its boot would ignore:
    # save refuses it, naming the field, and stores nothing.
    r = run(*d, "save")
    check(r.returncode == 3 and "limits.slew_V_per_s" in r.stderr and os.path.getsize(store) == 0,
          "save of a fresh board's set refused, naming limits.slew_V_per_s", r.stderr)
    # A fresh board's recorder group is a valid set to change one field of.
    r = run(*d, "set", "recorder", "--json", '{"decimation": 3}')
    rec = get_all(d) or {}
    check(r.returncode == 0 and rec.get("recorder", {}).get("decimation") == 3,
          "set recorder with one field on a fresh board", r.stderr)
    r = run(*d, "set", "--scenario", scenario, "--case", "dahl_ff_K", "--frequency-hz", "10")
    check(r.returncode == 0, "set --scenario --case dahl_ff_K", r.stderr)
    r = run(*d, "set", "link", "--json", '{"client_timeout_s": 2.5}')
    check(r.returncode == 0, "set link", r.stderr)
    commissioned = get_all(d)
    check(commissioned is not None and commissioned != defaults, "the commissioned set differs from the defaults")

    r = run(*d, "arm")
    check(r.returncode == 0, "arm", r.stderr)
    r = run(*d, "save")
    check(r.returncode == 3 and "Save refused (armed)" in r.stderr, "save refused while armed", r.stderr)
    r = run(*d, "disarm")
    r = run(*d, "save")
    j = json.loads(r.stdout) if r.returncode == 0 else {}
    check(r.returncode == 0 and j.get("saved") == commissioned, "save: prints the stored set", r.stderr)
    check(os.path.getsize(store) > 100, "the storage file holds the record", str(os.path.getsize(store)))
    check(stop(emu) == 0, "SIGTERM ends the board")

    # ---- second boot: the saved set is back ------------------------------------
    emu, d, info = start()
    s = status(d).get("status", {})
    check(info.get("storage_at_boot") == "applied" and s.get("storage", {}).get("at_boot") == "applied" and
          s.get("storage", {}).get("text") == "stored set applied at boot",
          "reboot: status says the stored set was applied at boot", json.dumps(s.get("storage")))
    check(s.get("armed") is False, "reboot: the board boots disarmed")
    check(get_all(d) == commissioned, "reboot: get all returns the saved set")
    r = run(*d, "load")
    check(r.returncode == 0 and json.loads(r.stdout).get("loaded") == commissioned, "load by hand", r.stderr)
    check(stop(emu) == 0, "SIGTERM ends the board")

    # ---- third boot: one corrupted byte -----------------------------------------
    with open(store, "r+b") as f:
        data = bytearray(f.read())
        data[len(data) // 2] ^= 0x20
        f.seek(0)
        f.write(data)
    emu, d, info = start()
    s = status(d).get("status", {})
    st = s.get("storage", {})
    check(st.get("at_boot") == "ignored_corrupt" and "corrupt" in st.get("text", "") and
          st.get("why", "").startswith("storage.crc:"),
          "corrupted file: status says ignored, corrupt, and names the CRC", json.dumps(st))
    check(get_all(d) == defaults, "corrupted file: the board runs its defaults")
    check(s.get("armed") is False, "corrupted file: the board boots disarmed")
    r = run(*d, "load")
    check(r.returncode == 3 and "storage.crc" in r.stderr, "load of the corrupt record refused, naming the CRC",
          r.stderr)
    check(get_all(d) == defaults, "the refused load changed nothing")
    r = run(*d, "save")
    with open(store, "rb") as f:
        kept = f.read() == bytes(data)
    check(r.returncode == 3 and "limits.slew_V_per_s" in r.stderr and kept,
          "save of the defaults refused, the record left as it was", r.stderr)
    r = run(*d, "forget")
    check(r.returncode == 0 and os.path.getsize(store) == 0, "forget empties the storage file", r.stderr)
    r = run(*d, "load")
    check(r.returncode == 3 and "storage.record: nothing stored" in r.stderr, "load after forget: nothing stored",
          r.stderr)
    check(stop(emu) == 0, "SIGTERM ends the board")

    # ---- a board without storage -----------------------------------------------
    emu, d, info = start(storage=False)
    s = status(d)
    check("storage" not in s.get("hello", {}).get("capabilities", []) and
          s.get("status", {}).get("storage", {}).get("at_boot") == "absent",
          "without --storage: no capability, status says absent")
    r = run(*d, "save")
    check(r.returncode == 3 and "Save refused (unsupported)" in r.stderr and "--storage" in r.stderr,
          "without --storage: save refused, saying how to get storage", r.stderr)
    check(stop(emu) == 0, "SIGTERM ends the board")
finally:
    emulators.stop_all()
    shutil.rmtree(tmp, ignore_errors=True)

check.exit()
