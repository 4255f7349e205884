// The web page in a real browser (Debian's headless chromium, driven by playwright-core): the live
// canvas shows non-empty frames that change while a replay runs, and the mesh viewer draws the
// finished session's model. Usage: node browser_check.mjs URL RECORDING OUT_DIR
// Exit 0: passed; 1: failed (one line says what); 77: skipped (no chromium or playwright-core).
import { existsSync } from 'node:fs';
import { createRequire } from 'node:module';

const [url, recording, outDir] = process.argv.slice(2);
const chromium = '/usr/bin/chromium';
const require = createRequire(new URL('../../src/serve/web/package.json', import.meta.url));
let playwright;
try {
  playwright = require('playwright-core');
} catch {
  console.log('SKIP: playwright-core is not installed (tools/install-deps.sh --tests)');
  process.exit(77);
}
if (!existsSync(chromium)) {
  console.log('SKIP: no chromium at /usr/bin/chromium (tools/install-deps.sh --tests)');
  process.exit(77);
}

const fail = (message) => { console.log(`FAIL: ${message}`); process.exit(1); };
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const headers = { 'Content-Type': 'application/json', 'X-Aoscan-Client': 'browser-test' };

// Pixel statistics of a canvas (a WebGL canvas is copied into a 2D one first): the share of
// pixels that differ from the page's background, whether the centre and the corners do, and a
// hash of the pixels.
function canvasStats(id) {
  const source = document.getElementById(id);
  const copy = document.createElement('canvas');
  copy.width = source.width;
  copy.height = source.height;
  const context = copy.getContext('2d');
  context.drawImage(source, 0, 0);
  const { data, width, height } = context.getImageData(0, 0, copy.width, copy.height);
  const isBackground = (i) => Math.abs(data[i] - 24) + Math.abs(data[i + 1] - 24) + Math.abs(data[i + 2] - 32) < 12;
  let lit = 0;
  let hash = 0;
  for (let i = 0; i < data.length; i += 4) {
    if (!isBackground(i)) lit += 1;
    hash = (hash * 31 + data[i] + 7 * data[i + 1] + 13 * data[i + 2]) >>> 0;
  }
  const at = (x, y) => ((y * width + x) * 4);
  let centreLit = 0;
  for (let y = Math.floor(height * 0.4); y < height * 0.6; y += 4)
    for (let x = Math.floor(width * 0.4); x < width * 0.6; x += 4) if (!isBackground(at(x, y))) centreLit += 1;
  const corners = [at(2, 2), at(width - 3, 2), at(2, height - 3), at(width - 3, height - 3)];
  return { lit: lit / (width * height), centreLit, cornersBackground: corners.every(isBackground), hash, width, height };
}

const browser = await playwright.chromium.launch({
  executablePath: chromium,
  args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1100 } });
  const errors = [];
  page.on('pageerror', (error) => errors.push(error.message));
  await page.goto(url);

  const start = await fetch(`${url}api/sessions`, { method: 'POST', headers, body: JSON.stringify({ source: recording, realtime: true, loop: 20 }) });
  if (start.status !== 201) fail(`POST /api/sessions: ${start.status} ${await start.text()}`);
  const { id } = await start.json();

  await page.waitForFunction(() => Number(document.getElementById('live').dataset.frames || 0) >= 3, null, { timeout: 60000 })
    .catch(() => fail('the live canvas received no frames within 60 s'));
  const first = await page.evaluate(canvasStats, 'live');
  // The next frame that differs: within 1.5 s on an idle machine; the stream runs at nice +10, so
  // a machine saturated by other work may hold it back for seconds.
  let second = first;
  for (let i = 0; i < 60 && second.hash === first.hash; ++i) {
    await sleep(500);
    second = await page.evaluate(canvasStats, 'live');
  }
  await page.screenshot({ path: `${outDir}/live.png` });
  if (first.lit < 0.05 || second.lit < 0.05) fail(`the live canvas is nearly blank (${first.lit}, ${second.lit} of its pixels drawn)`);
  if (first.hash === second.hash) fail('the live canvas did not change in 30 s of a running replay');
  const hud = await page.locator('#hud').innerText();
  if (!hud.includes('fps')) fail(`the HUD shows no figures: "${hud}"`);

  const stop = await fetch(`${url}api/sessions/${id}/stop`, { method: 'POST', headers });
  if (stop.status !== 200) fail(`stop: ${stop.status} ${await stop.text()}`);
  for (let i = 0; i < 600; ++i) {
    const status = await (await fetch(`${url}api/status`)).json();
    if (status.session === null) break;
    await sleep(100);
  }
  await page.evaluate((sessionId) => window.aoscan.loadMesh(sessionId), id);
  await page.waitForFunction(() => Number(document.getElementById('mesh').dataset.drawn || 0) >= 1, null, { timeout: 60000 })
    .catch(async () => fail(`the mesh viewer drew nothing: ${await page.locator('#mesh-message').innerText()}`));
  const mesh = await page.evaluate(canvasStats, 'mesh');
  await page.screenshot({ path: `${outDir}/mesh.png` });
  if (mesh.lit < 0.05) fail(`the mesh viewer is nearly blank (${mesh.lit} of its pixels drawn)`);
  if (mesh.centreLit === 0) fail('the mesh viewer shows nothing at its centre, where the model is framed');
  if (!mesh.cornersBackground) fail('the mesh viewer has no background at its corners: no silhouette');
  if (errors.length > 0) fail(`errors on the page: ${errors.join('; ')}`);
  console.log(`PASS: live canvas ${first.width}x${first.height} ${(second.lit * 100).toFixed(0)} % drawn and changing; ` +
              `mesh ${(mesh.lit * 100).toFixed(0)} % drawn with its silhouette`);
} finally {
  await browser.close();
}
