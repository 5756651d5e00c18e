// dofkit view's browser test (run by run_view_test.sh): click to focus, shift-click, the
// f-number slider, the A/B split, the focus-zone overlay, Save against `dofkit render` with the
// displayed command line, and the slider → new preview latency (reported, never asserted).
import {execFileSync} from "node:child_process";
import {readFileSync} from "node:fs";
import {join} from "node:path";
import {chromium} from "playwright-core";

const [url, executablePath, X, Y, FOCUS, dofkit, work, shots] = process.argv.slice(2);
const x = +X, y = +Y, expectedFocus = +FOCUS;
const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures.push(what);
};

const browser = await chromium.launch({executablePath, args: ["--no-sandbox", "--disable-gpu"]});
try {
  const params = JSON.parse(readFileSync(join(work, "scene", "params.json"), "utf8"));
  const info = [params.width, params.height];
  // The page's image area is the viewport less the 300 px side bar: DOFKIT_VIEW_DISPLAY=scene
  // makes it the scene's size, so the preview renders at that size.
  const display = process.env.DOFKIT_VIEW_DISPLAY === "scene";
  const viewport = display ? {width: info[0] + 300, height: info[1]} : {width: 1280, height: 720};
  const page = await browser.newPage({viewport});
  page.on("pageerror", (e) => failures.push("page error: " + e.message));
  await page.goto(url);
  const frames = () => page.evaluate(() => window.dofkitView.frames);
  // Waits until a frame newer than `n` is on screen and no preview request is pending.
  const nextFrame = async (n) => {
    await page.waitForFunction((m) => window.dofkitView.frames > m && !window.dofkitView.busy, n, {timeout: 30000});
  };
  const picture = () => page.evaluate(() => document.getElementById("view").toDataURL());
  await nextFrame(0);
  check((await page.evaluate(() => document.getElementById("error").textContent)) === "", "page loads without an error");

  // Click to focus on the near object: the focus the server reports is the depth there.
  let n = await frames();
  const [cx, cy] = await page.evaluate(([a, b]) => window.dofkitView.imageToClient(a, b), [x, y]);
  await page.mouse.click(cx, cy);
  await page.waitForFunction(() => document.getElementById("focus-readout").dataset.focusM !== "", null, {timeout: 10000});
  await nextFrame(n);
  const focus = +(await page.evaluate(() => document.getElementById("focus-readout").dataset.focusM));
  check(Math.abs(focus - expectedFocus) <= 1e-6 * expectedFocus,
        `click at (${x}, ${y}) focuses at ${focus} m = the median depth there ${expectedFocus} m`);
  const state = await page.evaluate(() => window.dofkitView.state);
  check(state.focus_at && state.focus_at[0] === x && state.focus_at[1] === y, "the focus is kept as --focus-at " + state.focus_at);
  // The command line is fetched beside the preview, not before it: wait for it.
  const shown = await page.waitForFunction((s) => document.getElementById("cmd").value.includes(s), `--focus-at ${x},${y}`, {timeout: 10000})
    .then(() => true, () => false);
  check(shown, "the command line shows --focus-at");

  // Shift-click inspects the depth and keeps the focus.
  const [fx, fy] = await page.evaluate(([a, b]) => window.dofkitView.imageToClient(a, b), [info[0] - 10, 10]);
  await page.keyboard.down("Shift");
  await page.mouse.click(fx, fy);
  await page.keyboard.up("Shift");
  await page.waitForFunction((a) => document.getElementById("depth-readout").textContent.includes(`(${a}, 10)`), info[0] - 10, {timeout: 10000});
  const after = await page.evaluate(() => window.dofkitView.state);
  check(after.focus_m === focus && after.focus_at[0] === x, "shift-click keeps the focus");

  // The f-number slider: the thin-lens model, an 85 mm lens, then f/2.8 → f/2.
  n = await frames();
  await page.selectOption("#model", "f_number");
  await nextFrame(n);
  n = await frames();
  await page.$eval("#focal_length_mm", (el) => { el.value = 85; el.dispatchEvent(new Event("input", {bubbles: true})); });
  await nextFrame(n);
  const before = await picture();
  n = await frames();
  await page.$eval("#f_number", (el) => { el.value = 232; el.dispatchEvent(new Event("input", {bubbles: true})); });
  await nextFrame(n);
  check((await picture()) !== before, "moving the f-number slider changes the preview");
  await page.screenshot({path: join(shots, "view.png")});

  // A/B split against the ground truth (a scene), with the PSNR shown.
  const noSplit = await picture();
  await page.check("#split");
  await page.waitForFunction(() => window.dofkitView.bShown, null, {timeout: 10000});
  check((await picture()) !== noSplit, "the A/B split shows the ground truth beside the render");
  check((await page.evaluate(() => document.getElementById("status").textContent)).includes("PSNR"), "the PSNR against the ground truth is shown");
  await page.screenshot({path: join(shots, "view-split.png")});
  await page.uncheck("#split");

  // The focus-zone overlay.
  const plain = await picture();
  n = await frames();
  await page.selectOption("#overlay", "coc");
  await nextFrame(n);
  check((await picture()) !== plain, "the focus-zone overlay changes the picture");
  await page.screenshot({path: join(shots, "view-focus-zone.png")});
  n = await frames();
  await page.selectOption("#overlay", "");
  await page.waitForTimeout(50);

  // Save, then the displayed command line gives the same file bit for bit.
  await page.fill("#save_path", "browser.exr");
  await page.click("#save");
  await page.waitForFunction(() => ["done", "error", "refused"].includes(document.getElementById("save_status").dataset.state), null, {timeout: 60000});
  const saveState = await page.evaluate(() => document.getElementById("save_status").dataset.state);
  check(saveState === "done", "Save finishes (" + saveState + ")");
  const command = await page.evaluate(() => document.getElementById("cmd").value);
  const saved = join(work, "save", "browser.exr"), again = join(work, "cli.exr");
  check(command.includes(saved), "the command line names the saved file");
  const cli = command.replace(saved, again).replace(/^dofkit /, `'${dofkit}' `);
  execFileSync("sh", ["-c", cli + " 2>/dev/null"]);
  check(Buffer.compare(readFileSync(saved), readFileSync(again)) === 0, "the saved file equals `dofkit render` with the displayed command line, bit for bit");
  // A path outside the save folder is refused in the page.
  await page.fill("#save_path", "../outside.exr");
  await page.click("#save");
  await page.waitForFunction(() => document.getElementById("save_status").dataset.state === "refused", null, {timeout: 10000});
  check((await page.evaluate(() => document.getElementById("error").textContent)).includes(".."), "a path with .. is refused with a one-line error");

  // Latency: an f-number slider change (f/2 to f/6 at 50 mm) → the new preview on screen, the
  // first step (its width chosen by the page from the time previous ones took) and the
  // displayed-size one (medians; reported, never asserted).
  n = await frames();
  await page.$eval("#focal_length_mm", (el) => { el.value = 50; el.dispatchEvent(new Event("input", {bubbles: true})); });
  await nextFrame(n);
  const runs = +(process.env.DOFKIT_VIEW_LATENCY_RUNS || 10);
  const first = [], full = [];
  for (let i = 0; i < runs; ++i) {
    n = await frames();
    const [c0, f0] = await page.evaluate(() => [window.dofkitView.latencies.length, window.dofkitView.fullLatencies.length]);
    await page.$eval("#f_number", (el, v) => { el.value = v; el.dispatchEvent(new Event("input", {bubbles: true})); }, 230 + 30 * (i % 8));
    await nextFrame(n);
    const [c, f] = await page.evaluate(([a, b]) => [window.dofkitView.latencies[a], window.dofkitView.fullLatencies[b]], [c0, f0]);
    if (c !== undefined) first.push(c);
    if (f !== undefined) full.push(f);
  }
  const median = (v) => { v.sort((a, b) => a - b); return v.length ? v[Math.floor(v.length / 2)].toFixed(1) + " ms" : "n/a"; };
  const size = await page.evaluate(() => window.dofkitView.previewSize);
  const [rc, rf, sc, sf, fw] = await page.evaluate((k) => [window.dofkitView.renderMs, window.dofkitView.fullRenderMs,
                                                            window.dofkitView.serverMs, window.dofkitView.fullServerMs,
                                                            window.dofkitView.firstWidths.slice(-k)], runs);
  const widths = fw.slice().sort((a, b) => a - b);
  console.log(`slider -> new preview on screen over ${runs} changes, method lens, displayed size ${size}: ` +
              `median ${median(first)} to the first step (${widths[Math.floor(widths.length / 2)]} px wide, median), ` +
              `${median(full)} to the displayed-size one ` +
              `(over all previews of the test, the library's render: median ${median(rc)} first step, ${median(rf)} displayed size; ` +
              `with the 8-bit conversion and the PSNR: ${median(sc)}, ${median(sf)})`);
} finally {
  await browser.close();
}
if (failures.length) {
  console.log(`${failures.length} check(s) failed`);
  process.exit(1);
}
console.log("all browser checks passed");
