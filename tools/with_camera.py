"""Copy a glTF file (.glb, or .gltf with the files beside it) into a folder with a camera
node named "cam" added: on +Z at `--distance` looking down −Z, `--yfov` radians, square. The
Khronos sample models have no camera, and a reference renderer and raysplat must share one
(docs/results/run.sh).

    python3 tools/with_camera.py MODEL.glb OUT_DIR [--distance 3.3] [--yfov 0.7]
"""
import argparse
import json
import os
import shutil
import struct

p = argparse.ArgumentParser()
p.add_argument("model")
p.add_argument("out_dir")
p.add_argument("--distance", type=float, default=3.3)
p.add_argument("--yfov", type=float, default=0.7)
a = p.parse_args()
os.makedirs(a.out_dir, exist_ok=True)


def add_camera(j):
    j.setdefault("cameras", []).append(
        {"type": "perspective", "perspective": {"yfov": a.yfov, "znear": 0.05, "aspectRatio": 1.0}}
    )
    j["nodes"].append({"name": "cam", "camera": len(j["cameras"]) - 1,
                       "translation": [0.0, 0.0, a.distance]})
    j["scenes"][j.get("scene", 0)]["nodes"].append(len(j["nodes"]) - 1)
    return j


out = os.path.join(a.out_dir, os.path.basename(a.model))
if a.model.endswith(".glb"):
    b = open(a.model, "rb").read()
    n = struct.unpack("<I", b[12:16])[0]
    j = add_camera(json.loads(b[20:20 + n]))
    rest = b[20 + n:]
    jb = json.dumps(j).encode()
    jb += b" " * (-len(jb) % 4)
    head = b"glTF" + struct.pack("<II", 2, 12 + 8 + len(jb) + len(rest))
    open(out, "wb").write(head + struct.pack("<I", len(jb)) + b"JSON" + jb + rest)
else:
    src = os.path.dirname(os.path.abspath(a.model))
    for f in os.listdir(src):
        if not f.endswith(".gltf"):
            shutil.copy(os.path.join(src, f), a.out_dir)
    json.dump(add_camera(json.load(open(a.model))), open(out, "w"))
