// The page's 3D view geometry (web/surface.js), without a browser: the camera of a
// parameters.cfg (web/loader.js), metric depth by the HCI benchmark's formula, the
// mesh's shape and the triangles left out across depth steps.
import { test } from "node:test";
import assert from "node:assert/strict";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import { root } from "./pkg.mjs";

const { depthMetres, surfaceMesh } = await import(pathToFileURL(join(root, "web/surface.js")).href);
const { parseConfig, cameraOf } = await import(pathToFileURL(join(root, "web/loader.js")).href);

const COTTON = `[intrinsics]
focal_length_mm = 100.0
image_resolution_x_px = 512
image_resolution_y_px = 512
sensor_size_mm = 35.0 ; the larger side
fstop = 100.0

[extrinsics]
num_cams_x = 9
num_cams_y = 9
baseline_mm = 25.0
focus_distance_m = 4.25
# a comment
[meta]
disp_min = -1.6
`;

test("the camera of an HCI parameters.cfg and its metric depth", () => {
  const camera = cameraOf(parseConfig(COTTON));
  assert.ok(Math.abs(camera.focalPx - (100 / 35) * 512) < 1e-9);
  assert.deepEqual([camera.baselineMm, camera.focusMm], [25, 4250]);
  // Zero disparity lies at the focus distance; positive disparities are nearer.
  assert.ok(Math.abs(depthMetres(0, camera) - 4.25) < 1e-12);
  const bf = 25 * camera.focalPx;
  assert.ok(Math.abs(depthMetres(1, camera) - (bf * 4250) / (4250 + bf) / 1000) < 1e-12);
  assert.ok(depthMetres(1, camera) < 4.25 && depthMetres(-1, camera) > 4.25);
  // At and beyond infinity: no depth.
  assert.equal(depthMetres(-bf / 4250, camera), null);
  assert.equal(depthMetres(-100, camera), null);
  // A key missing: no camera.
  assert.equal(cameraOf(parseConfig(COTTON.replace("baseline_mm = 25.0", ""))), null);
  assert.equal(cameraOf(parseConfig("[meta]\nscene = x\n")), null);
});

test("the mesh: a plane is flat, a depth step is not bridged", () => {
  const width = 40, height = 20;
  const rgb = new Uint8Array(width * height * 3).fill(128);
  const camera = cameraOf(parseConfig(COTTON));
  const flat = surfaceMesh({ disparity: new Float32Array(width * height).fill(0.5), rgb, channels: 3, width, height, camera });
  const zs = flat.positions.filter((_, i) => i % 3 === 2);
  assert.ok(zs.every((z) => Math.abs(z) < 1e-6), "a fronto-parallel plane has one depth");
  const xs = flat.positions.filter((_, i) => i % 3 === 0), ys = flat.positions.filter((_, i) => i % 3 === 1);
  const extent = (a) => Math.max(...a) - Math.min(...a);
  assert.ok(Math.abs(extent(xs) - 2) < 1e-5 && Math.abs(extent(ys) / extent(xs) - 19 / 39) < 1e-5);
  assert.equal(flat.indices.length / 3, 2 * (width - 1) * (height - 1));
  // Left half 1 px nearer than the right: the column of cells across the step is left out.
  const step = Float32Array.from({ length: width * height }, (_, i) => (i % width < width / 2 ? 1 : 0));
  const mesh = surfaceMesh({ disparity: step, rgb, channels: 3, width, height, camera: null });
  assert.equal(mesh.indices.length / 3, 2 * (width - 2) * (height - 1));
  assert.equal(mesh.metric, false);
  // Nearer is towards the viewer (+z).
  assert.ok(mesh.positions[2] > mesh.positions[3 * (width - 1) + 2]);
});
