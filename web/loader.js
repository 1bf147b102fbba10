// Turns dropped or picked files into a light field: view images ordered by their names,
// decoded locally, packed as RGB bytes in row-major grid order.
import { viewBytes } from "./engine.js";

const HCI = /^input_Cam(\d{3})\.(png|jpe?g|bmp|webp)$/i;
const ROW_COL = /_(\d+)_(\d+)\.(png|jpe?g|bmp|webp)$/i;
const IMAGE = /\.(png|jpe?g|bmp|webp)$/i;

/** Every File under the dropped items (folders are walked). */
export async function filesFromDrop(dataTransfer) {
  const entries = [...dataTransfer.items].map((i) => i.webkitGetAsEntry?.()).filter(Boolean);
  if (!entries.length) return [...dataTransfer.files];
  const files = [];
  const walk = async (entry) => {
    if (entry.isFile) {
      files.push(await new Promise((ok, fail) => entry.file(ok, fail)));
    } else if (entry.isDirectory) {
      const reader = entry.createReader();
      for (;;) {
        const batch = await new Promise((ok, fail) => reader.readEntries(ok, fail));
        if (!batch.length) break;
        for (const e of batch) await walk(e);
      }
    }
  };
  for (const e of entries) await walk(e);
  return files;
}

/**
 * Sorts files into views. Returns `{ views: File[] (row-major), rows, cols, known,
 * groundTruth: File|null }`; `known` is false when the grid is a guess the user confirms.
 */
export function arrange(files) {
  const images = files.filter((f) => IMAGE.test(f.name));
  const groundTruth = files.find((f) => /\.pfm$/i.test(f.name) && /gt|disp/i.test(f.name)) ??
    files.find((f) => /\.pfm$/i.test(f.name)) ?? null;
  const hci = images.filter((f) => HCI.test(f.name));
  if (hci.length >= 9) {
    const side = Math.round(Math.sqrt(hci.length));
    const sorted = hci.sort((a, b) => Number(HCI.exec(a.name)[1]) - Number(HCI.exec(b.name)[1]));
    return { views: sorted, rows: side, cols: side, known: side * side === hci.length, groundTruth };
  }
  const rc = images.filter((f) => ROW_COL.test(f.name));
  if (rc.length >= 9 && rc.length === images.length) {
    const pos = rc.map((f) => ROW_COL.exec(f.name).slice(1, 3).map(Number));
    const rows = Math.max(...pos.map((p) => p[0])) + 1 - Math.min(...pos.map((p) => p[0]));
    const cols = Math.max(...pos.map((p) => p[1])) + 1 - Math.min(...pos.map((p) => p[1]));
    const r0 = Math.min(...pos.map((p) => p[0])), c0 = Math.min(...pos.map((p) => p[1]));
    const views = new Array(rows * cols);
    rc.forEach((f, i) => (views[(pos[i][0] - r0) * cols + pos[i][1] - c0] = f));
    return { views, rows, cols, known: views.every(Boolean) && rows * cols === rc.length, groundTruth };
  }
  const sorted = images.sort((a, b) => a.name.localeCompare(b.name, undefined, { numeric: true }));
  const side = Math.round(Math.sqrt(sorted.length));
  return { views: sorted, rows: side, cols: side, known: false, groundTruth };
}

/** Decodes the views (row-major `File`s) into packed RGB bytes. */
export async function decodeViews(files, rows, cols, onProgress) {
  if (files.length !== rows * cols || files.some((f) => !f)) {
    throw new Error(`a ${rows}x${cols} grid needs ${rows * cols} views, but ${files.filter(Boolean).length} images were given`);
  }
  let width = 0, height = 0, views = null;
  for (let i = 0; i < files.length; i++) {
    const bitmap = await createImageBitmap(files[i], { colorSpaceConversion: "none", premultiplyAlpha: "none" });
    if (i === 0) {
      ({ width, height } = bitmap);
      views = viewBytes(files.length * width * height * 3);
    } else if (bitmap.width !== width || bitmap.height !== height) {
      throw new Error(`${files[i].name} is ${bitmap.width}x${bitmap.height} but the first view is ${width}x${height}: all views must have one size`);
    }
    const canvas = new OffscreenCanvas(width, height);
    const ctx = canvas.getContext("2d", { willReadFrequently: true });
    ctx.drawImage(bitmap, 0, 0);
    bitmap.close();
    const rgba = ctx.getImageData(0, 0, width, height, { colorSpace: "srgb" }).data;
    const out = views.subarray(i * width * height * 3);
    for (let p = 0, q = 0; p < rgba.length; p += 4, q += 3) {
      out[q] = rgba[p];
      out[q + 1] = rgba[p + 1];
      out[q + 2] = rgba[p + 2];
    }
    onProgress((i + 1) / files.length);
  }
  return { views, shape: { rows, cols, width, height, channels: 3 } };
}
