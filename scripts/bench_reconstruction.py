#!/usr/bin/python3
"""Reconstruction benchmark: cuefusion against Open3D 0.16 (Debian's python3-open3d) on the
same frames, voxel size and truncation, in one run.

For each dataset it measures
  * cuefusion `run` with tracking: ATE RMSE against the dataset's poses, per-stage
    milliseconds per frame (median, p90), peak memory;
  * cuefusion `run --use-gt-poses`: integrate + raycast with the reference poses;
  * Open3D ScalableTSDFVolume and (when present) the tensor VoxelBlockGrid on the CPU:
    integration ms per frame with the reference poses, peak memory;
  * Open3D RGB-D odometry (hybrid term) chained frame to frame: ATE and ms per frame.
Everything is printed as Markdown, ready for docs/benchmarks.md.
"""
import argparse
import datetime
import glob
import json
import os
import platform
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


# ---------------------------------------------------------------- datasets

def redwood_frames(root):
    depth = sorted(glob.glob(os.path.join(root, "depth", "*.png")))
    color = sorted(glob.glob(os.path.join(root, "image", "*.jpg")) + glob.glob(os.path.join(root, "image", "*.png")))
    lines = [l.split() for l in open(os.path.join(root, "trajectory.log")) if l.strip()]
    poses = [np.array([[float(x) for x in row] for row in lines[i + 1:i + 5]]) for i in range(0, len(lines), 5)]
    k = json.load(open(os.path.join(root, "camera_intrinsics.json")))["intrinsic_matrix"]
    return depth, color, poses, (k[0], k[4], k[6], k[7])  # column-major


def seven_scenes_frames(root):
    depth = sorted(glob.glob(os.path.join(root, "frame-*.depth.png")))
    color = [d.replace(".depth.png", ".color.jpg") for d in depth]
    poses = [np.loadtxt(d.replace(".depth.png", ".pose.txt")) for d in depth]
    k = np.loadtxt(os.path.join(root, "camera-intrinsics.txt"))
    return depth, color, poses, (k[0, 0], k[1, 1], k[0, 2], k[1, 2])


def tum_frames(root):
    """A TUM-layout folder as `cuefusion synth` writes it (depth.txt, rgb.txt in the same
    order, groundtruth.txt, intrinsics.txt "fx fy cx cy w h"); poses by nearest timestamp."""
    def listing(name):
        return [l.split() for l in open(os.path.join(root, name)) if l.strip() and not l.startswith("#")]
    depth = listing("depth.txt")
    color = listing("rgb.txt")
    truth = [(float(v[0]), [float(x) for x in v[1:]]) for v in listing("groundtruth.txt")]
    stamps = np.array([t for t, _ in truth])

    def pose(t):
        tx, ty, tz, x, y, z, w = truth[int(np.abs(stamps - t).argmin())][1]
        m = np.eye(4)
        m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        m[:3, 3] = [tx, ty, tz]
        return m
    k = [float(x) for x in open(os.path.join(root, "intrinsics.txt")).read().split()[:4]]
    return ([os.path.join(root, d[1]) for d in depth], [os.path.join(root, c[1]) for c in color],
            [pose(float(d[0])) for d in depth], tuple(k))


def load_dataset(root):
    if os.path.exists(os.path.join(root, "depth.txt")):
        return tum_frames(root)
    if os.path.exists(os.path.join(root, "trajectory.log")):
        return redwood_frames(root)
    return seven_scenes_frames(root)


# ---------------------------------------------------------------- metrics

def ate_rmse(estimate, reference):
    """Translational ATE after a rigid (Horn/Umeyama, no scale) alignment."""
    a = np.array([p[:3, 3] for p in estimate])
    b = np.array([p[:3, 3] for p in reference])
    ma, mb = a.mean(0), b.mean(0)
    u, _, vt = np.linalg.svd((a - ma).T @ (b - mb))
    d = np.eye(3)
    d[2, 2] = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ d @ u.T
    return float(np.sqrt((np.linalg.norm((r @ (a - ma).T).T + mb - b, axis=1) ** 2).mean()))


def read_tum(path):
    out = []
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        v = [float(x) for x in line.split()]
        x, y, z, w = v[4:8]
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        t = np.eye(4)
        t[:3, :3] = r
        t[:3, 3] = v[1:4]
        out.append((v[0], t))
    return out


def depth_residual_mm(depth_a, depth_b, k, t_b_a):
    """Median |z_b − z| of frame a's points moved into camera b by t_b_a (a check of a
    relative pose against the depth images themselves)."""
    fx, fy, cx, cy = k
    v, u = np.nonzero(depth_a)
    z = depth_a[v, u]
    p = np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z, np.ones_like(z)])
    q = (t_b_a @ p)[:3]
    ub = np.round(q[0] / q[2] * fx + cx).astype(int)
    vb = np.round(q[1] / q[2] * fy + cy).astype(int)
    ok = (q[2] > 0) & (ub >= 0) & (ub < depth_b.shape[1]) & (vb >= 0) & (vb < depth_b.shape[0])
    zb = depth_b[vb[ok], ub[ok]]
    r = np.abs(zb - q[2][ok])[zb > 0]
    return float(np.median(r) * 1000) if r.size else float("nan")


def reference_jumps(root, estimate, reference, threshold_mm=10.0):
    """Frames where the reference's frame-to-frame motion differs from the estimate's by
    more than threshold_mm, with the depth residual each relative pose leaves."""
    import open3d as o3d
    depth_files, _, _, k = load_dataset(root)

    def depth(i):
        d = np.asarray(o3d.io.read_image(depth_files[i])).astype(np.float64) / 1000.0
        d[d > 60.0] = 0.0  # 65535 marks invalid pixels in 7-Scenes
        return d

    jumps = []
    for i in range(len(estimate) - 1):
        de = np.linalg.inv(estimate[i]) @ estimate[i + 1]
        dr = np.linalg.inv(reference[i]) @ reference[i + 1]
        diff = np.linalg.norm((np.linalg.inv(dr) @ de)[:3, 3]) * 1000
        if diff > threshold_mm:
            a, b = depth(i), depth(i + 1)
            jumps.append((i, diff, depth_residual_mm(a, b, k, np.linalg.inv(de)), depth_residual_mm(a, b, k, np.linalg.inv(dr))))
    return jumps


def long_span_residuals(root, estimate, reference, span=50, every=25):
    """Median depth residual of warping frame i onto frame i+span with each trajectory's
    relative pose, over i = 0, every, 2·every, …: a drift check against the images
    themselves that needs no trusted reference."""
    import open3d as o3d
    depth_files, _, _, k = load_dataset(root)

    def depth(i):
        d = np.asarray(o3d.io.read_image(depth_files[i])).astype(np.float64) / 1000.0
        d[d > 60.0] = 0.0
        return d

    ours, theirs = [], []
    for i in range(0, len(estimate) - span, every):
        a, b = depth(i), depth(i + span)
        ours.append(depth_residual_mm(a, b, k, np.linalg.inv(estimate[i + span]) @ estimate[i]))
        theirs.append(depth_residual_mm(a, b, k, np.linalg.inv(reference[i + span]) @ reference[i]))
    return ours, theirs


def med_p90(values):
    values = sorted(values)
    return statistics.median(values), values[int(round(0.9 * (len(values) - 1)))]


# ---------------------------------------------------------------- cuefusion

def run_cuefusion(binary, root, out, extra):
    cmd = ["/usr/bin/time", "-f", "%M", binary, "run", root, "--out", out] + extra
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("cuefusion failed: " + proc.stderr.strip())
    peak_mib = int(proc.stderr.strip().splitlines()[-1]) / 1024.0
    timings = json.load(open(os.path.join(out, "timings.json")))["stages"]
    tracking = json.load(open(os.path.join(out, "tracking.json")))
    result = {"peak_mib": peak_mib, "stages": timings, "tracked": tracking["tracked"], "frames": tracking["frames"],
              "blocks": tracking["volume"]["blocks"], "volume_mib": tracking["volume"]["bytes"] / 2 ** 20}
    ref = os.path.join(out, "reference_trajectory.txt")
    if "--use-gt-poses" not in extra and os.path.exists(ref):
        est = dict(read_tum(os.path.join(out, "trajectory.txt")))
        refs = dict(read_tum(ref))
        keys = sorted(set(est) & set(refs))
        result["ate"] = ate_rmse([est[k] for k in keys], [refs[k] for k in keys])
        result["estimate"] = [est[k] for k in keys]
        result["reference"] = [refs[k] for k in keys]
    return result


# ---------------------------------------------------------------- Open3D (run in a child per method for its peak memory)

def open3d_child(method, root, voxel, trunc, max_depth):
    import open3d as o3d
    depth_files, color_files, poses, (fx, fy, cx, cy) = load_dataset(root)
    scale = 5000.0 if os.path.exists(os.path.join(root, "depth.txt")) else 1000.0  # TUM: 5000 units per metre
    first = o3d.io.read_image(depth_files[0])
    h, w = np.asarray(first).shape[:2]
    intrinsic = o3d.camera.PinholeCameraIntrinsic(w, h, fx, fy, cx, cy)
    times, estimate = [], []

    def rgbd(i):
        color = o3d.io.read_image(color_files[i])
        depth = o3d.io.read_image(depth_files[i])
        if np.asarray(color).shape[:2] != (h, w):
            color = o3d.geometry.Image(np.ascontiguousarray(np.asarray(color)[:h, :w]))
        return o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth, depth_scale=scale, depth_trunc=max_depth, convert_rgb_to_intensity=(method == "odometry"))

    if method == "scalable":
        volume = o3d.pipelines.integration.ScalableTSDFVolume(
            voxel_length=voxel, sdf_trunc=trunc, color_type=o3d.pipelines.integration.TSDFVolumeColorType.RGB8)
        for i in range(len(depth_files)):
            frame = rgbd(i)
            t0 = time.perf_counter()
            volume.integrate(frame, intrinsic, np.linalg.inv(poses[i]))
            times.append((time.perf_counter() - t0) * 1000)
    elif method == "voxelblockgrid":
        device = o3d.core.Device("CPU:0")
        vbg = o3d.t.geometry.VoxelBlockGrid(attr_names=("tsdf", "weight", "color"),
                                            attr_dtypes=(o3d.core.float32, o3d.core.float32, o3d.core.float32),
                                            attr_channels=((1), (1), (3)), voxel_size=voxel, block_resolution=8,
                                            block_count=100000, device=device)
        k = o3d.core.Tensor(intrinsic.intrinsic_matrix, o3d.core.Dtype.Float64)
        for i in range(len(depth_files)):
            depth = o3d.t.io.read_image(depth_files[i]).to(device)
            color = o3d.t.io.read_image(color_files[i]).to(device)
            if color.rows != h or color.columns != w:
                color = o3d.t.geometry.Image(o3d.core.Tensor(np.ascontiguousarray(np.asarray(color)[:h, :w])))
            extrinsic = o3d.core.Tensor(np.linalg.inv(poses[i]), o3d.core.Dtype.Float64)
            t0 = time.perf_counter()
            blocks = vbg.compute_unique_block_coordinates(depth, k, extrinsic, scale, max_depth, trunc_voxel_multiplier=trunc / voxel)
            vbg.integrate(blocks, depth, color, k, extrinsic, scale, max_depth, trunc_voxel_multiplier=trunc / voxel)
            times.append((time.perf_counter() - t0) * 1000)
    elif method == "odometry":
        pose = poses[0]
        estimate.append(pose)
        option = o3d.pipelines.odometry.OdometryOption()
        option.depth_max = max_depth
        previous = rgbd(0)
        for i in range(1, len(depth_files)):
            current = rgbd(i)
            t0 = time.perf_counter()
            ok, t_prev_cur, _ = o3d.pipelines.odometry.compute_rgbd_odometry(
                current, previous, intrinsic, np.identity(4),
                o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm(), option)
            times.append((time.perf_counter() - t0) * 1000)
            if ok:
                pose = pose @ t_prev_cur
            estimate.append(pose)
            previous = current
    elif method == "frame_to_model":
        # Open3D frame-to-model point-to-plane tracking. Debian's Open3D 0.16 is built
        # without IPP, so its dense SLAM (t.pipelines.slam.Model.track_frame_to_model) and
        # t.pipelines.odometry fail on the CPU ("FilterBilateral ... not implemented"). The
        # same loop from the parts that work: ray-cast the VoxelBlockGrid at the last pose,
        # Open3D's point-to-plane ICP (registration_icp, coarse to fine over 4 / 2 / 1 cm
        # voxel grids, correspondences within 7 cm as in dense_slam.py) of the frame against
        # that model surface, integrate at the tracked pose. Starts at the reference's first
        # pose, as cuefusion does.
        device = o3d.core.Device("CPU:0")
        k = o3d.core.Tensor(intrinsic.intrinsic_matrix, o3d.core.Dtype.Float64)
        vbg = o3d.t.geometry.VoxelBlockGrid(attr_names=("tsdf", "weight", "color"),
                                            attr_dtypes=(o3d.core.float32, o3d.core.float32, o3d.core.float32),
                                            attr_channels=((1), (1), (3)), voxel_size=voxel, block_resolution=8,
                                            block_count=100000, device=device)
        registration = o3d.pipelines.registration
        scales = ((0.04, 0.07, 20), (0.02, 0.035, 15), (0.01, 0.02, 10))  # voxel, max distance, iterations
        pose = poses[0]
        for i in range(len(depth_files)):
            depth = o3d.t.io.read_image(depth_files[i]).to(device)
            color = o3d.t.io.read_image(color_files[i]).to(device)
            if color.rows != h or color.columns != w:
                color = o3d.t.geometry.Image(o3d.core.Tensor(np.ascontiguousarray(np.asarray(color)[:h, :w])))
            t0 = time.perf_counter()
            if i > 0:
                extrinsic = o3d.core.Tensor(np.linalg.inv(pose), o3d.core.Dtype.Float64)
                blocks = vbg.compute_unique_block_coordinates(depth, k, extrinsic, scale, max_depth,
                                                              trunc_voxel_multiplier=trunc / voxel)
                cast = vbg.ray_cast(blocks, k, extrinsic, w, h, ["vertex", "normal"], scale, 0.1, max_depth, 1.0)
                vertex = cast["vertex"].numpy().reshape(-1, 3)
                normal = cast["normal"].numpy().reshape(-1, 3)
                valid = np.isfinite(vertex).all(axis=1) & (np.abs(vertex).sum(axis=1) > 0) & (np.abs(normal).sum(axis=1) > 0)
                target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(vertex[valid].astype(np.float64)))
                target.normals = o3d.utility.Vector3dVector(normal[valid].astype(np.float64))
                # The ray cast is in the last camera's frame; the ICP finds this camera in it.
                source = o3d.geometry.PointCloud.create_from_depth_image(
                    o3d.geometry.Image(np.asarray(depth.cpu())), intrinsic, depth_scale=scale, depth_trunc=max_depth, stride=2)
                motion = np.identity(4)
                for size, distance, iterations in scales:
                    result = registration.registration_icp(
                        source.voxel_down_sample(size), target.voxel_down_sample(size), distance, motion,
                        registration.TransformationEstimationPointToPlane(),
                        registration.ICPConvergenceCriteria(max_iteration=iterations))
                    motion = result.transformation
                pose = pose @ motion
            extrinsic = o3d.core.Tensor(np.linalg.inv(pose), o3d.core.Dtype.Float64)
            blocks = vbg.compute_unique_block_coordinates(depth, k, extrinsic, scale, max_depth, trunc_voxel_multiplier=trunc / voxel)
            vbg.integrate(blocks, depth, color, k, extrinsic, scale, max_depth, trunc_voxel_multiplier=trunc / voxel)
            times.append((time.perf_counter() - t0) * 1000)
            estimate.append(pose)
    result = {"times": times, "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}
    if estimate:
        result["ate"] = ate_rmse(estimate, poses)
    print(json.dumps(result))


def run_open3d(method, root, voxel, trunc, max_depth):
    proc = subprocess.run([sys.executable, __file__, "--open3d-child", method, root, str(voxel), str(trunc), str(max_depth)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "failed"}
    return json.loads(proc.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------- report

def machine():
    model = "unknown CPU"
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    mem = int(re.search(r"MemTotal:\s+(\d+)", open("/proc/meminfo").read()).group(1)) / 2 ** 20
    return "%s, %d cores, %.0f GiB, %s" % (model, os.cpu_count(), mem, platform.platform())


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--open3d-child":
        open3d_child(sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6]))
        return
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("datasets", nargs="+", help="dataset folders (Redwood layout or 7-Scenes frames)")
    parser.add_argument("--binary", default="build/apps/cuefusion")
    parser.add_argument("--voxel", type=float, default=0.01)
    parser.add_argument("--truncation", type=float, default=4.0, help="in voxels")
    parser.add_argument("--max-depth", type=float, default=5.0)
    args = parser.parse_args()
    trunc = args.voxel * args.truncation
    common = ["--voxel", str(args.voxel), "--truncation", str(args.truncation), "--max-depth", str(args.max_depth)]

    print("## Reconstruction (%s)\n" % datetime.date.today().isoformat())
    print("- machine: %s" % machine())
    print("- command: `scripts/bench %s`" % " ".join(sys.argv[1:]))
    print("- voxel %.3f m, truncation %.3f m, depth ≤ %.1f m, 640×480; threads: OpenCV's pool, %s\n"
          % (args.voxel, trunc, args.max_depth, os.environ.get("OPENCV_FOR_THREADS_NUM", "all cores")))
    for root in args.datasets:
        name = os.path.basename(os.path.normpath(root))
        with tempfile.TemporaryDirectory() as tmp:
            tracked = run_cuefusion(args.binary, root, os.path.join(tmp, "track"), common)
            gt = run_cuefusion(args.binary, root, os.path.join(tmp, "gt"), common + ["--use-gt-poses"])
        o3d = {m: run_open3d(m, root, args.voxel, trunc, args.max_depth) for m in ("scalable", "voxelblockgrid", "odometry")}

        def stage(result, key):
            s = result["stages"][key]
            return "%.1f / %.1f" % (s["median"], s["p90"])

        print("### %s (%d frames)\n" % (name, tracked["frames"]))
        print("| system | ATE RMSE | tracked | preprocess ms | track ms | integrate ms | raycast ms | track+integrate+raycast ms | peak memory |")
        print("|---|---|---|---|---|---|---|---|---|")
        print("| cuefusion (ICP tracking) | %.1f mm | %d/%d | %s | %s | %s | %s | %s | %.0f MiB |" % (
            tracked["ate"] * 1000, tracked["tracked"], tracked["frames"], stage(tracked, "preprocess"), stage(tracked, "track"),
            stage(tracked, "integrate"), stage(tracked, "raycast"), stage(tracked, "track+integrate+raycast"), tracked["peak_mib"]))
        print("| cuefusion (--use-gt-poses) | – | – | %s | – | %s | %s | integrate+raycast %s | %.0f MiB |" % (
            stage(gt, "preprocess"), stage(gt, "integrate"), stage(gt, "raycast"),
            "%.1f" % (gt["stages"]["integrate"]["median"] + gt["stages"]["raycast"]["median"]), gt["peak_mib"]))
        od = o3d["odometry"]
        if "error" in od:
            print("| Open3D RGB-D odometry | failed: %s | | | | | | | |" % od["error"])
        else:
            m, p = med_p90(od["times"])
            print("| Open3D RGB-D odometry (hybrid, chained) | %.1f mm | %d/%d | – | %.1f / %.1f | – | – | – | %.0f MiB |" % (
                od["ate"] * 1000, len(od["times"]) + 1, tracked["frames"], m, p, od["peak_mib"]))
        for method, label in (("scalable", "Open3D ScalableTSDFVolume"), ("voxelblockgrid", "Open3D VoxelBlockGrid (CPU)")):
            r = o3d[method]
            if "error" in r:
                print("| %s | failed: %s | | | | | | | |" % (label, r["error"]))
                continue
            m, p = med_p90(r["times"])
            print("| %s (reference poses) | – | – | – | – | %.1f / %.1f | – | – | %.0f MiB |" % (label, m, p, r["peak_mib"]))
        print("\nTimes are median / p90 ms per frame. cuefusion volume after tracking: %d blocks, %.0f MiB.\n"
              % (tracked["blocks"], tracked["volume_mib"]))
        integrate_raycast = gt["stages"]["integrate"]["median"] + gt["stages"]["raycast"]["median"]
        ratios = []
        for method in ("scalable", "voxelblockgrid"):
            if "error" not in o3d[method]:
                ratios.append("%s integrate %.1f ms → cuefusion integrate+raycast is %.2f× its time" % (
                    method, statistics.median(o3d[method]["times"]), integrate_raycast / statistics.median(o3d[method]["times"])))
        if ratios:
            print("Ratios (medians): " + "; ".join(ratios) + ".\n")
        if len(tracked["estimate"]) == tracked["frames"]:
            jumps = reference_jumps(root, tracked["estimate"], tracked["reference"])
            if jumps:
                print("Reference check: frame pairs where the reference's motion differs from cuefusion's by > 1 cm, with "
                      "the median depth residual each relative pose leaves when frame i is warped onto frame i+1:\n")
                print("| frames | motion difference | residual, cuefusion | residual, reference |")
                print("|---|---|---|---|")
                for i, diff, ours, theirs in jumps:
                    print("| %d→%d | %.1f mm | %.2f mm | %.2f mm |" % (i, i + 1, diff, ours, theirs))
                cuts = [0] + [i + 1 for i, diff, ours, theirs in jumps if theirs > 2 * ours] + [tracked["frames"]]
                parts = ["%d–%d: %.1f mm" % (a, b - 1, ate_rmse(tracked["estimate"][a:b], tracked["reference"][a:b]) * 1000)
                         for a, b in zip(cuts[:-1], cuts[1:]) if b - a >= 10]
                print("\nATE RMSE of cuefusion within the stretches between reference jumps that the depth contradicts "
                      "(residual > 2× cuefusion's): " + "; ".join(parts) + ".\n")
        if len(tracked["estimate"]) == tracked["frames"] and tracked["frames"] > 60:
            ours, theirs = long_span_residuals(root, tracked["estimate"], tracked["reference"])
            print("Drift check: frame i warped onto frame i+50 (i = 0, 25, 50, …) with each trajectory's relative pose; "
                  "median depth residual over the pairs: cuefusion %.2f mm, reference %.2f mm (worst pair %.2f vs %.2f mm).\n"
                  % (statistics.median(ours), statistics.median(theirs), max(ours), max(theirs)))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
