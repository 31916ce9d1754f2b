"""An independent reference for raysplat: Blender Cycles (the `bpy` package from PyPI,
`pip install bpy==4.2.0` with CPython 3.11) renders a glTF file as Blender's own importer
reads it, lit by a uniform environment, with no denoiser or clamping and a one-pixel box
filter (raysplat's: its eye samples are spread evenly over each pixel), into a linear EXR that
`raysplat compare --reference` reads. Every Principled BSDF is
set to single-scattering GGX, the glTF specification's microfacet model (Blender's default,
multiscatter GGX, adds the energy single scattering loses; `--multiscatter` keeps it).
Cycles' path-length limits are raised to 1,024 bounces of every kind and its Filter Glossy
(which roughens glossy and glass lobes met after a rough bounce) is off: Blender's defaults
(4 diffuse, 4 glossy bounces, Filter Glossy 1) bias the image, most where light passes
through glass (a glass sphere read 7-30% darker than with these settings).

    python3 tools/cycles_reference.py SCENE.glb OUT.exr --spp 2048 --width 200 --height 200 \
        [--camera NAME] [--env-strength 1]

Run it from a folder without a file named `cycles.py` (Python would import that instead of
Blender's add-on). The file needs a camera of its own (raysplat's framing camera is its own
invention); both renderers then use it. docs/results.md, "The file's own materials".
"""
import argparse

import bpy

p = argparse.ArgumentParser()
p.add_argument("scene")
p.add_argument("out")
p.add_argument("--spp", type=int, default=2048)
p.add_argument("--width", type=int, default=200)
p.add_argument("--height", type=int, default=200)
p.add_argument("--camera", default=None)
p.add_argument("--env-strength", type=float, default=1.0)
p.add_argument("--env-map", default=None, help="an equirectangular map instead of the uniform light")
p.add_argument("--multiscatter", action="store_true")
p.add_argument("--env-rotation-z", type=float, default=-1.5707963, help=argparse.SUPPRESS)
a = p.parse_args()

bpy.ops.wm.read_factory_settings(use_empty=True)
import addon_utils  # noqa: E402  (after the factory settings, which reset the add-ons)

addon_utils.enable("cycles", default_set=True)
bpy.ops.import_scene.gltf(filepath=a.scene)
sc = bpy.context.scene
if not a.multiscatter:
    for mat in bpy.data.materials:
        for node in mat.node_tree.nodes if mat.use_nodes else []:
            if node.type == "BSDF_PRINCIPLED":
                node.distribution = "GGX"
cams = [o for o in sc.objects if o.type == "CAMERA" and (a.camera is None or o.name == a.camera)]
if not cams:
    raise SystemExit(f"{a.scene}: no camera" + (f" named {a.camera}" if a.camera else ""))
sc.camera = cams[0]
world = bpy.data.worlds.new("uniform")
sc.world = world
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
bg.inputs[0].default_value = (1, 1, 1, 1)
bg.inputs[1].default_value = a.env_strength
if a.env_map:
    # raysplat's map convention (scene::environment::direction_of_uv, glTF's Y up): u = 1/2
    # looks along -Z, u = 3/4 along +X. Blender's (Z up, glTF -Z is Blender +Y): u = 1/2
    # looks along +X. A quarter turn about the vertical maps one onto the other.
    nodes, links = world.node_tree.nodes, world.node_tree.links
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(a.env_map)
    tex.image.colorspace_settings.name = "Linear Rec.709"
    tex.interpolation = "Closest"
    coord = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, a.env_rotation_z)
    links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], bg.inputs[0])
sc.render.engine = "CYCLES"
sc.cycles.device = "CPU"
sc.cycles.samples = a.spp
sc.cycles.use_denoising = False
sc.cycles.use_adaptive_sampling = False
# An unbiased reference: no path-length limit that matters, no filter on glossy lobes.
for kind in ("max", "diffuse", "glossy", "transmission", "volume", "transparent_max"):
    setattr(sc.cycles, f"{kind}_bounces", 1024)
sc.cycles.blur_glossy = 0.0
sc.cycles.caustics_reflective = True
sc.cycles.caustics_refractive = True
sc.cycles.sample_clamp_direct = 0
sc.cycles.sample_clamp_indirect = 0
sc.cycles.pixel_filter_type = "BOX"
sc.cycles.filter_width = 1.0
sc.render.resolution_x = a.width
sc.render.resolution_y = a.height
sc.render.resolution_percentage = 100
sc.view_settings.view_transform = "Standard"
sc.render.image_settings.file_format = "OPEN_EXR"
sc.render.image_settings.color_depth = "32"
sc.render.filepath = a.out
bpy.ops.render.render(write_still=True)
