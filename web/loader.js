// Turns dropped or picked files into a light field: view images ordered by their names,
// decoded locally, packed as RGB bytes in row-major grid order.
import { viewBytes } from "./engine.js";

const HCI = /^input_Cam(\d{3})\.(png|jpe?g|bmp|webp)$/i;
const ROW_COL = /_(\d+)_(\d+)\.(png|jpe?g|bmp|webp)$/i;
const IMAGE = /\.(png|jpe?g|bmp|webp)$/i;
/** Images a light-field folder holds beside its views: masks, object ids, ground-truth
 * or depth renderings, normals, thumbnails (a whole word of the name: `display_01_01.png`
 * is a view). They never count as views. */
const NOT_A_VIEW = /(^|[_\-. ])(masks?|object_?ids?|gt|depth|disp|disparity|normals?|thumb|thumbnail|preview)([_\-. ]|$)/i;
/** The disparity ground truth, by name: HCI's `gt_disp_lowres.pfm` first (the views'
 * resolution), then any other `gt_disp*`, then a PFM naming disparity. Depth PFMs
 * (`gt_depth*`) are never taken for disparity. */
const GT_DISP = [/^gt_disp_lowres\.pfm$/i, /^gt_disp.*\.pfm$/i, /disp.*\.pfm$/i];
const CONFIG = /^parameters\.cfg$/i;

/** Where a file lies under what the user picked or dropped: its relative path
 * (`cotton/input_Cam000.png`), or its name when none is known. */
export function pathOf(file) {
  return file.webkitRelativePath || file.lfdepthPath || file.name;
}

/** Every File under the dropped items (folders are walked; each file remembers its
 * path under the dropped folder, see `pathOf`). */
export async function filesFromDrop(dataTransfer) {
  const entries = [...dataTransfer.items].map((i) => i.webkitGetAsEntry?.()).filter(Boolean);
  if (!entries.length) return [...dataTransfer.files];
  const files = [];
  const walk = async (entry) => {
    if (entry.isFile) {
      const file = await new Promise((ok, fail) => entry.file(ok, fail));
      file.lfdepthPath = entry.fullPath.replace(/^\/+/, "");
      files.push(file);
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

/** The light field's name: the innermost folder holding all its views when they came
 * in a folder, else the common start of the view names (`view_01_01.png`, … → "view"),
 * else "light field". */
export function lightFieldName(views) {
  const dirs = views.filter(Boolean).map((f) => pathOf(f).split("/").slice(0, -1));
  if (dirs.length && dirs.every((d) => d.length)) {
    let common = dirs[0];
    for (const d of dirs) {
      let k = 0;
      while (k < common.length && k < d.length && common[k] === d[k]) k++;
      common = common.slice(0, k);
    }
    if (common.length) return common[common.length - 1];
  }
  const names = views.filter(Boolean).map((f) => f.name);
  let prefix = names[0] ?? "";
  for (const n of names) while (!n.startsWith(prefix)) prefix = prefix.slice(0, -1);
  // A prefix that ends inside a number or a separator names no light field.
  prefix = prefix.replace(/[\d_\-. ]+$/, "");
  return names.length > 1 && prefix ? prefix : "light field";
}

/**
 * Sorts files into views. Returns `{ views: File[] (row-major), rows, cols, known,
 * groundTruths: File[], config: File|null, ignored: string[], name }`: `known` is false
 * when the grid is a guess the user confirms; `groundTruths` are the disparity
 * ground-truth candidates, best first (the first of the views' size is used);
 * `config` is a `parameters.cfg`; `ignored` names every file used for none of these.
 */
export function arrange(files) {
  const images = files.filter((f) => IMAGE.test(f.name) && !NOT_A_VIEW.test(f.name));
  const groundTruths = [];
  for (const pattern of GT_DISP) {
    for (const f of files) if (pattern.test(f.name) && !/depth/i.test(f.name) && !groundTruths.includes(f)) groundTruths.push(f);
  }
  const config = files.find((f) => CONFIG.test(f.name)) ?? null;
  const arranged = (views, rows, cols, known) => {
    const used = new Set([...views, ...groundTruths, config]);
    const ignored = files.filter((f) => !used.has(f)).map((f) => f.name).sort((a, b) => a.localeCompare(b, undefined, { numeric: true }));
    return { views, rows, cols, known, groundTruths, config, ignored, name: lightFieldName(views) };
  };
  const hci = images.filter((f) => HCI.test(f.name));
  if (hci.length >= 9) {
    const side = Math.round(Math.sqrt(hci.length));
    const sorted = hci.sort((a, b) => Number(HCI.exec(a.name)[1]) - Number(HCI.exec(b.name)[1]));
    return arranged(sorted, side, side, side * side === hci.length);
  }
  const rc = images.filter((f) => ROW_COL.test(f.name));
  if (rc.length >= 9 && rc.length === images.length) {
    const pos = rc.map((f) => ROW_COL.exec(f.name).slice(1, 3).map(Number));
    const rows = Math.max(...pos.map((p) => p[0])) + 1 - Math.min(...pos.map((p) => p[0]));
    const cols = Math.max(...pos.map((p) => p[1])) + 1 - Math.min(...pos.map((p) => p[1]));
    const r0 = Math.min(...pos.map((p) => p[0])), c0 = Math.min(...pos.map((p) => p[1]));
    const views = new Array(rows * cols);
    rc.forEach((f, i) => (views[(pos[i][0] - r0) * cols + pos[i][1] - c0] = f));
    return arranged(views, rows, cols, views.every(Boolean) && rows * cols === rc.length);
  }
  const sorted = images.sort((a, b) => a.name.localeCompare(b.name, undefined, { numeric: true }));
  const side = Math.round(Math.sqrt(sorted.length));
  return arranged(sorted, side, side, false);
}

/** The keys of a `parameters.cfg` (HCI's INI-like format: `[section]` headers,
 * `key = value`, `#`/`;` comments) as `{ "section.key": value }` of strings. */
export function parseConfig(text) {
  const out = {};
  let section = "";
  for (const raw of text.split(/\r?\n/)) {
    const line = raw.replace(/[#;].*$/, "").trim();
    if (!line) continue;
    const header = /^\[(.+)\]$/.exec(line);
    if (header) section = header[1].trim();
    else {
      const eq = line.indexOf("=");
      if (eq > 0) out[`${section}.${line.slice(0, eq).trim()}`] = line.slice(eq + 1).trim();
    }
  }
  return out;
}

/** The camera of a `parameters.cfg` (`parseConfig`) as the 3D view needs it, or null
 * when a key is missing: focal length in pixels (`focal_length_mm / sensor_size_mm ·
 * max(res_x, res_y)`), baseline in mm and focus distance in mm, for the HCI benchmark's
 * depth `z = b·f·D / (d·D + b·f)`. */
export function cameraOf(config) {
  const num = (key) => {
    const v = Number(config[key]);
    return config[key] !== undefined && Number.isFinite(v) && v > 0 ? v : null;
  };
  const focal = num("intrinsics.focal_length_mm"), sensor = num("intrinsics.sensor_size_mm");
  const rx = num("intrinsics.image_resolution_x_px"), ry = num("intrinsics.image_resolution_y_px");
  const baseline = num("extrinsics.baseline_mm"), focus = num("extrinsics.focus_distance_m");
  if (!(focal && sensor && rx && ry && baseline && focus)) return null;
  return { focalPx: (focal / sensor) * Math.max(rx, ry), baselineMm: baseline, focusMm: focus * 1000 };
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
