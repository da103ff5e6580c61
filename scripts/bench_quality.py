#!/usr/bin/python3
"""Segmentation-quality benchmark on generated sequences (no real data needed).

For each scene, seed and error level of the simulated detector, `cuefusion synth`
renders the scene (640x480, Kinect depth noise on), `cuefusion run` maps it in the
geometry, masks and fused modes with its own tracking (ICP), and `cuefusion eval`
scores every run against the exact truth: mean per-frame object IoU (final map seen from
the estimated poses, Hungarian matching), 3D instance AP / AP50 / AP25 (ScanNet
definition, class-agnostic), ATE, and how the map's segments cover the truth (segments of
>= 100 voxels in segments.json against the scene's objects and stuff surfaces, objects
over-segmented, segments holding two objects). Geometry mode does not read masks, so it
runs once per scene and seed. `--compare-binary OLD` also runs the fused mode with another
build on the same sequences (scored by this build's eval). `--distance MIN-MAX` views
each scene from across a room instead: per scene and seed a distance drawn uniformly in
[MIN, MAX] m and an elevation in 15-30 degrees (a hand-held camera looking at a table from
standing height), the scene's own azimuths, and the runs given the true poses
(`--use-gt-poses`: tracking is not the question). Scenes named kitchen, office or living
are random rooms instead (`cuefusion synth --room TYPE --seed SEED`: a new room per seed,
3-6 m across, a hand-held path from 1-4 m, `--room-frames` frames); for them the report
adds the mean object IoU by object size (largest side < 0.3 m, 0.3-1 m, >= 1 m, stuff
included) and segments per object and stuff surface; `--true-poses` gives any scene's runs
the true poses (segmentation alone). Prints Markdown for
docs/benchmarks.md: medians over seeds, with min-max.
"""
import argparse
import csv
import datetime
import json
import math
import os
import random
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_reconstruction import machine  # noqa: E402

SCENES = ["tabletop", "clutter"]
ROOMS = ["kitchen", "office", "living"]  # random rooms (cuefusion synth --room)
SIZES = [("small (< 0.3 m)", 0.0, 0.3), ("medium (0.3–1 m)", 0.3, 1.0), ("large (≥ 1 m)", 1.0, float("inf"))]
# Simulated detector settings (cuefusion synth --mask-* options). Merges and splits are
# drawn per pair/mask and frame, as real networks fail in some views and not in others.
LEVELS = [
    ("perfect", []),
    ("typical", ["--mask-boundary", "2", "--mask-jitter", "2", "--mask-merge", "0.1", "--mask-miss", "0.05",
                 "--mask-false-positives", "0.2"]),
    ("merging", ["--mask-boundary", "1", "--mask-jitter", "1", "--mask-merge", "0.3", "--mask-miss", "0.05"]),
    ("leaky", ["--mask-boundary", "6", "--mask-jitter", "2", "--mask-false-positives", "0.5"]),
    ("splitting", ["--mask-boundary", "-3", "--mask-jitter", "1", "--mask-split", "0.2", "--mask-miss", "0.1"]),
    ("harsh", ["--mask-boundary", "3", "--mask-jitter", "4", "--mask-merge", "0.3", "--mask-miss", "0.25",
               "--mask-false-positives", "1", "--mask-split", "0.1"]),
    # Not simulated: cuefusion's own network (data/models/xyz_instances.onnx) on each depth frame.
    ("network", []),
]
NETWORK = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "models", "xyz_instances.onnx")
SCENE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "scenes")


def far_scene(scene, seed, distance_range, out):
    """The bundled `scene` seen from a distance drawn in `distance_range` (m) at an elevation of
    15-30 degrees, on its own azimuths; returns (scene file, distance, elevation)."""
    rng = random.Random("%s-%d" % (scene, seed))
    distance = rng.uniform(*distance_range)
    elevation = rng.uniform(15.0, 30.0)
    lines = []
    for line in open(os.path.join(SCENE_DIR, scene + ".scene")).read().splitlines():
        if line.startswith("trajectory "):
            fields = dict(f.split("=", 1) for f in line.split()[1:])
            fields["radius"] = "%.4f" % (distance * math.cos(math.radians(elevation)))
            fields["height"] = "%.4f" % (distance * math.sin(math.radians(elevation)))
            line = "trajectory " + " ".join("%s=%s" % kv for kv in fields.items())
        lines.append(line)
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    return out, distance, elevation
MODES = ["geometry", "masks", "fused"]


def run(cmd):
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit("bench_quality: %s failed (exit %d): %s" % (" ".join(cmd), done.returncode, done.stderr.strip()[-2000:]))


def iou_by_size(seq, report_dir):
    """Mean object IoU of the instances in each of SIZES (by the largest side of their box)."""
    with open(os.path.join(seq, "scene.json")) as f:
        sizes = {i["id"]: max(i["size"]) for i in json.load(f)["instances"]}
    by_size = {name: [] for name, _, _ in SIZES}
    with open(os.path.join(report_dir, "object_iou.csv")) as f:
        for row in csv.DictReader(f):
            extent = sizes[int(row["instance"])]
            for name, lo, hi in SIZES:
                if lo <= extent < hi:
                    by_size[name].append(float(row["mean_iou"]))
    return {name: statistics.mean(v) if v else float("nan") for name, v in by_size.items()}


def evaluate(binary, seq, run_dir, report_dir):
    run([binary, "eval", "--run", run_dir, "--gt", seq, "--out", report_dir, "--no-plots"])
    with open(os.path.join(report_dir, "report.json")) as f:
        r = json.load(f)["runs"][0]
    with open(os.path.join(run_dir, "segments.json")) as f:
        segments = json.load(f)["segments"]
    ap = r["instance_ap"]["class_agnostic"]
    counts = r["instance_ap"].get("segmentation", {})
    return {"iou": r["object_iou"]["mean"] or 0.0, "ap": ap["ap"], "ap50": ap["ap50"], "ap25": ap["ap25"],
            "ate": r["tracking"]["ate"]["rmse"] if r["tracking"] else float("nan"),
            "segments": sum(1 for s in segments if s["voxels"] >= 100),
            "per_surface": sum(1 for s in segments if s["voxels"] >= 100) / scene_objects(seq),
            "by_size": iou_by_size(seq, report_dir),
            "over": counts.get("over_segmented", float("nan")), "under": counts.get("under_segmented", float("nan"))}


def cell(values, fmt="{:.2f}"):
    values = [v for v in values if v == v]
    if not values:
        return "n/a"
    med = statistics.median(values)
    if len(values) == 1 or min(values) == max(values):
        return fmt.format(med)
    return (fmt + " ({}–{})").format(med, fmt.format(min(values)), fmt.format(max(values)))


def scene_objects(seq):
    """Objects and stuff surfaces some frame measured (points in gt_cloud.pcd)."""
    with open(os.path.join(seq, "scene.json")) as f:
        return sum(1 for i in json.load(f)["instances"] if i.get("gt_points", 1) > 0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="build/apps/cuefusion")
    parser.add_argument("--compare-binary", help="another build whose fused mode runs on the same sequences")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--model", default=NETWORK, help="the network of the `network` level (default: the shipped one)")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--room-frames", type=int, default=150, help="frames of a room's sequence")
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--levels", default=",".join(name for name, _ in LEVELS))
    parser.add_argument("--distance", help="MIN-MAX: view the scenes from this far (m, drawn per seed) with the true poses")
    parser.add_argument("--true-poses", action="store_true",
                        help="give the runs the true poses (--use-gt-poses): segmentation alone, tracking not the question")
    parser.add_argument("--sensor", default="kinect", choices=["kinect", "realsense"],
                        help="the depth sensor `cuefusion synth --noise` imitates")
    args = parser.parse_args()
    distance_range = tuple(float(v) for v in args.distance.split("-")) if args.distance else None
    drawn = []
    scenes = args.scenes.split(",")
    levels = [(n, o) for n, o in LEVELS if n in args.levels.split(",")]
    modes = MODES + (["fused (before)"] if args.compare_binary else [])
    results = {}  # (scene, level, mode) -> list of score dicts
    objects = {}
    with tempfile.TemporaryDirectory(prefix="cuefusion-quality-") as tmp:
        for scene in scenes:
            for seed in range(1, args.seeds + 1):
                geometry = None
                for level, options in levels:
                    seq = os.path.join(tmp, f"seq-{scene}-{seed}-{level}")
                    scene_arg = scene
                    if distance_range:
                        scene_arg, distance, elevation = far_scene(scene, seed, distance_range, seq + ".scene")
                        if level == levels[0][0]:
                            drawn.append(f"{scene} seed {seed}: {distance:.2f} m, {elevation:.0f}°")
                    source = ["--room", scene, "--frames", str(args.room_frames)] if scene in ROOMS else \
                        ["--scene", scene_arg, "--frames", str(args.frames)]
                    run([args.binary, "synth"] + source + ["--layout", "redwood",
                         "--noise", "--sensor", args.sensor, "--seed", str(seed), "--out", seq] + options)
                    objects.setdefault(scene, set()).add(scene_objects(seq))
                    for mode in modes:
                        if mode == "geometry" and geometry is not None:
                            results.setdefault((scene, level, mode), []).append(geometry)
                            continue
                        out = os.path.join(tmp, f"run-{scene}-{seed}-{level}-{mode.split()[0]}{'-before' if 'before' in mode else ''}")
                        binary = args.compare_binary if "before" in mode else args.binary
                        cmd = [binary, "run", seq, "--out", out, "--mode", mode.split()[0]] + \
                            (["--use-gt-poses"] if distance_range or args.true_poses else [])
                        if mode != "geometry":
                            cmd += ["--model", args.model] if level == "network" else ["--masks", os.path.join(seq, "detections")]
                        run(cmd)
                        scores = evaluate(args.binary, seq, out, out + "-report")
                        if mode == "geometry":
                            geometry = scores
                        results.setdefault((scene, level, mode), []).append(scores)
                        print(f"{scene} seed {seed} {level:9s} {mode:14s} IoU {scores['iou']:.3f} AP50 {scores['ap50']:.3f} "
                              + " ".join(f"{k.split()[0]} {v:.2f}" for k, v in scores["by_size"].items()) + " "
                              f"AP25 {scores['ap25']:.3f} segments {scores['segments']} over {scores['over']} "
                              f"under {scores['under']} ATE {scores['ate']*100:.2f} cm", file=sys.stderr)
                    subprocess.run(["rm", "-rf", seq] + [os.path.join(tmp, d) for d in os.listdir(tmp) if d.startswith("run-")])
    print("### Segmentation quality on generated sequences\n")
    only = "" if args.levels == ",".join(name for name, _ in LEVELS) else f" --levels {args.levels}"
    far = f" --distance {args.distance}" if distance_range else ""
    far += "" if args.sensor == "kinect" else f" --sensor {args.sensor}"
    far += " --true-poses" if args.true_poses else ""
    scenes_option = "" if args.scenes == ",".join(SCENES) else f" --scenes {args.scenes}"
    sensor = {"kinect": "Kinect depth noise", "realsense": "RealSense-like stereo depth (noise ∝ z², speckle, edge fattening, holes on dark surfaces)"}[args.sensor]
    print(f"Command: `scripts/bench quality {args.seeds}{only}{scenes_option}{far}` ({datetime.date.today()}, {machine()}). "
          f"Scenes {', '.join(scenes)}; {args.frames} frames ({args.room_frames} for a room) at 640×480 with {sensor}, "
          + (f"seen from {args.distance} m ({'; '.join(drawn)}), the true poses given; " if distance_range
             else "the true poses given; " if args.true_poses else "camera tracked by ICP; ") +
          f"seeds 1–{args.seeds} (noise and detector errors). "
          "Scores: mean per-frame object IoU of the final map seen from the estimated poses; class-agnostic "
          "3D instance AP of map.pcd against gt_cloud.pcd (ScanNet definition); segments of ≥ 100 voxels in "
          "segments.json against the scene's objects and stuff surfaces; objects over-segmented and segments "
          "holding two objects (under) on gt_cloud.pcd; medians over seeds (min–max).\n")
    print("Detector levels (`cuefusion synth` options):\n")
    for level, options in levels:
        if level == "network":
            shown = os.path.relpath(os.path.abspath(args.model), os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
            print(f"- network: no simulated detector; `cuefusion run --model {shown}` "
                  "(cuefusion's own network on each frame)")
        else:
            print(f"- {level}: `{' '.join(options) if options else '(none)'}`")
    for scene in scenes:
        counts = sorted(objects[scene])
        shown = str(counts[0]) if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"
        print(f"\n#### {scene} ({shown} objects and stuff surfaces{', a new room per seed' if scene in ROOMS else ''})\n")
        print("| detector | mode | mean object IoU | AP50 | AP25 | AP | segments ≥ 100 voxels | over | under | ATE (cm) |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for level, _ in levels:
            for mode in modes:
                s = results[(scene, level, mode)]
                print(f"| {level if mode == 'geometry' else ''} | {mode} | {cell([x['iou'] for x in s])} | "
                      f"{cell([x['ap50'] for x in s])} | {cell([x['ap25'] for x in s])} | {cell([x['ap'] for x in s])} | "
                      f"{cell([x['segments'] for x in s], '{:.0f}')} | {cell([x['over'] for x in s], '{:.0f}')} | "
                      f"{cell([x['under'] for x in s], '{:.0f}')} | {cell([x['ate'] * 100 for x in s], '{:.2f}')} |")
    print("\nFused against geometry and masks alone (medians over seeds; ✓ = fused ≥ both):\n")
    print("| scene | detector | IoU fused / geometry / masks | AP50 fused / geometry / masks | |")
    print("|---|---|---|---|---|")
    for scene in scenes:
        for level, _ in levels:
            med = {m: {k: statistics.median(x[k] for x in results[(scene, level, m)]) for k in ("iou", "ap50")} for m in MODES}
            ok = all(med["fused"][k] >= med[m][k] for k in ("iou", "ap50") for m in ("geometry", "masks"))
            print(f"| {scene} | {level} | {med['fused']['iou']:.2f} / {med['geometry']['iou']:.2f} / {med['masks']['iou']:.2f} | "
                  f"{med['fused']['ap50']:.2f} / {med['geometry']['ap50']:.2f} / {med['masks']['ap50']:.2f} | {'✓' if ok else '✗'} |")
    rooms = [scene for scene in scenes if scene in ROOMS]
    if rooms:
        print("\nRooms: mean object IoU by object size (largest side of its box; stuff is large) and segments of ≥ 100 voxels "
              "per object and stuff surface (medians over seeds, min–max):\n")
        print("| room | detector | mode | " + " | ".join(name for name, _, _ in SIZES) + " | segments per surface |")
        print("|---|---|---|" + "---|" * len(SIZES) + "---|")
        for scene in rooms:
            for level, _ in levels:
                for mode in modes:
                    s = results[(scene, level, mode)]
                    print(f"| {scene} | {level} | {mode} | " + " | ".join(cell([x['by_size'][name] for x in s]) for name, _, _ in SIZES)
                          + f" | {cell([x['per_surface'] for x in s])} |")


if __name__ == "__main__":
    main()
