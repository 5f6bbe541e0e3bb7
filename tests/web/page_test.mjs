// The page at / in a real browser (Debian's Chromium, driven by playwright-core) against a real
// `textond serve` on 127.0.0.1: upload, texton and RME, the map's tiles (all 200, no console
// errors, more on pan and zoom), no seam across tile boundaries in a screenshot, a new seed
// changes the tiles, downloads have the asked size, errors in plain words, the stored list, a
// material set uploaded from the page and its lit and normal views, and a PMTiles archive written
// by `textond export` opened on the page (read by the pmtiles library: tiles byte for byte the
// service's), and a server with an API key and signed URLs used from the page (POST /v1/sign).
//
// usage: node page_test.mjs TEXTOND_BINARY EXEMPLAR.png ARTEFACT_DIR
import { chromium } from 'playwright-core';
import { spawnSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { checker, startServer as startServerOf } from './harness.mjs';

const [binary, exemplar, artefacts] = process.argv.slice(2);
mkdirSync(artefacts, { recursive: true });
const { check, failures } = checker();
const startServer = (data, extra) => startServerOf(binary, data, extra);

// Width and height from a PNG's IHDR, and its bit depth.
function pngSize(buf) {
  if (buf.readUInt32BE(0) !== 0x89504e47) return null;
  return { w: buf.readUInt32BE(16), h: buf.readUInt32BE(20), depth: buf[24] };
}

// Mean absolute jump between neighbouring columns (x, x+1) and rows of a screenshot, decoded by
// the browser itself; the jumps across tile boundaries against the jumps inside tiles.
// [naturalWidth, naturalHeight] once the <img> has loaded (an image set by the page just before
// may still be on its way, under a loaded CI machine), or [0, 0] after 15 s.
async function loadedImageSize(page, selector) {
  const loaded = await page.waitForFunction((sel) => {
    const i = document.querySelector(sel);
    return i && i.complete && i.naturalWidth > 0;
  }, selector, { timeout: 15000 }).then(() => true, () => false);
  if (!loaded) return [0, 0];
  return page.locator(selector).evaluate((i) => [i.naturalWidth, i.naturalHeight]);
}

async function seamStats(page, png, boundaries) {
  return page.evaluate(async ({ b64, boundaries }) => {
    const img = new Image();
    img.src = `data:image/png;base64,${b64}`;
    await img.decode();
    const c = document.createElement('canvas');
    c.width = img.width;
    c.height = img.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(img, 0, 0);
    const { data, width, height } = ctx.getImageData(0, 0, c.width, c.height);
    const g = (x, y) => { const i = 4 * (y * width + x); return data[i] + data[i + 1] + data[i + 2]; };
    const col = (x) => { let s = 0; for (let y = 0; y < height; ++y) s += Math.abs(g(x + 1, y) - g(x, y)); return s / height; };
    const row = (y) => { let s = 0; for (let x = 0; x < width; ++x) s += Math.abs(g(x, y + 1) - g(x, y)); return s / width; };
    // Columns and rows apart (a texture need not be isotropic); each statistic averages a
    // whole column or row of the screenshot.
    const stats = (n, jump, at) => {
      const inside = [], across = [];
      for (let i = 0; i + 1 < n; ++i) (at.includes(i + 1) ? across : inside).push(jump(i));
      const mean = inside.reduce((a, b) => a + b, 0) / inside.length;
      const sd = Math.sqrt(inside.reduce((a, b) => a + (b - mean) ** 2, 0) / inside.length);
      return { mean, sd, across };
    };
    const sx = stats(width, col, boundaries.x), sy = stats(height, row, boundaries.y);
    const mean = sx.mean, sd = sx.sd;
    const across = [...sx.across.map((v) => (v - sx.mean) / sx.sd),
                    ...sy.across.map((v) => (v - sy.mean) / sy.sd)];
    // What a seam between unrelated content would look like: columns 48 pixels apart.
    let far = 0;
    for (let x = 0; x + 48 < width; ++x) {
      let s = 0;
      for (let y = 0; y < height; ++y) s += Math.abs(g(x + 48, y) - g(x, y));
      far += s / height;
    }
    const seamLike = (far / (width - 48) - mean) / sd;
    return { mean, sd, seamLike, across }; // across and seamLike: sds above the inside mean
  }, { b64: png.toString('base64'), boundaries });
}

// Screen positions (in the map element) where one tile ends and the next begins.
async function tileBoundaries(page) {
  return page.evaluate(() => {
    const map = document.getElementById('map').getBoundingClientRect();
    const xs = new Set(), ys = new Set();
    for (const t of document.querySelectorAll('#map .leaflet-tile-loaded')) {
      const r = t.getBoundingClientRect();
      for (const x of [r.left, r.right]) if (x - map.left > 1 && map.right - x > 1) xs.add(Math.round(x - map.left));
      for (const y of [r.top, r.bottom]) if (y - map.top > 1 && map.bottom - y > 1) ys.add(Math.round(y - map.top));
    }
    return { x: [...xs], y: [...ys] };
  });
}

const data = mkdtempSync(join(tmpdir(), 'textond-web-'));
const { proc, url } = await startServer(data);
const browser = await chromium.launch({
  executablePath: '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking',
         '--disable-component-update', '--no-first-run'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1200, height: 1000 }, acceptDownloads: true });
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(e.message));
  const tileStatus = [];
  page.on('response', (r) => { if (r.url().includes('/map/')) tileStatus.push(r.status()); });

  await page.goto(url + '/');
  check(await page.title() === 'textond: an infinite texture from a photo', 'the page loads');
  await page.selectOption('#size', '32');
  await page.setInputFiles('#file', exemplar);
  await page.waitForFunction(() => document.getElementById('rme').textContent !== '', null, { timeout: 120000 });
  const id = await page.textContent('#texton-id');
  const rme = Number(await page.textContent('#rme'));
  check(/^[0-9a-f]{64}$/.test(id), `the texton id appears (${id})`);
  check(rme > 0 && rme < 1, `the RME appears (${rme})`);
  check((await page.textContent('#analysis-ms')).endsWith('ms'), 'the analysis time appears');
  const kind = await page.textContent('#kind');
  check(/^micro-texture: the noise keeps its look \(shape score -\d+\.\d\d\)$/.test(kind),
        `the verdict appears in plain words (${kind})`);
  const texton = await loadedImageSize(page, '#texton-img');
  check(texton[0] === 32 && texton[1] === 32, `the texton image shows (32 x 32: ${texton})`);

  await page.waitForFunction(() => window.textond.tilesLoaded >= 6, null, { timeout: 30000 });
  await page.waitForLoadState('networkidle');
  const first = tileStatus.length;
  check(first >= 6 && tileStatus.every((s) => s === 200), `the map loads tiles, all 200 (${first})`);

  // No seam: the jump across a tile boundary is no larger than the jumps inside tiles. Leaflet
  // fades tiles in: a tile caught half faded made a seam of its own on a loaded machine.
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile')]
    .every((t) => getComputedStyle(t).opacity === '1'), null, { timeout: 30000 });
  const boundaries = await tileBoundaries(page);
  const controls = await page.addStyleTag({ content: '.leaflet-control-container { display: none }' });
  const shot = await page.locator('#map').screenshot({ path: join(artefacts, 'map.png') });
  await controls.evaluate((e) => e.remove());
  const stats = await seamStats(page, shot, boundaries);
  check(boundaries.x.length + boundaries.y.length >= 2, `tile boundaries on screen (${JSON.stringify(boundaries)})`);
  // Each jump averages a whole column or row, so the jumps inside tiles vary little: a boundary
  // must stay within 4 of their sds, and a seam between unrelated content (the control: columns
  // 48 pixels apart) would not.
  const worst = Math.max(...stats.across);
  check(worst < 4, `no seam: worst boundary jump ${worst.toFixed(2)} sd above the inside mean ` +
        `(inside columns: mean ${stats.mean.toFixed(2)}, sd ${stats.sd.toFixed(2)})`);
  check(stats.seamLike > 4, `the seam check can fail: unrelated columns are ${stats.seamLike.toFixed(1)} sd above`);

  // Pan and zoom load more tiles.
  const box = await page.locator('#map').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 - 600, box.y + box.height / 2 - 300, { steps: 8 });
  await page.mouse.up();
  await page.waitForLoadState('networkidle');
  const afterPan = tileStatus.length;
  check(afterPan > first, `panning loads more tiles (${first} -> ${afterPan})`);
  await page.click('.leaflet-control-zoom-in');
  await page.waitForTimeout(400);
  await page.waitForLoadState('networkidle');
  await page.click('.leaflet-control-zoom-out');
  await page.click('.leaflet-control-zoom-out');
  await page.waitForTimeout(400);
  await page.waitForLoadState('networkidle');
  check(tileStatus.length > afterPan, `zooming loads more tiles (${afterPan} -> ${tileStatus.length})`);
  check(tileStatus.every((s) => s === 200), 'every tile answered 200');
  await page.screenshot({ path: join(artefacts, 'page.png'), fullPage: true });

  // A new seed changes the tiles.
  const before = await page.locator('#map').screenshot();
  await page.fill('#seed', '7');
  await page.click('#apply');
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile-loaded')]
    .some((t) => t.src.includes('seed=7')), null, { timeout: 30000 });
  await page.waitForLoadState('networkidle');
  await page.waitForTimeout(300);
  const after = await page.locator('#map').screenshot({ path: join(artefacts, 'map-seed7.png') });
  check(!before.equals(after), 'changing the seed changes the tiles');

  // Downloads have the asked size and format.
  await page.fill('#dl-w', '300');
  await page.fill('#dl-h', '200');
  await page.selectOption('#dl-format', 'png');
  for (const [button, fmt, depth] of [['#dl-region', 'png', 8], ['#dl-tileable', 'png16', 16]]) {
    await page.selectOption('#dl-format', fmt);
    const [download] = await Promise.all([page.waitForEvent('download'), page.click(button)]);
    const size = pngSize(readFileSync(await download.path()));
    check(size && size.w === 300 && size.h === 200 && size.depth === depth,
          `${button} downloads a ${fmt} of 300 x 200 (${JSON.stringify(size)})`);
  }
  await page.selectOption('#dl-format', 'exr');
  const [exr] = await Promise.all([page.waitForEvent('download'), page.click('#dl-region')]);
  check(readFileSync(await exr.path()).readUInt32LE(0) === 20000630, 'the EXR download is an OpenEXR file');
  const [kit] = await Promise.all([page.waitForEvent('download'), page.click('#dl-kit')]);
  const tar = readFileSync(await kit.path());
  check(tar.subarray(257, 262).toString() === 'ustar' && tar.subarray(0, 100).toString().includes('textond-kit-'),
        'the engine kit downloads as a tar of the kit directory');

  await page.click('#copy-url');
  const template = await page.inputValue('#tile-url');
  check(template.startsWith(url) && template.includes('/map/{z}/{x}/{y}.png?seed=7'),
        `the tile URL template is absolute, with the seed (${template})`);

  // The photo's colours: the map reloads with marginals=exemplar, every tile 200, a new picture.
  const gaussianMap = await page.locator('#map').screenshot();
  const tilesBefore = tileStatus.length;
  await page.check('#marginals');
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile-loaded')]
    .some((t) => t.src.includes('marginals=exemplar')), null, { timeout: 30000 });
  await page.waitForLoadState('networkidle');
  await page.waitForTimeout(300);
  const restoredMap = await page.locator('#map').screenshot({ path: join(artefacts, 'map-marginals.png') });
  check((await page.inputValue('#tile-url')).includes('marginals=exemplar'),
        'the photo\'s colours reach the tile URL template');
  check(tileStatus.length > tilesBefore && tileStatus.every((s) => s === 200),
        'tiles with the photo\'s colours load, all 200');
  check(!gaussianMap.equals(restoredMap), 'the photo\'s colours change the map');

  const quality = await loadedImageSize(page, '#quality-img');
  check(quality[0] > 0 && quality[1] > quality[0] / 2, `the quality report's picture shows (${quality})`);
  const numbers = await page.textContent('#quality-numbers');
  check(/Gaussian 0\.\d{4}, with the photo's colours 0\.\d{4}/.test(numbers),
        `the quality report's numbers show (${numbers})`);

  const spectra = await loadedImageSize(page, '#spectrum-img');
  check(spectra[0] === 2 * spectra[1] + 4, `the spectra show, side by side (${spectra})`);
  check(await page.evaluate(() => !!window.textond.histograms), 'the histograms are drawn');
  check(await page.locator('#texton-list li img').count() >= 1, 'the stored textons are listed with thumbnails');

  // A tile archive of this texton (`textond export` of its texton.exr), opened from the page: the
  // pmtiles library reads it in the browser, Leaflet shows its tiles, and each is the service's
  // own tile of that address, byte for byte (the service stores PNGs, as --png-compression 0).
  const scratch = mkdtempSync(join(tmpdir(), 'textond-archive-'));
  const textonExr = join(scratch, 'texton.exr'), archive = join(scratch, 'cork.pmtiles');
  writeFileSync(textonExr, Buffer.from(await (await fetch(`${url}/v1/textons/${id}/texton.exr`)).arrayBuffer()));
  const exported = spawnSync(binary, ['export', textonExr, '--zooms', '22-24', '--bbox', '0,0,1024,768',
                                      '--png-compression', '0', '--backend', 'cpu', '--quiet', '-o', archive]);
  check(exported.status === 0, `textond export writes the archive (${exported.stderr})`);
  await page.setInputFiles('#archive-file', archive);
  await page.waitForFunction(() => document.querySelectorAll('#archive-map .leaflet-tile-loaded').length >= 4,
                             null, { timeout: 30000 }).catch(() => {});
  const archiveTiles = await page.locator('#archive-map .leaflet-tile-loaded').count();
  check(archiveTiles >= 4, `the archive's tiles show on the page's map (${archiveTiles})`);
  check(/17 tiles, zooms 22-24, texton [0-9a-f]{12}/.test(await page.textContent('#archive-info')),
        `the archive is described (${await page.textContent('#archive-info')})`);
  await page.waitForTimeout(300); // Leaflet fades tiles in
  await page.locator('#archive-map').screenshot({ path: join(artefacts, 'archive.png') });
  const same = await page.evaluate(async (texton) => {
    const out = [];
    for (const [z, x, y] of [[24, 0, 0], [24, 3, 2], [23, 1, 1], [22, 0, 0]]) {
      const tile = await window.textond.archive.getZxy(z, x, y);
      const res = await fetch(`/v1/textons/${texton}/map/${z}/${x}/${y}.png`);
      const a = new Uint8Array(tile ? tile.data : []), b = new Uint8Array(await res.arrayBuffer());
      out.push(res.status === 200 && a.length === b.length && a.length > 0 && a.every((v, i) => v === b[i]));
    }
    return out;
  }, id);
  check(same.every(Boolean), `archive tiles equal the service's, byte for byte (${same})`);
  rmSync(scratch, { recursive: true, force: true });

  check(consoleErrors.length === 0, `no console errors (${JSON.stringify(consoleErrors)})`);

  // A material set from the page's set form (albedo and height: the same photo, whose channels
  // the height averages): the map shows the lit view by default, with the light in its URL; the
  // normals are another view; every tile 200; a single photo hides the selector.
  check(await page.locator('#map-view-label').isHidden(), 'a single photo has no map selector');
  check(await page.locator('#terrain-link').isHidden(), 'a single photo has no terrain link');
  await page.click('#set-upload summary');
  await page.setInputFiles('#set-albedo', exemplar);
  await page.setInputFiles('#set-height', exemplar);
  const setTiles = tileStatus.length;
  await page.click('#set-send');
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile-loaded')]
    .some((t) => t.src.includes('map=lit')), null, { timeout: 60000 });
  check(!(await page.locator('#map-view-label').isHidden()), 'a set shows the map selector');
  check(!(await page.locator('#light-label').isHidden()), 'the lit view shows the light');
  const terrain = await page.getAttribute('#terrain-link', 'href');
  check(!(await page.locator('#terrain-link').isHidden()) && /^\/static\/terrain\.html\?texton=[0-9a-f]{64}&seed=\d+&mni=\d+$/.test(terrain),
        `a set with a height links its 3D terrain (${terrain})`);
  const views = await page.locator('#map-view option').allTextContents();
  check(JSON.stringify(views) === JSON.stringify(['albedo', 'height', 'normal', 'lit']),
        `the set's views are offered (${views})`);
  check((await page.inputValue('#tile-url')).includes('map=lit&strength=8&light=135,45'),
        `the lit view and its light reach the tile URL (${await page.inputValue('#tile-url')})`);
  await page.waitForLoadState('networkidle');
  await page.waitForTimeout(500); // Leaflet fades tiles in
  await page.locator('#map').screenshot({ path: join(artefacts, 'map-set-lit.png') });
  await page.fill('#light', '300');
  await page.dispatchEvent('#light', 'change');
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile-loaded')]
    .some((t) => t.src.includes('light=300,45')), null, { timeout: 30000 });
  await page.selectOption('#map-view', 'normal');
  await page.waitForFunction(() => [...document.querySelectorAll('#map .leaflet-tile-loaded')]
    .some((t) => t.src.includes('map=normal')), null, { timeout: 30000 });
  check(await page.locator('#light-label').isHidden(), 'the normals hide the light');
  await page.waitForLoadState('networkidle');
  check(tileStatus.length > setTiles && tileStatus.every((s) => s === 200),
        'the set\'s tiles load, all 200');

  // An error in plain words (its 415 is the one console error the browser may log).
  await page.setInputFiles('#file', { name: 'notes.txt', mimeType: 'text/plain', buffer: Buffer.from('not a picture') });
  await page.waitForSelector('#error:not([hidden])', { timeout: 10000 });
  const error = await page.textContent('#error');
  check(/not an image/.test(error), `a bad upload is explained (${error})`);
  check(consoleErrors.every((e) => /415/.test(e)), `no other console errors (${JSON.stringify(consoleErrors)})`);
  await page.screenshot({ path: join(artefacts, 'page-end.png'), fullPage: true });

  // A server with an API key and signed image URLs: without the key the page says what to do;
  // with it the upload goes through and every image URL the page uses is signed by the server
  // (the page never sees the signing key), and opens.
  const signedData = mkdtempSync(join(tmpdir(), 'textond-web-signed-'));
  const signedServer = await startServer(signedData, ['--api-key', 'page-test-key',
                                                      '--url-signing-key', 'a signing key of some length']);
  try {
    const p2 = await browser.newPage({ viewport: { width: 1200, height: 1000 } });
    const statuses = [];
    p2.on('response', (r) => { if (/\/(map|region|spectrum|quality)/.test(r.url())) statuses.push([r.status(), r.url()]); });
    await p2.goto(signedServer.url + '/');
    await p2.selectOption('#size', '32');
    await p2.setInputFiles('#file', exemplar);
    await p2.waitForSelector('#error:not([hidden])', { timeout: 30000 });
    check(/API key/.test(await p2.textContent('#error')),
          `without the API key the page says to enter it (${await p2.textContent('#error')})`);
    await p2.fill('#api-key', 'page-test-key');
    await p2.dispatchEvent('#api-key', 'change');
    await p2.setInputFiles('#file', { name: 'cork.png', mimeType: 'image/png', buffer: readFileSync(exemplar) });
    await p2.waitForFunction(() => window.textond.tilesLoaded >= 4, null, { timeout: 120000 }).catch(() => {});
    await p2.waitForLoadState('networkidle');
    const tiles = await p2.locator('#map .leaflet-tile-loaded').evaluateAll((ts) => ts.map((t) => t.src));
    check(tiles.length >= 4 && tiles.every((u) => /[?&]exp=\d+&sig=[0-9a-f]{64}$/.test(u)),
          `a signing server's tiles load through signed URLs (${tiles.length}: ${tiles[0]})`);
    const synthesis = await loadedImageSize(p2, '#side-synthesis');
    check(synthesis[0] > 0, `the signed synthesis shows (${synthesis})`);
    await p2.waitForFunction(() => document.getElementById('quality-numbers').textContent !== '', null,
                             { timeout: 30000 }).catch(() => {});
    check(/Gaussian 0\.\d{4}/.test(await p2.textContent('#quality-numbers')), 'the signed quality report shows');
    const download = await p2.getAttribute('#dl-region', 'href');
    const got = await p2.evaluate(async (u) => (await fetch(u)).status, download);
    check(/sig=/.test(download) && got === 200, `downloads are signed and open (${got})`);
    check(statuses.length >= 6 && statuses.every(([st]) => st === 200),
          `every signed image URL answered 200 (${JSON.stringify(statuses.filter(([st]) => st !== 200).slice(0, 3))})`);
    check(!(await p2.textContent('#error')) || await p2.locator('#error').isHidden(),
          `no error shown with the key (${await p2.textContent('#error')})`);
    await p2.screenshot({ path: join(artefacts, 'page-signed.png'), fullPage: true });
  } finally {
    signedServer.proc.kill('SIGTERM');
    rmSync(signedData, { recursive: true, force: true });
  }
} catch (e) {
  failures.push(String(e.stack || e));
  console.log('FAIL', e);
} finally {
  await browser.close();
  proc.kill('SIGTERM');
  rmSync(data, { recursive: true, force: true });
}
console.log(failures.length ? `${failures.length} failure(s)` : 'page test: all checks passed');
process.exit(failures.length ? 1 : 0);
