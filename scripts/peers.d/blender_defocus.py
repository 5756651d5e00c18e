"""Blender's compositor Defocus node with dofkit's CoC as its radius map, timed in-process.

run: blender -b --factory-startup --python-exit-code 1 --python blender_defocus.py -- \
        COLOR.exr RADIUS_RGB.exr RADIUS_JSON OUT.exr --runs N --threads T [--mode tiled|full_frame]
        [--noop-out NOOP.exr]

Compositor-only scene (no Render Layers node, so render() renders no 3-D scene):
  Image (colour, Linear) -> Defocus.Image;  Image (|r| in px, Non-Color) -> Defocus.Z
  Defocus -> Composite
Defocus settings: use_zbuffer = False (the Z socket is the blur radius in pixels times
z_scale = 1, capped at blur_max = ceil(max |r|)), bokeh CIRCLE, threshold 0, no gamma
correction, no preview (full quality), compositor quality HIGH, no OpenCL,
render threads fixed to T. Output: view transform Standard, 32-bit float RGBA EXR (linear).

Timing: bpy.ops.render.render() wall time with perf_counter, for the Defocus graph and for
a no-op graph (Image -> Composite) in alternating pairs after one untimed warm-up of each;
the blur's time is median(defocus) - median(no-op) (the no-op pays the render pipeline's
fixed cost: render-result set-up, image fetch from Blender's cache, composite copy).
Prints one JSON line prefixed by "PEERS_JSON ".
"""
import json
import math
import statistics
import sys
import time

import bpy


def parse():
    argv = sys.argv[sys.argv.index("--") + 1:]
    pos = [a for a in argv if not a.startswith("--")]
    opts = {"runs": 5, "threads": 2, "mode": "tiled", "noop-out": ""}
    i = 0
    while i < len(argv):
        if argv[i].startswith("--"):
            opts[argv[i][2:]] = argv[i + 1]
            pos.remove(argv[i + 1]) if argv[i + 1] in pos else None
            i += 2
        else:
            i += 1
    color, radius, radius_json, out = pos[:4]
    return (color, radius, radius_json, out, int(opts["runs"]), int(opts["threads"]), opts["mode"],
            opts["noop-out"])


def main():
    color_path, radius_path, radius_json, out_path, runs, threads, mode, noop_out = parse()
    with open(radius_json) as f:
        info = json.load(f)
    scene = bpy.context.scene
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = info["width"], info["height"], 100
    r.threads_mode = "FIXED"
    r.threads = threads
    r.use_compositing = True
    r.use_sequencer = False
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGBA"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0

    scene.use_nodes = True
    tree = scene.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    tree.use_opencl = False
    tree.render_quality = "HIGH"
    tree.edit_quality = "HIGH"
    if hasattr(tree, "execution_mode"):
        tree.execution_mode = "FULL_FRAME" if mode == "full_frame" else "TILED"

    img = bpy.data.images.load(color_path)
    img.colorspace_settings.name = "Linear"
    img.alpha_mode = "PREMUL"
    rad = bpy.data.images.load(radius_path)
    rad.colorspace_settings.name = "Non-Color"

    n_img = tree.nodes.new("CompositorNodeImage")
    n_img.image = img
    n_rad = tree.nodes.new("CompositorNodeImage")
    n_rad.image = rad
    dof = tree.nodes.new("CompositorNodeDefocus")
    dof.bokeh = "CIRCLE"
    dof.use_zbuffer = False
    dof.z_scale = 1.0
    dof.blur_max = float(math.ceil(info["max_radius_px"]))
    dof.threshold = 0.0
    dof.use_gamma_correction = False
    dof.use_preview = False
    comp = tree.nodes.new("CompositorNodeComposite")
    comp.use_alpha = True
    tree.links.new(n_img.outputs["Image"], dof.inputs["Image"])
    tree.links.new(n_rad.outputs["Image"], dof.inputs["Z"])

    def link(use_dof):
        for l in list(comp.inputs["Image"].links):
            tree.links.remove(l)
        tree.links.new((dof if use_dof else n_img).outputs["Image"], comp.inputs["Image"])

    def timed():
        t0 = time.perf_counter()
        bpy.ops.render.render()
        return (time.perf_counter() - t0) * 1000.0

    t_dof, t_noop = [], []
    for i in range(runs + 1):
        link(False)
        a = timed()
        link(True)
        b = timed()
        if i > 0:
            t_noop.append(a)
            t_dof.append(b)
    # The last render is the Defocus graph: save it.
    bpy.data.images["Render Result"].save_render(out_path, scene=scene)
    if noop_out:  # round-trip check: the no-op graph must return the input unchanged
        link(False)
        bpy.ops.render.render()
        bpy.data.images["Render Result"].save_render(noop_out, scene=scene)
    med_dof, med_noop = statistics.median(t_dof), statistics.median(t_noop)
    print("PEERS_JSON " + json.dumps({
        "tool": "blender", "version": bpy.app.version_string, "mode": mode, "threads": threads,
        "blur_max": dof.blur_max, "defocus_ms": t_dof, "noop_ms": t_noop,
        "median_defocus_ms": med_dof, "median_noop_ms": med_noop,
        "median_ms": med_dof - med_noop}))


main()
