// File formats of the page, all produced locally: PFM (read/write), 16-bit grayscale PNG,
// PLY point clouds.

/** Parses a PFM ("Pf" gray or "PF" colour: first channel); rows come top row first. */
export function parsePfm(buffer) {
  const bytes = new Uint8Array(buffer);
  const tokens = [];
  let pos = 0;
  while (tokens.length < 4 && pos < bytes.length) {
    while (pos < bytes.length && /\s/.test(String.fromCharCode(bytes[pos]))) pos++;
    let token = "";
    while (pos < bytes.length && !/\s/.test(String.fromCharCode(bytes[pos]))) token += String.fromCharCode(bytes[pos++]);
    tokens.push(token);
  }
  pos++; // the single whitespace after the scale
  const [magic, w, h, s] = tokens;
  const channels = magic === "Pf" ? 1 : magic === "PF" ? 3 : 0;
  const width = Number(w), height = Number(h), scale = Number(s);
  if (!channels || !(width > 0) || !(height > 0) || !Number.isFinite(scale) || scale === 0) {
    throw new Error("not a PFM file: expected a 'Pf' or 'PF' header with width, height and scale");
  }
  const little = scale < 0;
  const needed = width * height * channels * 4;
  if (bytes.length - pos < needed) throw new Error(`PFM data is truncated: ${bytes.length - pos} of ${needed} bytes`);
  const view = new DataView(buffer, pos);
  const out = new Float32Array(width * height);
  for (let y = 0; y < height; y++) {
    const src = (height - 1 - y) * width; // stored bottom row first
    for (let x = 0; x < width; x++) out[y * width + x] = view.getFloat32((src + x) * channels * 4, little);
  }
  return { width, height, data: out };
}

/** A gray little-endian PFM of `data` (top row first in memory, stored bottom-to-top). */
export function writePfm(data, width, height) {
  const header = new TextEncoder().encode(`Pf\n${width} ${height}\n-1.0\n`);
  const out = new Uint8Array(header.length + width * height * 4);
  out.set(header);
  const view = new DataView(out.buffer, header.length);
  for (let y = 0; y < height; y++) {
    const row = (height - 1 - y) * width;
    for (let x = 0; x < width; x++) view.setFloat32((row + x) * 4, data[y * width + x], true);
  }
  return new Blob([out], { type: "application/octet-stream" });
}

const CRC_TABLE = (() => {
  const t = new Uint32Array(256);
  for (let n = 0; n < 256; n++) {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    t[n] = c >>> 0;
  }
  return t;
})();

function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = CRC_TABLE[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

function chunk(type, data) {
  const out = new Uint8Array(12 + data.length);
  const view = new DataView(out.buffer);
  view.setUint32(0, data.length);
  const typed = new TextEncoder().encode(type);
  out.set(typed, 4);
  out.set(data, 8);
  view.setUint32(8 + data.length, crc32(out.subarray(4, 8 + data.length)));
  return out;
}

async function deflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new CompressionStream("deflate"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

/**
 * A 16-bit grayscale PNG: value = round((d − min) / (max − min) · 65535). The mapping is
 * recorded in a tEXt chunk ("disparity: min MIN max MAX").
 */
export async function writePng16(data, width, height, min, max) {
  const raw = new Uint8Array(height * (1 + width * 2));
  const span = max > min ? max - min : 1;
  for (let y = 0; y < height; y++) {
    const row = y * (1 + width * 2); // filter byte 0 (none)
    for (let x = 0; x < width; x++) {
      const d = data[y * width + x];
      const v = Number.isFinite(d) ? Math.round(Math.min(1, Math.max(0, (d - min) / span)) * 65535) : 0;
      raw[row + 1 + 2 * x] = v >> 8;
      raw[row + 2 + 2 * x] = v & 0xff;
    }
  }
  const ihdr = new Uint8Array(13);
  const view = new DataView(ihdr.buffer);
  view.setUint32(0, width);
  view.setUint32(4, height);
  ihdr.set([16, 0, 0, 0, 0], 8); // 16 bit, grayscale, deflate, adaptive filter, no interlace
  const text = new TextEncoder().encode(`Comment\0disparity: min ${min} max ${max} (px between adjacent views)`);
  const signature = new Uint8Array([137, 80, 78, 71, 13, 10, 26, 10]);
  const parts = [signature, chunk("IHDR", ihdr), chunk("tEXt", text), chunk("IDAT", await deflate(raw)), chunk("IEND", new Uint8Array())];
  return new Blob(parts, { type: "image/png" });
}

/**
 * A binary PLY point cloud: one vertex per pixel at (x, −y, disparity · zScale) in pixel
 * units (no camera calibration is known), coloured by the centre view.
 */
export function writePly(disparity, rgb, width, height, zScale = 10) {
  const count = width * height;
  const header = new TextEncoder().encode(
    "ply\nformat binary_little_endian 1.0\ncomment lfdepth: x, y in pixels, z = disparity (px) x " +
      zScale +
      `\nelement vertex ${count}\nproperty float x\nproperty float y\nproperty float z\n` +
      "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
  );
  const out = new Uint8Array(header.length + count * 15);
  out.set(header);
  const view = new DataView(out.buffer, header.length);
  for (let i = 0; i < count; i++) {
    const o = i * 15;
    view.setFloat32(o, i % width, true);
    view.setFloat32(o + 4, -Math.floor(i / width), true);
    view.setFloat32(o + 8, disparity[i] * zScale, true);
    view.setUint8(o + 12, rgb[3 * i]);
    view.setUint8(o + 13, rgb[3 * i + 1]);
    view.setUint8(o + 14, rgb[3 * i + 2]);
  }
  return new Blob([out], { type: "application/octet-stream" });
}
