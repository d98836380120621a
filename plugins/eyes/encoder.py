"""The bundled NanoDet-g's backbone and PAN as a trainable torch module, its weights read from the ONNX file.

No converter: :class:`OnnxEncoder` walks the ONNX graph from its input to the named feature tensors and runs
each node with the torch operation ONNX defines for it (Conv, Pad, LeakyRelu, Concat, Add, Resize, MaxPool,
and the Casts that turn the stored float16 weights into float32). Every weight becomes a float32
``nn.Parameter``; batch norm is already folded into the convolutions, so training and inference are the same.

The PAN resizes by fixed ×2 / ×0.5 factors, which only fit inputs whose sides are multiples of 32: here a
resized map that does not match the map it is added to is resized to that map's size instead, so any input
size runs (and multiples of 32 give exactly the ONNX file's numbers).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

FEATURES = {
    "c2": "PartitionedCall/onnx_tf_prefix_Concat_12:0",  # stride 4, 64 channels
    "p3": "PartitionedCall/onnx_tf_prefix_Add_107:0",  # stride 8, 128 channels (PAN)
    "p4": "PartitionedCall/onnx_tf_prefix_Add_128:0",  # stride 16, 128
    "p5": "PartitionedCall/onnx_tf_prefix_Add_149:0",  # stride 32, 128
}
"""Feature maps the eyes network reads (name → ONNX tensor of the bundled graph)."""
STRIDE8 = "PartitionedCall/onnx_tf_prefix_Concat_27:0"
"""The backbone's stride-8 map (c3): ``--freeze stride8`` keeps what computes it fixed."""
CHANNELS = {"c2": 64, "p3": 128, "p4": 128, "p5": 128}
MEAN_BGR = (103.53, 116.28, 123.675)
STD_BGR = (57.375, 57.12, 58.395)
"""The detector's input normalisation (BGR, 0-255 scale)."""


def default_onnx() -> Path:
    """The bundled NanoDet-g file."""
    return Path(__file__).resolve().parent.parent / "detectors" / "nanodet.onnx"


def normalise(rgb: torch.Tensor) -> torch.Tensor:
    """sRGB in [0, 1], [B, 3, H, W] → the encoder's input (BGR, normalised as the detector was trained)."""
    bgr = rgb.flip(1) * 255.0
    mean = torch.tensor(MEAN_BGR, device=rgb.device).view(1, 3, 1, 1)
    std = torch.tensor(STD_BGR, device=rgb.device).view(1, 3, 1, 1)
    return (bgr - mean) / std


class OnnxEncoder(nn.Module):
    """The part of an ONNX graph that computes ``outputs`` (name → tensor name) from its single input."""

    def __init__(self, path: Path | None = None, outputs: dict[str, str] | None = None) -> None:
        import onnx
        from onnx import numpy_helper

        super().__init__()
        graph = onnx.load(str(path or default_onnx())).graph
        self.outputs = dict(outputs or FEATURES)
        self.input = graph.input[0].name
        constants = {i.name: numpy_helper.to_array(i) for i in graph.initializer}
        producers = {out: node for node in graph.node for out in node.output}
        needed: list = []
        seen: set[str] = set()

        def visit(tensor: str) -> None:  # depth-first: each node after the nodes it reads
            node = producers.get(tensor)
            if node is None or node.name + node.output[0] in seen:
                return
            seen.add(node.name + node.output[0])
            for name in node.input:
                visit(name)
            needed.append(node)

        for tensor in self.outputs.values():
            if tensor not in producers:
                raise ValueError(f"{path or default_onnx()}: no tensor '{tensor}' in the graph")
            visit(tensor)
        self.params = nn.ParameterDict()
        self.names: dict[str, str] = {}  # ONNX tensor → parameter key
        self.nodes: list[tuple[str, list[str], str, dict]] = []
        for node in needed:
            attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
            if node.op_type == "Cast" and node.input[0] in constants:  # stored float16 weight → float32
                constants[node.output[0]] = constants[node.input[0]].astype(np.float32)
                continue
            if node.op_type == "Conv":
                for name in node.input[1:]:
                    key = f"w{len(self.params)}"
                    self.params[key] = nn.Parameter(torch.from_numpy(constants[name].astype(np.float32).copy()))
                    self.names[name] = key
            inputs = [n for n in node.input if n]
            attrs.update({f"const:{n}": constants[n] for n in inputs if n in constants and n not in self.names})
            self.nodes.append((node.op_type, inputs, node.output[0], attrs))

    def frozen(self, how: str) -> list[str]:
        """Parameter keys to keep fixed: none (``none``), the layers up to the stride-8 map (``stride8``: what
        computes :data:`STRIDE8`), or all (``encoder``)."""
        if how == "none":
            return []
        if how == "encoder":
            return list(self.params)
        producers = {output: inputs for _, inputs, output, _ in self.nodes}
        reached: set[str] = set()
        todo = [STRIDE8]
        while todo:
            tensor = todo.pop()
            if tensor not in reached:
                reached.add(tensor)
                todo.extend(producers.get(tensor, []))
        return [key for name, key in self.names.items() if name in reached]

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        """The feature maps (name → [B, C, H/s, W/s]) of a normalised input [B, 3, H, W] (:func:`normalise`)."""
        values: dict[str, torch.Tensor] = {self.input: x}
        resized_from: dict[str, torch.Tensor] = {}
        for op, inputs, output, attrs in self.nodes:
            found = [
                values[n] if n in values else self.params[self.names[n]] if n in self.names else None for n in inputs
            ]
            args = [tensor for tensor in found if tensor is not None]  # constants (attrs) only ever follow tensors
            if not args or (op in ("Concat", "Add") and len(args) != len(found)):
                raise NotImplementedError(
                    f"ONNX node {output} ({op}) has constant inputs the eyes encoder does not read"
                )
            first = args[0]
            if op == "Conv":
                pads = attrs.get("pads", [0, 0, 0, 0])
                out = F.conv2d(
                    first,
                    args[1],
                    args[2] if len(args) > 2 else None,
                    tuple(attrs.get("strides", (1, 1))),
                    (pads[0], pads[1]),
                    tuple(attrs.get("dilations", (1, 1))),
                    attrs.get("group", 1),
                )
            elif op == "Pad":
                pads = attrs[f"const:{inputs[1]}"].tolist()
                half = len(pads) // 2  # ONNX: all begins, then all ends; torch: last axis first, (begin, end)
                torch_pads = [p for axis in reversed(range(half)) for p in (pads[axis], pads[axis + half])]
                value = float(attrs[f"const:{inputs[2]}"]) if len(inputs) > 2 else 0.0
                out = F.pad(first, torch_pads[:4], value=value)
            elif op == "LeakyRelu":
                out = F.leaky_relu(first, attrs.get("alpha", 0.01))
            elif op == "Concat":
                out = torch.cat(args, dim=attrs["axis"])
            elif op == "Add":
                a, b = args
                if a.shape[-2:] != b.shape[-2:]:  # a ×2 / ×0.5 resize of a map that is not a multiple of 32
                    if inputs[0] in resized_from:
                        a = F.interpolate(
                            resized_from[inputs[0]], size=b.shape[-2:], mode="bilinear", align_corners=False
                        )
                    else:
                        b = F.interpolate(
                            resized_from[inputs[1]], size=a.shape[-2:], mode="bilinear", align_corners=False
                        )
                out = a + b
            elif op == "Resize":
                scales = attrs[f"const:{inputs[2]}"]
                size = [int(np.floor(s * f)) for s, f in zip(first.shape[-2:], scales[-2:])]
                resized_from[output] = first
                out = F.interpolate(first, size=size, mode="bilinear", align_corners=False)
            elif op == "MaxPool":
                out = F.max_pool2d(
                    first,
                    tuple(attrs["kernel_shape"]),
                    tuple(attrs["strides"]),
                    tuple(attrs.get("pads", [0, 0, 0, 0])[:2]),
                )
            else:
                raise NotImplementedError(f"ONNX operator {op} is not read by the eyes encoder")
            values[output] = out
        return {name: values[tensor] for name, tensor in self.outputs.items()}
