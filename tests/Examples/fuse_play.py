#!/usr/bin/env python3
"""`coloc fuse play` feeds a fusion node over real UDP, as a headset and a localizer would:
a node (`coloc fuse --listen PORT --out FUSED`) hears a headset's drifting poses (/coloc/xr_pose)
and global poses (/coloc/pose, 50 ms after their stamps) played from TUM files; what it fuses
lands on the truth, and the file it writes when stopped holds those fused poses. Paced by
events: the node is ready when it says so, the player ends when its files do, the node stops on
SIGINT.

Exit 0 on success, 1 on failure.
"""
import argparse
import json
import math
import os
import pathlib
import signal
import subprocess
import sys
import tempfile


sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import free_udp_port  # noqa: E402

def write_tum(path, poses):
    with open(path, "w") as f:
        for t, (x, y, z), (qx, qy, qz, qw) in poses:
            f.write(f"{t:.6f} {x:.6f} {y:.6f} {z:.6f} {qx} {qy} {qz} {qw}\n")


def read_tum(path):
    out = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                v = [float(x) for x in line.split()]
                out.append((v[0], v[1:4]))
    return out


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    args = p.parse_args()
    # A head walking along y at 0.5 m/s for 3 s; the headset's frame is 1 m off in x.
    truth = [(i / 90.0, (0.0, 0.5 * i / 90.0, 1.7), (0, 0, 0, 1)) for i in range(270)]
    xr = [(t, (x - 1.0, y, z), q) for t, (x, y, z), q in truth]
    world = [pose for i, pose in enumerate(truth) if i % 9 in (0, 5)]  # ~20 Hz
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        xr_file, world_file = os.path.join(tmp, "xr.txt"), os.path.join(tmp, "world.txt")
        fused_file = os.path.join(tmp, "fused.txt")
        write_tum(xr_file, xr)
        write_tum(world_file, world)
        port = free_udp_port()
        url = f"osc.udp://127.0.0.1:{port}"
        node = subprocess.Popen([args.coloc, "fuse", "--listen", str(port), "--out", fused_file,
                                 "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        # Ready when it says it listens (its socket is bound before it says so).
        for line in node.stderr:
            if "fusion node: OSC in" in line:
                break
        else:
            print("the node did not start:", node.communicate()[1][-2000:])
            return 1
        # One player, both streams: the headset, and the global poses 50 ms after their
        # stamps as a localizer sends them. One thread sends both in one order, so the node
        # sees the same messages in the same order on any machine.
        run = subprocess.run([args.coloc, "fuse", "play", xr_file, "--global", world_file,
                              "--latency", "0.05", "--to", url, "--speed", "3"],
                             capture_output=True, text=True, check=False)
        print(run.stdout.strip())
        ok &= run.returncode == 0 and "played 330 of 330" in run.stdout
        node.send_signal(signal.SIGINT)
        out, err = node.communicate(timeout=120)
        if node.returncode != 0:
            print("node failed:", err[-2000:])
            return 1
        stats = json.loads(out)
        print(json.dumps(stats))
        ok &= stats["xr_poses"] == 270 and stats["global_poses"] == 60
        ok &= stats["initialized"] == 1 and stats["accepted"] >= 50
        fused = read_tum(fused_file)
        ok &= len(fused) > 0
        by_time = {round(t, 6): pos for t, pos, _ in truth}
        worst = max(math.dist(pos, by_time[round(t, 6)]) for t, pos in fused) if fused else 1e9
        print(f"{len(fused)} fused poses written, largest error {worst:.4f} m "
              f"(the headset alone is 1 m off)")
        ok &= worst < 0.05
        # Unanchored poses are not written: every fused pose came after a global one.
        ok &= len(fused) <= stats["xr_poses"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
