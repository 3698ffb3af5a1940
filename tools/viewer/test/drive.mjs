// Drives a replay page in Debian's headless Chromium (playwright-core, never a downloaded
// browser) and prints what the page shows as JSON: the browser tests
// (sim-host/tests/viewer.rs) and scripts/screenshots.sh call it.
//
//   node tools/viewer/test/drive.mjs SCRIPT.json
//
// SCRIPT: { "page": "…/replay.html", "width": 1280, "height": 800,
//           "ops": [ { "op": "state", "t": 12.5, "camera": "inertial" },
//                    { "op": "clickPlot", "fraction": 0.5 },
//                    { "op": "screenshot", "t": 100, "camera": "lvlh", "path": "…png" } ] }
// Output: { "firstFrameMs", "loadWallMs", "consoleErrors": [...], "pageErrors": [...],
//           "results": [ one per op ] }. Exit status 1 when the browser cannot start or
// the page never reports its first frame.
import { chromium } from 'playwright-core';
import { readFileSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const CHROMIUM = process.env.ACS_CHROMIUM || '/usr/bin/chromium';
const FIRST_FRAME_TIMEOUT_MS = 60_000;

const script = JSON.parse(readFileSync(process.argv[2], 'utf8'));
const profile = mkdtempSync(join(tmpdir(), 'acs-chromium-'));
// A fresh profile directory per run (playwright passes it as --user-data-dir).
const width = script.width || 1280, height = script.height || 800;
const context = await chromium.launchPersistentContext(profile, {
  executablePath: CHROMIUM,
  headless: true,
  viewport: { width, height },
  args: [
    '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
    '--disable-sync', '--no-first-run', '--enable-unsafe-swiftshader', '--use-angle=swiftshader',
  ],
});
const out = { consoleErrors: [], pageErrors: [], requests: [], results: [] };
try {
  const page = context.pages()[0] || (await context.newPage());
  page.on('console', (m) => { if (m.type() === 'error') out.consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => out.pageErrors.push(String(e)));
  // The page must not touch the network: every request other than the page itself is
  // recorded (the test fails on any) and refused.
  const url = pathToFileURL(resolve(script.page)).href;
  await page.route('**/*', (route) => {
    const u = route.request().url();
    if (u === url) return route.continue();
    if (u.startsWith('data:') || u.startsWith('blob:')) return route.continue();
    out.requests.push(u);
    return route.abort();
  });
  const t0 = Date.now();
  await page.goto(url, { waitUntil: 'load', timeout: FIRST_FRAME_TIMEOUT_MS });
  await page.waitForFunction(() => window.acsReplay && (window.acsReplay.ready || window.acsReplay.error), null, { timeout: FIRST_FRAME_TIMEOUT_MS });
  out.loadWallMs = Date.now() - t0;
  out.firstFrameMs = await page.evaluate(() => window.acsReplay.firstFrameMs);
  out.startError = await page.evaluate(() => window.acsReplay.error || null);
  out.rowTimes = await page.evaluate(() => (window.acsReplay.rows ? window.acsReplay.rows().length : 0));
  for (const op of script.ops || []) {
    if (op.camera) await page.evaluate((c) => window.acsReplay.setCamera(c), op.camera);
    if (op.t !== undefined) await page.evaluate((t) => window.acsReplay.seek(t), op.t);
    if (op.op === 'state') {
      out.results.push(await page.evaluate(() => window.acsReplay.state()));
    } else if (op.op === 'clickPlot') {
      const box = await page.locator('#plot').boundingBox();
      // The plot's data area starts 54 px in and ends 10 px before the right edge (plot.js pad).
      const sx = box.width / (await page.evaluate(() => document.getElementById('plot').width));
      const x = box.x + sx * (54 + op.fraction * (await page.evaluate(() => document.getElementById('plot').width) - 64));
      await page.mouse.click(x, box.y + box.height / 2);
      out.results.push(await page.evaluate(() => window.acsReplay.state()));
    } else if (op.op === 'screenshot') {
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      await page.screenshot({ path: op.path });
      out.results.push({ path: op.path });
    } else if (op.op === 'text') {
      out.results.push(await page.evaluate((sel) => document.querySelector(sel).textContent, op.selector));
    }
  }
} finally {
  await context.close();
  rmSync(profile, { recursive: true, force: true });
}
console.log(JSON.stringify(out));
