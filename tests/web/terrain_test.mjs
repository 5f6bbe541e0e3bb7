// The 3D terrain view (server/web/terrain.html) in Debian's Chromium, WebGL through SwiftShader,
// against a real `textond serve`: a material set (a grey photo as albedo and height) uploaded,
// then MapLibre GL JS loads the set's two TileJSONs, its terrarium elevation tiles (terrain and
// hillshade) and its lit drape tiles, all 200, with no console or map errors; the terrain answers
// elevations that differ from place to place; the canvas is not blank; a pan and a zoom fetch
// new tiles of both kinds (the plane does not end). A screenshot goes to ARTEFACT_DIR.
//
// usage: node terrain_test.mjs TEXTOND_BINARY HEIGHT_AND_ALBEDO.png ARTEFACT_DIR
import { chromium } from 'playwright-core';
import { mkdirSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { checker, startServer } from './harness.mjs';

const [binary, photo, artefacts] = process.argv.slice(2);
mkdirSync(artefacts, { recursive: true });
const { check, failures } = checker();

const data = mkdtempSync(join(tmpdir(), 'textond-terrain-'));
const { proc, url } = await startServer(binary, data);

let browser;
try {
  browser = await chromium.launch({
    executablePath: '/usr/bin/chromium', headless: true,
    // WebGL in a headless browser without a GPU: ANGLE on SwiftShader.
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--ignore-gpu-blocklist', '--disable-background-networking', '--no-first-run'],
  });
  const form = new FormData();
  const png = new Blob([readFileSync(photo)], { type: 'image/png' });
  form.append('albedo', png, 'albedo.png');
  form.append('height', png, 'height.png');
  form.append('size', '32');
  form.append('iterations', '20');
  const up = await fetch(`${url}/v1/textons`, { method: 'POST', body: form });
  const set = await up.json();
  check(up.status === 201 && set.maps.length === 2, `the set uploads (${up.status})`);

  const page = await browser.newPage({ viewport: { width: 1000, height: 700 } });
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(e.message));
  const tiles = { dem: [], drape: [] };
  page.on('response', (r) => {
    const u = r.url();
    if (!u.includes('/map/')) return;
    (u.includes('encoding=terrarium') ? tiles.dem : tiles.drape).push({ u, status: r.status() });
  });
  const settled = () => page.waitForFunction(() => {
    const m = window.textondTerrain;
    return m && m.loaded() && m.areTilesLoaded() && m.getTerrain();
  }, null, { timeout: 120000, polling: 250 }).then(() => true, () => false);

  await page.goto(`${url}/static/terrain.html?texton=${set.id}`);
  check(await settled(), 'MapLibre loads the style, the terrain and every tile');
  const counts = () => `${tiles.dem.length} elevation, ${tiles.drape.length} drape`;
  check(tiles.dem.length > 0 && tiles.drape.length > 0, `elevation and drape tiles fetched (${counts()})`);
  check([...tiles.dem, ...tiles.drape].every((t) => t.status === 200), 'every tile answered 200');
  const heights = await page.evaluate(() => {
    const m = window.textondTerrain;
    const c = m.getCenter();
    const out = [];
    for (let i = -3; i <= 3; ++i)
      out.push(m.queryTerrainElevation([c.lng + i * 0.00001, c.lat + i * 0.00001]));
    return out;
  });
  const spread = Math.max(...heights) - Math.min(...heights);
  check(heights.every((h) => typeof h === 'number' && Number.isFinite(h)) && spread > 0.001,
        `the terrain has relief: elevations ${heights.map((h) => h.toFixed(3)).join(', ')} m`);
  const ink = await page.evaluate(() => {
    const src = window.textondTerrain.getCanvas();
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let s = 0, s2 = 0, n = 0;
    for (let i = 0; i < d.length; i += 4 * 7) { const g = (d[i] + d[i + 1] + d[i + 2]) / 3; s += g; s2 += g * g; ++n; }
    const mean = s / n;
    return { mean, sd: Math.sqrt(s2 / n - mean * mean) };
  });
  check(ink.sd > 8, `the canvas is not blank (grey level sd ${ink.sd.toFixed(1)}, mean ${ink.mean.toFixed(1)})`);
  await page.screenshot({ path: join(artefacts, 'terrain.jpg'), type: 'jpeg', quality: 75 });

  const before = { dem: tiles.dem.length, drape: tiles.drape.length };
  await page.evaluate(() => { window.textondTerrain.jumpTo({ center: [0.01, -0.02], zoom: 20 }); });
  check(await settled(), 'after a jump elsewhere and a zoom out the view settles again');
  check(tiles.dem.length > before.dem && tiles.drape.length > before.drape,
        `new tiles of both kinds after the jump (${counts()})`);
  check([...tiles.dem, ...tiles.drape].every((t) => t.status === 200), 'still every tile 200');
  check((await page.textContent('#status')) === '', 'the page reports no error');
  check(errors.length === 0, `no console errors${errors.length ? ': ' + errors.slice(0, 3).join(' | ') : ''}`);
} finally {
  if (browser) await browser.close();
  proc.kill('SIGTERM');
  rmSync(data, { recursive: true, force: true });
}
if (failures.length) {
  console.log(`${failures.length} failed`);
  process.exit(1);
}
console.log('terrain_test: passed');
