// The console page: one live stream from `piezoloop ui` (server-sent events:
// hello, frame, status) and the JSON API for what the user changes. The
// page's data are keyed by signal name (state.signals, frame.series): a
// signal of another axis is another name.
'use strict';

const token = new URLSearchParams(location.search).get('token') || '';
const state = {
  viewer: null,        // this page's id on the server
  controls: false,     // holds the control seat
  signals: [],         // [{name, unit}]
  paused: false,
  frame: null,         // the frame on screen: {seq, t0_s, span_s, columns, series: {name: Float32Array}}
  framesDrawn: 0,
  drawTimes: [],       // ms of the last frames drawn (frame rate)
  frameLog: [],        // [wall ms, end of the frame's window in device s] of the last frames received
  latencies: [],       // ms, newest sample's arrival at the host to its frame on screen
  status: null,
  measuring: false,    // a frequency response runs (the board's other commands wait)
  frf: null,           // the measurement's progress: {state, phase, fraction, request, error}
  frfResult: null,     // the last result, as the server sent it
  jobs: {},            // step, loops: {progress, seen: [progress...], result}
  cursors: {},         // scope cursors A, B: the server's nearest sample {t_s, values}
  nextCursor: 'A',
  psdCursors: {},      // spectrum cursors A, B: {bin, f_Hz, density}
  nextPsdCursor: 'A',
  axes: ['x'],         // the board's axes
  axis: '',            // a board of axes: the axis the forms, the wave and the measurements act on
};
window.piezoloop = state;  // for the browser tests and the curious

function $(id) { return document.getElementById(id); }

// A board of axes: the selected axis, in a query or a request's body.
function multiAxis() { return state.axes.length > 1; }
function axisQuery() { return multiAxis() ? `?axis=${state.axis}` : ''; }
function withAxis(body) { return multiAxis() ? Object.assign({}, body, { axis: state.axis }) : body; }

async function api(method, path, body) {
  const headers = { 'X-Piezoloop-Token': token };
  if (state.viewer) headers['X-Piezoloop-Viewer'] = state.viewer;
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  const res = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const type = res.headers.get('Content-Type') || '';
  const data = type.startsWith('application/json') ? await res.json() : await res.text();
  return { ok: res.ok, status: res.status, data };
}

// ---- scope -------------------------------------------------------------------

let plot = null;

function decodeFloat32(b64) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
  return new Float32Array(bytes.buffer);
}

function makePlot() {
  const colours = { r: '#888', y: '#06c', e: '#c60', u: '#2a2', u_ff: '#a2a', u_fb: '#2aa', u_rc: '#aa2', d: '#a22' };
  const series = [{ label: 't (s)' }];
  // Another axis's signal (y.u): the signal's colour, dashed.
  const dashes = { y: [6, 3], z: [2, 2] };
  for (const s of state.signals) {
    const [axis, signal] = s.name.includes('.') ? s.name.split('.') : ['x', s.name];
    series.push({
      label: `${s.name} (${s.unit})`,
      scale: s.unit === 'V' ? 'V' : 'um',
      stroke: colours[signal] || '#000',
      dash: dashes[axis],
      width: 1,
      spanGaps: true,  // columns without samples (zoomed in past the loop rate): join their neighbours
      points: { show: false },
    });
  }
  const width = Math.max(400, $('plot').clientWidth || 800);
  plot = new uPlot({
    width,
    height: 380,
    series,
    scales: { x: { time: false } },
    axes: [
      { label: 't (s)' },
      { scale: 'um', label: 'µm' },
      { scale: 'V', label: 'V', side: 1, grid: { show: false } },
    ],
    cursor: { drag: { x: false, y: false } },
    hooks: { draw: [(u) => drawCursorLines(u, state.cursors, (c) => c.t_s)] },
  }, [[], ...state.signals.map(() => [])], $('plot'));
  plot.over.addEventListener('click', (ev) => {
    if (!$('cursors').checked) return;
    const t = plot.posToVal(ev.offsetX, 'x');
    setCursor(state.nextCursor, t);
    state.nextCursor = state.nextCursor === 'A' ? 'B' : 'A';
  });
  // The server decimates to one min/max pair per pixel column.
  sendScope({ columns: Math.round(plot.bbox.width / devicePixelRatio) || width });
}

// The recorded signals (at the start, and when the channels change): the
// trigger's and the spectrum's choices, the channel picks, a new plot.
function applySignals(signals, scope) {
  state.signals = signals;
  const options = () => signals.map((s) => new Option(`${s.name} (${s.unit})`, s.name));
  $('trigger-signal').replaceChildren(...options());
  $('trigger-signal').value = scope.trigger_signal;
  const psd = $('psd-signal').value;
  $('psd-signal').replaceChildren(...options());
  $('psd-signal').value = signals.some((s) => s.name === psd) ? psd : signals.some((s) => s.name === 'y') ? 'y' : signals[0].name;
  const recorded = new Set(signals.map((s) => s.name));
  $('channel-picks').replaceChildren(...state.channelChoices.map((name) => {
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.value = name;
    box.checked = recorded.has(name);
    label.append(box, ` ${name} `);
    return label;
  }));
  if (plot) {
    plot.destroy();
    plot = null;
  }
  makePlot();
}

async function recordChannels() {
  const names = [...document.querySelectorAll('#channel-picks input:checked')].map((c) => c.value);
  $('channels-error').textContent = '';
  const r = await api('POST', '/api/scope/channels', { channels: names });
  if (!r.ok) $('channels-error').textContent = `refused: ${r.data.error}`;
}

function drawFrame(f) {
  // A frame of the channels before a change (the signals event came first).
  if (state.signals.some((s) => f.series[s.name] === undefined)) {
    api('POST', '/api/scope/drawn', { seq: f.seq });  // taken, not drawn: keep the stream going
    return;
  }
  const started = performance.now();
  const cols = f.columns;
  const x = new Float64Array(2 * cols);
  const w = f.span_s / cols;
  for (let c = 0; c < cols; ++c) x[2 * c] = x[2 * c + 1] = f.t0_s + (c + 0.5) * w;
  const series = {};
  const data = [x];
  for (const s of state.signals) {
    const v = decodeFloat32(f.series[s.name]);
    series[s.name] = v;
    // NaN (a column without samples) is a gap for uPlot.
    data.push(Array.from(v, (a) => (Number.isNaN(a) ? null : a)));
  }
  state.frame = { seq: f.seq, t0_s: f.t0_s, span_s: f.span_s, columns: cols, samples: f.samples, mode: f.mode, trigger_t_s: f.trigger_t_s, series };
  plot.setScale('x', { min: f.t0_s, max: f.t0_s + f.span_s });
  plot.setData(data, false);
  plot.setScale('x', { min: f.t0_s, max: f.t0_s + f.span_s });
  requestAnimationFrame(() => {
    const now = Date.now();
    state.framesDrawn += 1;
    state.drawTimes.push(now);
    state.latencies.push(now - f.newest_arrival_ms);
    if (state.drawTimes.length > 200) state.drawTimes.shift();
    if (state.latencies.length > 200) state.latencies.shift();
  });
  // The server sends the next frames once this one is drawn (uPlot draws
  // the new data in a microtask of setData).
  queueMicrotask(() => queueMicrotask(() => api('POST', '/api/scope/drawn', { seq: f.seq })));
  state.drawMs = (state.drawMs || 0) * 0.9 + (performance.now() - started) * 0.1;
  $('scope-state').textContent = `${f.mode}${f.waiting ? ' (waiting for trigger)' : ''}, ${f.samples} samples`;
}

function rates() {
  const t = state.drawTimes;
  const recent = t.filter((x) => x > Date.now() - 2000);
  const fps = recent.length / 2;
  const lat = state.latencies.slice(-50).sort((a, b) => a - b);
  const median = lat.length ? lat[Math.floor(lat.length / 2)] : NaN;
  state.fps = fps;
  // How fast the board's record grows, in device seconds per wall second (an
  // emulated board runs slower than real time on a loaded machine).
  const log = state.frameLog.filter((x) => x[0] > Date.now() - 2000);
  state.deviceSpeed = log.length > 1 ? (log[log.length - 1][1] - log[0][1]) / ((log[log.length - 1][0] - log[0][0]) / 1000) : NaN;
  state.latencyMedianMs = median;
  $('rates').textContent = `${fps.toFixed(0)} frames/s, host-to-screen latency ${Number.isNaN(median) ? '–' : median + ' ms'} (median); ` +
    `the record grows ${Number.isNaN(state.deviceSpeed) ? '–' : state.deviceSpeed.toFixed(2)} s per second`;
}
setInterval(rates, 500);

async function sendScope(settings) {
  if (!state.viewer) return;
  const r = await api('POST', '/api/scope', settings);
  $('scope-error').textContent = r.ok ? '' : r.data.error;
}

function scopeControls() {
  $('mode').onchange = () => sendScope({ mode: $('mode').value });
  $('span').onchange = () => sendScope({ span_s: Number($('span').value) });
  $('trigger-signal').onchange = () => sendScope({ trigger_signal: $('trigger-signal').value });
  $('trigger-level').onchange = () => sendScope({ trigger_level: Number($('trigger-level').value) });
  $('edge').onchange = () => sendScope({ edge: $('edge').value });
  $('cursors').onchange = () => {
    if ($('cursors').checked) return;
    state.cursors = {};
    state.nextCursor = 'A';
    $('cursor-readout').hidden = true;
    plot.redraw(false);
  };
  $('channels-apply').onclick = recordChannels;
  $('pause').onclick = () => {
    state.paused = !state.paused;
    $('pause').textContent = state.paused ? 'Run' : 'Pause';
  };
  $('csv').onclick = async () => {
    const f = state.frame;
    if (!f) return;
    const res = await fetch(`/api/scope/csv?t0_s=${f.t0_s}&span_s=${f.span_s}`, { headers: { 'X-Piezoloop-Token': token } });
    const blob = await res.blob();
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = `scope_${f.seq}.csv`;
    a.click();
    URL.revokeObjectURL(a.href);
  };
}

// ---- cursors: two vertical lines, on the scope and on the spectrum ------------

// A number to n significant digits (the readouts' format).
function sig(x, n) { return x === null || x === undefined ? '–' : String(Number(x.toPrecision(n))); }

function drawCursorLines(u, cursors, at) {
  const g = u.ctx;
  g.save();
  g.lineWidth = 1;
  g.setLineDash([4, 3]);
  for (const [name, colour] of [['A', '#d0a'], ['B', '#0ad']]) {
    const c = cursors[name];
    if (!c || at(c) === null) continue;
    const x = u.valToPos(at(c), 'x', true);
    if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) continue;
    g.strokeStyle = colour;
    g.beginPath();
    g.moveTo(x, u.bbox.top);
    g.lineTo(x, u.bbox.top + u.bbox.height);
    g.stroke();
    g.fillStyle = colour;
    g.fillText(name, x + 3, u.bbox.top + 12);
  }
  g.restore();
}

// A readout table: rows [label, [[key, value, text], ...]], each cell with
// its exact value in data-value.
function readout(el, head, rows) {
  el.hidden = false;
  el.replaceChildren();
  const h = el.insertRow();
  for (const t of head) { const th = document.createElement('th'); th.textContent = t; h.append(th); }
  for (const [label, cells] of rows) {
    const tr = el.insertRow();
    const th = document.createElement('th');
    th.textContent = label;
    tr.append(th);
    for (const [key, value, text] of cells) {
      const td = tr.insertCell();
      td.dataset.key = key;
      td.dataset.value = JSON.stringify(value === undefined ? null : value);
      td.textContent = text;
    }
  }
}

// Scope cursor `name` at time t: the server's nearest recorded sample.
async function setCursor(name, t) {
  const r = await api('GET', `/api/scope/cursors?t_s=${t}`);
  if (!r.ok) { $('scope-error').textContent = r.data.error; return; }
  state.cursors[name] = r.data.cursors[0];
  showCursors();
  plot.redraw(false);
}

function showCursors() {
  const { A, B } = state.cursors;
  const names = state.signals.map((s) => s.name);
  const head = ['', 't (s)', ...state.signals.map((s) => `${s.name} (${s.unit})`)];
  const row = (c) => [['t_s', c ? c.t_s : null, c && c.t_s !== null ? sig(c.t_s, 9) : '–'],
    ...names.map((n) => { const v = c && c.values ? c.values[n] : null; return [n, v, sig(v, 7)]; })];
  const rows = [['A', row(A)], ['B', row(B)]];
  if (A && B && A.t_s !== null && B.t_s !== null) {
    const dt = B.t_s - A.t_s;
    rows.push(['B − A', [['dt_s', dt, `${sig(dt, 6)} s (${dt !== 0 ? sig(1 / Math.abs(dt), 6) : '–'} Hz)`],
      ...names.map((n) => { const a = A.values[n]; const b = B.values[n]; const d = a === null || b === null ? null : b - a; return [n, d, sig(d, 7)]; })]]);
  }
  readout($('cursor-readout'), head, rows);
}

// Spectrum cursor `name` at frequency f: the nearest bin of the spectrum shown.
function setPsdCursor(name, f) {
  const p = state.psd;
  if (!p) return;
  let k = 1;
  for (let i = 1; i < p.frequency_Hz.length; ++i) if (Math.abs(p.frequency_Hz[i] - f) < Math.abs(p.frequency_Hz[k] - f)) k = i;
  state.psdCursors[name] = { bin: k, f_Hz: p.frequency_Hz[k], density: p.density[k] };
  showPsdCursors();
  if (psdPlot) psdPlot.redraw(false);
}

function showPsdCursors() {
  const { A, B } = state.psdCursors;
  const unit = state.psd ? state.psd.unit : '';
  const row = (c) => [['f_Hz', c ? c.f_Hz : null, c ? sig(c.f_Hz, 6) : '–'], ['density', c ? c.density : null, c ? sig(c.density, 4) : '–']];
  const rows = [['A', row(A)], ['B', row(B)]];
  if (A && B) rows.push(['B − A', [['df_Hz', B.f_Hz - A.f_Hz, sig(B.f_Hz - A.f_Hz, 6)], ['ratio_dB', 10 * Math.log10(B.density / A.density), `${sig(10 * Math.log10(B.density / A.density), 4)} dB`]]]);
  readout($('psd-cursor-readout'), ['', 'f (Hz)', `PSD (${unit})`], rows);
}

// ---- spectrum: Welch PSD of a signal over the window on screen ----------------

let psdPlot = null;

async function updatePsd() {
  const f = state.frame;
  if (!f) return;
  const signal = $('psd-signal').value;
  const q = `signal=${encodeURIComponent(signal)}&t0_s=${f.t0_s}&span_s=${f.span_s}&segment=${$('psd-segment').value}`;
  const r = await api('GET', `/api/scope/psd?${q}`);
  $('psd-error').textContent = r.ok ? '' : r.data.error;
  if (!r.ok) return;
  // Bin 0 (DC) has no place on a log frequency axis.
  const x = r.data.frequency_Hz.slice(1);
  const y = r.data.density.slice(1).map((d) => (d > 0 ? d : null));
  state.psd = r.data;
  $('psd-state').textContent = `${r.data.segments} segments of ${r.data.segment} samples, ${(r.data.frequency_Hz[1]).toPrecision(3)} Hz apart`;
  if (psdPlot) psdPlot.destroy();
  psdPlot = new uPlot({
    width: Math.max(400, $('psd-plot').clientWidth || 800),
    height: 260,
    series: [{ label: 'f (Hz)' }, { label: `${signal} PSD (${r.data.unit})`, stroke: '#06c', width: 1, spanGaps: true }],
    scales: { x: { time: false, distr: 3 }, y: { distr: 3 } },
    axes: [{ label: 'Hz' }, { label: r.data.unit, size: 70, values: (u, vals) => vals.map((v) => (v == null ? '' : v.toExponential(0))) }],
    hooks: { draw: [(u) => drawCursorLines(u, state.psdCursors, (c) => c.f_Hz)] },
  }, [x, y], $('psd-plot'));
  psdPlot.over.addEventListener('click', (ev) => {
    if (!$('psd-cursors').checked) return;
    setPsdCursor(state.nextPsdCursor, psdPlot.posToVal(ev.offsetX, 'x'));
    state.nextPsdCursor = state.nextPsdCursor === 'A' ? 'B' : 'A';
  });
  // A new spectrum: the cursors keep their frequencies, with its values.
  for (const n of ['A', 'B']) if (state.psdCursors[n]) setPsdCursor(n, state.psdCursors[n].f_Hz);
}

function psdControls() {
  $('psd-update').onclick = updatePsd;
  $('psd-cursors').onchange = () => {
    if ($('psd-cursors').checked) return;
    state.psdCursors = {};
    state.nextPsdCursor = 'A';
    $('psd-cursor-readout').hidden = true;
    if (psdPlot) psdPlot.redraw(false);
  };
  setInterval(() => { if ($('psd-follow').checked && !state.paused) updatePsd(); }, 500);
}

// ---- status ------------------------------------------------------------------

function fill(dl, entries) {
  dl.replaceChildren();
  for (const [k, v, cls] of entries) {
    const dt = document.createElement('dt');
    dt.textContent = k;
    const dd = document.createElement('dd');
    dd.textContent = v;
    if (cls) dd.className = cls;
    dl.append(dt, dd);
  }
}

function showStatus(st) {
  state.status = st;
  const s = st.status || {};
  $('device').textContent = `${st.device} — ${st.hello ? st.hello.board : ''}`;
  fill($('status'), [
    ['armed', s.armed ? 'armed' : 'disarmed', s.armed ? 'armed' : ''],
    ['trip', s.tripped ? `${s.trip_reason}: ${st.trip_meaning}` : 'none', s.tripped ? 'tripped' : ''],
    ['wave', s.wave_running ? 'running' : 'stopped'],
    ['stream', s.streaming ? 'running' : 'stopped'],
    ['stored set', st.storage_text || ''],
    // The board's float32 values to 0.1 nm and 0.1 mV, not their 17 digits.
    ['setpoint r', s.r_um === undefined ? '' : `${s.r_um.toFixed(4)} µm`],
    ['reading y', s.y_um === undefined ? '' : `${s.y_um.toFixed(4)} µm`],
    ['output u', s.u_V === undefined ? '' : `${s.u_V.toFixed(4)} V`],
  ].concat((st.axes || []).map((a) => [`axis ${a.axis}`,
    `${a.armed ? 'armed' : 'disarmed'}, ${a.tripped ? `tripped (${a.trip_reason})` : 'not tripped'}, wave ` +
    `${a.wave_running ? 'running' : 'stopped'}, r ${a.r_um.toFixed(4)} µm, y ${a.y_um.toFixed(4)} µm, ` +
    `u ${a.u_V.toFixed(4)} V`, a.tripped ? 'tripped' : (a.armed ? 'armed' : '')]))
    .concat(st.link_error ? [['link', st.link_error, 'tripped']] : []));
  const faults = $('faults');
  faults.replaceChildren();
  for (const f of st.fault_meanings || []) {
    const li = document.createElement('li');
    li.textContent = `${f.fault}: ${f.meaning}`;
    faults.append(li);
  }
  if (!faults.children.length) faults.textContent = 'none';
  fill($('limits'), Object.entries(st.limits || {}).map(([k, v]) => [k, String(v)]));
  const hl = st.host_link || {};
  const bl = s.link || {};
  fill($('link'), [
    ['frames ok (board)', bl.frames_ok], ['bad CRC / COBS (board)', `${bl.bad_crc} / ${bl.bad_cobs}`],
    ['requests (host)', hl.requests], ['log frames (host)', hl.log_frames],
    ['lost blocks / tick gaps', `${hl.lost_blocks} / ${hl.tick_gaps}`], ['recorder overruns', hl.recorder_overruns],
  ].map(([k, v]) => [k, String(v)]));
  state.measuring = !!st.measuring || anyRunning();
  if (st.control) showControl(st.control);
  else updateButtons();
}

function showControl(c) {
  state.controls = c.controls;
  state.control = c;
  const req = c.request || null;
  // The deadline by this page's clock (the server sends the seconds left).
  state.seatDeadline = req ? Date.now() + 1000 * req.seconds_left : null;
  $('seat-request').hidden = !(req && req.to_me);
  $('seat').textContent = c.controls ? 'you control the board' : req && req.from_me ? 'asking the controlling page for control…' :
    (c.seat_taken ? 'watching (another page controls)' : 'watching');
  if (c.refused) $('action-error').textContent = 'the controlling page kept control: this page watches';
  else if (req && req.from_me) $('action-error').textContent = '';
  seatCountdown();
  $('seat').className = c.controls ? 'seat controls' : 'seat';
  $('claim').hidden = c.controls;
  $('release').hidden = !c.controls;
  updateButtons();
}

// Commands need the seat; while a measurement runs only the stops are offered.
function updateButtons() {
  const c = state.controls;
  for (const b of document.querySelectorAll('.ctl')) b.disabled = !c || (state.measuring && b.id !== 'stop');
  $('frf-stop').disabled = !c || !state.measuring;
  // Each measurement's own stop, while it runs (on the board, or simulated).
  for (const b of document.querySelectorAll('.stop-job')) {
    const j = state.jobs[b.id.replace(/-stop$/, '')];
    b.disabled = !c || !(j && j.progress && j.progress.state === 'running');
  }
  for (const b of document.querySelectorAll('#params button')) b.disabled = !c || state.measuring;
}

async function act(path) {
  const r = await api('POST', path);
  $('action-error').textContent = r.ok ? '' : r.data.error;
  if (r.ok) showStatus(Object.assign({}, r.data, { control: { controls: true, seat_taken: true } }));
}

// ---- parameter forms, generated from the schema ------------------------------

function fieldRow(name, schema, value, path) {
  const row = document.createElement('div');
  row.className = 'field' + (schema.limitCritical ? ' critical' : '');
  row.dataset.path = path;
  const label = document.createElement('label');
  label.textContent = name;
  label.title = schema.description || '';
  let input;
  if (schema.enum) {
    input = document.createElement('select');
    for (const e of schema.enum) input.append(new Option(e, e));
    input.value = value;
  } else if (schema.type === 'boolean') {
    input = document.createElement('input');
    input.type = 'checkbox';
    input.checked = !!value;
  } else if (schema.type === 'array' || schema.type === 'object') {
    input = document.createElement('textarea');
    input.rows = schema.type === 'array' ? 3 : 2;
    input.value = JSON.stringify(value);
  } else {
    input = document.createElement('input');
    input.type = 'text';
    input.value = String(value);
  }
  input.name = path;
  input.dataset.kind = schema.enum ? 'enum' : schema.type;
  const unit = document.createElement('span');
  unit.className = 'unit';
  const range = [];
  if (schema.minimum !== undefined && Math.abs(schema.minimum) < 1e30) range.push(`≥ ${schema.minimum}`);
  if (schema.exclusiveMinimum !== undefined) range.push(`> ${schema.exclusiveMinimum}`);
  if (schema.maximum !== undefined && Math.abs(schema.maximum) < 1e30) range.push(`≤ ${schema.maximum}`);
  unit.textContent = [schema.unit && schema.unit !== '1' ? schema.unit : '', range.join(', ')].filter(Boolean).join('  ');
  const err = document.createElement('span');
  err.className = 'error';
  err.dataset.errorFor = path;
  row.append(label, input, unit, err);
  return row;
}

function readField(input) {
  switch (input.dataset.kind) {
    case 'boolean': return input.checked;
    case 'enum': return input.value;
    case 'array':
    case 'object': return JSON.parse(input.value);
    default: return Number(input.value);
  }
}

// Nested objects (feedback.pid, ...) as fieldsets of their own fields.
function addFields(container, schema, values, prefix) {
  for (const [name, sub] of Object.entries(schema.properties || {})) {
    const path = prefix ? `${prefix}.${name}` : name;
    if (sub.type === 'object' && sub.properties) {
      const fs = document.createElement('fieldset');
      fs.dataset.path = path;
      const lg = document.createElement('legend');
      lg.textContent = name;
      fs.append(lg);
      addFields(fs, sub, (values || {})[name] || {}, path);
      container.append(fs);
    } else {
      container.append(fieldRow(name, sub, (values || {})[name], path));
    }
  }
}

function collect(form) {
  const out = {};
  for (const input of form.querySelectorAll('[name]')) {
    const keys = input.name.split('.');
    let o = out;
    for (const k of keys.slice(0, -1)) o = o[k] = o[k] || {};
    o[keys[keys.length - 1]] = readField(input);
  }
  return out;
}

function renderGroup(group, schema, values) {
  const form = document.createElement('form');
  form.className = 'group';
  form.id = `group-${group}`;
  const fs = document.createElement('fieldset');
  const lg = document.createElement('legend');
  lg.textContent = `${group} — ${schema.description || ''}`;
  fs.append(lg);
  addFields(fs, schema, values, '');
  const send = document.createElement('button');
  send.type = 'submit';
  send.textContent = `Send ${group}`;
  send.disabled = !state.controls;
  const err = document.createElement('span');
  err.className = 'error';
  err.dataset.errorFor = '';
  fs.append(send, err);
  form.append(fs);
  form.onsubmit = async (ev) => {
    ev.preventDefault();
    let body;
    try {
      body = collect(form);
    } catch (e) {
      err.textContent = `not JSON: ${e.message}`;
      return;
    }
    const r = await api('POST', `/api/params/${group}${axisQuery()}`, body);
    if (!r.ok) {
      err.textContent = r.data.error || r.data;
      return;
    }
    // The form as the board now holds it, the refusal at the field it names.
    const fresh = renderGroup(group, schema, r.data.values);
    form.replaceWith(fresh);
    if (!r.data.ok) showFieldError(fresh, r.data.error);
  };
  return form;
}

function showFieldError(form, e) {
  const text = `${e.refused_by === 'board' ? 'the board refused' : 'refused'}: ${e.message}`;
  const candidates = [...form.querySelectorAll('[data-error-for]')];
  const field = e.field || '';
  const hit = candidates.find((c) => c.dataset.errorFor === field) ||
    candidates.find((c) => c.dataset.errorFor && c.dataset.errorFor.endsWith(`.${field}`)) ||
    candidates.find((c) => c.dataset.errorFor === '');
  hit.textContent = text;
}

async function loadParams() {
  const r = await api('GET', `/api/params${axisQuery()}`);
  const box = $('params');
  box.replaceChildren();
  if (!r.ok) {
    box.textContent = r.data.error || String(r.data);
    return;
  }
  for (const group of r.data.groups) box.append(renderGroup(group, r.data.schema[group], r.data.values[group]));
}

// ---- wave ----------------------------------------------------------------------

function waveForm() {
  $('wave').onsubmit = async (ev) => {
    ev.preventDefault();
    const f = ev.target;
    const body = {
      trajectory: f.trajectory.value,
      frequency_Hz: Number(f.frequency_Hz.value),
      amplitude_um: Number(f.amplitude_um.value),
      offset: f.offset.value,
      cycles: Number(f.cycles.value),
      arm: f.arm.checked,
    };
    const r = await api('POST', '/api/wave', withAxis(body));
    $('wave-error').textContent = r.ok ? '' : r.data.error;
    if (r.ok) loadParams();
  };
}

// ---- frequency response: the board's `measure frf`, as a Bode plot ------------

let bodeMag = null;
let bodePhase = null;

function frfErrors() { return [...document.querySelectorAll('#frf [data-error-for]')]; }

function showFrfError(field, message) {
  const spans = frfErrors();
  const at = spans.find((e) => e.dataset.errorFor === field) || spans.find((e) => e.dataset.errorFor === '');
  at.textContent = `refused: ${message}`;
}

function frfForm() {
  const f = $('frf');
  f.onsubmit = async (ev) => {
    ev.preventDefault();
    for (const e of frfErrors()) e.textContent = '';
    const body = {
      from_Hz: Number(f.from_Hz.value),
      to_Hz: Number(f.to_Hz.value),
      amplitude_V: Number(f.amplitude_V.value),
      bias_V: Number(f.bias_V.value),
      periods: Number(f.periods.value),
      transient_periods: Number(f.transient_periods.value),
      signal: f.signal.value,
      mode: f.mode.value,
      restart_stage: f.restart_stage.checked,
      fit_order: f.fit_order.value.trim(),
    };
    const r = await api('POST', '/api/frf/start', withAxis(body));
    if (!r.ok) showFrfError(r.data.field || '', r.data.error || String(r.data));
  };
  $('frf-stop').onclick = () => api('POST', '/api/frf/stop');
  $('frf-csv').onclick = async () => {
    const res = await fetch('/api/frf/csv', { headers: { 'X-Piezoloop-Token': token } });
    const a = document.createElement('a');
    a.href = URL.createObjectURL(await res.blob());
    a.download = 'frf.csv';
    a.click();
    URL.revokeObjectURL(a.href);
  };
}

function showFrfProgress(p) {
  const was = state.frf;
  state.frf = p;
  state.frfSeen = (state.frfSeen || []).concat([{ state: p.state, phase: p.phase, fraction: p.fraction }]);
  state.measuring = anyRunning();
  $('frf-progress').value = p.fraction || 0;
  const pct = `${Math.round(100 * (p.fraction || 0))} %`;
  const text = {
    idle: 'no measurement yet',
    running: `${p.phase} ${p.phase === 'recording' || p.phase === 'scanning' ? pct : ''}`,
    done: 'measured',
    failed: 'refused or failed',
    stopped: 'stopped',
  };
  $('frf-state').textContent = text[p.state] || p.state;
  if (p.state === 'running' && (!was || was.state !== 'running')) for (const e of frfErrors()) e.textContent = '';
  if (p.error) showFrfError(p.error.field || '', p.error.message);
  // The forms as the board holds them again (a page opened meanwhile has none).
  if (was && was.state === 'running' && p.state !== 'running') loadParams();
  updateButtons();
}

// The measured lines, ±1 standard deviation (the magnitude's std_dB; in
// phase the same relative deviation sigma_G/|G| in radians), and the fit.
function bodeSeries(res) {
  const degPerDb = (Math.log(10) / 20) * (180 / Math.PI);
  const sd = res.std_dB;
  const band = (y, scale) => [y.map((v, i) => (sd[i] == null ? null : v + scale * sd[i])),
    y.map((v, i) => (sd[i] == null ? null : v - scale * sd[i]))];
  const fit = res.fit && res.fit.magnitude_dB ? res.fit : null;
  const none = res.frequency_Hz.map(() => null);
  return {
    mag: [res.frequency_Hz, res.magnitude_dB, ...band(res.magnitude_dB, 1), fit ? fit.magnitude_dB : none],
    phase: [res.frequency_Hz, res.phase_deg, ...band(res.phase_deg, degPerDb), fit ? fit.phase_deg : none],
  };
}

function bodePlot(el, data, unit, fitLabel) {
  const series = [
    { label: 'f (Hz)' },
    { label: `measured (${unit})`, stroke: '#06c', width: 1.5, points: { show: true, size: 4 } },
    { label: '+1 std', stroke: 'rgba(0,102,204,0.35)', width: 1, points: { show: false } },
    { label: '−1 std', stroke: 'rgba(0,102,204,0.35)', width: 1, points: { show: false } },
    { label: fitLabel, stroke: '#c22', width: 1.5, dash: [6, 4], points: { show: false } },
  ];
  const f = data[0];
  return new uPlot({
    width: Math.max(400, el.clientWidth || 800),
    height: 220,
    series,
    bands: [{ series: [2, 3], fill: 'rgba(0,102,204,0.15)' }],
    // The measured band, not the decades around it.
    scales: { x: { time: false, distr: 3, range: () => [f[0], f[f.length - 1]] } },
    legend: { live: false },
    axes: [{ label: 'Hz' }, { label: unit, size: 60 }],
  }, data, el);
}

function showFrfResult(res) {
  state.frfResult = res;
  if (!res) return;
  const d = bodeSeries(res);
  const fit = res.fit || null;
  const fitLabel = fit && fit.magnitude_dB ? `fit ${fit.order}` : 'fit';
  if (bodeMag) bodeMag.destroy();
  if (bodePhase) bodePhase.destroy();
  bodeMag = bodePlot($('bode-mag'), d.mag, 'dB (µm/V)', fitLabel);
  bodePhase = bodePlot($('bode-phase'), d.phase, 'deg', fitLabel);
  const f = res.frequency_Hz;
  const fmt = (x, n = 3) => String(Number(Number(x).toPrecision(n)));  // 2000, not 2.00e+3
  let text = `${res.lines} lines, ${fmt(f[0])} – ${fmt(f[f.length - 1])} Hz, ${res.signal}, ${res.periods} periods ` +
    `(+ ${res.transient_periods} transient): ${fmt(res.device_s)} s on the board in ${fmt(res.wall_s)} s; ` +
    `clipped samples ${res.clipped_samples}; limiter trip ${res.limiter_trip}; log hash ${res.log_hash}`;
  if (fit && fit.magnitude_dB) {
    const res0 = (fit.resonances || []).map((r) => `${fmt(r.frequency_Hz)} Hz (ζ ${fmt(r.damping, 2)})`).join(', ');
    text += `. Fit ${fit.order}: weighted rms ${fmt(fit.weighted_rms)}${res0 ? `, resonances ${res0}` : ''}`;
  }
  $('frf-summary').textContent = text;
  const w = $('frf-warnings');
  w.replaceChildren(...(res.warnings || []).map((t) => { const li = document.createElement('li'); li.textContent = t; return li; }));
  if (fit && fit.error) showFrfError(fit.error.field, fit.error.message);
  $('frf-csv').disabled = false;
}

// What the Bode plots hold, as plain arrays (for the browser test).
state.bodeData = () => ({
  mag: bodeMag ? bodeMag.data.map((a) => Array.from(a)) : null,
  phase: bodePhase ? bodePhase.data.map((a) => Array.from(a)) : null,
});

// ---- steps and loops: the board's `measure step` and `measure loops` ----------

// A job that holds the board (commissioning the simulated stage does not).
function holdsBoard(j) {
  return j && j.progress && j.progress.state === 'running' && !(j.progress.request && j.progress.request.on === 'simulator');
}

function anyRunning() {
  return (state.frf && state.frf.state === 'running') || Object.values(state.jobs).some(holdsBoard);
}

// A number as the page shows it: 4 significant digits (scaled first: ms).
function fig(x, scale = 1) { return x === null || x === undefined ? '–' : String(Number((x * scale).toPrecision(4))); }

function jobErrors(name) { return [...document.querySelectorAll(`#${name} [data-error-for]`)]; }

function showJobError(name, field, message) {
  const spans = jobErrors(name);
  const at = spans.find((e) => e.dataset.errorFor === field) || spans.find((e) => e.dataset.errorFor === '');
  at.textContent = `refused: ${message}`;
}

// An empty field is not given (the command line's option left out).
function optionalNumber(input) { return input.value.trim() === '' ? null : Number(input.value); }

function download(path, file) {
  return async () => {
    const res = await fetch(path, { headers: { 'X-Piezoloop-Token': token } });
    const a = document.createElement('a');
    a.href = URL.createObjectURL(await res.blob());
    a.download = file;
    a.click();
    URL.revokeObjectURL(a.href);
  };
}

// The form of job `name`, started with the body `read` makes of it.
function jobForm(name, read) {
  const f = $(name);
  f.onsubmit = async (ev) => {
    ev.preventDefault();
    for (const e of jobErrors(name)) e.textContent = '';
    let body;
    try {
      body = read(f);
    } catch (e) {
      showJobError(name, e.field || '', e.message);
      return;
    }
    // A scan moves x and y; a stage's axes commissioned together name them.
    const r = await api('POST', `/api/${name}/start`, name === 'scan' || body.axes ? body : withAxis(body));
    if (!r.ok) showJobError(name, r.data.field || '', r.data.error || String(r.data));
  };
  $(`${name}-stop`).onclick = () => api('POST', `/api/${name}/stop`);
  if ($(`${name}-csv`)) $(`${name}-csv`).onclick = download(`/api/${name}/csv`, `${name}.csv`);
}

function showJobProgress(name, p) {
  const job = state.jobs[name] = state.jobs[name] || { seen: [] };
  const was = job.progress;
  job.progress = p;
  job.seen.push({ state: p.state, phase: p.phase, fraction: p.fraction });
  state.measuring = anyRunning();
  $(`${name}-progress`).value = p.fraction || 0;
  const pct = `${Math.round(100 * (p.fraction || 0))} %`;
  const text = { idle: $(`${name}-state`).textContent, running: `${p.phase} ${p.phase === 'recording' || p.phase === 'scanning' ? pct : ''}`,
    done: 'measured', failed: 'refused or failed', stopped: 'stopped' };
  $(`${name}-state`).textContent = text[p.state] || p.state;
  if (p.state === 'running' && (!was || was.state !== 'running')) for (const e of jobErrors(name)) e.textContent = '';
  if (p.error) showJobError(name, p.error.field || '', p.error.message);
  if (was && was.state === 'running' && p.state !== 'running') loadParams();
  updateButtons();
}

function warnings(el, list) {
  el.replaceChildren(...(list || []).map((t) => { const li = document.createElement('li'); li.textContent = t; return li; }));
}

// Figures as [label, key, scale, unit]: the text is fig(value, scale), the
// exact value in data-value.
function figures(dl, res, rows) {
  dl.replaceChildren();
  for (const [label, key, scale, unit] of rows) {
    const dt = document.createElement('dt');
    dt.textContent = label;
    const dd = document.createElement('dd');
    const v = res[key];
    dd.dataset.key = key;
    dd.dataset.value = JSON.stringify(v);
    dd.textContent = typeof v === 'number' || v === null ? `${fig(v, scale)}${unit ? ` ${unit}` : ''}` : String(v);
    dl.append(dt, dd);
  }
}

let stepPlot = null;

function showStepResult(res) {
  state.jobs.step = state.jobs.step || { seen: [] };
  state.jobs.step.result = res;
  if (!res) return;
  figures($('step-figures'), res, [
    ['initial', 'initial_um', 1, 'µm'], ['final', 'final_value_um', 1, 'µm'], ['overshoot', 'overshoot_pct', 1, '%'],
    ['peak', 'peak_um', 1, 'µm'], ['peak time', 'peak_time_s', 1e3, 'ms'], ['rise 10–90 %', 'rise_time_s', 1e3, 'ms'],
    ['settling 2 %', 'settling_time_s', 1e3, 'ms'], ['settled', 'settled'], ['clipped samples', 'clipped_samples'],
    ['limiter trip', 'limiter_trip'], ['log hash', 'log_hash'], ['wall', 'wall_s', 1, 's'],
  ]);
  warnings($('step-warnings'), res.warnings);
  if (stepPlot) stepPlot.destroy();
  stepPlot = new uPlot({
    width: Math.max(400, $('step-plot').clientWidth || 800),
    height: 280,
    series: [{ label: 't (s)' },
      { label: 'r (µm)', stroke: '#888', width: 1, scale: 'um' },
      { label: 'y (µm)', stroke: '#06c', width: 1.5, scale: 'um' },
      { label: 'u (V)', stroke: '#2a2', width: 1, scale: 'V' }],
    scales: { x: { time: false } },
    axes: [{ label: 't (s), 0 at the step' }, { scale: 'um', label: 'µm' }, { scale: 'V', label: 'V', side: 1, grid: { show: false } }],
  }, [res.time_s, res.reference_um, res.response_um, res.command_V], $('step-plot'));
  $('step-csv').disabled = false;
}

// The loops as y against u, one colour per amplitude, on a canvas (x is not
// monotonic: a line plot of a time series does not fit).
function drawLoops(canvas, loops) {
  const g = canvas.getContext('2d');
  const w = canvas.width;
  const h = canvas.height;
  const m = { l: 60, r: 12, t: 12, b: 40 };
  g.clearRect(0, 0, w, h);
  const all = (k) => loops.flatMap((l) => l[k]);
  const range = (v) => { const lo = Math.min(...v); const hi = Math.max(...v); return hi > lo ? [lo, hi] : [lo - 1, hi + 1]; };
  const [u0, u1] = range(all('u'));
  const [y0, y1] = range(all('y'));
  const X = (u) => m.l + (u - u0) / (u1 - u0) * (w - m.l - m.r);
  const Y = (y) => h - m.b - (y - y0) / (y1 - y0) * (h - m.t - m.b);
  g.strokeStyle = '#ccd';
  g.fillStyle = '#556';
  g.font = '11px sans-serif';
  for (let i = 0; i <= 5; ++i) {
    const u = u0 + (u1 - u0) * i / 5;
    const y = y0 + (y1 - y0) * i / 5;
    g.beginPath(); g.moveTo(X(u), m.t); g.lineTo(X(u), h - m.b); g.moveTo(m.l, Y(y)); g.lineTo(w - m.r, Y(y)); g.stroke();
    g.fillText(fig(u), X(u) - 10, h - m.b + 14);
    g.fillText(fig(y), 4, Y(y) + 4);
  }
  g.fillText('u (V)', w / 2, h - 6);
  g.fillText('y (µm)', m.l + 4, m.t + 10);
  const colours = ['#06c', '#c60', '#2a2', '#a2a', '#2aa', '#a22'];
  loops.forEach((l, k) => {
    g.strokeStyle = colours[k % colours.length];
    g.beginPath();
    l.u.forEach((u, i) => (i ? g.lineTo(X(u), Y(l.y[i])) : g.moveTo(X(u), Y(l.y[i]))));
    g.stroke();
    g.fillStyle = g.strokeStyle;
    g.fillText(`${fig(l.amplitude_V)} V`, w - m.r - 50, m.t + 14 * (k + 1));
  });
}

function showLoopsResult(res) {
  state.jobs.loops = state.jobs.loops || { seen: [] };
  state.jobs.loops.result = res;
  if (!res) return;
  const t = $('loops-figures');
  t.replaceChildren();
  const head = t.insertRow();
  for (const h of ['amplitude (V)', 'hysteresis (%)', 'widest gap (%)', 'y min (µm)', 'y max (µm)']) {
    const th = document.createElement('th'); th.textContent = h; head.append(th);
  }
  for (const l of res.loops) {
    const row = t.insertRow();
    for (const k of ['amplitude_V', 'hysteresis_pct', 'max_width_pct', 'y_min_um', 'y_max_um']) {
      const td = row.insertCell();
      td.dataset.key = k;
      td.dataset.value = JSON.stringify(l[k]);
      td.textContent = fig(l[k]);
    }
  }
  warnings($('loops-warnings'), res.warnings);
  // Each amplitude's samples, in the order recorded.
  const loops = res.loops.map((l) => ({ amplitude_V: l.amplitude_V, u: [], y: [] }));
  res.amplitude_V.forEach((a, i) => {
    const l = loops.find((x) => x.amplitude_V === a);
    l.u.push(res.u_V[i]);
    l.y.push(res.y_um[i]);
  });
  state.jobs.loops.plotted = loops;
  drawLoops($('loops-plot'), loops);
  $('loops-csv').disabled = false;
}

// What the step plot holds (for the browser test).
state.stepData = () => (stepPlot ? stepPlot.data.map((a) => Array.from(a)) : null);

function stepLoopsForms() {
  const step = $('step');
  const mode = () => { step.className = `measure ${step.mode.value}`; };
  step.mode.onchange = mode;
  mode();
  jobForm('step', (f) => {
    const open = f.mode.value === 'open';
    const body = { mode: f.mode.value, duration_s: Number(f.duration_s.value), restart_stage: f.restart_stage.checked };
    if (open) Object.assign(body, { step_V: optionalNumber(f.step_V), bias_V: optionalNumber(f.bias_V) });
    else Object.assign(body, { step_um: optionalNumber(f.step_um), from_um: optionalNumber(f.from_um) });
    return body;
  });
  jobForm('loops', (f) => {
    const amplitudes = f.amplitudes_V.value.split(/[,\s]+/).filter((x) => x !== '').map(Number);
    return {
      amplitudes_V: amplitudes,
      bias_V: optionalNumber(f.bias_V),
      frequency_Hz: Number(f.frequency_Hz.value),
      cycles: Number(f.cycles.value),
      shape: f.shape.value,
      restart_stage: f.restart_stage.checked,
    };
  });
}

// ---- scans: `piezoloop --device ADDR scan` from the page ----------------------

// A colour for t in [0, 1]: viridis-like (heights) or blue-white-red
// (errors), by a few anchors linearly between.
const colourMaps = {
  viridis: [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]],
  coolwarm: [[59, 76, 192], [221, 221, 221], [180, 4, 38]],
};
function colour(map, t) {
  const a = colourMaps[map] || colourMaps.viridis;
  const x = Math.min(1, Math.max(0, t)) * (a.length - 1);
  const i = Math.min(a.length - 2, Math.floor(x));
  const f = x - i;
  return a[i].map((c, k) => Math.round(c + f * (a[i + 1][k] - c)));
}

// An image (ny x nx values, row j at y0 + j dy; null where no pixel fell:
// grey) drawn with y up, scaled to the canvas; errors symmetric about 0.
function drawImage(canvas, im) {
  const { nx, ny, values } = im;
  canvas.width = nx;
  canvas.height = ny;
  const finite = values.filter((v) => v !== null);
  let lo = Math.min(...finite), hi = Math.max(...finite);
  if (im.cmap === 'coolwarm') { hi = Math.max(Math.abs(lo), Math.abs(hi)); lo = -hi; }
  const span = hi > lo ? hi - lo : 1;
  const ctx = canvas.getContext('2d');
  const px = ctx.createImageData(nx, ny);
  for (let j = 0; j < ny; j++) {
    for (let i = 0; i < nx; i++) {
      const v = values[j * nx + i];
      const [r, g, b] = v === null ? [160, 160, 160] : colour(im.cmap, (v - lo) / span);
      const at = 4 * ((ny - 1 - j) * nx + i);
      px.data.set([r, g, b, 255], at);
    }
  }
  ctx.putImageData(px, 0, 0);
  return { lo, hi };
}

function showScanResult(res) {
  state.jobs.scan = state.jobs.scan || { seen: [] };
  state.jobs.scan.result = res;
  if (!res) return;
  const t = res.tracking || {};
  const last = res.tracking_last_frame || {};
  figures($('scan-figures'), Object.assign({}, res, {
    rms_x_percent: t.rms_x_percent, max_x_percent: t.max_x_percent,
    rms_y_percent: t.rms_y_percent, max_y_percent: t.max_y_percent,
    last_rms_x_percent: last.rms_x_percent, last_rms_y_percent: last.rms_y_percent,
    pitch_commanded_um: res.pitch ? res.pitch.commanded_um : null,
    pitch_measured_um: res.pitch ? res.pitch.measured_um : null,
  }), [
    ['complete', 'complete'], ['pixels', 'pixels'], ['line rate', 'line_rate_Hz', 1, 'Hz'],
    ['x error RMS', 'rms_x_percent', 1, '%'], ['x error max', 'max_x_percent', 1, '%'],
    ['y error RMS', 'rms_y_percent', 1, '%'], ['y error max', 'max_y_percent', 1, '%'],
    ['x error RMS, last frame', 'last_rms_x_percent', 1, '%'], ['y error RMS, last frame', 'last_rms_y_percent', 1, '%'],
    ['used fraction', 'used_fraction'], ['frame time', 'frame_time_s', 1, 's'],
    ['pitch, commanded', 'pitch_commanded_um', 1, 'µm'], ['pitch, measured', 'pitch_measured_um', 1, 'µm'],
    ['sync words off the generator', 'sync_mismatches'],
  ]);
  const box = $('scan-images');
  box.replaceChildren();
  const order = ['image_commanded', 'image_measured', 'error_x', 'error_y'];
  const images = Object.entries(res.images || {}).sort(([a], [b]) => order.indexOf(a) - order.indexOf(b));
  for (const [name, im] of images) {
    const figure = document.createElement('figure');
    const canvas = document.createElement('canvas');
    canvas.id = `scan-${name}`;
    canvas.className = 'scan-image';
    const { lo, hi } = drawImage(canvas, im);
    const cap = document.createElement('figcaption');
    cap.textContent = `${im.title.replace('\n', ': ')} (${fig(lo)} to ${fig(hi)} ${im.clabel})`;
    figure.append(canvas, cap);
    box.append(figure);
  }
}

function scanForm() {
  jobForm('scan', (f) => {
    const cx = f.centre_x.value.trim(), cy = f.centre_y.value.trim();
    if ((cx === '') !== (cy === '')) throw Object.assign(new Error('give both x and y, or neither'), { field: 'centre_um' });
    return {
      pattern: f.pattern.value,
      size_um: [Number(f.size_x.value), Number(f.size_y.value)],
      pixels: [Number(f.pixels_x.value), Number(f.pixels_y.value)],
      line_rate_Hz: Number(f.line_rate_Hz.value),
      frames: Number(f.frames.value),
      centre_um: cx === '' ? null : [Number(cx), Number(cy)],
      sample: f.sample.value,
      restart_stage: f.restart_stage.checked,
    };
  });
}

// ---- commissioning: `piezoloop commission` from the page ----------------------

// A table of rows (objects) by columns [heading, key, scale]: each cell's
// text fig(value, scale) (or the text), the exact value in data-value.
function table(el, rows, columns) {
  el.replaceChildren();
  const head = el.insertRow();
  for (const [h] of columns) { const th = document.createElement('th'); th.textContent = h; head.append(th); }
  for (const r of rows) {
    const tr = el.insertRow();
    for (const [, key, scale] of columns) {
      const td = tr.insertCell();
      const v = key.split('.').reduce((o, k) => (o == null ? o : o[k]), r);
      td.dataset.key = key;
      td.dataset.value = JSON.stringify(v === undefined ? null : v);
      td.textContent = typeof v === 'number' || v === null || v === undefined ? fig(v, scale || 1) : String(v);
    }
  }
}

function showCommissionProgress(p) {
  showJobProgress('commission', p);
  const log = $('commission-log');
  const lines = p.log || [];
  // The log grows while it runs: only the new lines are added.
  if (log.children.length > lines.length) log.replaceChildren();
  for (let i = log.children.length; i < lines.length; ++i) {
    const li = document.createElement('li');
    li.textContent = lines[i];
    log.append(li);
  }
  if (p.state === 'running') $('commission-state').textContent = p.phase === 'recording' ?
    `recording ${Math.round(100 * (p.fraction || 0))} % — ${lines.length ? lines[lines.length - 1] : ''}` : (lines.length ? lines[lines.length - 1] : 'starting');
}

// `commission --axes`: each axis's outcome, the coupling before and after
// the output matrix, and how far the held axes move on each axis's triangle.
function showAxesCommissionResult(res) {
  const names = Object.keys(res.axes);
  const v = $('commission-verdict');
  v.textContent = `axes ${names.join(', ')}: ${res.verified ? 'every axis verified' : 'not every axis verified'}; ` +
    (res.decoupled ? 'decoupled' : 'not decoupled') + (res.output_matrix ? `, output matrix ${JSON.stringify(res.output_matrix.map((r) => r.map((x) => Number(x.toPrecision(4)))))}` : '') +
    (res.on === 'simulator' ? ' (on the simulated stage; nothing was loaded on the board)' : res.saved ? '; saved on the board' : '; not saved');
  v.className = res.verified && res.decoupled ? 'verified' : 'failed';
  table($('commission-axes'), names.map((a) => ({ axis: a, ...res.axes[a] })), [['axis', 'axis'], ['range (µm)', 'range_um'], ['chosen', 'chosen'],
    ['verified', 'verified'], ['bandwidth (Hz)', 'bandwidth_Hz'], ['|T| above -3 dB up to (Hz)', 'bandwidth_above_Hz'],
    ['whole-range triangle within 1 % up to (Hz)', 'fastest_triangle.up_to_Hz'], ['centre (µm)', 'centre_um']]);
  const c = res.coupling || {};
  table($('commission-coupling'), Object.keys(c.before_db || {}).map((pair) => ({ pair, before: c.before_db[pair], after: (c.after_db || {})[pair], reduction: (c.reduction_db || {})[pair] })),
    [['coupling', 'pair'], ['before (dB)', 'before'], ['after (dB)', 'after'], ['reduction (dB)', 'reduction']]);
  const checks = (res.check || {}).axes || {};
  const held = (m) => Object.entries(m || {}).map(([axis, pct]) => `${axis} ${fig(pct)} %`).join(', ');
  table($('commission-cross'), Object.keys(checks).map((a) => ({ driven: a, e_max_pct: checks[a].e_max_pct, held: held(checks[a].cross_motion_pct),
    without: held(checks[a].cross_motion_pct_without_decoupling) })),
  [[`${(res.check || {}).frequency_Hz} Hz triangle on`, 'driven'], ['e_max (%)', 'e_max_pct'], ['held axes move (% of range)', 'held'], ['without the matrix', 'without']]);
  for (const id of ['commission-safety', 'commission-fits', 'commission-candidates', 'commission-verification']) $(id).replaceChildren();
  $('commission-fastest').textContent = '';
}

function showCommissionResult(res) {
  state.jobs.commission = state.jobs.commission || { seen: [] };
  state.jobs.commission.result = res;
  if (!res) return;
  for (const id of ['commission-axes', 'commission-coupling', 'commission-cross']) $(id).replaceChildren();
  if (res.axes) {
    showAxesCommissionResult(res);
    showCommissionFigures(res);
    return;
  }
  const v = $('commission-verdict');
  v.textContent = res.chosen === null ? 'no candidate passed the checks: nothing was loaded' :
    `chosen: ${res.chosen}; ${res.verified ? 'verified' : `not verified: ${res.verification_failure}`}` +
    (res.on === 'simulator' ? ' (on the simulated stage; nothing was loaded on the board)' : res.saved ? '; saved on the board' : '; not saved');
  v.className = res.verified ? 'verified' : 'failed';
  table($('commission-safety'), res.safety, [['safety step (V)', 'step_V'], ['from (V)', 'from_V'], ['Δy (µm)', 'dy_um'], ['noise (µm)', 'noise_um'], ['gain (µm/V)', 'gain_um_per_V']]);
  table($('commission-fits'), res.fits, [['model fit', 'order'], ['rms error (%)', 'rms_rel', 100], ['DC gain (µm/V)', 'dc_gain_um_per_V'], ['chosen', 'chosen']]);
  table($('commission-candidates'), res.candidates, [['candidate', 'name'], ['order', 'order'], ['PM (°)', 'measured_phase_margin_deg'],
    ['at (Hz)', 'measured_crossover_Hz'], ['GM (dB)', 'measured_gain_margin_db'], ['max|S|', 'measured_max_sensitivity'],
    ['predicted e_max (%)', 'predicted_10Hz_half_range.e_max_pct'], ['passes', 'passes'], ['refusal', 'refusal']]);
  table($('commission-verification'), res.verification || [], [['triangle (Hz)', 'frequency_Hz'], ['range (µm)', 'range_um'],
    ['e_max measured (%)', 'measured.e_max_pct'], ['predicted (%)', 'predicted.e_max_pct'], ['e_rms measured (%)', 'measured.e_rms_pct'],
    ['predicted (%)', 'predicted.e_rms_pct'], ['trip', 'measured.trip']]);
  $('commission-fastest').textContent = res.fastest_triangle ? `Fastest triangle: ${res.fastest_triangle.text}.` : '';
  showCommissionFigures(res);
}

// The figures; a stage of axes' under a heading per axis (AXIS/NAME.png).
function showCommissionFigures(res) {
  const shown = [];
  let axis = '';
  for (const name of res.figures || []) {
    const a = name.includes('/') ? name.split('/')[0] : '';
    if (a !== axis) {
      const h = document.createElement('h4');
      h.textContent = `axis ${a}`;
      shown.push(h);
      axis = a;
    }
    const img = new Image();
    img.alt = name;
    img.title = name;
    // A new result, a new URL (the browser caches none: no-store).
    img.src = `/api/commission/figure/${name}?token=${encodeURIComponent(token)}&wall=${res.wall_s || res.out}`;
    shown.push(img);
  }
  $('commission-figures').replaceChildren(...shown);
  $('commission-report').textContent = res.report_md || '';
}

function commissionForm() {
  jobForm('commission', (f) => {
    const bw = f.target_bandwidth_Hz.value.trim();
    const body = { range_um: Number(f.range_um.value), target_bandwidth_Hz: bw === '' ? null : Number(bw), on: f.on.value, save: f.save.checked };
    if (multiAxis() && f.axes.checked) body.axes = 'all';
    return body;
  });
}

// ---- the stream ----------------------------------------------------------------

function connect() {
  const es = new EventSource(`/api/stream?token=${encodeURIComponent(token)}`);
  state.stream = es;
  es.addEventListener('hello', (ev) => {
    const h = JSON.parse(ev.data);
    state.viewer = h.viewer;
    state.rate_Hz = h.rate_Hz;
    state.channelChoices = h.channel_choices || [];
    $('channels-note').textContent = `at most ${h.channel_capacity} at once`;
    applySignals(h.signals, h.scope);
    // Commissioning the simulated stage needs the console's --scenario.
    const sim = document.querySelector('#commission [name="on"] option[value="simulator"]');
    if (sim && !h.simulator) sim.remove();
    state.axes = h.axes && h.axes.length ? h.axes : ['x'];
    // Scans need a board of two or three axes (x and y move together).
    $('scan-panel').hidden = !multiAxis();
    $('commission-axes-box').hidden = !multiAxis();
    if (multiAxis()) {
      const sel = $('axis');
      if (!state.axis) state.axis = state.axes[0];
      sel.replaceChildren(...state.axes.map((a) => new Option(a, a)));
      sel.value = state.axis;
      sel.onchange = () => { state.axis = sel.value; loadParams(); };
      $('axis-box').hidden = false;
    }
    showControl(h);
    loadParams();
    // The first page takes control when nobody has it; later ones watch.
    if (!h.seat_taken) claim().then(() => { state.ready = true; });
    else state.ready = true;
  });
  es.addEventListener('signals', (ev) => {
    const m = JSON.parse(ev.data);
    applySignals(m.signals, m.scope);
  });
  es.addEventListener('frame', (ev) => {
    const f = JSON.parse(ev.data);
    state.frameLog.push([Date.now(), f.t0_s + f.span_s]);
    if (state.frameLog.length > 200) state.frameLog.shift();
    if (state.paused || !plot) {
      api('POST', '/api/scope/drawn', { seq: f.seq });  // taken, not drawn: keep the stream going
      return;
    }
    drawFrame(f);
  });
  es.addEventListener('status', (ev) => showStatus(JSON.parse(ev.data)));
  es.addEventListener('control', (ev) => showControl(JSON.parse(ev.data)));
  es.addEventListener('frf', (ev) => showFrfProgress(JSON.parse(ev.data)));
  es.addEventListener('frf-result', (ev) => showFrfResult(JSON.parse(ev.data)));
  es.addEventListener('step', (ev) => showJobProgress('step', JSON.parse(ev.data)));
  es.addEventListener('step-result', (ev) => showStepResult(JSON.parse(ev.data)));
  es.addEventListener('loops', (ev) => showJobProgress('loops', JSON.parse(ev.data)));
  es.addEventListener('loops-result', (ev) => showLoopsResult(JSON.parse(ev.data)));
  es.addEventListener('scan', (ev) => showJobProgress('scan', JSON.parse(ev.data)));
  es.addEventListener('scan-result', (ev) => showScanResult(JSON.parse(ev.data)));
  es.addEventListener('commission', (ev) => showCommissionProgress(JSON.parse(ev.data)));
  es.addEventListener('commission-result', (ev) => showCommissionResult(JSON.parse(ev.data)));
  es.onerror = () => { $('device').textContent = 'disconnected: reconnecting…'; };
}

function seatCountdown() {
  const left = state.seatDeadline === null ? null : Math.max(0, Math.ceil((state.seatDeadline - Date.now()) / 1000));
  const text = left === null ? '' : `(it passes in ${left} s without an answer)`;
  $('seat-request-left').textContent = text;
  if (state.control && state.control.request && state.control.request.from_me) $('seat').textContent = `asking the controlling page for control… ${text}`;
}
setInterval(seatCountdown, 500);

// Takes the free seat, or asks the controlling page for it (HTTP 202: its
// answer, or the timeout, comes on the stream).
async function claim() {
  const r = await api('POST', '/api/control/claim');
  showControl(r.data);
  if (r.status === 409) $('action-error').textContent = r.data.error;
}
$('give').onclick = async () => showControl((await api('POST', '/api/control/answer', { give: true })).data);
$('keep').onclick = async () => showControl((await api('POST', '/api/control/answer', { give: false })).data);
$('claim').onclick = claim;
$('release').onclick = async () => showControl((await api('POST', '/api/control/release')).data);
$('arm').onclick = () => act('/api/arm');
$('disarm').onclick = () => act('/api/disarm');
$('clear-trip').onclick = () => act('/api/clear-trip');
$('stop').onclick = () => act('/api/stop');
scopeControls();
psdControls();
waveForm();
frfForm();
stepLoopsForms();
scanForm();
commissionForm();
showControl({ controls: false, seat_taken: false });
connect();
