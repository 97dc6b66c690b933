#!/usr/bin/env python3
"""Checks `coloc eval ate` against an independent implementation.

The reference here shares no code with coloc: it associates timestamps like the TUM tools
(greedy, nearest first, |dt| <= 20 ms), aligns with Horn's closed-form QUATERNION method (the
eigenvector of the 4x4 matrix N; coloc uses Umeyama's SVD) for SE3, and with Umeyama's scale
for Sim3, then computes the statistics with numpy. Input: the real TUM fr1/xyz ground truth,
and a copy moved by a known similarity transform with seeded noise and a time offset.
Exit 0 when they agree to 1e-6 m, 1 otherwise, 77 (skipped) without numpy or the data.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys

sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import shared_data_dir  # noqa: E402

try:
    import numpy as np
except ImportError:
    print("numpy not installed: skipped")
    sys.exit(77)


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            rows.append([float(v) for v in line.replace(",", " ").split()[:8]])
    a = np.array(rows)
    return a[np.argsort(a[:, 0], kind="stable")]


def quat_to_matrix(q):  # x y z w
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def associate(ta, tb, max_dt):
    cands = []
    for i, t in enumerate(ta):
        for j in np.nonzero(np.abs(tb - t) <= max_dt)[0]:
            cands.append((abs(tb[j] - t), i, int(j)))
    cands.sort()
    used_a, used_b, pairs = set(), set(), []
    for _, i, j in cands:
        if i in used_a or j in used_b:
            continue
        used_a.add(i)
        used_b.add(j)
        pairs.append((i, j))
    return sorted(pairs)


def horn_quaternion(src, dst):
    """Rotation and translation minimizing |dst - (R src + t)|^2 (Horn 1987)."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    s = (src - ms).T @ (dst - md)  # S_ab = sum src_a dst_b
    sxx, sxy, sxz = s[0]
    syx, syy, syz = s[1]
    szx, szy, szz = s[2]
    n = np.array([
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]])
    w, v = np.linalg.eigh(n)
    q0, qx, qy, qz = v[:, np.argmax(w)]
    r = quat_to_matrix(np.array([qx, qy, qz, q0]))
    return 1.0, r, md - r @ ms


def umeyama_sim3(src, dst):
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - ms, dst - md
    cov = b.T @ a / len(src)
    u, d, vt = np.linalg.svd(cov)
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2, 2] = -1
    r = u @ sign @ vt
    scale = np.trace(np.diag(d) @ sign) / (a * a).sum(axis=1).mean()
    return scale, r, md - scale * r @ ms


def reference_ate(gt, est, align):
    pairs = associate(gt[:, 0], est[:, 0], 0.02)
    g = np.array([gt[i, 1:4] for i, _ in pairs])
    e = np.array([est[j, 1:4] for _, j in pairs])
    scale, r, t = (horn_quaternion if align == "se3" else umeyama_sim3)(e, g)
    err = np.linalg.norm(g - (scale * (r @ e.T).T + t), axis=1)
    return {"count": len(err), "rmse": float(np.sqrt(np.mean(err ** 2))),
            "mean": float(np.mean(err)), "median": float(np.median(err)),
            "std": float(np.std(err)), "min": float(np.min(err)), "max": float(np.max(err))}


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    p.add_argument("--work", required=True)
    args = p.parse_args()
    data = shared_data_dir()
    gt_file = os.path.join(data, "tum_fr1_xyz_37f", "groundtruth.txt")
    if not os.path.exists(gt_file):
        print("TUM data not found: skipped")
        return 77
    os.makedirs(args.work, exist_ok=True)
    gt = read_tum(gt_file)

    rng = np.random.default_rng(2024)
    angle = 0.7
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    worst = 0.0
    for align, scale in (("se3", 1.0), ("sim3", 0.6)):
        est = gt.copy()
        est[:, 0] += rng.uniform(-0.004, 0.004, len(gt))  # clock jitter within association
        est[:, 1:4] = scale * (rot @ gt[:, 1:4].T).T + np.array([1.0, -2.0, 0.5])
        est[:, 1:4] += rng.normal(0.0, 0.02, est[:, 1:4].shape)
        est_file = os.path.join(args.work, f"est_{align}.txt")
        np.savetxt(est_file, est, fmt="%.9f")
        out = subprocess.run([args.coloc, "eval", "ate", gt_file, est_file, "--align", align,
                              "--json"], capture_output=True, text=True, check=True)
        ours = json.loads(out.stdout)["translation_m"]
        ref = reference_ate(gt, est, align)
        for key, v in ref.items():
            diff = abs(ours[key] - v)
            worst = max(worst, diff)
            print(f"{align} {key:6s} coloc {ours[key]:.9f} reference {v:.9f} diff {diff:.2e}")
    print(f"largest difference {worst:.2e} m")
    return 0 if worst <= 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
