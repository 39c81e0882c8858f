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
      s[k] = boxValue(el);
    }
  }
  return s;
}

// a box shows a value rounded to 6 significant digits; while it shows that, the request
// carries the full value (a map point, a preset's mass)
function short(v, digits = 6) {
  const x = Number(v);
  return (typeof v === 'number' || (v !== '' && Number.isFinite(x))) && Number.isFinite(x)
    ? String(Number(x.toPrecision(digits))) : String(v);
}
function setBox(el, v, digits = 6) {
  el.value = short(v, digits);
  el.dataset.full = String(v);
  el.dataset.shown = el.value;
}
function boxValue(el) {
  const typed = el.value.trim();
  return (el.dataset.full !== undefined && typed === el.dataset.shown) ? el.dataset.full : typed;
}

function showErrors(error, control) {
  for (const el of document.querySelectorAll('.err')) {
    // the map's and the measurement's messages belong to their own requests
    if (el.id !== 'err-map' && el.id !== 'err-measurement') el.textContent = '';
  }
  for (const el of document.querySelectorAll('#controls .bad')) el.classList.remove('bad');
  if (!error) return;
  const box = (control && $('err-' + control)) || $('err-general');
  box.textContent = error;
  if (control && $(control)) $(control).classList.add('bad');
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

// any failure (server unreachable, an error page, a payload that cannot be drawn) is said
// in the status line and by the control; the page, and the last good run, stay usable
async function doRun() {
  const seq = ++runSeq;
  const t0 = performance.now();
  state.requests += 1;
  $('status').textContent = 'running…';
  let status, data;
  try {
    const [st, r] = await post('/api/run', { settings: settings() });
    status = st;
    if (seq !== runSeq || status === 409) return;  // a newer change is on its way
    const text = await r.text();
    try { data = JSON.parse(text); } catch (e) { data = { error: `the server answered ${status}: ${text.slice(0, 200)}` }; }
  } catch (e) {
    if (seq === runSeq) failed(`server unreachable (${e.message})`, null, 'server unreachable');
    return;
  }
  if (seq !== runSeq) return;
  if (status !== 200) {
    const error = (data && data.error) || `the server answered ${status}`;
    failed(error, data && data.control, data && data.control
      ? 'refused: see the message by the control' : 'refused: see the message under the controls');
    return;
  }
  const previous = state.run;
  try {
    loadRun(data);
  } catch (e) {
    state.run = previous;
    if (previous) { buildBody(previous.body); frameView(previous); for (const c of plots) drawPlotBase(c); showFrame(0); }
    failed(`this run could not be drawn: ${e.message}`, null, 'the run could not be drawn');
    return;
  }
  state.lastError = null;
  showErrors(null);
  state.latencies.push(performance.now() - t0);
  // classroom mode leaves the timing out: a first lesson does not need it
  $('status').textContent = state.classroom ? 'ready'
    : `run ${state.runs} in ${(performance.now() - t0).toFixed(0)} ms`;
}

function setClassroom(on) {
  state.classroom = on;
  document.body.classList.toggle('classroom', on);
  $('classroom').checked = on;
}

function failed(error, control, status) {
  state.lastError = error;
  state.failures = (state.failures || 0) + 1;
  showErrors(error, control);
  $('status').textContent = status;
}

const finite = (v) => typeof v === 'number' && Number.isFinite(v);
const fixed = (v, d) => (finite(v) ? v.toFixed(d) : '—');

function loadRun(data) {
  if (!data || !Array.isArray(data.t) || !data.t.length || !data.summary || !data.body) {
    throw new Error('the answer holds no run');
  }
  // the samples that can be drawn: a pose and a spin (a run stopped at t = 0 has one)
  let n = 0;
  while (n < data.t.length && finite(data.t[n]) && finite(data.spin[n])
         && [0, 1, 2].every((k) => finite(data.position[3 * n + k]))
         && [0, 1, 2, 3].every((k) => finite(data.quaternion[4 * n + k]))) n++;
  if (n === 0) throw new Error('no sample of the run holds a pose');
  for (const k of ['a', 'b', 'c']) if (!(finite(data.body[k]) && data.body[k] > 0)) throw new Error(`the body's ${k} is not drawable`);
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
  const rev = !finite(s.first_reversal_time) ? 'no reversal'
    : `first reversal at ${s.first_reversal_time.toFixed(3)} s`;
  const slip = data.rolling ? 'rolling (μ = ∞): no slip'
    : `slipping ${finite(s.slip_fraction) ? (100 * s.slip_fraction).toFixed(0) : '—'} %`;
  const warnings = data.warnings || [];
  $('summary').textContent = `${rev}; reversals ${s.n_reversals}; final spin `
    + `${fixed(s.final_spin, 3)} rad/s; ${slip}; `
    + `status ${s.status}` + (warnings.length ? ' ⚠ ' + warnings.join('; ') : '');
  $('summary').classList.toggle('warn', warnings.length > 0);
  $('python').textContent = data.python || '';
  buildBody(data.body);
  const pts = [];
  for (let i = 0; i < n; i++) {
    const x = data.contact[2 * i], y = data.contact[2 * i + 1];
    pts.push(finite(x) ? x : p[3 * i], finite(y) ? y : p[3 * i + 1], 0.0002 * viewScale(data.body) / 0.05);
  }
  track.geometry.dispose();
  track.geometry = new THREE.BufferGeometry();
  track.geometry.setAttribute('position', new THREE.Float32BufferAttribute(pts, 3));
  frameView(data);
  for (const c of plots) drawPlotBase(c);
  showFrame(0);
  explainMapPoint(s);
}

// the map stops each launch at its first reversal; the run goes on to its end: a point the
// map calls reversed whose run later capsizes or lifts off says so under the map too
function explainMapPoint(s) {
  const from = state.loadedFromMap, m = state.map;
  state.loadedFromMap = null;
  if (!from || !m) return;
  const name = (m.outcome_names[from.outcome] || '').replace(/_/g, ' ');
  const note = $('map-note');
  note.textContent = m.boundary_note || '';
  if (name.includes('reversed') && s.status !== 'ok' && finite(s.first_reversal_time)) {
    const end = s.steps * s.dt;
    note.textContent = `This point is ${name} on the map, which stops each launch at its `
      + `first reversal (${fixed(s.first_reversal_time, 3)} s); run on, it `
      + `${s.status.replace(/_/g, ' ')} at ${fixed(end, 3)} s, as the run shows. `
      + (m.boundary_note || '');
  }
}

// the size the view is framed for (m): the body's largest extent, its height counted
// twice so that the spin arrow above it stays in view
const viewScale = (b) => Math.max(b.a, b.b, 1.6 * b.c);

function frameView(data) {
  const L = viewScale(data.body), p = data.position;
  grid.scale.set(10 * L, 10 * L, 10 * L);
  grid.position.x = p[0]; grid.position.y = p[1];
  floor.scale.set(20 * L, 20 * L, 1);
  floor.position.set(p[0], p[1], 0);
  if (!cam.dist || Math.abs(Math.log(L / cam.L)) > 0.7) cam.dist = 4.5 * L;  // a new scale
  cam.L = L;
  camera.near = L / 200; camera.far = L * 400; camera.updateProjectionMatrix();
  // the arrow grows with |spin| and saturates at ARROW_MAX of the view's scale:
  // half of that at SPIN_HALF rad/s, so that 1, 5 and 20 rad/s read differently
  state.arrowMax = 0.6 * L;
}
const SPIN_HALF = 10;  // rad/s

// the largest |x|, |y| in normalised device coordinates (-1 .. 1: in view) of the spin
// arrow's tip and the body's ends, at the frame shown; read by the browser tests
state.extentInView = () => {
  const r = state.run, i = state.frame;
  if (!r) return null;
  const tip = arrow.position.clone().add(new THREE.Vector3(0, 0, r.spin[i] >= 0 ? state.arrowLength : -state.arrowLength));
  scene.updateMatrixWorld();
  const pts = [tip, arrow.position.clone()];
  for (const [x, y, z] of [[r.body.a, 0, 0], [-r.body.a, 0, 0], [0, r.body.b, 0], [0, -r.body.b, 0], [0, 0, -r.body.c]]) {
    pts.push(bodyMesh.localToWorld(new THREE.Vector3(x, y, z)));
  }
  scene.updateMatrixWorld(); camera.updateMatrixWorld();
  return Math.max(...pts.map((v) => { const n = v.clone().project(camera); return Math.max(Math.abs(n.x), Math.abs(n.y)); }));
};
const arrowLength = (w) => state.arrowMax * Math.abs(w) / (Math.abs(w) + SPIN_HALF);

// the camera orbits the body (drag) and zooms (wheel), following it over the floor
const cam = { az: -0.9, el: 0.42, dist: 0, L: 0.05 };
function placeCamera(x, y, z) {
  if (!(finite(x) && finite(y) && finite(z))) return;
  camera.position.set(x + cam.dist * Math.cos(cam.el) * Math.cos(cam.az),
                      y + cam.dist * Math.cos(cam.el) * Math.sin(cam.az),
                      z + cam.dist * Math.sin(cam.el));
  camera.lookAt(x, y, z);
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
const floor = new THREE.Mesh(new THREE.PlaneGeometry(1, 1),
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
  i = Math.max(0, Math.min(r.n - 1, Number.isFinite(i) ? i : 0));
  state.frame = i;
  const q = r.quaternion, p = r.position;
  bodyGroup.position.set(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  placeCamera(p[3 * i], p[3 * i + 1], 0.5 * r.body.c);
  bodyGroup.quaternion.set(q[4 * i + 1], q[4 * i + 2], q[4 * i + 3], q[4 * i]);
  const w = r.spin[i] || 0;
  const len = Math.max(1e-6 * cam.L, arrowLength(w));
  state.arrowLength = len;
  // above the body: up for counter-clockwise spin, down onto it for clockwise
  arrow.position.set(p[3 * i], p[3 * i + 1], p[3 * i + 2] + r.body.c * 0.8 + (w >= 0 ? 0 : len));
  arrow.setDirection(new THREE.Vector3(0, 0, w >= 0 ? 1 : -1));
  arrow.setLength(len, 0.3 * Math.min(len, r.body.a), 0.15 * Math.min(len, r.body.a));
  arrow.setColor(w >= 0 ? 0x2266cc : 0xcc2222);
  track.geometry.setDrawRange(0, i + 1);
  $('scrub').value = i;
  $('clock').textContent = `${fixed(r.t[i], 2)} s`;
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
  requestAnimationFrame(tick);  // first: a failing frame must not stop the playback
  const r = state.run;
  try {
    if (r && state.playing && lastWall !== null) {
      const T = r.t[r.n - 1];
      state.tPlay += (now - lastWall) / 1000 * Number($('speed').value);
      if (!(state.tPlay <= T)) state.tPlay = 0;
      showFrame(frameAt(state.tPlay));
    }
    state.ticks = (state.ticks || 0) + 1;
  } catch (e) {
    $('status').textContent = `drawing failed: ${e.message}`;
  }
  lastWall = now;
}

function frameAt(t) {
  const ts = state.run.t;
  let lo = 0, hi = state.run.n - 1;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (ts[mid] < t) lo = mid + 1; else hi = mid; }
  return lo;
}

// ---------------------------------------------------------------- plots
const plots = [...document.querySelectorAll('canvas.plot')];
const MIN_SPAN = { spin: 0.1, tilt_deg: 0.5, energy: 0, slip_speed: 1e-3 };
// a plot spans at least MIN_REL of its largest |value|: a nearly constant series (energy
// without friction losses: changes of 1e-4 of it are the integrator's rounding) is drawn
// flat, not zoomed onto noise that reads as "energy not conserved"
const MIN_REL = 0.01;
function plotRange(series, values) {
  const v = values.filter(finite);
  if (!v.length) return [0, 1];
  let lo = v.reduce((a, b) => Math.min(a, b)), hi = v.reduce((a, b) => Math.max(a, b));
  const span = Math.max(MIN_SPAN[series] || 0, MIN_REL * Math.max(Math.abs(lo), Math.abs(hi)), 1e-300);
  if (!(hi - lo >= span)) {
    // a series that is never negative (slip speed) keeps 0 at the bottom
    if (lo >= 0 && lo - span / 2 < 0) { lo = 0; hi = span; }
    else { const mid = (hi + lo) / 2; lo = mid - span / 2; hi = mid + span / 2; }
  }
  const pad = 0.05 * (hi - lo);
  return [lo >= 0 && lo - pad < 0 ? 0 : lo - pad, hi + pad];
}
// the measured turning rate drawn over the spin plot, within the run's time
function measuredIn(c, T) {
  const m = state.measured;
  if (!m || c.dataset.series !== 'spin') return null;
  const t = [], v = [];
  for (let i = 0; i < m.t.length; i++) {
    if (m.t[i] <= T && finite(m.rate[i])) { t.push(m.t[i]); v.push(m.rate[i]); }
  }
  return { t, v };
}
function plotFrame(c) {
  const r = state.run, t = r.t;
  const own = r[c.dataset.series].slice(0, r.n);
  const m = measuredIn(c, t[r.n - 1]);
  const [lo, hi] = plotRange(c.dataset.series, m ? own.concat(m.v) : own);
  const T = t[r.n - 1];
  return { x0: 70, x1: c.width - 8, y0: 8, y1: c.height - 18, lo, hi, T: T > 0 ? T : 1 };
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
    if (!finite(ys[i])) { pen = false; continue; }
    if (pen) ctx.lineTo(X(r.t[i]), Y(ys[i])); else ctx.moveTo(X(r.t[i]), Y(ys[i]));
    pen = true;
  }
  ctx.stroke();
  if (r.n === 1 && finite(ys[0])) {  // a run stopped at t = 0: its one sample as a dot
    ctx.fillStyle = '#1f5fa8'; ctx.beginPath(); ctx.arc(X(r.t[0]), Y(ys[0]), 3, 0, 2 * Math.PI); ctx.fill();
  }
  const m = measuredIn(c, f.T);
  if (m) {  // the measurement as dots under its label
    ctx.fillStyle = 'rgba(200, 60, 40, 0.55)';
    for (let i = 0; i < m.t.length; i++) ctx.fillRect(X(m.t[i]) - 1, Y(m.v[i]) - 1, 2, 2);
    ctx.font = '11px sans-serif';
    ctx.fillText(`dots: measured ${state.measured.what}`, f.x0 + 4, f.y0 + 24);
  }
  ctx.fillStyle = '#333'; ctx.font = '11px sans-serif';
  const u = plotUnits(c, f);
  ctx.fillText(u.label, f.x0 + 4, f.y0 + 11);
  // round values in human units (mJ rather than 8.0e-4 J), at least three of them
  let vs = ticks(f.lo * u.scale, f.hi * u.scale, 4);
  if (vs.length < 3) vs = ticks(f.lo * u.scale, f.hi * u.scale, 6);
  ctx.textAlign = 'right';
  for (const v of vs) {
    const y = Y(v / u.scale);
    ctx.fillText(tickText(v), f.x0 - 3, Math.min(f.y1, Math.max(f.y0 + 8, y + 4)));
    ctx.strokeStyle = '#bbb'; ctx.beginPath(); ctx.moveTo(f.x0 - 2, y); ctx.lineTo(f.x0, y); ctx.stroke();
  }
  ctx.textAlign = 'left';
  c._ticks = vs;
  ctx.fillText('0', f.x0, c.height - 4);
  ctx.fillText(`${fmt(f.T)} s`, f.x1 - 34, c.height - 4);
  c._base = ctx.getImageData(0, 0, c.width, c.height);
  c._frame = f;
}

// a plot's label and the factor its tick values are shown with: energies under 0.1 J in
// mJ, speeds under 0.1 m/s in mm/s
function plotUnits(c, f) {
  const big = Math.max(Math.abs(f.lo), Math.abs(f.hi));
  const small = big < 0.1;
  if (c.dataset.series === 'energy' && small) return { scale: 1000, label: 'energy (mJ)' };
  if (c.dataset.series === 'slip_speed' && small) return { scale: 1000, label: 'slip speed (mm/s)' };
  return { scale: 1, label: c.dataset.label };
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
  if (!finite(v)) return String(v);
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
let mapSeq = 0;
async function startMap() {
  clearTimeout(mapPoll);
  const seq = ++mapSeq;
  $('err-map').textContent = '';
  $('map-bar').style.width = '0%';  // a new map starts from nothing done
  for (const el of document.querySelectorAll('#map .bad')) el.classList.remove('bad');
  let status, data;
  try {
    const [st, r] = await post('/api/map', mapRequest());
    status = st;
    const text = await r.text();
    try { data = JSON.parse(text); } catch (e) { data = { error: `the server answered ${status}: ${text.slice(0, 200)}` }; }
  } catch (e) { $('err-map').textContent = `server unreachable (${e.message})`; return; }
  if (status !== 200) {
    $('err-map').textContent = data.error || `the server answered ${status}`;
    const el = { map_x: 'map-x-param', map_y: 'map-y-param', map_levels: 'map-levels' }[data.control];
    if (el) $(el).classList.add('bad');
    return;
  }
  state.mapStarted = performance.now();
  showMap(data, seq);
}

const label = (param) => {
  const a = state.config && state.config.map_axes[param];
  return a ? a.label + (a.units && a.units !== '1' ? ` (${a.units})` : '') : param;
};

function showMap(m, seq) {
  if (seq !== mapSeq || !m || !m.x || !m.outcome) return;
  state.map = m;
  // the bar: the levels done, plus the share of the current level's launches
  $('map-bar').style.width = `${(100 * (m.done ? 1 : m.progress)).toFixed(1)}%`;
  const what = m.done ? `done: ${m.simulated} launches simulated in ${m.seconds.toFixed(1)} s`
    : `level ${m.level} of ${m.levels}: ${m.level_done} / ${m.level_points} launches`;
  $('map-info').textContent = `${m.x.values.length} × ${m.y.values.length} points; ${what}. `
    + 'Click a point to load its launch.';
  $('map-note').textContent = m.boundary_note;
  drawMap();
  if (!m.done) mapPoll = setTimeout(() => pollMap(seq), 250);
}

async function pollMap(seq) {
  if (seq !== mapSeq) return;
  try {
    const r = await fetch(`/api/map?session=${session}`);
    if (r.status === 200) { showMap(await r.json(), seq); return; }
    $('err-map').textContent = `the map stopped: the server answered ${r.status}`;
  } catch (e) {
    mapPoll = setTimeout(() => pollMap(seq), 1000);  // the server may be busy: ask again
  }
}

// a tick's value as short as it is: 10, 0.5, 2e-7
const tickText = (v) => {
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential().replace('e+', 'e') : String(Number(v.toPrecision(6)));
};

// a few round values between lo and hi (1, 2 or 5 times a power of ten apart)
function ticks(lo, hi, most = 7) {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / (most - 1), p = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((k) => k * p).find((k) => k >= raw);
  const out = [];
  for (let v = Math.ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step) {
    out.push(Math.abs(v) < 1e-12 * step ? 0 : Number(v.toPrecision(12)));
  }
  return out;
}

function mapFrame() {
  const c = $('map-canvas');
  return { c, x0: 62, x1: c.width - 8, y0: 8, y1: c.height - 34 };
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
  state.mapEdges = false;
  if (m.unstable) {  // hatch the linearly unstable cells, then the edges to stable ones
    const u = m.unstable;
    ctx.save(); ctx.strokeStyle = 'rgba(0, 0, 0, 0.35)'; ctx.lineWidth = 1;
    for (let j = 0; j < ny; j++) {
      for (let i = 0; i < nx; i++) {
        if (u[j][i] !== 1) continue;
        ctx.save(); ctx.beginPath(); ctx.rect(x0 + i * w, Y1 - (j + 1) * h, w, h); ctx.clip();
        ctx.beginPath();
        for (let d = -h; d < w + h; d += 6) {
          ctx.moveTo(x0 + i * w + d, Y1 - j * h); ctx.lineTo(x0 + i * w + d + h, Y1 - (j + 1) * h);
        }
        ctx.stroke(); ctx.restore();
      }
    }
    ctx.restore();
    ctx.strokeStyle = '#000'; ctx.lineWidth = 2; ctx.setLineDash([5, 3]); ctx.beginPath();
    for (let j = 0; j < ny; j++) {
      for (let i = 0; i < nx; i++) {
        // null: neutral to rounding (no spin, no misalignment): no edge beside it
        if (u[j][i] === null) continue;
        if (i + 1 < nx && u[j][i + 1] !== null && u[j][i] !== u[j][i + 1]) {
          state.mapEdges = true;
          ctx.moveTo(x0 + (i + 1) * w, Y1 - j * h); ctx.lineTo(x0 + (i + 1) * w, Y1 - (j + 1) * h);
        }
        if (j + 1 < ny && u[j + 1][i] !== null && u[j][i] !== u[j + 1][i]) {
          state.mapEdges = true;
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
  // cell i spans [i, i + 1] of the width: value xv[i] sits at its centre
  const at = (vals, n, a, b, v) => {
    const f = n > 1 ? (v - vals[0]) / (vals[n - 1] - vals[0]) * (n - 1) : 0;
    return a + (b - a) * (f + 0.5) / n;
  };
  ctx.textAlign = 'center';
  state.mapTicks = { x: [], y: [] };
  for (const v of ticks(Math.min(xv[0], xv[nx - 1]), Math.max(xv[0], xv[nx - 1]))) {
    const x = at(xv, nx, x0, X1, v);
    ctx.beginPath(); ctx.moveTo(x, Y1); ctx.lineTo(x, Y1 + 4); ctx.stroke();
    ctx.fillText(tickText(v), x, Y1 + 14);
    state.mapTicks.x.push(v);
  }
  ctx.fillText(label(m.x.param), (x0 + X1) / 2, Y1 + 28);
  ctx.textAlign = 'right';
  for (const v of ticks(Math.min(yv[0], yv[ny - 1]), Math.max(yv[0], yv[ny - 1]))) {
    const y = at(yv, ny, Y1, y0, v);
    ctx.beginPath(); ctx.moveTo(x0 - 4, y); ctx.lineTo(x0, y); ctx.stroke();
    ctx.fillText(tickText(v), x0 - 6, y + 4);
    state.mapTicks.y.push(v);
  }
  ctx.textAlign = 'center';
  ctx.save(); ctx.translate(11, (y0 + Y1) / 2); ctx.rotate(-Math.PI / 2);
  ctx.fillText(label(m.y.param), 0, 0); ctx.restore();
  ctx.textAlign = 'left';
  const present = new Set(m.outcome.flat());
  const entries = m.outcome_names.map((n, k) => [n, k]).filter(([, k]) => present.has(k))
    .map(([n, k]) => `<span><i style="background:${OUTCOME_COLOURS[k]}"></i>${n.replace(/_/g, ' ')}</span>`);
  if (present.has(-1)) entries.push('<span><i style="background:#eeeeee"></i>not computed yet</span>');
  if (m.unstable && m.unstable.flat().some((u) => u === 1)) {
    entries.push('<span class="hatch"><i></i>hatched: steady spin unstable (linear theory)</span>');
  }
  if (state.mapEdges) entries.push('<span class="line"><i></i>dashed: where it turns stable</span>');
  $('map-legend').innerHTML = entries.join('');
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
  $('map-canvas').title = `${label(m.x.param)} = ${fmt(m.x.values[i], 4)}, ${label(m.y.param)} = `
    + `${fmt(m.y.values[j], 4)}: ${o < 0 ? 'not computed yet' : m.outcome_names[o].replace(/_/g, ' ')}`;
});

$('map-canvas').addEventListener('click', (ev) => {
  const m = state.map, cell = mapCell(ev);
  if (!cell) return;
  const [i, j] = cell;
  state.marker = [i, j];
  // shown to 4 digits (a refined grid's 0.346875 reads 0.3469); the run takes the value
  setBox($(m.x.param), m.x.values[i], 4);
  setBox($(m.y.param), m.y.values[j], 4);
  syncSlider();
  state.loadedFromMap = { x: m.x.values[i], y: m.y.values[j], outcome: m.outcome[j][i] };
  drawMap();
  doRun();
});

async function downloadToml() {
  let status, r;
  try { [status, r] = await post('/api/toml', mapRequest()); } catch (e) {
    $('err-map').textContent = `server unreachable (${e.message})`; return;
  }
  if (status !== 200) {
    const text = await r.text();
    let error; try { error = JSON.parse(text).error; } catch (e) { error = text.slice(0, 200); }
    $('err-map').textContent = error || `the server answered ${status}`; return;
  }
  const blob = new Blob([await r.text()], { type: 'application/toml' });
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob); a.download = 'map.toml'; a.click();
}

// ---------------------------------------------------------------- wiring
// a new map axis gets its own default range: from the server's description of the
// input, or about the current body's value for a size or a mass
function setAxisRange(k) {
  const param = $(`map-${k}-param`).value, a = state.config.map_axes[param];
  if (!a) return;
  let lo = a.start, hi = a.stop;
  if (a.relative) {
    const v = Number(boxValue($(param)));
    const base = Number.isFinite(v) && v > 0 ? v : 1;
    [lo, hi] = a.relative.map((f) => Number((f * base).toPrecision(3)));
  }
  $(`map-${k}-start`).value = lo; $(`map-${k}-stop`).value = hi;
}

// a preset shows its own size and mass in the (greyed, read-only) body boxes; the
// semi-ellipsoid's values come back when it is chosen again
const BODY_BOXES = ['a', 'b', 'c', 'mass', 'delta_deg'];
function showPresetBody() {
  const name = $('preset').value, custom = name === 'custom';
  if (!custom && !state.customBody) {
    state.customBody = Object.fromEntries(BODY_BOXES.map((k) => [k, [$(k).value, $(k).dataset.full, $(k).dataset.shown]]));
  }
  if (custom && state.customBody) {
    for (const k of BODY_BOXES) {
      const [v, full, shown] = state.customBody[k];
      $(k).value = v;
      if (full === undefined) { delete $(k).dataset.full; delete $(k).dataset.shown; }
      else { $(k).dataset.full = full; $(k).dataset.shown = shown; }
    }
    state.customBody = null;
  } else if (!custom) {
    const b = state.config.presets[name];
    for (const k of ['a', 'b', 'c', 'mass']) setBox($(k), b[k]);
    $('delta_deg').value = '';
    $('delta_deg').placeholder = 'preset';
  }
  for (const k of BODY_BOXES) $(k).readOnly = !custom;
  if (!custom) {
    // a preset's shape and misalignment are its own: a map axis over them becomes μ (or
    // the roll, when μ is the other axis), so that the map still works
    for (const [k, other] of [['x', 'y'], ['y', 'x']]) {
      if (BODY_BOXES.includes($(`map-${k}-param`).value)) {
        $(`map-${k}-param`).value = $(`map-${other}-param`).value === 'mu' ? 'roll_deg' : 'mu';
        setAxisRange(k);
      }
    }
  }
  $('custom-body').style.opacity = custom ? 1 : 0.6;
  $('custom-body').title = custom ? '' : 'the preset body: choose "semi-ellipsoid" to edit';
}

function syncSlider() {
  const v = Number($('spin').value);
  if (Number.isFinite(v)) $('spin-slider').value = v;
}

// ---------------------------------------------------------------- a measured rattleback
const FIT_DEFAULT = ['spin', 'roll_deg', 'damping'];
// the phone's turn on the flat face is fitted too, but is no control of the run
const fitLabel = (k) => (k === 'sensor_yaw_deg' ? 'phone turned by (yaw)' : state.config.labels[k]);
async function loadMeasurement() {
  const file = $('measurement').files[0];
  if (!file) return;
  $('err-measurement').textContent = '';
  $('fit-status').textContent = 'reading…';
  let status, data;
  try {
    const [st, r] = await post('/api/measurement', { name: file.name, text: await file.text() });
    status = st; data = await r.json();
  } catch (e) {
    $('fit-status').textContent = '';
    $('err-measurement').textContent = `could not send the file (${e.message})`;
    return;
  }
  if (status !== 200) {
    state.measured = null; $('fit').disabled = true; $('fit-status').textContent = '';
    $('err-measurement').textContent = data.error || `the server answered ${status}`;
    for (const c of plots) drawPlotBase(c);
    return;
  }
  state.measured = data;
  $('fit-free').innerHTML = data.free.map((k) =>
    `<label class="tick"><input type="checkbox" value="${k}"${FIT_DEFAULT.includes(k) ? ' checked' : ''}> ${fitLabel(k)}</label>`).join(' ');
  $('fit').disabled = false;
  $('fit-status').textContent = `${data.samples} samples over ${fmt(data.duration)} s loaded`;
  setBox($('t_end'), Number(data.duration.toFixed(3)));
  scheduleRun();
}

async function fitMeasurement() {
  const free = [...document.querySelectorAll('#fit-free input:checked')].map((e) => e.value);
  $('err-measurement').textContent = '';
  $('fit').disabled = true;
  $('fit-status').textContent = 'fitting… (about 10 s)';
  const t0 = performance.now();
  let status, data;
  try {
    const [st, r] = await post('/api/fit', { settings: settings(), free });
    status = st; data = await r.json();
  } catch (e) {
    status = 0; data = { error: `server unreachable (${e.message})` };
  }
  $('fit').disabled = false;
  if (status !== 200) {
    $('fit-status').textContent = 'not fitted';
    $('err-measurement').textContent = data.error || `the server answered ${status}`;
    return;
  }
  for (const [k, v] of Object.entries(data.fitted)) if ($(k)) setBox($(k), v.value);
  setBox($('t_end'), data.settings.t_end);
  syncSlider();
  state.fit = data;
  $('fit-result').innerHTML = Object.entries(data.fitted).map(([k, v]) => {
    // digits enough for the interval's ends to differ
    const digits = Math.min(8, 3 + Math.max(0, Math.round(Math.log10(
      Math.max(Math.abs(v.low), Math.abs(v.high)) / Math.max(v.high - v.low, 1e-300)))));
    const range = v.determined ? `95 %: ${fmt(v.low, digits)} … ${fmt(v.high, digits)}`
      : 'not pinned down by these data';
    const units = state.config.units[k] || (k === 'sensor_yaw_deg' ? 'deg' : '');
    return `<li>${fitLabel(k)} = ${fmt(v.value, digits)}${units === '1' ? '' : ' ' + units} (${range})</li>`;
  }).join('') + data.notes.map((n) => `<li class="note">${n}</li>`).join('');
  $('fit-status').textContent = `fitted in ${((performance.now() - t0) / 1000).toFixed(1)} s `
    + `(${data.runs} model runs); the controls now hold the fit`;
  scheduleRun();
}

async function init() {
  const wanted = new URLSearchParams(location.search).get('classroom');
  setClassroom(wanted !== null && wanted !== '0' && wanted !== 'false');
  $('classroom').addEventListener('change', () => {
    setClassroom($('classroom').checked);
    const url = new URL(location.href);
    if (state.classroom) url.searchParams.set('classroom', '1');
    else url.searchParams.delete('classroom');
    history.replaceState(null, '', url);
    if (state.run) $('status').textContent = state.classroom ? 'ready' : `run ${state.runs}`;
  });
  const config = await (await fetch('/api/config')).json();
  state.config = config;
  const preset = $('preset');
  preset.innerHTML = '<option value="custom">semi-ellipsoid (below)</option>'
    + Object.entries(config.presets).map(([p, b]) => `<option value="${p}">preset: ${b.label}</option>`).join('');
  const d = config.defaults;
  for (const k of CONTROLS) {
    if (k === 'masses') $(k).value = d.masses.map((r) => r.join(', ')).join('\n');
    else if (k === 'preset') $(k).value = d[k];
    else setBox($(k), d[k]);
  }
  syncSlider();
  const axes = Object.entries(config.map_axes).map(([k, a]) =>
    `<option value="${k}" title="${a.description}">${label(k)}</option>`).join('');
  $('map-x-param').innerHTML = axes; $('map-y-param').innerHTML = axes;
  $('map-x-param').value = 'spin'; $('map-y-param').value = 'delta_deg';
  setAxisRange('x'); setAxisRange('y');
  $('map-x-num').value = 13; $('map-y-num').value = 9;
  $('map-info').textContent = 'Choose what goes across and up, then press compute map: '
    + 'each cell is one launch, coloured by what it did; click one to watch it.';
  $('map-levels').value = 1;
  for (const k of ['x', 'y']) $(`map-${k}-param`).addEventListener('change', () => setAxisRange(k));
  const c = config.caps;
  $('caps').innerHTML = [
    `run length ≤ ${c.max_t_end} s and ≤ ${c.max_steps} time steps`,
    `≤ ${c.max_point_masses} point masses`,
    `map: ≤ ${c.max_map_num} points per axis, ≤ ${c.max_map_levels} refinement levels, `
      + `run length ≤ ${c.max_map_t_end} s per point`,
    `${c.max_frames} samples of each run are drawn`,
    `a measurement to fit: ≤ ${c.max_fit_t_end} s and ≤ ${c.max_fit_samples} samples; one fit at a time`,
  ].map((t) => `<li>${t}</li>`).join('');
  for (const k of CONTROLS) {
    $(k).addEventListener('input', () => { if (k === 'spin') syncSlider(); scheduleRun(); });
  }
  $('custom-body').style.opacity = 1;
  $('preset').addEventListener('change', showPresetBody);
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
  $('measurement').addEventListener('change', loadMeasurement);
  $('fit').addEventListener('click', fitMeasurement);
  $('download-toml').addEventListener('click', downloadToml);
  $('copy-python').addEventListener('click', async () => {
    const text = $('python').textContent;
    let said;
    try { await navigator.clipboard.writeText(text); said = 'Python copied'; }
    catch (e) {
      const range = document.createRange(); range.selectNodeContents($('python'));
      const sel = window.getSelection(); sel.removeAllRanges(); sel.addRange(range);
      said = document.execCommand('copy') ? 'Python copied' : 'select the code and copy it';
    }
    $('status').textContent = said;
    $('copied').textContent = said === 'Python copied' ? 'copied ✓' : said;
    clearTimeout(state.copiedTimer);
    state.copiedTimer = setTimeout(() => { $('copied').textContent = ''; }, 2500);
  });
  window.addEventListener('resize', resize);
  resize();
  await doRun();
  requestAnimationFrame(tick);
  state.ready = true;
}

init();
