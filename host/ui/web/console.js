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
};
window.piezoloop = state;  // for the browser tests and the curious

function $(id) { return document.getElementById(id); }

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
  for (const s of state.signals) {
    series.push({
      label: `${s.name} (${s.unit})`,
      scale: s.unit === 'V' ? 'V' : 'um',
      stroke: colours[s.name] || '#000',
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
  }, [[], ...state.signals.map(() => [])], $('plot'));
  // The server decimates to one min/max pair per pixel column.
  sendScope({ columns: Math.round(plot.bbox.width / devicePixelRatio) || width });
}

function drawFrame(f) {
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
  }, [x, y], $('psd-plot'));
}

function psdControls() {
  $('psd-update').onclick = updatePsd;
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
  ].concat(st.link_error ? [['link', st.link_error, 'tripped']] : []));
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
  state.measuring = !!st.measuring || (state.frf && state.frf.state === 'running');
  if (st.control) showControl(st.control);
  else updateButtons();
}

function showControl(c) {
  state.controls = c.controls;
  $('seat').textContent = c.controls ? 'you control the board' : (c.seat_taken ? 'watching (another page controls)' : 'watching');
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
    const r = await api('POST', `/api/params/${group}`, body);
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
  const r = await api('GET', '/api/params');
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
    const r = await api('POST', '/api/wave', body);
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
    const r = await api('POST', '/api/frf/start', body);
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
  state.measuring = p.state === 'running';
  $('frf-progress').value = p.fraction || 0;
  const pct = `${Math.round(100 * (p.fraction || 0))} %`;
  const text = {
    idle: 'no measurement yet',
    running: `${p.phase} ${p.phase === 'recording' ? pct : ''}`,
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

// ---- the stream ----------------------------------------------------------------

function connect() {
  const es = new EventSource(`/api/stream?token=${encodeURIComponent(token)}`);
  state.stream = es;
  es.addEventListener('hello', (ev) => {
    const h = JSON.parse(ev.data);
    state.viewer = h.viewer;
    state.signals = h.signals;
    state.rate_Hz = h.rate_Hz;
    const sel = $('trigger-signal');
    sel.replaceChildren(...h.signals.map((s) => new Option(`${s.name} (${s.unit})`, s.name)));
    sel.value = h.scope.trigger_signal;
    $('psd-signal').replaceChildren(...h.signals.map((s) => new Option(`${s.name} (${s.unit})`, s.name)));
    $('psd-signal').value = h.signals.some((s) => s.name === 'y') ? 'y' : h.signals[0].name;
    if (!plot) makePlot();
    showControl(h);
    loadParams();
    // The first page takes control when nobody has it; later ones watch.
    if (!h.seat_taken) claim().then(() => { state.ready = true; });
    else state.ready = true;
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
  es.addEventListener('frf', (ev) => showFrfProgress(JSON.parse(ev.data)));
  es.addEventListener('frf-result', (ev) => showFrfResult(JSON.parse(ev.data)));
  es.onerror = () => { $('device').textContent = 'disconnected: reconnecting…'; };
}

async function claim() {
  const r = await api('POST', '/api/control/claim');
  showControl(r.data);
  $('action-error').textContent = r.ok ? '' : r.data.error;
}
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
showControl({ controls: false, seat_taken: false });
connect();
