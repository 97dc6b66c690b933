#!/usr/bin/env python3
"""`coloc session` end to end over real UDP on loopback, with two calibrations solved by
`coloc handeye simulate|solve --output` and liblo's own tools as the XR systems and renderer:
  - `coloc session check` validates the description;
  - a locked pair of controllers (vive:0, quest:0) is streamed, each instant's two poses in one
    OSC bundle (garbage and an unknown participant come from oscsend); oscdump receives
    /coloc/users/<id>/controller/0 in the world frame, equal to the hand computation through
    each calibration;
  - garbage and an unknown participant are counted (--json), the session keeps going;
  - the session log feeds `coloc session stability` (Table 2), whose mean relative pose is the
    locked offset.

Exit 0 on success, 1 on failure, 77 when oscdump/oscsend (liblo-tools) are missing.
"""
import argparse
import json
import os
import pathlib
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import struct
import time

import numpy as np


sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import free_udp_port  # noqa: E402

# Waits for what is bound to happen (a datagram on loopback, a child's output): the deadlines
# only stop a stuck run, never a slow one (CI runs the suite on a busy 2-core machine).
ARRIVAL_S = 60


def wait_until(condition, timeout=ARRIVAL_S):
    deadline = time.time() + timeout
    while not condition():
        if time.time() >= deadline:
            return False
        time.sleep(0.02)
    return True


def osc_string(text):
    data = text.encode() + b"\0"
    return data + b"\0" * (-len(data) % 4)


def osc_message(address, types, *args):
    """An OSC 1.0 message (types d, i, f, s), as oscsend writes it."""
    body = b""
    for t, a in zip(types, args):
        body += {"d": lambda v: struct.pack(">d", v), "i": lambda v: struct.pack(">i", v),
                 "f": lambda v: struct.pack(">f", v), "s": osc_string}[t](a)
    return osc_string(address) + osc_string("," + types) + body


def osc_bundle(*messages):
    """A bundle to be handled at once (timetag 1): its messages arrive in one datagram."""
    out = osc_string("#bundle") + struct.pack(">II", 0, 1)
    for m in messages:
        out += struct.pack(">i", len(m)) + m
    return out


def read_matrix(path, key):
    for line in open(path):
        if line.startswith(key + ":"):
            values = line.split(":", 1)[1].replace("[", " ").replace("]", " ").replace(",", " ")
            return np.array([float(v) for v in values.split()]).reshape(4, 4)
    raise RuntimeError(key + " missing in " + path)


def quat_to_matrix(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--coloc", required=True)
    args = parser.parse_args()
    if not shutil.which("oscsend") or not shutil.which("oscdump"):
        print("liblo-tools (oscsend, oscdump) missing: skipped")
        return 77
    tmp = tempfile.mkdtemp(prefix="coloc_session_osc_")
    for name, seed in (("vive", "3"), ("quest", "4")):
        subprocess.run([args.coloc, "handeye", "simulate", "--out", os.path.join(tmp, name),
                        "--seed", seed], check=True, stdout=subprocess.DEVNULL)
        subprocess.run([args.coloc, "handeye", "solve", "--pairs",
                        os.path.join(tmp, name, "pairs.csv"), "--output",
                        os.path.join(tmp, name + ".yaml")], check=True, stdout=subprocess.DEVNULL)
    config = os.path.join(tmp, "session.yaml")
    with open(config, "w") as f:
        f.write("anchor:\n  world_from_camera: [1, 2, 0.5, 0, 0, 0.7071068, 0.7071068]\n"
                "participants:\n"
                "  - {id: vive, kind: vr, calibration: vive.yaml}\n"
                "  - {id: quest, kind: vr, calibration: quest.yaml}\n")
    ok = subprocess.run([args.coloc, "session", "check", config],
                        stdout=subprocess.DEVNULL).returncode == 0

    listen, dump_port = free_udp_port(), free_udp_port()
    dump = subprocess.Popen(["oscdump", "-L", str(dump_port)], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    lines = []
    threading.Thread(target=lambda: [lines.append(l.split()) for l in dump.stdout],
                     daemon=True).start()
    # oscdump listens once it prints a probe sent to it.
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ok &= wait_until(lambda: probe.sendto(b"/coloc/probe\0\0\0\0,\0\0\0",
                                          ("127.0.0.1", dump_port)) > 0 and
                     wait_until(lambda: any("/coloc/probe" in l for l in list(lines)), 0.2))
    probe.close()
    log = os.path.join(tmp, "log.csv")
    session = subprocess.Popen([args.coloc, "session", "--config", config, "--listen", str(listen),
                                "--publish", "osc.udp://127.0.0.1:%d" % dump_port, "--log", log,
                                "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    # The node listens once it says so on stderr.
    errors = []
    threading.Thread(target=lambda: [errors.append(l) for l in session.stderr],
                     daemon=True).start()
    ok &= wait_until(lambda: any("OSC in on udp" in l for l in list(errors)) or
                     session.poll() is not None)

    def send(*argv):
        subprocess.run(["oscsend", "127.0.0.1", str(listen)] + [str(a) for a in argv], check=True)

    send("/coloc/xr_pose", "s", "garbage")
    send("/coloc/xr_pose", "diifffffffs", 1.0, 1, 1, 0, 0, 1.6, 0, 0, 0, 1, "ghost")
    # Locked controllers, held still (the pairing by arrival time then cannot mix samples up):
    # vive's at (0.5, 0.2, 1.0), quest's 5 cm further along x, seen from quest's tracking space
    # (through the two calibrations).
    vive_vr_cam = read_matrix(os.path.join(tmp, "vive.yaml"), "vr_from_camera")
    quest_vr_cam = read_matrix(os.path.join(tmp, "quest.yaml"), "vr_from_camera")
    quest_from_vive = quest_vr_cam @ np.linalg.inv(vive_vr_cam)
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for i in range(30):
        a = np.eye(4)
        a[:3, 3] = [0.5, 0.2, 1.0]
        b = quest_from_vive @ a
        b[:3, 3] += quest_from_vive[:3, :3] @ np.array([0.05, 0, 0])
        qw = np.sqrt(max(0.0, 1 + np.trace(b[:3, :3]))) / 2
        q = [(b[2, 1] - b[1, 2]) / (4 * qw), (b[0, 2] - b[2, 0]) / (4 * qw),
             (b[1, 0] - b[0, 1]) / (4 * qw), qw]
        # Both systems' poses of one instant in one datagram (one bundle): `session stability`
        # pairs them by arrival time, which two oscsend processes would space by their start-up
        # time (tens of ms on a busy machine), not by anything the test controls.
        pair = osc_bundle(
            osc_message("/coloc/xr_controller", "diifffffffis", 1.0 + 0.01 * i, i, 1,
                        *a[:3, 3], 0, 0, 0, 1, 0, "vive"),
            osc_message("/coloc/xr_controller", "diifffffffis", 7.0 + 0.01 * i, i, 1,
                        *b[:3, 3], *q, 0, "quest"))
        udp.sendto(pair, ("127.0.0.1", listen))
    # Every message was handled once the last one of each system came out in the world frame.
    def published(user, t):
        address = "/coloc/users/%s/controller/0" % user
        return any(address in l and abs(float(l[l.index(address) + 2]) - t) < 1e-6
                   for l in list(lines))
    ok &= wait_until(lambda: published("vive", 1.29) and published("quest", 7.29))
    session.send_signal(2)
    out = session.stdout.read()
    session.wait(timeout=600)
    dump.terminate()
    stats = json.loads(out.strip().splitlines()[-1])
    ok &= session.returncode == 0
    ok &= stats["controller_poses"] == 60 and stats["dropped"]["wrong_types"] == 1
    ok &= stats["dropped"]["unknown_participant"] == 1
    # Hand computation of vive's last controller: world_from_camera * vr_from_camera^-1 * a.
    world_cam = np.eye(4)
    world_cam[:3, :3] = quat_to_matrix(0, 0, 0.7071068, 0.7071068)
    world_cam[:3, 3] = [1, 2, 0.5]
    expected = (world_cam @ np.linalg.inv(vive_vr_cam) @ a)[:3, 3]
    got = [l for l in lines if "/coloc/users/vive/controller/0" in l]
    ok &= len(got) >= 1
    if got:
        i = got[-1].index("/coloc/users/vive/controller/0")
        position = np.array([float(v) for v in got[-1][i + 5:i + 8]])
        ok &= np.linalg.norm(position - expected) < 1e-4
    table = subprocess.run([args.coloc, "session", "stability", "--config", config, "--log", log,
                            "--a", "vive:0", "--b", "quest:0", "--max-dt", "0.05", "--json"],
                           capture_output=True, text=True)
    ok &= table.returncode == 0
    if table.returncode == 0:
        row = json.loads(table.stdout)
        ok &= row["poses"] >= 20 and abs(row["translation_mean_m"] - 0.05) < 1e-3
        ok &= row["translation_rms_m"] < 1e-3
    shutil.rmtree(tmp, ignore_errors=True)
    print("session_osc:", "ok" if ok else "FAILED", stats)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
