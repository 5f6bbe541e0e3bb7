// The textond page: upload an exemplar, look at its texton, pan an infinite texture of it.
// Plain ES module over the HTTP API (api/openapi.yaml); Leaflet draws the maps, and the pmtiles
// library reads archives written by `textond export`.
const $ = (id) => document.getElementById(id);
const state = {
  meta: null, map: null, layer: null, tilesLoaded: 0, tileErrors: 0, archiveMap: null, archive: null,
  signing: false, // the server wants signed image URLs (learnt from its first refusal)
};
window.textond = state; // for people poking around, and for the browser test

// API errors in plain words: the server's message, with what to do for the common cases.
const advice = {
  unsupported_media_type: 'That file is not an image in a format this server accepts (PNG, JPEG, TIFF, BMP).',
  invalid_image: 'That image looks damaged or truncated.',
  image_too_large: 'That image has too many pixels for this server.',
  payload_too_large: 'That file is too large for this server.',
  exemplar_too_small: 'The photo is too small for this texton size: pick a smaller size.',
  overloaded: 'The server is busy analysing other photos: try again in a few seconds.',
  unauthorized: 'This server needs its API key: enter it under the upload.',
  signature_missing: 'This server signs its image URLs: enter its API key under the upload to view them.',
  signing_unavailable: 'This server needs signed image URLs and signs them for nobody: ask its operator for signed links.',
};

function showError(text) {
  $('error').textContent = text;
  $('error').hidden = !text;
}

// An Error in plain words, with the API's error code in .code.
async function apiError(res) {
  try {
    const e = (await res.json()).error || {};
    const text = (advice[e.code] ? advice[e.code] + ' ' : '') + `(${e.message || res.statusText})`;
    return Object.assign(new Error(text), { code: e.code });
  } catch {
    return new Error(`The server answered ${res.status} ${res.statusText}.`);
  }
}

async function getJson(url) {
  const res = await fetch(url);
  if (!res.ok) throw await apiError(res);
  return res.json();
}

// The API key (--api-key) for uploads and signatures, kept for this tab only.
const apiKeyField = $('api-key');
apiKeyField.value = sessionStorage.getItem('textond-api-key') || '';
apiKeyField.addEventListener('change', () => sessionStorage.setItem('textond-api-key', apiKeyField.value));
function authHeaders() {
  return apiKeyField.value ? { Authorization: `Bearer ${apiKeyField.value}` } : {};
}

// A server run with --url-signing-key refuses unsigned image URLs. The page never holds that
// key: once the server says signature_missing, it asks POST /v1/sign (for the API key's holder)
// to sign its URLs, valid for a day.
async function signed(urls) {
  if (!state.signing) return urls;
  const res = await fetch('/v1/sign', {
    method: 'POST',
    headers: { ...authHeaders(), 'Content-Type': 'application/json' },
    body: JSON.stringify({ urls, expires_in: 86400 }),
  });
  if (!res.ok) throw await apiError(res);
  return (await res.json()).urls;
}

// A TileJSON (the first image URL the page asks for), learning on the way whether the server
// signs.
async function tileJson(url) {
  try {
    return await getJson((await signed([url]))[0]);
  } catch (e) {
    if (e.code !== 'signature_missing' || state.signing) throw e;
    state.signing = true;
    return getJson((await signed([url]))[0]);
  }
}

// Seed and MNI: what every noise image takes (the spectrum too).
function seedQuery() {
  const seed = Math.max(0, Math.floor(Number($('seed').value) || 0));
  const mni = Math.min(200, Math.max(1, Number($('mni').value) || 30));
  return `seed=${seed}&mni=${mni}`;
}

// The tiles, regions and downloads: also the exemplar's colour marginals when asked for, and a
// material set's view (map=, with the light for map=lit).
function noiseQuery() {
  const marginals = $('marginals').checked && !$('marginals').disabled;
  let q = seedQuery() + (marginals ? '&marginals=exemplar' : '');
  const view = $('map-view-label').hidden ? '' : $('map-view').value;
  if (view) q += `&map=${view}`;
  if (view === 'lit') q += `&light=${Number($('light').value) || 0},45`;
  return q;
}

// A material set's views in the map selector: each map, and from a height its normals and the
// lit albedo (the default, the set's preview); hidden for a single photo.
function showMapViews(meta) {
  const select = $('map-view');
  select.replaceChildren();
  const names = (meta.maps || []).map((m) => m.name);
  if (names.includes('height')) names.push('normal', 'lit');
  for (const name of names) select.append(new Option(name, name));
  if (names.includes('lit')) select.value = 'lit';
  $('map-view-label').hidden = names.length === 0;
  $('light-label').hidden = select.value !== 'lit';
}

// A height map is terrain: its elevation tiles in the 3D view (terrain.html), with this seed and
// MNI. Not on a server that signs its image URLs: the 3D view does not sign them.
function showTerrainLink(meta) {
  const link = $('terrain-link');
  link.hidden = !(meta.maps || []).some((m) => m.name === 'height') || state.signing;
  link.href = `/static/terrain.html?texton=${meta.id}&${seedQuery()}`;
}

// POSTs an upload (asking for an asynchronous analysis), follows its progress and shows the
// texton; errors in plain words.
async function postTexton(label, url, init) {
  showError('');
  $('progress').hidden = false;
  $('progress').value = 0;
  $('progress-text').textContent = `Uploading ${label}...`;
  try {
    const res = await fetch(url, {
      method: 'POST', ...init, headers: { ...init.headers, ...authHeaders(), Prefer: 'respond-async' },
    });
    if (!res.ok) throw await apiError(res);
    let body = await res.json();
    if (res.status === 202) body = await waitForAnalysis(body);
    $('progress-text').textContent = 'Done.';
    await show(body);
  } catch (e) {
    $('progress-text').textContent = '';
    showError(e.message);
  } finally {
    $('progress').hidden = true;
  }
}

function upload(file) {
  return postTexton(file.name, `/v1/textons?size=${$('size').value}`, {
    body: file,
    headers: { 'Content-Type': file.type || 'application/octet-stream' },
  });
}

// A material set: the chosen maps as one multipart form (core/README.md "Material sets").
function uploadSet() {
  const form = new FormData();
  for (const name of ['albedo', 'height', 'roughness', 'ao', 'metallic']) {
    const file = $(`set-${name}`).files[0];
    if (file) form.append(name, file, file.name);
  }
  if ([...form.keys()].length === 0) {
    showError('Pick at least one map of the set (albedo, height, ...).');
    return Promise.resolve();
  }
  form.append('size', $('size').value);
  return postTexton('the set', '/v1/textons', { body: form, headers: {} });
}

async function waitForAnalysis(accepted) {
  for (;;) {
    const s = await getJson(accepted.links.status);
    if (s.state === 'failed') throw new Error(s.error ? s.error.message : 'The analysis failed.');
    if (s.state === 'done') return getJson(`/v1/textons/${s.id}`);
    const { done, total } = s.progress;
    $('progress').value = total ? done / total : 0;
    $('progress-text').textContent =
      s.state === 'queued' ? 'Waiting for an analysis worker...' : `Analysing: projection ${done} of ${total}`;
    await new Promise((r) => setTimeout(r, 200));
  }
}

// The micro/macro verdict in plain words, as the server words it (api/texton_meta.cpp: "keeps
// its look" only under micro, with an RME that does not say the texton misses its model).
function verdict(meta) {
  if (!meta.verdict) return 'not measured (analysed by an older server)';
  return meta.shape_score === undefined
    ? meta.verdict
    : `${meta.verdict} (shape score ${meta.shape_score.toFixed(2)})`;
}

async function show(meta) {
  state.meta = meta;
  $('result').hidden = false;
  $('exemplar-img').src = meta.links.exemplar_png;
  $('texton-img').src = meta.links.texton_png;
  $('rme').textContent = meta.rme.toFixed(3);
  $('kind').textContent = verdict(meta);
  // Textons analysed before the marginals were kept offer the Gaussian ones only.
  $('marginals').disabled = !(meta.marginals || []).includes('exemplar');
  const m = meta.mean.length === 1 ? [meta.mean[0], meta.mean[0], meta.mean[0]] : meta.mean;
  const rgb = m.map((v) => Math.round(255 * Math.min(1, Math.max(0, v))));
  $('mean-swatch').style.background = `rgb(${rgb.join(',')})`;
  $('mean').textContent = meta.mean.map((v) => v.toFixed(3)).join(', ');
  $('analysis-ms').textContent = `${Math.round(meta.analysis_ms)} ms`;
  $('texton-id').textContent = meta.id;
  showMapViews(meta);
  await refreshNoise();
  refreshList();
}

// Everything that depends on seed and MNI: the map, downloads, synthesis, spectra, histograms.
async function refreshNoise() {
  const meta = state.meta;
  if (!meta) return;
  const tj = await tileJson(`${meta.links.tilejson}?${noiseQuery()}`);
  showTerrainLink(meta); // after a first request: state.signing is known
  if (!state.map) {
    state.map = L.map('map', {
      crs: L.CRS.Simple, minZoom: tj.minzoom, maxZoom: tj.maxzoom, attributionControl: false,
    });
    state.map.setView([0, 0], tj.textond.native_zoom);
  }
  if (state.layer) state.map.removeLayer(state.layer);
  state.layer = L.tileLayer(tj.tiles[0], {
    tileSize: tj.textond.tile_size, minZoom: tj.minzoom, maxZoom: tj.maxzoom, noWrap: true,
  });
  state.layer.on('tileload', () => { state.tilesLoaded += 1; });
  state.layer.on('tileerror', () => {
    state.tileErrors += 1;
    showError('Some tiles could not be loaded: is the server still running?');
  });
  state.layer.addTo(state.map);
  $('tile-url').value = tj.tiles[0];
  await updateDownloads();
  const w = Math.min(meta.exemplar.width, 1024), h = Math.min(meta.exemplar.height, 1024);
  const [synthesis, spectrum] = await signed([
    `/v1/textons/${meta.id}/region.png?w=${w}&h=${h}&${noiseQuery()}`,
    `${meta.links.spectrum_png}?${seedQuery()}`,
  ]);
  $('side-exemplar').src = meta.links.exemplar_png;
  $('side-synthesis').src = synthesis;
  $('spectrum-img').src = spectrum;
  drawHistograms();
  await showQuality(meta);
}

// The server's quality report (GET .../quality.json and its PNG): the verdict and how far each
// noise's colours are from the photo's.
async function showQuality(meta) {
  const [report] = await signed([`/v1/textons/${meta.id}/quality.json?${seedQuery()}`]);
  const q = await getJson(report);
  const w = q.wasserstein;
  $('quality-numbers').textContent =
    `RME ${q.rme.toFixed(3)} · ${q.verdict} · distance of the colours to the photo's ` +
    `(1-D Wasserstein): Gaussian ${w.gaussian.toFixed(4)}` +
    (w.restored !== undefined ? `, with the photo's colours ${w.restored.toFixed(4)}` : '');
  $('quality-img').src = q.links.png;
}

async function updateDownloads() {
  const meta = state.meta;
  if (!meta) return;
  // Whole numbers as the API spells them ("0512" and "512.0" are other URLs, refused).
  const side = (id) => Math.min(4096, Math.max(8, Math.round(Number($(id).value)) || 512));
  const w = side('dl-w'), h = side('dl-h'), f = $('dl-format').value;
  const ext = f === 'exr' ? 'exr' : 'png';
  const q = `w=${w}&h=${h}&${noiseQuery()}`;
  const mni = new URLSearchParams(noiseQuery()).get('mni');
  const [region, tileable, kit] = await signed([`/v1/textons/${meta.id}/region.${f}?${q}`,
                                                `/v1/textons/${meta.id}/tileable.${f}?${q}`,
                                                `/v1/textons/${meta.id}/kit.tar${mni ? `?mni=${mni}` : ''}`]);
  $('dl-region').href = region;
  $('dl-region').download = `textond-${meta.id.slice(0, 8)}-${w}x${h}.${ext}`;
  $('dl-tileable').href = tileable;
  $('dl-tileable').download = `textond-${meta.id.slice(0, 8)}-tileable-${w}x${h}.${ext}`;
  $('dl-kit').href = kit;
  $('dl-kit').download = `textond-kit-${meta.id.slice(0, 12)}.tar`;
}

function loadImage(src) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new Error(`could not load ${src}`));
    img.src = src;
  });
}

function histogram(img, bins) {
  const c = document.createElement('canvas');
  c.width = img.naturalWidth;
  c.height = img.naturalHeight;
  const ctx = c.getContext('2d');
  ctx.drawImage(img, 0, 0);
  const px = ctx.getImageData(0, 0, c.width, c.height).data;
  const h = [0, 1, 2].map(() => new Float64Array(bins));
  for (let i = 0; i < px.length; i += 4)
    for (let ch = 0; ch < 3; ++ch) h[ch][Math.min(bins - 1, (px[i + ch] * bins) >> 8)] += 1;
  const n = px.length / 4;
  return h.map((a) => a.map((v) => v / n));
}

async function drawHistograms() {
  try {
    const [ex, syn] = await Promise.all([loadImage($('side-exemplar').src),
                                         loadImage($('side-synthesis').src)]);
    const bins = 64, he = histogram(ex, bins), hs = histogram(syn, bins);
    const canvas = $('histograms'), ctx = canvas.getContext('2d');
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    const peak = Math.max(...he.flatMap((a) => [...a]), ...hs.flatMap((a) => [...a]));
    const colours = state.meta.channels === 1 ? ['#333', '#333', '#333'] : ['#c22', '#2a2', '#22c'];
    for (const [hist, dash] of [[he, []], [hs, [4, 3]]])
      for (let ch = 0; ch < 3; ++ch) {
        ctx.beginPath();
        ctx.setLineDash(dash);
        ctx.strokeStyle = colours[ch];
        for (let b = 0; b < bins; ++b) {
          const x = (b + 0.5) * canvas.width / bins;
          const y = canvas.height - 4 - (hist[ch][b] / peak) * (canvas.height - 8);
          b ? ctx.lineTo(x, y) : ctx.moveTo(x, y);
        }
        ctx.stroke();
      }
    state.histograms = { exemplar: he, synthesis: hs };
  } catch (e) {
    showError(`Could not draw the histograms (${e.message}).`);
  }
}

async function refreshList() {
  try {
    const page = await getJson('/v1/textons?limit=100');
    const list = $('texton-list');
    list.replaceChildren();
    for (const meta of page.items) {
      const li = document.createElement('li');
      const img = document.createElement('img');
      img.alt = `texton ${meta.id.slice(0, 8)}`;
      img.loading = 'lazy';
      img.src = meta.links.exemplar_png;
      img.onerror = () => { img.onerror = null; img.src = meta.links.texton_png; };
      li.append(img, `${meta.id.slice(0, 8)} · RME ${meta.rme.toFixed(2)}`);
      li.onclick = () => show(meta);
      list.append(li);
    }
  } catch (e) {
    showError(`Could not list the stored textons (${e.message}).`);
  }
}

// A PMTiles archive from `textond export`, read from the local file by range (nothing is
// uploaded) and shown on its own map, framed on the box it was exported for.
async function openArchive(file) {
  const archive = new pmtiles.PMTiles(new pmtiles.FileSource(file));
  const header = await archive.getHeader();
  if (![2, 4, 5].includes(header.tileType)) throw new Error(`${file.name} holds no PNG, WebP or AVIF tiles`);
  const info = (await archive.getMetadata()).textond || {};
  const size = info.tile_size || 256;
  if (state.archiveMap) state.archiveMap.remove();
  $('archive-map').hidden = false;
  const map = L.map('archive-map', {
    crs: L.CRS.Simple, minZoom: header.minZoom, maxZoom: header.maxZoom, attributionControl: false,
  });
  // Zoom 24 draws one texel a pixel, so the box's texels are its pixels there.
  const [x0, y0, x1, y1] = info.bbox || [0, 0, size, size];
  const bounds = L.latLngBounds(map.unproject([x0, y1], 24), map.unproject([x1, y0], 24));
  map.fitBounds(bounds);
  pmtiles.leafletRasterLayer(archive, {
    tileSize: size, minZoom: header.minZoom, maxZoom: header.maxZoom, bounds, noWrap: true,
  }).addTo(map);
  state.archiveMap = map;
  state.archive = archive;
  $('archive-info').textContent = `${file.name}: ${header.numAddressedTiles} tiles, zooms ` +
    `${header.minZoom}-${header.maxZoom}${info.texton ? `, texton ${info.texton.slice(0, 12)}` : ''}`;
}

$('file').addEventListener('change', (e) => { if (e.target.files[0]) upload(e.target.files[0]); });
const drop = $('drop');
drop.addEventListener('dragover', (e) => { e.preventDefault(); drop.classList.add('over'); });
drop.addEventListener('dragleave', () => drop.classList.remove('over'));
drop.addEventListener('drop', (e) => {
  e.preventDefault();
  drop.classList.remove('over');
  if (e.dataTransfer.files[0]) upload(e.dataTransfer.files[0]);
});
$('apply').addEventListener('click', () => refreshNoise().catch((e) => showError(e.message)));
$('marginals').addEventListener('change', () => refreshNoise().catch((e) => showError(e.message)));
$('map-view').addEventListener('change', () => {
  $('light-label').hidden = $('map-view').value !== 'lit';
  refreshNoise().catch((e) => showError(e.message));
});
$('light').addEventListener('change', () => refreshNoise().catch((e) => showError(e.message)));
$('set-send').addEventListener('click', () => uploadSet());
$('archive-file').addEventListener('change', (e) => {
  if (e.target.files[0]) openArchive(e.target.files[0]).catch((err) => showError(err.message));
});
for (const id of ['dl-w', 'dl-h', 'dl-format', 'seed', 'mni'])
  $(id).addEventListener('input', () => updateDownloads().catch((e) => showError(e.message)));
$('copy-url').addEventListener('click', async () => {
  $('tile-url').select();
  try {
    await navigator.clipboard.writeText($('tile-url').value);
    $('copy-url').textContent = 'Copied';
  } catch {
    $('copy-url').textContent = 'Selected: press Ctrl+C';
  }
});
if (typeof L === 'undefined')
  showError('The map library (Leaflet) is missing from this installation: run make deps and rebuild.');
refreshList();
