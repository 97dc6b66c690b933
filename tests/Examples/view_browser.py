#!/usr/bin/env python3
"""`coloc view` and `coloc map --view` in a real browser: Debian's chromium, headless, driven by
playwright-core (tests/Examples/browser/view_page.mjs).

saved (default): a twin room is mapped and saved; `coloc view MAP --markers --sequence` serves
it; the page must show the map's keyframe count, the markers SLAM saw and the scan's, draw the
scene, and show a keyframe's image with its keypoints when the keyframe is clicked in the 3-D
view. Then the bad inputs: a busy port and a damaged map are clear errors (exit 1).
--live: `coloc map --view` on a 6 s twin room (181 frames: the 37-frame TUM clip maps in about a
second, which a loaded 2-core machine's browser cannot sample before the run ends); the page must
see the pose advance; the browser then closes mid-run and the run must finish as without it.

A screenshot of the page is kept (--artefacts DIR, default the working directory). Exit 0 on
success, 1 on failure, 77 when node, chromium or playwright-core are missing.
"""
import argparse
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "testing"))
import coloc_testing  # noqa: E402

PAGE_SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "browser", "view_page.mjs")
PLAYWRIGHT = coloc_testing.REPO / "slam" / "view" / "web" / "node_modules" / "playwright-core" / "index.mjs"


def check(name, condition, detail=""):
    print(("ok   " if condition else "FAIL ") + name + (": " + str(detail) if detail else ""))
    return bool(condition)


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)


def page(mode, url, shot, seconds=None):
    env = dict(os.environ, PLAYWRIGHT_CORE=str(PLAYWRIGHT))
    cmd = ["node", PAGE_SCRIPT, mode, url, shot] + ([str(seconds)] if seconds else [])
    r = run(cmd, env=env, timeout=180)
    if r.returncode != 0:
        print("page failed:", r.stderr[-3000:])
        return None
    return json.loads(r.stdout.strip().splitlines()[-1])


def marker_yaml(truth, path):
    """The twin's true marker corners (groundtruth/markers.txt) as a marker map file."""
    markers = []
    with open(truth) as f:
        for line in f:
            v = line.split()
            if not v or line.startswith("#"):
                continue
            markers.append((int(v[0]), float(v[1]), [float(x) for x in v[2:14]]))
    with open(path, "w") as f:
        f.write("%YAML:1.0\n---\nformat: coloc-marker-map\nversion: 1\ndictionary: DICT_4X4_50\n"
                "frame: global\nmarkers:\n")
        for mid, size, c in markers:
            f.write("   -\n      id: %d\n      edge_length: %.6f\n      corners: [ %s ]\n"
                    % (mid, size, ", ".join("%.6f" % x for x in c)))
    return len(markers)


def saved_map_test(coloc, tmp, artefacts):
    ok = True
    seq = room_twin(coloc, tmp)
    if seq is None:
        return False
    db = os.path.join(tmp, "room.db")
    m = run([coloc, "map", "--sequence", seq, "--config", os.path.join(seq, "camera.yaml"),
             "--trajectory", os.path.join(tmp, "t.txt"), "--save", db, "--json"])
    if m.returncode != 0:
        print("map failed:", m.stderr[-2000:])
        return False
    scan_markers = marker_yaml(os.path.join(os.path.dirname(seq), "groundtruth", "markers.txt"),
                               os.path.join(tmp, "markers.yaml"))
    # Registered to the scan's (true) markers: the view then shows both marker sets in one
    # frame, and the registration's residuals.
    registered = os.path.join(tmp, "room_scan.db")
    report = os.path.join(tmp, "report")
    reg = run([coloc, "register", "--map", db, "--markers", os.path.join(tmp, "markers.yaml"),
               "--out", registered, "--report", report, "--min-markers", "2", "--json"])
    if reg.returncode != 0:
        print("register failed:", reg.stderr[-2000:])
        return False
    registration = json.loads(reg.stdout)
    db = registered
    info = json.loads(run([coloc, "mapdb", "info", db, "--json"]).stdout)
    view = subprocess.Popen([coloc, "view", db, "--port", "0", "--json", "--sequence", seq,
                             "--markers", os.path.join(tmp, "markers.yaml"), "--report", report],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        served = json.loads(view.stdout.readline())
        print("coloc view:", served)
        shot = os.path.join(artefacts, "view_saved_map.png")
        p = page("saved", served["url"], shot)
        ok &= check("page loaded", p is not None)
        if p:
            print("page:", json.dumps(p))
            c = p["counts"]
            ok &= check("keyframes", c["keyframes"] == info["keyframes"] == served["keyframes"],
                        (c["keyframes"], info["keyframes"]))
            ok &= check("map points", c["points"] == info["map_points"], c["points"])
            ok &= check("SLAM markers", c["slam_markers"] == served["slam_markers"] > 0,
                        c["slam_markers"])
            ok &= check("scan markers", c["scan_markers"] == scan_markers > 0, c["scan_markers"])
            ok &= check("scene drawn", p["canvas_colours"] > 8, p["canvas_colours"])
            ok &= check("scan frame", c["frame"] == "scan", c["frame"])
            ok &= check("registration residuals", p["registration"]["shown"]
                        and p["registration"]["markers"] == len(registration["rough"]["markers"]),
                        p["registration"])
            panel = p["panel"]
            ok &= check("clicked keyframe shown", panel["id"] == p["clicked"] == panel["selected"])
            ok &= check("its image", panel["loaded"] == str(p["clicked"])
                        and panel["natural_width"] == 640, panel)
            ok &= check("its keypoints", panel["tracked"] > 50, panel["tracked"])
            ok &= check("no page errors", not p["page_errors"], p["page_errors"])
            ok &= check("screenshot", os.path.getsize(shot) > 10000, shot)

        # Bad input: the port is taken (by this viewer), the map file is damaged.
        busy = run([coloc, "view", db, "--port", str(served["port"]), "--seconds", "0"])
        ok &= check("busy port", busy.returncode == 1 and "in use" in busy.stderr,
                    busy.stderr.strip())
    finally:
        view.send_signal(signal.SIGINT)
        rc = view.wait(timeout=30)
    ok &= check("Ctrl-C stops the viewer", rc == 0, rc)
    bad = os.path.join(tmp, "bad.db")
    with open(bad, "wb") as f:
        f.write(b"not a map" * 100)
    r = run([coloc, "view", bad, "--port", "0", "--seconds", "0"])
    ok &= check("damaged map", r.returncode == 1 and "bad.db" in r.stderr, r.stderr.strip()[-300:])
    return ok


def room_twin(coloc, tmp):
    """A 6 s twin room without a scan; its sequence folder, or None (the reason is printed)."""
    twin = os.path.join(tmp, "room")
    g = run([coloc, "twin", "generate", "--preset", "room", "--seed", "1", "--seconds", "6",
             "--no-scan", "--out", twin])
    if g.returncode != 0:
        print("twin failed:", g.stderr[-2000:])
        return None
    return os.path.join(twin, "sequence")


def live_test(coloc, tmp, artefacts):
    ok = True
    seq = room_twin(coloc, tmp)
    if seq is None:
        return False
    traj = os.path.join(tmp, "live.txt")
    # A port in use: the run goes on without a viewer.
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        busy = s.getsockname()[1]
        r = run([coloc, "map", "--sequence", seq, "--trajectory", traj, "--view", "--view-port",
                 str(busy), "--json"])
    ok &= check("busy port: the run goes on", r.returncode == 0 and "viewer not started" in r.stderr
                and json.loads(r.stdout)["frames"] > 150, r.stderr[-300:])
    reference_frames = json.loads(r.stdout)["frames"]

    # Sequential mapping and 30 pushed frames/s: the page has time to see the camera move.
    cmd = [coloc, "map", "--sequence", seq, "--trajectory", traj, "--sequential", "--view",
           "--view-port", "0", "--view-wait", "60", "--view-fps", "30", "--view-linger", "1", "--json"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    url = None
    log = []
    for line in proc.stderr:
        log.append(line)
        found = re.search(r"viewer at (http://\S+/)", line)
        if found:
            url = found.group(1)
            break
    ok &= check("viewer announced", url is not None, "".join(log)[-500:])
    p = page("live", url, os.path.join(artefacts, "view_live.png"), 60) if url else None
    out, err = proc.communicate(timeout=300)
    err = "".join(log) + err
    ok &= check("map run succeeded", proc.returncode == 0, err[-1500:])
    ok &= check("page saw frames", p is not None and len(p["frames"]) >= 3,
                p and len(p["frames"]))
    if p and len(p["frames"]) >= 2:
        frames = p["frames"]
        print("frames seen:", [(f["index"], f["state"], f["shown"]) for f in frames])
        idx = [f["index"] for f in frames]
        ok &= check("frame index advances", idx == sorted(idx) and len(set(idx)) == len(idx), idx)
        poses = [f["pose"] for f in frames if f["pose"]]
        # The twin's walk starts with a pan on the spot: the camera turns before it travels.
        moved = max((sum((a - b) ** 2 for a, b in zip(q[4:], poses[0][4:])) ** 0.5
                     for q in poses), default=0.0)
        turned = max((2 * math.degrees(math.acos(min(1.0, abs(sum(
            a * b for a, b in zip(q[:4], poses[0][:4])))))) for q in poses), default=0.0)
        ok &= check("pose advances", len(poses) >= 2 and (moved > 0.005 or turned > 2.0),
                    "%.3f m, %.1f deg" % (moved, turned))
        ok &= check("keypoints pushed", max(f["keypoints"] for f in frames) > 100)
        ok &= check("no page errors", not p["page_errors"], p["page_errors"])
        ok &= check("the growing map on the page", p["counts"]["keyframes"] > 0, p["counts"])
    summary = json.loads(out) if out.strip() else {}
    ok &= check("the run is complete", summary.get("frames") == reference_frames, summary)
    gone = re.search(r"(\d+) pages \((\d+) gone\)", err)
    ok &= check("the page left mid-stream and was counted",
                gone is not None and int(gone.group(2)) >= 1, gone and gone.group(0))
    return ok


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--coloc", required=True)
    ap.add_argument("--live", action="store_true")
    ap.add_argument("--artefacts", default=os.getcwd())
    a = ap.parse_args()
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    for need, what in ((shutil.which("node"), "node (Debian package nodejs)"),
                       (os.path.exists(chromium), "chromium (scripts/install_deps.sh)"),
                       (PLAYWRIGHT.exists(), "playwright-core (scripts/install_web)")):
        if not need:
            print("skipped: missing", what)
            return 77
    os.makedirs(a.artefacts, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        ok = live_test(a.coloc, tmp, a.artefacts) if a.live else \
            saved_map_test(a.coloc, tmp, a.artefacts)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
