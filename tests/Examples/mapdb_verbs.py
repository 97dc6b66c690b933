#!/usr/bin/env python3
"""`coloc mapdb info|verify|export-trajectory|export-ply` on a small map written by
`coloc bench mapdb --keep`, and the README's sqlite3 queries on the same file: counts agree,
exports are complete, a damaged file fails `verify` (exit 1) naming the table and row, and an
output into a missing directory is an error that leaves nothing behind.

Exit 0 on success, 1 on failure.
"""
import argparse
import json
import os
import sqlite3
import struct
import subprocess
import sys
import tempfile


def check(number, condition):
    """A named check: prints which one failed."""
    if not condition:
        print("check", number, "failed")
    return bool(condition)


def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    coloc = p.parse_args().coloc
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        bench = run([coloc, "bench", "mapdb", "--keyframes", "40", "--keypoints", "200", "--keep",
                     "--dir", tmp, "--json"])
        if bench.returncode != 0:
            print("bench failed:", bench.stderr[-2000:])
            return 1
        b = json.loads(bench.stdout)
        db = os.path.join(tmp, "bench.db")

        info = json.loads(run([coloc, "mapdb", "info", db, "--json"]).stdout)
        print("info:", info)
        ok &= check(1, info["keyframes"] == b["keyframes"] == 40
                    and info["map_points"] == b["map_points"])
        ok &= check(2, info["observations"] == b["observations"] and info["bytes"] == b["bytes"])

        verify = run([coloc, "mapdb", "verify", db, "--json"])
        ok &= check(3, verify.returncode == 0 and json.loads(verify.stdout)["ok"])

        traj = os.path.join(tmp, "kf.txt")
        ok &= check(4, run([coloc, "mapdb", "export-trajectory", db, traj]).returncode == 0)
        with open(traj) as f:
            poses = [line.split() for line in f if line.strip() and not line.startswith("#")]
        ok &= check(5, len(poses) == 40 and all(len(pose) == 8 for pose in poses))

        ply = os.path.join(tmp, "points.ply")
        ok &= check(6, run([coloc, "mapdb", "export-ply", db, ply]).returncode == 0)
        with open(ply, "rb") as f:
            data = f.read()
        header, body = data.split(b"end_header\n", 1)
        count = int(header.split(b"element vertex ")[1].split(b"\n")[0])
        ok &= check(7, count == info["map_points"] and len(body) == count * (6 * 4 + 4))
        x, y, z = struct.unpack_from("<3f", body, 0)
        print("first point", x, y, z)

        # The README's queries.
        con = sqlite3.connect(db)
        ok &= check(8, con.execute("SELECT COUNT(*) FROM keyframes").fetchone()[0] == 40)
        markers = con.execute(
            "SELECT m.keyframe_id, k.timestamp, m.marker_id, k.marker_size, m.x0, m.y0, m.x1, "
            "m.y1, m.x2, m.y2, m.x3, m.y3 FROM markers m JOIN keyframes k ON k.id = m.keyframe_id "
            "ORDER BY m.keyframe_id, m.seq").fetchall()
        ok &= check(9, len(markers) == info["markers"] and all(r[3] > 0 for r in markers))
        tum = con.execute(
            "SELECT printf('%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f', timestamp, tx, ty, tz, "
            "qx, qy, qz, qw) FROM keyframes ORDER BY timestamp").fetchall()
        # Same numbers (the two printf implementations differ in the sign of a rounded -0).
        ok &= check(10, len(tum) == len(poses) and all(
            abs(float(a) - float(b)) < 1e-9
            for r, pose in zip(tum, poses) for a, b in zip(r[0].split(), pose)))
        # Loop edges (schema 2): one row per direction, each closure once by the README's query.
        loops = con.execute("SELECT keyframe_id, other_id FROM loop_edges "
                            "WHERE keyframe_id < other_id ORDER BY keyframe_id").fetchall()
        ok &= check(15, info["schema_version"] == 4 and info["loop_edges"] > 0
                    and len(loops) * 2 == info["loop_edges"]
                    == con.execute("SELECT COUNT(*) FROM loop_edges").fetchone()[0])
        # The IMU's measurements (schema 3) by recording, by the README's query: the synthetic
        # map has two recordings.
        imu = con.execute(
            "SELECT k.recording, COUNT(*), SUM(g.keyframe_id IS NOT NULL), SUM(k.dt) "
            "FROM gyro_links k LEFT JOIN gravity_windows g ON g.keyframe_id = k.keyframe_id "
            "GROUP BY k.recording ORDER BY k.recording").fetchall()
        print("imu by recording:", imu)
        ok &= check(16, len(imu) == 2 and sum(r[1] for r in imu) == info["gyro_links"] > 0
                    and all(0 < r[2] <= r[1] and r[3] > 0 for r in imu))
        con.close()

        # One damaged byte in the middle of the file (keyframe blobs fill most of it).
        bad = os.path.join(tmp, "bad.db")
        with open(bad, "wb") as f:
            f.write(data_with_flip(db))
        v = run([coloc, "mapdb", "verify", bad])
        print("damaged:", v.returncode, v.stdout.strip())
        tables = ("metadata", "cameras", "keyframes", "keyframe_features", "markers",
                  "map_points", "observations", "covisibility", "loop_edges", "gravity_windows",
                  "gyro_links", "keyframe_depth", "erased_keyframes")
        ok &= check(11, v.returncode == 1 and "bad.db" in v.stdout
                    and any(t in v.stdout for t in tables))

        missing = os.path.join(tmp, "no_such_dir", "kf.txt")
        e = run([coloc, "mapdb", "export-trajectory", db, missing])
        ok &= check(12, e.returncode == 1 and "does not exist" in e.stderr)
        ok &= check(13, not os.path.exists(os.path.dirname(missing)))
        leftovers = [n for n in os.listdir(tmp) if ".tmp-" in n]
        ok &= check(14, not leftovers)
    return 0 if ok else 1


def data_with_flip(path):
    with open(path, "rb") as f:
        data = bytearray(f.read())
    data[len(data) // 2] ^= 0x40
    return bytes(data)


if __name__ == "__main__":
    sys.exit(main())
