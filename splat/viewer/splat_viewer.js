// A small WebGL 2 viewer of 3-D Gaussian splats, written for splat's capture report (no network, no
// dependencies). The scene is embedded in the page as <script type="application/json" id="...-scene">:
// {count, data: base64 of count records of 40 bytes (float32 centre x y z, float32 covariance
// xx xy xz yy yz zz, uint8 sRGB-encoded r g b and opacity), cameras: [{name, R (row-major 3x3
// world-to-camera), t, focal, principal, size}], scale}. Each frame sorts the Gaussians by camera depth and
// draws one instanced quad per Gaussian, back to front with premultiplied alpha, with the projection of
// splat.rendering: EWA covariance J W Σ Wᵀ Jᵀ + 0.3 px², cut off at 3σ and below alpha 1/255, alpha at
// most 0.99, black background (Kerbl et al. 2023, eqs. 2–6; Zwicker et al. 2002).
(function () {
  "use strict";

  const VS = `#version 300 es
precision highp float;
in vec2 corner;
in vec3 centre;
in vec3 covA;
in vec3 covB;
in vec4 colour;
uniform mat3 R;
uniform vec3 t;
uniform vec2 focal;
uniform vec2 pp;
uniform vec2 size;
out vec4 vColour;
out vec2 vD;
out vec3 vConic;
void main() {
  vec3 p = R * centre + t;
  if (p.z <= 0.01) { gl_Position = vec4(0.0, 0.0, 2.0, 1.0); return; }
  float z = p.z;
  float lim = 0.3;
  float tx = z * clamp(p.x / z, -(pp.x / focal.x) - lim * size.x / focal.x / 2.0,
                       (size.x - pp.x) / focal.x + lim * size.x / focal.x / 2.0);
  float ty = z * clamp(p.y / z, -(pp.y / focal.y) - lim * size.y / focal.y / 2.0,
                       (size.y - pp.y) / focal.y + lim * size.y / focal.y / 2.0);
  vec3 j0 = vec3(focal.x / z, 0.0, -focal.x * tx / (z * z));
  vec3 j1 = vec3(0.0, focal.y / z, -focal.y * ty / (z * z));
  vec3 T0 = j0 * R;
  vec3 T1 = j1 * R;
  mat3 S = mat3(covA.x, covA.y, covA.z, covA.y, covB.x, covB.y, covA.z, covB.y, covB.z);
  float a = dot(T0, S * T0) + 0.3;
  float b = dot(T0, S * T1);
  float c = dot(T1, S * T1) + 0.3;
  float det = a * c - b * b;
  if (!(det > 0.0)) { gl_Position = vec4(0.0, 0.0, 2.0, 1.0); return; }
  vConic = vec3(c / det, -b / det, a / det);
  vec2 m = vec2(focal.x * p.x / z + pp.x, focal.y * p.y / z + pp.y);
  vec2 off = corner * 3.0 * sqrt(vec2(a, c));
  vec2 q = m + off;
  gl_Position = vec4(2.0 * q.x / size.x - 1.0, 1.0 - 2.0 * q.y / size.y, 0.0, 1.0);
  vD = off;
  vColour = colour;
}`;

  const FS = `#version 300 es
precision highp float;
in vec4 vColour;
in vec2 vD;
in vec3 vConic;
out vec4 fragColour;
void main() {
  float m2 = vConic.x * vD.x * vD.x + 2.0 * vConic.y * vD.x * vD.y + vConic.z * vD.y * vD.y;
  if (m2 > 9.0) discard;
  float alpha = min(0.99, vColour.a * exp(-0.5 * m2));
  if (alpha < 1.0 / 255.0) discard;
  fragColour = vec4(vColour.rgb * alpha, alpha);
}`;

  function compile(gl, type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }

  function decode(scene) {
    const raw = atob(scene.data);
    const bytes = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
    const n = scene.count;
    const dv = new DataView(bytes.buffer);
    const rec = new Float32Array(n * 13); // centre 3, covA 3, covB 3, colour 4
    for (let i = 0; i < n; i++) {
      const o = 40 * i;
      for (let k = 0; k < 9; k++) rec[13 * i + k] = dv.getFloat32(o + 4 * k, true);
      for (let k = 0; k < 4; k++) rec[13 * i + 9 + k] = bytes[o + 36 + k] / 255;
    }
    return rec;
  }

  function rodrigues(axis, angle) {
    const n = Math.hypot(axis[0], axis[1], axis[2]) || 1;
    const [x, y, z] = axis.map((v) => v / n);
    const c = Math.cos(angle), s = Math.sin(angle), C = 1 - c;
    return [
      [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
      [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
      [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ];
  }
  const mul = (A, B) => A.map((r) => [0, 1, 2].map((j) => r[0] * B[0][j] + r[1] * B[1][j] + r[2] * B[2][j]));
  const mv = (A, v) => A.map((r) => r[0] * v[0] + r[1] * v[1] + r[2] * v[2]);
  const T = (A) => [0, 1, 2].map((i) => [0, 1, 2].map((j) => A[j][i]));

  function start(root) {
    const scene = JSON.parse(root.querySelector("script.splat-scene").textContent);
    const canvas = root.querySelector("canvas");
    const status = root.querySelector(".splat-status");
    const gl = canvas.getContext("webgl2", {
      antialias: false, alpha: false, premultipliedAlpha: true, preserveDrawingBuffer: true,
    });
    if (!gl) {
      status.textContent = "This browser has no WebGL 2: the interactive view cannot be shown.";
      canvas.dataset.frames = "-1";
      return;
    }
    const t0 = performance.now();
    const rec = decode(scene);
    const n = scene.count;
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    gl.useProgram(prog);
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const quad = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, quad);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    const loc = (name) => gl.getAttribLocation(prog, name);
    gl.enableVertexAttribArray(loc("corner"));
    gl.vertexAttribPointer(loc("corner"), 2, gl.FLOAT, false, 0, 0);
    const inst = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, inst);
    let off = 0;
    for (const [name, size] of [["centre", 3], ["covA", 3], ["covB", 3], ["colour", 4]]) {
      const l = loc(name);
      gl.enableVertexAttribArray(l);
      gl.vertexAttribPointer(l, size, gl.FLOAT, false, 52, off);
      gl.vertexAttribDivisor(l, 1);
      off += 4 * size;
    }
    const u = (name) => gl.getUniformLocation(prog, name);
    const sorted = new Float32Array(n * 13);
    const depth = new Float32Array(n);
    const order = new Uint32Array(n);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.disable(gl.DEPTH_TEST);

    // the view: world-to-camera R (rows), camera centre c, intrinsics at the canvas' size
    const W = canvas.width, H = canvas.height;
    let view = null;
    let target = [0, 0, 0];
    for (let i = 0; i < n; i++) for (let k = 0; k < 3; k++) target[k] += rec[13 * i + k] / Math.max(n, 1);
    let up = [0, -1, 0];

    function setCamera(i) {
      const c = scene.cameras[i];
      const s = W / c.size[0];
      const R = c.R;
      const centre = mv(T(R), c.t).map((v) => -v);
      view = { R: R, c: centre, focal: [c.focal[0] * s, c.focal[1] * s], pp: [c.principal[0] * s, c.principal[1] * s] };
      up = R[1].map((v) => -v);
      label.textContent = `${i + 1} / ${scene.cameras.length}: ${c.name}`;
      current = i;
      draw();
    }

    function draw() {
      const R = view.R, t = mv(R, view.c).map((v) => -v);
      for (let i = 0; i < n; i++) {
        depth[i] = R[2][0] * rec[13 * i] + R[2][1] * rec[13 * i + 1] + R[2][2] * rec[13 * i + 2] + t[2];
        order[i] = i;
      }
      order.sort((a, b) => depth[b] - depth[a]); // far to near
      for (let j = 0; j < n; j++) sorted.set(rec.subarray(13 * order[j], 13 * order[j] + 13), 13 * j);
      gl.bindBuffer(gl.ARRAY_BUFFER, inst);
      gl.bufferData(gl.ARRAY_BUFFER, sorted, gl.DYNAMIC_DRAW);
      gl.uniformMatrix3fv(u("R"), true, new Float32Array(R.flat()));
      gl.uniform3fv(u("t"), new Float32Array(t));
      gl.uniform2fv(u("focal"), new Float32Array(view.focal));
      gl.uniform2fv(u("pp"), new Float32Array(view.pp));
      gl.uniform2fv(u("size"), new Float32Array([W, H]));
      gl.viewport(0, 0, W, H);
      gl.clearColor(0, 0, 0, 1);
      gl.clear(gl.COLOR_BUFFER_BIT);
      gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 4, n);
      canvas.dataset.frames = String(Number(canvas.dataset.frames || 0) + 1);
    }

    const label = root.querySelector(".splat-label");
    let current = 0;
    root.querySelector(".splat-prev").onclick = () =>
      setCamera((current + scene.cameras.length - 1) % scene.cameras.length);
    root.querySelector(".splat-next").onclick = () => setCamera((current + 1) % scene.cameras.length);

    // orbit about the scene's centre: drag turns, the wheel moves closer or further
    let drag = null, pending = false;
    const redraw = () => {
      if (!pending) {
        pending = true;
        requestAnimationFrame(() => { pending = false; draw(); });
      }
    };
    function turn(axis, angle) {
      const Q = rodrigues(axis, angle);
      const d = [0, 1, 2].map((k) => view.c[k] - target[k]);
      view.c = mv(Q, d).map((v, k) => v + target[k]);
      view.R = mul(view.R, T(Q));
    }
    canvas.addEventListener("pointerdown", (e) => {
      drag = [e.clientX, e.clientY];
      try { canvas.setPointerCapture(e.pointerId); } catch (err) { /* a synthetic pointer */ }
    });
    canvas.addEventListener("pointerup", () => { drag = null; });
    canvas.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const dx = e.clientX - drag[0], dy = e.clientY - drag[1];
      drag = [e.clientX, e.clientY];
      turn(up, -0.005 * dx);
      turn(view.R[0], 0.005 * dy);
      label.textContent = "free view (the arrows return to the photographs)";
      redraw();
    });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      const f = Math.exp(0.001 * e.deltaY);
      view.c = view.c.map((v, k) => target[k] + (v - target[k]) * f);
      redraw();
    }, { passive: false });

    setCamera(0);
    const ms = performance.now() - t0;
    canvas.dataset.loadMs = ms.toFixed(1);
    status.textContent = `${n} Gaussians, first frame in ${ms.toFixed(0)} ms. Drag to turn, scroll to move closer.`;
  }

  for (const root of document.querySelectorAll(".splat-viewer")) {
    try {
      start(root);
    } catch (err) {
      root.querySelector(".splat-status").textContent = `The viewer failed: ${err.message}`;
      root.querySelector("canvas").dataset.frames = "-1";
    }
  }
})();
