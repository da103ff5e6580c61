# SPDX-License-Identifier: BSD-3-Clause
"""segment_frame, InstanceSegmenter and the evaluation functions on generated frames with
exact truth; bad arrays and files raise ValueError / OSError with the library's message."""
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

import cuefusion
from conftest import BUILD_DIR


@pytest.fixture(scope="module")
def frame(sequence):
    return cuefusion.open_sequence(sequence)[5]


def test_segment_frame_finds_the_true_objects(frame):
    truth = frame.instance_mask.astype(np.int32)
    masks_only = cuefusion.segment_frame(frame, masks=truth, mode="masks")
    assert masks_only.dtype == np.int32 and masks_only.shape == truth.shape
    assert cuefusion.evaluate_labels(masks_only, truth)["mean_iou"] > 0.9
    # Fused, the objects of 1000 pixels and more come out whole (at 160x120 the smallest
    # ones fall below the geometric segmentation's segment size).
    fused = cuefusion.segment_frame(frame.depth, frame.color, frame.K, masks=truth)
    large = [o for o in cuefusion.evaluate_labels(fused, truth)["objects"] if o["truth_pixels"] >= 1000]
    assert len(large) >= 3 and min(o["iou"] for o in large) > 0.85, large
    geometry = cuefusion.segment_frame(frame, mode="geometry")
    assert len(np.unique(geometry[geometry > 0])) >= 3


def test_the_shipped_network_from_python(frame):
    network = cuefusion.InstanceSegmenter("xyz_instances", score_threshold=0.3)
    assert "xyz_instances" in network.name
    masks = network(frame)
    assert len(masks) >= 1
    for mask, score, name in masks:
        assert mask.dtype == np.bool_ and mask.shape == frame.depth.shape and mask.any()
        assert 0.0 <= score <= 1.0 and name == "object"  # mean foreground ≥ 0.3, times its stability
    # Its masks cover the truth's objects: fused with them, the frame's objects come out.
    labels = cuefusion.segment_frame(frame, masks=masks)
    objects = cuefusion.evaluate_labels(labels, frame.instance_mask.astype(np.int32))["objects"]
    assert np.median([o["iou"] for o in objects if o["truth_pixels"] >= 1000]) > 0.7, objects


def test_evaluation_on_arrays():
    rng = np.random.default_rng(7)
    truth = rng.integers(0, 6, size=(60, 80)).astype(np.uint16)
    truth[:, :40] = 3
    relabelled = np.where(truth > 0, truth.astype(np.int32) + 10, 0)
    assert cuefusion.evaluate_labels(relabelled, truth, min_truth_pixels=1)["mean_iou"] == pytest.approx(1.0)
    merged = np.where(truth > 0, 1, 0)
    assert cuefusion.evaluate_labels(merged, truth, min_truth_pixels=1)["mean_iou"] < 0.6
    points = np.repeat(np.arange(1, 6), 200)
    ap = cuefusion.evaluate_instances(points + 100, points)
    assert ap["ap50"] == pytest.approx(1.0) and ap["truth_instances"] == 5
    poses = []
    for k in range(20):
        pose = np.eye(4)
        pose[:3, 3] = [0.1 * k, 0.02 * k, 0.0]
        poses.append((k / 30.0, pose))
    shifted = [(t, p.copy()) for t, p in poses]
    for _, p in shifted:
        p[:3, 3] += [0.5, 0.0, 0.0]
    assert cuefusion.evaluate_trajectory(shifted, poses)["rmse"] < 1e-9  # aligned
    assert cuefusion.evaluate_trajectory(shifted, poses, align=False)["rmse"] == pytest.approx(0.5)


def test_bad_arrays_raise_clear_errors(frame):
    depth, color, K = frame.depth, frame.color, frame.K
    pipeline = cuefusion.Pipeline()
    bad = [
        (dict(depth=depth.astype(np.float64)), "dtype"),
        (dict(depth=depth[None]), "HxW"),
        (dict(depth=np.asfortranarray(depth)), "C-contiguous"),
        (dict(depth=depth[:, ::2]), "C-contiguous"),
        (dict(color=np.ascontiguousarray(color[:, :, 0])), "HxWx3"),
        (dict(color=color.astype(np.float32)), "uint8"),
        (dict(K=np.full((3, 3), np.nan)), "not finite"),
        (dict(K=np.eye(2)), "3x3"),
        (dict(K=np.zeros((3, 3))), "focal"),
        (dict(masks=np.zeros((3, 3), np.int32)), "id image"),
        (dict(masks=np.full(depth.shape, -1, np.int32)), "[0, 65535]"),
        (dict(masks=np.zeros(depth.shape, np.float32)), "integer"),
        (dict(masks=[(np.zeros(depth.shape, bool), 2.0, "cup")]), "score"),
        (dict(masks=[(np.zeros(depth.shape, bool), "high", "cup")]), "score must be a number"),
        (dict(masks=[(np.zeros(depth.shape, bool), 0.5, 41)]), "class name"),
        (dict(masks="cup"), "masks must be"),
        (dict(depth=depth.astype(np.uint16), depth_scale=0.0), "depth_scale"),
    ]
    for change, message in bad:
        args = dict(depth=depth, color=color, K=K, masks=None, depth_scale=1000.0)
        args.update(change)
        with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
            pipeline.process(**args)
        with pytest.raises(ValueError):
            cuefusion.segment_frame(args["depth"], args["color"], args["K"], masks=args["masks"] if args["masks"] is not None else np.zeros(depth.shape, np.int32),
                                    depth_scale=args["depth_scale"])
    assert pipeline.frames == 0  # nothing was processed
    pipeline.process(frame)  # and the pipeline still works
    with pytest.raises(ValueError, match="pose"):
        cuefusion.Pipeline().process(depth, color, K, pose=np.ones((4, 4)))


def test_bad_settings_and_files(tmp_path):
    with pytest.raises(ValueError, match="no_such_field"):
        cuefusion.Pipeline(config={"no_such_field": 1})
    with pytest.raises(ValueError, match="voxel_size"):
        cuefusion.Pipeline(config={"reconstruction": {"volume": {"voxel_size": -1}}})
    with pytest.raises(ValueError, match="Mode"):
        cuefusion.Pipeline(mode="everything")
    with pytest.raises(OSError):
        cuefusion.Pipeline(config=str(tmp_path / "missing.json"))
    with pytest.raises(OSError, match="missing"):
        cuefusion.open_sequence(tmp_path / "missing")
    with pytest.raises(OSError, match="nothing.onnx"):
        cuefusion.InstanceSegmenter(str(tmp_path / "nothing.onnx"))
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(OSError, match="file"):
        cuefusion.Pipeline().save(tmp_path / "file")
    with pytest.raises(ValueError, match="mode 'fused' needs masks"):
        cuefusion.segment_frame(np.ones((40, 40), np.float32), None, np.array([[50, 0, 20], [0, 50, 20], [0, 0, 1]]))
    with pytest.raises(IndexError):
        cuefusion.open_sequence(_tiny_sequence(tmp_path))[99]


def _tiny_sequence(tmp_path):
    out = str(tmp_path / "tiny")
    subprocess.run([os.path.join(BUILD_DIR, "apps", "cuefusion"), "synth", "--scene", "tabletop", "--frames", "2", "--size", "80x60", "--layout", "redwood",
                    "--out", out], check=True, capture_output=True)
    return out


def test_the_installed_package_imports_outside_the_source_tree(tmp_path):
    prefix = tmp_path / "prefix"
    for component in ("runtime", "python"):
        subprocess.run(["cmake", "--install", BUILD_DIR, "--prefix", str(prefix), "--component", component],
                       check=True, capture_output=True)
    site = prefix / "lib" / "python3" / "dist-packages"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH")}
    env["PYTHONPATH"] = str(site)
    code = ("import cuefusion, numpy as np; "
            "assert cuefusion.__file__.startswith(%r), cuefusion.__file__; "
            "K = np.array([[100.0, 0, 40], [0, 100.0, 30], [0, 0, 1]]); "
            "d = np.full((60, 80), 1.5, np.float32); "
            "print(cuefusion.segment_frame(d, None, K, mode='geometry').shape)" % str(site))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=str(tmp_path), env=env)
    assert proc.returncode == 0, proc.stderr
    assert "(60, 80)" in proc.stdout


def test_threads_may_share_a_pipeline_and_a_network(sequence):
    # The GIL is let go while the library works: two Python threads calling one Pipeline
    # and one InstanceSegmenter take turns inside (each object has its lock), never crash.
    seq = cuefusion.open_sequence(sequence)
    frames = [seq[i] for i in range(12)]
    pipeline = cuefusion.Pipeline(mode="geometry")
    network = cuefusion.InstanceSegmenter("xyz_instances")
    errors = []

    def work(part):
        try:
            for f in part:
                assert len(network(f)) >= 1
                pipeline.process(f)
                pipeline.labelled_cloud()
                pipeline.trajectory()
                pipeline.noise_scale
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(frames[k::2],)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert pipeline.frames == 12
