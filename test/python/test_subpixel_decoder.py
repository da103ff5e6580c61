# SPDX-License-Identifier: BSD-3-Clause
"""tools/train_masks/subpixel_decoder.py: the rewritten decoder computes the function of
the original (nearest upsampling, concatenation, 3x3 convolution) in OpenCV's DNN, and
train.py's --init-onnx gets the original convolutions back from it."""
import os
import sys

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
cv2 = pytest.importorskip("cv2")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "train_masks"))
import subpixel_decoder  # noqa: E402


def decoder_step(rng, coarse, skip, out, h, w):
    """One step of model.py's decoder on an input of coarse channels at h x w and skip
    channels at 2h x 2w, with random weights."""
    weight = rng.standard_normal((out, coarse + skip, 3, 3)).astype(np.float32)
    bias = rng.standard_normal(out).astype(np.float32)
    nodes = [
        helper.make_node("Constant", [], ["roi"], value=numpy_helper.from_array(np.zeros(0, np.float32))),
        helper.make_node("Constant", [], ["scales"], value=numpy_helper.from_array(np.array([1, 1, 2, 2], np.float32))),
        helper.make_node("Resize", ["a", "roi", "scales"], ["up"], mode="nearest", nearest_mode="floor",
                         coordinate_transformation_mode="asymmetric"),
        helper.make_node("Concat", ["up", "s"], ["cat"], axis=1),
        helper.make_node("Conv", ["cat", "w", "b"], ["conv"], kernel_shape=[3, 3], pads=[1, 1, 1, 1]),
        helper.make_node("Relu", ["conv"], ["y"]),
    ]
    graph = helper.make_graph(
        nodes, "step",
        [helper.make_tensor_value_info("a", TensorProto.FLOAT, [1, coarse, h, w]),
         helper.make_tensor_value_info("s", TensorProto.FLOAT, [1, skip, 2 * h, 2 * w])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, out, 2 * h, 2 * w])],
        [numpy_helper.from_array(weight, "w"), numpy_helper.from_array(bias, "b")])
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 11)]), weight, bias


def forward(model, inputs, path):
    onnx.save(model, path)
    net = cv2.dnn.readNetFromONNX(path)
    for name, value in inputs.items():
        net.setInput(value, name)
    return net.forward()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_rewritten_step_computes_the_original_function(tmp_path, seed):
    rng = np.random.default_rng(seed)
    coarse, skip, out = (int(v) for v in rng.integers(2, 12, 3))
    h, w = (int(v) for v in rng.integers(3, 17, 2))
    model, weight, bias = decoder_step(rng, coarse, skip, out, h, w)
    inputs = {"a": rng.standard_normal((1, coarse, h, w)).astype(np.float32),
              "s": rng.standard_normal((1, skip, 2 * h, 2 * w)).astype(np.float32)}
    # The original function, computed here without OpenCV: nearest upsampling by 2, then
    # the 3x3 convolution with zero padding.
    x = np.concatenate([inputs["a"].repeat(2, 2).repeat(2, 3), inputs["s"]], 1)[0].astype(np.float64)
    padded = np.pad(x, ((0, 0), (1, 1), (1, 1)))
    expected = np.zeros((out, 2 * h, 2 * w)) + bias[:, None, None]
    for dy in range(3):
        for dx in range(3):
            expected += np.einsum("oc,chw->ohw", weight[:, :, dy, dx], padded[:, dy:dy + 2 * h, dx:dx + 2 * w])
    expected = np.maximum(expected, 0)

    before = forward(model, inputs, str(tmp_path / "before.onnx"))[0]
    assert subpixel_decoder.rewrite(model) == 1
    onnx.checker.check_model(model)
    kinds = [n.op_type for n in model.graph.node]
    assert "Resize" not in kinds and "Concat" not in kinds and "ConvTranspose" in kinds
    after = forward(model, inputs, str(tmp_path / "after.onnx"))[0]
    scale = np.abs(expected).max()
    assert np.abs(before - expected).max() < 1e-5 * scale
    assert np.abs(after - expected).max() < 1e-5 * scale

    # --init-onnx reads the original convolution back.
    (name, recovered, recovered_bias), = subpixel_decoder.conv_weights(model)
    assert recovered.shape == weight.shape
    assert np.abs(recovered - weight).max() < 1e-5 * np.abs(weight).max()
    assert np.array_equal(recovered_bias, bias)


def test_the_shipped_model_is_stored_rewritten():
    path = os.path.join(os.path.dirname(__file__), "..", "..", "data", "models", "xyz_instances.onnx")
    kinds = [n.op_type for n in onnx.load(path).graph.node]
    assert kinds.count("ConvTranspose") == 3 and "Resize" not in kinds
