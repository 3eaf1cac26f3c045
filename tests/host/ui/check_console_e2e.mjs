// The browser console (`piezoloop ui`) in Debian's Chromium, headless, driven
// by playwright-core, against an emulated qemu-m7 board (`piezoloop emulate`
// with the Ahmad2020 stage and its dahl_ff_K controller), or with --scenario
// against the board `piezoloop ui --scenario` starts itself:
//   - a request without the token, with a foreign Origin or a foreign Host is
//     refused (403); the page with the token loads;
//   - a second page watches: its claim of the control seat and its commands
//     are refused (409);
//   - arm and disarm from the page change the board's status, which the page
//     shows; Stop stops the wave the page started;
//   - the scope holds the board's samples: every pixel column the page drew
//     equals the min/max of the samples the server exports for the same
//     window (CSV), exactly (both are the board's float32 values); the record
//     has no tick gap and its reference r is the wave the page started;
//   - a limit the board refuses is shown at its field with the board's
//     message, the form shows the board's value, and after the console has
//     ended `piezoloop get limits` reads the unchanged value from the board;
//   - the frame rate and the host-to-screen latency are printed (a figure,
//     not a pass/fail check);
//   - (device) a frequency response measured from the page: a watcher cannot
//     start one; a band above rate/2 is refused at to_Hz with the plan's
//     message and changes nothing on the board; the measurement's progress
//     shows on the page and on a watcher; every point of the Bode plots
//     (magnitude, phase, the ±1 std band, the fit) equals the server's result,
//     exactly, and so does the CSV download; the board's groups are put back;
//     after the console `piezoloop measure frf` with the same request on the
//     same board gives the same log hash and the same response, bit for bit
//     (both restart the emulated stage at rest).
//
//   - (axes) a board of axes: see axesConsole.
//
//   node check_console_e2e.mjs PIEZOLOOP SERVO_ELF CONFIGS_DIR device|scenario|axes [SCOPE.png [BODE.png]]
//   (axes: SCOPE.png is the scan panel's screenshot)
// Exit 77 (skipped) without QEMU, the image or /usr/bin/chromium.
import { spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import os from 'node:os';
import { createRequire } from 'node:module';
import http from 'node:http';
import net from 'node:net';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '../../../host/ui/web/package.json'));
const { chromium } = require('playwright-core');

const [exe, image, configs, mode = 'device', screenshot, bodeShot, loopsShot, commissionShot] = process.argv.slice(2);
const chromiumPath = '/usr/bin/chromium';
const qemu = spawnSync('sh', ['-c', 'command -v qemu-system-arm']).status === 0;
if (!existsSync(image) || !qemu || !existsSync(chromiumPath)) {
  console.log(`skipped: needs qemu-system-arm, ${image} and ${chromiumPath}`);
  process.exit(77);
}
const env = { ...process.env, PIEZOLOOP_FIRMWARE_DIR: path.resolve(image, '../../..') };
const scenario = path.join(configs, 'ahmad2020.json');

let passed = 0;
let failed = 0;
function check(ok, what, detail = '') {
  if (ok) { passed += 1; console.log(`ok   ${what}`); } else { failed += 1; console.log(`FAIL ${what}${detail ? `: ${detail}` : ''}`); }
  return ok;
}

// Processes this test started, stopped with SIGTERM (emulate then stops QEMU).
const children = [];
function start(args) {
  const p = spawn(exe, args, { env, stdio: ['ignore', 'pipe', 'pipe'] });
  children.push(p);
  p.stderrText = '';
  p.stderr.on('data', (d) => { p.stderrText += d; });
  return p;
}
function firstLines(p, pattern) {
  return new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error(`no ${pattern} within 60 s: ${text} ${p.stderrText}`)), 60000);
    p.stdout.on('data', (d) => {
      text += d;
      const m = text.match(pattern);
      if (m) { clearTimeout(timer); resolve(m); }
    });
    p.on('exit', (code) => reject(new Error(`exited ${code}: ${text} ${p.stderrText}`)));
  });
}
function stop(p) {
  return new Promise((resolve) => {
    if (p.exitCode !== null || p.signalCode !== null) return resolve(p.exitCode);
    p.on('exit', (code) => resolve(code));
    p.kill('SIGTERM');
    setTimeout(() => p.kill('SIGKILL'), 20000).unref();
  });
}
function run(args) {
  const r = spawnSync(exe, args, { env, encoding: 'utf8', timeout: 60000 });
  return { code: r.status, out: r.stdout, err: r.stderr };
}

// A raw request with any Host and Origin (a browser would not let a test set them).
function request(port, pathAndQuery, headers = {}) {
  return new Promise((resolve, reject) => {
    const req = http.request({ host: '127.0.0.1', port, path: pathAndQuery, headers }, (res) => {
      let body = '';
      res.on('data', (d) => { body += d; });
      res.on('end', () => resolve({ status: res.statusCode, body }));
    });
    req.on('error', reject);
    req.end();
  });
}

async function waitFor(page, fn, arg, what, timeout = 20000) {
  try {
    await page.waitForFunction(fn, arg, { timeout, polling: 50 });
    return true;
  } catch (e) {
    return check(false, what, `not within ${timeout} ms`);
  }
}

async function refusedLimit(page) {
  await waitFor(page, () => document.querySelector('#group-limits [name="u_max_V"]'), null, 'the limits form');
  const before = await page.inputValue('#group-limits [name="u_max_V"]');
  await page.fill('#group-limits [name="u_max_V"]', '50');
  await page.click('#group-limits button[type="submit"]');
  await waitFor(page, () => document.querySelector('#group-limits [data-error-for="u_max_V"]')?.textContent, null, 'the refusal at u_max_V');
  const message = await page.textContent('#group-limits [data-error-for="u_max_V"]');
  check(message.includes('the board refused') && message.includes('hard limit'),
    'u_max_V above the hard limit: the board\'s refusal is shown at u_max_V', message);
  const after = await page.inputValue('#group-limits [name="u_max_V"]');
  check(after === before, 'the form shows the board\'s u_max_V again', `${before} -> ${after}`);
}

// The measurement the page runs, and `measure frf` repeats after the console.
// Its 100 transient periods (2 s of board time, about as long in wall time
// on a busy machine) keep the recording running long enough for the pages
// to see its progress: with 20 (0.4 s) one loaded run saw none.
const frfRequest = { from_Hz: 50, to_Hz: 2000, amplitude_V: 0.09, bias_V: 3, periods: 4, transient_periods: 100, fit_order: '6/5' };

async function fillFrf(page, r) {
  for (const [k, v] of Object.entries(r)) await page.fill(`#frf [name="${k}"]`, String(v));
}

async function frequencyResponse(page, context, url, token) {
  const watcher = await context.newPage();
  await watcher.goto(url);
  await waitFor(watcher, () => window.piezoloop.ready, null, 'a watching page loads');
  const forced = await watcher.evaluate(async ([t, r]) => {
    const res = await fetch('/api/frf/start', { method: 'POST', headers: { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' }, body: JSON.stringify(r) });
    return res.status;
  }, [token, frfRequest]);
  check(forced === 409 && await watcher.isDisabled('#frf-start'), 'a watching page cannot start a measurement (409, Measure disabled)', `status ${forced}`);

  // Refused before anything moves: the band above rate / 2.
  const board = () => page.evaluate(async (t) => {
    const p = await (await fetch('/api/params', { headers: { 'X-Piezoloop-Token': t } })).json();
    return { values: p.values, status: window.piezoloop.status.status };
  }, token);
  const before = await board();
  await fillFrf(page, { ...frfRequest, to_Hz: 6000 });
  await page.click('#frf-start');
  await waitFor(page, () => document.querySelector('#frf [data-error-for="to_Hz"]').textContent, null, 'the refusal at to_Hz');
  const refusal = await page.textContent('#frf [data-error-for="to_Hz"]');
  check(refusal.includes('to_Hz: must be below the Nyquist frequency, rate / 2 = 5000 Hz'), 'to_Hz above rate/2: the plan\'s refusal at to_Hz', refusal);
  const after = await board();
  check(JSON.stringify(after.values) === JSON.stringify(before.values) && !after.status.excitation_running &&
    after.status.armed === before.status.armed && (await page.evaluate(() => window.piezoloop.frf.state)) === 'idle',
    'the refused request changed nothing (groups, armed, no excitation, no measurement)');

  // The measurement, from rest, with a 6/5 fit.
  await fillFrf(page, frfRequest);
  await page.check('#frf [name="restart_stage"]');
  const scopeEndAtStart = await page.evaluate(() => window.piezoloop.frame.t0_s + window.piezoloop.frame.span_s);
  const t0 = Date.now();
  await page.click('#frf-start');
  const finished = await waitFor(page, () => window.piezoloop.frf && ['done', 'failed', 'stopped'].includes(window.piezoloop.frf.state) &&
    window.piezoloop.frfResult, null, 'the measurement ends', 120000);
  const wall = (Date.now() - t0) / 1000;
  const progress = await page.evaluate(() => window.piezoloop.frf);
  if (!finished || !check(progress.state === 'done', 'the measurement ran from the page', JSON.stringify(progress))) return null;
  const seen = await page.evaluate(() => window.piezoloop.frfSeen);
  const watcherSeen = await watcher.evaluate(() => window.piezoloop.frfSeen);
  const partial = (l) => l.some((p) => p.state === 'running' && p.phase === 'recording' && p.fraction > 0 && p.fraction < 1);
  check(partial(seen) && partial(watcherSeen), 'its progress shows, on the page and on the watcher (recording, 0 < fraction < 1)',
    JSON.stringify(seen.map((p) => `${p.phase}:${p.fraction}`)));
  await waitFor(page, () => !window.piezoloop.status.measuring, null, 'the status after the measurement');

  const server = await page.evaluate(async (t) => (await fetch('/api/frf', { headers: { 'X-Piezoloop-Token': t } })).json(), token);
  const res = server.result;
  const same = (a, b) => Array.isArray(a) && Array.isArray(b) && a.length === b.length && a.every((x, i) => x === b[i]);
  // The band as the page must draw it: magnitude ± std_dB, phase ± the same relative deviation in degrees.
  const degPerDb = (Math.log(10) / 20) * (180 / Math.PI);
  const band = (y, k, sign) => y.map((v, i) => (res.std_dB[i] == null ? null : v + sign * k * res.std_dB[i]));
  const plotted = await page.evaluate(() => window.piezoloop.bodeData());
  check(res.lines > 30 && same(plotted.mag[0], res.frequency_Hz) && same(plotted.mag[1], res.magnitude_dB) &&
    same(plotted.phase[1], res.phase_deg), 'the Bode plot\'s measured magnitude and phase are the server\'s lines, exactly',
    `${res.lines} lines`);
  check(res.std_dB.every((x) => x !== null && x > 0) && same(plotted.mag[2], band(res.magnitude_dB, 1, 1)) &&
    same(plotted.mag[3], band(res.magnitude_dB, 1, -1)) && same(plotted.phase[2], band(res.phase_deg, degPerDb, 1)) &&
    same(plotted.phase[3], band(res.phase_deg, degPerDb, -1)), 'the std band drawn is the server\'s std_dB at every line');
  check(res.fit && !res.fit.error && same(plotted.mag[4], res.fit.magnitude_dB) && same(plotted.phase[4], res.fit.phase_deg),
    'the 6/5 fit drawn is the server\'s fit', JSON.stringify(res.fit && (res.fit.error || res.fit.weighted_rms)));
  // 6/5 fits the Ahmad2020 stage's lines within their noise (|G - fit| about one std on average).
  check(res.fit && res.fit.weighted_rms < 1.5, 'the 6/5 fit is within the measurement\'s noise (weighted rms < 1.5)', String(res.fit && res.fit.weighted_rms));
  const watcherResult = await watcher.evaluate(() => window.piezoloop.frfResult);
  check(JSON.stringify(watcherResult) === JSON.stringify(res), 'the watching page got the same result');
  const download = page.waitForEvent('download');
  await page.click('#frf-csv');
  const csv = readFileSync(await (await download).path(), 'utf8').trim().split('\n');
  const rows = csv.slice(1).map((l) => l.split(',').map((c) => (c === '' ? null : Number(c))));
  const col = (k) => rows.map((r) => r[k]);
  check(csv[0] === 'frequency_Hz,magnitude_dB,phase_deg,std_dB,re_um_per_V,im_um_per_V,fit_magnitude_dB,fit_phase_deg' &&
    same(col(0), res.frequency_Hz) && same(col(1), res.magnitude_dB) && same(col(2), res.phase_deg) && same(col(3), res.std_dB) &&
    same(col(4), res.response.map((g) => g[0])) && same(col(5), res.response.map((g) => g[1])) && same(col(6), res.fit.magnitude_dB),
    'the CSV download holds the server\'s lines, exactly', csv[0]);
  const afterRun = await board();
  for (const g of ['feedforward', 'feedback', 'rc', 'limits'])
    check(JSON.stringify(afterRun.values[g]) === JSON.stringify(before.values[g]), `the board's ${g} group is put back`);
  check(!afterRun.status.armed && !afterRun.status.excitation_running, 'the loop is left disarmed, no excitation running');
  // The scope meanwhile: the measurement's own recording (r, y, u of every
  // tick, e not recorded: nan), between the console's recordings.
  const drawnBefore = await page.evaluate(() => window.piezoloop.framesDrawn);
  await waitFor(page, (n) => window.piezoloop.framesDrawn > n + 5, drawnBefore, 'the scope draws again after the measurement');
  // From a second before the click to now: every sample since.
  const end = await page.evaluate(() => window.piezoloop.frame.t0_s + window.piezoloop.frame.span_s);
  const from = scopeEndAtStart - 1;
  const scope = (await page.evaluate(async ([t, f, e]) => (await fetch(`/api/scope/csv?t0_s=${f}&span_s=${e - f}`, { headers: { 'X-Piezoloop-Token': t } })).text(), [token, from, end]))
    .trim().split('\n');
  const head = scope[0].split(',');
  const srows = scope.slice(1).map((l) => l.split(',').map(Number));
  const [ie, iu] = [head.indexOf('e_um'), head.indexOf('u_V')];
  const during = srows.map((r, i) => [r, i]).filter(([r]) => Number.isNaN(r[ie]));
  const first = during.length ? during[0][1] : -1;
  const last = during.length ? during[during.length - 1][1] : -1;
  const ticks = Math.round(res.device_s * res.rate_Hz);
  const contiguous = during.every(([r], k) => k === 0 || Math.abs((r[0] - during[k - 1][0][0]) * res.rate_Hz - 1) < 1e-6);
  // The excitation's ticks (the recorder runs a few ms past its end). Its
  // lead-in, at most a quarter of a period, moves u from the command in
  // effect into the band; from then on u stays within it.
  const leadTicks = Math.floor(ticks / (res.transient_periods + res.periods) / 4);
  const u0 = during.length ? during[0][0][iu] : NaN;
  const bandLo = frfRequest.bias_V - frfRequest.amplitude_V - 1e-6, bandHi = frfRequest.bias_V + frfRequest.amplitude_V + 1e-6;
  const uIn = during.slice(0, ticks).every(([r], k) => k < leadTicks
    ? r[iu] >= Math.min(u0, bandLo) && r[iu] <= Math.max(u0, bandHi)
    : r[iu] >= bandLo && r[iu] <= bandHi);
  check(during.length >= ticks && last - first + 1 === during.length && contiguous && uIn && first > 0 && last < srows.length - 1 &&
    srows[first][0] > srows[first - 1][0] && srows[last + 1][0] > srows[last][0],
    'the scope holds the measurement\'s recording, every tick, u within bias ± amplitude over the excitation after its lead-in, between the console\'s own',
    `${during.length} rows (the run: ${ticks} ticks), rows ${first}..${last} of ${srows.length}, contiguous ${contiguous}, u in band ${uIn}`);
  console.log(`figure: frequency response ${res.lines} lines ${res.frequency_Hz[0]}-${res.frequency_Hz[res.lines - 1]} Hz, ` +
    `${res.transient_periods}+${res.periods} periods = ${res.device_s} s on the board, measured in ${res.wall_s.toFixed(2)} s ` +
    `(${wall.toFixed(1)} s from the click to the plot); std ${Math.min(...res.std_dB).toExponential(2)}..${Math.max(...res.std_dB).toExponential(2)} dB; ` +
    `fit ${res.fit.order} weighted rms ${res.fit.weighted_rms.toPrecision(3)}; warnings: ${JSON.stringify(res.warnings)}`);
  if (bodeShot) {
    await page.locator('#frf-panel').scrollIntoViewIfNeeded();
    await page.locator('#frf-panel').screenshot({ path: bodeShot });
  }

  // A longer one stopped half-way: meanwhile the board's other commands are
  // refused; after the stop the groups are back and the last result stays.
  // 800 periods (16 s of board time): long enough that the stop lands
  // before the end on a loaded machine (with 100, 2 s, a page slow to click
  // once saw the run finish first).
  await fillFrf(page, { ...frfRequest, periods: 800 });
  await page.click('#frf-start');
  await waitFor(page, () => window.piezoloop.frf.state === 'running' && window.piezoloop.frf.phase === 'recording', null, 'the long measurement records');
  const busy = await page.evaluate(async (t) => {
    const r = await fetch('/api/arm', { method: 'POST', headers: { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer } });
    return { status: r.status, body: await r.json() };
  }, token);
  check(busy.status === 409 && busy.body.error.includes('measurement is running') && await page.isDisabled('#arm'),
    'while it runs, Arm is disabled and refused (409)', JSON.stringify(busy));
  await page.click('#frf-stop');
  await waitFor(page, () => ['stopped', 'done', 'failed'].includes(window.piezoloop.frf.state), null, 'the stopped measurement ends', 60000);
  const stopped = await page.evaluate(() => window.piezoloop.frf);
  check(stopped.state === 'stopped' && stopped.error.message.includes('stopped before the end'), 'Stop measuring stops it', JSON.stringify(stopped));
  await waitFor(page, () => !window.piezoloop.status.measuring, null, 'the status after the stop');
  const afterStop = await board();
  check(['feedforward', 'feedback', 'rc'].every((g) => JSON.stringify(afterStop.values[g]) === JSON.stringify(before.values[g])) &&
    !afterStop.status.armed && !afterStop.status.excitation_running, 'after the stop the groups are put back, the loop disarmed, no excitation');
  const kept = await page.evaluate(async (t) => (await (await fetch('/api/frf', { headers: { 'X-Piezoloop-Token': t } })).json()).result, token);
  check(JSON.stringify(kept) === JSON.stringify(res), 'the last result stays');
  await watcher.close();
  return res;
}

// The step and the loops the page measures, and `measure step | loops` repeats after the console.
// Each records for about 1 s of board time or more, so the pages see its
// progress on a busy machine (0.1 and 0.2 s did not always show it).
const stepRequest = { mode: 'open', step_V: 1, bias_V: 3, duration_s: 0.5 };
const loopsRequest = { amplitudes_V: '2, 4', frequency_Hz: 20, cycles: 10 };

// The page's number format (console.js fig): 4 significant digits, scaled first.
const fig = (x, scale = 1) => (x === null || x === undefined ? '–' : String(Number((x * scale).toPrecision(4))));

async function fillForm(page, form, r) {
  for (const [k, v] of Object.entries(r)) {
    const sel = `#${form} [name="${k}"]`;
    if (await page.evaluate((q) => document.querySelector(q).tagName, sel) === 'SELECT') await page.selectOption(sel, String(v));
    else await page.fill(sel, String(v));
  }
}

// Runs job `name` from the page (restart at rest), waits for its end; its
// progress seen on the page and on the watcher.
async function measureJob(page, watcher, name) {
  await page.check(`#${name} [name="restart_stage"]`);
  const t0 = Date.now();
  await page.click(`#${name}-start`);
  const finished = await waitFor(page, (n) => { const j = window.piezoloop.jobs[n]; return j && j.progress && ['done', 'failed', 'stopped'].includes(j.progress.state) && j.result; },
    name, `the ${name} measurement ends`, 120000);
  const wall = (Date.now() - t0) / 1000;
  const job = await page.evaluate((n) => window.piezoloop.jobs[n], name);
  if (!finished || !check(job.progress.state === 'done', `the ${name} measurement ran from the page`, JSON.stringify(job.progress))) return null;
  const watcherSeen = await watcher.evaluate((n) => window.piezoloop.jobs[n].seen, name);
  const partial = (l) => l.some((p) => p.state === 'running' && p.phase === 'recording' && p.fraction > 0 && p.fraction < 1);
  check(partial(job.seen) && partial(watcherSeen), `its progress shows, on the page and on the watcher (recording, 0 < fraction < 1)`,
    JSON.stringify(job.seen.map((p) => `${p.phase}:${p.fraction}`)));
  await waitFor(page, () => !window.piezoloop.status.measuring, null, `the status after the ${name} measurement`);
  const server = await page.evaluate(async ([t, n]) => (await fetch(`/api/${n}`, { headers: { 'X-Piezoloop-Token': t } })).json(), [token(page), name]);
  const watcherResult = await watcher.evaluate((n) => window.piezoloop.jobs[n].result, name);
  check(JSON.stringify(watcherResult) === JSON.stringify(server.result), `the watching page got the same ${name} result`);
  return { res: server.result, wall };
}
function token(page) { return new URL(page.url()).searchParams.get('token'); }

async function csvOf(page, button) {
  const download = page.waitForEvent('download');
  await page.click(button);
  const lines = readFileSync(await (await download).path(), 'utf8').trim().split('\n');
  return { head: lines[0], rows: lines.slice(1).map((l) => l.split(',').map(Number)) };
}

async function stepsAndLoops(page, context, url) {
  const started = Date.now();
  const t = token(page);
  const watcher = await context.newPage();
  await watcher.goto(url);
  await waitFor(watcher, () => window.piezoloop.ready, null, 'a watching page loads');
  const forced = await watcher.evaluate(async ([tk, r]) => {
    const res = await fetch('/api/step/start', { method: 'POST', headers: { 'X-Piezoloop-Token': tk, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' }, body: JSON.stringify(r) });
    return res.status;
  }, [t, stepRequest]);
  check(forced === 409 && await watcher.isDisabled('#step-start') && await watcher.isDisabled('#loops-start'),
    'a watching page cannot start a step (409; Measure disabled for steps and loops)', `status ${forced}`);

  const board = () => page.evaluate(async (tk) => {
    const p = await (await fetch('/api/params', { headers: { 'X-Piezoloop-Token': tk } })).json();
    return { values: p.values, status: window.piezoloop.status.status };
  }, t);
  const before = await board();
  // Refused before anything moves: 3 V + 8 V passes the 10 V command limit.
  await fillForm(page, 'step', { ...stepRequest, step_V: 8 });
  await page.click('#step-start');
  await waitFor(page, () => document.querySelector('#step [data-error-for="step_V"]').textContent, null, 'the refusal at step_V');
  const refusal = await page.textContent('#step [data-error-for="step_V"]');
  check(refusal.includes('step_V: from 3 V the step must end within the board\'s command limits'), 'a step past the command limit: the plan\'s refusal at step_V', refusal);
  await fillForm(page, 'loops', { ...loopsRequest, amplitudes_V: '2, 12' });
  await page.click('#loops-start');
  await waitFor(page, () => document.querySelector('#loops [data-error-for="amplitudes_V"]').textContent, null, 'the refusal at amplitudes_V');
  const loopsRefusal = await page.textContent('#loops [data-error-for="amplitudes_V"]');
  check(loopsRefusal.includes('amplitudes_V: each must be in (0, '), 'a loop past the command limit: the plan\'s refusal at amplitudes_V', loopsRefusal);
  const after = await board();
  check(JSON.stringify(after.values) === JSON.stringify(before.values) && !after.status.excitation_running &&
    after.status.armed === before.status.armed &&
    (await page.evaluate(() => ['step', 'loops'].every((n) => window.piezoloop.jobs[n].progress.state === 'idle' && !window.piezoloop.jobs[n].result))),
    'the refused requests changed nothing (groups, armed, no excitation, no measurement)');

  // ---- the step ----
  await fillForm(page, 'step', stepRequest);
  const step = await measureJob(page, watcher, 'step');
  if (step) {
    const res = step.res;
    const plotted = await page.evaluate(() => window.piezoloop.stepData());
    const same = (a, b) => Array.isArray(a) && Array.isArray(b) && a.length === b.length && a.every((x, i) => x === b[i]);
    check(res.time_s.length > 500 && same(plotted[0], res.time_s) && same(plotted[1], res.reference_um) && same(plotted[2], res.response_um) &&
      same(plotted[3], res.command_V), 'the step plot\'s t, r, y, u are the server\'s samples, exactly', `${res.time_s.length} samples`);
    const shown = await page.$$eval('#step-figures dd', (dds) => dds.map((d) => ({ key: d.dataset.key, value: JSON.parse(d.dataset.value), text: d.textContent })));
    const scale = { peak_time_s: 1e3, rise_time_s: 1e3, settling_time_s: 1e3 };
    const bad = shown.filter((d) => JSON.stringify(d.value) !== JSON.stringify(res[d.key]) ||
      !d.text.startsWith(typeof res[d.key] === 'number' ? fig(res[d.key], scale[d.key] || 1) : String(res[d.key])));
    check(shown.length >= 12 && bad.length === 0 && ['overshoot_pct', 'rise_time_s', 'settling_time_s', 'initial_um', 'final_value_um'].every((k) => shown.some((d) => d.key === k)),
      'every step figure shown is the server\'s (overshoot, rise, settling, initial, final, peak, ...)', JSON.stringify(bad));
    // The open-loop step of 1 V moves the Ahmad2020 stage by about its gain (µm/V), the command steps by 1 V.
    const u = res.command_V;
    check(u[0] === 3 && u[u.length - 1] === 4 && res.final_value_um - res.initial_um > 0.5 && res.rise_time_s > 0,
      'the step: u from 3 V to 4 V, y rises', `y ${res.initial_um} -> ${res.final_value_um}, rise ${res.rise_time_s}`);
    const csv = await csvOf(page, '#step-csv');
    check(csv.head === 't,r,u,y' && csv.rows.length === res.time_s.length && csv.rows.every((r, i) => Math.fround(r[3]) === Math.fround(res.response_um[i]) && Math.fround(r[2]) === Math.fround(res.command_V[i])),
      'the step CSV holds the server\'s samples (the board\'s float32 values)');
    console.log(`figure: step ${stepRequest.step_V} V from ${stepRequest.bias_V} V open loop: y ${res.initial_um.toFixed(4)} -> ${res.final_value_um.toFixed(4)} µm, ` +
      `overshoot ${fig(res.overshoot_pct)} %, rise ${fig(res.rise_time_s, 1e3)} ms, settling ${fig(res.settling_time_s, 1e3)} ms; ` +
      `${res.wall_s.toFixed(2)} s measured, ${step.wall.toFixed(1)} s from the click to the plot; warnings ${JSON.stringify(res.warnings)}`);
  }

  // ---- the loops ----
  await fillForm(page, 'loops', loopsRequest);
  const loops = await measureJob(page, watcher, 'loops');
  if (loops) {
    const res = loops.res;
    const plotted = await page.evaluate(() => window.piezoloop.jobs.loops.plotted);
    const amps = [2, 4];
    const exact = amps.every((a, k) => {
      const idx = res.amplitude_V.map((x, i) => [x, i]).filter(([x]) => x === a).map(([, i]) => i);
      const p = plotted[k];
      return p && p.amplitude_V === a && idx.length > 500 && p.u.length === idx.length &&
        idx.every((i, j) => p.u[j] === res.u_V[i] && p.y[j] === res.y_um[i]);
    });
    check(plotted.length === 2 && exact, 'each loop drawn (y against u) is the server\'s samples of its amplitude, exactly',
      JSON.stringify(plotted.map((p) => [p.amplitude_V, p.u.length])));
    const cells = await page.$$eval('#loops-figures td', (tds) => tds.map((d) => ({ key: d.dataset.key, value: JSON.parse(d.dataset.value), text: d.textContent })));
    const want = res.loops.flatMap((l) => ['amplitude_V', 'hysteresis_pct', 'max_width_pct', 'y_min_um', 'y_max_um'].map((k) => ({ key: k, value: l[k], text: fig(l[k]) })));
    check(JSON.stringify(cells) === JSON.stringify(want), 'every loop figure shown is the server\'s (hysteresis, widest gap, y range)', JSON.stringify(cells));
    // The Ahmad2020 stage is hysteretic (its Dahl model): each loop opens.
    check(res.loops.every((l) => l.hysteresis_pct > 0.5 && l.max_width_pct > 0.5 && l.y_max_um > l.y_min_um),
      'each loop opens (hysteresis and widest gap > 0.5 %)', JSON.stringify(res.loops));
    const csv = await csvOf(page, '#loops-csv');
    check(csv.head === 't,u,y,v,x,amplitude_V' && csv.rows.length === res.y_um.length && csv.rows.every((r, i) => Math.fround(r[1]) === Math.fround(res.u_V[i]) && Math.fround(r[2]) === Math.fround(res.y_um[i]) && r[5] === res.amplitude_V[i]),
      'the loops CSV (identify pi\'s columns) holds the server\'s samples');
    console.log(`figure: loops ${loopsRequest.amplitudes_V} V at ${loopsRequest.frequency_Hz} Hz, ${loopsRequest.cycles} cycles: hysteresis ` +
      `${res.loops.map((l) => `${fig(l.hysteresis_pct)} % (widest ${fig(l.max_width_pct)} %)`).join(', ')}; ` +
      `${res.wall_s.toFixed(2)} s measured, ${loops.wall.toFixed(1)} s from the click to the plot`);
    if (loopsShot) {
      await page.locator('#loops-panel').scrollIntoViewIfNeeded();
      await page.locator('#loops-panel').screenshot({ path: loopsShot });
    }
  }
  const afterRuns = await board();
  check(['feedforward', 'feedback', 'rc', 'limits'].every((g) => JSON.stringify(afterRuns.values[g]) === JSON.stringify(before.values[g])) &&
    !afterRuns.status.armed && !afterRuns.status.excitation_running, 'after the step and the loops the groups are put back, the loop disarmed');
  await watcher.close();
  console.log(`figure: the step and loops checks took ${((Date.now() - started) / 1000).toFixed(1)} s`);
  return { step: step && step.res, loops: loops && loops.res };
}

// Commissioning from the page on the scenario's stage, simulated (`ui
// --scenario`; on the emulated board it takes half a minute); the board's
// path is checked up to commission's own refusal of a range beyond the
// travel, before anything moves.
const commissionRequest = { range_um: 12 };

async function commissionFromPage(page, context, url) {
  const started = Date.now();
  const t = token(page);
  const watcher = await context.newPage();
  await watcher.goto(url);
  await waitFor(watcher, () => window.piezoloop.ready, null, 'a watching page loads');
  const forced = await watcher.evaluate(async ([tk]) => {
    const res = await fetch('/api/commission/start', { method: 'POST', headers: { 'X-Piezoloop-Token': tk, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' }, body: JSON.stringify({ range_um: 12, on: 'simulator' }) });
    return res.status;
  }, [t]);
  check(forced === 409 && await watcher.isDisabled('#commission-start'), 'a watching page cannot commission (409, the button disabled)', `status ${forced}`);

  const board = () => page.evaluate(async (tk) => {
    const p = await (await fetch('/api/params', { headers: { 'X-Piezoloop-Token': tk } })).json();
    return { values: p.values, status: window.piezoloop.status.status };
  }, t);
  const before = await board();
  // The form's own check, then commission's on the board: a range beyond the travel, before anything moves.
  await page.selectOption('#commission [name="on"]', 'board');
  await page.fill('#commission [name="range_um"]', '-1');
  await page.click('#commission-start');
  await waitFor(page, () => document.querySelector('#commission [data-error-for="range_um"]').textContent, null, 'the refusal at range_um');
  const own = await page.textContent('#commission [data-error-for="range_um"]');
  check(own.includes('range_um: must be a number > 0'), 'range_um -1: refused at range_um', own);
  await page.fill('#commission [name="range_um"]', '5000');
  await page.click('#commission-start');
  await waitFor(page, () => { const j = window.piezoloop.jobs.commission; return j && j.progress && j.progress.state === 'failed'; }, null, 'commission refuses 5000 µm');
  const travel = await page.textContent('#commission [data-error-for="range_um"]');
  check(/range_um: 5000 um is beyond the board's travel/.test(travel), 'range_um 5000 on the board: commission\'s refusal at range_um', travel);
  await waitFor(page, () => !window.piezoloop.status.measuring, null, 'the status after the refusal');
  const after = await board();
  check(JSON.stringify(after.values) === JSON.stringify(before.values) && !after.status.excitation_running && !after.status.wave_running &&
    after.status.armed === before.status.armed, 'the refused commissioning changed nothing on the board (groups, armed, no excitation)');

  // The simulated stage, commissioned from the page: stopped once, then run to the end.
  await page.selectOption('#commission [name="on"]', 'simulator');
  await page.fill('#commission [name="range_um"]', String(commissionRequest.range_um));
  // The simulated run takes a second or two with its figures: Stop is sent right after the start, as the page's Stop sends it.
  const stopSent = await page.evaluate(async (tk) => {
    const h = { 'X-Piezoloop-Token': tk, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' };
    const start = await fetch('/api/commission/start', { method: 'POST', headers: h, body: JSON.stringify({ range_um: 12, on: 'simulator' }) });
    const stop = await fetch('/api/commission/stop', { method: 'POST', headers: h });
    return [start.status, stop.status];
  }, t);
  await waitFor(page, () => { const p = window.piezoloop.jobs.commission.progress; return p.request && p.request.on === 'simulator' && ['done', 'failed', 'stopped'].includes(p.state); },
    null, 'the simulated commissioning ends', 60000);
  const halted = await page.evaluate(() => window.piezoloop.jobs.commission.progress);
  check(JSON.stringify(stopSent) === '[200,200]' && halted.state === 'stopped' && halted.error.message.includes('stopped before the end'),
    'Stop interrupts the simulated commissioning', JSON.stringify({ stopSent, state: halted.state, error: halted.error }));
  const t0 = Date.now();
  await page.click('#commission-start');
  const finished = await waitFor(page, () => { const j = window.piezoloop.jobs.commission; return j && j.progress && ['done', 'failed', 'stopped'].includes(j.progress.state) && j.progress.request.on === 'simulator' && j.result; },
    null, 'commissioning ends', 180000);
  const wall = (Date.now() - t0) / 1000;
  const job = await page.evaluate(() => window.piezoloop.jobs.commission);
  if (!finished || !check(job.progress.state === 'done', 'commissioning ran from the page', JSON.stringify(job.progress))) return null;
  const server = await page.evaluate(async (tk) => (await fetch('/api/commission', { headers: { 'X-Piezoloop-Token': tk } })).json(), t);
  const res = server.result;
  const shownLog = await page.$$eval('#commission-log li', (lis) => lis.map((l) => l.textContent));
  const watcherLog = await watcher.$$eval('#commission-log li', (lis) => lis.map((l) => l.textContent));
  check(res.log.length > 10 && JSON.stringify(shownLog) === JSON.stringify(res.log) && JSON.stringify(watcherLog) === JSON.stringify(res.log),
    'its steps and decisions, as they were made, are the server\'s log, on the page and on the watcher', `${shownLog.length} lines, server ${res.log.length}`);
  check(job.seen.filter((p) => p.state === 'running').length > 3, 'its progress showed while it ran', String(job.seen.length));
  const cells = (id) => page.$$eval(`#${id} td`, (tds) => tds.map((d) => ({ key: d.dataset.key, value: JSON.parse(d.dataset.value), text: d.textContent })));
  const pick = (r, key) => key.split('.').reduce((o, k) => (o == null ? o : o[k]), r);
  const want = (rows, cols) => rows.flatMap((r) => cols.map(([k, sc]) => {
    const v = pick(r, k);
    return { key: k, value: v === undefined ? null : v, text: typeof v === 'number' || v == null ? fig(v, sc || 1) : String(v) };
  }));
  const tables = {
    'commission-safety': [res.safety, [['step_V'], ['from_V'], ['dy_um'], ['noise_um'], ['gain_um_per_V']]],
    'commission-fits': [res.fits, [['order'], ['rms_rel', 100], ['dc_gain_um_per_V'], ['chosen']]],
    'commission-candidates': [res.candidates, [['name'], ['order'], ['measured_phase_margin_deg'], ['measured_crossover_Hz'], ['measured_gain_margin_db'],
      ['measured_max_sensitivity'], ['predicted_10Hz_half_range.e_max_pct'], ['passes'], ['refusal']]],
    'commission-verification': [res.verification, [['frequency_Hz'], ['range_um'], ['measured.e_max_pct'], ['predicted.e_max_pct'], ['measured.e_rms_pct'], ['predicted.e_rms_pct'], ['measured.trip']]],
  };
  for (const [id, [rows, cols]] of Object.entries(tables)) {
    const shown = await cells(id);
    check(rows.length > 0 && JSON.stringify(shown) === JSON.stringify(want(rows, cols)), `every figure of the ${id.replace('commission-', '')} table is the server's`,
      JSON.stringify(shown).slice(0, 300));
  }
  const verdict = await page.textContent('#commission-verdict');
  check(res.chosen && verdict.includes(`chosen: ${res.chosen}`) && verdict.includes(res.verified ? 'verified' : 'not verified'), 'the verdict names the chosen candidate and the verification', verdict);
  const fastest = await page.textContent('#commission-fastest');
  check(res.fastest_triangle && fastest === `Fastest triangle: ${res.fastest_triangle.text}.` && res.report_md.includes(fastest),
    'the fastest whole-range triangle within 1 % is the server\'s, as in report.md', fastest);
  const report = await page.textContent('#commission-report');
  check(report === res.report_md && report.includes('# piezoloop commission'), 'the page holds the server\'s report.md');
  const images = await page.$$eval('#commission-figures img', (imgs) => imgs.map((i) => ({ alt: i.alt, ok: i.complete && i.naturalWidth > 0 })));
  await waitFor(page, () => [...document.querySelectorAll('#commission-figures img')].every((i) => i.complete), null, 'the figures load');
  const loaded = await page.$$eval('#commission-figures img', (imgs) => imgs.map((i) => ({ alt: i.alt, ok: i.naturalWidth > 0 })));
  check(res.figures.length === images.length && loaded.every((i) => i.ok) && (res.figures.length === 4 || res.report_md.includes('The figures could not be drawn')),
    'the report\'s figures are shown (frf, loops, candidates, verification), or the report says why not', JSON.stringify(loaded));
  console.log(`figure: commissioning ${commissionRequest.range_um} µm of the simulated stage from the page: chosen ${res.chosen}, ` +
    `verified ${res.verified}, bandwidth ${fig(res.bandwidth_Hz)} Hz, ${res.log.length} steps logged; ${res.wall_s.toFixed(1)} s on the server, ` +
    `${wall.toFixed(1)} s from the click to the result`);
  if (commissionShot) {
    await page.locator('#commission-panel').scrollIntoViewIfNeeded();
    await page.locator('#commission-panel').screenshot({ path: commissionShot });
  }
  await watcher.close();
  console.log(`figure: the commissioning checks took ${((Date.now() - started) / 1000).toFixed(1)} s`);
  return res;
}

// axes: a board of three coupled axes (the XYZ flexure on qemu-m7): the
// axis selector, the forms of the selected axis (y's own u_max_V), a refusal
// on y at its field leaving y and x as they were, a wave started on y from
// the page (the status's per-axis lines), the scope's other axes' signals,
// and a scan from the page (a refusal at its field, its figures and images).
async function axesConsole() {
  // The console starts the emulated XYZ board itself (--scenario), so that
  // commissioning can also run on the scenario's simulated stage.
  const xyz = path.join(configs, 'stages', 'xyz_flexure.json');
  const ui = start(['ui', '--scenario', xyz, '--case', 'pi_notch', '--seat-answer-s', '120']);
  const started = await firstLines(ui, /console of tcp:127\.0\.0\.1:(\d+) at\s+(http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]{32})/);
  const url = started[2];
  const browser = await chromium.launch({ executablePath: chromiumPath, args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'] });
  try {
    const page = await (await browser.newContext({ viewport: { width: 1400, height: 1000 } })).newPage();
    await page.goto(url);
    if (!await waitFor(page, () => window.piezoloop.ready && window.piezoloop.controls && window.piezoloop.framesDrawn > 3, null, 'the page controls and draws')) return;
    const token = url.split('token=')[1];
    const limitsOf = (axis) => page.evaluate(async ([t, a]) => (await (await fetch(`/api/params?axis=${a}`, { headers: { 'X-Piezoloop-Token': t } })).json()).values.limits.u_max_V, [token, axis]);
    const y9 = await page.evaluate(async (t) => (await fetch('/api/params/limits?axis=y', { method: 'POST',
      headers: { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' },
      body: JSON.stringify({ u_max_V: 9 }) })).status, token);
    if (!check(y9 === 200 && await limitsOf('y') === 9 && await limitsOf('x') === 10, 'the XYZ case on the board, y\'s u_max_V set to 9 V', `status ${y9}`)) return;
    const options = await page.$$eval('#axis option', (os) => os.map((o) => o.value));
    check(await page.isVisible('#axis-box') && JSON.stringify(options) === '["x","y","z"]', 'the axis selector offers x, y and z', JSON.stringify(options));
    const names = await page.evaluate(() => window.piezoloop.signals.map((s) => s.name));
    check(['r', 'y', 'y.y', 'z.y'].every((n) => names.includes(n)), 'the scope records x\'s r and y and the other axes\' y (y.y, z.y)', JSON.stringify(names));
    const refusedAxis = await page.evaluate(async (t) => {
      const h = { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' };
      const p = await fetch('/api/params?axis=w', { headers: h });
      const s = await fetch('/api/step/start', { method: 'POST', headers: h, body: JSON.stringify({ step_V: 0.1, axis: 'w' }) });
      return { params: p.status, paramsError: (await p.json()).error, step: s.status, stepField: (await s.json()).field };
    }, token);
    check(refusedAxis.params === 400 && refusedAxis.paramsError.includes('axis:') && refusedAxis.step === 400 &&
      refusedAxis.stepField === 'axis', 'an axis the board has not got is refused naming axis (parameters, a measurement)',
      JSON.stringify(refusedAxis));
    const umax = '#group-limits [name="u_max_V"]';
    await waitFor(page, (s) => document.querySelector(s), umax, 'the limits form');
    const x = await page.inputValue(umax);
    await page.selectOption('#axis', 'y');
    await waitFor(page, (s) => document.querySelector(s) && document.querySelector(s).value === '9', umax, 'y\'s limits form');
    check(x === '10' && await page.inputValue(umax) === '9', 'the forms show the selected axis\'s groups (x 10 V, y 9 V)', `${x}, ${await page.inputValue(umax)}`);
    await page.fill(umax, '50');
    await page.click('#group-limits button[type="submit"]');
    await waitFor(page, () => document.querySelector('#group-limits [data-error-for="u_max_V"]')?.textContent, null, 'the refusal at u_max_V');
    check((await page.textContent('#group-limits [data-error-for="u_max_V"]')).includes('the board refused') && await page.inputValue(umax) === '9',
      'y\'s u_max_V above the hard limit: the board\'s refusal at the field, the form back at 9 V');
    await page.selectOption('#wave [name="trajectory"]', 'triangle');
    await page.fill('#wave [name="frequency_Hz"]', '20');
    await page.fill('#wave [name="amplitude_um"]', '4');
    await page.check('#wave [name="arm"]');
    await page.click('#wave button[type="submit"]');
    const yWave = () => page.evaluate(() => (window.piezoloop.status.axes || []).find((a) => a.axis === 'y') || {});
    await waitFor(page, () => {
      const a = (window.piezoloop.status.axes || []).find((x) => x.axis === 'y');
      return a && a.wave_running && a.armed;
    }, null, 'the wave on y');
    const axes = await page.evaluate(() => window.piezoloop.status.axes.map((a) => [a.axis, a.wave_running]));
    check(JSON.stringify(axes) === '[["x",false],["y",true],["z",false]]' && /axis y\s*armed, not tripped, wave running/.test(await page.textContent('#status')),
      'a wave started on y from the page runs on y alone, and the status says so per axis',
      `${JSON.stringify(axes)} ${await page.textContent('#wave-error')}`);
    await waitFor(page, () => {
      const v = window.piezoloop.frame && window.piezoloop.frame.series['y.y'];
      const f = v ? [...v].filter(Number.isFinite) : [];
      return f.length > 10 && Math.max(...f) - Math.min(...f) > 1;
    }, null, 'y.y moving on the scope');
    check(true, 'the scope draws y.y following the wave (more than 1 um peak to peak)');
    await scopeChannels(page, token);
    await page.click('#stop');
    await waitFor(page, () => !(window.piezoloop.status.axes || []).find((x) => x.axis === 'y').wave_running, null, 'Stop');
    check(!(await yWave()).wave_running, 'Stop stops y\'s wave');

    // A scan from the page: refused at its field first, then a 16 x 16
    // raster about (50, 50) um (the console has no scenario: the centre is
    // given), its figures and images drawn as the server holds them.
    check(await page.isVisible('#scan-panel'), 'the scan panel is shown on a board of axes');
    const badScans = await page.evaluate(async (t) => {
      const h = { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' };
      const out = [];
      for (const body of [{ bogus: 1 }, { pixels: ['a', 2] }, { centre_um: [1] }, { line_rate_Hz: 1e9, centre_um: [50, 50] }]) {
        const r = await fetch('/api/scan/start', { method: 'POST', headers: h, body: JSON.stringify(body) });
        out.push([r.status, (await r.json()).field]);
      }
      return out;
    }, token);
    check(JSON.stringify(badScans) === '[[400,""],[400,"pixels"],[400,"centre_um"],[400,"line_rate_Hz"]]',
      'scan requests the console cannot take are refused at their fields (unknown, pixels, centre_um, line_rate_Hz)', JSON.stringify(badScans));
    await page.fill('#scan [name="size_x"]', '1e7');
    await page.fill('#scan [name="centre_x"]', '50');
    await page.fill('#scan [name="centre_y"]', '50');
    await page.click('#scan-start');
    await waitFor(page, () => document.querySelector('#scan [data-error-for="size_um"]')?.textContent, null, 'the scan\'s refusal at size_um');
    check((await page.textContent('#scan [data-error-for="size_um"]')).includes('size_um'), 'a scan beyond the range is refused at size_um');
    await page.fill('#scan [name="size_x"]', '10');
    await page.fill('#scan [name="size_y"]', '10');
    await page.fill('#scan [name="pixels_x"]', '16');
    await page.fill('#scan [name="pixels_y"]', '16');
    await page.fill('#scan [name="line_rate_Hz"]', '100');
    const scanStarted = Date.now();
    await page.click('#scan-start');
    if (await waitFor(page, () => window.piezoloop.jobs.scan && window.piezoloop.jobs.scan.result && window.piezoloop.jobs.scan.progress.state === 'done', null, 'the scan\'s result', 240000)) {
      const res = await page.evaluate(() => window.piezoloop.jobs.scan.result);
      const server = await page.evaluate(async (t) => (await (await fetch('/api/scan', { headers: { 'X-Piezoloop-Token': t } })).json()).result, token);
      check(res.complete === true && res.sync_mismatches === 0 && res.pixels > 0 && JSON.stringify(res) === JSON.stringify(server),
        'the scan from the page: complete, the sync word the generator\'s on every tick, the page\'s result the server\'s',
        JSON.stringify({ complete: res.complete, sync: res.sync_mismatches, pixels: res.pixels, incomplete: res.incomplete }));
      const drawn = await page.$$eval('#scan-images canvas', (cs) => cs.map((c) => [c.id, c.width, c.height]));
      const sizes = ['image_commanded', 'image_measured', 'error_x', 'error_y'].map((k) => [`scan-${k}`, res.images[k].nx, res.images[k].ny]);
      check(drawn.length === 4 && JSON.stringify(drawn) === JSON.stringify(sizes), 'its four images drawn at their grids', JSON.stringify(drawn));
      const shown = await page.$eval('#scan-figures dd[data-key="rms_x_percent"]', (d) => JSON.parse(d.dataset.value));
      check(shown === res.tracking.rms_x_percent, 'the x error RMS shown is the result\'s', `${shown} vs ${res.tracking.rms_x_percent}`);
      const shownLast = await page.$eval('#scan-figures dd[data-key="last_rms_y_percent"]', (d) => JSON.parse(d.dataset.value));
      check(shownLast === res.tracking_last_frame.rms_y_percent, 'the last frame\'s y error RMS shown is the result\'s',
            `${shownLast} vs ${res.tracking_last_frame.rms_y_percent}`);
      console.log(`figure: a 16 x 16 raster scanned from the page in ${((Date.now() - scanStarted) / 1000).toFixed(1)} s`);
      if (screenshot) {  // axes mode: the scan panel (docs/img/console_scan.png)
        await page.locator('#scan-panel').scrollIntoViewIfNeeded();
        await page.locator('#scan-panel').screenshot({ path: screenshot });
      }
    }
    await commissionAxesFromPage(page, token);
    check(await limitsOf('y') === 9 && await limitsOf('x') === 10, 'the board still holds y 9 V and x 10 V after the refused 50',
      `${await limitsOf('y')}, ${await limitsOf('x')}`);
  } finally {
    await browser.close();
  }
  check(await stop(ui) === 0, 'the console ends cleanly on SIGTERM');
}

// The scope's channels, any signal of any axis: refused at `channels` when
// the board cannot record them; then y's error and command and z's position
// picked on the page are what the scope draws (y.u moving with y's wave),
// and the CSV's columns; the console's channels back afterwards.
async function scopeChannels(page, token) {
  const before = await page.evaluate(() => window.piezoloop.signals.map((s) => s.name));
  const choices = await page.$$eval('#channel-picks input', (is) => is.map((i) => i.value));
  check(choices.length === 24 && ['r', 'u_rc', 'y.u', 'z.d'].every((c) => choices.includes(c)),
    'the channel picks offer every signal of every axis (3 x 8)', JSON.stringify(choices));
  const refused = await page.evaluate(async ([t, all]) => {
    const h = { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer, 'Content-Type': 'application/json' };
    const out = [];
    for (const channels of [all.slice(0, 9), ['w.r'], ['y.u', 'y.u'], []]) {
      const r = await fetch('/api/scope/channels', { method: 'POST', headers: h, body: JSON.stringify({ channels }) });
      out.push([r.status, (await r.json()).field]);
    }
    return out;
  }, [token, choices]);
  check(JSON.stringify(refused) === '[[400,"channels"],[400,"channels"],[400,"channels"],[400,"channels"]]' &&
    JSON.stringify(await page.evaluate(() => window.piezoloop.signals.map((s) => s.name))) === JSON.stringify(before),
  'nine channels, an unknown one, one twice or none: refused naming channels, the scope unchanged', JSON.stringify(refused));
  const picked = ['y.e', 'y.u', 'z.y'];  // in the picks' order
  await page.click('#channels-box summary');
  for (const name of choices) {
    const box = page.locator(`#channel-picks input[value="${name}"]`);
    if (picked.includes(name)) await box.check(); else await box.uncheck();
  }
  await page.click('#channels-apply');
  const drawn = await waitFor(page, (p) => {
    const f = window.piezoloop.frame;
    if (!f || JSON.stringify(Object.keys(f.series)) !== JSON.stringify(p)) return false;
    const u = [...f.series['y.u']].filter(Number.isFinite);
    return u.length > 10 && Math.max(...u) - Math.min(...u) > 0.01;
  }, picked, 'the scope drawing the picked channels');
  const signals = await page.evaluate(() => window.piezoloop.signals.map((s) => `${s.name} ${s.unit}`));
  check(drawn && JSON.stringify(signals) === JSON.stringify(['y.e um', 'y.u V', 'z.y um']),
    'the picked channels y.e, y.u and z.y are what the scope draws, y.u moving with y\'s wave', JSON.stringify(signals));
  const csvHead = await page.evaluate(async (t) => {
    const f = window.piezoloop.frame;
    const r = await fetch(`/api/scope/csv?t0_s=${f.t0_s}&span_s=${f.span_s}`, { headers: { 'X-Piezoloop-Token': t } });
    return (await r.text()).split('\n')[0];
  }, token);
  check(csvHead === 't_s,y.e_um,y.u_V,z.y_um', 'the CSV of the screen has the picked channels\' columns', csvHead);
  for (const name of choices) {
    const box = page.locator(`#channel-picks input[value="${name}"]`);
    if (before.includes(name)) await box.check(); else await box.uncheck();
  }
  await page.click('#channels-apply');
  const back = await waitFor(page, (p) => JSON.stringify(window.piezoloop.signals.map((s) => s.name).sort()) === JSON.stringify([...p].sort()),
    before, 'the console\'s channels back');
  check(back, 'the console\'s channels recorded again', JSON.stringify(before));
}

// `commission --axes all` from the page, on the XYZ scenario's simulated
// stage (seconds; on the board it takes minutes): axis together with axes
// is refused at axis; then every axis verified, the coupling reduced, the
// tables the result's and each axis's figures served.
async function commissionAxesFromPage(page, token) {
  check(await page.isVisible('#commission-axes-box'), 'the commissioning form offers every axis at once on a board of axes');
  const both = await page.evaluate(async (t) => {
    const r = await fetch('/api/commission/start', { method: 'POST', headers: { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer,
      'Content-Type': 'application/json' }, body: JSON.stringify({ range_um: 10, on: 'simulator', axes: 'all', axis: 'x' }) });
    return [r.status, (await r.json()).field];
  }, token);
  check(JSON.stringify(both) === '[400,"axis"]', 'axis with axes is refused naming axis', JSON.stringify(both));
  await page.selectOption('#commission [name="on"]', 'simulator');
  await page.fill('#commission [name="range_um"]', '10');
  await page.check('#commission [name="axes"]');
  await page.click('#commission-start');
  if (!await waitFor(page, () => { const j = window.piezoloop.jobs.commission; return j && j.result && j.progress && ['done', 'failed'].includes(j.progress.state); },
    null, 'the axes\' commissioning ends', 120000)) return;
  const res = await page.evaluate(() => window.piezoloop.jobs.commission.result);
  const names = Object.keys(res.axes || {});
  check(JSON.stringify(names) === '["x","y","z"]' && res.verified === true && res.decoupled === true && res.on === 'simulator',
    'commission --axes all from the page: x, y and z verified and decoupled on the simulated stage', JSON.stringify({ names, verified: res.verified, decoupled: res.decoupled }));
  const chosen = await page.$$eval('#commission-axes td[data-key="chosen"]', (tds) => tds.map((td) => JSON.parse(td.dataset.value)));
  const reductions = await page.$$eval('#commission-coupling td[data-key="reduction"]', (tds) => tds.map((td) => JSON.parse(td.dataset.value)));
  const fastest = await page.$$eval('#commission-axes td[data-key="fastest_triangle.up_to_Hz"]', (tds) => tds.map((td) => JSON.parse(td.dataset.value)));
  check(JSON.stringify(chosen) === JSON.stringify(names.map((a) => res.axes[a].chosen)) &&
    JSON.stringify(fastest) === JSON.stringify(names.map((a) => res.axes[a].fastest_triangle.up_to_Hz)) &&
    JSON.stringify(reductions) === JSON.stringify(Object.keys(res.coupling.before_db).map((pair) => res.coupling.reduction_db[pair] ?? null)),
  'the page\'s tables are the result\'s: each axis\'s controller, its fastest triangle within 1 % and the coupling\'s reduction per pair',
  JSON.stringify({ chosen, fastest, reductions }));
  const figures = await page.evaluate(async ([t, fs]) => Promise.all(fs.map(async (f) => {
    const r = await fetch(`/api/commission/figure/${f}?token=${t}`);
    return [f, r.status, r.headers.get('content-type')];
  })), [token, res.figures]);
  check(res.figures.includes('z/frf.png') && figures.every(([, s, ct]) => s === 200 && ct === 'image/png'),
    'each axis\'s figures served (AXIS/frf.png ...)', JSON.stringify(figures));
  const outside = await page.evaluate(async (t) => (await fetch(`/api/commission/figure/w/frf.png?token=${t}`)).status, token);
  check(outside === 404, 'a figure of no axis is not served (404)', String(outside));
  if (commissionShot) {  // axes mode: docs/img/console_commission_axes.png, the panel down to its figures
    const panel = await page.locator('#commission-panel').boundingBox();
    const figs = await page.locator('#commission-figures').boundingBox();
    // boundingBox is in the viewport; a full-page clip is in the page.
    const [sx, sy] = await page.evaluate(() => [window.scrollX, window.scrollY]);
    await page.screenshot({ path: commissionShot, fullPage: true, clip: { x: panel.x + sx, y: panel.y + sy, width: panel.width, height: figs.y - panel.y } });
  }
}

async function main() {
  if (mode === 'axes') return axesConsole();
  let device = null;
  let ui;
  let frf = null;
  let stepLoops = null;
  let commissioned = null;
  if (mode === 'device') {
    const emu = start(['emulate', '--board', 'qemu-m7', '--scenario', scenario]);
    device = JSON.parse((await firstLines(emu, /^\{.*\}\n/))[0]).device;
    const set = run(['--device', device, 'set', '--scenario', scenario, '--case', 'dahl_ff_K']);
    if (!check(set.code === 0, 'the Ahmad2020 controller is set on the emulated board', set.err)) return;
    ui = start(['--device', device, 'ui', '--seat-answer-s', '120']);
  } else {
    ui = start(['ui', '--scenario', scenario, '--case', 'dahl_ff_K', '--seat-answer-s', '120']);
  }
  const started = await firstLines(ui, /console of tcp:127\.0\.0\.1:(\d+) at\s+(http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]{32})/);
  const boardPort = Number(started[1]);
  const url = started[2];
  const port = Number(url.match(/:(\d+)\//)[1]);
  const token = url.split('token=')[1];
  console.log(`console at ${url.replace(token, '<token>')}`);

  // ---- the gate ----
  const host = `127.0.0.1:${port}`;
  check((await request(port, '/')).status === 403, 'the page without the token is refused (403)');
  check((await request(port, '/?token=0123456789abcdef0123456789abcdef')).status === 403, 'a wrong token is refused (403)');
  check((await request(port, `/api/stream?token=${token}`, { Origin: 'http://evil.example' })).status === 403,
    'the live stream from a foreign Origin is refused, token or not (403)');
  check((await request(port, `/?token=${token}`, { Host: `evil.example:${port}` })).status === 403,
    'a foreign Host (DNS rebinding) is refused (403)');
  check((await request(port, `/api/params?token=${token}`, { Origin: `http://${host}` })).status === 200,
    'the same request from the page\'s own Origin passes');

  const browser = await chromium.launch({ executablePath: chromiumPath, args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'] });
  try {
    const context = await browser.newContext({ viewport: { width: 1400, height: 1000 }, acceptDownloads: true });
    const page = await context.newPage();
    const response = await page.goto(url);
    check(response.status() === 200, 'the page loads with the token');
    if (!await waitFor(page, () => window.piezoloop.ready && window.piezoloop.framesDrawn > 3, null, 'the scope draws frames')) return;
    check(true, 'the scope draws frames from the board');

    // ---- one controller, others watch ----
    const watcher = await context.newPage();
    await watcher.goto(url);
    await waitFor(watcher, () => window.piezoloop.ready, null, 'the second page loads');
    check(await page.evaluate(() => window.piezoloop.controls), 'the first page took the free control seat');
    // Taking control: the watcher asks, the controlling page is asked and
    // keeps it (the timeout that passes the seat is checked in test_control_seat).
    await watcher.click('#claim');
    await waitFor(page, () => !document.getElementById('seat-request').hidden, null, 'the controlling page is asked');
    check(await page.isVisible('#seat-request') && (await watcher.textContent('#seat')).includes('asking the controlling page') &&
      /passes in \d+ s/.test(await page.textContent('#seat-request-left')),
      'a watcher asks for control: the controlling page is asked (with the seconds left), the watcher says it is asking');
    await page.click('#keep');
    await waitFor(watcher, () => document.getElementById('action-error').textContent.includes('kept control'), null, 'the refusal on the watcher');
    // The controlling page closes its request when the next seat state reaches it (its own stream).
    await waitFor(page, () => document.getElementById('seat-request').hidden, null, 'the request closed on the controlling page');
    check(!(await watcher.evaluate(() => window.piezoloop.controls)) && await page.evaluate(() => window.piezoloop.controls) &&
      (await watcher.textContent('#action-error')).includes('kept control') && !(await page.isVisible('#seat-request')),
      'Keep control: the watcher is refused and watches, the controlling page keeps the seat');
    const forced = await watcher.evaluate(async (t) => {
      const r = await fetch('/api/arm', { method: 'POST', headers: { 'X-Piezoloop-Token': t, 'X-Piezoloop-Viewer': window.piezoloop.viewer } });
      return r.status;
    }, token);
    check(forced === 409, 'a command from the watching page is refused (409)', `status ${forced}`);
    check(await watcher.isDisabled('#arm'), 'the watching page\'s Arm button is disabled');
    // Asked again, the controlling page gives the seat; then it takes it back once freed.
    await watcher.click('#claim');
    await waitFor(page, () => !document.getElementById('seat-request').hidden, null, 'asked again');
    await page.click('#give');
    await waitFor(watcher, () => window.piezoloop.controls, null, 'the watcher controls');
    await waitFor(page, () => !window.piezoloop.controls, null, 'the first page watches');
    check(await watcher.evaluate(() => window.piezoloop.controls) && !(await page.evaluate(() => window.piezoloop.controls)) &&
      await page.isDisabled('#arm') && !(await watcher.isDisabled('#arm')), 'Give control: the asking page controls, the other watches');
    await watcher.click('#release');
    await page.click('#claim');
    await waitFor(page, () => window.piezoloop.controls, null, 'the first page controls again');
    check(await page.evaluate(() => window.piezoloop.controls), 'a freed seat is taken at once by the page that claims it');

    // ---- arm / disarm round trip ----
    await page.click('#arm');
    await waitFor(page, () => window.piezoloop.status && window.piezoloop.status.status.armed === true, null, 'armed');
    check(await page.evaluate(() => window.piezoloop.status.status.armed), 'Arm: the board reports armed');
    await waitFor(watcher, () => window.piezoloop.status && window.piezoloop.status.status.armed === true, null, 'watcher sees armed');
    check(await watcher.evaluate(() => window.piezoloop.status.status.armed), 'the watching page sees the board armed');
    await page.click('#disarm');
    await waitFor(page, () => window.piezoloop.status.status.armed === false, null, 'disarmed');
    check(!(await page.evaluate(() => window.piezoloop.status.status.armed)), 'Disarm: the board reports disarmed');

    // ---- a refused parameter ----
    if (mode === 'device') await refusedLimit(page);  // --scenario: the same page, fewer checks

    // ---- a wave, the scope's samples ----
    await page.selectOption('#wave [name="trajectory"]', 'triangle');
    await page.fill('#wave [name="frequency_Hz"]', '20');
    await page.fill('#wave [name="amplitude_um"]', '4');
    await page.check('#wave [name="arm"]');
    await page.click('#wave button[type="submit"]');
    await waitFor(page, () => window.piezoloop.status.status.wave_running && window.piezoloop.status.status.armed, null, 'wave running');
    check(await page.evaluate(() => window.piezoloop.status.status.wave_running), 'Start wave: the board runs the wave, armed');
    const rate = await page.evaluate(() => window.piezoloop.rate_Hz);
    await page.selectOption('#span', '0.05');
    // The measured page in front: a browser pauses the drawing of background tabs.
    await watcher.close();
    await page.bringToFront();
    await page.waitForTimeout(1000);
    const t0 = Date.now();
    const drawnBefore = await page.evaluate(() => window.piezoloop.framesDrawn);
    await page.waitForTimeout(4000);
    const rates = await page.evaluate(() => ({ fps: window.piezoloop.fps, latency: window.piezoloop.latencyMedianMs, speed: window.piezoloop.deviceSpeed }));
    const wall = (Date.now() - t0) / 1000;
    console.log(`figure: scope ${rates.fps.toFixed(1)} frames/s drawn, median host-to-screen latency ${rates.latency} ms ` +
      `(newest sample's arrival at the host to its frame on screen), over ${wall.toFixed(1)} s; the board's record ` +
      `grew ${rates.speed.toFixed(2)} s per wall second`);
    // Frames go on being drawn (on a loaded machine the stream may pause
    // for a few seconds: the rate above is the figure, this the check).
    check(await waitFor(page, (n) => window.piezoloop.framesDrawn > n + 10, drawnBefore, 'frames drawn while the wave runs', 20000),
      'frames keep coming while the wave runs');

    await page.click('#pause');
    await page.waitForTimeout(200);
    const shown = await page.evaluate(() => {
      const f = window.piezoloop.frame;
      const series = {};
      for (const [k, v] of Object.entries(f.series)) series[k] = Array.from(v);
      return { t0_s: f.t0_s, span_s: f.span_s, columns: f.columns, samples: f.samples, series };
    });
    const csv = await page.evaluate(async ([t, f]) => {
      const r = await fetch(`/api/scope/csv?t0_s=${f.t0_s}&span_s=${f.span_s}`, { headers: { 'X-Piezoloop-Token': t } });
      return r.text();
    }, [token, shown]);
    const lines = csv.trim().split('\n');
    const names = lines[0].split(',').slice(1).map((c) => c.replace(/_(um|V)$/, ''));
    const rows = lines.slice(1).map((l) => l.split(',').map(Number));
    check(rows.length === shown.samples && rows.length > 100, 'the CSV export holds the window\'s samples',
      `${rows.length} rows, frame had ${shown.samples}`);
    let mismatches = 0;
    for (let s = 0; s < names.length; ++s) {
      const first = new Array(shown.columns).fill(NaN);
      const second = new Array(shown.columns).fill(NaN);
      const lo = new Array(shown.columns).fill(-1);
      const hi = new Array(shown.columns).fill(-1);
      rows.forEach((r, i) => {
        const c = Math.floor((r[0] - shown.t0_s) / shown.span_s * shown.columns);
        const v = Math.fround(r[s + 1]);
        if (lo[c] < 0 || v < Math.fround(rows[lo[c]][s + 1])) lo[c] = i;
        if (hi[c] < 0 || v > Math.fround(rows[hi[c]][s + 1])) hi[c] = i;
      });
      for (let c = 0; c < shown.columns; ++c) {
        if (lo[c] < 0) continue;
        first[c] = Math.fround(rows[Math.min(lo[c], hi[c])][s + 1]);
        second[c] = Math.fround(rows[Math.max(lo[c], hi[c])][s + 1]);
      }
      const drawn = shown.series[names[s]];
      for (let c = 0; c < shown.columns; ++c) {
        const a = drawn[2 * c];
        const b = drawn[2 * c + 1];
        const same = (x, y) => (Number.isNaN(x) && Number.isNaN(y)) || x === y;
        if (!same(a, first[c]) || !same(b, second[c])) mismatches += 1;
      }
    }
    check(mismatches === 0, 'every column drawn equals the min/max of the exported samples, exactly', `${mismatches} columns differ`);
    const plotHolds = await page.evaluate(() => {
      const f = window.piezoloop.frame;
      const u = document.querySelector('#plot .uplot') && window.piezoloop.frame;
      return u !== null && f.series.y.length === 2 * f.columns;
    });
    check(plotHolds, 'the plot holds two points per pixel column');
    // Two cursors on the paused plot: each the server's nearest recorded
    // sample, which is the exported row at its time; the readout shows them.
    await page.check('#cursors');
    const over = await page.locator('#plot .u-over').boundingBox();
    await page.mouse.click(over.x + over.width * 0.3, over.y + over.height / 2);
    await waitFor(page, () => window.piezoloop.cursors.A, null, 'cursor A');
    await page.mouse.click(over.x + over.width * 0.7, over.y + over.height / 2);
    await waitFor(page, () => window.piezoloop.cursors.B && document.querySelectorAll('#cursor-readout tr').length === 4, null, 'cursor B');
    const cursors = await page.evaluate(() => window.piezoloop.cursors);
    const rowAt = (c) => rows.find((r) => Math.abs(r[0] - c.t_s) < 0.5 / rate);
    const sig = (x, n) => (x === null || x === undefined ? '–' : String(Number(x.toPrecision(n))));
    const onRow = (c) => { const r = rowAt(c); return r && names.every((n, k) => Math.fround(r[k + 1]) === c.values[n]); };
    const expectTimes = shown.t0_s + 0.3 * shown.span_s;
    check(cursors.A && cursors.B && onRow(cursors.A) && onRow(cursors.B) && Math.abs(cursors.A.t_s - expectTimes) < 0.02 * shown.span_s &&
      cursors.B.t_s > cursors.A.t_s, 'the cursors are the recorded samples where the plot was clicked (the exported rows at their times)',
      JSON.stringify(cursors));
    const cells = await page.$$eval('#cursor-readout td', (tds) => tds.map((d) => ({ key: d.dataset.key, value: JSON.parse(d.dataset.value), text: d.textContent })));
    const dtc = cursors.B.t_s - cursors.A.t_s;
    const wantCells = [cursors.A, cursors.B].flatMap((c) => [{ key: 't_s', value: c.t_s, text: sig(c.t_s, 9) }, ...names.map((n) => ({ key: n, value: c.values[n], text: sig(c.values[n], 7) }))])
      .concat([{ key: 'dt_s', value: dtc, text: `${sig(dtc, 6)} s (${sig(1 / dtc, 6)} Hz)` },
        ...names.map((n) => { const d = cursors.B.values[n] - cursors.A.values[n]; return { key: n, value: d, text: sig(d, 7) }; })]);
    check(JSON.stringify(cells) === JSON.stringify(wantCells), 'the readout shows each cursor\'s time and values, Δt and the differences, as the server sent them',
      JSON.stringify(cells).slice(0, 400));
    const dt = rows.slice(1).map((r, i) => r[0] - rows[i][0]);
    check(dt.every((d) => Math.abs(d * rate - 1) < 1e-6), 'the exported window has no tick gap (one sample per loop tick)');
    const r = rows.map((row) => row[1 + names.indexOf('r')]);
    const rMin = Math.min(...r);
    const rMax = Math.max(...r);
    // A 20 Hz triangle over a 50 ms window spans its whole range 0..4 µm (float32 steps).
    check(rMin >= -1e-4 && rMax <= 4 + 1e-4 && rMax - rMin > 3.9, 'r is the page\'s wave: a 4 µm triangle from 0',
      `r in [${rMin}, ${rMax}]`);
    const y = rows.map((row) => row[1 + names.indexOf('y')]);
    check(Math.max(...y) - Math.min(...y) > 3, 'y follows it (the loop tracks the wave)');

    // The spectrum of y over the window on screen: 50 ms of a 20 Hz triangle,
    // one segment of about 500 samples, about 20 Hz apart: the fundamental is the top bin
    // (the Welch estimate itself is checked against scipy in test_psd.cpp).
    await page.selectOption('#psd-signal', 'y');
    await page.click('#psd-update');
    await waitFor(page, () => window.piezoloop.psd, null, 'the spectrum');
    const psd = await page.evaluate(() => window.piezoloop.psd);
    if (psd) {
      const d = psd.density.slice(1);
      const top = psd.frequency_Hz[1 + d.indexOf(Math.max(...d))];
      check(psd.segments === 1 && Math.abs(top - 20) < psd.frequency_Hz[1] / 2, 'the spectrum of y peaks at the wave\'s 20 Hz (the bin nearest it)', `${psd.segments} segments, peak at ${top} Hz`);
      // Two cursors on the spectrum: bins of the server's estimate, and Δf.
      await page.check('#psd-cursors');
      const box = await page.locator('#psd-plot .u-over').boundingBox();
      await page.mouse.click(box.x + box.width * 0.25, box.y + box.height / 2);
      await page.mouse.click(box.x + box.width * 0.6, box.y + box.height / 2);
      await waitFor(page, () => window.piezoloop.psdCursors.B && document.querySelectorAll('#psd-cursor-readout tr').length === 4, null, 'the spectrum cursors');
      const pc = await page.evaluate(() => window.piezoloop.psdCursors);
      const pcells = await page.$$eval('#psd-cursor-readout td', (tds) => tds.map((d) => JSON.parse(d.dataset.value)));
      const okBins = ['A', 'B'].every((n) => pc[n] && pc[n].f_Hz === psd.frequency_Hz[pc[n].bin] && pc[n].density === psd.density[pc[n].bin]);
      check(okBins && pc.B.bin > pc.A.bin && JSON.stringify(pcells.slice(0, 5)) === JSON.stringify([pc.A.f_Hz, pc.A.density, pc.B.f_Hz, pc.B.density, pc.B.f_Hz - pc.A.f_Hz]),
        'the spectrum\'s cursors are bins of the server\'s estimate, with Δf between them', JSON.stringify(pc));
    }

    if (screenshot) await page.screenshot({ path: screenshot, fullPage: false });

    await page.click('#pause');

    // Triggered: r rising through 2 µm, a tenth of the way into the window.
    await page.selectOption('#mode', 'triggered');
    await page.fill('#trigger-level', '2');
    await page.dispatchEvent('#trigger-level', 'change');
    await page.selectOption('#trigger-signal', 'r');
    await page.selectOption('#edge', 'rising');
    await waitFor(page, () => window.piezoloop.frame.mode === 'triggered' && window.piezoloop.frame.trigger_t_s !== null, null, 'a triggered frame');
    const trig = await page.evaluate(() => {
      const f = window.piezoloop.frame;
      return { t0_s: f.t0_s, span_s: f.span_s, columns: f.columns, mode: f.mode, trigger_t_s: f.trigger_t_s, r: Array.from(f.series.r) };
    });
    if (trig.mode === 'triggered') {
      const c = Math.floor((trig.trigger_t_s - trig.t0_s) / trig.span_s * trig.columns);
      // The crossing sample is drawn in column c (>= 2 µm); the sample before it, in an earlier column, is below.
      const inC = [trig.r[2 * c], trig.r[2 * c + 1]].filter((v) => !Number.isNaN(v));
      const before = trig.r.slice(0, 2 * c).filter((v) => !Number.isNaN(v));
      const prev = before[before.length - 1];
      check(Math.abs(trig.trigger_t_s - trig.t0_s - 0.1 * trig.span_s) < 1e-9 && inC.length > 0 && inC[0] >= 2 && prev < 2,
        'triggered: r crosses 2 µm rising a tenth of the way into the window', `column ${c}: ${inC}, before: ${prev}`);
    }
    await page.selectOption('#mode', 'roll');
    await page.click('#stop');
    await waitFor(page, () => !window.piezoloop.status.status.wave_running, null, 'stopped');
    check(!(await page.evaluate(() => window.piezoloop.status.status.wave_running)), 'Stop: the wave stops');
    await page.click('#disarm');
    await waitFor(page, () => window.piezoloop.status.status.armed === false, null, 'disarmed at the end');

    if (mode === 'device') frf = await frequencyResponse(page, context, url, token);
    if (mode === 'device') stepLoops = await stepsAndLoops(page, context, url);
    if (mode === 'scenario') commissioned = await commissionFromPage(page, context, url);
  } finally {
    await browser.close();
  }
  const code = await stop(ui);
  check(code === 0, 'the console ends cleanly on SIGTERM', `exit ${code}: ${ui.stderrText}`);
  if (!device) {
    const refused = await new Promise((resolve) => {
      const c = net.connect(boardPort, '127.0.0.1');
      c.on('connect', () => { c.destroy(); resolve(false); });
      c.on('error', (e) => resolve(e.code === 'ECONNREFUSED'));
    });
    check(refused, 'the emulated board the console started has stopped with it');
  }
  if (device) {
    const limits = run(['--device', device, 'get', 'limits']);
    const held = limits.code === 0 ? JSON.parse(limits.out).u_max_V : NaN;
    check(held === 10, 'the board still holds u_max_V = 10 V after the refused 50', limits.err || String(held));
  }
  if (device && frf) {
    // The same request from the CLI on the same board, its stage restarted at rest too.
    const dir = mkdtempSync(path.join(os.tmpdir(), 'console-frf-'));
    const out = path.join(dir, 'frf.json');
    const r = frfRequest;
    const cli = run(['--device', device, 'measure', 'frf', '--from-hz', r.from_Hz, '--to-hz', r.to_Hz, '--amplitude-v', r.amplitude_V,
      '--bias-v', r.bias_V, '--periods', r.periods, '--transient-periods', r.transient_periods, '--restart-stage', '--out', out].map(String));
    if (check(cli.code === 0, '`piezoloop measure frf` with the same request on the same board', cli.err)) {
      const j = JSON.parse(readFileSync(out, 'utf8'));
      check(j.log_hash === frf.log_hash, 'the console\'s measurement has the CLI\'s log hash (the same recording)', `${frf.log_hash} vs ${j.log_hash}`);
      check(JSON.stringify(j.frequency_Hz) === JSON.stringify(frf.frequency_Hz) && JSON.stringify(j.response) === JSON.stringify(frf.response) &&
        JSON.stringify(j.std_db) === JSON.stringify(frf.std_dB), 'and the CLI\'s response and std_db at every line, bit for bit');
      const tf = run(['identify', 'tf', '--frf', out, '--order', r.fit_order]);
      const model = tf.code === 0 ? JSON.parse(tf.out).model : {};
      check(JSON.stringify(model.num) === JSON.stringify(frf.fit.model.num) && JSON.stringify(model.den) === JSON.stringify(frf.fit.model.den),
        '`identify tf --order 6/5` on the CLI\'s response gives the console\'s fitted model, coefficient for coefficient', tf.err);
    }
    rmSync(dir, { recursive: true, force: true });
  }

  if (commissioned) {
    // The same commissioning from the CLI: the simulator's run, figure for figure.
    const dir = mkdtempSync(path.join(os.tmpdir(), 'console-commission-'));
    const c = run(['commission', '--scenario', scenario, '--range-um', String(commissionRequest.range_um), '--out', dir]);
    if (check(c.code === 0 || c.code === 1, '`piezoloop commission --scenario` with the same request', c.err)) {
      const j = JSON.parse(c.out);
      const same = ['chosen', 'verified', 'candidates', 'fits', 'safety', 'verification', 'log', 'bandwidth_Hz', 'model', 'centre_um']
        .filter((k) => JSON.stringify(j[k]) !== JSON.stringify(commissioned[k]));
      check(same.length === 0, 'the console\'s commissioning is the CLI\'s: chosen, candidates, fits, safety steps, verification and log, bit for bit',
        `differ: ${same.join(', ')}`);
    }
    rmSync(dir, { recursive: true, force: true });
  }
  if (device && stepLoops && stepLoops.step) {
    // The same step and loops from the CLI on the same board, restarted at rest too.
    const dir = mkdtempSync(path.join(os.tmpdir(), 'console-step-'));
    const s = stepRequest;
    const out = path.join(dir, 'step.json');
    const cli = run(['--device', device, 'measure', 'step', '--step-v', s.step_V, '--bias-v', s.bias_V, '--duration-s', s.duration_s,
      '--restart-stage', '--out', out].map(String));
    if (check(cli.code === 0, '`piezoloop measure step` with the same request on the same board', cli.err)) {
      const j = JSON.parse(readFileSync(out, 'utf8'));
      const st = stepLoops.step;
      check(j.log_hash === st.log_hash && ['initial_um', 'final_value_um', 'overshoot_pct', 'peak_um', 'rise_time_s', 'settling_time_s'].every((k) => j[k] === st[k]) &&
        JSON.stringify(j.response_um) === JSON.stringify(st.response_um), 'the console\'s step has the CLI\'s log hash, response and figures, bit for bit',
        `${st.log_hash} vs ${j.log_hash}`);
    }
    if (stepLoops.loops) {
      const l = loopsRequest;
      const lj = path.join(dir, 'loops.json');
      const lc = run(['--device', device, 'measure', 'loops', '--amplitudes-v', l.amplitudes_V.replace(/\s/g, ''), '--frequency-hz', l.frequency_Hz,
        '--cycles', l.cycles, '--restart-stage', '--out', path.join(dir, 'loops.csv'), '--json', lj].map(String));
      if (check(lc.code === 0, '`piezoloop measure loops` with the same request on the same board', lc.err)) {
        const j = JSON.parse(readFileSync(lj, 'utf8'));
        // The first amplitude starts at rest on both; the next ones start from
        // where the one before left the stage after the host's pause between
        // them, which differs from run to run.
        check(JSON.stringify(j.loops[0]) === JSON.stringify(stepLoops.loops.loops[0]) && j.loops.length === stepLoops.loops.loops.length,
          'the console\'s first loop (from rest) has the CLI\'s figures, bit for bit',
          `${JSON.stringify(j.loops)} vs ${JSON.stringify(stepLoops.loops.loops)}`);
      }
    }
    rmSync(dir, { recursive: true, force: true });
  }
}

try {
  await main();
} catch (e) {
  check(false, 'the test ran to its end', e.stack);
} finally {
  for (const p of children.reverse()) await stop(p);
}
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
