#!/usr/bin/env python3
"""rgbd_tum (ORB-SLAM3's example, same arguments and output files) and `coloc map` run the same
SLAM pipeline: on TUM fr1/xyz with one associations file they write the same trajectory, and
both reach the accuracy of the pipeline (global BA included).

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


def read_list(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                t, name = line.split()[:2]
                rows.append((float(t), name))
    return rows


def read_tum(path):
    poses = {}
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                v = [float(x) for x in line.split()]
                poses[round(v[0], 6)] = v[1:4]
    return poses


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    p.add_argument("--rgbd-tum", required=True)
    p.add_argument("--source", required=True)
    args = p.parse_args()
    src = os.path.join(shared_data_dir(), "tum_fr1_xyz_37f")
    if not os.path.isdir(src):
        print("no data at", src)
        return 77
    vocabulary = os.path.join(args.source, "Vocabulary", "coloc_orb_k10_L5.cvoc")
    settings = os.path.join(args.source, "Examples", "RGB-D", "TUM1.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        seq = os.path.join(tmp, "seq")
        shutil.copytree(src, seq)
        # Each colour image with the nearest depth image (as TUM's associate.py pairs them).
        depth = read_list(os.path.join(seq, "depth.txt"))
        with open(os.path.join(seq, "associations.txt"), "w") as f:
            for t, name in read_list(os.path.join(seq, "rgb.txt")):
                td, dname = min(depth, key=lambda d: abs(d[0] - t))
                if abs(td - t) < 0.02:
                    f.write(f"{t:.6f} {name} {td:.6f} {dname}\n")
        run = subprocess.run([args.rgbd_tum, vocabulary, settings, seq,
                              os.path.join(seq, "associations.txt")],
                             cwd=tmp, capture_output=True, text=True, check=False)
        if run.returncode != 0:
            print("rgbd_tum failed:", run.stderr[-2000:])
            return 1
        print(run.stderr.strip().splitlines()[-1])
        traj = os.path.join(tmp, "coloc_map.txt")
        out = subprocess.run([args.coloc, "map", "--sequence", seq, "--config", settings,
                              "--vocabulary", vocabulary, "--trajectory", traj, "--json"],
                             capture_output=True, text=True, check=False)
        if out.returncode != 0:
            print("coloc map failed:", out.stderr[-2000:])
            return 1
        summary = json.loads(out.stdout)
        ours = read_tum(os.path.join(tmp, "CameraTrajectory.txt"))
        cli = read_tum(traj)
        if set(ours) != set(cli) or not ours:
            print(f"different frames: rgbd_tum {len(ours)}, coloc map {len(cli)}")
            return 1
        worst = max(max(abs(a - b) for a, b in zip(ours[t], cli[t])) for t in ours)
        print(f"{len(ours)} poses, largest difference {worst:.2e} m; coloc map ATE "
              f"{summary.get('ate_rmse_m')}")
        if worst > 1e-6:
            print("rgbd_tum and coloc map made different maps")
            return 1
        if "ATE rmse" not in run.stderr:
            print("rgbd_tum printed no ATE although the sequence has ground truth")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
