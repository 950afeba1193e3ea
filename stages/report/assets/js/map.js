/* roadsurvey survey report: the Leaflet map: orthophoto, trajectory and damage layers, scale bar,
 * fit control, zooming onto a damage and refitting for print.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { SEVERITY_COLOURS, state, isNum, el, byId, mm, severityOf, hasMap, originText } = R;

  const SELECTED_STROKE = '#1e90ff';
  // Zooming onto a damage keeps road around it (at least this much, else its own size), so the
  // reader sees where it lies.
  const ZOOM_MARGIN_M = 0.6;
  const MAX_ZOOM = 9;

  // ---------------------------------------------------------------------------------------------
  // Map

  /** A scale bar that reads down to millimetres (Leaflet's own stops at 1 m). */
  function scaleBar() {
    return new (L.Control.extend({
      options: { position: 'bottomleft', maxWidth: 140 },
      onAdd(map) {
        this._bar = el('div', { class: 'scale-bar-line' });
        this._label = el('div', { class: 'scale-bar-label' });
        const box = el('div', { class: 'scale-bar', 'aria-hidden': 'true' }, [this._bar, this._label]);
        map.on('zoomend moveend resize', this._update, this);
        this._map = map;
        this._update();
        return box;
      },
      onRemove(map) {
        map.off('zoomend moveend resize', this._update, this);
      },
      _update() {
        const size = this._map.getSize();
        if (!size.x) return;
        const y = size.y / 2;
        const a = this._map.containerPointToLatLng([0, y]);
        const b = this._map.containerPointToLatLng([this.options.maxWidth, y]);
        const span = Math.abs(b.lng - a.lng);
        if (!(span > 0)) return;
        const nice = niceBelow(span);
        this._bar.style.width = `${Math.round((this.options.maxWidth * nice) / span)}px`;
        this._label.textContent = lengthLabel(nice);
      },
    }))();
  }

  /** The largest 1, 2 or 5 × 10^k not above x. */
  function niceBelow(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    for (const m of [5, 2, 1]) if (m * p <= x * (1 + 1e-9)) return m * p;
    return p;
  }

  function lengthLabel(m) {
    if (m >= 1000) return `${+(m / 1000).toPrecision(3)} km`;
    if (m >= 1) return `${+m.toPrecision(3)} m`;
    if (m >= 0.01) return `${+(m * 100).toPrecision(3)} cm`;
    return `${+(m * 1000).toPrecision(3)} mm`;
  }

  /** A button that fits the map to the survey's extent again. */
  function fitControl() {
    return new (L.Control.extend({
      options: { position: 'topleft' },
      onAdd() {
        const a = el('a', { id: 'map-fit', href: '#', role: 'button', title: 'Fit to survey extent',
          'aria-label': 'Fit to survey extent', text: '⤢' });
        const box = el('div', { class: 'leaflet-bar leaflet-control map-fit' }, a);
        L.DomEvent.disableClickPropagation(box);
        L.DomEvent.on(a, 'click', (e) => {
          L.DomEvent.preventDefault(e);
          if (state.fitExtent) state.fitExtent();
        });
        return box;
      },
    }))();
  }

  /** The survey's extent: the stated one, else what the trajectory and damages cover. */
  function surveyBounds(report) {
    const m = report.map || {};
    const b = L.latLngBounds([]);
    if (Array.isArray(m.extent) && m.extent.length === 2) b.extend(m.extent[0]).extend(m.extent[1]);
    if (!b.isValid()) {
      for (const p of m.trajectory || []) b.extend(p);
      for (const d of report.damages || []) if (Array.isArray(d.centroid)) b.extend(d.centroid);
    }
    return b.isValid() ? padBounds(b, 1) : null;
  }

  /** Bounds grown by a margin in metres (L.LatLngBounds.pad is relative, useless on a point). */
  function padBounds(b, margin) {
    return L.latLngBounds([b.getSouth() - margin, b.getWest() - margin], [b.getNorth() + margin, b.getEast() + margin]);
  }

  function orthoLayer(ortho) {
    if (!ortho || !Array.isArray(ortho.pieces) || !ortho.pieces.length) return null;
    return L.layerGroup(ortho.pieces.map((p) => L.imageOverlay(p.file, p.bounds, {
      className: 'ortho-piece', interactive: false, alt: '',
    })));
  }

  function trajectoryLayer(trajectory) {
    if (!Array.isArray(trajectory) || trajectory.length < 2) return null;
    return L.layerGroup([
      L.polyline(trajectory, { color: '#0b3d91', weight: 2, opacity: 0.8, dashArray: '6 4', interactive: false,
        className: 'trajectory' }),
      L.circleMarker(trajectory[0], { radius: 5, color: '#0b3d91', weight: 2, fillColor: '#fff', fillOpacity: 1,
        className: 'trajectory-start' }).bindTooltip('Start of the survey (chainage 0)'),
    ]);
  }

  function damageStyle(d, selected) {
    const colour = SEVERITY_COLOURS[severityOf(d)];
    const line = d.geometry && d.geometry.type === 'LineString';
    return {
      color: selected ? SELECTED_STROKE : colour,
      weight: (line ? 4 : 2) + (selected ? 3 : 0),
      opacity: 1,
      fillColor: colour,
      fillOpacity: selected ? 0.6 : 0.35,
    };
  }

  /** One damage's map layer: polygon for depressions, polyline for cracks, a dot otherwise. */
  function damageLayer(d) {
    const g = d.geometry || {};
    const opts = Object.assign(damageStyle(d, false), { className: `damage-path damage-id-${d.id}` });
    let layer;
    if (g.type === 'Polygon' && Array.isArray(g.coordinates)) layer = L.polygon(g.coordinates, opts);
    else if (g.type === 'LineString' && Array.isArray(g.coordinates)) layer = L.polyline(g.coordinates, opts);
    else if (Array.isArray(d.centroid)) layer = L.circleMarker(d.centroid, Object.assign(opts, { radius: 6 }));
    else return null;
    layer.bindTooltip(`#${d.id} ${d.type}, ${severityOf(d)}`, { sticky: true });
    // selectDamage comes from js/table.js, loaded after this file: look it up when clicked.
    layer.on('click', () => R.selectDamage(d.id, { zoom: false, scroll: true }));
    // Leaflet builds a new <path> each time a layer is added (filters remove and add layers).
    layer.on('add', () => markLayer(d.id, layer));
    return layer;
  }

  function markLayer(id, layer) {
    const path = layer.getElement && layer.getElement();
    if (!path) return;
    path.setAttribute('data-id', String(id));
    path.classList.toggle('damage-selected', id === state.selectedId);
  }

  function renderMap(report) {
    const m = report.map;
    if (!hasMap(report)) {
      renderNoMap(report);
      return;
    }
    const map = L.map('map', {
      crs: L.CRS.Simple, minZoom: -6, maxZoom: MAX_ZOOM, zoomSnap: 0.25, zoomDelta: 0.5,
      attributionControl: false, preferCanvas: false,
    });
    state.map = map;

    const bases = {};
    const overlays = {};
    const ortho = orthoLayer(m.ortho);
    if (ortho) bases['Orthophoto'] = ortho.addTo(map);
    bases['Blank'] = ortho ? L.layerGroup() : L.layerGroup().addTo(map);
    const traj = trajectoryLayer(m.trajectory);
    if (traj) overlays['Trajectory'] = traj.addTo(map);
    const damages = L.featureGroup();
    for (const d of state.damages) {
      const layer = damageLayer(d);
      if (!layer) continue;
      state.layers.set(d.id, layer);
      damages.addLayer(layer);
    }
    overlays['Damages'] = damages.addTo(map);
    state.damageGroup = damages;

    // The view first: the scale bar measures the map as soon as it is added.
    const bounds = surveyBounds(report);
    state.fitExtent = () => (bounds ? map.fitBounds(bounds, { animate: false }) : map.setView([0, 0], 0));
    state.fitExtent();

    L.control.layers(bases, overlays, { collapsed: false, position: 'topright' }).addTo(map);
    scaleBar().addTo(map);
    fitControl().addTo(map);

    byId('map-note').textContent = [
      ortho ? `Orthophoto at ${isNum(m.ortho.cell_m) ? mm(m.ortho.cell_m) + ' mm' : 'reduced'} cells.`
        : 'No orthophoto: the surface model was not computed.',
      `Coordinates in metres east and north of ${originText(report)}.`,
      state.damages.length ? 'Click a damage to select it in the table.' : '',
    ].filter(Boolean).join(' ');
  }

  /** Without georeferenced cameras there is no map frame: say so where the map would be. */
  function renderNoMap(report) {
    const box = byId('map');
    box.classList.add('no-map');
    const georef = report.survey && report.survey.georeferenced;
    box.appendChild(el('p', { class: 'note', text: georef === false
      ? 'No map: the cameras are not georeferenced, so nothing can be placed in a map frame.'
      : 'No map: the report data has no map frame.' }));
    byId('map-note').textContent = '';
  }

  function zoomToDamage(id) {
    const layer = state.layers.get(id);
    if (!layer || !state.map) return;
    const b = layer.getBounds ? layer.getBounds() : L.latLngBounds([layer.getLatLng()]);
    const size = Math.max(b.getNorth() - b.getSouth(), b.getEast() - b.getWest());
    state.map.fitBounds(padBounds(b, Math.max(ZOOM_MARGIN_M, 0.75 * size)), { maxZoom: MAX_ZOOM - 1 });
  }

  // Print pages are narrower than a screen: Leaflet must measure the map again and refit.
  function refitForMedia() {
    if (!state.map) return;
    state.map.invalidateSize({ animate: false });
    if (state.selectedId !== null && state.layers.has(state.selectedId)) zoomToDamage(state.selectedId);
    else if (state.fitExtent) state.fitExtent();
  }

  Object.assign(R, { renderMap, damageStyle, markLayer, zoomToDamage, refitForMedia });
})();
