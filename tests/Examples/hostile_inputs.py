#!/usr/bin/env python3
"""Issue 37's cross-cutting check: every file-reading verb fed the same hostile set
  - a FIFO (opening one for reading blocks until a writer comes: forever),
  - YAML on which OpenCV 4.6's reader loops forever ("----x"),
  - a NaN matrix and a non-rigid (scaled) matrix, where the file holds one,
  - an empty file and a directory,
exits 1 with a message naming the file, writes no output, and does not hang.

Exit 0 on success, 1 on failure, 77 (skipped) without the data.
"""
import argparse
import os
import pathlib
import subprocess
import sys
import tempfile

sys.path.insert(0, next(str(p / "testing") for p in pathlib.Path(__file__).resolve().parents
                        if p.name == "tests"))
from coloc_testing import REPO, shared_data_dir  # noqa: E402

FAILURES = []
# Only a stuck run reaches it (every case is refused before any work).
HANG_S = 120

IDENTITY = "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]"
NAN = "[1,0,0,.nan, 0,1,0,0, 0,0,1,0, 0,0,0,1]"
SCALED = "[1.2,0,0,0, 0,1.2,0,0, 0,0,1.2,0, 0,0,0,1]"
# A camera calibration file (record --calibration) without its color_from_depth.
CAMERA = ("%YAML:1.0\n---\nCamera.width: 640\nCamera.height: 480\nCamera1.fx: 517.3\n"
          "Camera1.fy: 516.5\nCamera1.cx: 318.6\nCamera1.cy: 255.3\n")


def opencv_matrix(key, data):
    return "%s: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: %s\n" % (key, data)


def make(kind, path, matrix_text=None):
    """Writes the hostile input `kind` at `path` (matrix kinds through matrix_text(data))."""
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "yaml_loop":
        with open(path, "w") as f:
            f.write("%YAML:1.0\n---\nkey: 1\n----x\n")
    elif kind == "empty":
        open(path, "w").close()
    elif kind == "directory":
        os.mkdir(path)
    elif kind in ("nan_matrix", "non_rigid"):
        with open(path, "w") as f:
            f.write(matrix_text(NAN if kind == "nan_matrix" else SCALED))


def case(coloc, tmp, name, kind, argv, hostile, outputs, matrix_text=None):
    """Runs argv (with {hostile} and {tmp} filled in) once the hostile input is in place."""
    make(kind, hostile, matrix_text)
    args = [a.format(hostile=hostile, tmp=tmp) for a in argv]
    what = "%s fed %s" % (name, kind)
    try:
        r = subprocess.run([coloc, *args], capture_output=True, text=True, timeout=HANG_S,
                           stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        print("FAIL %s: hangs" % what)
        FAILURES.append(what)
        return
    last = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""
    named = os.path.basename(hostile) in r.stderr
    written = [o for o in outputs if os.path.exists(o.format(tmp=tmp))]
    ok = r.returncode == 1 and named and not written
    print(("ok   " if ok else "FAIL ") + what + ": exit %d: %s%s" %
          (r.returncode, last, (" (wrote %s)" % written) if written else ""))
    if not ok:
        FAILURES.append(what)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    coloc = p.parse_args().coloc
    data = shared_data_dir()
    tum = os.path.join(data, "tum_fr1_xyz_37f")
    if not os.path.isdir(tum):
        print("no data at", tum)
        return 77
    config = str(REPO / "Examples" / "RGB-D" / "TUM1.yaml")
    with open(config) as f:
        settings = f.read()
    kinds = ["fifo", "yaml_loop", "empty", "directory", "nan_matrix", "non_rigid"]
    plain = ["fifo", "empty", "directory"]
    with tempfile.TemporaryDirectory() as base:
        replay = os.path.join(base, "replay")
        subprocess.run([coloc, "devices", "make-replay", "--sequence", tum, "--config", config,
                        "--out", replay, "--frames", "4", "--unpaced"], check=True,
                       capture_output=True)
        calibration = os.path.join(base, "vive.yaml")
        with open(calibration, "w") as f:
            f.write("device_from_marker: %s\nvr_from_camera: %s\n" % (IDENTITY, IDENTITY))
        n = 0
        for kind in kinds:
            def fresh():
                nonlocal n
                n += 1
                d = os.path.join(base, "case%d" % n)
                os.mkdir(d)
                return d
            # The session description (yaml-cpp) and a participant's hand-eye calibration.
            tmp = fresh()
            session = lambda m: ("anchor:\n  world_from_camera: %s\nparticipants:\n"  # noqa
                                 "  - {id: vive, kind: vr, calibration: %s}\n" % (m, calibration))
            case(coloc, tmp, "session check", kind, ["session", "check", "{hostile}"],
                 os.path.join(tmp, "session.yaml"), [], session)
            tmp = fresh()
            case(coloc, tmp, "session --config", kind,
                 ["session", "--config", "{hostile}", "--listen", "0", "--duration", "0.1",
                  "--log", "{tmp}/log.csv"], os.path.join(tmp, "session.yaml"),
                 ["{tmp}/log.csv"], session)
            tmp = fresh()
            hostile = os.path.join(tmp, "quest.yaml")
            with open(os.path.join(tmp, "session.yaml"), "w") as f:
                f.write("anchor:\n  world_from_camera: %s\nparticipants:\n"
                        "  - {id: quest, kind: vr, calibration: %s}\n" % (IDENTITY, hostile))
            case(coloc, tmp, "session check (calibration)", kind,
                 ["session", "check", os.path.join(tmp, "session.yaml")], hostile, [],
                 lambda m: "device_from_marker: %s\nvr_from_camera: %s\n" % (IDENTITY, m))
            # ORB-SLAM settings (OpenCV YAML behind the guard), the IMU transform as matrix.
            tmp = fresh()
            case(coloc, tmp, "map --config", kind,
                 ["map", "--sequence", tum, "--config", "{hostile}", "--trajectory",
                  "{tmp}/t.txt"], os.path.join(tmp, "settings.yaml"), ["{tmp}/t.txt"],
                 lambda m: settings + opencv_matrix("IMU.T_b_c1", m))
            # A camera's calibration file (record --calibration).
            tmp = fresh()
            case(coloc, tmp, "record --calibration", kind,
                 ["record", "--camera", "replay:" + replay, "--out", "{tmp}/rec", "--mode",
                  "depth=640x480@30,color=640x480@30", "--calibration", "{hostile}"],
                 os.path.join(tmp, "camera.yaml"), ["{tmp}/rec"],
                 lambda m: CAMERA + opencv_matrix("color_from_depth", m))
            if kind in plain:
                tmp = fresh()
                case(coloc, tmp, "calibrate (image)", kind,
                     ["calibrate", "{hostile}", "--chessboard", "9x6", "--square", "0.02",
                      "--out", "{tmp}/c.yaml"], os.path.join(tmp, "board.png"),
                     ["{tmp}/c.yaml"])
                tmp = fresh()
                case(coloc, tmp, "eval (trajectory)", kind,
                     ["eval", "ate", os.path.join(tum, "groundtruth.txt"), "{hostile}"],
                     os.path.join(tmp, "t.txt"), [])
    print("hostile inputs:", "all refused" if not FAILURES else "%d FAILED" % len(FAILURES))
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
