// Drawing: colour maps, image canvases at native resolution (CSS scales them), the
// legend and the residual plot.

// Viridis as a degree-6 polynomial per channel (perceptually uniform, colour-blind safe).
const VIRIDIS = [
  [0.2777273272234177, 0.005407344544966578, 0.3340998053353061],
  [0.1050930431085774, 1.404613529898575, 1.384590162594685],
  [-0.3308618287255563, 0.214847559468213, 0.09509516302823659],
  [-4.634230498983486, -5.799100973351585, -19.33244095627987],
  [6.228269936347081, 14.17993336680509, 56.69055260068105],
  [4.776384997670288, -13.74514537774601, -65.35303263337234],
  [-5.435455855934631, 4.645852612178535, 26.3124352495832],
];

/** 256-entry RGB lookup table of viridis. */
export const viridis = (() => {
  const lut = new Uint8Array(256 * 3);
  for (let i = 0; i < 256; i++) {
    const t = i / 255;
    for (let c = 0; c < 3; c++) {
      let v = 0;
      for (let k = VIRIDIS.length - 1; k >= 0; k--) v = v * t + VIRIDIS[k][c];
      lut[3 * i + c] = Math.round(Math.min(1, Math.max(0, v)) * 255);
    }
  }
  return lut;
})();

function put(canvas, width, height, fill) {
  canvas.width = width;
  canvas.height = height;
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(width, height);
  fill(image.data);
  ctx.putImageData(image, 0, 0);
}

/** A scalar map through a lookup table over [min, max]; NaN is shown in gray. */
export function drawMap(canvas, data, width, height, min, max, lut = viridis) {
  const span = max > min ? max - min : 1;
  put(canvas, width, height, (px) => {
    for (let i = 0; i < width * height; i++) {
      const v = data[i];
      const o = 4 * i;
      if (!Number.isFinite(v)) {
        px.set([128, 128, 128, 255], o);
        continue;
      }
      const k = 3 * Math.round(Math.min(1, Math.max(0, (v - min) / span)) * 255);
      px[o] = lut[k];
      px[o + 1] = lut[k + 1];
      px[o + 2] = lut[k + 2];
      px[o + 3] = 255;
    }
  });
}

/** Gray ramp (confidence). */
export const grays = (() => {
  const lut = new Uint8Array(256 * 3);
  for (let i = 0; i < 256; i++) lut.fill(i, 3 * i, 3 * i + 3);
  return lut;
})();

/** White → orange → dark red (absolute error). */
export const heat = (() => {
  const lut = new Uint8Array(256 * 3);
  const stops = [[255, 255, 255], [253, 174, 97], [215, 48, 39], [103, 0, 13]];
  for (let i = 0; i < 256; i++) {
    const t = (i / 255) * (stops.length - 1);
    const k = Math.min(stops.length - 2, Math.floor(t));
    const f = t - k;
    for (let c = 0; c < 3; c++) lut[3 * i + c] = Math.round(stops[k][c] * (1 - f) + stops[k + 1][c] * f);
  }
  return lut;
})();

/** Packed RGB (or gray) bytes of one view. */
export function drawRgb(canvas, bytes, width, height, channels) {
  put(canvas, width, height, (px) => {
    for (let i = 0; i < width * height; i++) {
      const s = i * channels;
      px[4 * i] = bytes[s];
      px[4 * i + 1] = bytes[s + (channels > 1 ? 1 : 0)];
      px[4 * i + 2] = bytes[s + (channels > 2 ? 2 : 0)];
      px[4 * i + 3] = 255;
    }
  });
}

/**
 * The EPI through image row `y` (views of the centre camera row, one per EPI row, each
 * repeated `stretch` times) and through image column `x` (views of the centre column),
 * drawn transposed so both are wide.
 */
export function drawEpis(hCanvas, vCanvas, lightField, x, y, stretch = 6) {
  const { views, shape } = lightField;
  const { rows, cols, width, height, channels } = shape;
  const r0 = (rows - 1) >> 1, c0 = (cols - 1) >> 1;
  const viewLen = width * height * channels;
  const sample = (r, c, px, py, ch) => views[(r * cols + c) * viewLen + (py * width + px) * channels + Math.min(ch, channels - 1)];
  put(hCanvas, width, cols * stretch, (out) => {
    for (let k = 0; k < cols; k++)
      for (let s = 0; s < stretch; s++)
        for (let t = 0; t < width; t++) {
          const o = 4 * ((k * stretch + s) * width + t);
          for (let ch = 0; ch < 3; ch++) out[o + ch] = sample(r0, k, t, y, ch);
          out[o + 3] = 255;
        }
  });
  put(vCanvas, height, rows * stretch, (out) => {
    for (let k = 0; k < rows; k++)
      for (let s = 0; s < stretch; s++)
        for (let t = 0; t < height; t++) {
          const o = 4 * ((k * stretch + s) * height + t);
          for (let ch = 0; ch < 3; ch++) out[o + ch] = sample(k, c0, x, t, ch);
          out[o + 3] = 255;
        }
  });
}

/** A horizontal colour bar of `lut`. */
export function drawLegend(canvas, lut = viridis) {
  const width = 256;
  put(canvas, width, 1, (px) => {
    for (let i = 0; i < width; i++) px.set([lut[3 * i], lut[3 * i + 1], lut[3 * i + 2], 255], 4 * i);
  });
}

/** The TV residual per iteration on a log axis; a note when there is none. */
export function drawResiduals(canvas, residuals) {
  const dpr = window.devicePixelRatio || 1;
  const cssWidth = canvas.clientWidth || 320;
  const cssHeight = Math.round(cssWidth * 0.56);
  canvas.width = Math.round(cssWidth * dpr);
  canvas.height = Math.round(cssHeight * dpr);
  const ctx = canvas.getContext("2d");
  ctx.scale(dpr, dpr);
  ctx.fillStyle = "#ffffff";
  ctx.fillRect(0, 0, cssWidth, cssHeight);
  ctx.font = "13px system-ui, sans-serif";
  ctx.fillStyle = "#5a6470";
  const finite = Array.from(residuals).filter((r) => Number.isFinite(r) && r > 0);
  if (!finite.length) {
    ctx.fillText("No TV iterations yet:", 12, cssHeight / 2 - 8);
    ctx.fillText("run the estimation.", 12, cssHeight / 2 + 10);
    return;
  }
  const pad = { l: 44, r: 10, t: 10, b: 26 };
  const lo = Math.log10(Math.min(...finite)), hi = Math.log10(Math.max(...finite));
  const span = hi > lo ? hi - lo : 1;
  const X = (i) => pad.l + (i / Math.max(1, residuals.length - 1)) * (cssWidth - pad.l - pad.r);
  const Y = (r) => pad.t + (1 - (Math.log10(r) - lo) / span) * (cssHeight - pad.t - pad.b);
  ctx.strokeStyle = "#d9dde3";
  ctx.strokeRect(pad.l, pad.t, cssWidth - pad.l - pad.r, cssHeight - pad.t - pad.b);
  ctx.fillText(`1e${hi.toFixed(1)}`, 4, pad.t + 10);
  ctx.fillText(`1e${lo.toFixed(1)}`, 4, cssHeight - pad.b);
  ctx.fillText(`iteration (${residuals.length})`, cssWidth / 2 - 40, cssHeight - 6);
  ctx.strokeStyle = "#2357c6";
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  residuals.forEach((r, i) => (i ? ctx.lineTo(X(i), Y(r)) : ctx.moveTo(X(i), Y(r))));
  ctx.stroke();
}

/**
 * On the EPIs of `drawEpis` (same `stretch`), the line a disparity `d` at pixel (`x`,
 * `y`) claims: the point the centre view sees there lies at `x − d·(c − c0)` in the view
 * of column `c` (and at `y − d·(r − r0)` in the view of row `r`; HCI's sign), so on the
 * EPIs it is a straight line of slope `−d` pixels per view through the picked pixel.
 * Returns where the line crosses the first and the last view on the horizontal EPI.
 */
export function drawEpiLine(hCanvas, vCanvas, shape, x, y, d, stretch = 6) {
  const { rows, cols } = shape;
  const r0 = (rows - 1) >> 1, c0 = (cols - 1) >> 1;
  // At canvas row `t` the EPI shows view `k = t / stretch − ½` (its rows' middle).
  const line = (canvas, at, count, centre) => {
    const ctx = canvas.getContext("2d");
    const xAt = (k) => at - d * (k - centre) + 0.5;
    ctx.save();
    ctx.lineWidth = 1.5;
    ctx.strokeStyle = "#ff2d95";
    ctx.beginPath();
    ctx.moveTo(xAt(-0.5), 0);
    ctx.lineTo(xAt(count - 0.5), count * stretch);
    ctx.stroke();
    // The picked pixel itself, on the centre view's EPI rows.
    ctx.strokeStyle = "#ffffff";
    ctx.lineWidth = 1;
    ctx.strokeRect(at - 2, centre * stretch - 1, 5, stretch + 2);
    ctx.restore();
    return [xAt(0) - 0.5, xAt(count - 1) - 0.5];
  };
  line(vCanvas, y, rows, r0);
  return line(hCanvas, x, cols, c0);
}
