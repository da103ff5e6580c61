#!/usr/bin/python3
"""Geometric segmentation benchmark on the OSD learn clouds ($DATA/osd-learn, docs/design.md).

In one run, on the same clouds:
  * cuefusion `segment-frame --drop-support-plane` (defaults), scored with
    the data set's osd_eval.py ($DATA/../tools; overlap and boundary P/R/F, %75), ms per 640x480 frame
    per stage (median over all clouds, median of --repeat runs);
  * the PCL peer (build/apps/cuefusion_pcl_peer_segmentation: OrganizedMultiPlane-
    Segmentation for planes + OrganizedConnectedComponentSegmentation with
    EuclideanClusterComparator), scored and timed the same way;
  * ablations of cuefusion's choices (thesis tangent-plane convexity test, no edge
    assignment, one closing, integral-image normals, ...);
  * the instance cue: masks derived from the OSD ground truth with the synthetic
    generator's detector error model (build/apps/cuefusion_bench_osd_masks), several
    error settings, each scored geometry-only, masks-only and fused;
  * cuefusion's own network (data/models/xyz_instances.onnx, trained on synthetic views
    only): masks alone and fused, and what it adds per frame (segment-frame with and
    without it, same run); --network-only runs just this part;
  * normal accuracy on noisy synthetic views (build/apps/cuefusion_bench_normals).
Everything is printed as Markdown, ready for docs/benchmarks.md.
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

STAGES = ["smoothing_ms", "normals_ms", "edges_ms", "labeling_ms", "segmentation_ms", "plane_ms"]
PEER_STAGES = ["normals_ms", "planes_ms", "clusters_ms", "segmentation_ms"]

ABLATIONS = [
    ("thesis convexity test (tangent plane)", ["--convexity-test", "tangent"]),
    ("no edge assignment (edge pixels stay 0)", ["--edge-radius", "0"]),
    ("one closing instead of two", ["--closings", "1"]),
    ("central differences ±2 px", ["--normal-step", "2"]),
    ("integral-image normals", ["--normals", "integral"]),
    ("bilateral range 5 σ_z instead of 8", ["--range-sigma", "5"]),
    ("no concavity edges", ["--no-concavity"]),
    ("no depth-discontinuity edges", ["--no-depth-edges"]),
]


def score(evaluator, gt, pred, tmp):
    out = os.path.join(tmp, "score.json")
    subprocess.run([sys.executable, evaluator, "--gt-dir", gt, "--pred-dir", pred, "--quiet", "--jobs", "2", "--out", out],
                   check=True, stdout=subprocess.DEVNULL)
    return json.load(open(out))["mean_percent"]


def medians(timing_files, keys):
    """Per key: median over frames of each run, then the median over runs."""
    runs = [json.load(open(f))["frames"] for f in timing_files]
    return {k: statistics.median(statistics.median(f[k] for f in frames) for frames in runs) for k in keys}


def run_ours(binary, data, out, extra, timings):
    subprocess.run([binary, "segment-frame", data, "--out", out, "--drop-support-plane", "--timings", timings] + extra,
                   check=True, stdout=subprocess.DEVNULL)


MASK_SETTINGS = [
    ("perfect masks", ["--dilate", "0", "--jitter", "0", "--merge", "0", "--miss", "0"]),
    ("typical network (dilate 2 px ± 1, merge 0.2, miss 0.1)", []),
    ("issue 18's typical detector (boundary +1…+5 px, merge 0.1, miss 0.05, 0.2 false positives)",
     ["--dilate", "3", "--jitter", "2", "--merge", "0.1", "--miss", "0.05", "--false-positives", "0.2"]),
    ("shrinking and splitting (erode 3 px ± 1, split 0.2, miss 0.1)",
     ["--dilate", "-3", "--jitter", "1", "--merge", "0", "--miss", "0.1", "--split", "0.2"]),
    ("leaky masks (dilate 6 px ± 2)", ["--dilate", "6", "--jitter", "2", "--merge", "0", "--miss", "0"]),
    ("merging network (every touching pair merged)", ["--dilate", "2", "--jitter", "1", "--merge", "1", "--miss", "0"]),
    ("missing network (miss 0.5)", ["--dilate", "2", "--jitter", "1", "--merge", "0", "--miss", "0.5"]),
]


def fmt_scores(s):
    return "%.1f | %.1f | **%.1f** | %.1f | %.1f | **%.1f** | %.1f" % (
        s["overlap_P"], s["overlap_R"], s["overlap_F"], s["boundary_P"], s["boundary_R"], s["boundary_F"], s["pct_075"])


NETWORK = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "models", "xyz_instances.onnx")


def network_section(binary, osd, evaluator, tmp, repeat, model=NETWORK):
    """The shipped network (or `model`) on the real clouds: scores per mode, and per-frame
    time with and without it (median over clouds, median of `repeat` runs, all in this run)."""
    shown = os.path.relpath(os.path.abspath(model), os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    print("\n| cuefusion's network (`--model %s`) | mode | O-P | O-R | O-F | B-P | B-R | B-F "
          "| %%75 | ms per frame (segmentation + masks) |" % shown)
    print("|---|---|---|---|---|---|---|---|---|---|")
    totals = {}
    for mode in ("geometry", "masks", "fused"):
        timings = []
        for r in range(repeat):
            pred = os.path.join(tmp, "net_" + mode)
            timings.append(os.path.join(tmp, "net_%s_%d.json" % (mode, r)))
            subprocess.run(["rm", "-rf", pred])
            extra = [] if mode == "geometry" else ["--model", model, "--mode", mode]
            run_ours(binary, osd, pred, extra, timings[-1])
        s = score(evaluator, osd, pred, tmp)
        t = medians(timings, ["segmentation_ms", "masks_ms"])
        totals[mode] = t["segmentation_ms"] + t["masks_ms"]
        print("| %s | %s | %s | %.1f + %.1f |" % ("shipped network" if mode == "geometry" else "", mode, fmt_scores(s),
                                                t["segmentation_ms"], t["masks_ms"]))
    print("\nThe network adds %.1f ms per 640×480 frame in fused mode (%.1f with it, %.1f without; medians, same run)."
          % (totals["fused"] - totals["geometry"], totals["fused"], totals["geometry"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("osd", help="folder of mOSD clouds (e.g. $CUEFUSION_BENCH_DATA/osd-learn)")
    parser.add_argument("--evaluator", default=None,
                        help="the data set's osd_eval.py (default: tools/osd_eval.py beside the OSD folder's parent)")
    parser.add_argument("--build", default="build/apps")
    parser.add_argument("--repeat", type=int, default=3, help="timing runs (the median is reported)")
    parser.add_argument("--no-ablations", action="store_true")
    parser.add_argument("--network-only", action="store_true", help="only the shipped network's section")
    parser.add_argument("--model", default=NETWORK, help="the network of that section (default: the shipped one)")
    args = parser.parse_args()
    if args.evaluator is None:
        args.evaluator = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(args.osd))), "tools", "osd_eval.py")
    if not os.path.isfile(args.evaluator):
        sys.exit("bench_segmentation: no scorer %s (give --evaluator PATH)" % args.evaluator)
    binary = os.path.join(args.build, "cuefusion")
    peer = os.path.join(args.build, "cuefusion_pcl_peer_segmentation")
    clouds = len([f for f in os.listdir(args.osd) if f.endswith(".pcd")])

    print("## Geometric segmentation (%s)\n" % datetime.date.today().isoformat())
    print("- machine: %s" % machine())
    print("- command: `scripts/bench segmentation %s%s`" % (args.osd, " --network-only" if args.network_only else ""))
    print("- data: %s (%d clouds, 640×480); scored with osd_eval.py (objects = GT label // 10; a segment on "
          "the table counts against precision)\n" % (args.osd, clouds))
    if args.network_only:
        with tempfile.TemporaryDirectory() as tmp:
            network_section(binary, args.osd, args.evaluator, tmp, args.repeat, args.model)
        return
    with tempfile.TemporaryDirectory() as tmp:
        ours_t, peer_t = [], []
        for r in range(args.repeat):
            ours_t.append(os.path.join(tmp, "ours%d.json" % r))
            run_ours(binary, args.osd, os.path.join(tmp, "ours"), [], ours_t[-1])
            peer_t.append(os.path.join(tmp, "peer%d.json" % r))
            subprocess.run([peer, args.osd, os.path.join(tmp, "peer"), peer_t[-1]], check=True)
        ours = score(args.evaluator, args.osd, os.path.join(tmp, "ours"), tmp)
        theirs = score(args.evaluator, args.osd, os.path.join(tmp, "peer"), tmp)
        ot, pt = medians(ours_t, STAGES), medians(peer_t, PEER_STAGES)

        print("| system | O-P | O-R | O-F | B-P | B-R | B-F | %75 | ms per frame (median) |")
        print("|---|---|---|---|---|---|---|---|---|")
        print("| cuefusion segment-frame --drop-support-plane | %s | %.1f + plane %.1f |" % (
            fmt_scores(ours), ot["segmentation_ms"], ot["plane_ms"]))
        print("| PCL peer (multi-plane + Euclidean clusters) | %s | %.1f |" % (fmt_scores(theirs), pt["segmentation_ms"]))
        print("\ncuefusion stages (ms, median): " + ", ".join("%s %.2f" % (k[:-3], ot[k]) for k in STAGES))
        print("\nPCL peer stages (ms, median): " + ", ".join("%s %.2f" % (k[:-3], pt[k]) for k in PEER_STAGES))

        if not args.no_ablations:
            print("\n| ablation (one change from the defaults) | O-P | O-R | O-F | B-P | B-R | B-F | %75 | ms |")
            print("|---|---|---|---|---|---|---|---|---|")
            for name, extra in ABLATIONS:
                pred = os.path.join(tmp, "abl")
                timing = os.path.join(tmp, "abl.json")
                subprocess.run(["rm", "-rf", pred])
                run_ours(binary, args.osd, pred, extra, timing)
                s = score(args.evaluator, args.osd, pred, tmp)
                print("| %s (`%s`) | %s | %.1f |" % (name, " ".join(extra), fmt_scores(s),
                                                  medians([timing], ["segmentation_ms"])["segmentation_ms"]))
        print("\n| masks from the GT with the detector error model | mode | O-P | O-R | O-F | B-P | B-R | B-F | %75 | ms (segmentation + masks) |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        masker = os.path.join(args.build, "cuefusion_bench_osd_masks")
        for name, extra in MASK_SETTINGS:
            masks = os.path.join(tmp, "masks")
            subprocess.run(["rm", "-rf", masks])
            subprocess.run([masker, args.osd, masks] + extra, check=True)
            for mode in ("geometry", "masks", "fused"):
                pred = os.path.join(tmp, "pred_" + mode)
                timing = os.path.join(tmp, "t_" + mode + ".json")
                subprocess.run(["rm", "-rf", pred])
                run_ours(binary, args.osd, pred, ["--masks", masks, "--mode", mode], timing)
                s = score(args.evaluator, args.osd, pred, tmp)
                t = medians([timing], ["segmentation_ms", "masks_ms"])
                print("| %s | %s | %s | %.1f + %.1f |" % (name if mode == "geometry" else "", mode, fmt_scores(s),
                                                        t["segmentation_ms"], t["masks_ms"]))
        network_section(binary, args.osd, args.evaluator, tmp, args.repeat, args.model)
    scene = os.path.join(os.path.dirname(__file__), "..", "data", "scenes", "tabletop.scene")
    print()
    sys.stdout.flush()
    subprocess.run([os.path.join(args.build, "cuefusion_bench_normals"), scene, "8"], check=True)


if __name__ == "__main__":
    main()
