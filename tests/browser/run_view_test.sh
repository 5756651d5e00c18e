#!/usr/bin/env bash
# dofkit view in a real browser: Debian's chromium, headless, driven by playwright-core
# (tests/browser/view_test.mjs). Usage: run_view_test.sh DOFKIT WORKDIR
# Environment: DOFKIT_VIEW_SIZE (scene size, default 320x180), DOFKIT_VIEW_SCREENSHOTS (folder
# for the screenshots, default WORKDIR), DOFKIT_VIEW_LATENCY_RUNS (slider changes timed,
# default 10), DOFKIT_VIEW_SAMPLES (ground-truth samples, default 64), DOFKIT_VIEW_DISPLAY=scene (size the page so the preview is the scene's size).
# Exit 77 (CTest: skipped) only when chromium is not installed.
set -euo pipefail
DOFKIT=$(realpath "$1")
WORK=$2
HERE=$(cd "$(dirname "$0")" && pwd)
CHROMIUM=${CHROMIUM:-$(command -v chromium || true)}
if [ -z "$CHROMIUM" ]; then
  echo "SKIPPED: chromium is not installed (scripts/deps installs Debian's chromium); dofkit view's browser test did not run"
  exit 77
fi
if [ ! -f "$HERE/node_modules/playwright-core/package.json" ]; then
  echo "playwright-core is missing: run scripts/deps (or scripts/browser-deps)" >&2
  exit 1
fi
SIZE=${DOFKIT_VIEW_SIZE:-320x180}
rm -rf "$WORK"
mkdir -p "$WORK/save"
"$DOFKIT" scene occluder --out "$WORK/scene" --size "$SIZE" --samples "${DOFKIT_VIEW_SAMPLES:-64}" --layers 0 >/dev/null
# The pixel to click: the nearest surface (the pillar), away from the border; its expected focus
# is the median of the finite depths in the 7x7 window around it (the --focus-at rule).
# Debian's python3 (numpy and OpenImageIO from scripts/deps), not a virtual environment's.
PYTHON=${PYTHON:-$(command -v /usr/bin/python3 || command -v python3)}
read -r X Y FOCUS < <("$PYTHON" - "$WORK/scene/depth.exr" <<'PY'
import sys
import numpy as np
import OpenImageIO as oiio
z = oiio.ImageBuf(sys.argv[1]).get_pixels(oiio.FLOAT)[:, :, 0]
h, w = z.shape
inner = np.full_like(z, np.inf)
inner[8:h - 8, 8:w - 8] = z[8:h - 8, 8:w - 8]
y, x = np.unravel_index(np.argmin(inner), z.shape)
win = z[y - 3:y + 4, x - 3:x + 4].ravel()
v = np.sort(win[np.isfinite(win) & (win > 0)])
print(x, y, repr(float(v[len(v) // 2])))
PY
)
"$DOFKIT" view "$WORK/scene" --no-browser --save-dir "$WORK/save" --threads 2 >"$WORK/url.txt" 2>"$WORK/view.log" &
PID=$!
trap 'kill -INT $PID 2>/dev/null || true; wait $PID 2>/dev/null || true' EXIT
for _ in $(seq 1 400); do
  if [ -s "$WORK/url.txt" ]; then break; fi
  sleep 0.05
done
URL=$(head -n 1 "$WORK/url.txt")
if [ -z "$URL" ]; then
  echo "dofkit view printed no URL:" >&2
  cat "$WORK/view.log" >&2
  exit 1
fi
node "$HERE/view_test.mjs" "$URL" "$CHROMIUM" "$X" "$Y" "$FOCUS" "$DOFKIT" "$WORK" "${DOFKIT_VIEW_SCREENSHOTS:-$WORK}"
kill -INT $PID
STATUS=0
wait $PID || STATUS=$?
trap - EXIT
if [ $STATUS -ne 0 ]; then
  echo "dofkit view exited with $STATUS after SIGINT" >&2
  exit 1
fi
echo "dofkit view stopped cleanly on SIGINT"
