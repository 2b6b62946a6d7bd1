// The page's script: reads the scene that dalembert.plotting.view embedded in the page
// (<script id="dalembert-scene" type="application/json">) and plays it with three.js.
// Bundled with three.js into one file by build.sh; the page needs no network.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const PALETTE = [0x4c72b0, 0xdd8452, 0x55a868, 0xc44e52, 0x8172b3,
                 0x937860, 0xda8bc3, 0x8c8c8c, 0xccb974, 0x64b5cd];
const JOINT_COLOR = 0xf2b134;
const GROUND_COLOR = 0x333333;
const FORCE_COLOR = 0xd62728;
const TRACE_COLORS = [0x2ca02c, 0x9467bd, 0xff7f0e, 0x17becf, 0xe377c2, 0x7f7f7f, 0xbcbd22, 0x1f77b4];

// scratch objects of the per-frame updates (no allocation per body per frame)
const TMP = { v: new THREE.Vector3(), q: new THREE.Quaternion() };
const ONE = new THREE.Vector3(1, 1, 1);

function decode(text, Type) {
  const bin = atob(text);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  return new Type(bytes.buffer);
}

// Poses of every body at any time: linear interpolation of positions and normalized
// interpolation of quaternions between the two recorded frames around it.
class Poses {
  constructor(scene) {
    this.t = decode(scene.t, Float32Array);
    this.nb = scene.bodies.length;
    this.pos = decode(scene.positions, Float32Array);
    this.quat = decode(scene.quaternions, Int16Array);
    this.frames = this.t.length;
    this.p = new Float32Array(this.nb * 3);
    this.q = new Float32Array(this.nb * 4);
  }

  // index i and weight w with t[i] <= time <= t[i + 1]
  locate(time) {
    const t = this.t;
    if (this.frames < 2 || time <= t[0]) return [0, 0];
    if (time >= t[this.frames - 1]) return [this.frames - 1, 0];
    let lo = 0, hi = this.frames - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (t[mid] <= time) lo = mid; else hi = mid;
    }
    return [lo, (time - t[lo]) / (t[hi] - t[lo])];
  }

  at(time) {
    const [i, w] = this.locate(time);
    const j = Math.min(i + 1, this.frames - 1);
    const nb = this.nb, P = this.pos, Q = this.quat;
    for (let b = 0; b < nb; b++) {
      const a3 = (i * nb + b) * 3, b3 = (j * nb + b) * 3;
      for (let k = 0; k < 3; k++) this.p[b * 3 + k] = P[a3 + k] + w * (P[b3 + k] - P[a3 + k]);
      const a4 = (i * nb + b) * 4, b4 = (j * nb + b) * 4;
      const sign = (Q[a4] * Q[b4] + Q[a4 + 1] * Q[b4 + 1] + Q[a4 + 2] * Q[b4 + 2]
                    + Q[a4 + 3] * Q[b4 + 3]) < 0 ? -1 : 1;
      let n = 0;
      for (let k = 0; k < 4; k++) {
        const v = Q[a4 + k] + w * (sign * Q[b4 + k] - Q[a4 + k]);
        this.q[b * 4 + k] = v;
        n += v * v;
      }
      n = Math.sqrt(n) || 1;
      for (let k = 0; k < 4; k++) this.q[b * 4 + k] /= n;
    }
    return i;
  }

  matrix(b, out) {
    const q = this.q, p = this.p;
    return out.compose(TMP.v.set(p[3 * b], p[3 * b + 1], p[3 * b + 2]),
                       TMP.q.set(q[4 * b], q[4 * b + 1], q[4 * b + 2], q[4 * b + 3]), ONE);
  }

  // world position of a body-fixed point (the ground's, index -1, is the point itself)
  point(b, local, out) {
    out.set(local[0], local[1], local[2]);
    if (b < 0) return out;
    const q = this.q;
    out.applyQuaternion(TMP.q.set(q[4 * b], q[4 * b + 1], q[4 * b + 2], q[4 * b + 3]));
    return out.add(TMP.v.set(this.p[3 * b], this.p[3 * b + 1], this.p[3 * b + 2]));
  }
}

const UP = new THREE.Vector3(0, 1, 0);

// the matrix taking the unit shape (y axis from -1/2 to 1/2) onto the segment a -> b
function segmentMatrix(a, b, radius) {
  const A = new THREE.Vector3(...a), B = new THREE.Vector3(...b);
  const d = B.clone().sub(A);
  const length = d.length();
  const q = new THREE.Quaternion().setFromUnitVectors(UP, length > 0 ? d.normalize() : UP);
  return new THREE.Matrix4().compose(A.add(B).multiplyScalar(0.5), q,
                                     new THREE.Vector3(radius, length, radius));
}

function shapeMatrix(s) {
  if (s.kind === 'cylinder') return segmentMatrix(s.from, s.to, s.radius);
  // a sphere may be an ellipsoid: its three radii along its turned axes
  const size = s.kind === 'box' ? s.size : (s.radii || [s.radius, s.radius, s.radius]);
  return new THREE.Matrix4().compose(new THREE.Vector3(...s.center),
                                     new THREE.Quaternion(...(s.rotation || [0, 0, 0, 1])),
                                     new THREE.Vector3(...size));
}

// Bodies' shapes (and joint markers): one instanced mesh per kind of geometry, so a
// chain of hundreds of links is a handful of draw calls.
class Shapes {
  constructor(group, shapes, geometries, material) {
    this.items = [];
    for (const [kind, geometry] of Object.entries(geometries)) {
      const own = shapes.filter((s) => s.kind === kind);
      if (!own.length) continue;
      const mesh = new THREE.InstancedMesh(geometry, material.clone(), own.length);
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      mesh.frustumCulled = false;
      own.forEach((s, i) => mesh.setColorAt(i, new THREE.Color(s.color)));
      group.add(mesh);
      this.items.push({ mesh, shapes: own, local: own.map(shapeMatrix) });
    }
  }

  update(poses) {
    const body = new THREE.Matrix4(), m = new THREE.Matrix4();
    for (const { mesh, shapes, local } of this.items) {
      shapes.forEach((s, i) => {
        if (s.body < 0) m.copy(local[i]);
        else m.multiplyMatrices(poses.matrix(s.body, body), local[i]);
        mesh.setMatrixAt(i, m);
      });
      mesh.instanceMatrix.needsUpdate = true;
    }
  }
}

// Constraint forces: a line from each joint point along the force, a cone at its tip.
class Arrows {
  constructor(group, scene, poses) {
    const f = scene.forces;
    this.arrows = scene.arrows;
    this.data = f ? decode(f.values, Int16Array) : null;
    this.unit = f ? f.unit : 0;           // force of one stored step
        this.length = f ? f.length : 0;       // world length of the largest force
    this.largest = f ? f.largest : 0;
    this.scale = 1;
    this.poses = poses;
    const n = this.arrows.length;
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(n * 6), 3));
    // drawn over the bodies: a joint's force often lies along a link, inside it
    this.lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({
      color: FORCE_COLOR, depthTest: false }));
    this.lines.frustumCulled = false;
    this.lines.renderOrder = 2;
    this.heads = new THREE.InstancedMesh(new THREE.ConeGeometry(0.5, 1, 12),
                                         new THREE.MeshBasicMaterial({ color: FORCE_COLOR,
                                                                       depthTest: false }),
                                         Math.max(n, 1));
    this.heads.renderOrder = 2;
    this.heads.frustumCulled = false;
    this.heads.count = 0;
    this.head = scene.extent * 0.02;
    group.add(this.lines, this.heads);
  }

  update(time) {
    if (!this.data || !this.arrows.length) return;
    const visible = this.scale > 0;
    this.lines.visible = this.heads.visible = visible;
    if (!visible) return;
    const [i, w] = this.poses.locate(time);
    const j = Math.min(i + 1, this.poses.frames - 1);
    const pos = this.lines.geometry.attributes.position.array;
    const per = this.length / this.largest * this.scale * this.unit;
    const P = new THREE.Vector3(), F = new THREE.Vector3(), m = new THREE.Matrix4();
    const tip = new THREE.Vector3(), base = new THREE.Vector3(), q = new THREE.Quaternion();
    const scale = new THREE.Vector3();
    let heads = 0;
    const count = this.arrows.length;
    this.arrows.forEach((arrow, k) => {
      this.poses.point(arrow.body, arrow.point, P);
      const a = (i * count + k) * 3, b = (j * count + k) * 3;
      const D = this.data;
      F.set(D[a] + w * (D[b] - D[a]), D[a + 1] + w * (D[b + 1] - D[a + 1]),
            D[a + 2] + w * (D[b + 2] - D[a + 2])).multiplyScalar(per);
      const length = F.length();
      const head = Math.min(this.head, 0.4 * length);
      tip.copy(P).add(F);
      base.copy(P).addScaledVector(F, length > 0 ? 1 - head / length : 1);
      pos[k * 6] = P.x; pos[k * 6 + 1] = P.y; pos[k * 6 + 2] = P.z;
      pos[k * 6 + 3] = base.x; pos[k * 6 + 4] = base.y; pos[k * 6 + 5] = base.z;
      if (head > 0) {
        q.setFromUnitVectors(UP, F.normalize());
        m.compose(base.add(tip).multiplyScalar(0.5), q, scale.set(head * 0.6, head, head * 0.6));
        this.heads.setMatrixAt(heads++, m);
      }
    });
    this.heads.count = heads;
    this.heads.instanceMatrix.needsUpdate = true;
    this.lines.geometry.attributes.position.needsUpdate = true;
  }
}

// The paths of traced points over the recorded frames, drawn up to the current frame.
class Traces {
  constructor(group, scene, poses) {
    this.lines = scene.traces.map((trace, k) => {
      const path = new Float32Array(poses.frames * 3);
      const v = new THREE.Vector3();
      for (let i = 0; i < poses.frames; i++) {
        poses.at(poses.t[i]);
        poses.point(trace.body, trace.point, v);
        path.set([v.x, v.y, v.z], 3 * i);
      }
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.BufferAttribute(path, 3));
      const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({
        color: TRACE_COLORS[k % TRACE_COLORS.length] }));
      line.frustumCulled = false;
      group.add(line);
      return line;
    });
  }

  update(frame) {
    for (const line of this.lines) line.geometry.setDrawRange(0, frame + 1);
  }
}

// Lines between points (a system of particles' sticks).
class Sticks {
  constructor(group, scene, poses) {
    this.pairs = scene.sticks;
    this.poses = poses;
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position',
                          new THREE.BufferAttribute(new Float32Array(this.pairs.length * 6), 3));
    this.lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color: 0x555555 }));
    this.lines.frustumCulled = false;
    group.add(this.lines);
  }

  update() {
    const pos = this.lines.geometry.attributes.position.array, p = this.poses.p;
    this.pairs.forEach(([a, b], k) => {
      pos.set([p[3 * a], p[3 * a + 1], p[3 * a + 2], p[3 * b], p[3 * b + 1], p[3 * b + 2]], 6 * k);
    });
    this.lines.geometry.attributes.position.needsUpdate = true;
  }
}

// A small time plot on a 2D canvas: the curves drawn once, a cursor at the current time.
class Plot {
  constructor(canvas, plot) {
    this.canvas = canvas;
    this.t = decode(plot.t, Float32Array);
    this.series = plot.series.map((s) => ({ ...s, y: decode(s.values, Float32Array) }));
    this.title = plot.title;
    this.log = plot.log;
    this.drawn = false;
    this.line = document.createElement('div');
    this.line.className = 'cursor';
    canvas.parentElement.appendChild(this.line);
  }

  draw() {
    const c = this.canvas, ctx = c.getContext('2d');
    const W = c.width, H = c.height, L = 58, R = 8, T = 20, B = 22;
    const value = (v) => (this.log ? Math.log10(Math.max(v, 1e-300)) : v);
    let lo = Infinity, hi = -Infinity;
    for (const s of this.series) for (const v of s.y) {
      if (!Number.isFinite(v) || (this.log && v <= 0)) continue;
      lo = Math.min(lo, value(v)); hi = Math.max(hi, value(v));
    }
    if (!Number.isFinite(lo)) { lo = 0; hi = 1; }
    if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) { hi += 0.5; lo -= 0.5; }
    const t0 = this.t[0], t1 = this.t[this.t.length - 1] || 1;
    this.x = (t) => L + (W - L - R) * (t - t0) / ((t1 - t0) || 1);
    const y = (v) => T + (H - T - B) * (hi - value(v)) / (hi - lo);
    ctx.fillStyle = '#fff'; ctx.fillRect(0, 0, W, H);
    ctx.strokeStyle = '#999'; ctx.strokeRect(L, T, W - L - R, H - T - B);
    ctx.fillStyle = '#222'; ctx.font = '12px sans-serif';
    ctx.fillText(this.title, L, 14);
    const label = (v) => (this.log ? `1e${v.toFixed(0)}` : v.toPrecision(3));
    ctx.fillText(label(hi), 2, T + 10);
    ctx.fillText(label(lo), 2, H - B);
    ctx.fillText(`${t0.toPrecision(3)} s`, L, H - 6);
    const end = `${t1.toPrecision(3)} s`;
    ctx.fillText(end, W - R - ctx.measureText(end).width, H - 6);
    let right = W - R;  // the legend: on the title's line, right-aligned, off the data
    for (const s of [...this.series].reverse()) {
      ctx.fillStyle = s.color;
      right -= ctx.measureText(s.name).width;
      ctx.fillText(s.name, right, 14);
      right -= 10;
    }
    this.series.forEach((s) => {
      ctx.strokeStyle = s.color; ctx.beginPath();
      let pen = false;
      s.y.forEach((v, i) => {
        if (!Number.isFinite(v) || (this.log && v <= 0)) { pen = false; return; }
        const X = this.x(this.t[i]), Y = y(v);
        if (pen) ctx.lineTo(X, Y); else ctx.moveTo(X, Y);
        pen = true;
      });
      ctx.stroke();
    });
    this.drawn = true;
    Object.assign(this.line.style, { top: `${c.offsetTop + T}px`, height: `${H - T - B}px` });
  }

  // the cursor is a positioned element over the canvas: moving it redraws nothing
  cursor(time) {
    if (!this.drawn) this.draw();
    const scale = this.canvas.clientWidth / this.canvas.width;
    this.line.style.left = `${this.canvas.offsetLeft + scale * this.x(time)}px`;
  }
}

function main() {
  const scene = JSON.parse(document.getElementById('dalembert-scene').textContent);
  const poses = new Poses(scene);
  const view = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const world = new THREE.Scene();
  world.background = new THREE.Color(0xf4f5f7);
  const up = new THREE.Vector3(...scene.up).normalize();
  const camera = new THREE.PerspectiveCamera(40, 1, scene.extent * 1e-3, scene.extent * 100);
  camera.up.copy(up);
  const center = new THREE.Vector3(...scene.center);
  // look across the horizontal direction the motion spans least, turned a little and
  // from slightly above so that depth shows
  const side = new THREE.Vector3(...scene.view).normalize().applyAxisAngle(up, 0.45);
  camera.position.copy(center).addScaledVector(side, scene.extent * 1.7)
    .addScaledVector(up, scene.extent * 0.45);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(center);
  controls.update();
  world.add(new THREE.HemisphereLight(0xffffff, 0x8899aa, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.copy(up).multiplyScalar(scene.extent * 3).addScaledVector(side, scene.extent);
  world.add(sun);

  const material = new THREE.MeshLambertMaterial();
  const geometries = {
    cylinder: new THREE.CylinderGeometry(1, 1, 1, 10),
    box: new THREE.BoxGeometry(1, 1, 1),
    sphere: new THREE.SphereGeometry(1, 10, 6),
  };
  const bodies = new Shapes(world, scene.shapes.map((s) => ({
    ...s, color: s.body < 0 ? GROUND_COLOR : PALETTE[s.body % PALETTE.length] })),
  geometries, material);
  const jointGroup = new THREE.Group();
  world.add(jointGroup);
  const joints = new Shapes(jointGroup, scene.joints.map((j) => ({
    body: j.body, color: JOINT_COLOR, radius: j.radius, center: j.point,
    kind: j.axis ? 'cylinder' : 'sphere',
    from: j.axis && j.point.map((p, k) => p - 1.5 * j.radius * j.axis[k]),
    to: j.axis && j.point.map((p, k) => p + 1.5 * j.radius * j.axis[k]),
  })), geometries, new THREE.MeshLambertMaterial());
  const arrowGroup = new THREE.Group();
  world.add(arrowGroup);
  const arrows = new Arrows(arrowGroup, scene, poses);
  const traceGroup = new THREE.Group();
  world.add(traceGroup);
  const traces = new Traces(traceGroup, scene, poses);
  const sticks = new Sticks(world, scene, poses);

  const plots = scene.plots.map((p, k) => new Plot(document.getElementById(`plot${k}`), p));
  const slider = document.getElementById('time');
  const clock = document.getElementById('clock');
  const play = document.getElementById('play');
  const speed = document.getElementById('speed');
  const forceScale = document.getElementById('force-scale');
  const t0 = poses.t[0], t1 = poses.t[poses.frames - 1];
  const state = { time: t0, playing: true, last: null, frames: 0, shown: 0 };

  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = `${w}px`;
    renderer.domElement.style.height = `${h}px`;
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    plots.forEach((p) => { p.canvas.width = p.canvas.clientWidth; p.drawn = false; });
  }

  // the picture at ``time``; the controls and the plots' cursors too unless ``quiet``
  function show(time, quiet = false) {
    state.time = Math.min(Math.max(time, t0), t1);
    const frame = poses.at(state.time);
    bodies.update(poses);
    joints.update(poses);
    sticks.update();
    arrows.update(state.time);
    traces.update(frame);
    if (quiet) return;
    plots.forEach((p) => p.cursor(state.time));
    slider.value = String(Math.round(1000 * (state.time - t0) / ((t1 - t0) || 1)));
    clock.textContent = `t = ${state.time.toFixed(3)} s`;
  }

  function tick(now) {
    if (state.playing && state.last !== null) {
      let time = state.time + (now - state.last) / 1000 * Number(speed.value);
      if (time > t1) time = t0 + (time - t1) % ((t1 - t0) || 1);
      // the page's text and cursors change ten times a second: redrawing them every
      // frame costs more than the 3D picture
      const quiet = now - state.shown < 100;
      if (!quiet) state.shown = now;
      show(time, quiet);
    }
    state.last = now;
    controls.update();
    renderer.render(world, camera);
    state.frames++;
    requestAnimationFrame(tick);
  }

  function setPlaying(on) {
    state.playing = on;
    play.textContent = on ? 'Pause' : 'Play';
  }

  play.addEventListener('click', () => setPlaying(!state.playing));
  slider.addEventListener('input', () => {
    setPlaying(false);
    show(t0 + (t1 - t0) * Number(slider.value) / 1000);
  });
  forceScale.addEventListener('input', () => {
    arrows.scale = Number(forceScale.value) / 100;
    show(state.time);
  });
  arrows.scale = Number(forceScale.value) / 100;
  for (const [id, group] of [['show-joints', jointGroup], ['show-forces', arrowGroup],
                             ['show-traces', traceGroup]]) {
    const box = document.getElementById(id);
    box.addEventListener('change', () => { group.visible = box.checked; });
    group.visible = box.checked;
  }
  window.addEventListener('resize', resize);
  resize();
  show(t0);
  // for scripts driving the page (tests): where the time is, how many frames were drawn
  window.dalembertViewer = {
    get time() { return state.time; },
    get frames() { return state.frames; },
    get playing() { return state.playing; },
    setPlaying,
    show,
    ready: true,
  };
  requestAnimationFrame(tick);
}

main();
