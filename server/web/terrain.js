// The 3D view of a material set: /static/terrain.html?texton=ID[&seed=0&mni=30&height_scale=2&drape=lit]
// MapLibre reads two TileJSONs of the texton: its height map as terrarium elevation tiles
// (a raster-dem source, for the terrain and the hillshade) and its lit albedo (the drape).
// Web-map zoom z is texton level 24 - z: zoom 22 shows 4 texels a pixel, and Web Mercator's
// metres there are about 0.04 a pixel, so the height map's 0..1 spans height_scale metres.
'use strict';

(function () {
  const params = new URLSearchParams(location.search);
  const id = params.get('texton') || '';
  const status = document.getElementById('status');
  const say = (text) => { status.textContent = text; };
  if (!/^[0-9a-f]{64}$/.test(id)) {
    say('Open this page as terrain.html?texton=ID, where ID is a material set with a height map.');
    return;
  }
  const seed = params.get('seed') || '0';
  const mni = params.get('mni') || '30';
  const scale = params.get('height_scale') || '2';
  const drape = params.get('drape') === 'albedo' ? 'albedo' : 'lit';
  const base = `/v1/textons/${id}/tilejson.json?seed=${encodeURIComponent(seed)}` +
    `&mni=${encodeURIComponent(mni)}`;
  const dem = `${base}&map=height&encoding=terrarium&height_scale=${encodeURIComponent(scale)}`;
  // The CSP (default-src 'self') allows no blob: workers: the CSP build's worker file instead.
  maplibregl.setWorkerUrl('/static/maplibre/maplibre-gl-csp-worker.js');
  const map = new maplibregl.Map({
    container: 'terrain',
    center: [0.0005, -0.0005],
    zoom: 21,
    pitch: 60,
    bearing: -20,
    maxPitch: 80,
    preserveDrawingBuffer: true, // screenshots and the test read the canvas
    style: {
      version: 8,
      sources: {
        drape: { type: 'raster', url: `${base}&map=${drape}`, tileSize: 256 },
        // Two sources of the same tiles, as MapLibre advises: terrain and hillshade sample
        // them at different zooms.
        dem: { type: 'raster-dem', url: dem, encoding: 'terrarium', tileSize: 256 },
        shade: { type: 'raster-dem', url: dem, encoding: 'terrarium', tileSize: 256 },
      },
      layers: [
        { id: 'background', type: 'background', paint: { 'background-color': '#777' } },
        { id: 'drape', type: 'raster', source: 'drape' },
        { id: 'hillshade', type: 'hillshade', source: 'shade',
          paint: { 'hillshade-exaggeration': 0.4, 'hillshade-shadow-color': '#0008' } },
      ],
      terrain: { source: 'dem', exaggeration: 1 },
    },
  });
  map.addControl(new maplibregl.NavigationControl({ visualizePitch: true }));
  map.on('error', (e) => say(`error: ${e.error ? e.error.message : e}`));
  window.textondTerrain = map; // for the browser test
})();
