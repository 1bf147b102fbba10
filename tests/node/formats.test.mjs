// The page's file writers and PFM reader (web/formats.js) under Node: round trips and
// byte-level checks of the 16-bit PNG and PLY outputs.
import { test } from "node:test";
import assert from "node:assert/strict";
import { inflateSync } from "node:zlib";
import { pathToFileURL } from "node:url";
import { join } from "node:path";
import { root } from "./pkg.mjs";

const { parsePfm, writePfm, writePng16, writePly } = await import(pathToFileURL(join(root, "web/formats.js")).href);
const bytes = async (blob) => new Uint8Array(await blob.arrayBuffer());

const width = 5, height = 3;
const map = Float32Array.from({ length: width * height }, (_, i) => (i - 7) / 4);

test("PFM: written bottom row first, read back top row first, bit-exact", async () => {
  const file = await bytes(writePfm(map, width, height));
  const header = "Pf\n5 3\n-1.0\n";
  assert.equal(new TextDecoder().decode(file.subarray(0, header.length)), header);
  const firstStored = new DataView(file.buffer, header.length).getFloat32(0, true);
  assert.equal(firstStored, map[(height - 1) * width], "first stored row is the bottom row");
  const back = parsePfm(file.buffer);
  assert.deepEqual([back.width, back.height], [width, height]);
  assert.deepEqual(back.data, map);
  assert.throws(() => parsePfm(new TextEncoder().encode("P6\n1 1\n255\n").buffer), /not a PFM/);
  assert.throws(() => parsePfm(file.slice(0, file.length - 4).buffer), /truncated/);
});

test("16-bit PNG: signature, IHDR and big-endian samples scaled over [min, max]", async () => {
  const png = await bytes(await writePng16(map, width, height, -2, 2));
  assert.deepEqual([...png.subarray(0, 8)], [137, 80, 78, 71, 13, 10, 26, 10]);
  const view = new DataView(png.buffer);
  let pos = 8, idat = [], ihdr;
  while (pos < png.length) {
    const len = view.getUint32(pos);
    const type = new TextDecoder().decode(png.subarray(pos + 4, pos + 8));
    const data = png.subarray(pos + 8, pos + 8 + len);
    if (type === "IHDR") ihdr = data;
    if (type === "IDAT") idat.push(data);
    pos += 12 + len;
  }
  const h = new DataView(ihdr.buffer, ihdr.byteOffset);
  assert.deepEqual([h.getUint32(0), h.getUint32(4), ihdr[8], ihdr[9]], [width, height, 16, 0]);
  const raw = inflateSync(Buffer.concat(idat));
  assert.equal(raw.length, height * (1 + 2 * width));
  for (let y = 0; y < height; y++) {
    assert.equal(raw[y * (1 + 2 * width)], 0, "filter none");
    for (let x = 0; x < width; x++) {
      const o = y * (1 + 2 * width) + 1 + 2 * x;
      const expected = Math.round(((map[y * width + x] + 2) / 4) * 65535);
      assert.equal((raw[o] << 8) | raw[o + 1], expected);
    }
  }
});

test("PLY: header counts every pixel; vertices carry x, -y, scaled disparity and colour", async () => {
  const rgb = Uint8Array.from({ length: width * height * 3 }, (_, i) => i);
  const ply = await bytes(writePly(map, rgb, width, height, 10));
  const text = new TextDecoder("latin1").decode(ply);
  const end = text.indexOf("end_header\n") + "end_header\n".length;
  assert.match(text.slice(0, end), /element vertex 15\n/);
  assert.equal(ply.length - end, 15 * 15);
  const v = new DataView(ply.buffer, end + 7 * 15);
  assert.deepEqual([v.getFloat32(0, true), v.getFloat32(4, true), v.getFloat32(8, true)], [2, -1, map[7] * 10]);
  assert.deepEqual([v.getUint8(12), v.getUint8(13), v.getUint8(14)], [21, 22, 23]);
});
