// Renders a glTF/GLB file with three.js in headless Chromium and saves a PNG: proof that
// a stock viewer opens `coherad export`'s files as they are. The file's own camera is
// used when it has one (else the model is framed from the front).
// Needs: Debian's chromium, and `npm install three playwright-core` (NODE_PATH pointing
// at that node_modules). Usage: node .ci/screenshot_gltf.js FILE.glb OUT.png [W H]
const fs = require("fs");
const http = require("http");
const path = require("path");
const { chromium } = require("playwright-core");

const [file, out, w = "800", h = "600"] = process.argv.slice(2);
const three = path.dirname(path.dirname(require.resolve("three")));
const threeVersion = JSON.parse(fs.readFileSync(path.join(three, "package.json"))).version;
const page = `<!doctype html><html><body style="margin:0;background:#000">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
  "three/addons/": "/three/examples/jsm/"}}</script>
<script type="module">
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setSize(${w}, ${h});
document.body.appendChild(renderer.domElement);
new GLTFLoader().load("/model", (gltf) => {
  const scene = gltf.scene;
  let camera = gltf.cameras[0];
  if (camera) {
    camera.aspect = ${w} / ${h};
    camera.updateProjectionMatrix();
  } else {
    const box = new THREE.Box3().setFromObject(scene);
    const c = box.getCenter(new THREE.Vector3()), s = box.getSize(new THREE.Vector3()).length();
    camera = new THREE.PerspectiveCamera(45, ${w} / ${h}, s / 1000, s * 10);
    camera.position.set(c.x, c.y, c.z + 1.2 * s);
    camera.lookAt(c);
    scene.add(new THREE.AmbientLight(0xffffff, 1));
  }
  renderer.render(scene, camera);
  document.title = "rendered";
}, undefined, (e) => { document.title = "error: " + e; });
</script></body></html>`;

const server = http.createServer((req, res) => {
  if (req.url === "/") return res.end(page);
  if (req.url === "/model") return res.end(fs.readFileSync(file));
  if (req.url.startsWith("/three/")) {
    const p = path.join(three, req.url.slice(7));
    if (!p.startsWith(three) || !fs.existsSync(p)) { res.statusCode = 404; return res.end(); }
    res.setHeader("Content-Type", "text/javascript");
    return res.end(fs.readFileSync(p));
  }
  res.statusCode = 404;
  res.end();
});

server.listen(0, "127.0.0.1", async () => {
  const browser = await chromium.launch({
    executablePath: "/usr/bin/chromium",
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
      "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
      "--disable-background-networking", "--disable-component-update", "--disable-sync"],
  });
  try {
    const tab = await browser.newPage({ viewport: { width: +w, height: +h } });
    await tab.goto(`http://127.0.0.1:${server.address().port}/`);
    await tab.waitForFunction(() => document.title !== "", null, { timeout: 120000 });
    const title = await tab.title();
    if (title !== "rendered") throw new Error(title);
    await tab.locator("canvas").screenshot({ path: out });
    console.log(`${file}: rendered by three.js ${threeVersion} to ${out}`);
  } finally {
    await browser.close();
    server.close();
  }
});
