#!/usr/bin/python3
"""Turns dofkit's signed CoC map into the radius inputs the peer tools take.

usage: radius_maps.py COC.exr OUTDIR

dofkit writes the signed circle-of-confusion radius r (pixels, near > 0, far < 0, already
clamped) with `dofkit render --output-coc`. A disc of radius |r| covers pi*r^2 pixels in
dofkit (coverage sat(rho - d + 0.5), rho = max(|r|, 0.5)). Writes:

  radius_rgb.exr  R = G = B = |r| in pixels, A = 1: Blender's Defocus node with use_zbuffer
                  off reads its Z socket as the radius in pixels (times z_scale = 1); its
                  gather takes a neighbour when |dx|, |dy| < size and the circular bokeh
                  image is non-zero at (dx, dy)/size, i.e. a disc of radius |r|.
  gegl_mask.exr   one channel m = clamp((|r| - 0.5) / R, 0, 1) with R = max |r|: GEGL's
                  gegl:lens-blur (linear-mask on, radius R) scatters each pixel over the
                  integer offsets with dx^2 + dy^2 <= (m R + 0.5)^2, a disc of radius
                  m R + 0.5 (pi (mR + 0.5)^2 pixels), so m R + 0.5 = |r| gives the same area;
                  |r| <= 0.5 (in focus in dofkit) gives m = 0, the pixel itself.
  radius.json     {"max_radius_px": R, "width": W, "height": H}
"""
import json
import os
import sys

import numpy as np
import OpenImageIO as oiio


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    coc_path, outdir = sys.argv[1], sys.argv[2]
    buf = oiio.ImageBuf(coc_path)
    r = np.abs(buf.get_pixels(oiio.FLOAT)[:, :, 0].astype(np.float64))
    h, w = r.shape
    big_r = max(float(r.max()), 1.0)

    rgb = np.ones((h, w, 4), np.float32)
    rgb[:, :, 0] = rgb[:, :, 1] = rgb[:, :, 2] = r.astype(np.float32)
    out = oiio.ImageOutput.create(os.path.join(outdir, "radius_rgb.exr"))
    spec = oiio.ImageSpec(w, h, 4, oiio.FLOAT)
    out.open(os.path.join(outdir, "radius_rgb.exr"), spec)
    out.write_image(rgb)
    out.close()

    m = np.ascontiguousarray(np.clip((r - 0.5) / big_r, 0.0, 1.0).astype(np.float32)[:, :, None])
    spec1 = oiio.ImageSpec(w, h, 1, oiio.FLOAT)
    spec1.channelnames = ("Y",)
    out = oiio.ImageOutput.create(os.path.join(outdir, "gegl_mask.exr"))
    out.open(os.path.join(outdir, "gegl_mask.exr"), spec1)
    out.write_image(m)
    out.close()

    with open(os.path.join(outdir, "radius.json"), "w") as f:
        json.dump({"max_radius_px": big_r, "width": w, "height": h}, f)


if __name__ == "__main__":
    main()
