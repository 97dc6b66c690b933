#!/usr/bin/env python3
"""Issue 17, end to end through the `coloc` binary: bad input never costs data, never hangs and
never passes silently.

- a settings path that is a FIFO is refused at once (no hang), naming what it is;
- `e57 to-ply` / `e57 extract-images` that fail midway leave an existing output as it was and
  no temporary files; an output folder that does not exist fails before any work;
- `eval` on an empty trajectory says the file is empty; `--max-dt` NaN / negative is a usage
  error; two different poses for one timestamp are an error naming the line;
- `fuse` on an empty input is an error naming the file;
- `map` skips (and names) a frame whose depth image has the wrong size and tracks the rest.

Exit 0 on success, 1 on failure, 77 (skipped) without the data.
"""
import argparse
import json
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import shared_data_dir  # noqa: E402

FAILURES = []


def check(condition, what):
    print(("ok   " if condition else "FAIL ") + what)
    if not condition:
        FAILURES.append(what)


def run(coloc, *args, timeout=120):
    return subprocess.run([coloc, *args], capture_output=True, text=True, check=False,
                          timeout=timeout)


def png16(path, width, height):
    """A 16-bit grey PNG (depth image) of the given size, written without any imaging library."""
    raw = b"".join(b"\0" + struct.pack(">H", 5000) * width for _ in range(height))
    chunk = lambda tag, data: (struct.pack(">I", len(data)) + tag + data +  # noqa: E731
                               struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height,
                                                                   16, 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def debris(folder):
    return [n for n in os.listdir(folder) if ".tmp-" in n]


def check_fifo(coloc, data, tmp):
    fifo = os.path.join(tmp, "settings.yaml")
    os.mkfifo(fifo)
    try:
        r = run(coloc, "map", "--sequence", os.path.join(data, "tum_fr1_xyz_37f"), "--config",
                fifo, "--trajectory", os.path.join(tmp, "t.txt"), timeout=30)
        check(r.returncode == 1 and "FIFO" in r.stderr, "a FIFO as settings is refused: " +
              r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "")
    except subprocess.TimeoutExpired:
        check(False, "a FIFO as settings hangs coloc map")


def check_e57_outputs(coloc, data, tmp):
    good = os.path.join(data, "e57", "cry-inc-e57", "tiny_pc_and_images.e57")
    bad = os.path.join(tmp, "bad.e57")
    with open(good, "rb") as f:
        whole = f.read()
    with open(bad, "wb") as f:
        f.write(whole[: len(whole) // 2])  # cut in half: the XML section is gone
    # One flipped byte in a page of a larger scan: a checksum error after the output was claimed.
    with open(os.path.join(data, "e57", "libE57Format-test-data", "self",
                           "ColouredCubeFloat.e57"), "rb") as f:
        cube = f.read()
    flipped = os.path.join(tmp, "flipped.e57")
    at = 20 * 1024 + 500
    with open(flipped, "wb") as f:
        f.write(cube[:at] + bytes([cube[at] ^ 0xFF]) + cube[at + 1:])
    ply = os.path.join(tmp, "out.ply")
    check(run(coloc, "e57", "to-ply", good, ply).returncode == 0, "e57 to-ply of a good file")
    with open(ply, "rb") as f:
        before = f.read()
    for broken in (bad, flipped):
        r = run(coloc, "e57", "to-ply", broken, ply)
        with open(ply, "rb") as f:
            after = f.read()
        check(r.returncode != 0 and after == before and not debris(tmp),
              f"a failed to-ply ({os.path.basename(broken)}) leaves the existing PLY and no "
              "temporary file")
    r = run(coloc, "e57", "to-ply", good, os.path.join(tmp, "missing", "out.ply"))
    check(r.returncode != 0 and "does not exist" in r.stderr, "to-ply into a missing folder")
    images = os.path.join(tmp, "images")
    check(run(coloc, "e57", "extract-images", good, images).returncode == 0, "extract-images")
    yaml = os.path.join(images, "images.yaml")
    with open(yaml, "rb") as f:
        before = f.read()
    r = run(coloc, "e57", "extract-images", bad, images)
    with open(yaml, "rb") as f:
        check(r.returncode != 0 and f.read() == before and not debris(images),
              "a failed extract-images leaves images.yaml as it was")


def check_eval_and_fuse(coloc, tmp):
    empty = os.path.join(tmp, "empty.txt")
    with open(empty, "w") as f:
        f.write("# nothing\n")
    good = os.path.join(tmp, "good.txt")
    with open(good, "w") as f:
        for i in range(20):
            f.write(f"{i * 0.1:.3f} {i * 0.01} 0 0 0 0 0 1\n")
    r = run(coloc, "eval", "ate", good, empty)
    check(r.returncode == 1 and "empty" in r.stderr and "empty.txt" in r.stderr,
          "eval on an empty trajectory names the empty file")
    for bad in ("nan", "-1"):
        r = run(coloc, "eval", "ate", good, good, "--max-dt", bad)
        check(r.returncode == 2 and "max-dt" in r.stderr, f"--max-dt {bad} is a usage error")
    dup = os.path.join(tmp, "dup.txt")
    with open(dup, "w") as f:
        f.write("1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n1.0 5 0 0 0 0 0 1\n")
    r = run(coloc, "eval", "ate", good, dup)
    check(r.returncode == 1 and "two different poses" in r.stderr and ":3" in r.stderr,
          "two poses for one timestamp name the line")
    r = run(coloc, "fuse", "--xr", empty, "--global", good, "--out", os.path.join(tmp, "f.tum"))
    check(r.returncode == 1 and "empty.txt" in r.stderr and not os.path.exists(
        os.path.join(tmp, "f.tum")), "fuse of an empty input is an error, nothing written")


def check_wrong_depth_size(coloc, data, tmp):
    seq = os.path.join(tmp, "seq")
    shutil.copytree(os.path.join(data, "tum_fr1_xyz_37f"), seq)
    depth = sorted(os.listdir(os.path.join(seq, "depth")))
    wrong = os.path.join(seq, "depth", depth[10])
    png16(wrong, 320, 240)
    traj = os.path.join(tmp, "traj.txt")
    r = run(coloc, "map", "--sequence", seq, "--trajectory", traj, "--json", timeout=300)
    ok = r.returncode == 0
    if ok:
        j = json.loads(r.stdout)
        ok = j["skipped_frames"] == 1 and j["tracked"] > 20
    check(ok and os.path.basename(wrong) in r.stderr and "320x240" in r.stderr,
          "a depth image of the wrong size is skipped and named, the run goes on")
    if not ok:
        print(r.stdout, r.stderr[-1500:])


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    args = p.parse_args()
    data = shared_data_dir()
    if not os.path.isdir(os.path.join(data, "tum_fr1_xyz_37f")) or not os.path.isdir(
            os.path.join(data, "e57")):
        print("no data at", data)
        return 77
    with tempfile.TemporaryDirectory() as tmp:
        check_fifo(args.coloc, data, tmp)
        check_e57_outputs(args.coloc, data, tmp)
        check_eval_and_fuse(args.coloc, tmp)
        check_wrong_depth_size(args.coloc, data, tmp)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
