"""Renders the peer comparison's cloud (issue 62) with Blender Cycles to a linear EXR.

Works with Blender 3.4 (Debian's `blender`, run headless) and with the `bpy` 5.0.1 module:

  apt-get install -y blender     # Blender 3.4.1 on Debian 12
  blender -b --factory-startup -t 2 -P scripts/results/peers/render_cycles.py -- --out a.exr --spp 16 ...

  python3.11 -m venv /tmp/peers/venv511 && /tmp/peers/venv511/bin/pip install bpy==5.0.1
  /tmp/peers/venv511/bin/python scripts/results/peers/render_cycles.py --out a.exr --spp 16 [--biased]

Scene (host's conventions, see docs/results/peers.md): the VDB's own index->world map (y up, as
host's `--up y`), a Volume Scatter (colour = albedo, HG g) plus a Volume Absorption (colour =
albedo) shader, both of density 8 x the grid's "density": sigma_s = 8 d albedo, sigma_a = 8 d
(1 - albedo). A white world of strength 1, a pinhole camera with host's position, look-at and
vertical FOV (up +y), a box pixel filter of width 1 pixel, no clamping, denoising, adaptive
sampling, guiding or fast GI; volume clipping 0, full float grid; every bounce limit 1024.
--offset-voxels shifts the volume object by that many voxels along each axis: Cycles 3.4 puts
a grid's values half a voxel higher along x, y and z than OpenVDB's voxel centres (where host,
Mitsuba and Cycles 5.0 put them), so the default is -0.5 voxels before Blender 5.0 (only 3.4 was
measured) and 0 from 5.0 on; see docs/results/peers.md. Prints "render_seconds <t>" (the render call
only: scene sync, BVH/volume build and path tracing; not Python start-up or the scene setup).
"""
import argparse
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene import add_scene_args  # noqa: E402

import bpy
from mathutils import Matrix, Vector


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    ap = argparse.ArgumentParser()
    ap.add_argument("--vdb", default="/tmp/peers/cloud.vdb")
    add_scene_args(ap)
    ap.add_argument("--bounces", type=int, default=1024)
    ap.add_argument("--offset-voxels", type=float, default=None,
                    help="default: -0.5 before Blender 5.0 (measured on 3.4 only), else 0")
    ap.add_argument("--voxel-size", type=float, default=2.0 / 128)
    ap.add_argument("--biased", action="store_true", help="Cycles >= 5.0: volume_biased (ray marching)")
    ap.add_argument("--step-rate", type=float, default=1.0)
    return ap.parse_args(argv)


def try_set(obj, name, value):
    if hasattr(obj, name):
        setattr(obj, name, value)
        return True
    return False


def main():
    a = args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = a.spp
    c.seed = a.seed
    c.use_animated_seed = False
    c.use_adaptive_sampling = False
    c.use_denoising = False
    try_set(c, "use_guiding", False)
    try_set(c, "use_fast_gi", False)
    try_set(c, "ao_bounces", 0)
    try_set(c, "ao_bounces_render", 0)
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
              "volume_bounces", "transparent_max_bounces"):
        setattr(c, k, a.bounces)
    c.min_light_bounces = 0
    c.volume_step_rate = a.step_rate
    c.volume_max_steps = 1024
    if a.biased and not try_set(c, "volume_biased", True):
        raise SystemExit("--biased: this Cycles has no volume_biased (3.4 always ray-marches)")
    try_set(c, "volume_biased", a.biased)
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    try_set(c, "light_sampling_threshold", 0.0)
    scene.render.threads_mode = "FIXED"
    scene.render.threads = a.threads
    scene.render.resolution_x = scene.render.resolution_y = a.size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False
    try:
        scene.view_settings.view_transform = "Standard"
    except TypeError:
        pass  # the pip bpy module may have no OCIO config: EXR is written linear anyway
    try:
        scene.view_settings.look = "None"
    except TypeError:
        pass
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    im = scene.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    im.color_mode = "RGBA"

    # World: white, strength 1.
    world = bpy.data.worlds.new("white")
    scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background") or world.node_tree.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0

    # Volume object from the VDB; its own transform is the world map (host: --up y).
    vol = bpy.data.volumes.new("cloud")
    vol.filepath = a.vdb
    vol.render.precision = "FULL"
    vol.render.clipping = 0.0
    vol.render.space = "OBJECT"
    vol.render.step_size = 0.0
    ob = bpy.data.objects.new("cloud", vol)
    scene.collection.objects.link(ob)
    if a.offset_voxels is None:
        a.offset_voxels = -0.5 if bpy.app.version < (5, 0, 0) else 0.0
    print(f"blender {bpy.app.version_string}, volume offset {a.offset_voxels} voxels", flush=True)
    d = a.offset_voxels * a.voxel_size
    ob.location = (d, d, d)
    alb = [float(x) for x in a.albedo.split(",")]
    alb = alb * 3 if len(alb) == 1 else alb
    mat = bpy.data.materials.new("medium")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "density"
    mul = nt.nodes.new("ShaderNodeMath")
    mul.operation = "MULTIPLY"
    mul.inputs[1].default_value = a.density_scale
    nt.links.new(attr.outputs["Fac"], mul.inputs[0])
    sca = nt.nodes.new("ShaderNodeVolumeScatter")
    try_set(sca, "phase", "HENYEY_GREENSTEIN")
    sca.inputs["Color"].default_value = (*alb, 1.0)
    sca.inputs["Anisotropy"].default_value = a.hg_g
    absn = nt.nodes.new("ShaderNodeVolumeAbsorption")
    absn.inputs["Color"].default_value = (*alb, 1.0)
    nt.links.new(mul.outputs[0], sca.inputs["Density"])
    nt.links.new(mul.outputs[0], absn.inputs["Density"])
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(sca.outputs[0], add.inputs[0])
    nt.links.new(absn.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    vol.materials.append(mat)

    # Camera: host's pinhole (looks along -z local, +y local up).
    eye = Vector([float(x) for x in a.camera.split(",")])
    target = Vector([float(x) for x in a.look_at.split(",")])
    fwd = (target - eye).normalized()
    right = fwd.cross(Vector((0, 1, 0))).normalized()
    up = right.cross(fwd)
    m = Matrix((
        (right.x, up.x, -fwd.x, eye.x),
        (right.y, up.y, -fwd.y, eye.y),
        (right.z, up.z, -fwd.z, eye.z),
        (0, 0, 0, 1),
    ))
    cam_data = bpy.data.cameras.new("cam")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(a.fov)
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 1e4
    cam = bpy.data.objects.new("cam", cam_data)
    cam.matrix_world = m
    scene.collection.objects.link(cam)
    scene.camera = cam

    scene.render.filepath = a.out
    scene.render.use_file_extension = False
    t = time.monotonic()
    bpy.ops.render.render(write_still=True)
    print(f"render_seconds {time.monotonic() - t:.4f}", flush=True)


main()
