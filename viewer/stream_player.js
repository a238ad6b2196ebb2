// The 4D file player of dome's viewer: reads a `dome export` file (.dome4d, format in
// common/sequence/stream.h) as it arrives and decodes each instant as soon as its two
// records are in: the mesh with Draco's WebAssembly decoder (npm draco3d, copied to
// draco/ by the build), the atlas with the browser's own H.264 decoder (WebCodecs).
// Texture coordinates follow the atlas grid rule of common/mesh/texture.h over the
// decoded triangle order (sequence/mesh_codec.h), so the file carries none.
//
//   DomeStreamPlayer.open(url, {onManifest, onInstant, onEnd}) -> player
//     player.instants[i] = {name, timecode, start_s, triangles, state, why, object,
//                           decodeMs, readyAtBytes}; state: 'waiting', 'ready', 'broken'
//     player.bytes, player.totalBytes, player.done, player.error
// A record that fails its CRC-32, a file cut short, a mesh or frame that does not
// decode: that instant is 'broken' with the reason, the others play.
(function () {
  'use strict';

  const MAGIC = 'DOME4D\r\n';

  const CRC_TABLE = (() => {
    const t = new Uint32Array(256);
    for (let n = 0; n < 256; ++n) {
      let c = n;
      for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
      t[n] = c >>> 0;
    }
    return t;
  })();
  function crc32(bytes) {  // zlib's CRC-32 (ISO 3309)
    let c = 0xffffffff;
    for (let i = 0; i < bytes.length; ++i) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
    return (c ^ 0xffffffff) >>> 0;
  }

  let dracoModule = null;  // one Draco decoder module for every player
  function draco() {
    if (!dracoModule) {
      dracoModule = fetch('draco/draco_decoder.wasm')
        .then((r) => {
          if (!r.ok) throw new Error('draco/draco_decoder.wasm: HTTP ' + r.status);
          return r.arrayBuffer();
        })
        .then((wasm) => DracoDecoderModule({ wasmBinary: wasm }));
    }
    return dracoModule;
  }

  // The grid rule's corner k of triangle f, in texels from the atlas's top-left
  // (mesh::GridAtlasLayout::CornerTexel).
  const CORNER = [[[0, 0], [1, 0], [0, 1]], [[1, 1], [0, 1], [1, 0]]];

  // Positions (world mm) and texture coordinates (over the video frame, top-down) of a
  // mesh payload, one vertex per triangle corner.
  function decodeMesh(D, payload, width, height) {
    const view = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
    if (payload.byteLength < 24) throw new Error('mesh record is too short');
    const origin = [view.getFloat32(0, true), view.getFloat32(4, true), view.getFloat32(8, true)];
    const step = view.getFloat32(12, true);
    const cell = view.getUint32(16, true), columns = view.getUint32(20, true);
    if (!(step > 0) || cell < 1 || cell > 256 || columns < 1 || cell * columns > width) {
      throw new Error('mesh record has a bad grid or atlas layout');
    }
    const bytes = payload.subarray(24);
    if (bytes.length === 0) return { position: new Float32Array(0), uv: new Float32Array(0), triangles: 0 };
    const decoder = new D.Decoder();
    const mesh = new D.Mesh();
    try {
      const status = decoder.DecodeArrayToMesh(bytes, bytes.length, mesh);
      if (!status.ok() || mesh.ptr === 0) throw new Error('mesh record is not a Draco mesh: ' + status.error_msg());
      const nf = mesh.num_faces(), np = mesh.num_points();
      const attribute = decoder.GetAttribute(mesh, decoder.GetAttributeId(mesh, D.POSITION));
      const qBytes = np * 3 * 2, fBytes = nf * 3 * 4;
      const qPtr = D._malloc(qBytes), fPtr = D._malloc(fBytes);
      try {
        if (!decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, D.DT_UINT16, qBytes, qPtr) ||
            !decoder.GetTrianglesUInt32Array(mesh, fBytes, fPtr)) {
          throw new Error('mesh record has no 16-bit positions');
        }
        const q = new Uint16Array(D.HEAPU16.buffer, qPtr, np * 3);
        const tri = new Uint32Array(D.HEAPU32.buffer, fPtr, nf * 3);
        const position = new Float32Array(nf * 9), uv = new Float32Array(nf * 6);
        for (let f = 0; f < nf; ++f) {
          const c = Math.floor(f / 2), x0 = (c % columns) * cell, y0 = Math.floor(c / columns) * cell;
          const half = CORNER[f % 2];
          for (let k = 0; k < 3; ++k) {
            const p = tri[3 * f + k];
            if (p >= np) throw new Error('mesh record has a point past the end');
            for (let a = 0; a < 3; ++a) position[9 * f + 3 * k + a] = origin[a] + q[3 * p + a] * step;
            uv[6 * f + 2 * k] = (x0 + (half[k][0] ? cell - 0.5 : 0.5)) / width;
            uv[6 * f + 2 * k + 1] = (y0 + (half[k][1] ? cell - 0.5 : 0.5)) / height;
          }
        }
        return { position, uv, triangles: nf };
      } finally {
        D._free(qPtr);
        D._free(fPtr);
      }
    } finally {
      D.destroy(mesh);
      D.destroy(decoder);
    }
  }

  function open(url, hooks) {
    const player = {
      url, manifest: null, instants: [], bytes: 0, totalBytes: 0, done: false, error: null,
      // performance.now() when the manifest was read and the first instant was ready.
      manifestMs: null, firstReadyMs: null,
    };
    draco();  // compile the decoder while the file's first bytes are on their way
    let video = null;          // VideoDecoder
    let needKey = false;       // a broken frame: deltas wait for the next keyframe
    const pending = new Map(); // instant -> {mesh geometry arrays, bitmap}
    const meshWork = [];       // Draco decodes in flight

    const broken = (i, why) => {
      const inst = player.instants[i];
      if (!inst || inst.state === 'broken') return;
      inst.state = 'broken';
      inst.why = why;
      pending.delete(i);
      hooks.onInstant && hooks.onInstant(i);
    };
    const maybeReady = (i) => {
      const p = pending.get(i), inst = player.instants[i];
      if (!p || !p.mesh || !p.bitmap || inst.state !== 'waiting') return;
      pending.delete(i);
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(p.mesh.position, 3));
      g.setAttribute('uv', new THREE.BufferAttribute(p.mesh.uv, 2));
      const texture = new THREE.Texture(p.bitmap);
      texture.flipY = false;  // the rule's coordinates count rows from the top
      texture.minFilter = THREE.LinearFilter;
      texture.generateMipmaps = false;
      texture.needsUpdate = true;
      inst.object = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ map: texture, side: THREE.DoubleSide }));
      inst.triangles = p.mesh.triangles;
      inst.decodeMs = p.meshMs + (performance.now() - p.frameSentAt);
      inst.state = 'ready';
      inst.readyAtBytes = player.bytes;  // how much of the file had arrived
      if (player.firstReadyMs === null) player.firstReadyMs = performance.now();
      hooks.onInstant && hooks.onInstant(i);
    };
    const newVideoDecoder = () => {
      const m = player.manifest.video;
      video = new VideoDecoder({
        output: (frame) => {
          const i = Math.round(frame.timestamp / 1e6);
          createImageBitmap(frame).then((bitmap) => {
            frame.close();
            const p = pending.get(i);
            if (!p) { bitmap.close(); return; }
            p.bitmap = bitmap;
            maybeReady(i);
          }, (e) => { frame.close(); broken(i, 'atlas frame: ' + e.message); });
        },
        error: (e) => {
          // The decoder is closed after an error: the frames it held are lost.
          for (const [i, p] of pending) if (p.frameSentAt !== undefined && !p.bitmap) broken(i, 'atlas frame does not decode: ' + e.message);
          needKey = true;
          newVideoDecoder();
        },
      });
      video.configure({ codec: m.codec, codedWidth: m.width, codedHeight: m.height, optimizeForLatency: true });
    };

    const onManifest = (manifest) => {
      if (manifest.format !== 'dome4d' || manifest.version !== 1) throw new Error(url + ': manifest is not dome4d version 1');
      player.manifest = manifest;
      player.manifestMs = performance.now();
      player.instants = manifest.instants.map((m) => ({
        name: m.name, timecode: m.timecode, start_s: m.start_s, triangles: m.triangles,
        state: 'waiting', why: '', object: null, decodeMs: null,
      }));
      newVideoDecoder();
      hooks.onManifest && hooks.onManifest(manifest);
    };
    const onRecord = (tag, i, payload, crcOk) => {
      const inst = player.instants[i];
      if (!inst) return;
      const what = tag === 'MESH' ? 'mesh' : 'texture';
      if (!crcOk) {
        broken(i, what + ' record fails its CRC-32 (damaged)');
        if (tag === 'TEXF') needKey = true;
        return;
      }
      if (inst.state !== 'waiting') return;
      if (!pending.has(i)) pending.set(i, {});
      const p = pending.get(i);
      if (tag === 'MESH') {
        const t0 = performance.now();
        meshWork.push(draco().then((D) => {
          try {
            p.mesh = decodeMesh(D, payload, player.manifest.video.width, player.manifest.video.height);
            p.meshMs = performance.now() - t0;
            maybeReady(i);
          } catch (e) {
            broken(i, e.message);
          }
        }, (e) => broken(i, 'no Draco decoder: ' + e.message)));
      } else {
        const key = i % player.manifest.video.keyframe_every === 0;
        if (needKey && !key) { broken(i, 'its atlas frame depends on a broken one'); return; }
        needKey = false;
        p.frameSentAt = performance.now();
        video.decode(new EncodedVideoChunk({ type: key ? 'key' : 'delta', timestamp: i * 1e6, data: payload }));
      }
    };

    (async () => {
      const response = await fetch(url);
      if (!response.ok) throw new Error(url + ': HTTP ' + response.status);
      player.totalBytes = +response.headers.get('Content-Length') || 0;
      const reader = response.body.getReader();
      let buf = new Uint8Array(0), at = 0;
      const u32 = (k) => (buf[k] | (buf[k + 1] << 8) | (buf[k + 2] << 16) | (buf[k + 3] << 24)) >>> 0;
      for (;;) {
        const { done, value } = await reader.read();
        if (value) {
          const joined = new Uint8Array(buf.length - at + value.length);
          joined.set(buf.subarray(at));
          joined.set(value, buf.length - at);
          buf = joined;
          at = 0;
          player.bytes += value.length;
        }
        if (!player.manifest && buf.length >= 12) {
          if (new TextDecoder().decode(buf.subarray(0, 8)) !== MAGIC) throw new Error(url + ' is not a dome 4D file');
          const m = u32(8);
          if (buf.length >= 12 + m) {
            onManifest(JSON.parse(new TextDecoder().decode(buf.subarray(12, 12 + m))));
            at = 12 + m;
          }
        }
        while (player.manifest && buf.length - at >= 16) {
          const tag = new TextDecoder().decode(buf.subarray(at, at + 4));
          const i = u32(at + 4), length = u32(at + 8), crc = u32(at + 12);
          if ((tag !== 'MESH' && tag !== 'TEXF') || i >= player.instants.length) {
            throw new Error(url + ': damaged at byte ' + (player.bytes - (buf.length - at)) + ', nothing after it can be read');
          }
          if (buf.length - at - 16 < length) break;
          const payload = buf.slice(at + 16, at + 16 + length);
          at += 16 + length;
          onRecord(tag, i, payload, crc32(payload) === crc);
        }
        if (done) break;
      }
      if (!player.manifest) throw new Error(url + ' ends inside its manifest');
      if (buf.length - at >= 16) {
        const i = u32(at + 4), length = u32(at + 8);
        const what = new TextDecoder().decode(buf.subarray(at, at + 4)) === 'MESH' ? 'mesh' : 'texture';
        broken(i, what + ' record is cut short (' + (buf.length - at - 16) + ' of ' + length + ' bytes)');
      }
      await video.flush().catch(() => {});
      await Promise.all(meshWork);
      // Bitmaps of the last frames are made after flush resolves.
      await new Promise((resolve) => setTimeout(resolve, 50));
      player.instants.forEach((inst, i) => {
        if (inst.state !== 'waiting') return;
        const p = pending.get(i);
        if (!p) broken(i, 'its records are missing (the file ends before them)');
        else if (!p.mesh) broken(i, 'its mesh record is missing');
        else if (p.frameSentAt === undefined) broken(i, 'its texture record is missing');
      });
    })().catch((e) => {
      player.error = e.message;
      player.instants.forEach((inst, i) => { if (inst.state === 'waiting') broken(i, e.message); });
    }).finally(() => {
      player.done = true;
      hooks.onEnd && hooks.onEnd(player);
    });
    return player;
  }

  window.DomeStreamPlayer = { open };
})();
