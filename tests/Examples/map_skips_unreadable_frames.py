#!/usr/bin/env python3
"""`coloc map` on a copy of TUM fr1/xyz with one truncated colour image and one missing depth
image: both frames are skipped with a warning naming the file, every other frame is tracked,
and the trajectory is written (one bad file must not cost the session). A sequence whose images
are all unreadable is an error (exit 1), not a crash.

Exit 0 on success, 1 on failure, 77 (skipped) without the data.
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import shared_data_dir  # noqa: E402


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    args = p.parse_args()
    data = shared_data_dir()
    src = os.path.join(data, "tum_fr1_xyz_37f")
    if not os.path.isdir(src):
        print("no data at", src)
        return 77
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        seq = os.path.join(tmp, "seq")
        shutil.copytree(src, seq)
        rgb = sorted(os.listdir(os.path.join(seq, "rgb")))
        depth = sorted(os.listdir(os.path.join(seq, "depth")))
        bad_rgb = os.path.join(seq, "rgb", rgb[5])
        with open(bad_rgb, "r+b") as f:
            f.truncate(500)
        missing_depth = os.path.join(seq, "depth", depth[20])
        os.remove(missing_depth)
        traj = os.path.join(tmp, "traj.txt")
        out = subprocess.run([args.coloc, "map", "--sequence", seq, "--trajectory", traj, "--json"],
                             capture_output=True, text=True, check=False)
        print(out.stdout.strip())
        if out.returncode != 0:
            print("coloc map failed:", out.stderr[-2000:])
            return 1
        r = json.loads(out.stdout)
        ok &= r["skipped_frames"] == 2 and r["lost"] == 0 and r["tracked"] == r["frames"]
        ok &= os.path.basename(bad_rgb) in out.stderr and os.path.basename(missing_depth) in out.stderr
        with open(traj) as f:
            poses = [line for line in f if line.strip() and not line.startswith("#")]
        ok &= len(poses) == r["tracked"]
        # Every image unreadable: a clear error.
        for name in os.listdir(os.path.join(seq, "rgb")):
            with open(os.path.join(seq, "rgb", name), "r+b") as f:
                f.truncate(10)
        bad = subprocess.run([args.coloc, "map", "--sequence", seq, "--trajectory", traj],
                             capture_output=True, text=True, check=False)
        print(bad.returncode, bad.stderr.strip().splitlines()[-1:])
        ok &= bad.returncode == 1 and "no frame of the sequence could be read" in bad.stderr
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
