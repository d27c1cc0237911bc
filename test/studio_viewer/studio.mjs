// Open Foxglove Studio 1.48 (npm @foxglove/studio-base's web bundle) in a headless chromium on a
// live view, with a layout, and print as one JSON object what the page showed: the topic list's
// text, the Plot legends' text at two moments, the player problems and console warnings, the
// probe's message counts, lags and animation frames over a measuring window (probe.js), and
// when each phase was reached (seconds from the start: a time-out names where it stopped).
//
// node studio.mjs '{"url": "ws://127.0.0.1:PORT", "layout": "config/foxglove_layout.json",
//   "chromium": "/usr/bin/chromium", "artefacts": "DIR", "measure_s": 8, "timeout_s": 120,
//   "parameter": {"name": "/abb_simulator.fault.speed_noise", "value": "40"},
//   "publish": "Publish speed command", "profile": "DIR"}'
// parameter: typed into its row of the Parameters panel and set with the row's button; publish:
// the Publish panel's button clicked (both from the page, as a user does). profile: chromium's
// user data directory (its processes name it: the caller stops them should this one be killed).
import fs from "node:fs";
import http from "node:http";
import path from "node:path";
import { fileURLToPath } from "node:url";
import puppeteer from "puppeteer-core";

const here = path.dirname(fileURLToPath(import.meta.url));
const options = { measure_s: 8, timeout_s: 120, ...JSON.parse(process.argv[2]) };
const files = {
  "/": path.join(here, "index.html"),
  "/react.js": path.join(here, "node_modules/react/umd/react.production.min.js"),
  "/react-dom.js": path.join(here, "node_modules/react-dom/umd/react-dom.production.min.js"),
  "/layout.json": options.layout,
};
const assets = path.join(here, "node_modules/@foxglove/studio-base/assets");
const TYPES = { ".html": "text/html", ".js": "text/javascript", ".json": "application/json",
  ".wasm": "application/wasm", ".png": "image/png", ".woff2": "font/woff2" };

const server = http.createServer((request, response) => {
  const name = new URL(request.url, "http://page").pathname;
  const file = files[name] ?? (name.startsWith("/studio/")
    ? path.join(assets, path.normalize(name.slice("/studio/".length)).replace(/^(\.\.[/\\])+/, ""))
    : undefined);
  fs.readFile(file ?? "", (error, data) => {
    if (error) { response.writeHead(404); response.end(); return; }
    response.writeHead(200, { "Content-Type": TYPES[path.extname(file)] ?? "application/octet-stream" });
    response.end(data);
  });
});
await new Promise((resolve) => server.listen(0, "127.0.0.1", resolve));

const seen = { console: [], errors: [], phases: {} };
const started = Date.now();
const seconds = () => (Date.now() - started) / 1000;
const reached = (phase) => { seen.phases[phase] = seconds(); };
let finished = false;
const sleep = (s) => new Promise((resolve) => setTimeout(resolve, s * 1000));
const browser = await puppeteer.launch({
  executablePath: options.chromium, headless: true, userDataDir: options.profile, defaultViewport: { width: 1600, height: 1000 },
  args: ["--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader", "--window-size=1600,1000"],
});
const timer = setTimeout(() => finish("timed out"), options.timeout_s * 1000);

// Print what was seen, once: the first failure (a time-out) stops the page, and what was
// waiting on it then fails too, which is not news.
async function finish(failure) {
  if (finished) return;
  finished = true;
  if (failure) seen.failure = failure;
  clearTimeout(timer);
  process.stdout.write(JSON.stringify(seen) + "\n");
  await browser.close().catch(() => {});
  server.close();
  process.exit(0);
}

async function shot(page, name) {
  if (options.artefacts) await page.screenshot({ path: path.join(options.artefacts, `${name}.png`) });
}

async function waitFor(page, what, predicate, ...args) {
  await page.waitForFunction(predicate, { timeout: options.timeout_s * 1000, polling: 250 }, ...args)
    .catch(() => finish(`timed out waiting for ${what}`));
}

// What the page's probe measured since `from` (a snapshot of it): counts, lags, frames, and
// each topic's messages per second of their stamps (what the live view's cap bounds).
const window_of = (from) => {
  const p = window.__abbProbe;
  const now = Date.now() - p.start;
  const lags = {};
  const stampRates = {};
  for (const [topic, arrivals] of Object.entries(p.arrivals)) {
    const recent = p.lags[topic].filter((_, k) => arrivals[k] >= from.at);
    const stamps = p.stamps[topic].filter((_, k) => arrivals[k] >= from.at);
    recent.sort((a, b) => a - b);
    lags[topic] = recent.length ? { n: recent.length, median: recent[recent.length >> 1],
      p95: recent[Math.floor(recent.length * 0.95)], max: recent[recent.length - 1] } : null;
    const span = (Math.max(...stamps) - Math.min(...stamps)) / 1000;
    stampRates[topic] = stamps.length > 1 && span > 0 ? (stamps.length - 1) / span : null;
  }
  return { seconds: (now - from.at) / 1000, frames: p.frames - from.frames, lags, stampRates,
    counts: Object.fromEntries(Object.entries(p.counts).map(([t, n]) => [t, n - (from.counts[t] || 0)])) };
};

// Type `value` into the Parameters panel's row of `name` and press that row's button.
async function setParameter(page, { name, value }) {
  const rows = await page.$$("tr");
  for (const row of rows) {
    const text = await row.evaluate((e) => e.textContent);
    if (!text.startsWith(name)) continue;
    const box = await row.$("textarea");
    await box.click();
    await box.evaluate((e) => e.select());
    await box.type(value);
    const button = await row.$("button");
    await button.click();
    await sleep(1);
    seen.parameter_row = await row.evaluate((e) => e.textContent);
    return;
  }
  seen.parameter_row = null;
}

try {
  const page = await browser.newPage();
  page.on("console", (m) => { if (m.type() === "warn" || m.type() === "error") seen.console.push(m.text().slice(0, 300)); });
  page.on("pageerror", (error) => seen.errors.push(String(error).slice(0, 300)));
  await page.evaluateOnNewDocument(fs.readFileSync(path.join(here, "probe.js"), "utf8"));
  const port = server.address().port;
  await page.goto(`http://127.0.0.1:${port}/?layoutId=abb_ros&ds=foxglove-websocket&ds.url=${encodeURIComponent(options.url)}`);
  reached("page loaded");
  await waitFor(page, "the topic list", () => document.body.innerText.includes("/joint_states\n"));
  seen.connected_s = seconds();
  reached("topics listed");
  await waitFor(page, "markers and joint states in the page",
    () => (window.__abbProbe.counts["/visualization/markers"] || 0) > 20 && (window.__abbProbe.counts["/joint_states"] || 0) > 100);
  reached("messages flowing");
  const from = await page.evaluate(() => { const p = window.__abbProbe; return { at: Date.now() - p.start, frames: p.frames, counts: { ...p.counts } }; });
  const legends = () => [...document.querySelectorAll("*")].filter((e) => e.childElementCount === 0)
    .map((e) => e.textContent.trim()).filter((t) => /^-?[0-9.]+(e[-+][0-9]+)?$/.test(t));
  seen.legend_before = await page.evaluate(legends);
  await sleep(options.measure_s);
  seen.legend_after = await page.evaluate(legends);
  seen.window = await page.evaluate(window_of, from);
  reached("measured");
  seen.topics_text = await page.evaluate(() => document.body.innerText);
  seen.server_info = await page.evaluate(() => window.__abbProbe.serverInfo);
  await shot(page, "studio_layout");
  const [problems] = await page.$$("xpath/.//button[normalize-space()='Problems']");
  if (problems) {
    await problems.click();
    await sleep(1);
    seen.problems_text = await page.evaluate(() => document.body.innerText);
    await shot(page, "studio_problems");
  }
  reached("problems shown");
  if (options.parameter) await setParameter(page, options.parameter);
  reached("parameter set");
  if (options.publish) {
    const [button] = await page.$$(`xpath/.//button[normalize-space()='${options.publish}']`);
    seen.publish_button = Boolean(button);
    if (button) {
      await button.click();
      await sleep(1);
    }
  }
  seen.sent = await page.evaluate(() => ({ ops: window.__abbProbe.sent.map((m) => m.op),
    parameters: window.__abbProbe.sent.filter((m) => m.op === "setParameters"),
    advertised: window.__abbProbe.sent.filter((m) => m.op === "advertise"),
    published: window.__abbProbe.published }));
  await shot(page, "studio_after_actions");
  reached("published");
  seen.total_s = seconds();
  await finish();
} catch (error) {
  await finish(String(error && error.stack || error));
}
