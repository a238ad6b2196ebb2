// dome's viewer page: plays the meshes of an output folder instant by instant.
//
// Reads window.DOME_INDEX (index.js, written by `dome view`; the format is in
// common/view/output_index.h). World frame: millimetres, z up. Served by `dome view`
// the page fetches files; in an export (DOME_INDEX.packed) it loads each file as a
// script "<url>.js" that calls domeBlob(url, base64), because Chromium allows neither
// fetch nor WebGL textures from file:// (common/view/export.h). A 4D file of the output
// folder (INDEX.sequences, `dome export`) can be the source instead of the instants'
// files: stream_player.js reads and decodes it as it arrives (select "source", or
// ?sequence=<url>).
(function () {
  'use strict';

  const INDEX = window.DOME_INDEX;
  const BACKGROUND = 0x1d2127;
  const PREFETCH = 3;    // instants loaded ahead of the one shown
  const MAX_CACHED = 24; // loaded meshes kept (the farthest from the current go first)
  const query = new URLSearchParams(window.location.search);

  const $ = (id) => document.getElementById(id);
  const ui = {
    view: $('view'), play: $('play'), back: $('step-back'), forward: $('step-forward'),
    timeline: $('timeline'), timecode: $('timecode'), position: $('position'),
    variant: $('variant'), colouring: $('colouring'), showCameras: $('show-cameras'),
    status: $('status'), legend: $('legend'), panel: $('camera-panel'),
    cameraTitle: $('camera-title'), cameraImage: $('camera-image'),
    cameraDepth: $('camera-depth'), depthCaption: $('depth-caption'),
    cameraMask: $('camera-mask'), maskCaption: $('mask-caption'),
    cameraClose: $('camera-close'), source: $('source'), loop: $('loop'), speed: $('speed'),
    stats: $('stats'),
  };

  // ---- Bytes, over HTTP or from packed scripts ------------------------------------

  const packedWaiting = new Map();  // url -> {resolve, reject}
  window.domeBlob = function (url, base64) {
    const w = packedWaiting.get(url);
    if (!w) return;
    packedWaiting.delete(url);
    const text = atob(base64);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; ++i) bytes[i] = text.charCodeAt(i);
    w.resolve(bytes.buffer);
  };
  window.domeBlobError = function (url, why) {
    const w = packedWaiting.get(url);
    if (!w) return;
    packedWaiting.delete(url);
    w.reject(new Error(why));
  };

  function loadBytes(url) {
    if (!INDEX.packed) {
      return fetch(url).then((r) => {
        if (r.ok) return r.arrayBuffer();
        return r.text().then((t) => { throw new Error(t.trim() || url + ': HTTP ' + r.status); });
      });
    }
    return new Promise((resolve, reject) => {
      packedWaiting.set(url, { resolve, reject });
      const s = document.createElement('script');
      s.src = url + '.js';
      s.onload = () => s.remove();
      s.onerror = () => {
        s.remove();
        window.domeBlobError(url, url + ': not in the export');
      };
      document.head.appendChild(s);
    });
  }

  const decodeText = (buffer) => new TextDecoder().decode(buffer);

  function loadTexture(buffer) {
    const url = URL.createObjectURL(new Blob([buffer], { type: 'image/png' }));
    return new Promise((resolve, reject) => {
      new THREE.TextureLoader().load(url, (t) => { URL.revokeObjectURL(url); resolve(t); },
        undefined, () => { URL.revokeObjectURL(url); reject(new Error('texture is not a readable PNG')); });
    });
  }

  // ---- Scene ------------------------------------------------------------------------

  // On a software rasterizer (Chromium's SwiftShader without a GPU, Mesa's llvmpipe)
  // multisampling costs more than half the frame rate (1280x800, the demo's 4D file: 15
  // fps with it, 32 without), so it is on only where a GPU draws (?aa=0 / ?aa=1
  // override), and the frusta are drawn as edges only (their translucent faces, still
  // picked by a click, cost a quarter of it).
  function softwareRasterizer() {
    try {
      const gl = document.createElement('canvas').getContext('webgl');
      const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
      const name = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : '';
      const lose = gl && gl.getExtension('WEBGL_lose_context');
      if (lose) lose.loseContext();
      return /SwiftShader|llvmpipe|softpipe|software/i.test(name);
    } catch (e) {
      return false;
    }
  }
  const software = softwareRasterizer();
  const antialias = query.has('aa') ? query.get('aa') !== '0' : !software;
  const renderer = new THREE.WebGLRenderer({ antialias });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(BACKGROUND);
  ui.view.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, 1, 10, 100000);
  camera.up.set(0, 0, 1);
  camera.position.set(5000, -8000, 4000);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 0, 1000);
  controls.enableDamping = true;
  scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 1.0));
  const headlight = new THREE.DirectionalLight(0xffffff, 0.5);
  camera.add(headlight);
  scene.add(camera);
  const meshRoot = new THREE.Group();
  scene.add(meshRoot);

  function resize() {
    const w = ui.view.clientWidth, h = ui.view.clientHeight;
    renderer.setSize(w, h);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }
  window.addEventListener('resize', resize);
  resize();

  // ---- Cameras as frusta ------------------------------------------------------------

  const frusta = new THREE.Group();
  scene.add(frusta);
  const pickables = [];
  const FRUSTUM_COLOUR = 0x8fa3b8, SELECTED_COLOUR = 0xffc040;
  INDEX.cameras.forEach((cam, c) => {
    const o = new THREE.Vector3().fromArray(cam.centre_mm);
    const k = cam.corners_mm.map((p) => new THREE.Vector3().fromArray(p));
    const lines = new THREE.BufferGeometry().setFromPoints([
      o, k[0], o, k[1], o, k[2], o, k[3], k[0], k[1], k[1], k[2], k[2], k[3], k[3], k[0]]);
    const edge = new THREE.LineSegments(lines, new THREE.LineBasicMaterial({ color: FRUSTUM_COLOUR }));
    const faces = new THREE.BufferGeometry().setFromPoints([
      o, k[0], k[1], o, k[1], k[2], o, k[2], k[3], o, k[3], k[0], k[0], k[1], k[2], k[0], k[2], k[3]]);
    const pick = new THREE.Mesh(faces, new THREE.MeshBasicMaterial({
      color: FRUSTUM_COLOUR, transparent: true, opacity: 0.12, side: THREE.DoubleSide,
      depthWrite: false, visible: !software }));
    pick.userData.camera = c;
    edge.userData.camera = c;
    frusta.add(edge, pick);
    pickables.push(pick);
  });

  // ---- Error colours ----------------------------------------------------------------

  // Blue (on the truth) through yellow to red (error_range_mm or more).
  const STOPS = [[0, [44, 123, 182]], [0.25, [171, 217, 233]], [0.5, [255, 255, 191]],
    [0.75, [253, 174, 97]], [1, [215, 25, 28]]];
  function errorColour(t, out, at) {
    t = Math.min(Math.max(isFinite(t) ? t : 1, 0), 1);
    let i = 1;
    while (i < STOPS.length - 1 && t > STOPS[i][0]) ++i;
    const [t0, a] = STOPS[i - 1], [t1, b] = STOPS[i];
    const f = (t - t0) / (t1 - t0);
    for (let k = 0; k < 3; ++k) out[at + k] = (a[k] + f * (b[k] - a[k])) / 255;
  }
  function buildLegend() {
    const r = INDEX.error_range_mm;
    ui.legend.querySelector('.legend-bar').style.background = 'linear-gradient(to right, ' +
      STOPS.map(([t, c]) => 'rgb(' + c.join(',') + ') ' + (t * 100) + '%').join(', ') + ')';
    const ticks = ui.legend.querySelector('.legend-ticks');
    ticks.innerHTML = '';
    for (let q = 0; q <= 4; ++q) {
      const s = document.createElement('span');
      s.style.left = (q * 25) + '%';
      s.textContent = (q === 4 ? '\u2265' : '') + +(r * q / 4).toFixed(1);
      ticks.appendChild(s);
    }
  }
  buildLegend();

  // ---- Loading an instant's mesh ----------------------------------------------------

  const plyLoader = new THREE.PLYLoader();
  const surfaceGrey = () => new THREE.MeshLambertMaterial({ color: 0xc8c8c8, side: THREE.DoubleSide });

  function parsePly(buffer, what) {
    let g;
    try {
      g = plyLoader.parse(buffer);
    } catch (e) {
      throw new Error(what + ' is not a readable PLY (' + e.message + ')');
    }
    const pos = g.getAttribute('position');
    if (!pos || pos.count === 0 || !g.index || g.index.count === 0) {
      throw new Error(what + ' has no triangles (empty or corrupt PLY)');
    }
    for (let i = 0; i < pos.array.length; ++i) {
      if (!isFinite(pos.array[i])) throw new Error(what + ' has non-finite coordinates');
    }
    if (!g.getAttribute('normal')) g.computeVertexNormals();
    return g;
  }

  // dome's GLB node maps world mm (z up) to glTF's metres (y up): x' = x, y' = z,
  // z' = -y, times 0.001 (common/mesh/gltf.h). Undo it so GLB and PLY meshes share
  // the world frame of the frusta.
  const GLTF_TO_WORLD = new THREE.Matrix4().set(
    1000, 0, 0, 0,
    0, 0, -1000, 0,
    0, 1000, 0, 0,
    0, 0, 0, 1);
  function fromGltfFrame(object) {
    const world = new THREE.Group();
    world.matrixAutoUpdate = false;
    world.matrix.copy(GLTF_TO_WORLD);
    world.add(object);
    // The atlas already holds the observed shading: show it unlit, as the OBJ path does.
    object.traverse((m) => {
      if (m.isMesh && m.material && m.material.map) {
        // GLTFLoader marks base colour textures sRGB, which the renderer (linear output)
        // would darken: the atlas holds the cameras' pixel values, shown as they are, as
        // the OBJ path and the 4D player show them.
        m.material.map.encoding = THREE.LinearEncoding;
        m.material = new THREE.MeshBasicMaterial({ map: m.material.map, side: THREE.DoubleSide });
      }
    });
    return world;
  }

  // Resolves to {object, ...}: the mesh in world mm, its surface colours when any.
  function loadMesh(inst, variant) {
    if (variant === 'fused' || variant === 'decimated') {
      const url = inst[variant];
      if (!url) return Promise.reject(new Error('no ' + variant + ' mesh was written'));
      return loadBytes(url).then((buffer) => {
        const g = parsePly(buffer, url);
        const coloured = !!g.getAttribute('color');
        const mat = coloured
          ? new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide })
          : surfaceGrey();
        return { object: new THREE.Mesh(g, mat), surfaceColours: g.getAttribute('color') || null };
      });
    }
    if (inst.textured_glb) {
      return loadBytes(inst.textured_glb).then((buffer) => new Promise((resolve, reject) => {
        const fail = (e) => reject(new Error(inst.textured_glb + ' is not a readable glTF (' + (e.message || e) + ')'));
        try {
          new THREE.GLTFLoader().parse(buffer, '', (gltf) => resolve({ object: fromGltfFrame(gltf.scene) }), fail);
        } catch (e) {
          fail(e);
        }
      }));
    }
    if (!inst.textured_obj || !inst.textured_png) {
      return Promise.reject(new Error('no textured mesh was written'));
    }
    return Promise.all([loadBytes(inst.textured_obj), loadBytes(inst.textured_png)])
      .then(([obj, png]) => {
        let group;
        try {
          group = new THREE.OBJLoader().parse(decodeText(obj));
        } catch (e) {
          throw new Error(inst.textured_obj + ' is not a readable OBJ (' + e.message + ')');
        }
        let triangles = 0;
        group.traverse((m) => { if (m.isMesh) triangles += m.geometry.getAttribute('position').count / 3; });
        if (triangles === 0) throw new Error(inst.textured_obj + ' has no triangles');
        return loadTexture(png).then((texture) => {
          group.traverse((m) => {
            if (m.isMesh) m.material = new THREE.MeshBasicMaterial({ map: texture, side: THREE.DoubleSide });
          });
          return { object: group };
        });
      });
  }

  function loadErrors(inst, variant, entry) {
    const url = inst.error && inst.error[variant];
    if (!url) return Promise.reject(new Error('no truth to compare with for this mesh'));
    return loadBytes(url).then((buffer) => {
      const errors = new Float32Array(buffer);
      const count = entry.object.geometry.getAttribute('position').count;
      if (errors.length !== count) {
        throw new Error(url + ' has ' + errors.length + ' values for ' + count + ' vertices');
      }
      const colours = new Float32Array(3 * count);
      for (let v = 0; v < count; ++v) errorColour(errors[v] / INDEX.error_range_mm, colours, 3 * v);
      entry.errorColours = new THREE.BufferAttribute(colours, 3);
      entry.errorMaterial = new THREE.MeshLambertMaterial({
        vertexColors: THREE.VertexColors, side: THREE.DoubleSide });
      entry.surfaceMaterial = entry.object.material;
      return entry;
    });
  }

  const cache = new Map();  // "instant|variant" -> Promise of {object, ...}
  function request(i, variant) {
    const key = i + '|' + variant;
    if (!cache.has(key)) {
      const p = loadMesh(INDEX.instants[i], variant);
      p.catch(() => {});  // failures are shown when the instant is
      cache.set(key, p);
      evict();
    }
    return cache.get(key);
  }
  function evict() {
    if (cache.size <= MAX_CACHED) return;
    const n = INDEX.instants.length;
    const ahead = (key) => (+key.split('|')[0] - state.index + n) % n;
    const keys = [...cache.keys()].sort((a, b) => ahead(b) - ahead(a));
    while (cache.size > MAX_CACHED) {
      const key = keys.shift();
      cache.get(key).then((e) => {
        if (meshRoot.children.includes(e.object)) return;
        e.object.traverse((m) => { if (m.isMesh) m.geometry.dispose(); });
      }, () => {});
      cache.delete(key);
    }
  }

  // ---- State and display ------------------------------------------------------------

  const state = {
    index: 0,
    variant: query.get('variant') || 'textured',
    colouring: 'surface',
    playing: false,
    settled: false,       // the current instant has loaded or failed
    missing: false,
    drawnInstant: null,   // instant whose mesh is in the scene
    shown: 0,             // instants displayed since the page loaded
    selectedCamera: -1,
    frames: 0,            // frames rendered
    firstDrawMs: null,    // performance.now() when a mesh was first on screen
    fitted: false,
    sequence: null,       // the DomeStreamPlayer when a 4D file is the source
    drawMs: 0,            // the last frame's renderer.render time
    frameTimes: [],       // performance.now() of the last frames rendered (playback rate)
  };
  ui.variant.value = state.variant;
  const rate = () => +(query.get('rate') || INDEX.play_rate_hz);

  function setStatus(text, kind) {
    ui.status.textContent = text;
    ui.status.className = kind || '';
  }

  function fitView(object) {
    const box = new THREE.Box3().setFromObject(object);
    if (box.isEmpty()) return;
    const centre = box.getCenter(new THREE.Vector3());
    const size = box.getSize(new THREE.Vector3()).length();
    const dir = new THREE.Vector3(0.55, -1, 0.45).normalize();
    controls.target.copy(centre);
    camera.position.copy(centre).addScaledVector(dir, 0.9 * size / Math.tan(camera.fov * Math.PI / 360) / 2);
    controls.update();
    state.fitted = true;
  }

  function applyColouring(entry) {
    const wantErrors = state.colouring === 'error' && entry.errorColours;
    const mesh = entry.object;
    if (!mesh.isMesh || !entry.surfaceMaterial) return;
    if (wantErrors) {
      mesh.geometry.setAttribute('color', entry.errorColours);
      mesh.material = entry.errorMaterial;
    } else {
      if (entry.surfaceColours) mesh.geometry.setAttribute('color', entry.surfaceColours);
      mesh.material = entry.surfaceMaterial;
    }
  }

  function showEntry(entry, i) {
    meshRoot.clear ? meshRoot.clear() : meshRoot.children.slice().forEach((c) => meshRoot.remove(c));
    meshRoot.add(entry.object);
    if (!state.fitted) fitView(entry.object);
    state.drawnInstant = i;
    state.drawnEntry = entry;
  }

  // The instants of the source being played.
  const count = () => (state.sequence ? state.sequence.instants.length : INDEX.instants.length);

  function showSequenceInstant(i) {
    const inst = state.sequence.instants[i];
    ui.timeline.value = i;
    ui.timecode.textContent = inst.timecode;
    ui.position.textContent = (i + 1) + ' / ' + count();
    if (inst.state === 'waiting') return;
    state.settled = true;
    if (inst.state === 'broken') {
      state.missing = true;
      setStatus('instant ' + inst.name + ' is broken: ' + inst.why, 'missing');
      return;
    }
    showEntry({ object: inst.object }, i);
    setStatus('');
  }

  function show(i) {
    const n = count();
    if (n === 0) return;
    i = ((i % n) + n) % n;
    state.index = i;
    state.settled = false;
    state.missing = false;
    ++state.shown;
    if (state.sequence) {
      showSequenceInstant(i);
      return;
    }
    const inst = INDEX.instants[i];
    ui.timeline.value = i;
    ui.timecode.textContent = inst.label;
    ui.position.textContent = (i + 1) + ' / ' + n;
    updateCameraPanel();
    const variant = state.variant, colouring = state.colouring;
    let p = request(i, variant);
    if (colouring === 'error' && (variant === 'fused' || variant === 'decimated')) {
      p = p.then((entry) => entry.errorColours ? entry : loadErrors(inst, variant, entry)
        .catch((e) => { entry.errorNote = e.message; return entry; }));
    }
    p.then((entry) => {
      if (state.index !== i || state.variant !== variant) return;
      applyColouring(entry);
      showEntry(entry, i);
      state.settled = true;
      if (colouring === 'error' && !entry.errorColours) {
        setStatus(inst.label + ': no error colouring: ' +
          (entry.errorNote || 'shown on the fused and decimated meshes only'), 'info');
      } else {
        setStatus('');
      }
    }, (e) => {
      if (state.index !== i || state.variant !== variant) return;
      meshRoot.children.slice().forEach((c) => meshRoot.remove(c));
      state.drawnInstant = null;
      state.drawnEntry = null;
      state.missing = true;
      state.settled = true;
      setStatus(inst.label + ': ' + variant + ' mesh missing: ' + e.message, 'missing');
    });
    for (let k = 1; k <= PREFETCH && k < n; ++k) request((i + k) % n, variant);
  }

  // ---- Playback ---------------------------------------------------------------------

  let timer = null;
  const speed = () => +ui.speed.value;
  // Seconds the shown instant stays: a 4D file's timeline (its instants' timecodes),
  // else the index's playback rate; both divided by the speed.
  function holdSeconds() {
    if (state.sequence) {
      const inst = state.sequence.instants, i = state.index;
      const fps = state.sequence.manifest ? state.sequence.manifest.fps : 30;
      const next = i + 1 < inst.length ? inst[i + 1].start_s : inst[i].start_s + 1 / fps;
      return Math.max(next - inst[i].start_s, 1 / fps) / speed();
    }
    return 1 / rate() / speed();
  }
  function tick() {
    timer = null;
    if (!state.playing) return;
    // Never skip an instant: wait until the shown one has loaded (or failed).
    if (state.settled) {
      if (state.index + 1 >= count() && !ui.loop.checked) { setPlaying(false); return; }
      show(state.index + 1);
      timer = setTimeout(tick, 1000 * holdSeconds());
    } else {
      if (state.sequence) showSequenceInstant(state.index);
      timer = setTimeout(tick, 10);
    }
  }
  function setPlaying(on) {
    state.playing = on;
    ui.play.textContent = on ? 'Pause' : 'Play';
    if (on && timer === null) timer = setTimeout(tick, 1000 * holdSeconds());
    if (!on && timer !== null) { clearTimeout(timer); timer = null; }
  }
  ui.play.addEventListener('click', () => setPlaying(!state.playing));
  ui.back.addEventListener('click', () => { setPlaying(false); show(state.index - 1); });
  ui.forward.addEventListener('click', () => { setPlaying(false); show(state.index + 1); });
  ui.timeline.addEventListener('input', () => { setPlaying(false); show(+ui.timeline.value); });
  ui.variant.addEventListener('change', () => { state.variant = ui.variant.value; show(state.index); });
  ui.colouring.addEventListener('change', () => {
    state.colouring = ui.colouring.value;
    ui.legend.hidden = state.colouring !== 'error';
    show(state.index);
  });
  ui.showCameras.addEventListener('change', () => { frusta.visible = ui.showCameras.checked; });

  // ---- A 4D file as the source ------------------------------------------------------

  const warmScene = new THREE.Scene(), warmTarget = new THREE.WebGLRenderTarget(1, 1);
  function openSequence(url) {
    setPlaying(false);
    state.sequence = null;
    state.fitted = false;
    if (!url) {
      ui.timeline.max = Math.max(INDEX.instants.length - 1, 0);
      show(0);
      return;
    }
    const player = DomeStreamPlayer.open(url, {
      onManifest: () => { ui.timeline.max = Math.max(player.instants.length - 1, 0); },
      onInstant: (i) => {
        const inst = player.instants[i];
        // Upload its texture and buffers now (a 1x1 draw), not in the frame that first
        // shows it: a software rasterizer takes tens of ms for an atlas.
        if (inst.state === 'ready') {
          warmScene.add(inst.object);
          renderer.setRenderTarget(warmTarget);
          renderer.render(warmScene, camera);
          renderer.setRenderTarget(null);
          warmScene.remove(inst.object);
        }
        if (state.sequence === player && i === state.index && !state.settled) showSequenceInstant(i);
      },
      onEnd: () => {
        if (player.error && state.sequence === player) setStatus(url + ': ' + player.error, 'missing');
      },
    });
    state.sequence = player;
    if ([...ui.source.options].some((o) => o.value === url)) ui.source.value = url;
    state.index = 0;
    state.settled = false;
    meshRoot.children.slice().forEach((c) => meshRoot.remove(c));
    state.drawnInstant = null;
    setStatus('reading ' + url);
  }
  (INDEX.sequences || []).forEach((url) => {
    const o = document.createElement('option');
    o.value = url;
    o.textContent = url.replace(/^out\//, '');
    ui.source.appendChild(o);
  });
  ui.source.addEventListener('change', () => openSequence(ui.source.value));

  function updateStats() {
    if (!state.sequence) { ui.stats.textContent = ''; return; }
    const p = state.sequence, inst = p.instants[state.index];
    const buffered = p.instants.filter((x) => x.state === 'ready').length;
    const t = state.frameTimes, fps = t.length > 1 ? 1000 * (t.length - 1) / (t[t.length - 1] - t[0]) : 0;
    ui.stats.textContent = inst
      ? 'instant ' + (state.index + 1) + '/' + p.instants.length + ' ' + inst.timecode +
        ' | ' + (inst.triangles || 0).toLocaleString('en') + ' triangles' +
        ' | decode ' + (inst.decodeMs === null ? '-' : inst.decodeMs.toFixed(1)) + ' ms' +
        ' | draw ' + state.drawMs.toFixed(1) + ' ms | ' + fps.toFixed(0) + ' fps' +
        ' | buffered ' + buffered + '/' + p.instants.length
      : 'reading ' + p.url + ' (' + (p.bytes / 1e3).toFixed(0) + ' kB)';
  }
  window.addEventListener('keydown', (e) => {
    if (e.target.tagName === 'SELECT' || e.target.tagName === 'INPUT') return;
    if (e.key === ' ') { setPlaying(!state.playing); e.preventDefault(); }
    if (e.key === 'ArrowLeft') { setPlaying(false); show(state.index - 1); }
    if (e.key === 'ArrowRight') { setPlaying(false); show(state.index + 1); }
  });

  // ---- Picking a camera -------------------------------------------------------------

  function updateCameraPanel() {
    const c = state.selectedCamera;
    ui.panel.hidden = c < 0;
    frusta.children.forEach((o) => {
      if (o.isLineSegments) o.material.color.setHex(o.userData.camera === c ? SELECTED_COLOUR : FRUSTUM_COLOUR);
    });
    if (c < 0) return;
    const inst = INDEX.instants[state.index];
    const files = (inst.cameras && inst.cameras[c]) || {};
    ui.cameraTitle.textContent = INDEX.cameras[c].id + '  ' + inst.label;
    const setImage = (img, url) => {
      if (url) { img.src = url; img.hidden = false; } else { img.removeAttribute('src'); img.hidden = true; }
    };
    setImage(ui.cameraImage, files.image);
    setImage(ui.cameraDepth, files.depth);
    ui.depthCaption.textContent = files.depth
      ? (files.depth_source === 'truth' ? 'depth (truth), near red, far blue' : 'depth (stereo), near red, far blue')
      : 'no depth map for this instant';
    // The mask beside the image: the image darkened outside it, its outline in green.
    setImage(ui.cameraMask, files.mask);
    ui.maskCaption.textContent = files.mask
      ? 'mask (' + files.mask_source + '), background darkened'
      : 'no mask' + (INDEX.masks_unavailable ? ': ' + INDEX.masks_unavailable : ' for this instant');
  }
  ui.cameraClose.addEventListener('click', () => { state.selectedCamera = -1; updateCameraPanel(); });

  const raycaster = new THREE.Raycaster();
  let downAt = null;
  renderer.domElement.addEventListener('pointerdown', (e) => { downAt = [e.clientX, e.clientY]; });
  renderer.domElement.addEventListener('pointerup', (e) => {
    if (!downAt || Math.hypot(e.clientX - downAt[0], e.clientY - downAt[1]) > 4 || !frusta.visible) return;
    const r = renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2((e.clientX - r.left) / r.width * 2 - 1, -(e.clientY - r.top) / r.height * 2 + 1);
    raycaster.setFromCamera(ndc, camera);
    const hits = raycaster.intersectObjects(pickables);
    if (hits.length > 0) {
      state.selectedCamera = hits[0].object.userData.camera;
      updateCameraPanel();
    }
  });

  // ---- Render loop ------------------------------------------------------------------

  function frame() {
    requestAnimationFrame(frame);
    controls.update();
    const t0 = performance.now();
    renderer.render(scene, camera);
    state.drawMs = performance.now() - t0;
    state.frameTimes.push(t0);
    if (state.frameTimes.length > 60) state.frameTimes.shift();
    ++state.frames;
    if (state.frames % 10 === 0 || state.sequence) updateStats();
    if (state.firstDrawMs === null && state.drawnInstant !== null) {
      // Reading a pixel waits for the GPU, so the time is when the frame exists.
      const gl = renderer.getContext();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
      state.firstDrawMs = performance.now();
    }
  }

  // ---- Hooks for tests and benchmarks -----------------------------------------------

  function toPage(v) {
    const r = renderer.domElement.getBoundingClientRect();
    const p = v.clone().project(camera);
    if (p.z < -1 || p.z > 1) return null;
    return [r.left + (p.x + 1) / 2 * r.width, r.top + (1 - p.y) / 2 * r.height];
  }
  window.domeViewer = {
    state: () => ({
      index: state.index, timecode: ui.timecode.textContent, status: ui.status.textContent,
      settled: state.settled, missing: state.missing, drawnInstant: state.drawnInstant,
      shown: state.shown, frames: state.frames, firstDrawMs: state.firstDrawMs,
      playing: state.playing, instants: INDEX.instants.length, antialias, software,
      errorColoured: !!(state.drawnEntry && state.drawnEntry.errorColours && state.colouring === 'error'),
      stats: ui.stats.textContent,
      sequence: state.sequence && {
        url: state.sequence.url, bytes: state.sequence.bytes, totalBytes: state.sequence.totalBytes,
        done: state.sequence.done, error: state.sequence.error,
        manifestMs: state.sequence.manifestMs, firstReadyMs: state.sequence.firstReadyMs,
        instants: state.sequence.instants.map((x) => ({ name: x.name, state: x.state, why: x.why,
          triangles: x.triangles, decodeMs: x.decodeMs, readyAtBytes: x.readyAtBytes })),
      },
    }),
    // performance.now() of the frames rendered since the last call (playback timing).
    frameTimes: () => state.frameTimes.slice(),
    openSequence: (url) => openSequence(url),
    setPlaying: (on) => setPlaying(on),
    setSpeed: (x) => { ui.speed.value = String(x); },
    setLoop: (on) => { ui.loop.checked = on; },
    // Page coordinates (CSS px) of the centroids of up to n triangles of the drawn mesh
    // that lie inside the canvas and are not thin (interior points: a vertex on the
    // silhouette may fall on a background pixel).
    projectMesh: (n) => {
      const out = [];
      const r = renderer.domElement.getBoundingClientRect();
      const inside = (p) => p && p[0] >= r.left && p[0] < r.right && p[1] >= r.top && p[1] < r.bottom;
      meshRoot.updateMatrixWorld(true);
      meshRoot.traverse((m) => {
        if (!m.isMesh) return;
        const pos = m.geometry.getAttribute('position');
        const index = m.geometry.index;
        const triangles = index ? index.count / 3 : pos.count / 3;
        const corner = (t, k) => {
          const v = index ? index.getX(3 * t + k) : 3 * t + k;
          return toPage(new THREE.Vector3().fromBufferAttribute(pos, v).applyMatrix4(m.matrixWorld));
        };
        const step = Math.max(1, Math.floor(triangles / (20 * n)));
        for (let t = 0; t < triangles && out.length < n; t += step) {
          const [a, b, c] = [corner(t, 0), corner(t, 1), corner(t, 2)];
          if (!inside(a) || !inside(b) || !inside(c)) continue;
          // Inradius >= 1.5 px puts the centroid >= 1 px inside every edge, so its pixel
          // is covered (a thin sliver's centroid may not be).
          const area = Math.abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])) / 2;
          const perimeter = Math.hypot(b[0] - a[0], b[1] - a[1]) + Math.hypot(c[0] - b[0], c[1] - b[1]) +
            Math.hypot(a[0] - c[0], a[1] - c[1]);
          if (2 * area / perimeter >= 1.5) out.push([(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3]);
        }
      });
      return out;
    },
    // Renders a frame and reads back the canvas's RGB at page points [[x, y], ...].
    readPixels: (points) => {
      controls.update();
      renderer.render(scene, camera);
      const canvas = renderer.domElement, r = canvas.getBoundingClientRect();
      const gl = renderer.getContext(), px = new Uint8Array(4), scale = canvas.width / r.width;
      return points.map(([x, y]) => {
        gl.readPixels(Math.floor((x - r.left) * scale), canvas.height - 1 - Math.floor((y - r.top) * scale),
          1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
        return [px[0], px[1], px[2]];
      });
    },
    setMeshVisible: (on) => { meshRoot.visible = on; },
    setCamerasVisible: (on) => { frusta.visible = on; ui.showCameras.checked = on; },
    // Page coordinates of a point inside camera `id`'s frustum (its far face's centre).
    frustumPoint: (id) => {
      const c = INDEX.cameras.find((x) => x.id === id);
      if (!c) return null;
      const v = new THREE.Vector3();
      c.corners_mm.forEach((p) => v.add(new THREE.Vector3().fromArray(p)));
      return toPage(v.multiplyScalar(0.25).lerp(new THREE.Vector3().fromArray(c.centre_mm), 0.1));
    },
    show: (i) => show(i),
  };

  if (query.get('sequence')) {
    openSequence(query.get('sequence'));
    if (query.get('autoplay') === '1') setPlaying(true);
  } else if (INDEX.instants.length === 0) {
    setStatus('no instants in this output folder', 'missing');
  } else {
    ui.timeline.max = INDEX.instants.length - 1;
    show(0);
    if (query.get('autoplay') === '1') setPlaying(true);
  }
  requestAnimationFrame(frame);
})();
