// The page of `dofkit view` (see cmd_view.cpp for its API: /api/info, /api/preview,
// /api/image, /api/depth, /api/command, /api/save). Plain HTML, CSS and JavaScript.
#include "view_page.hpp"

namespace dofkit::cli {

namespace {
const char* const kPage = R"PAGE(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>dofkit view</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
*{box-sizing:border-box}
body{margin:0;font:13px system-ui,sans-serif;background:#1e1f22;color:#ddd;display:flex;height:100vh;overflow:hidden}
#side{width:300px;overflow-x:hidden;padding:8px 10px;overflow-y:auto;background:#2a2b2f;border-right:1px solid #444}
#main{flex:1;position:relative;overflow:hidden;cursor:crosshair}
canvas#view{position:absolute;left:0;top:0}
h1{font-size:15px;margin:2px 0 6px}
fieldset{border:1px solid #444;margin:6px 0;padding:4px 6px;min-width:0}
legend{color:#9ab}
label{display:flex;align-items:center;gap:6px;margin:3px 0}
label span.n{width:92px;flex:none}
label input[type=range]{flex:1;min-width:0}
label output{width:52px;flex:none;font-size:12px;text-align:right;font-variant-numeric:tabular-nums}
select,input[type=text],input[type=number],button{background:#1e1f22;color:#ddd;border:1px solid #555;border-radius:3px;padding:2px 4px}
button{cursor:pointer}
#error{color:#ff8080;min-height:1em;white-space:pre-wrap;word-break:break-word}
#cmd{width:100%;height:90px;font:11px monospace;background:#18191b;color:#cfc;border:1px solid #444}
#status{position:absolute;left:8px;bottom:6px;background:#000a;padding:3px 6px;border-radius:3px;pointer-events:none}
#readout{position:absolute;right:8px;bottom:6px;background:#000a;padding:3px 6px;border-radius:3px;pointer-events:none}
progress{width:100%}
.row{display:flex;gap:4px;flex-wrap:wrap}
</style></head><body>
<div id="side">
<h1>dofkit view <small id="title"></small></h1>
<div class="row"><button id="fit">Fit</button><button id="one">1:1</button>
<label title="drag the split on the image"><input type="checkbox" id="split"> A/B split</label>
<select id="bsrc"><option value="input">B: input</option></select></div>
<fieldset><legend>Focus</legend>
<div>Click the image to focus; shift-click reads the depth.</div>
<label><span class="n">focus (m)</span><input type="number" id="focus_m" step="any" min="0.000001" style="width:110px"></label>
<div id="focus-readout" data-focus-m=""></div><div id="depth-readout" data-depth-m=""></div>
</fieldset>
<fieldset><legend>Lens</legend>
<label><span class="n">model</span><select id="model"><option value="f_number">f-number</option><option value="blur_at_infinity">blur at infinity</option></select></label>
<label id="row-fn"><span class="n">f-number</span><input type="range" id="f_number" min="0" max="1000" value="500"><output id="o_f_number"></output></label>
<label id="row-fl"><span class="n">focal length mm</span><input type="range" id="focal_length_mm" min="8" max="400" step="1"><output id="o_focal_length_mm"></output></label>
<label id="row-k"><span class="n">blur at ∞ px</span><input type="range" id="blur_at_infinity_px" min="0" max="200" step="0.5"><output id="o_blur_at_infinity_px"></output></label>
<label><span class="n">max CoC px</span><input type="range" id="max_coc_px" min="0" max="200" step="1"><output id="o_max_coc_px"></output></label>
</fieldset>
<fieldset><legend>Aperture</legend>
<label><span class="n">blades</span><input type="range" id="blades" min="2" max="16" step="1"><output id="o_blades"></output></label>
<label><span class="n">rotation °</span><input type="range" id="blade_rotation_deg" min="0" max="360" step="1"><output id="o_blade_rotation_deg"></output></label>
<label><span class="n">curvature</span><input type="range" id="blade_curvature" min="0" max="1" step="0.01"><output id="o_blade_curvature"></output></label>
<label><span class="n">anamorphic</span><input type="range" id="anamorphic" min="0.25" max="4" step="0.01"><output id="o_anamorphic"></output></label>
<label><span class="n">cat-eye</span><input type="range" id="cat_eye" min="0" max="1" step="0.01"><output id="o_cat_eye"></output></label>
</fieldset>
<fieldset><legend>Highlights</legend>
<label><input type="checkbox" id="hl_auto" checked> default for the file</label>
<label><span class="n">boost</span><input type="range" id="highlight_boost" min="0" max="256" step="1"><output id="o_highlight_boost"></output></label>
</fieldset>
<fieldset><legend>Method and overlays</legend>
<label><span class="n">method</span><select id="method"></select></label>
<label><span class="n">overlay</span><select id="overlay"><option value="">none</option><option value="coc">focus zone (CoC)</option><option value="depth">depth</option></select></label>
<div style="font-size:11px;color:#aaa">focus zone: green sharp (|r| ≤ 0.5 px), red near, blue far (brighter = larger blur)</div>
</fieldset>
<fieldset><legend>Save (full resolution)</legend>
<div class="row"><input type="text" id="save_path" value="view_render.exr" style="flex:1"><button id="save">Save</button><button id="cancel">Cancel</button></div>
<progress id="save_progress" max="1" value="0"></progress><div id="save_status" data-state="idle"></div>
<div>Equivalent command:</div><textarea id="cmd" readonly></textarea>
</fieldset>
<div id="error"></div>
</div>
<div id="main"><canvas id="view"></canvas><div id="status"></div><div id="readout"></div></div>
<script>
"use strict";
const token = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);
const V = window.dofkitView = {frames: 0, firstMsPerPixel: 0, firstWidths: [], latencies: [], fullLatencies: [], renderMs: [], fullRenderMs: [], serverMs: [], fullServerMs: [], lastSeq: 0, state: null, info: null, busy: false};
let info, state, start;
const main = $("main"), canvas = $("view"), ctx = canvas.getContext("2d");
const A = document.createElement("canvas"), B = document.createElement("canvas"), O = document.createElement("canvas");
let haveA = false, bKey = "", oKind = "", debugImg = null;
let scale = 1, offX = 0, offY = 0, fitted = true, splitX = 0.5;
let inflight = 0, pendingInputAt = 0, sent = new Map(), nextLocal = 0;

function showError(m) { $("error").textContent = m || ""; }
async function api(path, opt) {
  const r = await fetch(path, opt);
  if (!r.ok && r.status !== 409) {
    let m = r.status + "";
    try { m = (await r.json()).error || m; } catch (e) {}
    throw new Error(m);
  }
  return r;
}
const post = (path, body) => api(path, {method: "POST", headers: {"Content-Type": "application/json"}, body: JSON.stringify(body)});

// f-number slider: logarithmic from f/0.7 to f/64.
const fnToSlider = (n) => Math.round(1000 * Math.log(n / 0.7) / Math.log(64 / 0.7));
const sliderToFn = (v) => Math.round(0.7 * Math.pow(64 / 0.7, v / 1000) * 100) / 100;
const numeric = ["focal_length_mm", "blur_at_infinity_px", "max_coc_px", "blades", "blade_rotation_deg", "blade_curvature", "anamorphic", "cat_eye", "highlight_boost"];

function syncControls() {
  $("model").value = state.model;
  $("f_number").value = fnToSlider(state.f_number); $("o_f_number").textContent = "f/" + state.f_number;
  for (const k of numeric) {
    let v = state[k];
    if (k === "blades") v = v === 0 ? 2 : v;
    if (k === "highlight_boost") v = v === null ? 0 : v;
    $(k).value = v;
    $("o_" + k).textContent = k === "blades" ? (state.blades === 0 ? "circle" : state.blades) : k === "max_coc_px" && !state.max_coc_px ? "none" : String(state[k] === null ? "auto" : state[k]);
  }
  $("hl_auto").checked = state.highlight_boost === null;
  $("focus_m").value = state.focus_m;
  $("row-fn").style.display = $("row-fl").style.display = state.model === "f_number" ? "" : "none";
  $("row-k").style.display = state.model === "f_number" ? "none" : "";
  $("method").value = state.method;
  V.state = state;
}

function readControls(ev) {
  const id = ev && ev.target && ev.target.id;
  state.model = $("model").value;
  if (id === "f_number") state.f_number = sliderToFn(+$("f_number").value);
  for (const k of numeric) if (id === k) state[k] = +$(k).value;
  if (id === "blades" && state.blades === 2) state.blades = 0;
  if (id === "hl_auto") state.highlight_boost = $("hl_auto").checked ? null : +$("highlight_boost").value;
  if (id === "highlight_boost") $("hl_auto").checked = false;
  if (id === "focus_m") { const f = +$("focus_m").value; if (f > 0) { state.focus_m = f; state.focus_at = null; } }
  if (id === "method") { state.method = $("method").value; fillOverlays(); state.debug_view = ""; }
  syncControls();
  changed();
}

function fillOverlays() {
  const m = info.methods.find((x) => x.name === state.method) || {debug_views: []};
  const sel = $("overlay"), keep = sel.value;
  while (sel.options.length > 3) sel.remove(3);
  for (const v of m.debug_views) { const o = document.createElement("option"); o.value = "debug:" + v; o.textContent = "debug: " + v; sel.add(o); }
  sel.value = [...sel.options].some((o) => o.value === keep) ? keep : "";
}

// --- view transform ---
function resize() {
  const dpr = window.devicePixelRatio || 1;
  canvas.width = main.clientWidth * dpr; canvas.height = main.clientHeight * dpr;
  canvas.style.width = main.clientWidth + "px"; canvas.style.height = main.clientHeight + "px";
  if (fitted) fit();
  draw();
}
function fit() {
  fitted = true;
  scale = Math.min(canvas.width / info.width, canvas.height / info.height);
  offX = (canvas.width - info.width * scale) / 2; offY = (canvas.height - info.height * scale) / 2;
}
function previewWidth() { return Math.max(8, Math.min(info.width, Math.round(info.width * scale))); }
function toImage(clientX, clientY) {
  const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
  return [Math.floor(((clientX - r.left) * dpr - offX) / scale), Math.floor(((clientY - r.top) * dpr - offY) / scale)];
}
V.imageToClient = (x, y) => {
  const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
  return [r.left + ((x + 0.5) * scale + offX) / dpr, r.top + ((y + 0.5) * scale + offY) / dpr];
};

function draw() {
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = "#1e1f22"; ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!haveA) return;
  ctx.imageSmoothingEnabled = scale < 1;
  const w = info.width * scale, h = info.height * scale;
  ctx.drawImage(A, offX, offY, w, h);
  const ov = $("overlay").value;
  if (ov && O.width) {
    ctx.globalAlpha = ov === "coc" ? 0.55 : 1;
    if (ov.startsWith("debug:") && debugImg && (debugImg.width !== A.width || debugImg.height !== A.height)) {
      const s = Math.min(w / O.width, h / O.height, 4);
      ctx.drawImage(O, offX, offY, O.width * s, O.height * s);
    } else ctx.drawImage(O, offX, offY, w, h);
    ctx.globalAlpha = 1;
  }
  if ($("split").checked && B.width) {
    const sx = offX + w * splitX;
    ctx.save(); ctx.beginPath(); ctx.rect(sx, offY, offX + w - sx, h); ctx.clip();
    ctx.drawImage(B, offX, offY, w, h); ctx.restore();
    ctx.fillStyle = "#fff"; ctx.fillRect(sx - 1, offY, 2, h);
    ctx.fillRect(sx - 6, offY + h / 2 - 12, 12, 24);
  }
}

// --- images from the server ---
function toCanvas(cv, buf, w, h, offset) {
  cv.width = w; cv.height = h;
  cv.getContext("2d").putImageData(new ImageData(new Uint8ClampedArray(buf, offset, w * h * 4), w, h), 0, 0);
}
async function loadB() {
  if (!$("split").checked) return;
  const which = $("bsrc").value, pw = previewWidth(), key = which + pw;
  if (key === bKey) return;
  const r = await api(`/api/image?which=${which}&width=${pw}`);
  toCanvas(B, await r.arrayBuffer(), +r.headers.get("X-Width"), +r.headers.get("X-Height"), 0);
  bKey = key; draw(); V.bShown = true;
}
async function loadDepthOverlay() {
  const pw = previewWidth();
  const r = await api(`/api/image?which=depth&width=${pw}`);
  toCanvas(O, await r.arrayBuffer(), +r.headers.get("X-Width"), +r.headers.get("X-Height"), 0);
  oKind = "depth" + pw; draw();
}

// --- previews: every change is sent; the server cancels the render in flight and answers the
// superseded requests 409; the newest finished frame is shown. ---
let lastBuf = null, lastHdr = null;
function changed() {
  V.changedAt = performance.now();
  requestPreview(V.changedAt);
  updateCommand();
}
// A change is shown in two steps: a small preview first (quick feedback while a slider
// moves), then one at the displayed size, requested once the first is on screen and no newer
// change has come. The first step's width is chosen so that the server's time for it stays
// near kFirstStepMs, from the time per pixel the previous first steps took: at most half the
// displayed width, at least an eighth of it.
const kFirstStepMs = 60;
function firstStepWidth(pw) {
  let w = Math.round(pw / 2);
  if (V.firstMsPerPixel > 0)
    w = Math.min(w, Math.round(Math.sqrt((kFirstStepMs / V.firstMsPerPixel) * info.width / info.height)));
  return Math.max(w, 8, Math.round(pw / 8));
}
async function requestPreview(t0, full) {
  const ov = $("overlay").value;
  const settings = Object.assign({}, state, {debug_view: ov.startsWith("debug:") ? ov.slice(6) : ""});
  const local = ++nextLocal, pw = previewWidth();
  const coarse = !full && pw >= 320;
  inflight++; V.busy = true; $("status").textContent = "rendering…";
  try {
    const r = await post("/api/preview", {settings, width: coarse ? firstStepWidth(pw) : pw, coc_map: ov === "coc"});
    if (r.status === 409) return;
    const seq = +r.headers.get("X-Seq");
    const buf = await r.arrayBuffer();
    if (seq <= V.lastSeq) return;
    V.lastSeq = seq;
    const w = +r.headers.get("X-Width"), h = +r.headers.get("X-Height");
    toCanvas(A, buf, w, h, 0);
    haveA = true; V.previewSize = w + "x" + h;
    const o = $("overlay").value;
    const cocMap = r.headers.get("X-Coc-Map") === "1";
    if (o === "coc" && cocMap) toCanvas(O, buf, w, h, w * h * 4);
    const dw = +r.headers.get("X-Debug-Width"), dh = +r.headers.get("X-Debug-Height");
    if (o.startsWith("debug:") && dw) { toCanvas(O, buf, dw, dh, w * h * (cocMap ? 8 : 4)); debugImg = {width: dw, height: dh}; }
    if (o === "depth" && oKind !== "depth" + w) loadDepthOverlay();
    if (!o) O.width = 0;
    draw();
    const psnr = r.headers.get("X-Psnr-Db");
    $("status").textContent = `${w}×${h} preview${coarse ? " (first step; full size follows)" : ""}, ${state.method}, ${r.headers.get("X-Render-Ms")} ms render` + (psnr ? `, PSNR ${psnr} dB vs the ground truth (the scene's camera, at preview size)` : "");
    V.psnr = psnr ? +psnr : null;
    showError("");
    await new Promise((res) => requestAnimationFrame(() => res()));
    V.frames++;
    (coarse ? V.latencies : V.fullLatencies).push(performance.now() - t0);
    (coarse ? V.renderMs : V.fullRenderMs).push(+r.headers.get("X-Render-Ms"));
    (coarse ? V.serverMs : V.fullServerMs).push(+r.headers.get("X-Server-Ms"));
    if (coarse) {
      const rate = +r.headers.get("X-Server-Ms") / (w * h);
      V.firstMsPerPixel = V.firstMsPerPixel > 0 ? 0.5 * (V.firstMsPerPixel + rate) : rate;
      V.firstWidths.push(w);
    }
    if (coarse && local === nextLocal) requestPreview(t0, true);
  } catch (e) { showError(e.message); $("status").textContent = ""; }
  finally { inflight--; V.busy = inflight > 0; }
}

// Command requests can finish out of order: only the newest one's answer is shown.
let commandSeq = 0;
async function updateCommand() {
  const mine = ++commandSeq;
  try {
    const r = await post("/api/command", state);
    const command = (await r.json()).command;
    if (mine === commandSeq) $("cmd").value = command;
  } catch (e) { showError(e.message); }
}

// --- clicks, zoom, pan, split ---
let drag = null;
canvas.addEventListener("mousedown", (e) => {
  const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
  const px = (e.clientX - r.left) * dpr, w = info.width * scale;
  const onSplit = $("split").checked && Math.abs(px - (offX + w * splitX)) < 10 * dpr;
  drag = {x: e.clientX, y: e.clientY, ox: offX, oy: offY, moved: false, split: onSplit};
});
window.addEventListener("mousemove", (e) => {
  if (!drag) {
    if (!haveA) return;
    const [x, y] = toImage(e.clientX, e.clientY);
    $("readout").textContent = x >= 0 && y >= 0 && x < info.width && y < info.height ? `(${x}, ${y})` : "";
    return;
  }
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y, dpr = window.devicePixelRatio || 1;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
  if (!drag.moved) return;
  if (drag.split) {
    const r = canvas.getBoundingClientRect();
    splitX = Math.min(1, Math.max(0, ((e.clientX - r.left) * dpr - offX) / (info.width * scale)));
  } else { offX = drag.ox + dx * dpr; offY = drag.oy + dy * dpr; fitted = false; }
  draw();
});
window.addEventListener("mouseup", async (e) => {
  const d = drag; drag = null;
  if (!d || d.moved || e.target !== canvas) return;
  const [x, y] = toImage(e.clientX, e.clientY);
  if (x < 0 || y < 0 || x >= info.width || y >= info.height) return;
  try {
    const j = await (await api(`/api/depth?x=${x}&y=${y}`)).json();
    $("depth-readout").textContent = `depth at (${x}, ${y}): ${j.depth_m} m`;
    $("depth-readout").dataset.depthM = j.depth_m;
    if (e.shiftKey) return;
    if (j.focus_m === undefined) { showError(j.focus_error); return; }
    state.focus_at = [x, y]; state.focus_m = j.focus_m;
    $("focus-readout").textContent = `focus ${j.focus_m.toPrecision(6)} m (median depth around (${x}, ${y}))`;
    $("focus-readout").dataset.focusM = j.focus_m;
    syncControls(); changed();
  } catch (err) { showError(err.message); }
});
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
  const mx = (e.clientX - r.left) * dpr, my = (e.clientY - r.top) * dpr;
  const f = Math.exp(-e.deltaY * 0.0015), ns = Math.min(32, Math.max(0.02, scale * f));
  offX = mx - (mx - offX) * ns / scale; offY = my - (my - offY) * ns / scale; scale = ns; fitted = false;
  draw(); schedule();
}, {passive: false});
let zoomTimer = 0;
function schedule() { clearTimeout(zoomTimer); zoomTimer = setTimeout(() => { if (previewWidth() !== A.width) changed(); loadB(); }, 150); }
$("fit").onclick = () => { fit(); draw(); schedule(); };
$("one").onclick = () => {
  const cx = canvas.width / 2, cy = canvas.height / 2, ns = 1;
  offX = cx - (cx - offX) * ns / scale; offY = cy - (cy - offY) * ns / scale; scale = ns; fitted = false; draw(); schedule();
};
$("split").onchange = () => { V.bShown = false; loadB().catch((e) => showError(e.message)); draw(); };
$("bsrc").onchange = () => { bKey = ""; loadB().catch((e) => showError(e.message)); };
$("overlay").onchange = () => {
  const o = $("overlay").value;
  if (o === "depth") loadDepthOverlay().catch((e) => showError(e.message));
  if (o === "coc" || o.startsWith("debug:")) changed();
  if (!o) { O.width = 0; draw(); }
};
for (const id of ["model", "f_number", ...numeric, "hl_auto", "method", "focus_m"]) $(id).addEventListener(id === "method" || id === "model" || id === "focus_m" || id === "hl_auto" ? "change" : "input", readControls);

// --- save ---
$("save").onclick = async () => {
  try {
    const r = await post("/api/save?token=" + encodeURIComponent(token), {path: $("save_path").value, settings: state});
    const j = await r.json();
    if (r.status === 409) { showError(j.error); return; }
    ++commandSeq; $("cmd").value = j.command;
    $("save_status").dataset.state = "running";
    poll();
  } catch (e) { showError(e.message); $("save_status").textContent = "refused: " + e.message; $("save_status").dataset.state = "refused"; }
};
$("cancel").onclick = () => post("/api/save/cancel", {});
async function poll() {
  const j = await (await api("/api/save")).json();
  $("save_progress").value = j.fraction;
  $("save_status").textContent = j.state === "running" ? `saving ${Math.round(j.fraction * 100)} %` :
    j.state === "done" ? `saved ${j.path}` + (j.psnr_db !== undefined ? ` (PSNR vs ground truth ${j.psnr_db.toFixed(2)} dB)` : "") :
    j.state === "error" ? "error: " + j.error : j.state;
  $("save_status").dataset.state = j.state;
  if (j.state === "error") showError(j.error);
  if (j.state === "running") setTimeout(poll, 150);
}

async function init() {
  info = V.info = await (await api("/api/info")).json();
  state = info.state; start = JSON.parse(JSON.stringify(state));
  $("title").textContent = info.scene ? "scene " + info.scene : info.color;
  for (const m of info.methods) { const o = document.createElement("option"); o.value = o.textContent = m.name; $("method").add(o); }
  if (info.ground_truth) { const o = document.createElement("option"); o.value = "truth"; o.textContent = "B: ground truth"; $("bsrc").add(o); $("bsrc").value = "truth"; }
  fillOverlays();
  if (state.debug_view) $("overlay").value = "debug:" + state.debug_view;
  syncControls();
  window.addEventListener("resize", () => { resize(); schedule(); });
  resize();
  changed();
}
init().catch((e) => showError(e.message));
</script></body></html>
)PAGE";
}  // namespace

const std::string& view_page() {
  static const std::string page(kPage);
  return page;
}

}  // namespace dofkit::cli
