#!/usr/bin/env python3
"""Issue 37's cross-cutting check: every file-reading verb fed the same hostile set
  - a FIFO (opening one for reading blocks until a writer comes: forever),
  - YAML on which OpenCV 4.6's reader loops forever ("----x", and a root that ends early),
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
    elif kind == "yaml_root":
        with open(path, "w") as f:
            f.write("%YAML:1.0\n -A\nA\n-")
    elif kind == "empty":
        open(path, "w").close()
    elif kind == "directory":
        os.mkdir(path)
    elif kind in ("nan_matrix", "non_rigid"):
        with open(path, "w") as f:
            f.write(matrix_text(NAN if kind == "nan_matrix" else SCALED))


def marker_map(data):
    """A marker map whose one marker's first corner is the matrix's 4th number (NaN or 0)."""
    corner = "0" if ".nan" not in data else ".nan"
    return ("%%YAML:1.0\n---\nformat: coloc-marker-map\nversion: 1\ndictionary: DICT_4X4_50\n"
            "markers:\n  - { id: 3, edge_length: 0.1, corners: [%s,0,0, 0.1,0,0, 0.1,0.1,0, "
            "0,0.1,0] }\n" % corner)


def case(coloc, tmp, name, kind, argv, hostile, outputs, matrix_text=None):
    """Runs argv (with {hostile} and {tmp} filled in) once the hostile input is in place.
    A matrix kind where the file holds no matrix (matrix_text None) is not run."""
    if kind in ("nan_matrix", "non_rigid") and matrix_text is None:
        return
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
    kinds = ["fifo", "yaml_loop", "yaml_root", "empty", "directory", "nan_matrix", "non_rigid"]
    plain = ["fifo", "empty", "directory"]
    with tempfile.TemporaryDirectory() as base:
        replay = os.path.join(base, "replay")
        subprocess.run([coloc, "devices", "make-replay", "--sequence", tum, "--config", config,
                        "--out", replay, "--frames", "4", "--unpaced"], check=True,
                       capture_output=True)
        map_db = os.path.join(base, "map.db")
        subprocess.run([coloc, "map", "--sequence", tum, "--config", config, "--trajectory",
                        os.path.join(base, "map.txt"), "--save", map_db], check=True,
                       capture_output=True)
        image = os.path.join(tum, "rgb", sorted(os.listdir(os.path.join(tum, "rgb")))[0])
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
            # The scan's marker map (registration and the viewer).
            tmp = fresh()
            case(coloc, tmp, "register --markers", kind,
                 ["register", "--map", map_db, "--markers", "{hostile}", "--out", "{tmp}/r.db"],
                 os.path.join(tmp, "markers.yaml"), ["{tmp}/r.db"],
                 marker_map if kind == "nan_matrix" else None)
            tmp = fresh()
            case(coloc, tmp, "view --markers", kind,
                 ["view", map_db, "--markers", "{hostile}", "--port", "0"],
                 os.path.join(tmp, "markers.yaml"), [],
                 marker_map if kind == "nan_matrix" else None)
            # The camera's mounting on the headset (localize).
            tmp = fresh()
            case(coloc, tmp, "localize --cam-from-head", kind,
                 ["localize", "--map", map_db, "--sequence", tum, "--config", config,
                  "--trajectory", "{tmp}/t.txt", "--cam-from-head", "{hostile}"],
                 os.path.join(tmp, "head.yaml"), ["{tmp}/t.txt"],
                 lambda m: "%YAML:1.0\n---\n" + opencv_matrix("cam_from_head", m))
            # A custom marker dictionary and OpenCV's detector parameters (markers detect).
            tmp = fresh()
            case(coloc, tmp, "markers detect --dictionary", kind,
                 ["markers", "detect", image, "--dictionary", "{hostile}"],
                 os.path.join(tmp, "dictionary.yml"), [])
            tmp = fresh()
            case(coloc, tmp, "markers detect --params", kind,
                 ["markers", "detect", image, "--dictionary", "DICT_4X4_50", "--params",
                  "{hostile}"], os.path.join(tmp, "detector_params.yml"), [])
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
