#!/usr/bin/python3
"""GEGL's gegl:lens-blur with dofkit's CoC as its per-pixel radius map, timed in-process.

usage: gegl_lensblur.py COLOR.exr GEGL_MASK.exr RADIUS_JSON OUT.exr --runs N --threads T

The inputs are read with OpenImageIO into GeglBuffers before any timing ("RGBA float"
colour: linear, straight alpha -- dofkit's scenes have alpha 1, so premultiplied and
straight agree; "Y float" mask). Each run builds a fresh graph
  gegl:buffer-source (colour) -> gegl:lens-blur (radius = R, linear-mask, clip) -> gegl:write-buffer
  gegl:buffer-source (mask)   -> lens-blur's aux pad
so no node cache is reused, and times only the sink's process() call (the whole blur, on
GEGL's own worker threads, Gegl.config().threads = T, OpenCL off). The first run is the
cold call (GEGL's worker threads and tile memory start here, as dofkit's do in a one-shot
`dofkit render`): reported as first_ms, not in the median. Prints one JSON object:
first_ms, the warm times in ms of the N runs after it and their median.
"""
import argparse
import json
import statistics
import time

import gi
gi.require_version("Gegl", "0.4")
from gi.repository import Gegl  # noqa: E402
import numpy as np  # noqa: E402
import OpenImageIO as oiio  # noqa: E402


def to_buffer(arr, fmt):
    h, w = arr.shape[:2]
    b = Gegl.Buffer.new(fmt, 0, 0, w, h)
    b.set(Gegl.Rectangle.new(0, 0, w, h), fmt, np.ascontiguousarray(arr, np.float32).tobytes())
    return b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("color")
    ap.add_argument("mask")
    ap.add_argument("radius_json")
    ap.add_argument("out")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()

    Gegl.init(None)
    cfg = Gegl.config()
    cfg.props.threads = a.threads
    cfg.props.use_opencl = False

    color = oiio.ImageBuf(a.color).get_pixels(oiio.FLOAT)
    if color.shape[2] == 3:
        color = np.concatenate([color, np.ones(color.shape[:2] + (1,), np.float32)], axis=2)
    mask = oiio.ImageBuf(a.mask).get_pixels(oiio.FLOAT)[:, :, 0]
    with open(a.radius_json) as f:
        big_r = json.load(f)["max_radius_px"]
    h, w = mask.shape
    src = to_buffer(color[:, :, :4], "RGBA float")
    aux = to_buffer(mask, "Y float")

    times = []
    first_ms = None
    out_buf = None
    for i in range(a.runs + 1):
        graph = Gegl.Node()
        n_src = graph.create_child("gegl:buffer-source")
        n_src.set_property("buffer", src)
        n_aux = graph.create_child("gegl:buffer-source")
        n_aux.set_property("buffer", aux)
        blur = graph.create_child("gegl:lens-blur")
        blur.set_property("radius", float(big_r))
        blur.set_property("linear-mask", True)
        blur.set_property("clip", True)
        blur.set_property("highlight-factor", 0.0)
        out_buf = Gegl.Buffer.new("RGBA float", 0, 0, w, h)
        sink = graph.create_child("gegl:write-buffer")
        sink.set_property("buffer", out_buf)
        n_src.connect_to("output", blur, "input")
        n_aux.connect_to("output", blur, "aux")
        blur.connect_to("output", sink, "input")
        t0 = time.perf_counter()
        sink.process()
        t1 = time.perf_counter()
        if i > 0:
            times.append((t1 - t0) * 1000.0)
        else:
            first_ms = (t1 - t0) * 1000.0
        del graph

    data = np.frombuffer(out_buf.get(Gegl.Rectangle.new(0, 0, w, h), 1.0, "RGBA float",
                                     Gegl.AbyssPolicy.NONE), np.float32).reshape(h, w, 4)
    # RGBA float is straight alpha; dofkit reads EXR as premultiplied (alpha is 1 here anyway).
    prem = data.copy()
    prem[:, :, :3] *= prem[:, :, 3:4]
    o = oiio.ImageOutput.create(a.out)
    o.open(a.out, oiio.ImageSpec(w, h, 4, oiio.FLOAT))
    o.write_image(prem)
    o.close()
    print(json.dumps({"tool": "gegl", "radius": big_r, "threads": a.threads,
                      "first_ms": first_ms, "times_ms": times,
                      "median_ms": statistics.median(times)}))


if __name__ == "__main__":
    main()
