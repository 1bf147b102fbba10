// The 3D view: the centre view's colours on the estimated surface, a triangle mesh with
// one vertex per pixel (every `step`-th pixel on large maps), drawn with plain WebGL2.
// Metric when the light field's parameters.cfg gives the camera (the HCI benchmark's
// depth z = b·f·D / (d·D + b·f), x and y through the pinhole), else in pixels with the
// disparity as relief. Orbit by dragging (mouse, pen or touch) or with the arrow keys,
// zoom with the wheel or +/−, 0 resets.

/** Most vertices along the longer side of the mesh. */
const MAX_SIDE = 320;

const VERTEX = `#version 300 es
in vec3 position;
in vec3 colour;
uniform mat4 mvp;
out vec3 shade;
void main() {
  gl_Position = mvp * vec4(position, 1.0);
  shade = colour;
}`;

const FRAGMENT = `#version 300 es
precision mediump float;
in vec3 shade;
out vec4 colour;
void main() {
  colour = vec4(shade, 1.0);
}`;

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`3D view shader: ${gl.getShaderInfoLog(shader)}`);
  return shader;
}

/** Column-major 4×4 product `a · b`. */
function multiply(a, b) {
  const out = new Float32Array(16);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) {
    let s = 0;
    for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
    out[c * 4 + r] = s;
  }
  return out;
}

function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2);
  const out = new Float32Array(16);
  out[0] = f / aspect;
  out[5] = f;
  out[10] = (far + near) / (near - far);
  out[11] = -1;
  out[14] = (2 * far * near) / (near - far);
  return out;
}

const rotateX = (a) => Float32Array.of(1, 0, 0, 0, 0, Math.cos(a), Math.sin(a), 0, 0, -Math.sin(a), Math.cos(a), 0, 0, 0, 0, 1);
const rotateY = (a) => Float32Array.of(Math.cos(a), 0, -Math.sin(a), 0, 0, 1, 0, 0, Math.sin(a), 0, Math.cos(a), 0, 0, 0, 0, 1);
const translate = (x, y, z) => Float32Array.of(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, y, z, 1);

/** Depth in metres of disparity `d` (px between neighbouring views) with the HCI
 * benchmark's formula `z = b·f·D / (d·D + b·f)` (`camera`: focal length in pixels,
 * baseline and focus distance in mm, see `cameraOf` in loader.js), as the CLI's
 * `--depth`; null at or beyond infinity. */
export function depthMetres(d, { focalPx, baselineMm, focusMm }) {
  const bf = baselineMm * focalPx;
  const denominator = d * focusMm + bf;
  const z = (bf * focusMm) / denominator / 1000;
  return denominator > 0 && Number.isFinite(z) ? z : null;
}

/**
 * Vertex positions (x right, y up, z towards the viewer, centred and scaled to a
 * largest extent of 2), colours and triangles of a disparity map. `camera`
 * (`{ focalPx, baselineMm, focusMm }`) makes it metric. Triangles across a depth step
 * (a disparity spread above 0.5 px per mesh step) or touching a point without a depth
 * are left out, so that the foreground does not hang on curtains.
 */
export function surfaceMesh({ disparity, rgb, channels, width, height, camera }) {
  const step = Math.max(1, Math.ceil(Math.max(width, height) / MAX_SIDE));
  const nx = Math.ceil(width / step), ny = Math.ceil(height / step);
  const positions = new Float32Array(nx * ny * 3);
  const colours = new Uint8Array(nx * ny * 3);
  const valid = new Uint8Array(nx * ny);
  const d = new Float32Array(nx * ny);
  const cx = (width - 1) / 2, cy = (height - 1) / 2;
  const finite = [];
  for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++) {
    const x = i * step, y = j * step, v = j * nx + i, p = y * width + x;
    d[v] = disparity[p];
    for (let ch = 0; ch < 3; ch++) colours[3 * v + ch] = rgb[p * channels + Math.min(ch, channels - 1)];
    if (Number.isFinite(d[v])) finite.push(d[v]);
  }
  finite.sort((a, b) => a - b);
  // Relief of a map without a camera: the 2nd to 98th percentile of the disparity spans
  // a third of the image's width.
  const lo = finite[Math.floor(0.02 * (finite.length - 1))] ?? 0, hi = finite[Math.ceil(0.98 * (finite.length - 1))] ?? 0;
  const relief = (0.35 * Math.max(width, height)) / Math.max(hi - lo, 1e-3);
  for (let v = 0; v < nx * ny; v++) {
    const x = (v % nx) * step - cx, y = Math.floor(v / nx) * step - cy;
    if (!Number.isFinite(d[v])) continue;
    if (camera) {
      const z = depthMetres(d[v], camera);
      if (z === null) continue;
      positions.set([(x * z) / camera.focalPx, (-y * z) / camera.focalPx, -z], 3 * v);
    } else {
      positions.set([x, -y, (d[v] - (lo + hi) / 2) * relief], 3 * v);
    }
    valid[v] = 1;
  }
  // Centre and scale: the box of the valid points (depth clipped to its 2nd–98th
  // percentile, so that a few far outliers do not shrink the scene).
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  const zs = [];
  for (let v = 0; v < nx * ny; v++) {
    if (!valid[v]) continue;
    for (let k = 0; k < 2; k++) {
      min[k] = Math.min(min[k], positions[3 * v + k]);
      max[k] = Math.max(max[k], positions[3 * v + k]);
    }
    zs.push(positions[3 * v + 2]);
  }
  zs.sort((a, b) => a - b);
  min[2] = zs[Math.floor(0.02 * (zs.length - 1))] ?? 0;
  max[2] = zs[Math.ceil(0.98 * (zs.length - 1))] ?? 0;
  const centre = min.map((m, k) => (m + max[k]) / 2);
  const scale = 2 / Math.max(max[0] - min[0], max[1] - min[1], max[2] - min[2], 1e-9);
  for (let v = 0; v < nx * ny; v++) for (let k = 0; k < 3; k++) positions[3 * v + k] = (positions[3 * v + k] - centre[k]) * scale;
  const gap = 0.5 * step;
  const triangles = [];
  const keep = (a, b, c) => valid[a] && valid[b] && valid[c] && Math.max(d[a], d[b], d[c]) - Math.min(d[a], d[b], d[c]) <= gap;
  for (let j = 0; j + 1 < ny; j++) for (let i = 0; i + 1 < nx; i++) {
    const a = j * nx + i, b = a + 1, c = a + nx, e = c + 1;
    if (keep(a, c, b)) triangles.push(a, c, b);
    if (keep(b, c, e)) triangles.push(b, c, e);
  }
  return { positions, colours, indices: Uint32Array.from(triangles), metric: Boolean(camera), vertices: nx * ny };
}

export class SurfaceView {
  /** A view on `canvas`; throws when WebGL2 is not available. */
  constructor(canvas) {
    const gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) throw new Error("WebGL2 is not available in this browser");
    this.canvas = canvas;
    this.gl = gl;
    const program = gl.createProgram();
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`3D view program: ${gl.getProgramInfoLog(program)}`);
    this.program = program;
    this.mvp = gl.getUniformLocation(program, "mvp");
    this.vao = gl.createVertexArray();
    this.buffers = { position: gl.createBuffer(), colour: gl.createBuffer(), index: gl.createBuffer() };
    gl.bindVertexArray(this.vao);
    const attribute = (name, buffer, type, normalised) => {
      const at = gl.getAttribLocation(program, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, 3, type, normalised, 0, 0);
    };
    attribute("position", this.buffers.position, gl.FLOAT, false);
    attribute("colour", this.buffers.colour, gl.UNSIGNED_BYTE, true);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers.index);
    gl.bindVertexArray(null);
    this.count = 0;
    this.reset();
    this.wire();
  }

  /** Back to the first view: from a little left of and above the centre camera, so
   * that the relief shows at once. */
  reset() {
    this.yaw = 0.45;
    this.pitch = 0.3;
    this.distance = 2.8;
    this.draw();
  }

  /** Shows `surfaceMesh(input)`; returns the mesh's counts. */
  show(input) {
    const gl = this.gl;
    const mesh = surfaceMesh(input);
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.position);
    gl.bufferData(gl.ARRAY_BUFFER, mesh.positions, gl.STATIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.colour);
    gl.bufferData(gl.ARRAY_BUFFER, mesh.colours, gl.STATIC_DRAW);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    this.count = mesh.indices.length;
    this.draw();
    return { vertices: mesh.vertices, triangles: mesh.indices.length / 3, metric: mesh.metric };
  }

  /** Turns the view by `yaw` and `pitch` radians and zooms by `zoom` (a factor). */
  orbit(yaw, pitch, zoom = 1) {
    this.yaw += yaw;
    this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch + pitch));
    this.distance = Math.max(0.8, Math.min(12, this.distance * zoom));
    this.draw();
  }

  /** Draws at the next animation frame (one draw per frame however many events came). */
  draw() {
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => {
      this.frame = 0;
      this.render();
    });
  }

  render() {
    const { gl, canvas } = this;
    const dpr = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round((canvas.clientWidth || 320) * dpr));
    const height = Math.max(1, Math.round(width * 0.75));
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
    gl.viewport(0, 0, width, height);
    gl.clearColor(0.925, 0.937, 0.953, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (!this.count) return;
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.program);
    const view = multiply(translate(0, 0, -this.distance), multiply(rotateX(this.pitch), rotateY(this.yaw)));
    gl.uniformMatrix4fv(this.mvp, false, multiply(perspective(Math.PI / 4, width / height, 0.05, 50), view));
    gl.bindVertexArray(this.vao);
    gl.drawElements(gl.TRIANGLES, this.count, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
    this.canvas.dataset.drawn = String((Number(this.canvas.dataset.drawn) || 0) + 1);
  }

  wire() {
    const canvas = this.canvas;
    let last = null;
    canvas.addEventListener("pointerdown", (e) => {
      last = [e.clientX, e.clientY];
      canvas.setPointerCapture(e.pointerId);
    });
    canvas.addEventListener("pointermove", (e) => {
      if (!last) return;
      const [dx, dy] = [e.clientX - last[0], e.clientY - last[1]];
      last = [e.clientX, e.clientY];
      this.orbit((dx / canvas.clientWidth) * Math.PI, (dy / canvas.clientWidth) * Math.PI);
    });
    const release = () => (last = null);
    canvas.addEventListener("pointerup", release);
    canvas.addEventListener("pointercancel", release);
    canvas.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        this.orbit(0, 0, Math.exp(Math.sign(e.deltaY) * 0.1));
      },
      { passive: false },
    );
    canvas.addEventListener("keydown", (e) => {
      const turn = Math.PI / 24;
      const action = {
        ArrowLeft: () => this.orbit(-turn, 0),
        ArrowRight: () => this.orbit(turn, 0),
        ArrowUp: () => this.orbit(0, -turn),
        ArrowDown: () => this.orbit(0, turn),
        "+": () => this.orbit(0, 0, 1 / 1.15),
        "=": () => this.orbit(0, 0, 1 / 1.15),
        "-": () => this.orbit(0, 0, 1.15),
        0: () => this.reset(),
      }[e.key];
      if (action) {
        e.preventDefault();
        action();
      }
    });
    new ResizeObserver(() => this.draw()).observe(canvas);
  }
}
