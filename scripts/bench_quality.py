#!/usr/bin/python3
"""Segmentation-quality benchmark on generated sequences (no real data needed).

For each seed and each error level of the simulated detector, `cuefusion synth` renders
the tabletop scene (640x480, Kinect depth noise on), `cuefusion run` maps it in the
geometry, masks and fused modes with its own tracking (ICP), and `cuefusion eval`
scores every run against the exact truth: mean per-frame object IoU (final map seen from
the estimated poses, Hungarian matching), 3D instance AP / AP50 / AP25 (ScanNet
definition, class-agnostic), ATE. Geometry mode does not read masks, so it runs once per
seed. Prints Markdown for docs/benchmarks.md: medians over seeds, with min-max.
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import machine  # noqa: E402

# Simulated detector settings (cuefusion synth --mask-* options).
LEVELS = [
    ("perfect", []),
    ("moderate", ["--mask-jitter", "2", "--mask-miss", "0.1", "--mask-false-positives", "0.3"]),
    ("harsh", ["--mask-boundary", "3", "--mask-jitter", "4", "--mask-merge", "0.3", "--mask-miss", "0.25",
               "--mask-false-positives", "1"]),
]
MODES = ["geometry", "masks", "fused"]


def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def evaluate(binary, seq, run_dir, report_dir):
    run([binary, "eval", "--run", run_dir, "--gt", seq, "--out", report_dir, "--no-plots"])
    with open(os.path.join(report_dir, "report.json")) as f:
        r = json.load(f)["runs"][0]
    ap = r["instance_ap"]["class_agnostic"]
    return {"iou": r["object_iou"]["mean"] or 0.0, "ap": ap["ap"], "ap50": ap["ap50"], "ap25": ap["ap25"],
            "ate": r["tracking"]["ate"]["rmse"] if r["tracking"] else float("nan")}


def cell(values, fmt="{:.2f}"):
    values = [v for v in values if v == v]
    if not values:
        return "n/a"
    med = statistics.median(values)
    if len(values) == 1:
        return fmt.format(med)
    return (fmt + " ({}–{})").format(med, fmt.format(min(values)), fmt.format(max(values)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="build/apps/cuefusion")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=60)
    args = parser.parse_args()
    results = {}  # (level, mode) -> list of score dicts
    with tempfile.TemporaryDirectory(prefix="cuefusion-quality-") as tmp:
        for seed in range(1, args.seeds + 1):
            geometry = None
            for level, options in LEVELS:
                seq = os.path.join(tmp, f"seq-{seed}-{level}")
                run([args.binary, "synth", "--scene", "tabletop", "--frames", str(args.frames), "--layout", "redwood",
                     "--noise", "--seed", str(seed), "--out", seq] + options)
                for mode in MODES:
                    if mode == "geometry" and geometry is not None:
                        results.setdefault((level, mode), []).append(geometry)
                        continue
                    out = os.path.join(tmp, f"run-{seed}-{level}-{mode}")
                    cmd = [args.binary, "run", seq, "--out", out, "--mode", mode]
                    if mode != "geometry":
                        cmd += ["--masks", os.path.join(seq, "detections")]
                    run(cmd)
                    scores = evaluate(args.binary, seq, out, out + "-report")
                    if mode == "geometry":
                        geometry = scores
                    results.setdefault((level, mode), []).append(scores)
                    print(f"seed {seed} {level:8s} {mode:8s} IoU {scores['iou']:.3f} AP50 {scores['ap50']:.3f} "
                          f"AP25 {scores['ap25']:.3f} ATE {scores['ate']*100:.2f} cm", file=sys.stderr)
    print("### Segmentation quality on generated sequences\n")
    print(f"Command: `scripts/bench quality` ({datetime.date.today()}, {machine()}). "
          f"Tabletop scene, {args.frames} frames at 640×480 with Kinect depth noise, camera tracked by ICP; "
          f"seeds 1–{args.seeds} (noise and detector errors; the scene is the same). "
          "Scores: mean per-frame object IoU of the final map seen from the estimated poses, and class-agnostic "
          "3D instance AP of map.pcd against gt_cloud.pcd (ScanNet definition); medians over seeds (min–max).\n")
    print("| detector | mode | mean object IoU | AP50 | AP25 | AP | ATE (cm) |")
    print("|---|---|---|---|---|---|---|")
    for level, options in LEVELS:
        for mode in MODES:
            s = results[(level, mode)]
            label = level + (" (" + " ".join(options) + ")" if options else "")
            print(f"| {label if mode == 'geometry' else ''} | {mode} | {cell([x['iou'] for x in s])} | "
                  f"{cell([x['ap50'] for x in s])} | {cell([x['ap25'] for x in s])} | {cell([x['ap'] for x in s])} | "
                  f"{cell([x['ate'] * 100 for x in s], '{:.2f}')} |")


if __name__ == "__main__":
    main()
