// rattlesweep explore: the page. Settings go to the server (/api/run, /api/map) on every
// change; the run comes back as series drawn in a three.js view and canvas plots.
import * as THREE from './vendor/three.min.js';

const $ = (id) => document.getElementById(id);
const session = (crypto.randomUUID ? crypto.randomUUID() : String(Math.random()).slice(2));
const state = { run: null, runs: 0, requests: 0, map: null, config: null, frame: 0,
                playing: true, tPlay: 0, lastError: null, latencies: [] };
window.explorer = state;  // read by the browser tests

const CONTROLS = ['preset', 'a', 'b', 'c', 'mass', 'delta_deg', 'masses', 'spin', 'roll_deg',
                  'pitch_deg', 'mu', 'mu_static', 'mu_spin', 'mu_roll', 'damping', 't_end'];
const OUTCOME_COLOURS = ['#9db4c8', '#f28e2b', '#c0392b', '#f1ce63', '#222222', '#8e44ad',
                         '#ff00ff'];

// ---------------------------------------------------------------- settings and runs
function settings() {
  const s = {};
  for (const k of CONTROLS) {
    const el = $(k);
    if (k === 'masses') {
      s.masses = el.value.split('\n').map((l) => l.trim()).filter((l) => l)
        .map((l) => l.split(/[\s,;]+/));
    } else {
      s[k] = el.value.trim();
    }
  }
  return s;
}

function showErrors(error, control) {
  for (const el of document.querySelectorAll('.err')) {
    if (el.id !== 'err-map') el.textContent = '';
  }
  for (const el of document.querySelectorAll('input.bad, textarea.bad')) el.classList.remove('bad');
  if (!error) return;
  const box = $('err-' + control) || $('err-general');
  box.textContent = error;
  if ($(control)) $(control).classList.add('bad');
}

async function post(path, body) {
  const r = await fetch(path, { method: 'POST', headers: { 'Content-Type': 'application/json' },
                                body: JSON.stringify({ session, ...body }) });
  return [r.status, r];
}

let runSeq = 0;
let runTimer = null;
function scheduleRun() {
  clearTimeout(runTimer);
  runTimer = setTimeout(doRun, 60);
}

async function doRun() {
  const seq = ++runSeq;
  const t0 = performance.now();
  state.requests += 1;
  $('status').textContent = 'running…';
  let status, r;
  try {
    [status, r] = await post('/api/run', { settings: settings() });
  } catch (e) {
    $('status').textContent = 'server unreachable';
    return;
  }
  if (seq !== runSeq || status === 409) return;  // a newer change is on its way
  const data = await r.json();
  if (status !== 200) {
    state.lastError = data.error;
    showErrors(data.error, data.control || 'general');
    $('status').textContent = 'refused: see the message by the control';
    return;
  }
  state.lastError = null;
  showErrors(null);
  state.latencies.push(performance.now() - t0);
  loadRun(data);
  $('status').textContent = `run ${state.runs} in ${(performance.now() - t0).toFixed(0)} ms`;
}

function loadRun(data) {
  const n = data.t.length;
  const p = data.position;
  data.n = n;
  state.run = data;
  state.runs += 1;
  state.tPlay = 0;
  state.frame = 0;
  $('scrub').max = n - 1;
  $('scrub').value = 0;
  $('python').textContent = data.python;
  $('download-nc').href = `/api/run.nc?session=${session}&n=${state.runs}`;
  const s = data.summary;
  const rev = s.first_reversal_time === null ? 'no reversal'
    : `first reversal at ${s.first_reversal_time.toFixed(3)} s`;
  $('summary').textContent = `${rev}; reversals ${s.n_reversals}; final spin `
    + `${s.final_spin.toFixed(3)} rad/s; slipping ${(100 * s.slip_fraction).toFixed(0)} %; `
    + `status ${s.status}` + (data.warnings.length ? ' ⚠ ' + data.warnings.join('; ') : '');
  buildBody(data.body);
  const pts = [];
  for (let i = 0; i < n; i++) pts.push(data.contact[2 * i], data.contact[2 * i + 1], 0.0002);
  track.geometry.dispose();
  track.geometry = new THREE.BufferGeometry();
  track.geometry.setAttribute('position', new THREE.Float32BufferAttribute(pts, 3));
  const L = Math.max(data.body.a, data.body.b);
  grid.scale.set(8 * L, 8 * L, 8 * L);
  grid.position.x = G0(p).x; grid.position.y = G0(p).y;
  if (!cam.dist || Math.abs(Math.log(L / cam.L)) > 0.7) cam.dist = 3.6 * L;  // a new scale
  cam.L = L;
  state.spinScale = 0.8 * L / Math.max(1e-9, ...data.spin.map((v) => Math.abs(v || 0)));
  for (const c of plots) drawPlotBase(c);
  showFrame(0);
}
const G0 = (p) => ({ x: p[0], y: p[1], z: p[2] });

// the camera orbits the body (drag) and zooms (wheel), following it over the floor
const cam = { az: -0.9, el: 0.42, dist: 0, L: 0.05 };
function placeCamera(x, y) {
  camera.position.set(x + cam.dist * Math.cos(cam.el) * Math.cos(cam.az),
                      y + cam.dist * Math.cos(cam.el) * Math.sin(cam.az),
                      cam.dist * Math.sin(cam.el));
  camera.lookAt(x, y, 0);
}

// ---------------------------------------------------------------- the 3-D view
const view = $('view');
const renderer = new THREE.WebGLRenderer({ canvas: view, antialias: true, preserveDrawingBuffer: true });
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xdde4ea);
const camera = new THREE.PerspectiveCamera(40, 1, 0.0005, 50);
camera.up.set(0, 0, 1);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1, -1, 2);
scene.add(sun);
const floor = new THREE.Mesh(new THREE.PlaneGeometry(10, 10),
  new THREE.MeshStandardMaterial({ color: 0xc8ccd0, roughness: 1 }));
scene.add(floor);
const grid = new THREE.GridHelper(1, 20, 0x8899aa, 0xaab4be);
grid.rotateX(Math.PI / 2);  // in the floor plane z = 0
grid.position.z = 0.00005;
scene.add(grid);
const track = new THREE.Line(new THREE.BufferGeometry(),
  new THREE.LineBasicMaterial({ color: 0x1f5fa8 }));
scene.add(track);
const bodyGroup = new THREE.Group();
scene.add(bodyGroup);
let bodyMesh = null;
const arrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 0.01, 0xcc2222);
scene.add(arrow);

function buildBody(b) {
  if (bodyMesh) { bodyGroup.remove(bodyMesh); }
  bodyMesh = new THREE.Group();
  const mat = new THREE.MeshStandardMaterial({ color: 0xe8a33d, roughness: 0.55, side: THREE.DoubleSide });
  const shell = new THREE.SphereGeometry(1, 48, 24, 0, 2 * Math.PI,
    b.full_ellipsoid ? 0 : Math.PI / 2, b.full_ellipsoid ? Math.PI : Math.PI / 2);
  shell.rotateX(Math.PI / 2);  // poles on z; the kept half has z < 0
  const m = new THREE.Mesh(shell, mat);
  m.scale.set(b.a, b.b, b.c);
  bodyMesh.add(m);
  if (!b.full_ellipsoid) {
    const top = new THREE.Mesh(new THREE.CircleGeometry(1, 48),
      new THREE.MeshStandardMaterial({ color: 0xf4d9a8, roughness: 0.8, side: THREE.DoubleSide }));
    top.scale.set(b.a, b.b, 1);
    bodyMesh.add(top);
  }
  // a stripe along body x on top, so that the turning shows
  const stripe = new THREE.Mesh(new THREE.PlaneGeometry(2 * b.a * 0.9, b.b * 0.18),
    new THREE.MeshBasicMaterial({ color: 0x7a2e0e, side: THREE.DoubleSide }));
  stripe.position.set(b.a * 0.0, 0, 0.0002 + (b.full_ellipsoid ? b.c : 0));
  bodyMesh.add(stripe);
  bodyMesh.position.set(-b.com[0], -b.com[1], -b.com[2]);  // the group sits at G
  bodyGroup.add(bodyMesh);
}

function showFrame(i) {
  const r = state.run;
  if (!r) return;
  i = Math.max(0, Math.min(r.n - 1, i));
  state.frame = i;
  const q = r.quaternion, p = r.position;
  bodyGroup.position.set(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  placeCamera(p[3 * i], p[3 * i + 1]);
  bodyGroup.quaternion.set(q[4 * i + 1], q[4 * i + 2], q[4 * i + 3], q[4 * i]);
  const w = r.spin[i] || 0;
  const len = Math.max(1e-6, Math.abs(w) * state.spinScale);
  // above the body: up for counter-clockwise spin, down onto it for clockwise
  arrow.position.set(p[3 * i], p[3 * i + 1], p[3 * i + 2] + r.body.c * 0.8 + (w >= 0 ? 0 : len));
  arrow.setDirection(new THREE.Vector3(0, 0, w >= 0 ? 1 : -1));
  arrow.setLength(len, 0.3 * Math.min(len, r.body.a), 0.15 * Math.min(len, r.body.a));
  arrow.setColor(w >= 0 ? 0x2266cc : 0xcc2222);
  track.geometry.setDrawRange(0, i + 1);
  $('scrub').value = i;
  $('clock').textContent = `${r.t[i].toFixed(2)} s`;
  for (const c of plots) drawCursor(c);
  renderer.render(scene, camera);
}

let drag = null;
view.addEventListener('pointerdown', (ev) => { drag = [ev.clientX, ev.clientY]; view.setPointerCapture(ev.pointerId); });
view.addEventListener('pointerup', () => { drag = null; });
view.addEventListener('pointermove', (ev) => {
  if (!drag) return;
  cam.az -= 0.01 * (ev.clientX - drag[0]);
  cam.el = Math.max(0.05, Math.min(1.5, cam.el + 0.01 * (ev.clientY - drag[1])));
  drag = [ev.clientX, ev.clientY];
  showFrame(state.frame);
});
view.addEventListener('wheel', (ev) => {
  ev.preventDefault();
  cam.dist = Math.max(1.2 * cam.L, Math.min(30 * cam.L, cam.dist * Math.exp(0.001 * ev.deltaY)));
  showFrame(state.frame);
}, { passive: false });

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h, false);
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  for (const c of plots) { c.width = c.clientWidth; c.height = c.clientHeight; drawPlotBase(c); }
  if (state.run) showFrame(state.frame);
  drawMap();
}

let lastWall = null;
function tick(now) {
  const r = state.run;
  if (r && state.playing && lastWall !== null) {
    const T = r.t[r.n - 1];
    state.tPlay += (now - lastWall) / 1000 * Number($('speed').value);
    if (state.tPlay > T) state.tPlay = 0;
    showFrame(frameAt(state.tPlay));
  }
  lastWall = now;
  requestAnimationFrame(tick);
}

function frameAt(t) {
  const ts = state.run.t;
  let lo = 0, hi = ts.length - 1;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (ts[mid] < t) lo = mid + 1; else hi = mid; }
  return lo;
}

// ---------------------------------------------------------------- plots
const plots = [...document.querySelectorAll('canvas.plot')];
const MIN_SPAN = { spin: 0.1, tilt_deg: 0.5, energy: 0, slip_speed: 1e-3 };
function plotFrame(c) {
  const r = state.run, t = r.t;
  const v = r[c.dataset.series].filter((x) => x !== null);
  let lo = Math.min(...v), hi = Math.max(...v);
  // a nearly constant series (energy without friction losses) is drawn flat, not as noise
  const span = Math.max(MIN_SPAN[c.dataset.series] || 0, 1e-4 * Math.max(Math.abs(lo), Math.abs(hi)));
  if (!(hi - lo >= span)) { const mid = (hi + lo) / 2; lo = mid - span / 2; hi = mid + span / 2; }
  const pad = 0.05 * (hi - lo);
  return { x0: 70, x1: c.width - 8, y0: 8, y1: c.height - 18, lo: lo - pad, hi: hi + pad,
           T: t[t.length - 1] || 1 };
}

function drawPlotBase(c) {
  const r = state.run;
  const ctx = c.getContext('2d');
  ctx.clearRect(0, 0, c.width, c.height);
  if (!r) return;
  const f = plotFrame(c);
  const X = (t) => f.x0 + (f.x1 - f.x0) * t / f.T;
  const Y = (y) => f.y1 - (f.y1 - f.y0) * (y - f.lo) / (f.hi - f.lo);
  ctx.fillStyle = 'rgba(255, 160, 60, 0.35)';
  for (const [a, b] of r.slips) ctx.fillRect(X(a), f.y0, Math.max(1, X(b) - X(a)), f.y1 - f.y0);
  ctx.strokeStyle = '#999'; ctx.lineWidth = 1;
  ctx.strokeRect(f.x0, f.y0, f.x1 - f.x0, f.y1 - f.y0);
  if (f.lo < 0 && f.hi > 0) {
    ctx.strokeStyle = '#ccc'; ctx.beginPath(); ctx.moveTo(f.x0, Y(0)); ctx.lineTo(f.x1, Y(0)); ctx.stroke();
  }
  const ys = r[c.dataset.series];
  ctx.strokeStyle = '#1f5fa8'; ctx.lineWidth = 1.5; ctx.beginPath();
  let pen = false;
  for (let i = 0; i < r.n; i++) {
    if (ys[i] === null) { pen = false; continue; }
    if (pen) ctx.lineTo(X(r.t[i]), Y(ys[i])); else ctx.moveTo(X(r.t[i]), Y(ys[i]));
    pen = true;
  }
  ctx.stroke();
  ctx.fillStyle = '#333'; ctx.font = '11px sans-serif';
  ctx.fillText(c.dataset.label, f.x0 + 4, f.y0 + 11);
  const digits = Math.min(8, 3 + Math.max(0, Math.round(Math.log10(
    Math.max(Math.abs(f.hi), Math.abs(f.lo)) / (f.hi - f.lo)))));
  ctx.fillText(fmt(f.hi, digits), 2, f.y0 + 9);
  ctx.fillText(fmt(f.lo, digits), 2, f.y1);
  ctx.fillText('0', f.x0, c.height - 4);
  ctx.fillText(`${fmt(f.T)} s`, f.x1 - 34, c.height - 4);
  c._base = ctx.getImageData(0, 0, c.width, c.height);
  c._frame = f;
}

function drawCursor(c) {
  const r = state.run;
  if (!r || !c._base) return;
  const ctx = c.getContext('2d');
  ctx.putImageData(c._base, 0, 0);
  const f = c._frame;
  const x = f.x0 + (f.x1 - f.x0) * r.t[state.frame] / f.T;
  ctx.strokeStyle = '#c00'; ctx.lineWidth = 1.5;
  ctx.beginPath(); ctx.moveTo(x, f.y0); ctx.lineTo(x, f.y1); ctx.stroke();
}

function fmt(v, digits = 3) {
  const a = Math.abs(v);
  return (a !== 0 && (a < 1e-2 || a >= 1e4)) ? v.toExponential(digits - 2) : v.toPrecision(digits);
}

for (const c of plots) {
  c.addEventListener('click', (ev) => {
    if (!state.run || !c._frame) return;
    const f = c._frame, rect = c.getBoundingClientRect();
    const t = (ev.clientX - rect.left - f.x0) / (f.x1 - f.x0) * f.T;
    state.tPlay = Math.max(0, t);
    showFrame(frameAt(state.tPlay));
  });
}

// ---------------------------------------------------------------- the map
function mapRequest() {
  const ax = (k) => ({ param: $(`map-${k}-param`).value, start: $(`map-${k}-start`).value,
                       stop: $(`map-${k}-stop`).value, num: $(`map-${k}-num`).value });
  return { settings: settings(), map: { x: ax('x'), y: ax('y'), levels: $('map-levels').value } };
}

let mapPoll = null;
async function startMap() {
  clearTimeout(mapPoll);
  $('err-map').textContent = '';
  const [status, r] = await post('/api/map', mapRequest());
  const data = await r.json();
  if (status !== 200) { $('err-map').textContent = data.error; return; }
  state.mapStarted = performance.now();
  showMap(data);
}

function showMap(m) {
  state.map = m;
  $('map-bar').style.width = `${(100 * m.progress).toFixed(1)}%`;
  const what = m.done ? `done: ${m.simulated} launches simulated in ${m.seconds.toFixed(1)} s`
    : `level ${m.level} of ${m.levels}: ${m.level_done} / ${m.level_points} launches`;
  $('map-info').textContent = `${m.x.values.length} × ${m.y.values.length} points; ${what}. `
    + 'Click a point to load its launch.';
  $('map-note').textContent = m.boundary_note;
  drawMap();
  if (!m.done) mapPoll = setTimeout(pollMap, 250);
}

async function pollMap() {
  const r = await fetch(`/api/map?session=${session}`);
  if (r.status === 200) showMap(await r.json());
}

function mapFrame() {
  const c = $('map-canvas');
  return { c, x0: 52, x1: c.width - 8, y0: 8, y1: c.height - 34 };
}

function drawMap() {
  const m = state.map, c = $('map-canvas');
  c.width = c.clientWidth; c.height = c.clientHeight;
  const { x0, x1, y0, y1 } = mapFrame();
  const ctx = c.getContext('2d');
  ctx.clearRect(0, 0, c.width, c.height);
  if (!m) return;
  const nx = m.x.values.length, ny = m.y.values.length;
  const w = (x1 - x0) / nx, h = (y1 - y0) / ny;
  const X1 = x1, Y1 = y1;
  for (let j = 0; j < ny; j++) {
    for (let i = 0; i < nx; i++) {
      const o = m.outcome[j][i];
      ctx.fillStyle = o < 0 ? '#eeeeee' : OUTCOME_COLOURS[o];
      ctx.fillRect(x0 + i * w, Y1 - (j + 1) * h, w + 0.5, h + 0.5);
    }
  }
  if (m.unstable) {  // edges between linearly stable and unstable cells
    ctx.strokeStyle = '#000'; ctx.lineWidth = 2; ctx.setLineDash([5, 3]); ctx.beginPath();
    const u = m.unstable;
    for (let j = 0; j < ny; j++) {
      for (let i = 0; i < nx; i++) {
        if (i + 1 < nx && u[j][i] !== u[j][i + 1]) {
          ctx.moveTo(x0 + (i + 1) * w, Y1 - j * h); ctx.lineTo(x0 + (i + 1) * w, Y1 - (j + 1) * h);
        }
        if (j + 1 < ny && u[j][i] !== u[j + 1][i]) {
          ctx.moveTo(x0 + i * w, Y1 - (j + 1) * h); ctx.lineTo(x0 + (i + 1) * w, Y1 - (j + 1) * h);
        }
      }
    }
    ctx.stroke(); ctx.setLineDash([]);
  }
  if (state.marker) {
    const [i, j] = state.marker;
    ctx.strokeStyle = '#000'; ctx.lineWidth = 2;
    ctx.strokeRect(x0 + i * w - 2, Y1 - (j + 1) * h - 2, w + 4, h + 4);
  }
  ctx.strokeStyle = '#666'; ctx.lineWidth = 1; ctx.strokeRect(x0, y0, X1 - x0, Y1 - y0);
  ctx.fillStyle = '#333'; ctx.font = '11px sans-serif';
  const xv = m.x.values, yv = m.y.values;
  ctx.fillText(fmt(xv[0]), x0, Y1 + 12);
  ctx.fillText(fmt(xv[nx - 1]), X1 - 30, Y1 + 12);
  ctx.fillText(`${m.x.param} (${m.x.units})`, (x0 + X1) / 2 - 30, Y1 + 26);
  ctx.fillText(fmt(yv[ny - 1]), 2, y0 + 10);
  ctx.fillText(fmt(yv[0]), 2, Y1);
  ctx.save(); ctx.translate(12, (y0 + Y1) / 2 + 30); ctx.rotate(-Math.PI / 2);
  ctx.fillText(`${m.y.param} (${m.y.units})`, 0, 0); ctx.restore();
  $('map-legend').innerHTML = m.outcome_names.map((n, k) =>
    `<span><i style="background:${OUTCOME_COLOURS[k]}"></i>${n.replace(/_/g, ' ')}</span>`).join('');
}

function mapCell(ev) {
  const m = state.map;
  if (!m) return null;
  const { c, x0, x1, y0, y1 } = mapFrame(), rect = c.getBoundingClientRect();
  const nx = m.x.values.length, ny = m.y.values.length;
  const i = Math.floor((ev.clientX - rect.left - x0) / ((x1 - x0) / nx));
  const j = Math.floor((y1 - (ev.clientY - rect.top)) / ((y1 - y0) / ny));
  return (i < 0 || i >= nx || j < 0 || j >= ny) ? null : [i, j];
}

$('map-canvas').addEventListener('mousemove', (ev) => {
  const m = state.map, cell = mapCell(ev);
  if (!cell) { $('map-canvas').title = ''; return; }
  const [i, j] = cell, o = m.outcome[j][i];
  $('map-canvas').title = `${m.x.param} = ${fmt(m.x.values[i], 4)}, ${m.y.param} = `
    + `${fmt(m.y.values[j], 4)}: ${o < 0 ? 'not computed yet' : m.outcome_names[o].replace(/_/g, ' ')}`;
});

$('map-canvas').addEventListener('click', (ev) => {
  const m = state.map, cell = mapCell(ev);
  if (!cell) return;
  const [i, j] = cell;
  state.marker = [i, j];
  $(m.x.param).value = String(m.x.values[i]);
  $(m.y.param).value = String(m.y.values[j]);
  syncSlider();
  state.loadedFromMap = { x: m.x.values[i], y: m.y.values[j], outcome: m.outcome[j][i] };
  drawMap();
  doRun();
});

async function downloadToml() {
  const [status, r] = await post('/api/toml', mapRequest());
  if (status !== 200) { $('err-map').textContent = (await r.json()).error; return; }
  const blob = new Blob([await r.text()], { type: 'application/toml' });
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob); a.download = 'map.toml'; a.click();
}

// ---------------------------------------------------------------- wiring
function syncSlider() {
  const v = Number($('spin').value);
  if (Number.isFinite(v)) $('spin-slider').value = v;
}

async function init() {
  const config = await (await fetch('/api/config')).json();
  state.config = config;
  const preset = $('preset');
  preset.innerHTML = '<option value="custom">semi-ellipsoid (below)</option>'
    + config.presets.map((p) => `<option value="${p}">preset: ${p}</option>`).join('');
  const d = config.defaults;
  for (const k of CONTROLS) {
    if (k === 'masses') $(k).value = d.masses.map((r) => r.join(', ')).join('\n');
    else $(k).value = d[k];
  }
  syncSlider();
  const axes = Object.entries(config.map_axes).map(([k, u]) => `<option value="${k}">${k} (${u})</option>`).join('');
  $('map-x-param').innerHTML = axes; $('map-y-param').innerHTML = axes;
  $('map-x-param').value = 'spin'; $('map-y-param').value = 'delta_deg';
  $('map-x-start').value = -30; $('map-x-stop').value = 30; $('map-x-num').value = 13;
  $('map-y-start').value = -8; $('map-y-stop').value = 8; $('map-y-num').value = 9;
  $('map-levels').value = 1;
  const c = config.caps;
  $('caps').innerHTML = [
    `run length ≤ ${c.max_t_end} s and ≤ ${c.max_steps} time steps`,
    `≤ ${c.max_point_masses} point masses`,
    `map: ≤ ${c.max_map_num} points per axis, ≤ ${c.max_map_levels} refinement levels, `
      + `run length ≤ ${c.max_map_t_end} s per point`,
    `${c.max_frames} samples of each run are drawn`,
  ].map((t) => `<li>${t}</li>`).join('');
  for (const k of CONTROLS) {
    $(k).addEventListener('input', () => { if (k === 'spin') syncSlider(); scheduleRun(); });
  }
  $('custom-body').style.opacity = 1;
  $('preset').addEventListener('change', () => {
    $('custom-body').style.opacity = $('preset').value === 'custom' ? 1 : 0.45;
  });
  $('spin-slider').addEventListener('input', () => { $('spin').value = $('spin-slider').value; scheduleRun(); });
  $('play').addEventListener('click', () => {
    state.playing = !state.playing;
    $('play').textContent = state.playing ? 'pause' : 'play';
  });
  $('scrub').addEventListener('input', () => {
    state.playing = false; $('play').textContent = 'play';
    const i = Number($('scrub').value);
    state.tPlay = state.run ? state.run.t[i] : 0;
    showFrame(i);
  });
  $('map-go').addEventListener('click', startMap);
  $('download-toml').addEventListener('click', downloadToml);
  $('copy-python').addEventListener('click', async () => {
    const text = $('python').textContent;
    try { await navigator.clipboard.writeText(text); $('status').textContent = 'Python copied'; }
    catch (e) {
      const range = document.createRange(); range.selectNodeContents($('python'));
      const sel = window.getSelection(); sel.removeAllRanges(); sel.addRange(range);
      $('status').textContent = document.execCommand('copy') ? 'Python copied' : 'select the code and copy it';
    }
  });
  window.addEventListener('resize', resize);
  resize();
  await doRun();
  requestAnimationFrame(tick);
  state.ready = true;
}

init();
