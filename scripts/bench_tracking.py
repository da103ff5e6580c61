#!/usr/bin/python3
"""Tracking against exact poses on generated sequences, with the events that break it.

`cuefusion synth` renders the tabletop orbit with Kinect depth noise (TUM layout), and the
script derives the cases from it by editing the frame lists (the renders are exact, so the
truth is too):
  - slow orbit: every frame of a 240-frame orbit;
  - fast orbit: the same orbit in 40 frames (6x the motion per frame);
  - gap: the 120-frame orbit with frames 50-69 missing (a jump of ~0.3 m and ~14 deg);
  - blackout: the 120-frame orbit with frames 50-59 without depth (a covered sensor);
  - return: frames 0-79, then frames 10-39 again (the camera back at an earlier view);
  - fastest orbit: the orbit in 12 frames (~16 cm and 7 deg a frame);
  - planar: a camera circling above a plain floor, nothing else in view (ICP degenerate:
    every frame after the first must be reported lost, none fused).
`cuefusion run` tracks each (geometry mode; the first frame at its true pose); the report
gives ATE (aligned RMSE over the frames reported tracked), the largest unaligned position
error of a frame reported tracked, frames lost, frames relocalised, and after the event
the share of frames tracked from the 5th frame on, and the frames tracked by the tracker as it
was before the motion model and the noise weights (`--no-motion-model --no-noise-weighting`).
Open3D 0.16 runs on the same frame lists, ATE over every frame: its RGB-D odometry
(frame-to-frame, hybrid term) and frame-to-model point-to-plane ICP (`bench_reconstruction.py`'s
peers). Then the real sequences (default ../shared/data/7scenes-redkitchen and
icl-livingroom1) against their shipped poses with the same peers. Prints Markdown for
docs/benchmarks.md.
"""
import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import ate_rmse, machine, read_tum, run_open3d  # noqa: E402

BINARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "apps", "cuefusion")


def synth(out, frames, size, scene="tabletop"):
    subprocess.run([BINARY, "synth", "--scene", scene, "--frames", str(frames), "--noise", "--size", size, "--out", out],
                   check=True, stdout=subprocess.DEVNULL)


PLANAR_SCENE = """scene planar
camera 640 480 525 525 319.5 239.5
trajectory target=0,0,0 radius=0.6 height=1.2 start=0 sweep=60 bob=0.0
object floor class=floor color=170,165,150 detectable=no texture=checker
  box center=0,0,-0.01 size=12,12,0.02
"""


def listing(root, name):
    lines = open(os.path.join(root, name)).read().splitlines()
    return [l for l in lines if l.startswith("#")], [l for l in lines if l.strip() and not l.startswith("#")]


def derive(base, out, order, blank=()):
    """A copy of the TUM folder `base` whose frames are base's frames in `order` (repeats get
    new timestamps 100 s later per pass, with their true poses); frames in `blank` get depth
    images of zeros."""
    shutil.copytree(base, out)
    heads = {}
    rows = {}
    for name in ("depth.txt", "rgb.txt", "groundtruth.txt"):
        heads[name], rows[name] = listing(base, name)
    seen = {}
    new = {name: [] for name in rows}
    for i in order:
        shift = 100.0 * seen.get(i, 0)
        seen[i] = seen.get(i, 0) + 1
        for name in ("depth.txt", "rgb.txt", "groundtruth.txt"):
            v = rows[name][i].split()
            new[name].append(" ".join(["%.6f" % (float(v[0]) + shift)] + v[1:]))
    for name in new:
        open(os.path.join(out, name), "w").write("\n".join(heads[name] + new[name]) + "\n")
    if blank:
        import cv2
        for i in blank:
            path = os.path.join(out, rows["depth.txt"][i].split()[1])
            depth = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            cv2.imwrite(path, np.zeros_like(depth))


def evaluate(seq, out, event, extra=()):
    shutil.rmtree(out, ignore_errors=True)
    proc = subprocess.run([BINARY, "run", seq, "--out", out, "--mode", "geometry"] + list(extra), capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("cuefusion run failed: " + proc.stderr.strip())
    tracking = json.load(open(os.path.join(out, "tracking.json")))
    lost = {l["index"] for l in tracking["lost"]}
    est = dict(read_tum(os.path.join(out, "trajectory.txt")))
    ref = dict(read_tum(os.path.join(out, "reference_trajectory.txt")))
    keys = sorted(set(est) & set(ref))
    errors = [float(np.linalg.norm(est[k][:3, 3] - ref[k][:3, 3])) for k in keys]
    frames = tracking["frames"]
    after = None
    if event is not None:
        window = [i for i in range(event + 5, frames)]
        after = sum(1 for i in window if i not in lost) / float(len(window)) if window else float("nan")
    loop = json.load(open(os.path.join(out, "timings.json")))["stages"]
    return {"frames": frames, "tracked": tracking["tracked"], "lost": len(lost), "relocalised": len(tracking.get("relocalised", [])),
            "ate": ate_rmse([est[k] for k in keys], [ref[k] for k in keys]) if len(keys) >= 3 else float("nan"),
            "max_error": max(errors) if errors else float("nan"), "after": after,
            "reloc_ms": loop.get("relocalise (lost frames only)", {}).get("median")}


BEFORE = ["--no-motion-model", "--no-noise-weighting"]  # the tracker before issue 23's second part


def open3d_ate(method, seq):
    r = run_open3d(method, seq, 0.01, 0.04, 5.0)
    return r["ate"] * 1000 if "ate" in r else None, r


def mm(value):
    return "-" if value is None or value != value else "%.1f" % value


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--real", nargs="*", default=[os.path.join(here, "..", "..", "shared", "data", d)
                                                  for d in ("7scenes-redkitchen", "icl-livingroom1")])
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="cuefusion-bench-tracking-")
    try:
        synth(os.path.join(work, "orbit240"), 240, args.size)
        synth(os.path.join(work, "orbit120"), 120, args.size)
        synth(os.path.join(work, "orbit40"), 40, args.size)
        synth(os.path.join(work, "orbit12"), 12, args.size)
        open(os.path.join(work, "planar.scene"), "w").write(PLANAR_SCENE)
        synth(os.path.join(work, "planar"), 30, args.size, os.path.join(work, "planar.scene"))
        cases = [
            ("slow orbit (240 frames)", os.path.join(work, "orbit240"), None),
            ("fast orbit (40 frames)", os.path.join(work, "orbit40"), None),
            ("fastest orbit (12 frames)", os.path.join(work, "orbit12"), None),
        ]
        derive(os.path.join(work, "orbit120"), os.path.join(work, "gap"), list(range(50)) + list(range(70, 120)))
        cases.append(("gap (frames 50-69 missing)", os.path.join(work, "gap"), 50))
        derive(os.path.join(work, "orbit120"), os.path.join(work, "blackout"), list(range(120)), blank=range(50, 60))
        cases.append(("blackout (frames 50-59 without depth)", os.path.join(work, "blackout"), 60))
        derive(os.path.join(work, "orbit120"), os.path.join(work, "return"), list(range(80)) + list(range(10, 40)))
        cases.append(("return (0-79, then 10-39 again)", os.path.join(work, "return"), 80))
        cases.append(("planar floor (30 frames)", os.path.join(work, "planar"), None))

        print("Tracking on generated sequences: `scripts/bench tracking` (%s; %s)\n" % (machine(), datetime.date.today().isoformat()))
        print("The tabletop orbit rendered by `cuefusion synth` at %s with Kinect depth noise; exact poses. cuefusion: "
              "`run --mode geometry`, ICP frame to model with noise weights and the motion model, failure detection and "
              "relocalisation on. ATE: RMSE after rigid alignment over the frames reported tracked; max: largest unaligned "
              "error of a frame reported tracked; after: share of the frames from the 5th after the event on that are "
              "tracked; before: frames tracked with `--no-motion-model --no-noise-weighting`. Open3D 0.16: RGB-D odometry "
              "frame to frame (hybrid term) and frame-to-model point-to-plane ICP, ATE over every frame.\n" % args.size)
        print("| sequence | frames | tracked | lost | relocalised | ATE (mm) | max (mm) | after the event | relocalisation ms (median) | tracked before | Open3D odometry ATE (mm) | Open3D frame-to-model ATE (mm) |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name, seq, event in cases:
            r = evaluate(seq, os.path.join(work, "run-" + os.path.basename(seq)), event)
            before = evaluate(seq, os.path.join(work, "before-" + os.path.basename(seq)), event, BEFORE)
            odometry, _ = open3d_ate("odometry", seq)
            f2m, _ = open3d_ate("frame_to_model", seq)
            print("| %s | %d | %d | %d | %d | %s | %s | %s | %s | %d | %s | %s |"
                  % (name, r["frames"], r["tracked"], r["lost"], r["relocalised"], mm(r["ate"] * 1000),
                     mm(r["max_error"] * 1000), "-" if r["after"] is None else "%.0f %%" % (100 * r["after"]),
                     "-" if r["reloc_ms"] is None else "%.0f" % r["reloc_ms"], before["tracked"], mm(odometry), mm(f2m)))

        print("\nReal sequences against their shipped reference poses (640x480, voxel 1 cm; the references "
              "are reconstructions themselves, see \"Reconstruction\"): cuefusion `run --mode geometry` as shipped and "
              "as before (`--no-motion-model --no-noise-weighting`), Open3D frame-to-model point-to-plane ICP and "
              "RGB-D odometry; ATE over every frame (cuefusion: the frames it tracked).\n")
        print("| dataset | frames | cuefusion tracked | cuefusion ATE (mm) | before ATE (mm) | Open3D frame-to-model ATE (mm) | Open3D odometry ATE (mm) | cuefusion / Open3D frame-to-model | Open3D frame-to-model ms/frame |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for root in args.real:
            name = os.path.basename(os.path.normpath(root))
            r = evaluate(root, os.path.join(work, "real-" + name), None)
            before = evaluate(root, os.path.join(work, "real-before-" + name), None, BEFORE)
            f2m, f2m_run = open3d_ate("frame_to_model", root)
            odometry, _ = open3d_ate("odometry", root)
            ms = sorted(f2m_run.get("times", [0]))[len(f2m_run.get("times", [0])) // 2]
            print("| %s | %d | %d | %s | %s | %s | %s | %s | %.0f |"
                  % (name, r["frames"], r["tracked"], mm(r["ate"] * 1000), mm(before["ate"] * 1000), mm(f2m), mm(odometry),
                     "-" if not f2m else "%.2f" % (r["ate"] * 1000 / f2m), ms))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
