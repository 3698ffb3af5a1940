// The replay page (docs/viewer.md): the scene, the time controls, the readouts beside the
// view and the time plot, driven by one clock. `window.acsReplay` exposes the state the
// browser tests read back (sim-host/tests/viewer.rs, tools/viewer/test/replay.test.mjs).
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { Replay, embedded } from './data.js';
import { Scene, OrbitScene } from './scene.js';
import { TimePlot, MODE_COLOURS } from './plot.js';

const t_start = performance.now();
const $ = (id) => document.getElementById(id);
const fmt = (x, d = 3) => (Number.isFinite(x) ? x.toFixed(d) : '—');

function banner(doc) {
  const el = $('status');
  if (doc.run_status === 'ok') {
    el.className = 'ok';
    el.textContent = 'run_status ok';
  } else {
    el.className = 'failed';
    el.textContent = `RUN ${String(doc.run_status).toUpperCase()}: ${doc.failure || 'see summary.json'} — the replay ends where the run stopped`;
  }
  const d = doc.decimation;
  const dec = d.buckets > 0
    ? `${d.rows_kept} of ${d.rows_recorded} rows (decimated: every transition, each of ${d.buckets} buckets' extremes)`
    : `all ${d.rows_recorded} rows`;
  const lost = d.transition_rows_dropped > 0 ? ` · ${d.transition_rows_dropped} transition rows did not fit` : '';
  $('meta').textContent = `${doc.scenario} · ${dec}${lost} · ${doc.geometry.note} · body: ${doc.spacecraft.box_source}`;
}

function main() {
  const doc = embedded();
  const replay = new Replay(doc);
  document.title = `${doc.scenario} — replay`;
  $('title').textContent = doc.scenario;
  banner(doc);

  const view = $('view');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  view.appendChild(renderer.domElement);
  const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
  camera.up.set(0, 0, 1);
  camera.position.set(3.2, 2.4, 1.8);
  const controls = new OrbitControls(camera, renderer.domElement);
  const orbitCamera = new THREE.PerspectiveCamera(45, 1, 0.01, 200);
  orbitCamera.up.set(0, 0, 1);
  orbitCamera.position.set(3.5, 3.5, 2.5);
  const orbitControls = new OrbitControls(orbitCamera, renderer.domElement);
  orbitControls.enabled = false;

  const scene = new Scene(replay);
  const orbitScene = new OrbitScene(replay);
  const state = { t: replay.t0, playing: false, speed: 1, camera: doc.geometry.source === 'none' ? 'inertial' : 'lvlh' };
  if (!scene.hasOrbit) for (const o of $('camera').options) o.disabled = o.value === 'lvlh' || o.value === 'orbit';
  $('camera').value = state.camera;
  // Default speed: the whole run in about a minute.
  const span = replay.t1 - replay.t0;
  const speeds = [1, 10, 100, 1000, 10000, 100000];
  state.speed = speeds.find((s) => span / s <= 90) || speeds[speeds.length - 1];
  $('speed').value = String(state.speed);

  const slider = $('scrub');
  slider.min = String(replay.t0); slider.max = String(replay.t1); slider.step = 'any';
  const plot = new TimePlot($('plot'), replay, (t) => seek(t));

  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h, false);
    camera.aspect = orbitCamera.aspect = w / h;
    camera.updateProjectionMatrix(); orbitCamera.updateProjectionMatrix();
  }
  window.addEventListener('resize', resize);
  resize();

  function readouts(loc) {
    const mode = replay.value('mode', loc);
    const name = Number.isFinite(mode) ? doc.modes[String(mode)] || `code ${mode}` : '—';
    $('time').textContent = `t = ${fmt(state.t, 2)} s`;
    $('mode').textContent = name;
    $('mode').style.background = MODE_COLOURS[name] || '#ccc';
    $('error').textContent = `${fmt(replay.value('error_deg', loc), 4)}°`;
    const extra = [];
    const add = (label, col, d, unit) => replay.has(col) && extra.push(`${label} ${fmt(replay.value(col, loc), d)}${unit}`);
    add('primary axis', 'pointing_primary_error_deg', 4, '°');
    add('flight error', 'flight_error_deg', 4, '°');
    add('estimation error', 'est_error_deg', 4, '°');
    const w = replay.vec3('rate_', loc, '_rad_s');
    extra.push(`|ω| ${fmt((Math.hypot(...w) * 180) / Math.PI, 4)}°/s`);
    (doc.spacecraft.wheels || []).forEach((_, i) => add(`wheel ${i + 1}`, `wheel${i + 1}_speed_rpm`, 0, ' rpm'));
    add('|h|', 'h_norm_nms', 6, ' N m s');
    if (scene.hasOrbit) extra.push(replay.value('geo_eclipse', loc) === 1 ? 'ECLIPSE' : 'sunlit');
    for (const k of scene.keepout || []) extra.push(`${k.boresight} ${k.cone} margin ${fmt(k.margin_deg, 2)}°${k.violated ? ' VIOLATED' : ''}`);
    $('readouts').innerHTML = extra.map((x) => `<div${x.includes('VIOLATED') ? ' class="bad"' : ''}>${x}</div>`).join('');
  }

  let frames = 0;
  function render() {
    const loc = replay.locate(state.t);
    if (state.camera === 'orbit') {
      orbitScene.update(loc);
      renderer.render(orbitScene.scene, orbitCamera);
    } else {
      scene.update(loc, state.camera);
      renderer.render(scene.scene, camera);
    }
    plot.frame(state.t);
    readouts(loc);
    slider.value = String(state.t);
    frames++;
    if (frames === 1) {
      api.firstFrameMs = performance.now() - t_start;
      api.ready = true;
    }
  }

  function seek(t) {
    state.t = Math.min(replay.t1, Math.max(replay.t0, t));
    render();
  }

  let last = null;
  function tick(now) {
    if (state.playing && last !== null) {
      state.t += ((now - last) / 1000) * state.speed;
      if (state.t >= replay.t1) { state.t = replay.t1; state.playing = false; $('play').textContent = '▶'; }
      render();
    }
    last = now;
    controls.update(); orbitControls.update();
    if (!state.playing) renderer.render(state.camera === 'orbit' ? orbitScene.scene : scene.scene, state.camera === 'orbit' ? orbitCamera : camera);
    requestAnimationFrame(tick);
  }

  $('play').addEventListener('click', () => {
    state.playing = !state.playing;
    if (state.playing && state.t >= replay.t1) state.t = replay.t0;
    $('play').textContent = state.playing ? '❚❚' : '▶';
  });
  $('speed').addEventListener('change', (e) => { state.speed = Number(e.target.value); });
  slider.addEventListener('input', () => seek(Number(slider.value)));
  $('camera').addEventListener('change', (e) => setCamera(e.target.value));

  function setCamera(c) {
    state.camera = c;
    $('camera').value = c;
    controls.enabled = c !== 'orbit';
    orbitControls.enabled = c === 'orbit';
    render();
  }

  // The state the tests read back: what the scene's objects hold, not what was asked.
  const v3 = (v) => [v.x, v.y, v.z];
  const q4 = (q) => [q.x, q.y, q.z, q.w];
  const api = {
    ready: false,
    firstFrameMs: null,
    seek,
    setCamera,
    play: () => { if (!state.playing) $('play').click(); },
    pause: () => { if (state.playing) $('play').click(); },
    rows: () => Array.from(replay.t),
    state() {
      const F = scene.F || new THREE.Quaternion();
      const Finv = F.clone().invert();
      const out = {
        t: state.t,
        camera: state.camera,
        mode: $('mode').textContent,
        status: $('status').textContent,
        craftQuat: q4(scene.craft.quaternion),
        worldFromEci: q4(F),
        bodyToEci: q4(Finv.clone().multiply(scene.craft.quaternion)),
        ghostToEci: scene.ghost.visible ? q4(Finv.clone().multiply(scene.ghost.quaternion)) : null,
        keepout: scene.keepout || [],
        targetEci: scene.target ? v3(scene.target.world.clone().applyQuaternion(Finv)) : null,
        targetVisible: scene.target ? scene.target.visible : null,
      };
      if (scene.hasOrbit) {
        const sunW = new THREE.Vector3(0, 1, 0).applyQuaternion(scene.sunArrow.quaternion);
        const earthW = scene.earth.position.clone().normalize();
        out.sunWorld = v3(sunW);
        out.earthWorld = v3(earthW);
        out.sunEci = v3(sunW.clone().applyQuaternion(Finv));
        out.earthEci = v3(earthW.clone().applyQuaternion(Finv));
        out.earthRadiusRad = Math.asin(scene.earth.scale.x / scene.earth.position.length());
        out.eclipse = scene.eclipse;
      }
      return out;
    },
  };
  window.acsReplay = api;
  render();
  requestAnimationFrame(tick);
}

try {
  main();
} catch (e) {
  const el = document.getElementById('status');
  el.className = 'failed';
  el.textContent = `the replay could not start: ${e.message}`;
  window.acsReplay = { ready: false, error: String(e && e.stack || e) };
  throw e;
}
