// Drives the `coloc view` page in Debian's chromium (headless, through playwright-core):
//   node view_page.mjs saved URL SCREENSHOT.png   -> JSON: counts, the clicked keyframe's panel
//   node view_page.mjs live URL SCREENSHOT.png SECONDS -> JSON: the live frames the page showed
// Prints one JSON line on stdout; exit 1 with the reason on stderr when the page fails.
// PLAYWRIGHT_CORE: path of playwright-core's index.mjs.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

// playwright-core from the viewer's npm tree (slam/view/web, scripts/install_web).
const { chromium } = await import(pathToFileURL(process.env.PLAYWRIGHT_CORE).href);

const [mode, url, screenshot, secondsArg] = process.argv.slice(2);

async function launch() {
  // A fresh profile each time; flags for running as root in a container without a GPU.
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'coloc-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    // VIEWPORT=WxH for a smaller picture (the README's screenshot).
    viewport: (([w, h]) => ({ width: w, height: h }))((process.env.VIEWPORT || '1280x720').split('x').map(Number)),
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  return { context, profile };
}

const text = (page, id) => page.locator('#' + id).textContent();

async function saved(page) {
  await page.goto(url, { timeout: 120000 });
  // The scene has arrived when the keyframe count is set and the 3-D view has framed it.
  await page.waitForFunction(() => window.colocView && window.colocView.state.scene, null, { timeout: 30000 });
  const counts = {
    keyframes: Number(await text(page, 'count-keyframes')),
    points: Number(await text(page, 'count-points')),
    slam_markers: Number(await text(page, 'count-slam-markers')),
    scan_markers: Number(await text(page, 'count-scan-markers')),
    loops: Number(await text(page, 'count-loops')),
    frame: await text(page, 'frame'),
  };
  // Click a keyframe in the 3-D view: the one whose camera centre is nearest the middle of
  // the screen, at its projected position (the page's own picking decides what was hit).
  const target = await page.evaluate(() => {
    const v = window.colocView, rect = document.getElementById('canvas').getBoundingClientRect();
    let best = null;
    for (const k of v.state.scene.keyframes) {
      const p = v.keyframeScreenPosition(k.id);
      if (!p.visible || p.x < rect.left + 5 || p.x > rect.right - 5 || p.y < rect.top + 5 || p.y > rect.bottom - 5) continue;
      const d = Math.hypot(p.x - (rect.left + rect.width / 2), p.y - (rect.top + rect.height / 2));
      if (!best || d < best.d) best = { id: k.id, x: p.x, y: p.y, d };
    }
    return best;
  });
  if (!target) throw new Error('no keyframe visible on screen');
  await page.mouse.click(target.x, target.y);
  await page.waitForFunction(() => !document.getElementById('keyframe').hidden &&
    document.getElementById('kf-image').dataset.loaded, null, { timeout: 15000 });
  const panel = await page.evaluate(() => {
    const img = document.getElementById('kf-image');
    return { id: Number(document.getElementById('kf-id').textContent), loaded: img.dataset.loaded,
             natural_width: img.naturalWidth, natural_height: img.naturalHeight,
             tracked: Number(document.getElementById('kf-tracked').textContent),
             markers: document.getElementById('kf-markers').textContent,
             selected: window.colocView.state.selected };
  });
  // The scene must actually be drawn: the canvas is not one flat colour.
  const drawn = await page.evaluate(() => {
    const c = document.getElementById('canvas');
    const g = document.createElement('canvas');
    g.width = 64; g.height = 36;
    const x = g.getContext('2d');
    x.drawImage(c, 0, 0, 64, 36);
    const d = x.getImageData(0, 0, 64, 36).data;
    const seen = new Set();
    for (let i = 0; i < d.length; i += 4) seen.add(d[i] << 16 | d[i + 1] << 8 | d[i + 2]);
    return seen.size;
  });
  const registration = await page.evaluate(() => ({
    shown: !document.getElementById('registration').hidden,
    markers: Math.max(0, document.querySelectorAll('#reg-markers tr').length - 1) }));
  return { counts, clicked: target.id, panel, canvas_colours: drawn, registration };
}

async function live(page, seconds) {
  await page.goto(url, { timeout: 120000 });
  const frames = [];
  const end = Date.now() + 1000 * seconds;
  // Sample what the live panel shows; leave (close the browser while the stream is open) once
  // 6 frames up to frame 30 at least (a second of camera motion) and the growing map have
  // arrived, or 30 s after the last new frame when the run ended sooner (a busy machine may
  // stall the run for seconds).
  let lastIndex = null, lastChange = Date.now();
  const mapShown = async () => Number(await text(page, 'count-keyframes')) > 0;
  while (Date.now() < end && !(frames.length >= 6 && lastIndex >= 30 && await mapShown()) &&
         !(frames.length > 0 && Date.now() - lastChange > 30000)) {
    const f = await page.evaluate(() => window.colocView && window.colocView.state.live &&
      { index: window.colocView.state.live.index, state: window.colocView.state.live.state,
        pose: window.colocView.state.live.pose,
        shown: document.getElementById('live-position').textContent,
        keypoints: window.colocView.state.live.keypoints.length / 2 });
    if (f && f.index !== lastIndex) { frames.push(f); lastIndex = f.index; lastChange = Date.now(); }
    await page.waitForTimeout(50);
  }
  const counts = { keyframes: Number(await text(page, 'count-keyframes')),
                   points: Number(await text(page, 'count-points')) };
  return { frames, counts };
}

const { context, profile } = await launch();
let code = 0;
try {
  const page = context.pages()[0] || await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const result = mode === 'live' ? await live(page, Number(secondsArg || 20)) : await saved(page);
  await page.screenshot({ path: screenshot });
  result.page_errors = errors;
  console.log(JSON.stringify(result));
} catch (e) {
  console.error('view_page:', e.message);
  code = 1;
} finally {
  await context.close();
  fs.rmSync(profile, { recursive: true, force: true });
}
process.exit(code);
