// btfgmm's real-time viewer (docs/RENDERING.md, "The viewer"): the models of models.js on the
// meshes of meshes.js in WebGL2, each pixel evaluated by the model's exported shader
// (btfgmm export-shader) after the same set-up as the CPU renderer (src/render/set_up.cpp:
// the tangent frame, the light and view in it, the tile position) and composed as
// src/render/render.cpp composes. The camera and the projection are Camera::orbit's and the
// geometry pass's (src/render/camera.cpp, rasterize.cpp).
//
// The query string fixes a scene: mesh=sphere&light=45,30&camera=60,0&repeat=4&fov=30&
// exposure=0&size=128x128&mode=model&model=0; readback=1 writes the pixels (RGBA, rows top
// to bottom, base64) into <pre id="readback"> per model; frames=N renders N frames more and
// writes their mean time into <pre id="timing">.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const query = new URLSearchParams(location.search);
  const models = window.BTFGMM_MODELS || [];
  const meshes = window.BTFGMM_MESHES || [];
  const pair = (text, fallback) => {
    const v = (text || "").split(/[,x]/).map(Number);
    return v.length === 2 && v.every(isFinite) ? v : fallback;
  };
  const state = {
    model: Math.min(Number(query.get("model") || 0), models.length - 1),
    mesh: query.get("mesh") || "sphere",
    mode: query.get("mode") || "both",
    light: pair(query.get("light"), [45, 30]),
    camera: pair(query.get("camera"), [60, 0]),
    repeat: Number(query.get("repeat") || 4),
    exposure: Number(query.get("exposure") || 0),
    fov: Number(query.get("fov") || 30),
    size: pair(query.get("size"), [800, 800]),
  };
  const fail = (text) => { $("error").textContent = text; };

  const canvas = $("view");
  const gl = canvas.getContext("webgl2", { antialias: false, preserveDrawingBuffer: true });
  if (!gl) return fail("This browser has no WebGL2: the viewer needs it.");
  if (!models.length || !meshes.length) return fail("models.js or meshes.js is missing.");

  const bytes = (b64) => {
    const s = atob(b64);
    const u = new Uint8Array(s.length);
    for (let i = 0; i < s.length; ++i) u[i] = s.charCodeAt(i);
    return u.buffer;
  };

  // ---- shaders -----------------------------------------------------------------------------
  const VERTEX = `#version 300 es
in vec3 a_position, a_normal, a_tangent, a_bitangent, a_face;
in vec2 a_uv;
uniform mat4 u_view_projection;
out vec3 v_position, v_normal, v_tangent, v_bitangent;
out vec2 v_uv;
flat out vec3 v_face;
void main() {
  v_position = a_position; v_normal = a_normal; v_tangent = a_tangent;
  v_bitangent = a_bitangent; v_uv = a_uv; v_face = a_face;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}`;

  // The set-up of src/render/set_up.cpp for a directional light, then btf() or the mean BRDF.
  const FRAGMENT_MAIN = `
in vec3 v_position, v_normal, v_tangent, v_bitangent;
in vec2 v_uv;
flat in vec3 v_face;
uniform vec3 u_eye, u_light;
uniform float u_texel, u_scale;
uniform int u_mean_only, u_hdr;
out vec4 o_colour;
void main() {
  vec3 g = v_face, n = v_normal;
  float nl = length(n), gn = length(g);
  n = nl > 1e-12 ? n / nl : g / (gn > 0.0 ? gn : 1.0);
  vec3 t = v_tangent - n * dot(v_tangent, n);
  float tl = length(t);
  bool ax = abs(n.x) < 0.9;
  vec3 q = vec3(ax ? 1.0 : 0.0, ax ? 0.0 : 1.0, 0.0) - n * (ax ? n.x : n.y);
  t = tl > 1e-12 ? t / tl : q / length(q);
  vec3 b = cross(n, t);
  b = dot(b, v_bitangent) < 0.0 ? -b : b;
  vec3 v = u_eye - v_position;
  float vl = length(v);
  v /= vl > 0.0 ? vl : 1.0;
  if ((dot(g, n) < 0.0) != (dot(g, v) < 0.0)) n = -n;
  float ln = dot(u_light, n);
  if (!(ln > 0.0)) { o_colour = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec3 light = vec3(dot(u_light, t), dot(u_light, b), ln);
  vec3 view = vec3(dot(v, t), dot(v, b), dot(v, n));
  if (view.z < 0.0) {
    float hl = length(view.xy);
    view = hl > 0.0 ? vec3(view.xy / hl, 0.0) : vec3(0.0, 0.0, 1.0);
  }
  vec2 xy = v_uv * u_texel;
  xy -= BTF_TILE * floor(xy / BTF_TILE);
  xy = vec2(xy.x < 0.0 || xy.x >= BTF_TILE.x ? 0.0 : xy.x,
            xy.y < 0.0 || xy.y >= BTF_TILE.y ? 0.0 : xy.y);
  vec3 value = u_mean_only != 0 ? MEAN_BRDF(light, view) : btf(xy / BTF_TILE, light, view);
  vec3 rgb = value * u_scale;
  if (u_hdr != 0) {
    rgb = clamp(rgb, 0.0, 1.0);
    rgb = 255.0 * mix(1.055 * pow(rgb, vec3(1.0 / 2.4)) - 0.055, 12.92 * rgb,
                      vec3(lessThanEqual(rgb, vec3(0.0031308))));
  }
  o_colour = vec4(rgb / 255.0, 1.0);
}`;

  function compile(type, source) {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }

  // A model's program and its parameter texture, made when first shown.
  function prepare(model) {
    if (model.program) return model;
    const fragment = "#version 300 es\nprecision highp float;\nprecision highp int;\n" +
      "precision highp sampler2D;\n" + model.glsl + "\n#define MEAN_BRDF " +
      (model.mean_brdf ? "btf_mean_brdf" : "btf_no_mean_brdf") +
      (model.mean_brdf ? "" : "\nvec3 btf_no_mean_brdf(vec3 l, vec3 v) { return vec3(0.0); }") +
      FRAGMENT_MAIN;
    const p = gl.createProgram();
    gl.attachShader(p, compile(gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fragment));
    gl.bindAttribLocation(p, 0, "a_position");
    gl.bindAttribLocation(p, 1, "a_normal");
    gl.bindAttribLocation(p, 2, "a_tangent");
    gl.bindAttribLocation(p, 3, "a_bitangent");
    gl.bindAttribLocation(p, 4, "a_uv");
    gl.bindAttribLocation(p, 5, "a_face");
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    model.program = p;
    model.texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, model.texture);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, model.params.width, model.params.height, 0,
                  gl.RGBA, gl.FLOAT, new Float32Array(bytes(model.params.data)));
    return model;
  }

  // ---- meshes ------------------------------------------------------------------------------
  // Every triangle's corners with their attributes and the face normal (the cross product of
  // its edges, as the CPU's set-up takes it), drawn without an index buffer.
  function prepareMesh(mesh) {
    if (mesh.vao) return mesh;
    const a = new Float32Array(bytes(mesh.attributes));
    const tri = new Uint32Array(bytes(mesh.triangles));
    const out = new Float32Array(tri.length * 17);
    for (let k = 0; k < tri.length; k += 3) {
      const p = [0, 1, 2].map((c) => 14 * tri[k + c]);
      const e1 = [0, 1, 2].map((c) => a[p[1] + c] - a[p[0] + c]);
      const e2 = [0, 1, 2].map((c) => a[p[2] + c] - a[p[0] + c]);
      const g = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0]];
      for (let c = 0; c < 3; ++c) {
        out.set(a.subarray(p[c], p[c] + 14), 17 * (k + c));
        out.set(g, 17 * (k + c) + 14);
      }
    }
    mesh.vao = gl.createVertexArray();
    gl.bindVertexArray(mesh.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, out, gl.STATIC_DRAW);
    const layout = [[0, 3, 0], [1, 3, 3], [2, 3, 6], [3, 3, 9], [4, 2, 12], [5, 3, 14]];
    for (const [loc, n, offset] of layout) {
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, n, gl.FLOAT, false, 68, offset * 4);
    }
    mesh.count = tri.length;
    return mesh;
  }

  // ---- the scene ---------------------------------------------------------------------------
  const rad = Math.PI / 180;
  const direction = ([t, p]) => [Math.sin(t * rad) * Math.cos(p * rad),
    Math.sin(t * rad) * Math.sin(p * rad), Math.cos(t * rad)];
  const sub = (a, b) => a.map((x, i) => x - b[i]);
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
    a[0] * b[1] - a[1] * b[0]];
  const unit = (a) => { const l = Math.sqrt(dot(a, a)); return a.map((x) => x / l); };

  // Camera::orbit: on a sphere around the mesh's centre, far enough that it fills the view;
  // the projection of the CPU's pinhole camera (vertical field of view, square pixels).
  function camera(mesh, width, height) {
    const [theta, phi] = state.camera;
    const d = direction(state.camera);
    const distance = 1.08 * mesh.radius / Math.sin(0.5 * state.fov * rad);
    const eye = mesh.center.map((c, i) => c + d[i] * distance);
    const p = phi * rad;
    const up0 = theta < 1e-6 ? [-Math.cos(p), -Math.sin(p), 0]
      : theta > 180 - 1e-6 ? [Math.cos(p), Math.sin(p), 0] : [0, 0, 1];
    const forward = unit(sub(mesh.center, eye));
    const right = unit(cross(forward, up0));
    const up = cross(right, forward);
    const f = 1 / Math.tan(0.5 * state.fov * rad);
    const near = Math.max(distance - 2 * mesh.radius, 0.01 * distance);
    const far = distance + 2 * mesh.radius;
    const view = [right, up, forward.map((x) => -x)];
    const proj = [f * height / width, f, (far + near) / (near - far), 2 * far * near / (near - far)];
    const m = new Float32Array(16);  // column-major: projection times view
    for (let c = 0; c < 3; ++c) {
      m[4 * c] = proj[0] * view[0][c];
      m[4 * c + 1] = proj[1] * view[1][c];
      m[4 * c + 2] = proj[2] * view[2][c];
      m[4 * c + 3] = -view[2][c];
    }
    const t = view.map((r) => -dot(r, eye));
    m[12] = proj[0] * t[0];
    m[13] = proj[1] * t[1];
    m[14] = proj[2] * t[2] + proj[3];
    m[15] = -t[2];
    return { eye, matrix: m };
  }

  // One view of the scene into the viewport (x, 0, w, h): the model or its mean BRDF alone.
  function drawView(model, mesh, x, w, h, meanOnly) {
    const cam = camera(mesh, w, h);
    gl.viewport(x, 0, w, h);
    const u = (name) => gl.getUniformLocation(model.program, name);
    gl.useProgram(model.program);
    gl.uniformMatrix4fv(u("u_view_projection"), false, cam.matrix);
    gl.uniform3fv(u("u_eye"), cam.eye);
    gl.uniform3fv(u("u_light"), unit(direction(state.light)));
    gl.uniform1f(u("u_texel"), state.repeat * model.tile[0]);
    gl.uniform1f(u("u_scale"), Math.pow(2, state.exposure));
    gl.uniform1i(u("u_mean_only"), meanOnly ? 1 : 0);
    gl.uniform1i(u("u_hdr"), model.hdr ? 1 : 0);
    gl.uniform1i(u("btf_params"), 0);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, model.texture);
    gl.bindVertexArray(mesh.vao);
    gl.drawArrays(gl.TRIANGLES, 0, mesh.count);
  }

  const sync = new Uint8Array(4);
  // The whole frame; returns its time in ms (until the pixels are done: a read of one pixel).
  function draw() {
    const model = prepare(models[state.model]);
    const mesh = prepareMesh(meshes.find((m) => m.name === state.mesh) || meshes[0]);
    const [w, h] = state.size;
    const both = state.mode === "both" && model.mean_brdf;
    const width = both ? 2 * w : w;
    if (canvas.width !== width || canvas.height !== h) {
      canvas.width = width;
      canvas.height = h;
    }
    const t0 = performance.now();
    gl.enable(gl.DEPTH_TEST);
    gl.disable(gl.CULL_FACE);
    gl.clearColor(40 / 255, 40 / 255, 40 / 255, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    drawView(model, mesh, 0, w, h, state.mode === "mean" && model.mean_brdf);
    if (both) drawView(model, mesh, w, w, h, true);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, sync);
    return performance.now() - t0;
  }

  // ---- the page ----------------------------------------------------------------------------
  // The command that renders the same view on the CPU, as the program that wrote the page
  // spells it (models.js: BTFGMM_CPU_COMMAND, with {mesh}, {light}, ... for the view's
  // settings); none where it gave none.
  const cpuTemplate = window.BTFGMM_CPU_COMMAND || "";
  const cpuCommand = cpuTemplate && (() => {
    const fill = {
      mesh: state.mesh, light: state.light.map((v) => v.toFixed(1)).join(","),
      camera: state.camera.map((v) => v.toFixed(1)).join(","), repeat: state.repeat,
      fov: state.fov, exposure: state.exposure, size: state.size.join("x"),
    };
    return cpuTemplate.replace(/\{(\w+)\}/g, (all, key) => (key in fill ? fill[key] : all));
  });
  let average = 0;
  function describe(ms) {
    const m = models[state.model];
    average = average ? 0.8 * average + 0.2 * ms : ms;
    $("frame-time").textContent = `frame ${ms.toFixed(1)} ms (mean ${average.toFixed(1)} ms), ` +
      `${canvas.width}\u00d7${canvas.height}`;
    $("info").innerHTML = `${m.name}: ${m.method}, ${m.size}, tile ${m.tile[0]}\u00d7` +
      `${m.tile[1]}.` + (cpuCommand ? ` The same on the CPU: <code>${cpuCommand()}</code>` : "");
  }
  let pending = false;
  function redraw() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      try { describe(draw()); } catch (e) { fail(String(e.message || e)); }
    });
  }

  function controls() {
    const select = (id, items, value, set) => {
      const el = $(id);
      if (items) el.innerHTML = items.map((v, i) => `<option value="${i}">${v}</option>`).join("");
      el.value = String(value);
      el.onchange = () => { set(el.value); redraw(); };
    };
    select("model", models.map((m) => `${m.name} (${m.method}, ${m.size})`), state.model,
           (v) => { state.model = Number(v); });
    const names = meshes.map((m) => m.name);
    select("mesh", names, Math.max(0, names.indexOf(state.mesh)),
           (v) => { state.mesh = names[Number(v)]; });
    select("mode", null, state.mode, (v) => { state.mode = v; });
    for (const key of ["repeat", "exposure"]) {
      const el = $(key);
      el.value = state[key];
      $(key + "-value").textContent = state[key];
      el.oninput = () => {
        state[key] = Number(el.value);
        $(key + "-value").textContent = el.value;
        redraw();
      };
    }
    let drag = null;
    canvas.oncontextmenu = (e) => e.preventDefault();
    canvas.onpointerdown = (e) => {
      drag = { x: e.clientX, y: e.clientY, light: e.shiftKey || e.button === 2 };
      canvas.setPointerCapture(e.pointerId);
    };
    canvas.onpointerup = () => { drag = null; };
    canvas.onpointermove = (e) => {
      if (!drag) return;
      const target = drag.light ? state.light : state.camera;
      target[1] = (((target[1] - 0.5 * (e.clientX - drag.x)) % 360) + 360) % 360;
      target[0] = Math.min(180, Math.max(0, target[0] - 0.5 * (e.clientY - drag.y)));
      drag.x = e.clientX;
      drag.y = e.clientY;
      redraw();
    };
  }

  // The pixels of the canvas, rows top to bottom, RGBA, as base64.
  function readback() {
    const w = canvas.width, h = canvas.height, px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let s = "";
    for (let y = h - 1; y >= 0; --y)
      for (let i = y * w * 4; i < (y + 1) * w * 4; i += 8192)
        s += String.fromCharCode.apply(null, px.subarray(i, Math.min(i + 8192, (y + 1) * w * 4)));
    return `${w}x${h} ${btoa(s)}`;
  }

  try {
    controls();
    if (query.has("readback")) {
      const out = [];
      for (let m = 0; m < models.length; ++m) {
        state.model = m;
        draw();
        out.push(readback());
      }
      $("readback").textContent = out.join("\n");
    }
    if (query.has("frames")) {
      draw();  // compiles, uploads
      const n = Math.max(1, Number(query.get("frames")));
      let total = 0;
      for (let k = 0; k < n; ++k) total += draw();
      $("timing").textContent = `${(total / n).toFixed(2)} ms a frame, ${n} frames, ` +
        `${canvas.width}x${canvas.height}, ${gl.getParameter(gl.RENDERER)}`;
      describe(total / n);
    } else {
      describe(draw());
    }
  } catch (e) {
    fail(String(e.message || e));
    $("readback").textContent = "error: " + String(e.message || e);
  }
})();
