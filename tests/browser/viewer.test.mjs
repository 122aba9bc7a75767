// The pbdam serve viewer in headless Chromium (Debian's /usr/bin/chromium driven by
// playwright-core): it loads, shows a server-rendered frame, flies with the keyboard, mouse drag
// and wheel (the frame and camera change), drapes a viewshed (V), lights the planet by the sun of
// a time (L) and moves it an hour (]), asks only for frames it shows, and logs no console errors. Screenshots go to ARTIFACT_DIR.
//   node viewer.test.mjs PBDAM_EXE DATASET_DIR ARTIFACT_DIR
import { spawn } from "node:child_process";
import { mkdtempSync, mkdirSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";

const [pbdam, dataset, artifacts] = process.argv.slice(2);
if (!pbdam || !dataset || !artifacts) {
  console.error("usage: node viewer.test.mjs PBDAM_EXE DATASET_DIR ARTIFACT_DIR");
  process.exit(2);
}
mkdirSync(artifacts, { recursive: true });

const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures.push(what);
};
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// The whole test is bounded: a hang is a failure, not a stuck CI job.
const watchdog = setTimeout(() => {
  console.error("FAIL: the browser test ran over 240 s");
  process.exit(1);
}, 240_000);

function startServer() {
  return new Promise((resolve, reject) => {
    const child = spawn(pbdam, ["serve", dataset, "--port", "0", "--workers", "1"],
                        { stdio: ["ignore", "pipe", "inherit"] });
    let out = "";
    child.stdout.on("data", (chunk) => {
      out += chunk;
      const m = out.match(/http:\/\/127\.0\.0\.1:(\d+)\//);
      if (m) resolve({ child, port: Number(m[1]), output: () => out });
    });
    child.on("exit", (code) => reject(new Error(`pbdam serve exited (${code}): ${out}`)));
  });
}

const server = await startServer();
const base = `http://127.0.0.1:${server.port}`;
const profile = mkdtempSync(join(tmpdir(), "pbdam-chromium-"));
let context;
try {
  context = await chromium.launchPersistentContext(profile, {
    executablePath: "/usr/bin/chromium",
    headless: true,
    viewport: { width: 480, height: 320 },
    // Without the background-networking flags Chromium keeps calling out to Google services,
    // which a closed network turns into a flood of failing connections.
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync"],
  });
  const page = context.pages()[0] ?? await context.newPage();
  const consoleErrors = [];
  page.on("console", (msg) => { if (msg.type() === "error") consoleErrors.push(msg.text()); });
  page.on("pageerror", (err) => consoleErrors.push(String(err)));

  const viewer = () => page.evaluate(() => ({ ...window.pbdamViewer,
                                              camera: { ...window.pbdamViewer.camera } }));
  // Waits until the viewer has shown more than `count` frames and has nothing in flight.
  async function settledAfter(count) {
    await page.waitForFunction((n) => window.pbdamViewer && window.pbdamViewer.framesShown > n,
                               count, { timeout: 60_000 });
    for (let quiet = 0; quiet < 5;) {
      await sleep(100);
      quiet = (await viewer()).inFlight ? 0 : quiet + 1;
    }
    return viewer();
  }

  await page.goto(`${base}/?lat=18.4&lon=-133.9&alt=400000&pitch=-60`);
  const first = await settledAfter(0);
  check(first.framesShown >= 1, `the first frame is shown (${first.framesShown})`);
  check((await page.locator("#frame").evaluate((img) => img.naturalWidth)) > 0,
        "the <img> holds a decoded frame");
  const hud = await page.locator("#hud").innerText();
  check(/lat 18\.4000°/.test(hud) && /alt 400\.00 km/.test(hud),
        `the HUD shows lat/lon/alt (${hud.split("\n")[0]})`);
  check(/patches/.test(hud) && /triangles/.test(hud), "the HUD shows frame statistics");
  const before = await page.screenshot();
  writeFileSync(join(artifacts, "viewer_start.png"), before);

  // Keyboard: fly forward and turn.
  await page.locator("#view").focus();
  await page.keyboard.down("w");
  await sleep(700);
  await page.keyboard.up("w");
  await page.keyboard.down("ArrowLeft");
  await sleep(400);
  await page.keyboard.up("ArrowLeft");
  const afterKeys = await settledAfter(first.framesShown);
  check(afterKeys.camera.lat !== first.camera.lat || afterKeys.camera.lon !== first.camera.lon,
        `W moved the camera (${first.camera.lat.toFixed(4)},${first.camera.lon.toFixed(4)} → ` +
        `${afterKeys.camera.lat.toFixed(4)},${afterKeys.camera.lon.toFixed(4)})`);
  check(afterKeys.camera.heading < first.camera.heading, "ArrowLeft turned the camera");
  const moved = await page.screenshot();
  writeFileSync(join(artifacts, "viewer_after_keys.png"), moved);
  check(Buffer.compare(before, moved) !== 0, "the frame on screen changed");

  // Mouse: drag to look, wheel for altitude.
  await page.mouse.move(240, 160);
  await page.mouse.down();
  await page.mouse.move(300, 130, { steps: 5 });
  await page.mouse.up();
  await page.mouse.wheel(0, 400);
  const afterMouse = await settledAfter(afterKeys.framesShown);
  check(afterMouse.camera.heading !== afterKeys.camera.heading, "dragging turned the camera");
  check(afterMouse.camera.alt > afterKeys.camera.alt, "the wheel raised the camera");
  writeFileSync(join(artifacts, "viewer_after_mouse.png"), await page.screenshot());

  // V: the viewshed of an eye 10 m above the ground under the camera, draped over the terrain,
  // with its figures in the HUD.
  const shownBefore = (await viewer()).framesShown;
  const plainShot = await page.screenshot();
  await page.locator("#view").focus();
  await page.keyboard.press("v");
  await page.waitForFunction(() => window.pbdamViewer.viewshed &&
                                   window.pbdamViewer.viewshed.visible_fraction !== undefined,
                             null, { timeout: 60_000 });
  await settledAfter(shownBefore);
  const vs = (await viewer()).viewshed;
  check(vs.visible_cells > 0 && vs.visible_cells < vs.cells_in_radius,
        `V computed a viewshed (${vs.visible_cells} of ${vs.cells_in_radius} cells visible)`);
  check(/viewshed from/.test(await page.locator("#hud").innerText()),
        "the HUD shows the viewshed's figures");
  const drapedShot = await page.screenshot();
  writeFileSync(join(artifacts, "viewer_viewshed.png"), drapedShot);
  check(Buffer.compare(plainShot, drapedShot) !== 0, "the viewshed is draped over the frame");

  // L: the sun of a time with the atmosphere; ] moves it an hour later. Each changes the frame
  // and the HUD names the instant.
  const unlit = await viewer();
  const unlitShot = await page.screenshot();
  await page.locator("#view").focus();
  await page.keyboard.press("l");
  const lit = await settledAfter(unlit.framesShown);
  check(lit.time === "2024-03-20T12:00:00Z", `L lit the planet by the sun of a time (${lit.time})`);
  check(/sun of 2024-03-20 12:00:00 UTC/.test(await page.locator("#hud").innerText()),
        "the HUD names the sun's instant");
  const litShot = await page.screenshot();
  writeFileSync(join(artifacts, "viewer_sun.png"), litShot);
  check(Buffer.compare(unlitShot, litShot) !== 0, "the sun changed the frame");
  await page.keyboard.press("]");
  const later = await settledAfter(lit.framesShown);
  check(later.time === "2024-03-20T13:00:00Z", `] moved the time an hour on (${later.time})`);
  check(Buffer.compare(litShot, await page.screenshot()) !== 0, "an hour later the frame differs");

  const last = await viewer();
  check(last.errors === 0, `no failed frame requests (${last.errors})`);
  check(last.requests === last.framesShown,
        `every frame asked for was shown (${last.requests} requests, ${last.framesShown} shown, ` +
        `${last.coalesced} camera updates coalesced)`);
  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? ": " +
        consoleErrors.join(" | ") : ""}`);
} catch (e) {
  failures.push(String(e && e.stack || e));
  console.error(e);
} finally {
  if (context) await context.close().catch(() => {});
  rmSync(profile, { recursive: true, force: true });
  const exited = new Promise((r) => server.child.once("exit", (code) => r(code)));
  server.child.kill("SIGTERM");
  const code = await exited;
  check(code === 0, `pbdam serve exited with ${code} after SIGTERM`);
  clearTimeout(watchdog);
}
console.log(failures.length ? `${failures.length} check(s) failed` : "all checks passed");
process.exit(failures.length ? 1 : 0);
