// Kestrel's live viewer page: decodes kestrel-viewer's frames (protocol in
// viewer/bridge/viewer_scene.h) into a model, and draws it: the 3D map as instanced voxels
// (three.js), the 2D maps, each vehicle's pose, flown and planned paths and goal, the explorers'
// candidates as arrows, and the map entropy over time. With several vehicles
// (docs/design.md §7.10) each one is drawn in its own colour and labelled with its prefix; with
// one, as before.
//
// The model does not depend on three.js: if the 3D view cannot start (no WebGL, three.js not
// staged) the rest of the page still works. window.kestrelViewer exposes the model's counters
// for tests (tests/viewer/viewer_e2e.mjs).

const state = {
  connected: false,
  connections: 0,            // WebSocket connections opened
  messagesReceived: 0,       // WebSocket messages of any kind
  voxelSnapshots: 0,         // voxel frames with the reset flag
  voxelDeltas: 0,            // voxel frames without it
  voxelCount: 0,             // occupied cells in the model
  renderedVoxels: 0,         // instances drawn by the 3D view
  mapSeq: -1,
  grids: [],                 // names of the 2D maps received
  pathPoints: 0,             // flown path points, all vehicles
  planPoints: 0,             // plan samples, all vehicles
  candidates: 0,             // candidates, all vehicles
  entropyPoints: 0,
  pose: null,                // the first vehicle's
  vehicles: [],              // per vehicle: {prefix, color, pathPoints, planPoints, candidates, state, pose}
  status: null,
  hello: null,
  errors: [],                // decode errors and the 3D view's start-up error, if any
  view3d: 'starting',        // 'ok' once the 3D view renders, else why not
  frames: 0,                 // 3D frames rendered
};
window.kestrelViewer = state;

// ---------------------------------------------------------------------------------------------
// Model

const model = {
  voxels: new Map(),     // key -> {x, y, z, q}
  origin: [0, 0, 0],
  resolution: 0.075,
  grids: new Map(),      // name -> {width, height, origin, heightM, resolution, values, utime}
  vehicles: [],          // by the bridge's vehicle index, see newVehicle()
  entropy: [],           // [[t_s, H]]
};

// Vehicle colours when there are several (the first one keeps the single vehicle's amber).
const kVehicleColors = ['#ffcc33', '#33ccff', '#ff5fd2', '#7dff5a', '#ff8c3a', '#b48cff',
                        '#3affc8', '#ff5050', '#c8c8c8', '#4d7dff', '#e6e64d', '#ff9ea8',
                        '#5ac88c', '#d28c4d', '#8cd2ff', '#d25ad2'];
const multi = () => model.vehicles.length > 1;

function newVehicle(prefix, index) {
  return {
    prefix, index, color: kVehicleColors[index % kVehicleColors.length],
    pose: null,          // {p, q, valid, utime}
    path: [],            // [[x, y, z]]
    plan: [],
    exploration: null,
  };
}
// The vehicle of a frame (index into hello's list); made on demand if the list is not known yet.
function vehicleOf(msg) {
  const k = Number.isInteger(msg.vehicle) ? msg.vehicle : 0;
  let changed = false;
  while (model.vehicles.length <= k) {
    model.vehicles.push(newVehicle(model.vehicles.length === 0 ? '' : `#${model.vehicles.length}`, model.vehicles.length));
    changed = true;
  }
  if (changed) view.vehiclesChanged();
  return model.vehicles[k];
}
function countVehicles() {
  state.vehicles = model.vehicles.map((v) => ({
    prefix: v.prefix, color: v.color, pathPoints: v.path.length, planPoints: v.plan.length,
    candidates: v.exploration ? v.exploration.candidates.length : 0,
    state: v.exploration ? v.exploration.state : null,
    pose: v.pose ? { p: v.pose.p, valid: v.pose.valid } : null,
  }));
  const sum = (key) => state.vehicles.reduce((n, v) => n + v[key], 0);
  state.pathPoints = sum('pathPoints');
  state.planPoints = sum('planPoints');
  state.candidates = sum('candidates');
  state.pose = state.vehicles.length > 0 ? state.vehicles[0].pose : null;
}
// The vehicle whose 2D map `name` is: the longest prefix it starts with ('' matches any).
function vehicleOfGrid(name) {
  let best = null;
  for (const v of model.vehicles) {
    if (name.startsWith(v.prefix) && (!best || v.prefix.length > best.prefix.length)) best = v;
  }
  return best;
}

const voxelKey = (x, y, z) => (x + 32768) + 65536 * ((y + 32768) + 65536 * (z + 32768));

function decodeVoxels(buffer) {
  const v = new DataView(buffer);
  const reset = (v.getUint8(1) & 1) !== 0;
  const n = v.getUint32(4, true);
  if (buffer.byteLength !== 48 + 8 * n) throw new Error(`voxel frame: ${buffer.byteLength} bytes for ${n} cells`);
  const origin = [v.getFloat64(8, true), v.getFloat64(16, true), v.getFloat64(24, true)];
  const resolution = v.getFloat64(32, true);
  const mapSeq = Number(v.getBigInt64(40, true));
  if (reset) {
    model.voxels.clear();
    view.clearVoxels();
    state.voxelSnapshots++;
  } else {
    state.voxelDeltas++;
  }
  model.origin = origin;
  model.resolution = resolution;
  for (let i = 0, o = 48; i < n; ++i, o += 8) {
    const x = v.getInt16(o, true), y = v.getInt16(o + 2, true), z = v.getInt16(o + 4, true);
    const q = v.getUint8(o + 6);
    const key = voxelKey(x, y, z);
    if (q === 0) {
      if (model.voxels.delete(key)) view.removeVoxel(key);
    } else {
      const cell = { x, y, z, q };
      model.voxels.set(key, cell);
      view.setVoxel(key, cell);
    }
  }
  state.voxelCount = model.voxels.size;
  state.mapSeq = mapSeq;
  view.voxelsChanged();
}

function decodeGrid(buffer) {
  const v = new DataView(buffer);
  const nameLength = v.getUint16(2, true);
  const width = v.getUint32(4, true), height = v.getUint32(8, true);
  const origin = [v.getFloat64(16, true), v.getFloat64(24, true)];
  const heightM = v.getFloat64(32, true), resolution = v.getFloat64(40, true);
  const utime = Number(v.getBigInt64(48, true));
  const name = new TextDecoder().decode(new Uint8Array(buffer, 56, nameLength));
  const valuesOffset = 56 + Math.ceil(nameLength / 8) * 8;
  if (buffer.byteLength !== valuesOffset + 4 * width * height) throw new Error(`grid frame ${name}: bad size`);
  const values = new Float32Array(buffer.slice(valuesOffset));
  model.grids.set(name, { name, width, height, origin, heightM, resolution, values, utime });
  state.grids = [...model.grids.keys()];
  panels.gridsChanged();
}

function onText(msg) {
  switch (msg.type) {
    case 'hello': {
      state.hello = msg;
      const prefixes = Array.isArray(msg.vehicles) && msg.vehicles.length > 0 ? msg.vehicles : [''];
      if (prefixes.join('\n') !== model.vehicles.map((v) => v.prefix).join('\n')) {
        model.vehicles = prefixes.map((p, k) => newVehicle(p, k));
        view.vehiclesChanged();
        countVehicles();
      }
      break;
    }
    case 'pose': {
      const v = vehicleOf(msg);
      v.pose = msg;
      view.poseChanged(v);
      countVehicles();
      break;
    }
    case 'path': {
      const v = vehicleOf(msg);
      if (msg.reset) v.path = [];
      for (const p of msg.points) v.path.push(p);
      view.pathChanged(v);
      countVehicles();
      break;
    }
    case 'plan': {
      const v = vehicleOf(msg);
      v.plan = msg.points;
      view.planChanged(v);
      countVehicles();
      break;
    }
    case 'exploration': {
      const v = vehicleOf(msg);
      v.exploration = msg;
      view.candidatesChanged(v);
      countVehicles();
      break;
    }
    case 'entropy':
      if (msg.reset) model.entropy = [];
      for (const p of msg.points) model.entropy.push(p);
      state.entropyPoints = model.entropy.length;
      break;
    case 'status': state.status = msg; break;
    default: break;
  }
  panels.dirty = true;
}

function onMessage(event) {
  state.messagesReceived++;
  try {
    if (typeof event.data === 'string') {
      onText(JSON.parse(event.data));
    } else {
      const kind = new DataView(event.data).getUint8(0);
      if (kind === 1) decodeVoxels(event.data);
      else if (kind === 2) decodeGrid(event.data);
    }
  } catch (e) {
    state.errors.push(String(e));
  }
  panels.dirty = true;
  view.dirty = true;
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/`);
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { state.connected = true; state.connections++; panels.dirty = true; };
  ws.onmessage = onMessage;
  ws.onclose = () => {
    state.connected = false;
    panels.dirty = true;
    setTimeout(connect, 1000);
  };
}

// ---------------------------------------------------------------------------------------------
// 3D view (three.js, loaded dynamically so that a failure leaves the rest working)

const view = {
  dirty: true,
  clearVoxels() {}, setVoxel() {}, removeVoxel() {}, voxelsChanged() {},
  vehiclesChanged() {}, poseChanged() {}, pathChanged() {}, planChanged() {}, candidatesChanged() {},
};

// Height colours (blue low -> red high), as in the paper's 3D map figures.
function heightColor(t, out) {
  const s = Math.min(1, Math.max(0, t));
  const r = Math.min(1, Math.max(0, 1.5 - Math.abs(4 * s - 3)));
  const g = Math.min(1, Math.max(0, 1.5 - Math.abs(4 * s - 2)));
  const b = Math.min(1, Math.max(0, 1.5 - Math.abs(4 * s - 1)));
  out[0] = 0.15 + 0.85 * r; out[1] = 0.15 + 0.85 * g; out[2] = 0.15 + 0.85 * b;
  return out;
}

async function startView() {
  const container = document.getElementById('view3d');
  let THREE, OrbitControls;
  try {
    THREE = await import('three');
    ({ OrbitControls } = await import('./OrbitControls.js'));
  } catch (e) {
    state.view3d = 'three.js not available: ' + e;
    state.errors.push(state.view3d);
    return;
  }
  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true });
  } catch (e) {
    state.view3d = 'no WebGL: ' + e;
    state.errors.push(state.view3d);
    return;
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  container.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1b1e23);
  const camera = new THREE.PerspectiveCamera(50, 1, 0.05, 200);
  camera.up.set(0, 0, 1);
  camera.position.set(-6, -9, 7);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.addEventListener('change', () => { view.dirty = true; });
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.4);
  sun.position.set(-3, -5, 10);
  scene.add(sun);
  const floor = new THREE.GridHelper(20, 20, 0x444a55, 0x30353d);
  floor.rotation.x = Math.PI / 2;
  scene.add(floor);
  scene.add(new THREE.AxesHelper(0.5));

  // Voxels: one InstancedMesh, slots kept dense by swap-remove, capacity doubled when full.
  const box = new THREE.BoxGeometry(1, 1, 1);
  const material = new THREE.MeshLambertMaterial({ color: 0xffffff });
  let capacity = 0, mesh = null;
  const slotOf = new Map();  // key -> slot
  const keyAt = [];          // slot -> key
  const m4 = new THREE.Matrix4(), color = new THREE.Color(), rgb = [0, 0, 0];
  let zRange = [0, 1];
  const grow = (needed) => {
    let next = Math.max(1024, capacity);
    while (next < needed) next *= 2;
    if (next === capacity) return;
    const bigger = new THREE.InstancedMesh(box, material, next);
    bigger.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    bigger.setColorAt(0, color);  // allocates instanceColor
    if (mesh) {
      bigger.instanceMatrix.array.set(mesh.instanceMatrix.array);
      bigger.instanceColor.array.set(mesh.instanceColor.array);
      scene.remove(mesh);
      mesh.dispose();
    }
    bigger.count = keyAt.length;
    bigger.frustumCulled = false;
    mesh = bigger;
    capacity = next;
    scene.add(mesh);
  };
  const place = (slot, cell) => {
    const r = model.resolution;
    m4.makeScale(0.94 * r, 0.94 * r, 0.94 * r);
    m4.setPosition(model.origin[0] + (cell.x + 0.5) * r, model.origin[1] + (cell.y + 0.5) * r,
                   model.origin[2] + (cell.z + 0.5) * r);
    mesh.setMatrixAt(slot, m4);
    const zM = model.origin[2] + (cell.z + 0.5) * r;
    heightColor((zM - zRange[0]) / Math.max(1e-6, zRange[1] - zRange[0]), rgb);
    // Darker for less certain cells (q = round(P * 255)).
    const shade = 0.55 + 0.45 * (cell.q / 255);
    color.setRGB(rgb[0] * shade, rgb[1] * shade, rgb[2] * shade);
    mesh.setColorAt(slot, color);
  };
  // The map's extent in cells, grown as voxels arrive: it sets the colour scale (height) and,
  // until the user moves the camera, the camera's framing.
  const box3 = { min: [Infinity, Infinity, Infinity], max: [-Infinity, -Infinity, -Infinity] };
  let userMoved = false, boxGrew = false;
  controls.addEventListener('start', () => { userMoved = true; });
  const extend = (cell) => {
    const p = [cell.x, cell.y, cell.z];
    for (let a = 0; a < 3; ++a) {
      if (p[a] < box3.min[a]) { box3.min[a] = p[a]; boxGrew = true; }
      if (p[a] > box3.max[a]) { box3.max[a] = p[a]; boxGrew = true; }
    }
  };
  const frame = () => {
    const r = model.resolution, o = model.origin;
    const zLo = o[2] + box3.min[2] * r, zHi = o[2] + (box3.max[2] + 1) * r;
    if (zLo !== zRange[0] || zHi !== zRange[1]) {
      zRange = [zLo, zHi];
      for (const [key, c] of model.voxels) place(slotOf.get(key), c);  // recolour
    }
    if (userMoved) return;
    const cx = o[0] + 0.5 * (box3.min[0] + box3.max[0] + 1) * r;
    const cy = o[1] + 0.5 * (box3.min[1] + box3.max[1] + 1) * r;
    const span = Math.max((box3.max[0] - box3.min[0] + 1) * r, (box3.max[1] - box3.min[1] + 1) * r, 2);
    controls.target.set(cx, cy, 0.5 * (zLo + zHi));
    camera.position.set(cx - 0.45 * span, cy - 0.75 * span, zHi + 0.6 * span);
    controls.update();
    floor.position.set(Math.round(cx), Math.round(cy), Math.min(0, zLo));
  };
  Object.assign(view, {
    clearVoxels() {
      slotOf.clear();
      keyAt.length = 0;
      if (mesh) mesh.count = 0;
      box3.min = [Infinity, Infinity, Infinity];
      box3.max = [-Infinity, -Infinity, -Infinity];
    },
    setVoxel(key, cell) {
      let slot = slotOf.get(key);
      if (slot === undefined) {
        grow(keyAt.length + 1);
        slot = keyAt.length;
        keyAt.push(key);
        slotOf.set(key, slot);
        mesh.count = keyAt.length;
        extend(cell);
      }
      place(slot, cell);
    },
    removeVoxel(key) {
      const slot = slotOf.get(key);
      if (slot === undefined) return;
      const last = keyAt.length - 1;
      if (slot !== last) {
        const moved = keyAt[last];
        keyAt[slot] = moved;
        slotOf.set(moved, slot);
        mesh.getMatrixAt(last, m4);
        mesh.setMatrixAt(slot, m4);
        mesh.getColorAt(last, color);
        mesh.setColorAt(slot, color);
      }
      keyAt.pop();
      slotOf.delete(key);
      mesh.count = keyAt.length;
    },
    voxelsChanged() {
      if (boxGrew && model.voxels.size > 0) frame();
      boxGrew = false;
      if (mesh) {
        mesh.instanceMatrix.needsUpdate = true;
        if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
      }
      state.renderedVoxels = mesh ? mesh.count : 0;
      view.dirty = true;
    },
  });

  // Each vehicle: a cone along its body x axis plus small axes, its flown path, its plan
  // (dashed), its candidates as arrows and, with several vehicles, its goal and a label. One
  // vehicle keeps the single-vehicle colours: amber cone, white path, cyan plan, red choice.
  const makeLine = (colorHex, dashed) => {
    const mat = dashed ? new THREE.LineDashedMaterial({ color: colorHex, dashSize: 0.1, gapSize: 0.06 })
                       : new THREE.LineBasicMaterial({ color: colorHex });
    const line = new THREE.Line(new THREE.BufferGeometry(), mat);
    line.frustumCulled = false;
    return line;
  };
  const makeLabel = (text, colorCss) => {
    const canvas = document.createElement('canvas');
    canvas.width = 256; canvas.height = 64;
    const ctx = canvas.getContext('2d');
    ctx.font = 'bold 40px "DejaVu Sans", sans-serif';
    ctx.textAlign = 'center'; ctx.textBaseline = 'middle';
    ctx.lineWidth = 6; ctx.strokeStyle = '#000000';
    ctx.strokeText(text, 128, 30);
    ctx.fillStyle = colorCss;
    ctx.fillText(text, 128, 30);
    const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(canvas), depthTest: false }));
    sprite.scale.set(1.2, 0.3, 1);
    sprite.renderOrder = 10;
    return sprite;
  };
  let drawn = [];  // per vehicle: its three.js objects
  const build = (v) => {
    const several = multi(), color = new THREE.Color(several ? v.color : '#ffcc33');
    const d = { group: new THREE.Group(), all: [] };
    const body = new THREE.Mesh(new THREE.ConeGeometry(0.12, 0.35, 16),
                                new THREE.MeshLambertMaterial({ color }));
    body.rotation.z = -Math.PI / 2;  // cone axis (+y) onto +x
    d.group.add(body);
    d.group.add(new THREE.AxesHelper(0.3));
    if (several) {
      const label = makeLabel(v.prefix || '(none)', v.color);
      label.position.set(0, 0, 0.4);
      d.group.add(label);
    }
    d.group.visible = false;
    d.path = makeLine(several ? color : 0xffffff, false);
    d.plan = makeLine(several ? color : 0x44ddff, true);
    d.arrows = new THREE.LineSegments(new THREE.BufferGeometry(),
                                      new THREE.LineBasicMaterial({ vertexColors: true }));
    d.arrows.frustumCulled = false;
    d.all.push(d.group, d.path, d.plan, d.arrows);
    if (several) {
      d.goal = new THREE.Mesh(new THREE.SphereGeometry(0.09, 16, 12),
                              new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.85 }));
      d.goal.visible = false;
      d.all.push(d.goal);
    }
    for (const o of d.all) scene.add(o);
    return d;
  };
  const setLine = (line, points) => {
    line.geometry.dispose();
    line.geometry = new THREE.BufferGeometry().setFromPoints(points.map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    if (line.material.isLineDashedMaterial) line.computeLineDistances();
    view.dirty = true;
  };
  const drawnOf = (v) => drawn[v.index];
  view.poseChanged = (v) => {
    const m = v.pose, d = drawnOf(v);
    if (!d) return;
    d.group.visible = m.valid;
    d.group.position.set(m.p[0], m.p[1], m.p[2]);
    d.group.quaternion.set(m.q[1], m.q[2], m.q[3], m.q[0]);
    view.dirty = true;
  };
  view.pathChanged = (v) => { if (drawnOf(v)) setLine(drawnOf(v).path, v.path); };
  view.planChanged = (v) => { if (drawnOf(v)) setLine(drawnOf(v).plan, v.plan); };
  // Candidates: arrows (shaft and head) at their pose, colour by objective; the chosen one red
  // (with several vehicles: in the vehicle's colour, and its goal a ball).
  view.candidatesChanged = (v) => {
    const d = drawnOf(v);
    if (!d) return;
    const e = v.exploration, pos = [], col = [];
    const several = multi(), own = new THREE.Color(v.color);
    let best = 1e-12;
    for (const c of e.candidates) best = Math.max(best, c[5]);
    e.candidates.forEach((c, i) => {
      const chosen = i === e.chosen, len = chosen ? 0.5 : 0.3, t = Math.max(0, c[5]) / best;
      const [x, y, z, yaw] = c, dx = Math.cos(yaw), dy = Math.sin(yaw);
      const tip = [x + len * dx, y + len * dy, z];
      const head = (s) => [tip[0] - 0.1 * (dx * Math.cos(s) - dy * Math.sin(s)) * (len / 0.3),
                           tip[1] - 0.1 * (dy * Math.cos(s) + dx * Math.sin(s)) * (len / 0.3), z];
      for (const seg of [[[x, y, z], tip], [tip, head(0.5)], [tip, head(-0.5)]]) {
        for (const p of seg) {
          pos.push(...p);
          if (chosen && several) col.push(own.r, own.g, own.b);
          else if (chosen) col.push(1, 0.15, 0.15);
          else col.push(0.2 + 0.8 * t, 0.9 * t + 0.1, 1 - 0.6 * t);
        }
      }
    });
    d.arrows.geometry.dispose();
    d.arrows.geometry = new THREE.BufferGeometry();
    d.arrows.geometry.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
    d.arrows.geometry.setAttribute('color', new THREE.Float32BufferAttribute(col, 3));
    if (d.goal) {
      const g = e.goal;
      d.goal.visible = e.chosen >= 0 && Array.isArray(g) && g.every(Number.isFinite);
      if (d.goal.visible) d.goal.position.set(g[0], g[1], g[2]);
    }
    view.dirty = true;
  };
  // (Re)builds every vehicle's objects and draws what the model holds.
  view.vehiclesChanged = () => {
    for (const d of drawn) {
      for (const o of d.all) {
        scene.remove(o);
        o.traverse((x) => { if (x.geometry) x.geometry.dispose(); });
      }
    }
    drawn = model.vehicles.map(build);
    for (const v of model.vehicles) {
      if (v.pose) view.poseChanged(v);
      view.pathChanged(v);
      view.planChanged(v);
      if (v.exploration) view.candidatesChanged(v);
    }
    view.dirty = true;
  };
  // Replay what arrived before the view started.
  for (const [key, c] of model.voxels) view.setVoxel(key, c);
  view.voxelsChanged();
  view.vehiclesChanged();

  const resize = () => {
    const w = container.clientWidth, h = container.clientHeight;
    renderer.setSize(w, h);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
    view.dirty = true;
  };
  window.addEventListener('resize', resize);
  resize();
  state.view3d = 'ok';
  const loop = () => {
    if (view.dirty) {  // draw only when something changed: the page idles at no cost
      view.dirty = false;
      renderer.render(scene, camera);
      state.frames++;
    }
    requestAnimationFrame(loop);
  };
  loop();
}

// ---------------------------------------------------------------------------------------------
// 2D panels: grid map with path, pose and candidates; entropy plot; status

// "MAP2D_COLLISION" -> "collision", "V2_MAP2D_COLLISION" -> "V2_ collision".
function gridLabel(name) {
  const m = /^(.*?)MAP2D_(.*)$/.exec(name);
  return m ? (m[1] ? `${m[1]} ` : '') + m[2].toLowerCase() : name.toLowerCase();
}

const panels = {
  dirty: true,
  userChoseGrid: false,
  gridsChanged() {
    const select = document.getElementById('gridSelect');
    const names = [...model.grids.keys()];
    if (select.options.length !== names.length) {
      const chosen = select.value;
      select.innerHTML = '';
      for (const n of names) select.add(new Option(gridLabel(n), n));
      const preferred = names.find((n) => /COMBINED/.test(n)) || names[0];
      select.value = panels.userChoseGrid && names.includes(chosen) ? chosen : preferred;
    }
    panels.dirty = true;
  },
};
document.getElementById('gridSelect').addEventListener('change', () => {
  panels.userChoseGrid = true;
  panels.dirty = true;
});

function drawGrid() {
  const canvas = document.getElementById('grid2d');
  const ctx = canvas.getContext('2d');
  ctx.fillStyle = '#111316';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const g = model.grids.get(document.getElementById('gridSelect').value);
  if (!g) {
    ctx.fillStyle = '#777';
    ctx.fillText('no 2D map yet', 10, 20);
    return;
  }
  let lo = Infinity, hi = -Infinity;
  for (const v of g.values) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  const probability = /COLLISION/.test(g.name);
  if (probability) { lo = 0; hi = 1; }
  const image = ctx.createImageData(g.width, g.height);
  for (let iy = 0; iy < g.height; ++iy) {
    for (let ix = 0; ix < g.width; ++ix) {
      const v = g.values[iy * g.width + ix];
      const t = Number.isFinite(v) ? (v - lo) / Math.max(1e-12, hi - lo) : 0;
      const o = 4 * ((g.height - 1 - iy) * g.width + ix);  // y up
      if (probability) {
        const c = 255 * (1 - t);
        image.data[o] = c; image.data[o + 1] = c; image.data[o + 2] = c;
      } else {
        const rgb = heightColor(t, [0, 0, 0]);
        image.data[o] = 255 * rgb[0]; image.data[o + 1] = 255 * rgb[1]; image.data[o + 2] = 255 * rgb[2];
      }
      image.data[o + 3] = 255;
    }
  }
  const scale = Math.min(canvas.width / g.width, canvas.height / g.height);
  const w = g.width * scale, h = g.height * scale;
  ctx.save();
  ctx.translate(Math.floor((canvas.width - w) / 2), 0);  // centred
  const off = document.createElement('canvas');
  off.width = g.width; off.height = g.height;
  off.getContext('2d').putImageData(image, 0, 0);
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(off, 0, 0, w, h);
  const toPx = (x, y) => [(x - g.origin[0]) / g.resolution * scale,
                          h - (y - g.origin[1]) / g.resolution * scale];
  const several = multi();
  for (const veh of model.vehicles) {  // every vehicle's flown path
    if (veh.path.length < 2) continue;
    ctx.strokeStyle = several ? veh.color : '#2a7fff'; ctx.lineWidth = 1.5;
    ctx.beginPath();
    veh.path.forEach((p, i) => { const [u, v] = toPx(p[0], p[1]); if (i) ctx.lineTo(u, v); else ctx.moveTo(u, v); });
    ctx.stroke();
  }
  const arrow = (x, y, yaw, len, style, width) => {
    const [u, v] = toPx(x, y), du = Math.cos(yaw) * len, dv = -Math.sin(yaw) * len;
    ctx.strokeStyle = style; ctx.lineWidth = width;
    ctx.beginPath();
    ctx.moveTo(u, v); ctx.lineTo(u + du, v + dv);
    const a = Math.atan2(dv, du);
    for (const s of [2.6, -2.6]) { ctx.moveTo(u + du, v + dv); ctx.lineTo(u + du + 0.4 * len * Math.cos(a + s), v + dv + 0.4 * len * Math.sin(a + s)); }
    ctx.stroke();
  };
  // The candidates of the vehicle whose 2D map this is (its explorer projected it).
  const owner = vehicleOfGrid(g.name);
  if (owner && owner.exploration) {
    const e = owner.exploration;
    e.candidates.forEach((c, i) => { if (i !== e.chosen) arrow(c[0], c[1], c[3], 9, '#e69f00', 1); });
    if (e.chosen >= 0) { const c = e.candidates[e.chosen]; arrow(c[0], c[1], c[3], 14, several ? owner.color : '#ff2020', 2); }
  }
  for (const veh of model.vehicles) {
    if (several && veh.exploration && veh.exploration.chosen >= 0) {  // goal: a ring
      const [u, v] = toPx(veh.exploration.goal[0], veh.exploration.goal[1]);
      ctx.strokeStyle = veh.color; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(u, v, 5, 0, 2 * Math.PI); ctx.stroke();
    }
    if (veh.pose && veh.pose.valid) {
      const q = veh.pose.q;
      const yaw = Math.atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
      arrow(veh.pose.p[0], veh.pose.p[1], yaw, 12, several ? veh.color : '#20d020', 2.5);
      if (several) {
        const [u, v] = toPx(veh.pose.p[0], veh.pose.p[1]);
        ctx.fillStyle = veh.color;
        ctx.fillText(veh.prefix || '(none)', u + 6, v - 6);
      }
    }
  }
  ctx.restore();
  ctx.fillStyle = '#9aa4b1';
  ctx.fillText(`${g.name}  ${g.width}x${g.height}  ${g.resolution.toFixed(3)} m  [${lo.toPrecision(3)}, ${hi.toPrecision(3)}]`, 4, canvas.height - 4);
}

function drawEntropy() {
  const canvas = document.getElementById('entropy');
  const ctx = canvas.getContext('2d');
  ctx.fillStyle = '#111316';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const pts = model.entropy;
  ctx.fillStyle = '#9aa4b1';
  if (pts.length < 2) { ctx.fillText('no entropy history yet', 10, 20); return; }
  const t0 = pts[0][0], t1 = pts[pts.length - 1][0];
  let lo = Infinity, hi = -Infinity;
  for (const p of pts) { lo = Math.min(lo, p[1]); hi = Math.max(hi, p[1]); }
  if (hi - lo < 1e-9) { hi += 1; lo -= 1; }
  const L = 56, R = 8, T = 8, B = 20, W = canvas.width - L - R, H = canvas.height - T - B;
  ctx.strokeStyle = '#444a55';
  ctx.strokeRect(L, T, W, H);
  ctx.fillText(hi.toExponential(3), 2, T + 8);
  ctx.fillText(lo.toExponential(3), 2, T + H);
  ctx.fillText('0 s', L, canvas.height - 5);
  ctx.fillText(`${(t1 - t0).toFixed(1)} s`, L + W - 40, canvas.height - 5);
  ctx.strokeStyle = '#ffb000'; ctx.lineWidth = 1.5;
  ctx.beginPath();
  pts.forEach((p, i) => {
    const u = L + (p[0] - t0) / Math.max(1e-9, t1 - t0) * W, v = T + (hi - p[1]) / (hi - lo) * H;
    if (i) ctx.lineTo(u, v); else ctx.moveTo(u, v);
  });
  ctx.stroke();
}

const escapeHtml = (t) => String(t).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
function drawStatus() {
  document.getElementById('conn').className = state.connected ? 'dot on' : 'dot';
  const s = state.status || {};
  document.getElementById('summary').textContent =
    `${state.voxelCount} occupied voxels  map seq ${state.mapSeq}` + (s.current === false ? ' (stale)' : '');
  // With several vehicles, a legend: each one's colour, prefix and explorer state.
  const legend = document.getElementById('legend');
  const entries = multi() ? model.vehicles.map((v) => {
    const e = v.exploration;
    return `<span class="swatch" style="background:${v.color}"></span>${escapeHtml(v.prefix || '(none)')} ` +
           `${e ? escapeHtml(e.state_name) : '-'}`;
  }) : [];
  const html = entries.join('&nbsp;&nbsp; ');
  if (legend.innerHTML !== html) legend.innerHTML = html;
  const vehicles = model.vehicles;
  // The state's name comes with the status, from the explorer's table (exploration/explorer_state.h).
  const explorerLine = (e) => (e ? `${e.state_name} (${e.mode}), plan ${e.seq}` : '-');
  const lines = [
    `connected        ${state.connected}`,
    `messages         ${state.messagesReceived}`,
    `voxel frames     ${state.voxelSnapshots} snapshot, ${state.voxelDeltas} delta`,
    `voxels           ${state.voxelCount}`,
    `path points      ${state.pathPoints}`,
  ];
  if (vehicles.length <= 1) {
    lines.push(`explorer         ${explorerLine(vehicles.length ? vehicles[0].exploration : null)}`);
  } else {  // one line per vehicle: its prefix, explorer state and plan
    for (const v of vehicles) {
      lines.push(`${`explorer ${v.prefix || '(none)'}`.padEnd(17)}${explorerLine(v.exploration)}`);
    }
  }
  lines.push(
    `candidates       ${state.candidates}`,
    `entropy          ${s.entropy !== undefined ? s.entropy.toExponential(5) + ' nats' : '-'}`,
    `rays/s           ${s.rays_per_s !== undefined ? Math.round(s.rays_per_s) : '-'}`,
  );
  for (const v of vehicles) {
    const e = v.exploration;
    if (e && e.reason) lines.push(`${vehicles.length > 1 ? `reason ${v.prefix || '(none)'}`.padEnd(17) : 'reason           '}${e.reason}`);
  }
  if (s.bridge) lines.push(`bridge           ${Object.entries(s.bridge).map(([k, v]) => `${k} ${v}`).join(', ')}`);
  if (state.view3d !== 'ok') lines.push(`3D view          ${state.view3d}`);
  document.getElementById('status').textContent = lines.join('\n');
}

function panelLoop() {
  if (panels.dirty) {
    panels.dirty = false;
    drawGrid();
    drawEntropy();
    drawStatus();
  }
  setTimeout(panelLoop, 200);
}

panelLoop();
connect();
startView();
