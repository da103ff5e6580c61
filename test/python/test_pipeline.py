# SPDX-License-Identifier: BSD-3-Clause
"""cuefusion.Pipeline and open_sequence: the map from Python is `cuefusion run`'s, byte for
byte, and masks given from Python act as a mask folder does."""
import os

import numpy as np

import cuefusion
from conftest import cuefusion_command

MAP_FILES = ["map.pcd", "mesh.ply", "segments.json", "trajectory.txt"]


def read(path):
    with open(path, "rb") as f:
        return f.read()


def python_run(sequence, out, masks_for=None, **pipeline_args):
    pipeline = cuefusion.Pipeline(**pipeline_args)
    reports = []
    for frame in cuefusion.open_sequence(sequence):
        reports.append(pipeline.process(frame, masks=masks_for(frame) if masks_for else None))
    pipeline.save(out)
    return pipeline, reports


def test_the_map_from_python_is_the_map_of_cuefusion_run(sequence, tmp_path):
    cuefusion_command("run", sequence, "--out", str(tmp_path / "cli"))
    pipeline, reports = python_run(sequence, str(tmp_path / "py"), mode="geometry")
    for name in MAP_FILES:
        assert read(tmp_path / "py" / name) == read(tmp_path / "cli" / name), name
    # The reports: every frame tracked on this generated sequence, poses as the truth's.
    seq = cuefusion.open_sequence(sequence)
    assert len(reports) == len(seq) == pipeline.frames == 30
    assert all(r["tracked"] for r in reports), [r["lost_reason"] for r in reports]
    for r, frame in zip(reports, seq):
        assert r["pose"].shape == (4, 4)
        assert np.linalg.norm(r["pose"][:3, 3] - frame.pose[:3, 3]) < 0.01
        # The call's whole loop beside its stages (values not asserted: times).
        assert isinstance(r["loop_ms"], float) and "geometric_segmentation" in r["timings_ms"]
    ate = cuefusion.evaluate_trajectory(pipeline.trajectory(), [(f.timestamp, f.pose) for f in seq])
    assert ate["pairs"] == 30 and ate["rmse"] < 0.005


def test_masks_from_python_change_the_map_as_mask_folders_do(sequence, tmp_path):
    # An id image per frame (the sequence's own instance ids, from a Python function) acts
    # as the folder of the same id PNGs; (mask, score, class) lists as a folder with JSON.
    cuefusion_command("run", sequence, "--out", str(tmp_path / "ids_cli"), "--masks", os.path.join(sequence, "instance"))
    python_run(sequence, str(tmp_path / "ids_py"), masks_for=lambda frame: frame.instance_mask.astype(np.int32))
    for name in MAP_FILES:
        assert read(tmp_path / "ids_py" / name) == read(tmp_path / "ids_cli" / name), name
    detections = os.path.join(sequence, "detections")
    cuefusion_command("run", sequence, "--out", str(tmp_path / "det_cli"), "--masks", detections)
    folder = cuefusion.InstanceSegmenter(detections)
    python_run(sequence, str(tmp_path / "det_py"), masks_for=lambda frame: [
        (mask, score, name) for mask, score, name in folder(frame)])
    for name in MAP_FILES:
        assert read(tmp_path / "det_py" / name) == read(tmp_path / "det_cli" / name), name
    # ... and they do change it.
    cuefusion_command("run", sequence, "--out", str(tmp_path / "geometry"))
    assert read(tmp_path / "ids_py" / "map.pcd") != read(tmp_path / "geometry" / "map.pcd")


def test_the_outputs_as_arrays_agree_with_each_other(sequence, tmp_path):
    pipeline = cuefusion.Pipeline()
    seq = cuefusion.open_sequence(sequence)
    for frame in seq:
        pipeline.process(frame.depth, frame.color, frame.K, masks=frame.instance_mask, timestamp=frame.timestamp)
    xyz, rgb, labels = pipeline.labelled_cloud()
    assert xyz.dtype == np.float32 and xyz.shape[1] == 3 and len(xyz) > 1000
    assert rgb.dtype == np.uint8 and rgb.shape == xyz.shape
    assert labels.dtype == np.uint32 and labels.shape == (len(xyz),)
    assert np.isfinite(xyz).all()
    segments = pipeline.segments()
    ids = {s["id"] for s in segments}
    assert set(np.unique(labels[labels > 0]).tolist()) <= ids
    for s in segments:  # each segment's points lie in its bounds
        points = xyz[labels == s["id"]]
        if len(points):
            assert (points >= np.array(s["bounds"]["min"]) - 0.02).all() and (points <= np.array(s["bounds"]["max"]) + 0.02).all()
    vertices, triangles, colors, vertex_labels = pipeline.mesh()
    assert vertices.shape[1] == 3 and triangles.shape[1] == 3 and triangles.max() < len(vertices)
    assert colors.shape == vertices.shape and vertex_labels.shape == (len(vertices),)
    # The uint16 depth path with a scale gives the float path's map.
    again = cuefusion.Pipeline()
    for frame in seq:
        depth_mm = np.round(frame.depth * 1000.0).astype(np.uint16)
        again.process(depth_mm, frame.color, frame.K, masks=frame.instance_mask, depth_scale=1000.0, timestamp=frame.timestamp)
    assert abs(len(again.labelled_cloud()[0]) - len(xyz)) < 0.05 * len(xyz)


def test_settings_from_a_dict_or_a_file(sequence, tmp_path):
    cuefusion_command("run", sequence, "--out", str(tmp_path / "cli"), "--voxel", "0.02", "--frames", "8")
    pipeline = cuefusion.Pipeline(config=str(tmp_path / "cli" / "outputs.json"))
    assert pipeline.config["reconstruction"]["volume"]["voxel_size"] == 0.02
    assert pipeline.config["mode"] == "geometry"
    for frame in list(cuefusion.open_sequence(sequence))[:8]:
        pipeline.process(frame)
    pipeline.save(tmp_path / "py")
    assert read(tmp_path / "py" / "map.pcd") == read(tmp_path / "cli" / "map.pcd")
    fields = cuefusion.Pipeline(config={"pipeline": {"reconstruction": {"volume": {"voxel_size": 0.03}}}}).config
    assert fields["reconstruction"]["volume"]["voxel_size"] == 0.03


def test_evaluate_run_is_cuefusion_eval(sequence, tmp_path):
    # The library's chapter 5 procedure from Python gives eval's report, number for number.
    import json
    run = str(tmp_path / "run")
    cuefusion_command("run", sequence, "--out", run, "--masks", os.path.join(sequence, "detections"))
    cuefusion_command("eval", "--run", run, "--gt", sequence, "--out", str(tmp_path / "rep"), "--no-plots")
    with open(tmp_path / "rep" / "report.json") as f:
        report = json.load(f)["runs"][0]
    found = cuefusion.evaluate_run(run, sequence)
    assert found["tracking"]["ate"]["rmse"] == report["tracking"]["ate"]["rmse"] < 0.005
    assert found["object_iou"]["mean"] == report["object_iou"]["mean"]
    assert found["object_iou"]["frames_scored"] == report["object_iou"]["frames_scored"] == 30
    assert {o["instance"]: o["mean_iou"] for o in report["object_iou"]["objects"]} == \
        {k: v["mean_iou"] for k, v in found["object_iou"]["objects"].items()}
    assert found["instance_ap"]["ap50"] == report["instance_ap"]["class_agnostic"]["ap50"]
    # The objects scored are the truth's: every non-stuff instance seen with at least
    # min_pixels (100) pixels in some frame, and no other.
    with open(os.path.join(sequence, "scene.json")) as f:
        stuff = {i["id"] for i in json.load(f)["instances"] if not i.get("detectable", True)}
    seen = set()
    for frame in cuefusion.open_sequence(sequence):
        ids, counts = np.unique(frame.instance_mask, return_counts=True)
        seen |= {int(i) for i, n in zip(ids, counts) if i != 0 and int(i) not in stuff and n >= 100}
    assert set(found["object_iou"]["objects"]) == seen
    try:
        cuefusion.evaluate_run(run, sequence, every=0)
        assert False, "every=0 accepted"
    except ValueError as e:
        assert "every" in str(e)
