#!/usr/bin/python3
"""Collates scripts/peers' results.jsonl into peers.md + results.json and cuts picture crops.

usage: report.py OUTDIR [--size WxH] [--threads N] [--runs N] [--crop SCENE:X0,Y0,X1,Y1 ...]

Per scene and tool: PSNR / SSIM / edge PSNR against the thin-lens ground truth (dofkit
compare), the median time in ms, and that time divided by dofkit reference's median and by
the fastest dofkit method's median on the same scene. The mean table averages the scores and
the per-scene medians over the scenes; its ratios are ratios of those mean times.
Crops: display-referred PNGs (linear clipped to [0, 1], sRGB-encoded, 8-bit) of the input,
the ground truth and every tool, in OUTDIR/img/SCENE_TOOL.png.
"""
import argparse
import json
import math
import os
from collections import OrderedDict

import numpy as np
import OpenImageIO as oiio

DEFAULT_CROPS = ["fence:200,60,460,250", "occluder:120,60,420,300"]


def name(r):
    return "dofkit " + r["label"] if r["tool"] == "dofkit" else r["label"]


def num(v):
    return float("inf") if v == "inf" else (float("nan") if v is None else float(v))


def srgb(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def crop_png(src, dst, box):
    a = oiio.ImageBuf(src).get_pixels(oiio.FLOAT)
    x0, y0, x1, y1 = box
    rgb = srgb(a[y0:y1, x0:x1, :3])
    out = oiio.ImageOutput.create(dst)
    out.open(dst, oiio.ImageSpec(x1 - x0, y1 - y0, 3, oiio.UINT8))
    out.write_image(np.ascontiguousarray((rgb * 255.0 + 0.5).astype(np.uint8)))
    out.close()


def fmt_ratio(t, base):
    if not base or math.isnan(t):
        return "–"
    x = t / base
    return f"{x:.2f}" if x < 10 else f"{x:.0f}"


def table(rows, ref_ms, fast_ms, warm=None):
    head = "| tool | PSNR dB | SSIM | edge PSNR dB | one call ms | × dofkit reference | × fastest dofkit |"
    rule = "|---|---:|---:|---:|---:|---:|---:|"
    if warm:
        head += " warm ms | warm × dofkit reference | warm × fastest dofkit |"
        rule += "---:|---:|---:|"
        wref = warm.get("dofkit reference")
        wd = [v for n, v in warm.items() if n.startswith("dofkit ") and v]
        wfast = min(wd) if wd else None
    lines = [head, rule]
    for n, r in rows.items():
        line = (f"| {n} | {r['psnr_db']:.2f} | {r['ssim']:.4f} | {r['edge_psnr_db']:.2f} | "
                f"{r['median_ms']:.1f} | {fmt_ratio(r['median_ms'], ref_ms)} | "
                f"{fmt_ratio(r['median_ms'], fast_ms)} |")
        if warm:
            w = warm.get(n)
            line += (f" {w:.1f} | {fmt_ratio(w, wref)} | {fmt_ratio(w, wfast)} |" if w
                     else " – | – | – |")
        lines.append(line)
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--size", default="")
    ap.add_argument("--threads", default="")
    ap.add_argument("--runs", default="")
    ap.add_argument("--crop", action="append", default=None)
    a = ap.parse_args()

    recs = [json.loads(l) for l in open(os.path.join(a.out, "results.jsonl")) if l.strip()]
    for r in recs:
        for k in ("psnr_db", "ssim", "edge_psnr_db"):
            r[k] = num(r[k])
    scenes = list(OrderedDict.fromkeys(r["scene"] for r in recs))
    tools = list(OrderedDict.fromkeys(name(r) for r in recs))
    by = {(r["scene"], name(r)): r for r in recs}

    md = [f"# dofkit against GEGL and Blender ({a.size}, {a.threads} threads, "
          f"median of {a.runs} timed runs)", ""]

    def ref_fast(rows):
        ref = rows.get("dofkit reference", {}).get("median_ms")
        d = [r["median_ms"] for n, r in rows.items() if n.startswith("dofkit ")]
        return ref, (min(d) if d else None)

    mean_rows = OrderedDict()
    for t in tools:
        rs = [by[(s, t)] for s in scenes if (s, t) in by]
        if len(rs) != len(scenes):
            continue
        mean_rows[t] = {k: float(np.mean([r[k] for r in rs]))
                        for k in ("psnr_db", "ssim", "edge_psnr_db", "median_ms")}
        if all(r.get("warm_ms") for r in rs):
            mean_rows[t]["warm_ms"] = float(np.mean([r["warm_ms"] for r in rs]))
    # Warm times: the peers' own (mean over scenes); dofkit's from `dofkit bench` (bench.json).
    warm = {t: r.get("warm_ms") for t, r in mean_rows.items()}
    bench_path = os.path.join(a.out, "bench.json")
    if os.path.exists(bench_path):
        for b in json.load(open(bench_path)):
            if b["method"] != "copy":
                warm["dofkit " + b["method"]] = b["median_ms"]
                if "dofkit " + b["method"] in mean_rows:
                    mean_rows["dofkit " + b["method"]]["warm_ms"] = b["median_ms"]
    md += ["## Mean over " + ", ".join(scenes), "", table(mean_rows, *ref_fast(mean_rows), warm), ""]
    for s in scenes:
        rows = OrderedDict((t, by[(s, t)]) for t in tools if (s, t) in by)
        md += [f"## {s}", "", table(rows, *ref_fast(rows)), ""]
    with open(os.path.join(a.out, "peers.md"), "w") as f:
        f.write("\n".join(md))
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump({"scenes": scenes, "records": recs, "mean": mean_rows}, f, indent=1)

    os.makedirs(os.path.join(a.out, "img"), exist_ok=True)
    for spec in (a.crop or DEFAULT_CROPS):
        s, box = spec.split(":")
        box = [int(v) for v in box.split(",")]
        d = os.path.join(a.out, s)
        if not os.path.isdir(d):
            continue
        files = {"input": "color.exr", "ground_truth": "ground_truth.exr"}
        for r in recs:
            if r["scene"] == s:
                stem = r["label"] if r["tool"] == "dofkit" else r["tool"]
                fn = ("dofkit_" + r["label"].replace(":", "_").replace("=", "_").replace(",", "_") + ".exr"
                      if r["tool"] == "dofkit" else r["tool"] + ".exr")
                files[stem.replace(":", "_").replace("=", "_")] = fn
        for stem, fn in files.items():
            crop_png(os.path.join(d, fn), os.path.join(a.out, "img", f"{s}_{stem}.png"), box)
    print("\n".join(md))


if __name__ == "__main__":
    main()
