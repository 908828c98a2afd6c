// The live monitor in a real browser: a dry run of the demo tour serves its page, headless
// Debian Chromium opens it (puppeteer-core drives it over the DevTools protocol), and the checks
// read what the page shows and what the run wrote.
//
//   node monitor_test.mjs SCENARIO --projtour BIN --source DIR --out DIR
//   SCENARIO: controls       the page follows the tour; pause, resume, skip and a 401 through it
//             browser-killed the browser dies mid-stream; the tour completes unaffected
// Exit status: 0 passed, 1 failed, 77 skipped (no Chromium). PROJTOUR_MONITOR_SCREENSHOT=FILE
// (relative to the source tree) also copies the mid-tour screenshot there: docs/monitor.png.
import { spawn } from "node:child_process";
import fs from "node:fs";
import path from "node:path";

const SKIP = 77;
const args = process.argv.slice(2);
const scenario = args[0];
const option = (name) => {
  const i = args.indexOf(name);
  if (i < 0 || i + 1 >= args.length) throw new Error(`missing ${name}`);
  return args[i + 1];
};
const projtour = option("--projtour");
const source = option("--source");
const outDir = option("--out");

const chromium = ["/usr/bin/chromium", "/usr/bin/chromium-browser"].find((p) => fs.existsSync(p));
if (!chromium) {
  console.log("skipped: no Chromium (/usr/bin/chromium)");
  process.exit(SKIP);
}
let puppeteer;
try {
  puppeteer = (await import("puppeteer-core")).default;
} catch (err) {
  throw new Error(`puppeteer-core is not installed: npm ci --prefix tests/executor/views/monitor (${err.message})`);
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const log = (...a) => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)} s]`, ...a);
const t0 = Date.now();
let failures = 0;
function check(ok, what) {
  log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures++;
  return ok;
}
// Polls `probe` until it returns a truthy value; throws naming `what` after `timeoutMs`.
async function until(what, probe, timeoutMs = 30000, everyMs = 100) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await probe();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await sleep(everyMs);
  }
}

// --- the run --------------------------------------------------------------------------------
// Unpaced, the demo tour (205 s of mission time) takes about 35 s of wall time on 2 cores; at
// these speeds it takes 40-60 s beside the browser, long enough to act on each visit.
const speed = scenario === "controls" ? "4" : "6";
fs.rmSync(outDir, { recursive: true, force: true });
fs.mkdirSync(outDir, { recursive: true });
const runDir = path.join(outDir, "run");
const child = spawn(projtour, [
  "run", path.join(source, "missions/demo_tour.yaml"), "--dry-run",
  "--world", path.join(source, "missions/demo_world.yaml"), "--speed", speed,
  "--monitor", "127.0.0.1:0", "--out", runDir, "--no-history",
], { stdio: ["ignore", "pipe", "pipe"] });
const stdoutLog = fs.createWriteStream(path.join(outDir, "projtour.stdout"));
const stderrLog = fs.createWriteStream(path.join(outDir, "projtour.stderr"));
child.stdout.pipe(stdoutLog);
let stderrText = "";
child.stderr.on("data", (d) => { stderrText += d; stderrLog.write(d); });
const exited = new Promise((resolve) => child.on("exit", (code, signal) => resolve({ code, signal })));
let exitStatus = null;
exited.then((s) => { exitStatus = s; });

let browser = null;  // the one open, closed at the end

// A browser on the page, with what the page did: script errors and the URLs it asked for.
async function openPage(base, token) {
  const profile = fs.mkdtempSync(path.join(outDir, "profile-"));
  browser = await puppeteer.launch({
    executablePath: chromium,
    headless: true,
    userDataDir: profile,
    args: ["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run"],
  });
  const page = await browser.newPage();
  await page.setViewport({ width: 1400, height: 1000 });
  const seen = { page, errors: [], consoleErrors: [], requested: [] };
  page.on("pageerror", (e) => seen.errors.push(e.message));
  // What the page or the browser logs as an error: a failed request, a script's console.error.
  page.on("console", (m) => {
    if (m.type() === "error") seen.consoleErrors.push({ text: m.text(), url: m.location().url || "" });
  });
  page.on("request", (r) => seen.requested.push(r.url()));
  await page.goto(`${base}#token=${token}`);
  seen.state = () => page.evaluate(() => window.projtourMonitor.lastState);
  await until("the first state", seen.state, 30000);
  await page.waitForSelector("#graph g[data-path]");
  return seen;
}

function checkRequests(seen, base, token) {
  check(seen.errors.length === 0, `no script errors on the page ${JSON.stringify(seen.errors)}`);
  // The one error the browser must log: the 401 of the resume the controls scenario sends with a
  // wrong token on purpose ("Failed to load resource: ... 401").
  const unexpected = seen.consoleErrors.filter((e) =>
    !(e.text.includes("401") && new URL(e.url || "about:blank").pathname === "/api/control/resume"));
  check(unexpected.length === 0, `no errors on the console ${JSON.stringify(unexpected)}`);
  const origin = new URL(base).origin;
  check(seen.requested.every((u) => u.startsWith(origin)), "the page asks nothing of any other host");
  // Puppeteer reports a navigation with its fragment, which the browser keeps to itself.
  check(seen.requested.every((u) => !u.split("#")[0].includes(token)),
        "the token is in no request's URL");
}

async function main() {
  const base = await until("the monitor's address on stderr", () => {
    if (exitStatus) throw new Error(`projtour exited early (${JSON.stringify(exitStatus)}): ${stderrText}`);
    const m = /monitor on (http:\/\/127\.0\.0\.1:\d+\/)/.exec(stderrText);
    return m && m[1];
  }, 60000);
  const tokenFile = path.join(runDir, "monitor_token");
  check((fs.statSync(tokenFile).mode & 0o777) === 0o600, "monitor_token is mode 0600");
  const token = fs.readFileSync(tokenFile, "utf8").trim();
  check(/^[0-9a-f]{32}$/.test(token), "the token is 32 hex digits");
  const api = async (p, init) => {
    const res = await fetch(new URL(p, base), init);
    return { status: res.status, body: await res.json().catch(() => null) };
  };
  const seen = await openPage(base, token);
  if (scenario === "controls") {
    await controls(seen.page, seen.state, api, token);
    checkRequests(seen, base, token);
  } else {
    await browserKilled(seen, api, base, token);
  }
}

async function screenshot(page, name) {
  const file = path.join(outDir, name);
  await page.screenshot({ path: file, fullPage: true });
  log(`screenshot ${file}`);
  return file;
}

async function controls(page, state, api, token) {
  // The graph marks the active state, and follows it.
  const shown = () => page.evaluate(() => {
    const active = [...document.querySelectorAll("#graph g.active")].map((g) => g.dataset.path);
    return { active, text: document.querySelector("#active-state").textContent,
             trail: [...document.querySelectorAll("#graph g.trail")].map((g) => g.dataset.path),
             pose: window.projtourMonitor.poseDrawn,
             time: document.querySelector("#mission-time").textContent,
             state: window.projtourMonitor.lastState };
  });
  let s = await until("an active leaf state", async () => {
    const v = await shown();
    return v.active.length === 1 && v.state.active_state.startsWith("tour/visit/") && v;
  });
  check(s.active[0] === s.state.active_state && s.text === s.state.active_state,
        `the graph and the header show the active state ${s.state.active_state}`);
  const graph = await page.evaluate(() => ({
    states: document.querySelectorAll("#graph g[data-path]").length,
    arcs: document.querySelectorAll("#graph path.edge").length }));
  check(graph.states === (await api("/api/machine")).body.states.length && graph.arcs > 0,
        `the graph draws every state (${graph.states}) and the transitions between them (${graph.arcs})`);
  const pose0 = s.pose;
  check(!!pose0 && Number.isFinite(pose0.x), "the map draws the estimated pose");
  await until("the drawn pose to move 0.5 m", async () => {
    const p = (await shown()).pose;
    return p && Math.hypot(p.x - pose0.x, p.y - pose0.y) > 0.5;
  }, 30000);
  check(true, "the drawn pose moves");
  await screenshot(page, "1-navigating.png");

  // Pause stops mission time; a control without the token is refused and changes nothing.
  await page.click("#pause");
  await until("the tour to pause", async () => (await state()).paused, 10000);
  await until("the reply in the status line", () =>
    page.$eval("#status", (e) => /^pause: accepted/.test(e.textContent)), 5000);
  await sleep(600);  // the state in flight when the pause was taken
  const before = await shown();
  await sleep(2000);
  const after = await shown();
  check(before.time === after.time, `paused, mission time stays at ${before.time} over 2 s`);
  check(before.pose.x === after.pose.x && before.pose.y === after.pose.y,
        "paused, the drawn pose stays");

  const bare = await api("/api/control/resume", { method: "POST" });
  check(bare.status === 401 && typeof bare.body?.error === "string", "resume without the token: 401");
  const wrong = await api("/api/control/resume",
                          { method: "POST", headers: { Authorization: "Bearer " + "0".repeat(32) } });
  check(wrong.status === 401, "resume with a wrong token: 401");
  // Through the page, with a wrong token typed in: the 401 shows in the status line.
  await page.$eval("#token", (e) => { e.value = ""; });
  await page.type("#token", "not-the-token");
  await page.click("#resume");
  await until("the 401 in the status line", () =>
    page.$eval("#status", (e) => e.textContent.includes("401")), 5000);
  await sleep(1500);
  const still = await state();
  check(still.paused && `${still.mission_s.toFixed(1)} s` === before.time,
        "after the refused resumes the tour is still paused at the same mission time");

  await page.$eval("#token", (e) => { e.value = ""; });
  await page.type("#token", token);
  await page.click("#resume");
  await until("the tour to resume", async () => !(await state()).paused, 10000);
  await until("mission time to move on", async () => (await shown()).time !== before.time, 10000);
  check(true, "resume: mission time moves on");

  // The graph follows the tour into the next state, tinting the visit's trail.
  const first = (await state()).active_state;
  s = await until("the active state to change", async () => {
    const v = await shown();
    return v.active.length === 1 && v.active[0] !== first && v;
  }, 60000);
  check(s.active[0] === s.state.active_state, `the graph moved on from ${first} to ${s.active[0]}`);
  const trail = s.state.trail.filter((p) => p !== s.state.active_state);
  check(trail.every((p) => s.trail.includes(p)), `the trail is tinted (${trail.join(", ")})`);

  // Skip, during the navigation to a target after the first, ends that visit.
  const firstTarget = s.state.target;
  s = await until("a navigation to a later target", async () => {
    const v = await state();
    return v.target && v.target !== firstTarget && v.active_state.endsWith("/navigate") && v;
  }, 90000);
  await page.click("#skip");
  await until("the skip's reply", () =>
    page.$eval("#status", (e) => /^skip: accepted/.test(e.textContent)), 10000);
  // The visit the skip ended is the one its control event names: the click may land after the
  // navigation seen, in a later state of the same visit or, rarely, in the next visit.
  const control = await until("the skip in the event log", async () => {
    const r = await api("/api/events?since=0");
    return r.body.events.find((e) => e.event === "control" && e.request === "skip");
  }, 10000);
  const skipped = control.target;
  const order = s.targets.map((t) => t.id);
  check([s.target, order[order.indexOf(s.target) + 1]].includes(skipped),
        `the skip, clicked during ${s.target}'s navigation, ended ${skipped}'s visit`);
  s = await until(`${skipped} to be skipped`, async () => {
    const v = await state();
    const t = v.targets.find((x) => x.id === skipped);
    return t.status === "skipped" && v;
  }, 30000);
  const target = s.targets.find((x) => x.id === skipped);
  check(target.reason === "skipped by operator", `${skipped}: reason "${target.reason}"`);
  await until(`${skipped}'s record in the table`, () => page.$eval(
    `#targets tr[data-target="${skipped}"]`, (tr) => tr.classList.contains("status-skipped") &&
      tr.textContent.includes("skipped by operator")), 10000);
  check(true, `the table marks ${skipped} skipped by operator`);
  const retryChoices = await page.$$eval("#retry-target option", (os) => os.map((o) => o.value));
  check(retryChoices.includes(skipped), `the retry choice offers ${skipped}`);

  // The event log and its filter.
  await page.type("#filter", skipped);
  const lines = await page.$$eval("#events li", (lis) =>
    lis.map((li) => ({ text: li.textContent, shown: !li.classList.contains("hidden") })));
  const visible = lines.filter((l) => l.shown);
  check(lines.length > 20 && visible.length > 0 && visible.length < lines.length &&
        visible.every((l) => l.text.toLowerCase().includes(skipped.toLowerCase())),
        `the filter "${skipped}" keeps ${visible.length} of ${lines.length} events, all naming it`);
  await page.$eval("#filter", (e) => { e.value = ""; e.dispatchEvent(new Event("input")); });

  await until("a frame on the page", () => page.$eval("#frame-depth",
    (img) => img.complete && img.naturalWidth > 0), 60000);
  check(true, "the depth frame is shown");
  const shot = await screenshot(page, "2-after-skip.png");
  if (process.env.PROJTOUR_MONITOR_SCREENSHOT) {
    const copy = path.resolve(source, process.env.PROJTOUR_MONITOR_SCREENSHOT);
    fs.copyFileSync(shot, copy);
    log(`copied to ${copy}`);
  }

  // The end: the run exits 3 (finished with a skip), the report agrees, and the page heard the
  // stream say so before the server went.
  const { code } = await until("the end of the run", () => exitStatus, 480000, 250);
  check(code === 3, `projtour exits 3 (was ${code})`);
  const report = JSON.parse(fs.readFileSync(path.join(runDir, "report.json"), "utf8"));
  const record = report.targets.find((t) => t.id === skipped);
  check(record && record.outcome === "skipped" && record.reason === "skipped by operator",
        `report.json: ${skipped} skipped by operator`);
  const last = await state();
  check(last.finished && last.outcome === report.outcome,
        `the page's last state is finished, ${last.outcome} (report: ${report.outcome})`);
  check(await page.$eval("#conn", (e) => e.textContent === "run over"), "the stream said end");
  const rows = await page.$$eval("#targets tbody tr", (trs) => trs.length);
  check(rows === report.targets.length, `the table has a row per target (${rows})`);
  await screenshot(page, "3-finished.png");
}

async function browserKilled(first, api, base, token) {
  const seen = new Set();
  await until("two states on the page", async () => {
    seen.add((await first.state()).active_state);
    return seen.size >= 2;
  }, 60000);
  const before = await first.state();
  await screenshot(first.page, "before-kill.png");
  browser.process().kill("SIGKILL");
  browser = null;
  log(`browser killed at mission time ${before.mission_s} s`);
  const later = await until("mission time to move on without the browser", async () => {
    const r = await api("/api/state");
    return r.status === 200 && r.body.mission_s > before.mission_s + 5 && r.body;
  }, 60000, 500);
  check(true, `the tour goes on (${later.mission_s} s)`);

  // A page opened later catches up: the whole log so far, in the order of events.jsonl.
  checkRequests(first, base, token);
  const second = await openPage(base, token);
  const known = (await api("/api/state")).body.events;
  const lines = await until(`the log's first ${known} events on the new page`, async () => {
    const texts = await second.page.$$eval("#events li:not(.note)", (lis) => lis.map((li) => li.textContent));
    return texts.length >= known && texts;
  }, 20000);
  const written = fs.readFileSync(path.join(runDir, "events.jsonl"), "utf8").trim().split("\n")
    .slice(0, known).map((l) => JSON.parse(l));
  const agree = written.every((e, i) => lines[i].includes(`${e.event} ${e.state}`) &&
                                        (!e.target || lines[i].includes(`[${e.target}]`)));
  check(written.length === known && agree, `the new page's log has events.jsonl's first ${known} events, in order`);
  checkRequests(second, base, token);
  await browser.close();
  browser = null;

  const { code, signal } = await exited;
  check(code === 0 || code === 3, `projtour exits 0 or 3 (was ${code}, signal ${signal})`);
  const report = JSON.parse(fs.readFileSync(path.join(runDir, "report.json"), "utf8"));
  check(report.outcome === "completed", `report.json: outcome ${report.outcome}`);
  check(report.targets.length === before.targets.length,
        `report.json: a record per target (${report.targets.length})`);
}

try {
  if (scenario !== "controls" && scenario !== "browser-killed") throw new Error(`no scenario ${scenario}`);
  await main();
} catch (err) {
  check(false, err.stack || String(err));
} finally {
  if (browser) await browser.close().catch(() => {});
  if (!exitStatus) child.kill("SIGINT");
  await exited;
  stderrLog.end();
}
log(`${failures ? "FAILED" : "passed"} (${scenario}); projtour's output in ${outDir}`);
process.exit(failures ? 1 : 0);
