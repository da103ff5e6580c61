#!/usr/bin/python3
"""Dataset-scale throughput of `cuefusion batch` on generated sequences.

Renders N sequences (`cuefusion synth`, 640x480, Kinect noise; the tabletop and clutter
scenes with different seeds), then processes all of them, each time into a fresh folder:
  - a plain shell loop (`cuefusion run` then `cuefusion eval` per sequence, one after the
    other): what a user writes without batch, the peer;
  - `cuefusion batch --eval --jobs 1`;
  - `cuefusion batch --eval --jobs 2`.
Every pass maps each sequence in fused mode with the simulated detector's masks and its own
tracking, and evaluates it against the exact truth. The three passes are repeated
(interleaved, so drifts of this shared machine hit all alike); the report gives medians of
wall-clock sequences per hour and the ratios, and the batch's dataset AP pooled over the
sequences beside the mean of per-sequence APs. Prints Markdown for docs/benchmarks.md.
"""
import argparse
import datetime
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import machine  # noqa: E402

BINARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "apps", "cuefusion")


def quiet(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def timed(fn):
    t0 = time.monotonic()
    fn()
    return time.monotonic() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sequences", type=int, default=8)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="cuefusion-bench-batch-")
    try:
        seqs = []
        for k in range(args.sequences):
            scene = ["tabletop", "clutter"][k % 2]
            seq = os.path.join(work, "%s-%d" % (scene, k // 2 + 1))
            quiet([BINARY, "synth", "--scene", scene, "--frames", str(args.frames), "--noise", "--seed", str(k // 2 + 1),
                   "--mask-boundary", "2", "--mask-jitter", "2", "--mask-merge", "0.1", "--out", seq])
            seqs.append(seq)

        def shell_loop(out):
            os.makedirs(out)
            for s in seqs:
                r = os.path.join(out, os.path.basename(s))
                quiet([BINARY, "run", s, "--out", r, "--masks", os.path.join(s, "detections")])
                quiet([BINARY, "eval", "--run", r, "--gt", s, "--out", os.path.join(r, "eval"), "--no-plots"])

        def batch(jobs):
            def go(out):
                quiet([BINARY, "batch"] + seqs + ["--out", out, "--eval", "--jobs", str(jobs), "--masks", "detections"])
            return go

        passes = [("shell loop (run + eval, one after the other)", shell_loop),
                  ("`cuefusion batch --eval --jobs 1`", batch(1)),
                  ("`cuefusion batch --eval --jobs 2`", batch(2))]
        seconds = {name: [] for name, _ in passes}
        summary = None
        for rep in range(args.repeats):
            for i, (name, fn) in enumerate(passes):
                out = os.path.join(work, "out-%d-%d" % (rep, i))
                seconds[name].append(timed(lambda: fn(out)))
                if fn is not shell_loop:
                    with open(os.path.join(out, "summary.json")) as f:
                        summary = json.load(f)
                shutil.rmtree(out)

        print("Batch throughput: `scripts/bench batch %d %d %d` (%s; %s)\n"
              % (args.sequences, args.frames, args.repeats, machine(), datetime.date.today().isoformat()))
        print("%d generated sequences (tabletop and clutter, 640x480, %d frames each, Kinect noise), each mapped in fused "
              "mode with the simulated detector's masks (typical errors) and its own ICP tracking, then evaluated against "
              "the exact truth (per-frame object IoU over every frame, 3D AP). Medians of %d passes, interleaved.\n"
              % (args.sequences, args.frames, args.repeats))
        print("| how | wall s (median, min-max) | sequences / hour | frames / s | vs shell loop |")
        print("|---|---:|---:|---:|---:|")
        base = statistics.median(seconds[passes[0][0]])
        for name, _ in passes:
            s = statistics.median(seconds[name])
            print("| %s | %.1f (%.1f-%.1f) | %.0f | %.1f | x%.2f |"
                  % (name, s, min(seconds[name]), max(seconds[name]), args.sequences * 3600.0 / s,
                     args.sequences * args.frames / s, base / s))
        if summary:
            a = summary["aggregate"][0]
            iap = a["instance_ap"]
            print("\nThe last batch's summary: %d of %d sequences ok, mean ATE %.4f m, mean object IoU %.3f; AP / AP50 / AP25 "
                  "pooled over the sequences (ScanNet) %.3f / %.3f / %.3f, mean of per-sequence values %.3f / %.3f / %.3f."
                  % (a["succeeded"], a["sequences"], a["mean_ate_rmse_m"], a["mean_object_iou"], iap["pooled"]["ap"],
                     iap["pooled"]["ap50"], iap["pooled"]["ap25"], iap["mean_of_sequences"]["ap"],
                     iap["mean_of_sequences"]["ap50"], iap["mean_of_sequences"]["ap25"]))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
