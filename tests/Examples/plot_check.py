#!/usr/bin/env python3
"""`coloc eval ate|rpe --plot`: matplotlib writes a complete image where asked (PNG, SVG), no
temporary file is left next to it, the JSON result on stdout is untouched by the plotting, and a
plot path that cannot be written (missing folder, unknown format) is an error naming it before
the evaluation runs.

Exit 0 on success, 1 on failure, 77 (skipped) when matplotlib is not installed.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile


def write_tum(path, poses):
    with open(path, "w") as f:
        for t, x, y, z in poses:
            f.write(f"{t:.6f} {x:.6f} {y:.6f} {z:.6f} 0 0 0 1\n")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    args = p.parse_args()
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        # A circle walked in 10 s and an estimate with a 2 cm wobble.
        gt = [(0.1 * i, math.cos(0.06 * i), math.sin(0.06 * i), 1.5) for i in range(100)]
        est = [(t, x + 0.02 * math.sin(3 * t), y, z) for t, x, y, z in gt]
        gt_file, est_file = os.path.join(tmp, "gt.txt"), os.path.join(tmp, "est.txt")
        write_tum(gt_file, gt)
        write_tum(est_file, est)
        out_dir = os.path.join(tmp, "plots")
        os.mkdir(out_dir)
        png = os.path.join(out_dir, "ate.png")
        r = subprocess.run([args.coloc, "eval", "ate", gt_file, est_file, "--json", "--plot", png],
                           capture_output=True, text=True, check=False)
        if "matplotlib is missing" in r.stderr:
            print(r.stderr.strip())
            return 77
        print(r.returncode, r.stdout.strip(), r.stderr.strip())
        ok &= r.returncode == 0 and json.loads(r.stdout)["metric"] == "ate"
        with open(png, "rb") as f:
            ok &= f.read(8) == b"\x89PNG\r\n\x1a\n"
        svg = os.path.join(out_dir, "rpe.svg")
        r = subprocess.run([args.coloc, "eval", "rpe", gt_file, est_file, "--plot", svg],
                           capture_output=True, text=True, check=False)
        ok &= r.returncode == 0
        with open(svg) as f:
            ok &= "<svg" in f.read(2000)
        left = sorted(os.listdir(out_dir))
        print("files:", left)
        ok &= left == ["ate.png", "rpe.svg"]
        for bad, why in ((os.path.join(tmp, "missing", "a.png"), "folder does not exist"),
                         (os.path.join(out_dir, "a.txt"), ".png, .pdf or .svg")):
            r = subprocess.run([args.coloc, "eval", "ate", gt_file, est_file, "--plot", bad],
                               capture_output=True, text=True, check=False)
            print(r.returncode, r.stdout.strip(), r.stderr.strip())
            # Checked before the work: nothing printed on stdout.
            ok &= r.returncode == 1 and why in r.stderr and bad in r.stderr and not r.stdout
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
