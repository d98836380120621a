"""The eyes network: the bundled NanoDet-g encoder (:mod:`.encoder`) with light heads at a quarter of the input
resolution, for surfaces, furniture categories, instances (a centre heatmap and per-pixel offsets to the
centre) and relative depth; and its export to ONNX.

Heads: the PAN maps (stride 8, 16, 32) are reduced to :data:`WIDTH` channels, summed at stride 8, upsampled
and added to the backbone's stride-4 map, then each output is a 3×3 + 1×1 convolution pair:

    surface   [B, len(SURFACES), H/4, W/4]    logits (:data:`.labels.SURFACES`)
    category  [B, len(CATEGORIES), H/4, W/4]  logits of an object pixel's :data:`.labels.CATEGORIES`
    center    [B, 1, H/4, W/4]                probability that an object's centre is here
    offset    [B, 2, H/4, W/4]                (dx, dy) from the pixel to its object's centre, quarter pixels
    depth     [B, 1, H/4, W/4]                log z-depth up to a constant (scale-invariant)

and the 3D heads (:data:`.box3d.BOX_OUTPUTS`, what they mean in :mod:`.box3d`): two 3×3 convolutions of the
shared map, then one 1×1 convolution per output.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import torch
import torch.nn.functional as F
from torch import nn

from .box3d import BOX_OUTPUTS
from .encoder import CHANNELS, OnnxEncoder, normalise
from .labels import CATEGORIES, SURFACES

if TYPE_CHECKING:
    import onnx

WIDTH = 64
"""Channels of the heads' shared map."""
PLANE_OUTPUTS = {"surface": len(SURFACES), "category": len(CATEGORIES), "center": 1, "offset": 2, "depth": 1}
"""The image-plane heads' outputs: name → channels."""
OUTPUTS = {**PLANE_OUTPUTS, **BOX_OUTPUTS}
"""Output name → channels, in the exported ONNX's output order."""
INPUT_SIZE = (240, 320)
"""Height and width the network is trained and exported at (a photo is resized to it)."""


def _block(channels_in: int, channels_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(channels_in, WIDTH, 3, padding=1), nn.LeakyReLU(0.1), nn.Conv2d(WIDTH, channels_out, 1)
    )


class EyesNet(nn.Module):
    """Encoder + heads; ``forward`` takes sRGB in [0, 1], [B, 3, H, W], and gives :data:`OUTPUTS` maps."""

    def __init__(self, onnx_path: Path | None = None) -> None:
        super().__init__()
        self.encoder = OnnxEncoder(onnx_path)
        self.lateral = nn.ModuleDict({name: nn.Conv2d(CHANNELS[name], WIDTH, 1) for name in ("p3", "p4", "p5", "c2")})
        self.smooth8 = nn.Sequential(nn.Conv2d(WIDTH, WIDTH, 3, padding=1), nn.LeakyReLU(0.1))
        self.smooth4 = nn.Sequential(nn.Conv2d(WIDTH, WIDTH, 3, padding=1), nn.LeakyReLU(0.1))
        heads = {name: _block(WIDTH, channels) for name, channels in PLANE_OUTPUTS.items()}
        centre = heads["center"][-1]
        assert isinstance(centre, nn.Conv2d) and centre.bias is not None
        nn.init.constant_(centre.bias, -4.0)  # a centre is rare: start near probability 0.02
        self.heads = nn.ModuleDict(heads)
        self.box_trunk = nn.Sequential(
            nn.Conv2d(WIDTH, WIDTH, 3, padding=1),
            nn.LeakyReLU(0.1),
            nn.Conv2d(WIDTH, WIDTH, 3, padding=1),
            nn.LeakyReLU(0.1),
        )
        self.box_heads = nn.ModuleDict({name: nn.Conv2d(WIDTH, channels, 1) for name, channels in BOX_OUTPUTS.items()})
        self.plane_frozen = False
        """True: the encoder and the image-plane heads run without gradients (only the 3D heads train)."""

    def features(self, rgb: torch.Tensor) -> torch.Tensor:
        """The shared stride-4 map [B, WIDTH, H/4, W/4]."""
        maps = self.encoder(normalise(rgb))
        size8 = maps["p3"].shape[-2:]
        f8 = self.lateral["p3"](maps["p3"])
        for name in ("p4", "p5"):
            f8 = f8 + F.interpolate(self.lateral[name](maps[name]), size=size8, mode="bilinear", align_corners=False)
        f8 = self.smooth8(f8)
        f4 = self.lateral["c2"](maps["c2"]) + F.interpolate(
            f8, size=maps["c2"].shape[-2:], mode="bilinear", align_corners=False
        )
        return self.smooth4(f4)

    def forward(self, rgb: torch.Tensor) -> dict[str, torch.Tensor]:
        with torch.set_grad_enabled(torch.is_grad_enabled() and not self.plane_frozen):
            shared = self.features(rgb)
            out = {name: head(shared) for name, head in self.heads.items()}
        out["center"] = torch.sigmoid(out["center"])
        trunk = self.box_trunk(shared)
        out.update({name: head(trunk) for name, head in self.box_heads.items()})
        return out

    def freeze_plane(self) -> None:
        """Keep the encoder and the image-plane heads as they are: only the 3D heads train."""
        self.plane_frozen = True
        for parameter in self.plane_parameters():
            parameter.requires_grad_(False)

    def plane_parameters(self) -> list[nn.Parameter]:
        own = {id(p) for p in self.box_parameters()}
        return [p for p in self.parameters() if id(p) not in own]

    def box_parameters(self) -> list[nn.Parameter]:
        return [*self.box_trunk.parameters(), *self.box_heads.parameters()]

    def load_onnx(self, path: Path) -> list[str]:
        """Take the weights of an exported eyes network (:func:`export_onnx`) whose names match; the names of
        the parameters it lacks (the 3D heads of a network exported without them)."""
        import onnx
        from onnx import numpy_helper

        stored = {
            init.name.removeprefix("net.").removesuffix("_fp16"): numpy_helper.to_array(init)
            for init in onnx.load(str(path)).graph.initializer
        }
        state = self.state_dict()
        lacking = [key for key in state if key not in stored]
        self.load_state_dict(
            {key: torch.from_numpy(stored[key].astype("float32")) for key in state if key in stored}, strict=False
        )
        return lacking

    def encoder_parameters(self) -> list[nn.Parameter]:
        return list(self.encoder.parameters())

    def head_parameters(self) -> list[nn.Parameter]:
        own = {id(p) for p in self.encoder.parameters()}
        return [p for p in self.parameters() if id(p) not in own]


class _Exported(nn.Module):
    """The network as exported: a tuple of outputs in :data:`OUTPUTS` order."""

    def __init__(self, net: EyesNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, rgb: torch.Tensor) -> tuple[torch.Tensor, ...]:
        out = self.net(rgb)
        return tuple(out[name] for name in OUTPUTS)


def export_onnx(net: EyesNet, path: Path, half: bool = False) -> Path:
    """Write ``net`` as ONNX (input ``image``: sRGB [1, 3, 240, 320] in [0, 1]; outputs :data:`OUTPUTS`), its
    weights float16 (with Casts, computing in float32) when ``half``; the path."""
    import onnx

    net = net.eval()
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".part.onnx")
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the tracer's notes on shapes taken as constants: the input size is fixed
        torch.onnx.export(
            _Exported(net),
            (torch.zeros(1, 3, *INPUT_SIZE),),
            str(partial),
            input_names=["image"],
            output_names=list(OUTPUTS),
            opset_version=17,
            dynamo=False,
        )
    model = onnx.load(str(partial))
    if half:
        model = _half_weights(model)
    onnx.save(model, str(partial))
    partial.replace(path)
    return path


def _half_weights(model: onnx.ModelProto) -> onnx.ModelProto:
    """Float32 initializers stored as float16, each read through a Cast back to float32."""
    import numpy as np
    import onnx
    from onnx import helper, numpy_helper

    graph = model.graph
    casts = []
    for init in list(graph.initializer):
        array = numpy_helper.to_array(init)
        if array.dtype != np.float32 or array.size < 16:
            continue
        half_name = init.name + "_fp16"
        graph.initializer.remove(init)
        graph.initializer.append(numpy_helper.from_array(array.astype(np.float16), half_name))
        casts.append(helper.make_node("Cast", [half_name], [init.name], to=onnx.TensorProto.FLOAT))
    nodes = casts + list(graph.node)
    del graph.node[:]
    graph.node.extend(nodes)
    return model
