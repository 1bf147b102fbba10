// How the page sorts the files of a light field (web/loader.js), without a browser:
// views, the disparity ground truth by name, the camera file, the files it ignores, the
// light field's name, and the paths of a dropped folder's files.
import { test } from "node:test";
import assert from "node:assert/strict";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import { root } from "./pkg.mjs";

const { arrange, lightFieldName, filesFromDrop, pathOf } = await import(pathToFileURL(join(root, "web/loader.js")).href);

test("views, ground truth and ignored files of an HCI folder; its name", () => {
  const file = (name, path) => ({ name, webkitRelativePath: path ?? `scenes/cotton/${name}` });
  const views = Array.from({ length: 9 }, (_, i) => file(`input_Cam${String(i).padStart(3, "0")}.png`));
  const others = ["gt_depth_lowres.pfm", "gt_disp_highres.pfm", "gt_disp_lowres.pfm", "valid_mask.png", "object_ids_lowres.png", "parameters.cfg"].map((n) => file(n));
  const arranged = arrange([...others, ...views]);
  assert.equal(arranged.views.length, 9);
  assert.deepEqual([arranged.rows, arranged.cols, arranged.known], [3, 3, true]);
  assert.deepEqual(arranged.groundTruths.map((f) => f.name), ["gt_disp_lowres.pfm", "gt_disp_highres.pfm"]);
  assert.equal(arranged.config.name, "parameters.cfg");
  assert.deepEqual(arranged.ignored, ["gt_depth_lowres.pfm", "object_ids_lowres.png", "valid_mask.png"]);
  assert.equal(arranged.name, "cotton");
  // Masks among unnamed views are not views.
  const shots = Array.from({ length: 9 }, (_, i) => file(`shot${i}.png`, `shot${i}.png`));
  const loose = arrange([...shots, file("mask.png", "mask.png")]);
  assert.deepEqual([loose.views.length, loose.ignored], [9, ["mask.png"]]);
  assert.equal(loose.name, "shot");
  assert.equal(lightFieldName([file("a.png", "a.png"), file("b.png", "b.png")]), "light field");
  // Only whole words mark a non-view: "display" is no "disp".
  const rc = Array.from({ length: 9 }, (_, i) => file(`display_${Math.floor(i / 3)}_${i % 3}.png`, `display_${Math.floor(i / 3)}_${i % 3}.png`));
  const grid = arrange([...rc, file("display_mask.png", "display_mask.png")]);
  assert.deepEqual([grid.views.length, grid.rows, grid.cols, grid.known, grid.ignored], [9, 3, 3, true, ["display_mask.png"]]);
});

test("a dropped folder: every file under it, with its path, and the folder names the light field", async () => {
  // The browser's FileSystemEntry API as a drop hands it over.
  const fileEntry = (path) => ({ isFile: true, isDirectory: false, fullPath: path, file: (ok) => ok(new File(["x"], path.split("/").pop())) });
  const dirEntry = (path, children) => {
    let read = false;
    return {
      isFile: false,
      isDirectory: true,
      fullPath: path,
      createReader: () => ({ readEntries: (ok) => ok(read ? [] : ((read = true), children)) }),
    };
  };
  const names = Array.from({ length: 9 }, (_, i) => `input_Cam${String(i).padStart(3, "0")}.png`);
  const folder = dirEntry("/boxes", [...names.map((n) => fileEntry(`/boxes/${n}`)), fileEntry("/boxes/gt_depth_lowres.pfm"), dirEntry("/boxes/extra", [fileEntry("/boxes/extra/notes.txt")])]);
  const files = await filesFromDrop({ items: [{ webkitGetAsEntry: () => folder }], files: [] });
  assert.equal(files.length, 11);
  assert.equal(pathOf(files[0]), "boxes/input_Cam000.png");
  const arranged = arrange(files);
  assert.equal(arranged.name, "boxes");
  assert.deepEqual(arranged.groundTruths, []);
  assert.deepEqual(arranged.ignored, ["gt_depth_lowres.pfm", "notes.txt"]);
  // Loose files (no folder): the common start of their names.
  const loose = await filesFromDrop({ items: [], files: names.map((n) => new File(["x"], n)) });
  assert.equal(arrange(loose).name, "input_Cam");
});
