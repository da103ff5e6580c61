# SPDX-License-Identifier: BSD-3-Clause
"""cuefusion from Python: object-level 3D maps from RGB-D frames, with numpy in and out.

    import cuefusion
    sequence = cuefusion.open_sequence("data/demo")          # a dataset folder
    pipeline = cuefusion.Pipeline()                           # the library's defaults
    for frame in sequence:
        report = pipeline.process(frame, masks=my_detector(frame.color))
    xyz, rgb, labels = pipeline.labelled_cloud()

Images are numpy arrays: depth HxW float32 in metres (or uint16 with depth_scale units per
metre), colour HxWx3 uint8 RGB, K the 3x3 intrinsic matrix, masks an HxW integer array of
instance ids (0 = none) or a list of (mask, score, class name). Bad arguments raise
ValueError, files that cannot be read or written OSError; the C++ work runs without the GIL.
docs/python.md has the whole API.
"""
import json as _json
import os as _os

from . import _cuefusion
from ._cuefusion import Frame, Sequence

__version__ = _cuefusion.__version__
__all__ = ["Pipeline", "InstanceSegmenter", "Frame", "Sequence", "open_sequence", "segment_frame",
           "evaluate_trajectory", "evaluate_labels", "evaluate_instances", "evaluate_run"]


def _settings_text(config):
    """None, a dict, or the path of a settings file or a run's outputs.json, as JSON text."""
    if config is None:
        return "", ""
    if isinstance(config, dict):
        return _json.dumps(config), "config"
    if isinstance(config, (str, bytes, _os.PathLike)):
        path = _os.fsdecode(config)
        with open(path, encoding="utf-8") as f:  # OSError naming the file when it cannot be read
            return f.read(), path
    raise ValueError("config must be None, a dict or the path of a settings file, not %s" % type(config).__name__)


class Pipeline:
    """The incremental pipeline (cuefusion::pipeline::FusionPipeline), one frame at a time.

    config: None (the library's defaults, which are `cuefusion run`'s), a dict of Config
    fields by name (`cuefusion run --print-config` prints them; {"pipeline": {...}} or the
    fields themselves), or the path of a settings file or a run's outputs.json.
    mode: "fused", "geometry" or "masks"; None keeps the config's ("fused" by default; as
    `cuefusion run` without --masks/--model, give "geometry" when no masks will come).
    """

    def __init__(self, config=None, mode=None):
        text, source = _settings_text(config)
        self._core = _cuefusion._Pipeline(text, source, mode or "")

    def process(self, depth, color=None, K=None, masks=None, depth_scale=1000.0, timestamp=None, pose=None):
        """Adds one frame; returns its report (a dict: tracked, pose 4x4, lost_reason,
        relocalised, segmented, segments, timings_ms, loop_ms, ...). The first argument may be a
        Frame of open_sequence (then color and K come with it); pose is the frame's
        reference pose (used with reconstruction.use_reference_poses)."""
        if isinstance(depth, Frame):
            return self._core.process_frame(depth, masks)
        if K is None:
            raise ValueError("K (the 3x3 intrinsic matrix) is needed with a depth array")
        return self._core.process(depth, color, K, masks, float(depth_scale), timestamp, pose)

    def labelled_cloud(self, color_by_segment=False):
        """The map's surface points: (xyz Nx3 float32 world frame, rgb Nx3 uint8, labels N uint32)."""
        return self._core.labelled_cloud(bool(color_by_segment))

    def mesh(self, color_by_segment=True):
        """Marching-cubes mesh: (vertices Nx3 float32, triangles Mx3 int32, colours Nx3 uint8, labels N uint32)."""
        return self._core.mesh(bool(color_by_segment))

    def segments(self):
        """Every segment of the map as segments.json lists it (id, class, score, voxels,
        bounds, centroid, oriented_box, frames)."""
        return _json.loads(self._core.segments_text())["segments"]

    def trajectory(self):
        """The accepted poses: a list of (timestamp, 4x4 camera-to-world)."""
        return self._core.trajectory()

    def save(self, folder):
        """Writes map.pcd, mesh.ply, segments.json and trajectory.txt into folder, as `cuefusion run`."""
        self._core.save(_os.fsdecode(folder))

    @property
    def frames(self):
        return self._core.frames

    @property
    def noise_scale(self):
        """The depth noise the thresholds follow, a multiple of the Kinect model's."""
        return self._core.noise_scale

    @property
    def config(self):
        """The effective settings, as `cuefusion run --print-config` prints them under "pipeline"."""
        return self._core.config


class InstanceSegmenter:
    """A mask source: the shipped network by name ("xyz_instances"), an ONNX file (YOLO-seg
    layouts), or a folder of 16-bit instance-id PNGs. Options are the network's Config
    fields (score_threshold=0.3, boundary_threshold=..., input_size=...).
    Calling it on a frame returns a list of (mask HxW bool, score, class name or None)."""

    def __init__(self, source="xyz_instances", **options):
        self._core = _cuefusion._Segmenter(_os.fsdecode(source), _json.dumps(options) if options else "")

    def __call__(self, depth, color=None, K=None, depth_scale=1000.0, index=0, name=""):
        if isinstance(depth, Frame):
            frame = depth
            return self._core.call(frame.depth, frame.color, frame.K, 1000.0, frame.index, frame.name)
        if K is None:
            raise ValueError("K (the 3x3 intrinsic matrix) is needed with a depth array")
        return self._core.call(depth, color, K, float(depth_scale), int(index), name)

    @property
    def name(self):
        return self._core.name


def open_sequence(path, format="auto", intrinsics=None):
    """A recorded sequence (TUM, Redwood/ICL, 7-Scenes, ScanNet, or cuefusion synth's
    layout): len(), indexing and iteration give Frames."""
    return _cuefusion._open_sequence(_os.fsdecode(path), format, _os.fsdecode(intrinsics) if intrinsics else "")


def segment_frame(depth, color=None, K=None, masks=None, mode="fused", depth_scale=1000.0, config=None):
    """One frame's segments without a map (`cuefusion segment-frame`): an HxW int32 label
    image (0 = no segment). mode "fused" and "masks" need masks."""
    if isinstance(depth, Frame):
        depth, color, K = depth.depth, depth.color, depth.K
    if K is None:
        raise ValueError("K (the 3x3 intrinsic matrix) is needed with a depth array")
    text, _ = _settings_text(config)
    return _cuefusion._segment_frame(depth, color, K, masks, mode, float(depth_scale), text)


def evaluate_trajectory(estimated, reference, max_time_difference=0.02, align=True):
    """Absolute trajectory error (metres): each a TUM file or a list of (timestamp, 4x4 pose).
    Returns rmse, mean, median, max, pairs and the alignment applied to the estimate."""
    return _cuefusion._evaluate_trajectory(estimated, reference, float(max_time_difference), bool(align))


def evaluate_labels(predicted, truth, min_truth_pixels=100):
    """Per-frame object IoU (thesis 5.3.2): segments matched one-to-one to the true
    instances (Hungarian); returns mean_iou and each object's match."""
    return _cuefusion._evaluate_labels(predicted, truth, int(min_truth_pixels))


def evaluate_instances(predicted, truth, predicted_scores=None, truth_classes=None, predicted_classes=None,
                       min_region_size=100):
    """3D instance AP as the ScanNet benchmark defines it, on labels per point (0 = none):
    ap, ap50, ap25 class-agnostic, per_class when truth_classes names them."""
    return _cuefusion._evaluate_instances(predicted, truth, predicted_scores or {}, truth_classes or {},
                                          predicted_classes or {}, int(min_region_size))


def evaluate_run(run, sequence, labels="final", every=1, min_pixels=100, min_region=100, match_radius=0.0,
                 format="auto", intrinsics=None):
    """The chapter 5 evaluation of a `cuefusion run` output folder (or Pipeline.save's)
    against the sequence it processed, as `cuefusion eval` does it: tracking (ATE, RPE),
    per-frame object IoU from the final map seen at each pose (labels="final") or the
    run's labels/ (labels="per-frame"), and 3D instance AP when the sequence has a
    labelled ground-truth cloud. Returns a dict: tracking, object_iou, instance_ap."""
    return _cuefusion._evaluate_run(_os.fsdecode(run), _os.fsdecode(sequence), labels, int(every), int(min_pixels),
                                    int(min_region), float(match_radius), format,
                                    _os.fsdecode(intrinsics) if intrinsics else "")
