"""A synthetic studio environment for raysplat's material comparisons (docs/results.md, "The
file's own materials"): an equirectangular linear EXR, 512×256, row 0 at the zenith. A dim
grey-blue upper sky over a darker floor, a large soft box high in front-left of the -Z
direction, a narrow warm strip light to the right and a small bright key behind, so that
glossy lobes, metals and glass each see structure and the image has soft, directional light.

    python3 tools/studio_environment.py OUT.exr

Directions follow raysplat's map convention (`scene::environment::direction_of_uv`): θ = πv
from +Y, φ = 2π(u − 1/2) from −Z towards +X. `tools/cycles_reference.py --env-map` turns
the map for Blender's convention.
"""
import sys

import Imath
import numpy as np
import OpenEXR

W, H = 512, 256
v = (np.arange(H) + 0.5) / H
u = (np.arange(W) + 0.5) / W
theta = np.pi * v[:, None]
phi = 2 * np.pi * (u[None, :] - 0.5)
d = np.stack(
    [np.sin(theta) * np.sin(phi), np.cos(theta) * np.ones_like(phi), -np.sin(theta) * np.cos(phi)],
    -1,
)
up = d[..., 1]
# Sky above, floor below, a soft horizon between.
t = np.clip(up * 4 + 0.5, 0, 1)[..., None]
rgb = (1 - t) * np.array([0.08, 0.07, 0.06]) + t * np.array([0.35, 0.4, 0.5])


def soft_box(direction, radius_deg, colour, softness=0.15):
    c = np.array(direction, dtype=np.float64)
    c /= np.linalg.norm(c)
    cos = (d * c).sum(-1)
    ang = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    w = np.clip((radius_deg - ang) / (softness * radius_deg) + 0.5, 0, 1)
    return w[..., None] * np.array(colour)


rgb += soft_box([-0.6, 0.8, -0.6], 22, [6.0, 6.0, 6.0])
rgb += soft_box([0.9, 0.35, -0.2], 8, [9.0, 6.5, 4.0])
rgb += soft_box([0.2, 0.5, 0.9], 4, [30.0, 30.0, 28.0])
rgb = rgb.astype(np.float32)
header = OpenEXR.Header(W, H)
header["channels"] = {c: Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT)) for c in "RGB"}
out = OpenEXR.OutputFile(sys.argv[1], header)
out.writePixels({c: rgb[..., i].tobytes() for i, c in enumerate("RGB")})
out.close()
