// acq view: the page. It reads /api/state and /api/series, follows
// /api/events while a session records, and writes every name from a rig or
// DBC file into the page as text (textContent), never as HTML.
'use strict';
(() => {
  const token = document.querySelector('meta[name="acq-token"]').content;
  const LIVE_WINDOW_S = 60;
  const LIVE_COLUMN_S = 0.05;
  // Live columns kept in the page: twice the window followed (a paused or
  // zoomed view reads its span from acq again). Every update walks them.
  const KEEP_LIVE_S = 2 * LIVE_WINDOW_S;
  const COLORS = ['#0969da', '#cf222e', '#1a7f37', '#8250df', '#bf8700', '#1b7c83',
    '#e16f24', '#57606a', '#a40e26', '#116329', '#953800', '#0550ae'];
  // The k-th signal's colour: the palette, then hues a golden angle apart
  // at alternating lightness, so 18 gauges in one chart never share one.
  function colour(k) {
    if (k < COLORS.length) return COLORS[k];
    const hue = Math.round((k * 137.508) % 360);
    return `hsl(${hue}, 70%, ${k % 2 ? 35 : 48}%)`;
  }

  // What the page has drawn, for the browser checks (and the curious).
  const view = { sessions: [], holdsShown: [], lastX: [], updates: 0, lost: 0, errors: [], watch: null, drawLog: [] };
  window.acqView = view;
  view.layoutJson = (i) => layoutJson(view.sessions[i]);
  view.exportCsv = (i) => exportCsv(view.sessions[i]);
  view.plotPng = (i, plot) => plotPng(view.sessions[i], view.sessions[i].groups[plot]);
  view.showRange = (i, range) => showRange(view.sessions[i], range);
  view.showWhole = (i) => showWhole(view.sessions[i]);
  view.applyLayout = (i, layout) => applyLayout(view.sessions[i], layout);
  view.setCursors = (i, times) => setCursors(view.sessions[i], times);
  view.setY = (i, plot, span) => setY(view.sessions[i].groups[plot], span);
  view.setOverlay = (i, from, shift) => setOverlay(view.sessions[i], from, shift);
  view.addPlot = (i, title, names) => addPlot(view.sessions[i], title, names.map((n) => view.sessions[i].sensors.findIndex((x) => x.name === n)));

  function url(path, params = {}) {
    const u = new URL(path, location.href);
    for (const [k, v] of Object.entries(params)) u.searchParams.set(k, v);
    if (token) u.searchParams.set('token', token);
    return u.toString();
  }

  function el(tag, props = {}, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(props)) {
      if (k === 'class') e.className = v;
      else if (k === 'text') e.textContent = v;
      else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v);
    }
    for (const c of children) e.append(c);
    return e;
  }

  async function getJson(path, params) {
    const response = await fetch(url(path, params));
    if (!response.ok) throw new Error(`${path}: HTTP ${response.status}`);
    return response.json();
  }

  function fmt(v) {
    if (v === null || v === undefined) return '-';
    const a = Math.abs(v);
    if (a !== 0 && (a >= 1e6 || a < 1e-3)) return v.toExponential(4);
    return v.toFixed(3);
  }

  function banner(text) {
    const b = document.getElementById('banner');
    b.textContent = text;
    b.hidden = false;
  }

  // ---- sessions and charts ----------------------------------------------

  function sessionSensors(state, info, several) {
    return state.sensors.filter((s) => !several || s.session === info.name);
  }

  // The plots of a session: a layout file's (each plot's signals this
  // session has, in its order), else one per sensor kind.
  function plotsOf(sensors, layout) {
    if (layout) {
      const index = (name) => sensors.findIndex((x) => x.name === name);
      return layout.plots.map((p) => ({
        title: p.title,
        members: (p.signals || []).map(index).filter((k) => k >= 0),
        xy: p.xy ? p.xy.map(index) : null,
      })).filter((p) => (p.xy ? p.xy.every((k) => k >= 0) : p.members.length));
    }
    const groups = new Map();
    sensors.forEach((sensor, k) => {
      if (!groups.has(sensor.group)) groups.set(sensor.group, []);
      groups.get(sensor.group).push(k);
    });
    return Array.from(groups, ([title, members]) => ({ title, members }));
  }

  function buildSession(index, info, sensors, layout) {
    const s = {
      index, name: info.name, live: info.live, follow: info.live,
      range: null, sensors, groups: [], holds: [], holdsNote: info.holds_note,
      columns: sensors.map(() => new Map()), zoomColumns: null, end: 0,
      tables: null, xy: null, xyCanvas: null,
    };
    const mode = el('span', { class: 'mode' });
    const button = (text, action) => el('button', { type: 'button', onclick: action, text });
    const controls = el('div', { class: 'controls' },
      button(info.live ? 'Pause' : 'Whole session', () => (s.live ? toggleFollow(s) : showWhole(s))),
      button('\u25c0', () => pan(s, -0.5)), button('\u25b6', () => pan(s, 0.5)),
      button('Zoom out', () => zoom(s, 2)),
      button('New plot', () => { addPlot(s, 'new plot', []); }),
      button('New XY plot', () => { addXyPlot(s, 0, Math.min(1, s.sensors.length - 1)); }),
      button('Save layout', () => download('layout.json', layoutJson(s), 'application/json')),
      button('Load layout', () => s.layoutPicker.click()),
      button('Export CSV', () => download(`${s.name}.csv`, exportCsv(s), 'text/csv')),
      button('Clear cursors', () => setCursors(s, [])),
      mode);
    s.controls = controls;
    // A layout file chosen later replaces the plots, as --layout sets them at start.
    s.layoutPicker = el('input', { type: 'file', accept: '.json,application/json', hidden: '' });
    s.layoutPicker.onchange = async () => {
      const file = s.layoutPicker.files[0];
      if (!file) return;
      try {
        applyLayout(s, JSON.parse(await file.text()));
      } catch (e) {
        banner(`Load layout: ${file.name} is not JSON (${e.message})`);
      }
      s.layoutPicker.value = '';
    };
    controls.append(s.layoutPicker);
    s.overlay = null;
    s.cursors = [];
    s.cursorBox = el('div', { class: 'cursors' });
    s.mode = mode;
    s.pauseButton = controls.firstChild;
    s.charts = el('div', { class: 'charts' });
    s.title = el('h2', { text: info.name + (info.live ? ' (recording)' : ' (recorded)') });
    const section = el('section', { class: 'session', 'data-session': String(index) },
      s.title, controls, s.charts, s.cursorBox);
    document.getElementById('sessions').append(section);
    s.xyPlots = [];
    for (const { title, members, xy } of plotsOf(sensors, layout)) {
      if (xy) addXyPlot(s, xy[0], xy[1], title);
      else addPlot(s, title, members);
    }
    if (info.has_xy) {
      s.xyCanvas = el('canvas', { class: 'xy', width: '560', height: '320' });
      s.xyBox = el('div', { class: 'chart' }, el('h3', { text: 'force against displacement' }), s.xyCanvas);
      s.charts.append(s.xyBox);
    }
    s.tables = el('div', { class: 'tables' });
    section.append(s.tables);
    renderCursors(s);
    return s;
  }

  // A plot of `members` (sensor indices) titled `title`, with its own
  // controls: add a signal, remove one, export it as PNG, close it.
  function addPlot(s, title, members) {
    const g = { group: title, members: members.slice(), plot: null };
    const heading = el('h3', { text: title });
    const add = el('select', { class: 'add-signal', title: 'add a signal to this plot' });
    const remove = el('select', { class: 'remove-signal', title: 'remove a signal from this plot' });
    const tools = el('div', { class: 'plot-tools' }, add, remove,
      el('button', { type: 'button', text: 'PNG', title: 'this plot as it is now, as an image', onclick: () => downloadUrl(`${s.name}-${g.group}.png`, plotPng(s, g)) }),
      el('button', { type: 'button', text: '\u00d7', title: 'close this plot', onclick: () => closePlot(s, g) }));
    g.box = el('div', { class: 'chart' }, heading, tools);
    add.onchange = () => { const k = Number(add.value); if (add.value !== '') { g.members.push(k); rebuildPlot(s, g); } };
    remove.onchange = () => { const k = Number(remove.value); if (remove.value !== '') { g.members = g.members.filter((m) => m !== k); rebuildPlot(s, g); } };
    g.add = add;
    g.remove = remove;
    if (s.xyBox && s.xyBox.parentNode === s.charts) s.charts.insertBefore(g.box, s.xyBox);
    else s.charts.append(g.box);
    s.groups.push(g);
    rebuildPlot(s, g);
    return g;
  }

  // A plot as the PNG a report takes: on white, its session and title
  // above, each signal's colour and name below (the page's legend is not
  // on the canvas).
  function plotPng(s, g) {
    const entries = g.members.map((k, j) => [colour(j), `${s.sensors[k].name} [${s.sensors[k].unit}]`]);
    return pngOf(g.plot.ctx.canvas, `${s.name}: ${g.group}`, entries);
  }

  function pngOf(canvas, title, entries) {
    const scale = devicePixelRatio || 1;
    const line = 18 * scale;
    const rows = Math.ceil(entries.length / 3);
    const out = document.createElement('canvas');
    out.width = canvas.width;
    out.height = canvas.height + line * (1.6 + rows) + 8 * scale;
    const ctx = out.getContext('2d');
    ctx.fillStyle = '#ffffff';
    ctx.fillRect(0, 0, out.width, out.height);
    ctx.fillStyle = '#1f2328';
    ctx.font = `bold ${13 * scale}px system-ui, sans-serif`;
    ctx.fillText(title, 8 * scale, line);
    ctx.drawImage(canvas, 0, line * 1.6);
    ctx.font = `${12 * scale}px system-ui, sans-serif`;
    const width = out.width / 3;
    entries.forEach(([stroke, label], i) => {
      const x = 8 * scale + (i % 3) * width;
      const y = canvas.height + line * 1.6 + line * (Math.floor(i / 3) + 1);
      ctx.fillStyle = stroke;
      ctx.fillRect(x, y - 9 * scale, 14 * scale, 4 * scale);
      ctx.fillStyle = '#1f2328';
      ctx.fillText(label, x + 20 * scale, y - 3 * scale);
    });
    return out.toDataURL('image/png');
  }

  function closePlot(s, g) {
    if (g.plot) g.plot.destroy();
    g.box.remove();
    s.groups = s.groups.filter((x) => x !== g);
  }

  function rebuildPlot(s, g) {
    const { sensors } = s;
    const options = (select, label, ks) => {
      select.replaceChildren(el('option', { value: '', text: label }),
        ...ks.map((k) => el('option', { value: String(k), text: sensors[k].name })));
    };
    options(g.add, 'add a signal\u2026', sensors.map((_, k) => k).filter((k) => !g.members.includes(k)));
    options(g.remove, 'remove\u2026', g.members);
    if (g.plot) g.plot.destroy();
    const width = Math.max(400, g.box.clientWidth - 12);
    g.plot = new uPlot({
      width, height: 220,
      // Without data (or with one value) uPlot finds no axis ticks: give
      // such scales a span of their own.
      scales: {
        x: { time: false, range: (u, min, max) => (min === null || !(max > min) ? [0, 1] : [min, max]) },
        // A y span the user chose (Shift + drag) holds until a double click.
        y: { range: (u, min, max) => g.y || (min === null ? [0, 1] : uPlot.rangeNum(min, max, 0.1, true)) },
      },
      axes: [{ label: 'session time (s)' }, { label: unitsOf(s, g.members) }],
      series: [{ label: 't (s)' }].concat(g.members.map((k, j) => ({
        label: sensors[k].name, stroke: colour(j), width: 1, spanGaps: false,
        points: { show: false },
      })), overlaySeries(s, g)),
      // A drag selects a span; the page then reads it at the chart's resolution.
      cursor: { drag: { x: true, y: false, setScale: false } },
      legend: { live: true },
      hooks: {
        drawClear: [(u) => shadeHolds(s, u)],
        draw: [(u) => drawCursors(s, u)],
        setSelect: [(u) => onSelect(s, u)],
        // Off the chart, back to the newest values.
        setCursor: [(u) => { if (u.cursor.left < 0) showLatest(u); }],
        // A click (not a drag) places cursor A, the next B.
        ready: [(u) => {
          u.over.addEventListener('click', (e) => {
            if (s.dragged) { s.dragged = false; return; }
            // The second click of a double click places nothing.
            if (e.detail > 1) return;
            g.beforeClick = s.cursors.slice();
            const t = u.posToVal(e.offsetX, 'x');
            setCursors(s, s.cursors.length === 1 ? [s.cursors[0], t] : [t]);
          });
          // Shift + drag: zoom the y axis to the span dragged over.
          u.over.addEventListener('mousedown', (e) => { g.yFrom = e.shiftKey ? e.offsetY : null; });
          u.over.addEventListener('mouseup', (e) => {
            if (g.yFrom == null || Math.abs(e.offsetY - g.yFrom) < 3) return;
            const [a, b] = [u.posToVal(g.yFrom, 'y'), u.posToVal(e.offsetY, 'y')];
            s.dragged = true;
            setY(g, [Math.min(a, b), Math.max(a, b)]);
          });
          // A double click resets y only: the cursor its first click
          // placed is taken back.
          u.over.addEventListener('dblclick', () => {
            if (g.beforeClick) setCursors(s, g.beforeClick);
            g.beforeClick = null;
            setY(g, null);
          });
          // Shift + wheel: pan the y axis by a tenth of its span (Chromium
          // turns a Shift + wheel into a horizontal scroll: either delta).
          u.over.addEventListener('wheel', (e) => {
            if (!e.shiftKey) return;
            const delta = e.deltaY || e.deltaX;
            if (!delta) return;
            e.preventDefault();
            const [lo, hi] = g.y || [u.scales.y.min, u.scales.y.max];
            const step = (hi - lo) * 0.1 * Math.sign(delta);
            setY(g, [lo - step, hi - step]);
          }, { passive: false });
        }],
      },
    }, plotData(s, g), g.box);
    if (s.range) g.plot.setScale('x', { min: s.range[0], max: s.range[1] });
    showLatest(g.plot);
  }

  // ---- XY plots of any two signals ------------------------------------------

  // A plot of signal `y` against signal `x` over the window in view: each
  // time column both have is a point (the middle of each's min and max),
  // joined in time order, so a hysteresis loop stays a loop.
  function addXyPlot(s, x, y, title) {
    const p = { x, y, title: title || 'XY', canvas: el('canvas', { class: 'xy', width: '560', height: '320' }) };
    const pick = (label, chosen, set) => {
      const select = el('select', { title: label });
      select.replaceChildren(...s.sensors.map((x, k) => el('option', { value: String(k), text: `${label}: ${x.name}` })));
      select.value = String(chosen);
      select.onchange = () => { set(Number(select.value)); drawXyPlot(s, p); };
      return select;
    };
    p.box = el('div', { class: 'chart' }, el('h3', { text: p.title }),
      el('div', { class: 'plot-tools' },
        pick('x', x, (k) => { p.x = k; }), pick('y', y, (k) => { p.y = k; }),
        el('button', { type: 'button', text: 'PNG', onclick: () => downloadUrl(`${s.name}-xy.png`, pngOf(p.canvas, `${s.name}: ${p.title}`, [])) }),
        el('button', { type: 'button', text: '\u00d7', title: 'close this plot', onclick: () => { p.box.remove(); s.xyPlots = s.xyPlots.filter((q) => q !== p); } })),
      p.canvas);
    s.charts.append(p.box);
    s.xyPlots.push(p);
    drawXyPlot(s, p);
    return p;
  }

  function drawXyPlot(s, p) {
    const source = s.follow || !s.zoomColumns ? s.columns : s.zoomColumns;
    const [a, b] = s.range || [-Infinity, Infinity];
    const mid = (c) => (c[0] + c[1]) / 2;
    // A column is keyed by its first sample's time, which differs between
    // signals: pair each x column with the y column nearest it in time,
    // within half a column.
    const sorted = (m) => Array.from(m).sort((u, v) => u[0] - v[0]);
    const xs = sorted(source[p.x]);
    const ys = sorted(source[p.y]);
    const points = [];
    let j = 0;
    for (const [key, cx] of xs) {
      const t = key / 1000;
      if (t < a || t > b) continue;
      while (j + 1 < ys.length && Math.abs(ys[j + 1][0] - key) <= Math.abs(ys[j][0] - key)) j += 1;
      if (ys[j] && Math.abs(ys[j][0] - key) <= 500 * cx[2]) points.push([mid(cx), mid(ys[j][1])]);
    }
    const { name: xName, unit: xUnit } = s.sensors[p.x];
    const { name: yName, unit: yUnit } = s.sensors[p.y];
    p.ticks = drawXy(s, { x: xName, x_unit: xUnit, y: yName, y_unit: yUnit, points }, p.canvas) || null;
    p.points = points.length;
  }

  // ---- two cursors ---------------------------------------------------------

  // Cursors A and B at session times `times` (0, 1 or 2 of them), drawn on
  // every plot of the session and read out with their differences.
  function setCursors(s, times) {
    s.cursors = times.slice(0, 2);
    for (const g of s.groups) g.plot.redraw(false);
    renderCursors(s);
  }

  function drawCursors(s, u) {
    const ctx = u.ctx;
    const { left, top, width, height } = u.bbox;
    ctx.save();
    ctx.font = `${11 * devicePixelRatio}px system-ui, sans-serif`;
    s.cursors.forEach((t, i) => {
      const x = u.valToPos(t, 'x', true);
      if (x < left || x > left + width) return;
      ctx.strokeStyle = i ? '#cf222e' : '#0969da';
      ctx.setLineDash([4 * devicePixelRatio, 3 * devicePixelRatio]);
      ctx.beginPath(); ctx.moveTo(x, top); ctx.lineTo(x, top + height); ctx.stroke();
      ctx.fillStyle = ctx.strokeStyle;
      ctx.fillText(i ? 'B' : 'A', x + 3 * devicePixelRatio, top + 12 * devicePixelRatio);
    });
    ctx.restore();
  }

  // A signal's value at session time t: the middle of the page's column
  // nearest t, within two column widths or the signal's own sample period
  // (zoomed in, a 10 Hz signal has a column only every tenth of a second),
  // else none.
  function valueAt(s, k, t) {
    const source = s.follow || !s.zoomColumns ? s.columns : s.zoomColumns;
    const period = periodMs(s.sensors[k]) / 1000;
    let best = null;
    for (const [key, c] of source[k]) {
      const d = Math.abs(key / 1000 - t);
      if (d <= Math.max(2 * c[2], period) && (!best || d < best.d)) best = { d, v: (c[0] + c[1]) / 2 };
    }
    return best ? best.v : null;
  }

  function renderCursors(s) {
    const [a, b] = s.cursors;
    if (a === undefined) {
      s.cursorBox.replaceChildren(el('p', { class: 'hint', text: 'Click a plot to place cursor A, again for B.' }));
      return;
    }
    const members = Array.from(new Set(s.groups.flatMap((g) => g.members)));
    const head = ['signal', 'unit', `A at ${fmt(a)} s`].concat(b === undefined ? [] : [`B at ${fmt(b)} s`, 'B \u2212 A']);
    const rows = members.map((k) => {
      const va = valueAt(s, k, a);
      const cells = [cell(s.sensors[k].name), cell(s.sensors[k].unit), cell(fmt(va), 'num')];
      if (b !== undefined) {
        const vb = valueAt(s, k, b);
        cells.push(cell(fmt(vb), 'num'), cell(va === null || vb === null ? '-' : fmt(vb - va), 'num'));
      }
      return el('tr', {}, ...cells);
    });
    s.cursorBox.replaceChildren(
      el('p', { text: b === undefined ? `A at ${fmt(a)} s; click again for B` : `A at ${fmt(a)} s, B at ${fmt(b)} s: \u0394t = ${fmt(b - a)} s` }),
      el('table', { class: 'cursor-values' },
        el('thead', {}, el('tr', {}, ...head.map((t) => el('th', { text: t })))),
        el('tbody', {}, ...rows)));
  }

  // A plot's y axis: fixed to `span`, or (null) following its data.
  function setY(g, span) {
    g.y = span;
    const { min, max } = g.plot.scales.x;
    // Setting the data again runs the y range (fixed, or the data's) and
    // resets x, which is put back.
    g.plot.setData(g.plot.data, true);
    g.plot.setScale('x', { min, max });
  }

  // The y axis's units: those of the plot's signals, once each.
  function unitsOf(s, members) {
    return Array.from(new Set(members.map((k) => s.sensors[k].unit))).join(', ');
  }

  // Replaces the session's plots by a layout's (what Save layout writes).
  function applyLayout(s, layout) {
    if (!layout || !Array.isArray(layout.plots)) {
      banner('Load layout: not a layout file: it needs "plots", as Save layout writes them');
      return;
    }
    for (const g of s.groups.slice()) closePlot(s, g);
    for (const p of s.xyPlots) p.box.remove();
    s.xyPlots = [];
    for (const { title, members, xy } of plotsOf(s.sensors, layout)) {
      if (xy) addXyPlot(s, xy[0], xy[1], title);
      else addPlot(s, title, members);
    }
    renderCursors(s);
  }

  // The plots as a layout file (`acq view --layout FILE` loads it).
  function layoutJson(s) {
    return JSON.stringify({
      format: 1,
      plots: s.groups.map((g) => ({ title: g.group, signals: g.members.map((k) => s.sensors[k].name) }))
        .concat(s.xyPlots.map((p) => ({ title: p.title, xy: [s.sensors[p.x].name, s.sensors[p.y].name] }))),
    }, null, 2);
  }

  // What the plots show now, as CSV: one row per time column in view, each
  // signal's min and max there (the page's own resolution), in the units
  // the header names. A signal slower than the columns keeps its last
  // column's min and max until its next sample, as the plot draws it; a
  // cell is empty only before its first sample and in a gap (no sample for
  // three of its periods), where the plot breaks its line too.
  function exportCsv(s) {
    const members = Array.from(new Set(s.groups.flatMap((g) => g.members)));
    const [x, ...ys] = chartData(s, linesOf(s, members));
    const header = ['time_s'].concat(members.flatMap((k) => {
      const { name, unit } = s.sensors[k];
      return [`${name}_min [${unit}]`, `${name}_max [${unit}]`];
    }));
    const lines = [header.join(',')];
    const [a, b] = s.range || [-Infinity, Infinity];
    const held = ys.map(() => ['', '']);
    for (let i = 0; i + 1 < x.length; i += 2) {
      ys.forEach((y, j) => {
        if (y[i] === null) held[j] = ['', ''];
        else if (y[i] !== undefined) held[j] = [y[i], y[i + 1]];
      });
      if (x[i] < a || x[i] > b) continue;
      lines.push([x[i]].concat(held.flat()).join(','));
    }
    return lines.join('\n') + '\n';
  }

  function download(name, text, type) {
    downloadUrl(name, URL.createObjectURL(new Blob([text], { type })));
  }

  function downloadUrl(name, href) {
    const a = el('a', { href, download: name });
    document.body.append(a);
    a.click();
    a.remove();
  }

  function shadeHolds(s, u) {
    const ctx = u.ctx;
    ctx.save();
    ctx.fillStyle = 'rgba(45, 164, 78, 0.18)';
    const { left, top, width, height } = u.bbox;
    for (const h of s.holds) {
      const x0 = Math.max(left, u.valToPos(h.start_s, 'x', true));
      const x1 = Math.min(left + width, u.valToPos(h.end_s, 'x', true));
      if (x1 > x0) ctx.fillRect(x0, top, x1 - x0, height);
    }
    ctx.restore();
  }

  // A drag across any chart: the session stops following and every chart
  // of it shows the span chosen, read again at the chart's resolution.
  function onSelect(s, u) {
    const { left, width } = u.select;
    if (width < 2) return;
    s.dragged = true;
    // A Shift + drag is the y axis's, not a span of time.
    if (s.groups.some((g) => g.plot === u && g.yFrom != null)) {
      u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
      return;
    }
    const range = [u.posToVal(left, 'x'), u.posToVal(left + width, 'x')];
    u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
    s.follow = false;
    showRange(s, range);
  }

  function setRange(s, range) {
    s.range = range;
    for (const g of s.groups) g.plot.setScale('x', { min: range[0], max: range[1] });
  }

  async function showRange(s, range) {
    s.range = range;
    updateMode(s);
    const px = Math.max(200, Math.round(s.groups[0] ? s.groups[0].plot.bbox.width / devicePixelRatio : 1000));
    try {
      const data = await getJson('/api/series', { session: s.index, from: range[0], to: range[1], px });
      // A range asked for since wins; its answer may come first.
      if (s.range !== range) return;
      const width = (range[1] - range[0]) / px;
      s.zoomColumns = data.series.map((cols) => toMap(cols, width));
      const drawn = redraw(s);
      refreshOverlay(s);
      await drawn;
    } catch (e) {
      banner(`could not read the series: ${e.message}`);
    }
  }

  function toMap(cols, width) {
    const m = new Map();
    for (const [t, min, max] of cols) m.set(Math.round(t * 1000), [min, max, width]);
    return m;
  }

  function toggleFollow(s) {
    s.follow = !s.follow;
    if (s.follow) {
      s.zoomColumns = null;
      followWindow(s);
    } else {
      showRange(s, s.range || liveWindow(s));
    }
    updateMode(s);
  }

  function showWhole(s) {
    s.follow = false;
    return getJson('/api/state').then((state) => {
      const info = state.sessions[s.index];
      return info.span_s ? showRange(s, info.span_s) : null;
    });
  }

  function pan(s, fraction) {
    const [a, b] = s.range || liveWindow(s);
    const shift = (b - a) * fraction;
    s.follow = false;
    showRange(s, [a + shift, b + shift]);
  }

  function zoom(s, factor) {
    const [a, b] = s.range || liveWindow(s);
    const mid = (a + b) / 2;
    const half = ((b - a) * factor) / 2;
    s.follow = false;
    showRange(s, [mid - half, mid + half]);
  }

  // The last minute; in the first minute, the minute from the start.
  function liveWindow(s) {
    return [Math.max(0, s.end - LIVE_WINDOW_S), Math.max(s.end, LIVE_WINDOW_S)];
  }

  function updateMode(s) {
    if (s.live) {
      s.pauseButton.textContent = s.follow ? 'Pause' : 'Follow';
      s.mode.textContent = s.follow ? `following the last ${LIVE_WINDOW_S} s`
        : 'paused (recording goes on); Follow returns to the newest data';
    } else if (s.range) {
      s.mode.textContent = `${fmt(s.range[0])} s to ${fmt(s.range[1])} s`;
    }
  }

  async function followWindow(s) {
    const data = await getJson('/api/series', {
      session: s.index, from: s.end - LIVE_WINDOW_S, to: s.end + 1,
      px: Math.round((LIVE_WINDOW_S + 1) / LIVE_COLUMN_S),
    });
    data.series.forEach((cols, k) => {
      for (const [t, min, max] of cols) s.columns[k].set(Math.round(t * 1000), [min, max, LIVE_COLUMN_S]);
    });
    redraw(s);
  }

  // Min and max of each column as two points half a column apart: the
  // envelope a line through every sample would fill. A column a line has
  // no sample in is bridged (undefined) unless its sensor was silent for
  // three of its periods and two columns (null: a gap is drawn).
  // `lines`: [{ map: time key (ms) -> [min, max, width], periodMs }].
  function chartData(s, lines) {
    const [a, b] = s.range || [-Infinity, Infinity];
    const keys = new Set();
    for (const { map } of lines) {
      for (const key of map.keys()) if (key / 1000 >= a - 1 && key / 1000 <= b + 1) keys.add(key);
    }
    const sorted = Array.from(keys).sort((p, q) => p - q);
    const x = new Array(sorted.length * 2);
    const ys = lines.map(() => new Array(sorted.length * 2).fill(undefined));
    const lastSeen = lines.map(() => -Infinity);
    sorted.forEach((key, i) => {
      let width = LIVE_COLUMN_S;
      lines.forEach(({ map, periodMs }, j) => {
        const c = map.get(key);
        if (c) {
          ys[j][2 * i] = c[0];
          ys[j][2 * i + 1] = c[1];
          width = c[2];
          lastSeen[j] = key;
        } else if (key - lastSeen[j] > Math.max(3 * periodMs, 2000 * width) && lastSeen[j] > -Infinity) {
          ys[j][2 * i] = null;
        }
      });
      x[2 * i] = key / 1000;
      x[2 * i + 1] = key / 1000 + width / 2;
    });
    return [x, ...ys];
  }

  function periodMs(sensor) {
    return sensor.expected_rate_hz > 0 ? 1000 / sensor.expected_rate_hz : 0;
  }

  // The session's own signals `members` as lines of a chart.
  function linesOf(s, members) {
    const source = s.follow || !s.zoomColumns ? s.columns : s.zoomColumns;
    return members.map((k) => ({ map: source[k], periodMs: periodMs(s.sensors[k]) }));
  }

  // A plot's data: its signals, then the overlaid session's of the same names.
  function plotData(s, g) {
    const o = s.overlay;
    const other = o ? view.sessions[o.from] : null;
    const overlaid = (g.overlaid || []).map((k) => ({
      map: (o && o.columns && o.columns[k]) || new Map(), periodMs: periodMs(other.sensors[k]),
    }));
    return chartData(s, linesOf(s, g.members).concat(overlaid));
  }

  // ---- another session overlaid, shifted in time -------------------------

  // The overlaid session's signals that this plot's signals are named as,
  // dashed in their colours, labelled with the session and the shift.
  function overlaySeries(s, g) {
    const o = s.overlay;
    g.overlaid = [];
    if (!o) return [];
    const other = view.sessions[o.from];
    const series = [];
    g.members.forEach((k, j) => {
      const match = other.sensors.findIndex((x) => x.name === s.sensors[k].name);
      if (match < 0) return;
      g.overlaid.push(match);
      const shift = `${o.shift < 0 ? '\u2212' : '+'}${fmt(Math.abs(o.shift))} s`;
      series.push({ label: `${s.sensors[k].name} (${other.name}, ${shift})`, stroke: colour(j), dash: [6, 4],
        width: 1, spanGaps: false, points: { show: false } });
    });
    return series;
  }

  // Session `from` drawn in this session's plots, its time t at t + shift
  // (null: no overlay).
  function setOverlay(s, from, shift) {
    const valid = from !== null && from !== s.index && view.sessions[from];
    s.overlay = valid ? { from, shift: Number(shift) || 0, columns: null, span: null } : null;
    for (const g of s.groups) rebuildPlot(s, g);
    return s.overlay ? refreshOverlay(s) : Promise.resolve();
  }

  // Reads the overlaid session over the span in view and half of it on
  // each side (a pan or a live window's step needs no new read), at twice
  // the plot's columns.
  async function refreshOverlay(s) {
    const o = s.overlay;
    if (!o || o.fetching) return;
    const [a, b] = s.range || liveWindow(s);
    if (o.span && o.span[0] <= a && o.span[1] >= b) return;
    const pad = (b - a) / 2;
    const [from, to] = [a - pad - o.shift, b + pad - o.shift];
    const px = Math.max(400, Math.round(2 * (s.groups[0] ? s.groups[0].plot.bbox.width / devicePixelRatio : 1000)));
    o.fetching = true;
    try {
      const data = await getJson('/api/series', { session: o.from, from, to, px });
      if (s.overlay !== o) return;
      const width = (to - from) / px;
      o.columns = data.series.map((cols) => {
        const m = new Map();
        for (const [t, min, max] of cols) m.set(Math.round((t + o.shift) * 1000), [min, max, width]);
        return m;
      });
      o.span = [a - pad, b + pad];
      redraw(s);
    } catch (e) {
      banner(`could not read the overlaid session: ${e.message}`);
    } finally {
      o.fetching = false;
    }
  }

  // With several sessions: a session to overlay, its shift, and a button
  // that sets the shift so that both sessions' first holds start together.
  function addOverlayControls(s) {
    const pick = el('select', { class: 'overlay', title: 'draw the signals of the same names of another session in these plots, dashed' },
      el('option', { value: '', text: 'overlay: none' }),
      ...view.sessions.filter((o) => o !== s).map((o) => el('option', { value: String(o.index), text: `overlay: ${o.name}` })));
    const shift = el('input', { type: 'number', step: '0.1', value: '0', class: 'shift', title: 'the overlaid session\'s time t is drawn at t + shift' });
    const apply = () => setOverlay(s, pick.value === '' ? null : Number(pick.value), Number(shift.value));
    pick.onchange = apply;
    shift.onchange = apply;
    const align = el('button', { type: 'button', text: 'Align first holds', onclick: () => {
      const other = pick.value === '' ? null : view.sessions[Number(pick.value)];
      // Say which of the two is missing: a session to overlay, or a hold.
      const noHold = [s, other].filter((x) => x && !x.holds.length).map((x) => x.name);
      if (!other) {
        banner('Align first holds: choose a session to overlay first.');
        return;
      }
      if (noHold.length) {
        banner(`Align first holds: ${noHold.join(' and ')} ${noHold.length > 1 ? 'have' : 'has'} no hold (steady stretches, as acq extract finds them); set the shift by hand.`);
        return;
      }
      shift.value = String(Number((s.holds[0].start_s - other.holds[0].start_s).toFixed(3)));
      apply();
    } });
    s.controls.insertBefore(el('span', { class: 'overlay-tools' }, pick, el('label', {}, ' shift (s) ', shift), align), s.mode);
  }

  // A session's next frame, drawn once however many asked for it; the
  // promise settles when it is on screen, so that what follows a new range
  // (a y span, a cursor's values) works on the data drawn, not the last.
  const pending = new Map();
  function redraw(s) {
    if (pending.has(s)) return pending.get(s);
    const drawn = new Promise((resolve) => requestAnimationFrame(() => {
      pending.delete(s);
      try {
        drawFrame(s);
      } finally {
        resolve();
      }
    }));
    pending.set(s, drawn);
    return drawn;
  }

  function drawFrame(s) {
    // setData rescales y (and x, which setRange then sets).
    for (const g of s.groups) {
      g.plot.setData(plotData(s, g));
      showLatest(g.plot);
    }
    if (s.range) setRange(s, s.range);
    for (const p of s.xyPlots) drawXyPlot(s, p);
    let last = null;
    for (const m of s.columns) for (const key of m.keys()) last = last === null ? key : Math.max(last, key);
    view.lastX[s.index] = last === null ? null : last / 1000;
    if (view.watch) noteDrawn(s);
  }

  // For a benchmark: when the newest value of the signal named
  // `view.watch` reached the screen (this animation frame), as
  // [unix ms, value] in `view.drawLog`.
  function noteDrawn(s) {
    for (const g of s.groups) {
      const j = g.members.findIndex((k) => s.sensors[k].name === view.watch);
      if (j < 0) continue;
      const ys = g.plot.data[j + 1];
      for (let i = ys.length - 1; i >= 0; i--) {
        if (ys[i] != null) { view.drawLog.push([Date.now(), ys[i]]); return; }
      }
      return;
    }
  }

  // The legend gives each signal's newest value in view while the cursor is
  // off the chart (uPlot's own legend says "--" then): per series, the
  // last index that holds a value.
  function showLatest(u) {
    if (u.cursor.idx != null && u.cursor.left >= 0) return;
    const idxs = u.data.map((ys, k) => {
      if (k === 0) return null;
      for (let i = ys.length - 1; i >= 0; i--) if (ys[i] != null) return i;
      return null;
    });
    idxs[0] = idxs.slice(1).reduce((m, i) => (i == null ? m : Math.max(m == null ? i : m, i)), null);
    u.setLegend({ idxs });
  }

  // ---- live updates -----------------------------------------------------

  function applyTails(s, tail) {
    if (!tail) return;
    const fromKey = Math.round(tail.from_s * 1000);
    tail.series.forEach((cols, k) => {
      const m = s.columns[k];
      // A Map may lose entries while it is walked (no copy of its keys).
      for (const key of m.keys()) if (key >= fromKey) m.delete(key);
      for (const [t, min, max] of cols) {
        const key = Math.round(t * 1000);
        m.set(key, [min, max, LIVE_COLUMN_S]);
        s.end = Math.max(s.end, t + LIVE_COLUMN_S);
      }
      const oldest = (s.end - KEEP_LIVE_S) * 1000;
      for (const key of m.keys()) {
        if (key >= oldest) break;
        m.delete(key);
      }
    });
    if (s.follow) s.range = liveWindow(s);
    redraw(s);
    refreshOverlay(s);
  }

  function applyState(state) {
    const several = state.sessions.length > 1;
    state.sessions.forEach((info, i) => {
      const s = view.sessions[i];
      if (!s) return;
      if (s.live && !info.live) {
        s.live = false;
        s.mode.textContent = info.ended ? `recording ended (${info.ended})` : 'recording ended';
        s.title.textContent = `${info.name} (recorded)`;
        s.pauseButton.textContent = 'Whole session';
        // A page that was following the recording now shows all of it.
        if (s.follow) showWhole(s);
        if (!view.sessions.some((x) => x.live)) {
          const connection = document.getElementById('connection');
          connection.textContent = 'recording ended: the page shows the whole session';
          connection.className = '';
        }
      }
      s.holdsNote = info.holds_note;
      s.framesNotShown = info.frames_not_shown;
      // An update carries the holds only when they changed.
      const holds = state.holds ? state.holds.filter((h) => !several || h.session === info.name) : s.holds;
      const changed = JSON.stringify(holds.map((h) => [h.start_s, h.end_s])) !== JSON.stringify(s.holds.map((h) => [h.start_s, h.end_s]));
      s.holds = holds;
      if (changed) {
        for (const g of s.groups) g.plot.redraw(false, false);
        for (const h of holds) {
          if (!view.holdsShown.some((x) => x.session === info.name && x.start_s === h.start_s && x.end_s === h.end_s)) {
            view.holdsShown.push({ session: info.name, index: h.index, start_s: h.start_s, end_s: h.end_s, shown_ms: Date.now() });
          }
        }
      }
      s.state = { info, sensors: sessionSensors(state, info, several),
        buses: state.buses.filter((b) => !several || b.session === info.name), holds };
    });
    renderStudy(state.study);
    renderTablesSoon();
  }

  let tablesDue = false;
  let tablesAt = 0;
  function renderTablesSoon() {
    if (tablesDue) return;
    tablesDue = true;
    setTimeout(() => {
      tablesDue = false;
      tablesAt = Date.now();
      for (const s of view.sessions) renderTables(s);
    }, Math.max(0, 400 - (Date.now() - tablesAt)));
  }

  function cell(text, cls) { return el('td', cls ? { class: cls, text } : { text }); }

  // A table body brought to `rows` in place: each row { cells, cls }, each
  // cell [text, class] or { bytes, before } (a payload, its changed bytes
  // marked). Only what changed is written: rebuilding the tables every
  // look cost the browser more than the six live plots together.
  function syncBody(tbody, rows) {
    while (tbody.rows.length > rows.length) tbody.deleteRow(-1);
    rows.forEach((row, i) => {
      const tr = tbody.rows[i] || tbody.insertRow();
      if (tr.className !== (row.cls || '')) tr.className = row.cls || '';
      row.cells.forEach((c, j) => {
        const td = tr.cells[j] || tr.insertCell();
        if (c.bytes !== undefined) {
          const key = `${c.before}|${c.bytes}`;
          if (td.dataset.bytes === key) return;
          td.dataset.bytes = key;
          td.className = 'bytes';
          const old = c.before === undefined ? null : c.before.split(' ');
          td.replaceChildren(...c.bytes.split(' ').filter(Boolean).map((byte, k) =>
            el('span', old && old[k] !== byte ? { class: 'changed', text: byte } : { text: byte })));
          return;
        }
        const [text, cls] = c;
        if (td.textContent !== text) td.textContent = text;
        if (td.className !== (cls || '')) td.className = cls || '';
      });
    });
  }

  function table(cls, heads) {
    const body = el('tbody');
    return { table: el('table', { class: cls }, el('thead', {}, el('tr', {}, ...heads.map((h) => el('th', { text: h })))), body), body };
  }

  // The session's tables, built once and then updated in place: the buses,
  // the sensors, the holds (rebuilt only when they change) and the raw
  // frames.
  function buildTables(s) {
    const t = {
      buses: table('buses', ['bus', 'state', 'frames/s', 'frames', 'kernel drops', 'error frames']),
      sensors: table('sensors', ['sensor', 'last value', 'unit', 'state']),
      holds: table('holds', ['hold', 'start (s)', 'end (s)', 'length (s)', 'measured values']),
      frames: table('frames', ['bus', 'id (hex)', 'kind', 'bytes', 'newest payload (hex)', 'frames', 'rate (Hz)', 'last gap (ms)', 'newest at (s)', 'signals']),
      notes: el('div'),
      holdsKey: null,
    };
    t.framesSummary = el('summary');
    t.framesBox = el('details', { class: 'frames' }, t.framesSummary,
      el('p', { class: 'note', text: 'One row per bus and CAN id. Bytes in bold changed since the page last looked; an id in grey gave the rig no value.' }),
      t.frames.table);
    s.tables.replaceChildren(el('div', {}, t.buses.table, t.notes), t.sensors.table, t.holds.table, t.framesBox);
    s.tableParts = t;
    return t;
  }

  function renderTables(s) {
    if (!s.state) return;
    const { info, sensors, buses, holds } = s.state;
    const t = s.tableParts || buildTables(s);
    syncBody(t.buses.body, buses.map((b) => ({ cells: [
      [b.iface], [b.state, b.state === 'down' ? 'fault' : ''], [fmt(b.frames_per_s), 'num'],
      [String(b.frames), 'num'], [String(b.kernel_drops), b.kernel_drops > 0 ? 'num fault' : 'num'],
      [String(b.error_frames), b.error_frames > 0 ? 'num fault' : 'num']] })));
    syncBody(t.sensors.body, sensors.map((x) => ({ cls: x.silent ? 'silent' : '', cells: [
      [x.name], [fmt(x.last_value), 'num'], [x.unit],
      [x.silent ? `SILENT${x.silence_reason ? ': ' + x.silence_reason : ''}` : 'alive']] })));
    const holdsKey = JSON.stringify(holds.map((h) => [h.name, h.start_s, h.end_s, h.values && h.values.map((v) => [v.mean, v.flags])]));
    if (holdsKey !== t.holdsKey) {
      t.holdsKey = holdsKey;
      renderHolds(t.holds.body, holds);
    }
    if (s.frames) renderFrames(s, t, s.frames, info.frames_not_listed);
    const notes = [];
    if (s.holdsNote) notes.push(el('p', { class: 'note', text: s.holdsNote }));
    if (info.load_sensor) notes.push(el('p', { class: 'note', text: `holds: steady stretches of ${info.load_sensor}, found as acq extract finds them` }));
    if (info.frames_not_shown > 0) notes.push(el('p', { class: 'fault', text: `this view fell behind: ${info.frames_not_shown} frames not shown (all of them recorded)` }));
    const notesKey = notes.map((n) => n.textContent).join('\n');
    if (t.notesKey !== notesKey) {
      t.notesKey = notesKey;
      t.notes.replaceChildren(...notes);
    }
  }

  // The holds with their values; the details a reader opened stay open.
  function renderHolds(body, holds) {
    const open = new Set(Array.from(body.querySelectorAll('details[open]')).map((d) => d.closest('tr').firstChild.textContent));
    body.replaceChildren(...holds.map((h) => {
      const details = el('details', {}, el('summary', { text: h.values ? `${h.values.length} values` : 'values: see acq extract' }));
      if (h.values) {
        details.append(el('table', {},
          el('thead', {}, el('tr', {}, ...['quantity', 'mean', 'std', '95 % interval', 'unit', 'flags'].map((t) => el('th', { text: t })))),
          el('tbody', {}, ...h.values.map((v) => el('tr', {},
            cell(v.quantity), cell(fmt(v.mean), 'num'), cell(fmt(v.std), 'num'),
            cell(v.ci95_half_width === null ? '-' : '\u00b1 ' + fmt(v.ci95_half_width), 'num'), cell(v.unit),
            cell(v.flags.join(', '), v.flags.length ? 'fault' : ''))))));
      }
      details.open = open.has(h.name);
      return el('tr', { class: 'hold' }, cell(h.name), cell(fmt(h.start_s), 'num'), cell(fmt(h.end_s), 'num'),
        cell(fmt(h.end_s - h.start_s), 'num'), el('td', {}, details));
    }));
  }

  // The raw frames, one row per bus and CAN id (a fixed-position trace):
  // the newest payload, its bytes that changed since the last look marked,
  // the count, the rate over the whole span and the newest gap, and the
  // signals the id carries. Open at first when it is short; then as the
  // reader left it.
  function renderFrames(s, t, frames, notListed) {
    const previous = s.frameData || new Map();
    s.frameData = new Map();
    syncBody(t.frames.body, frames.map((f) => {
      const key = `${f.bus} ${f.id} ${f.kind}`;
      s.frameData.set(key, f.data);
      return { cls: f.used === 'decoded' || f.used === 'protocol' ? '' : 'unused', cells: [
        [f.bus], [f.id, 'num'], [f.kind], [String(f.dlc), 'num'], { bytes: f.data, before: previous.get(key) },
        [String(f.count), 'num'], [f.rate_hz === null ? '-' : fmt(f.rate_hz), 'num'],
        [f.last_gap_s === null ? '-' : fmt(1000 * f.last_gap_s), 'num'], [fmt(f.last_s), 'num'],
        [f.signals.length ? f.signals.join(', ') : f.used]] };
    }));
    const summary = `Raw frames: ${frames.length} id(s)` + (notListed > 0 ? `, ${notListed} frames of further ids not listed` : '');
    if (t.framesSummary.textContent !== summary) t.framesSummary.textContent = summary;
    if (t.framesOpened === undefined && frames.length) {
      t.framesOpened = true;
      t.framesBox.open = frames.length <= 40;
    }
  }

  // The raw frames are read, not pushed: once a second while a session
  // records and its trace is open (or not yet shown), and once for a
  // recorded one.
  async function refreshFrames() {
    const wanted = view.sessions.filter((s) => (s.live || !s.framesRead)
      && (!s.tableParts || s.tableParts.framesOpened === undefined || s.tableParts.framesBox.open));
    if (!wanted.length) return;
    const { frames } = await getJson('/api/frames');
    const several = view.sessions.length > 1;
    for (const s of view.sessions) {
      s.frames = frames.filter((f) => !several || f.session === s.name);
      s.framesRead = true;
    }
    renderTablesSoon();
  }

  // Round tick values (1, 2 or 5 times a power of ten) covering lo..hi.
  function niceTicks(lo, hi, count) {
    if (!(hi > lo)) return [lo];
    const raw = (hi - lo) / Math.max(1, count);
    const power = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * power).find((v) => v >= raw) || 10 * power;
    const ticks = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
    return ticks;
  }

  // An XY plot on a canvas: the curve in drawing order (a loop stays a
  // loop), a grid at round values, tick labels and both axes named with
  // their units.
  function drawXy(s, xy, canvas = s.xyCanvas) {
    if (!canvas || !xy || !xy.points.length) return;
    const ctx = canvas.getContext('2d');
    const w = canvas.width;
    const h = canvas.height;
    const [left, right, top, bottom] = [62, 16, 12, 44];
    ctx.clearRect(0, 0, w, h);
    const xs = xy.points.map((p) => p[0]);
    const ys = xy.points.map((p) => p[1]);
    const xTicks = niceTicks(Math.min(...xs), Math.max(...xs), 6);
    const yTicks = niceTicks(Math.min(0, ...ys), Math.max(...ys), 5);
    const [x0, x1] = [Math.min(xTicks[0], ...xs), Math.max(xTicks[xTicks.length - 1], ...xs)];
    const [y0, y1] = [Math.min(yTicks[0], ...ys), Math.max(yTicks[yTicks.length - 1], ...ys)];
    const px = (x) => left + ((x - x0) / (x1 - x0 || 1)) * (w - left - right);
    const py = (y) => h - bottom - ((y - y0) / (y1 - y0 || 1)) * (h - top - bottom);
    ctx.font = '11px system-ui, sans-serif';
    ctx.lineWidth = 1;
    ctx.fillStyle = '#57606a';
    ctx.strokeStyle = '#e1e4e8';
    ctx.textAlign = 'center';
    ctx.textBaseline = 'top';
    for (const t of xTicks) {
      ctx.beginPath(); ctx.moveTo(px(t), top); ctx.lineTo(px(t), h - bottom); ctx.stroke();
      ctx.fillText(String(Number(t.toPrecision(6))), px(t), h - bottom + 4);
    }
    ctx.textAlign = 'right';
    ctx.textBaseline = 'middle';
    for (const t of yTicks) {
      ctx.beginPath(); ctx.moveTo(left, py(t)); ctx.lineTo(w - right, py(t)); ctx.stroke();
      ctx.fillText(String(Number(t.toPrecision(6))), left - 4, py(t));
    }
    ctx.strokeStyle = '#57606a';
    ctx.strokeRect(left, top, w - left - right, h - top - bottom);
    ctx.fillStyle = '#1b1f24';
    ctx.font = '12px system-ui, sans-serif';
    ctx.textAlign = 'center';
    ctx.textBaseline = 'bottom';
    ctx.fillText(`${xy.x} (${xy.x_unit})`, left + (w - left - right) / 2, h - 4);
    ctx.save();
    ctx.translate(14, top + (h - top - bottom) / 2);
    ctx.rotate(-Math.PI / 2);
    ctx.textBaseline = 'middle';
    ctx.fillText(`${xy.y} (${xy.y_unit})`, 0, 0);
    ctx.restore();
    ctx.strokeStyle = COLORS[0];
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    xy.points.forEach(([x, y], i) => (i ? ctx.lineTo(px(x), py(y)) : ctx.moveTo(px(x), py(y))));
    ctx.stroke();
    if (canvas === s.xyCanvas) s.xyTicks = { x: xTicks, y: yTicks };
    return { x: xTicks, y: yTicks };
  }

  async function refreshXy() {
    for (const s of view.sessions) {
      if (s.xyCanvas && (s.live || !s.xyDrawn)) {
        s.xyDrawn = true;
        drawXy(s, await getJson('/api/xy', { session: s.index }));
      }
    }
  }


  // ---- a study at the rig ---------------------------------------------------

  const SVG = 'http://www.w3.org/2000/svg';
  function svg(tag, attrs = {}) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
    return e;
  }

  // One parameter's bar: the prior's 90 % interval in grey, the posterior's
  // in colour, its mean as a tick, on a scale spanning both.
  function intervalBar(p) {
    const lo = Math.min(p.prior_q05, p.q05);
    const hi = Math.max(p.prior_q95, p.q95);
    const span = hi > lo ? hi - lo : 1;
    const x = (v) => 4 + 232 * (v - lo) / span;
    const bar = svg('svg', { width: 240, height: 18, viewBox: '0 0 240 18', class: 'interval' });
    bar.append(svg('rect', { x: x(p.prior_q05), y: 6, width: Math.max(1, x(p.prior_q95) - x(p.prior_q05)), height: 6, fill: '#d0d7de' }));
    const colour = { identified: '#1a7f37', confounded: '#bf8700', conflict: '#cf222e', 'not converged': '#6e7781' }[p.verdict] || '#0969da';
    bar.append(svg('rect', { x: x(p.q05), y: 3, width: Math.max(1, x(p.q95) - x(p.q05)), height: 12, fill: colour, 'fill-opacity': 0.75 }));
    bar.append(svg('line', { x1: x(p.mean), x2: x(p.mean), y1: 1, y2: 17, stroke: '#1b1f24', 'stroke-width': 1.5 }));
    return bar;
  }

  // Each parameter's interval width over its prior's, hold by hold.
  function historyChart(study) {
    const order = study.order;
    const rows = study.history;
    if (!rows.length || typeof uPlot === 'undefined') return null;
    const xs = [0, ...rows.map((r) => r.holds_used)];
    const series = [{ label: 'holds used' }];
    const data = [xs];
    order.forEach((name, k) => {
      const p = study.parameters[name];
      const prior = p ? p.prior_q95 - p.prior_q05 : 1;
      data.push([1, ...rows.map((r) => (r.parameters[name] ? (r.parameters[name].q95 - r.parameters[name].q05) / prior : null))]);
      series.push({ label: name, stroke: COLORS[k % COLORS.length], width: 2, points: { show: true } });
    });
    const box = el('div', { class: 'chart' }, el('h3', { text: '90 % interval width / prior\'s, hold by hold' }));
    const plot = new uPlot({ width: 520, height: 200, series, scales: { x: { time: false } },
      axes: [{ label: 'holds used' }, { label: 'width ratio' }] }, data, box);
    view.studyPlot = plot;
    return box;
  }

  let studyShown = '';
  function renderStudy(study) {
    const section = document.getElementById('study');
    if (!section) return;
    if (!study) { section.hidden = true; return; }
    const key = JSON.stringify([study.holds_seen, study.holds_used, study.updating, study.error, study.next && study.next.words]);
    if (key === studyShown) return;
    studyShown = key;
    view.study = study;
    section.hidden = false;
    const heading = el('h2', { text: `Study ${study.file}: after ${study.holds_used} hold(s)` +
      (study.holds_seen > study.holds_used ? ` (${study.holds_seen - study.holds_used} not used)` : '') +
      (study.updating ? ', updating\u2026' : '') });
    const parts = [heading];
    if (study.error) parts.push(el('p', { class: 'fault', text: `the posterior failed: ${study.error}` }));
    for (const skipped of study.skipped) parts.push(el('p', { class: 'note', text: `${skipped.hold} not used: ${skipped.why}` }));
    const rows = study.order.filter((name) => study.parameters[name]).map((name) => {
      const p = study.parameters[name];
      const verdict = p.verdict === 'confounded' && p.confounded
        ? `confounded with ${p.confounded.with} (r = ${p.confounded.correlation.toFixed(2)})`
        : p.why ? `${p.verdict}: ${p.why}` : p.verdict;
      return el('tr', { class: `verdict-${p.verdict.replace(' ', '-')}` }, cell(name), cell(fmt(p.mean), 'num'),
        cell(`${fmt(p.q05)} \u2026 ${fmt(p.q95)}`, 'num'), cell(`${fmt(p.prior_q05)} \u2026 ${fmt(p.prior_q95)}`, 'num'),
        el('td', {}, intervalBar(p)), cell(verdict),
        cell(p.rhat == null ? '-' : p.rhat.toFixed(3), 'num'),
        cell(p.ess_bulk == null ? '-' : p.ess_bulk.toFixed(0), 'num'),
        cell(p.ess_tail == null ? '-' : p.ess_tail.toFixed(0), 'num'));
    });
    parts.push(el('table', { class: 'study' },
      el('thead', {}, el('tr', {}, ...['parameter', 'mean', '90 % interval', 'prior 90 %', 'interval (colour) against the prior (grey)', 'verdict', 'R-hat', 'bulk ESS', 'tail ESS'].map((t) => el('th', { text: t })))),
      el('tbody', {}, ...rows)));
    if (study.next) {
      const next = study.next;
      parts.push(el('p', { class: 'next', text: next.words }));
      parts.push(el('table', { class: 'next' },
        el('thead', {}, el('tr', {}, ...['set', 'value', '', 'the twin predicts there', 'value'].map((t) => el('th', { text: t })))),
        el('tbody', {}, ...zipRows(Object.entries(next.inputs), Object.entries(next.predicted)).map(([a, b]) => el('tr', {},
          cell(a ? a[0] : ''), cell(a ? fmt(a[1]) : '', 'num'), cell(''), cell(b ? b[0] : ''), cell(b ? fmt(b[1]) : '', 'num'))))));
      parts.push(el('p', { class: 'note', text: `chosen of ${next.candidates} candidates by expected information gain (${next.information_nats.toFixed(2)} nats)` }));
    } else if (study.next_error) {
      parts.push(el('p', { class: 'fault', text: `no next point: ${study.next_error}` }));
    }
    const chart = historyChart(study);
    if (chart) parts.push(chart);
    section.replaceChildren(...parts);
  }

  function zipRows(a, b) {
    const rows = [];
    for (let k = 0; k < Math.max(a.length, b.length); k += 1) rows.push([a[k], b[k]]);
    return rows;
  }

  // ---- start --------------------------------------------------------------

  async function start() {
    const state = await getJson('/api/state');
    const several = state.sessions.length > 1;
    state.sessions.forEach((info, i) => {
      const s = buildSession(i, info, sessionSensors(state, info, several), state.layout);
      view.sessions.push(s);
    });
    if (view.sessions.length > 1) view.sessions.forEach(addOverlayControls);
    applyState(state);
    for (const s of view.sessions) {
      const info = state.sessions[s.index];
      const span = info.span_s || [0, 0];
      s.end = span[1];
      if (s.live) {
        s.range = liveWindow(s);
        await followWindow(s);
      } else {
        await showRange(s, span);
      }
      updateMode(s);
    }
    await refreshXy();
    await refreshFrames().catch(() => {});
    setInterval(() => { refreshFrames().catch(() => {}); }, 1000);
    const connection = document.getElementById('connection');
    if (!view.sessions.some((s) => s.live)) {
      const ended = state.sessions.map((info) => info.ended).filter(Boolean);
      connection.textContent = ended.length ? `recorded session (ended: ${ended.join(', ')})` : 'recorded session';
      // A study over recorded holds goes hold by hold: follow it until done.
      if (state.study) {
        const poll = setInterval(async () => {
          const now = await getJson('/api/state').catch(() => null);
          if (!now) return;
          renderStudy(now.study);
          if (now.study && !now.study.updating && now.study.holds_seen >= now.holds.filter((h) => h.values).length) clearInterval(poll);
        }, 1000);
      }
      return;
    }
    setInterval(() => { refreshXy().catch(() => {}); }, 1000);
    const events = new EventSource(url('/api/events'));
    const lostText = 'Connection to acq lost: the plots stop here until it is back (the page retries by itself). Whatever acq record wrote before is in the session.';
    events.onopen = () => {
      connection.textContent = 'live';
      connection.className = '';
      // Back: the banner this page raised for the loss goes.
      const b = document.getElementById('banner');
      if (b.textContent.startsWith('Connection to acq lost')) b.hidden = true;
    };
    events.onerror = () => {
      // After the recording ended, the stream closing is no fault.
      if (!view.sessions.some((s) => s.live)) return;
      connection.textContent = 'disconnected: the recording ended or acq stopped serving (retrying)';
      connection.className = 'down';
      banner(lostText);
    };
    events.addEventListener('update', (event) => {
      const update = JSON.parse(event.data);
      view.updates += 1;
      update.tails.forEach((tail, i) => { if (view.sessions[i]) applyTails(view.sessions[i], tail); });
      applyState(update.state);
    });
    events.addEventListener('lost', (event) => {
      const missed = Number(event.data);
      view.lost += missed;
      banner(`This page missed ${view.lost} update(s): the browser did not keep up. The recording is not affected; the plotted window was read again.`);
      for (const s of view.sessions) if (s.live && s.follow) followWindow(s);
    });
  }

  window.addEventListener('DOMContentLoaded', () => {
    start().catch((e) => {
      view.errors.push(String(e));
      banner(`acq view could not start: ${e.message}`);
    });
  });
})();
