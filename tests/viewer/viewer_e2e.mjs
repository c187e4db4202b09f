// Drives the live viewer page in headless Chromium (Debian's /usr/bin/chromium through
// playwright-core) for viewer_e2e_test.sh: opens a page, replays the LCM log into the bridge,
// checks the page's model against the oracle's count, opens a second page late, and checks that
// a screenshot shows content. Exits 0 on success, 1 with the reason otherwise.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import zlib from 'node:zlib';

// Writes RGBA pixels as an 8-bit indexed PNG (a palette of the 256 most frequent colours at
// 4 bits per channel, each pixel mapped to the nearest entry): a UI screenshot in well under
// half the bytes of the browser's RGB PNG, for a figure committed to docs/.
function writeIndexedPng(file, width, height, rgba) {
  const bins = new Map();
  for (let i = 0; i < rgba.length; i += 4) {
    const bin = ((rgba[i] >> 4) << 8) | ((rgba[i + 1] >> 4) << 4) | (rgba[i + 2] >> 4);
    const b = bins.get(bin) || { n: 0, r: 0, g: 0, b: 0 };
    b.n++; b.r += rgba[i]; b.g += rgba[i + 1]; b.b += rgba[i + 2];
    bins.set(bin, b);
  }
  const palette = [...bins.values()].sort((x, y) => y.n - x.n).slice(0, 256)
    .map((b) => [Math.round(b.r / b.n), Math.round(b.g / b.n), Math.round(b.b / b.n)]);
  const nearest = new Map();
  const indexOf = (r, g, b) => {
    const key = (r << 16) | (g << 8) | b;
    let best = nearest.get(key);
    if (best !== undefined) return best;
    let bestD = Infinity;
    palette.forEach((p, k) => {
      const d = (p[0] - r) ** 2 + (p[1] - g) ** 2 + (p[2] - b) ** 2;
      if (d < bestD) { bestD = d; best = k; }
    });
    nearest.set(key, best);
    return best;
  };
  const raw = Buffer.alloc(height * (width + 1));
  for (let y = 0; y < height; ++y) {
    raw[y * (width + 1)] = 0;  // filter: none
    for (let x = 0; x < width; ++x) {
      const o = 4 * (y * width + x);
      raw[y * (width + 1) + 1 + x] = indexOf(rgba[o], rgba[o + 1], rgba[o + 2]);
    }
  }
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc = (buf) => {
    let c = 0xffffffff;
    for (const byte of buf) c = crcTable[(c ^ byte) & 0xff] ^ (c >>> 8);
    return (c ^ 0xffffffff) >>> 0;
  };
  const chunk = (type, data) => {
    const head = Buffer.alloc(8);
    head.writeUInt32BE(data.length, 0);
    head.write(type, 4, 'ascii');
    const tail = Buffer.alloc(4);
    tail.writeUInt32BE(crc(Buffer.concat([head.subarray(4), data])), 0);
    return Buffer.concat([head, data, tail]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0);
  ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8; ihdr[9] = 3;  // 8-bit indexed colour
  fs.writeFileSync(file, Buffer.concat([
    Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', ihdr),
    chunk('PLTE', Buffer.from(palette.flat())), chunk('IDAT', zlib.deflateSync(raw, { level: 9 })),
    chunk('IEND', Buffer.alloc(0))]));
}

const args = {};
for (let i = 2; i + 1 < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
for (const key of ['web', 'url', 'lcm-url', 'log', 'expected', 'map-seq', 'screenshot']) {
  if (args[key] === undefined) {
    console.error(`usage: viewer_e2e.mjs --web DIR --url URL --lcm-url URL --log FILE --expected N --map-seq S --screenshot FILE [--speed X] [--figure FILE.png] (missing --${key})`);
    process.exit(2);
  }
}
const speed = args.speed || '4';
const expected = Number(args.expected), expectedSeq = Number(args['map-seq']);
const { chromium } = await import(pathToFileURL(path.join(args.web, 'node_modules/playwright-core/index.mjs')).href);

const failures = [];
const check = (condition, what) => { if (!condition) failures.push(what); };
const viewerState = (page) => page.evaluate(() => {
  const k = window.kestrelViewer;
  return { ...k, status: k.status, errors: [...k.errors] };
});
// Waits until the page's model reaches the oracle's map (count and sequence) and its 3D view has
// started (three.js loads after the socket connects: under load a snapshot can reach the model
// before the view exists, and the view then draws what the model holds), or times out.
async function waitForMap(page, name, timeoutMs) {
  try {
    await page.waitForFunction(([n, s]) => window.kestrelViewer.voxelCount === n && window.kestrelViewer.mapSeq === s &&
                               window.kestrelViewer.view3d !== 'starting',
                               [expected, expectedSeq], { timeout: timeoutMs, polling: 100 });
  } catch {
    const s = await viewerState(page);
    failures.push(`${name}: shows ${s.voxelCount} voxels at map_seq ${s.mapSeq}, expected ${expected} at ${expectedSeq}`);
  }
  return viewerState(page);
}

const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'kestrel-viewer-chromium-'));
let context;
try {
  context = await chromium.launchPersistentContext(userDataDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    viewport: { width: 1280, height: 720 },
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const pageErrors = [];
  const open = async (name) => {
    const page = await context.newPage();
    page.on('pageerror', (e) => pageErrors.push(`${name}: ${e.message}`));
    const response = await page.goto(args.url);
    check(response && response.status() === 200, `${name}: the page did not load (${response && response.status()})`);
    await page.waitForFunction(() => window.kestrelViewer && window.kestrelViewer.connected &&
                               window.kestrelViewer.messagesReceived > 0, null, { timeout: 15000 });
    return page;
  };

  // A page open from the start: snapshot (the first map) and then deltas.
  const early = await open('early page');
  const player = spawn('lcm-logplayer', [`--lcm-url=${args['lcm-url']}`, `--speed=${speed}`,
    '--regexp=^(MAP3D|MAP3D_DELTA|MAP_STATUS|MAP2D_.*|POSE_VICON|TRAJECTORY|EXPLORATION_STATUS)$',
    args.log], { stdio: ['ignore', 'ignore', 'inherit'] });
  const played = await new Promise((resolve) => player.on('exit', resolve));
  check(played === 0, `lcm-logplayer exited with ${played}`);
  const a = await waitForMap(early, 'early page', 15000);
  check(a.voxelSnapshots >= 1, `early page: no voxel snapshot (${a.voxelSnapshots})`);
  check(a.voxelDeltas >= 5, `early page: only ${a.voxelDeltas} voxel delta frames`);
  check(a.view3d === 'ok', `early page: the 3D view did not start: ${a.view3d}`);
  check(a.renderedVoxels === a.voxelCount, `early page: ${a.renderedVoxels} voxels drawn for ${a.voxelCount}`);
  check(a.pathPoints >= 10, `early page: flown path has ${a.pathPoints} points`);
  check(a.planPoints >= 2, `early page: plan has ${a.planPoints} points`);
  check(a.candidates >= 1, 'early page: no candidates');
  check(a.entropyPoints >= 5, `early page: entropy history has ${a.entropyPoints} points`);
  check(a.grids.length >= 1, 'early page: no 2D map');
  check(a.errors.length === 0, `early page: errors ${a.errors.join('; ')}`);
  const bridge = (a.status && a.status.bridge) || {};
  check(bridge.malformed === 0 && bridge.refused === 0,
        `bridge: ${bridge.malformed} malformed, ${bridge.refused} refused messages`);

  // A page opened after the run: it catches up from one snapshot.
  const late = await open('late page');
  const b = await waitForMap(late, 'late page', 10000);
  check(b.voxelSnapshots === 1 && b.voxelDeltas === 0,
        `late page: ${b.voxelSnapshots} snapshots and ${b.voxelDeltas} deltas, expected 1 and 0`);
  check(b.view3d === 'ok', `late page: the 3D view did not start: ${b.view3d}`);
  check(b.renderedVoxels === b.voxelCount, `late page: ${b.renderedVoxels} voxels drawn for ${b.voxelCount}`);
  check(b.pathPoints === a.pathPoints, `late page: path ${b.pathPoints} points, early page ${a.pathPoints}`);
  await late.close();

  // The screenshot shows content: many colours, and the 3D view is not just its background.
  await early.waitForTimeout(300);
  const png = await early.screenshot({ path: args.screenshot });
  const pixels = await early.evaluate(async ([b64, wantPixels]) => {
    const image = new Image();
    image.src = `data:image/png;base64,${b64}`;
    await image.decode();
    const canvas = document.createElement('canvas');
    canvas.width = image.width; canvas.height = image.height;
    const ctx = canvas.getContext('2d');
    ctx.drawImage(image, 0, 0);
    const data = ctx.getImageData(0, 0, image.width, image.height).data;
    const colours = new Set();
    let content3d = 0, area3d = 0;
    const width3d = image.width - 380;  // the side panel is 380 px wide
    for (let y = 0; y < image.height; ++y) {
      for (let x = 0; x < image.width; ++x) {
        const o = 4 * (y * image.width + x);
        colours.add((data[o] << 16) | (data[o + 1] << 8) | data[o + 2]);
        if (x < width3d && y > 60) {
          ++area3d;
          // Background #1b1e23 and the floor grid's greys are not content.
          const grey = Math.abs(data[o] - data[o + 2]) < 24 && Math.abs(data[o + 1] - data[o + 2]) < 24 && data[o] < 90;
          if (!grey) ++content3d;
        }
      }
    }
    // The pixels themselves only when a figure is asked for (base64 of RGBA).
    let rgba = '';
    if (wantPixels) {
      const bytes = new Uint8Array(data.buffer);
      for (let i = 0; i < bytes.length; i += 0x8000) rgba += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
      rgba = btoa(rgba);
    }
    return { width: image.width, height: image.height, colours: colours.size, content3d: content3d / area3d, rgba };
  }, [png.toString('base64'), args.figure !== undefined]);
  check(pixels.width === 1280 && pixels.height === 720, `screenshot is ${pixels.width}x${pixels.height}`);
  check(pixels.colours > 100, `screenshot has only ${pixels.colours} colours`);
  check(pixels.content3d > 0.01, `the 3D view shows content on ${(100 * pixels.content3d).toFixed(2)}% of its pixels`);
  if (args.figure) {
    writeIndexedPng(args.figure, pixels.width, pixels.height, Buffer.from(pixels.rgba, 'base64'));
    console.log(`figure: ${args.figure}, ${fs.statSync(args.figure).size} bytes (indexed colour)`);
  }
  check(pageErrors.length === 0, `page errors: ${pageErrors.join('; ')}`);
  console.log(`early page: ${a.voxelCount} voxels (${a.voxelSnapshots} snapshot, ${a.voxelDeltas} delta frames, ` +
              `${a.messagesReceived} messages), path ${a.pathPoints}, candidates ${a.candidates}, ` +
              `entropy points ${a.entropyPoints}, grids ${a.grids.join(',')}`);
  console.log(`late page: ${b.voxelCount} voxels from ${b.voxelSnapshots} snapshot`);
  console.log(`screenshot: ${png.length} bytes, ${pixels.colours} colours, 3D content on ${(100 * pixels.content3d).toFixed(1)}% of the view`);
} catch (e) {
  failures.push(`exception: ${e.stack || e}`);
} finally {
  if (context) await context.close();
  fs.rmSync(userDataDir, { recursive: true, force: true });
}
if (failures.length > 0) {
  for (const f of failures) console.log(`FAIL: ${f}`);
  process.exit(1);
}
console.log(`PASS: both pages show the ${expected} occupied cells of the reference map (map_seq ${expectedSeq})`);
