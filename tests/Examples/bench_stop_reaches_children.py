#!/usr/bin/env python3
"""A chain of coloc verbs ends with the coloc that started it: `coloc bench site` killed outright
(SIGKILL: no handler runs) while its first stage, a twin generation, runs as its child. The
child must end too (the kernel's parent-death signal), before it finishes its stage: its
twin.yaml, written last, must not appear. Before the fix, a stopped bench left a site
registration running for 40 minutes.

Paced by events (the child appearing, the child gone), not by sleeps: the polls only wait.
Exit 0 on success, 1 on failure.
"""
import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time


def children_of(pid):
    """Process ids whose parent is `pid` (from /proc)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(entry))
    return out


def alive(pid):
    """True while `pid` exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--coloc", required=True)
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        # A survey long enough that its generation is still running when the bench is killed.
        bench = subprocess.Popen([args.coloc, "bench", "site", tmp, "--preset", "room",
                                  "--survey-seconds", "600"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        child = None
        while child is None and bench.poll() is None:
            kids = children_of(bench.pid)
            child = kids[0] if kids else None
            time.sleep(0.05)
        if child is None:
            print("check failed: the bench ended before starting a stage:", bench.returncode)
            return 1
        # The stage has started when the child runs coloc (not the moment between fork and exec).
        while alive(child):
            try:
                with open(f"/proc/{child}/cmdline", "rb") as f:
                    if b"generate" in f.read():
                        break
            except OSError:
                break
            time.sleep(0.05)
        bench.send_signal(signal.SIGKILL)
        bench.wait()
        while alive(child):
            time.sleep(0.05)
        finished = os.path.exists(os.path.join(tmp, "site", "twin.yaml"))
        print("child", child, "gone; its stage finished:", finished)
        if finished:
            print("check failed: the child ran its stage to the end after the bench was killed")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
