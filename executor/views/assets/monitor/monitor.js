"use strict";
const $ = (id) => document.getElementById(id);
const SVG = "http://www.w3.org/2000/svg";
const STATUS_COLOUR = { pending: "#9aa3ad", visiting: "#1f6feb", projected: "#2da44e",
                        skipped: "#e8890c", failed: "#cf222e" };
const monitor = window.projtourMonitor = { lastState: null, poseDrawn: null };
let token = "";
let ended = false;

// --- the token: from the fragment, which stays in the browser, or typed in ----------------
const fragmentToken = /(?:^#|&)token=([^&]*)/.exec(location.hash);
if (fragmentToken) token = decodeURIComponent(fragmentToken[1]);
$("token").value = token;
$("token").addEventListener("input", () => { token = $("token").value.trim(); });

function el(tag, attrs, text) {
  const node = tag.startsWith("svg:") ? document.createElementNS(SVG, tag.slice(4))
                                      : document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
  if (text !== undefined) node.textContent = text;
  return node;
}
function fmt(v, digits) { return typeof v === "number" ? v.toFixed(digits) : "-"; }

// --- the state machine ------------------------------------------------------------------
// An arc diagram: each composite lays its children out in one row, nested boxes all the way
// down; a transition between siblings is an arc above the row when it goes forward (to the
// right) and below it when it goes back, higher the farther it reaches. Transitions to actions
// (skip_target, finish, ...) are in each state's tooltip.
const LEAF_W = 82, LEAF_H = 28, GAP = 10, PAD = 8, HEAD = 18;
const graph = { states: new Map(), boxes: new Map(), nodes: new Map() };
const arcHeight = (reach) => Math.min(44, 10 + 12 * Math.log2(1 + reach));

// The transitions between children of `s`, as [from index, to index] pairs, each once.
function siblingArcs(s) {
  const arcs = new Map();
  s.children.forEach((child, i) => {
    for (const t of graph.states.get(child)?.transitions || []) {
      const j = s.children.indexOf(resolve(s.path, t.to));
      if (j >= 0 && j !== i) arcs.set(i + ">" + j, [i, j]);
    }
  });
  return [...arcs.values()];
}

function measure(path) {
  const s = graph.states.get(path);
  if (!s || s.kind !== "composite" || !s.children.length) return { w: LEAF_W, h: LEAF_H };
  const sizes = s.children.map(measure);
  const inner = Math.max(...sizes.map((b) => b.h));
  let up = 0, down = 0;
  for (const [i, j] of siblingArcs(s)) {
    if (j > i) up = Math.max(up, arcHeight(j - i));
    else down = Math.max(down, arcHeight(i - j));
  }
  const w = sizes.reduce((a, b) => a + b.w, 0) + GAP * (sizes.length - 1) + 2 * PAD;
  return { w, h: HEAD + up + inner + down + PAD, sizes, inner, up };
}

function place(path, x, y) {
  const size = measure(path);
  graph.boxes.set(path, { x, y, w: size.w, h: size.h });
  if (!size.sizes) return;
  const s = graph.states.get(path);
  let cx = x + PAD;
  size.sizes.forEach((b, i) => {
    place(s.children[i], cx, y + HEAD + size.up + (size.inner - b.h) / 2);
    cx += b.w + GAP;
  });
}

// A transition's `to` and a composite's `initial` name a state by its path or, as a mission
// file does, by its name among the siblings (the children of `parent`).
function resolve(parent, name) {
  if (graph.states.has(name)) return name;
  const sibling = parent ? parent + "/" + name : name;
  return graph.states.has(sibling) ? sibling : null;
}
const parentOf = (path) => path.split("/").slice(0, -1).join("/");

function drawGraph(machine) {
  const svg = $("graph");
  svg.textContent = "";
  for (const s of machine.states) graph.states.set(s.path, s);
  place(machine.root, 1, 1);
  const root = graph.boxes.get(machine.root);
  svg.setAttribute("viewBox", `0 0 ${root.w + 2} ${root.h + 2}`);
  const defs = el("svg:defs");
  const marker = el("svg:marker", { id: "arrow", viewBox: "0 0 10 10", refX: 9, refY: 5,
                                    markerWidth: 6, markerHeight: 6, orient: "auto" });
  marker.appendChild(el("svg:path", { d: "M0,0 L10,5 L0,10 z", fill: "#8c959f" }));
  defs.appendChild(marker);
  svg.appendChild(defs);
  const boxes = el("svg:g"), edges = el("svg:g");
  svg.append(boxes, edges);
  for (const s of machine.states) {
    const b = graph.boxes.get(s.path);
    const g = el("svg:g", { "data-path": s.path, class: `state ${s.kind}` });
    const parent = graph.states.get(parentOf(s.path));
    if (parent && resolve(parent.path, parent.initial) === s.path) g.classList.add("initial");
    g.appendChild(el("svg:rect", { x: b.x, y: b.y, width: b.w, height: b.h, rx: 6 }));
    const label = s.name + (s.for_each ? " (for each target)" : "");
    if (s.kind === "composite") {
      g.appendChild(el("svg:text", { x: b.x + 8, y: b.y + 13 }, label));
    } else {
      g.appendChild(el("svg:text", { x: b.x + b.w / 2, y: b.y + b.h / 2 + 4,
                                     "text-anchor": "middle" }, label));
    }
    const tips = [s.path + (s.behaviour ? ` (${s.behaviour})` : "")];
    for (const t of s.transitions || []) tips.push(`${t.outcome} -> ${t.to}`);
    g.appendChild(el("svg:title", {}, tips.join("\n")));
    // Children come later in the list, so they are drawn over their composite's box.
    boxes.appendChild(g);
    graph.nodes.set(s.path, g);
  }
  for (const s of machine.states) {
    if (s.kind !== "composite") continue;
    for (const [i, j] of siblingArcs(s)) {
      const a = graph.boxes.get(s.children[i]), b = graph.boxes.get(s.children[j]);
      const forward = j > i, h = arcHeight(Math.abs(j - i)) / 0.75;  // a cubic peaks at 3/4
      const sx = a.x + a.w * (forward ? 0.62 : 0.38), ex = b.x + b.w * (forward ? 0.38 : 0.62);
      const sy = forward ? a.y : a.y + a.h, ey = forward ? b.y : b.y + b.h;
      const cy = forward ? Math.min(sy, ey) - h : Math.max(sy, ey) + h;
      edges.appendChild(el("svg:path", { class: "edge", d: `M${sx},${sy} C${sx},${cy} ${ex},${cy} ${ex},${ey}`,
                                         "marker-end": "url(#arrow)" }));
    }
  }
}

function highlight(state) {
  const trail = new Set(state.trail || []);
  for (const [path, g] of graph.nodes) {
    g.classList.toggle("active", path === state.active_state);
    g.classList.toggle("trail", trail.has(path) && path !== state.active_state);
  }
}

// --- the map ----------------------------------------------------------------------------
const map = { info: null, image: null, view: null };

// Map metres to the map image's pixels: its top row is the largest y.
function toImage(x, y) {
  const i = map.info;
  return [(x - i.x_min_m) / i.resolution_m, i.height_px - (y - i.y_min_m) / i.resolution_m];
}

// The part of the map worth seeing: the targets, the robot and its plan, with a margin. It only
// grows, so the picture does not jump as the robot moves.
function updateView(state) {
  const pts = (state.targets || []).map((t) => [t.x, t.y]).concat(state.plan || []);
  for (const p of [state.estimate, state.truth]) if (p) pts.push([p.x, p.y]);
  if (!pts.length) return;
  const m = 4;
  let v = { x0: Math.min(...pts.map((p) => p[0])) - m, x1: Math.max(...pts.map((p) => p[0])) + m,
            y0: Math.min(...pts.map((p) => p[1])) - m, y1: Math.max(...pts.map((p) => p[1])) + m };
  if (map.view) {
    v = { x0: Math.min(v.x0, map.view.x0), x1: Math.max(v.x1, map.view.x1),
          y0: Math.min(v.y0, map.view.y0), y1: Math.max(v.y1, map.view.y1) };
  }
  map.view = v;
}

function drawMap(state) {
  const canvas = $("map"), ctx = canvas.getContext("2d");
  ctx.fillStyle = "#e6e8eb";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!map.info || !state) return;
  updateView(state);
  if (!map.view) return;
  // Fit the view into the canvas, widening its shorter side so metres stay square.
  const v = map.view, cw = canvas.width, ch = canvas.height;
  const scale = Math.min(cw / (v.x1 - v.x0), ch / (v.y1 - v.y0));
  // Centred on the view, but shifted to show map rather than the void beyond its edge.
  const within = (c, half, lo, hi) => (hi - lo < 2 * half ? c : Math.min(Math.max(c, lo + half), hi - half));
  const mapW = map.info.width_px * map.info.resolution_m, mapH = map.info.height_px * map.info.resolution_m;
  const cx = within((v.x0 + v.x1) / 2, cw / 2 / scale, map.info.x_min_m, map.info.x_min_m + mapW);
  const cy = within((v.y0 + v.y1) / 2, ch / 2 / scale, map.info.y_min_m, map.info.y_min_m + mapH);
  const P = (x, y) => [cw / 2 + (x - cx) * scale, ch / 2 - (y - cy) * scale];
  if (map.image) {
    const [ix0, iy0] = toImage(cx - cw / 2 / scale, cy + ch / 2 / scale);
    const pxPerM = 1 / map.info.resolution_m;
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(map.image, ix0, iy0, (cw / scale) * pxPerM, (ch / scale) * pxPerM, 0, 0, cw, ch);
  }
  const plan = state.plan || [];
  if (plan.length > 1) {
    ctx.strokeStyle = "#8250df"; ctx.lineWidth = 2; ctx.setLineDash([6, 4]);
    ctx.beginPath();
    plan.forEach(([x, y], i) => { const [px, py] = P(x, y); i ? ctx.lineTo(px, py) : ctx.moveTo(px, py); });
    ctx.stroke(); ctx.setLineDash([]);
  }
  ctx.font = "12px system-ui, sans-serif";
  for (const t of state.targets || []) {
    const [px, py] = P(t.x, t.y);
    ctx.fillStyle = STATUS_COLOUR[t.status] || "#9aa3ad";
    ctx.beginPath(); ctx.arc(px, py, 6, 0, 2 * Math.PI); ctx.fill();
    ctx.strokeStyle = ctx.fillStyle; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(px, py);
    ctx.lineTo(px + 12 * Math.cos(t.theta), py - 12 * Math.sin(t.theta)); ctx.stroke();
    ctx.fillStyle = "#1d232b"; ctx.fillText(t.id, px + 9, py - 8);
  }
  ctx.fillStyle = "#bf3989";
  for (const [x, y] of state.people || []) {
    const [px, py] = P(x, y);
    ctx.beginPath(); ctx.arc(px, py, 4.5, 0, 2 * Math.PI); ctx.fill();
  }
  const robot = (pose, fill) => {
    const [px, py] = P(pose.x, pose.y), r = Math.max(7, 0.35 * scale);
    ctx.save(); ctx.translate(px, py); ctx.rotate(-pose.theta);
    ctx.beginPath(); ctx.moveTo(r * 1.4, 0); ctx.lineTo(-r, r * 0.8); ctx.lineTo(-r, -r * 0.8);
    ctx.closePath();
    if (fill) { ctx.fillStyle = "#1d232b"; ctx.fill(); }
    else { ctx.strokeStyle = "#8250df"; ctx.lineWidth = 2; ctx.stroke(); }
    ctx.restore();
    return [px, py];
  };
  if (state.truth) robot(state.truth, false);
  if (state.estimate) {
    const [px, py] = robot(state.estimate, true);
    monitor.poseDrawn = { x: state.estimate.x, y: state.estimate.y, px, py };
  }
}

// --- frames: reloaded when their sequence moves, at most twice a second each ----------------
const frameImages = {};
for (const kind of ["depth", "colour", "projector"]) {
  const img = $("frame-" + kind);
  frameImages[kind] = { img, wanted: null, shown: null, loading: false, at: 0 };
  img.addEventListener("load", () => { frameImages[kind].loading = false; });
  img.addEventListener("error", () => { frameImages[kind].loading = false; });
}
function refreshFrames() {
  const now = Date.now();
  for (const [kind, f] of Object.entries(frameImages)) {
    if (f.wanted === null || f.wanted === f.shown || f.loading || now - f.at < 500) continue;
    f.shown = f.wanted; f.loading = true; f.at = now;
    f.img.src = `/api/frame/${kind}.png?seq=${encodeURIComponent(f.wanted)}`;
  }
}
setInterval(refreshFrames, 500);

// --- the targets table and the retry choice ---------------------------------------------
function drawTargets(state) {
  const records = new Map((state.records || []).map((r) => [r.id, r]));
  const body = $("targets").tBodies[0];
  body.textContent = "";
  for (const t of state.targets || []) {
    const r = records.get(t.id) || {};
    const tr = el("tr", { "data-target": t.id, class: "status-" + t.status });
    const name = el("td");
    name.append(el("span", { class: "dot", style: `background:${STATUS_COLOUR[t.status] || "#9aa3ad"}` }), t.id);
    const after = r.projection_error_mm ? r.projection_error_mm.after_align : undefined;
    tr.append(name, el("td", {}, t.status), el("td", {}, t.reason || r.reason || ""),
              el("td", { class: "num" }, r.retries ?? "-"),
              el("td", { class: "num" }, fmt(r.projected_s, 1)),
              el("td", { class: "num" }, fmt(r.observed_error_mm ?? after, 2)));
    body.appendChild(tr);
  }
  const choices = (state.targets || []).filter((t) => t.status === "skipped" || t.status === "failed");
  const select = $("retry-target");
  const ids = choices.map((t) => t.id).join("\n");
  if (select.dataset.ids !== ids) {  // rebuilt only on change, so a choice being made stays
    const kept = select.value;
    select.textContent = "";
    if (!choices.length) select.appendChild(el("option", { value: "" }, "(nothing to retry)"));
    for (const t of choices) select.appendChild(el("option", { value: t.id }, `${t.id} (${t.status})`));
    if (choices.some((t) => t.id === kept)) select.value = kept;
    select.dataset.ids = ids;
  }
}

// --- the event log ----------------------------------------------------------------------
let eventsNext = 0;
let eventsQueue = Promise.resolve();

function eventLine(e) {
  const parts = [e.event, e.state || ""];
  if (e.target) parts.push("[" + e.target + "]");
  if (e.outcome) parts.push(e.outcome);
  if (e.to) parts.push("-> " + e.to);
  if (e.request) parts.push(e.request);
  if (e.message) parts.push("\u2014 " + e.message);
  return parts.join(" ");
}
function matches(li) {
  const f = $("filter").value.trim().toLowerCase();
  return !f || li.textContent.toLowerCase().includes(f);
}
function addNote(text) {
  $("events").appendChild(el("li", { class: "note" }, text));
}
function addEvents(list) {
  const box = $("events");
  const atBottom = box.scrollTop + box.clientHeight >= box.scrollHeight - 4;
  for (const e of list) {
    const li = el("li");
    li.append(el("span", { class: "t" }, fmt(e.t, 2).padStart(8) + "  "), eventLine(e));
    if (!matches(li)) li.classList.add("hidden");
    box.appendChild(li);
  }
  if (atBottom) box.scrollTop = box.scrollHeight;
}
// A batch from the stream: the events from index next - events.length to next (`first` is the
// oldest the server still keeps). Events missed before it (the page opened late, or the stream
// reconnected) are fetched first, so the log keeps its order; those the server no longer keeps
// are lost, and the log says so.
async function takeEvents(batch) {
  let start = batch.next - batch.events.length;
  while (start > eventsNext) {
    const res = await fetch(`/api/events?since=${eventsNext}`);
    if (!res.ok) break;
    const older = await res.json();
    const olderStart = older.next - older.events.length;
    if (olderStart > eventsNext) addNote(`(${olderStart - eventsNext} events no longer kept)`);
    if (!older.events.length) break;
    addEvents(older.events.slice(0, Math.max(0, start - olderStart)));
    eventsNext = Math.min(older.next, start);
  }
  addEvents(batch.events.slice(Math.max(0, eventsNext - start)));
  eventsNext = Math.max(eventsNext, batch.next);
}
function queueEvents(batch) {
  eventsQueue = eventsQueue.then(() => takeEvents(batch)).catch(() => {});
}
$("filter").addEventListener("input", () => {
  for (const li of $("events").children) li.classList.toggle("hidden", !matches(li));
  $("events").scrollTop = $("events").scrollHeight;
});

// --- the whole state --------------------------------------------------------------------
function onState(state) {
  monitor.lastState = state;
  $("mission").textContent = state.mission + (state.dry_run ? " (dry run)" : "");
  $("mission-time").textContent = fmt(state.mission_s, 1) + " s";
  $("active-state").textContent = state.active_state || "-";
  $("current-target").textContent = state.target || "-";
  const badge = $("run-badge");
  badge.textContent = state.finished ? "finished: " + state.outcome : state.paused ? "paused" : "running";
  badge.className = "badge" + (state.finished ? " finished" : state.paused ? " paused" : "");
  highlight(state);
  drawMap(state);
  drawTargets(state);
  for (const [kind, seq] of Object.entries(state.frames || {})) {
    if (frameImages[kind] && seq !== null && seq !== undefined) frameImages[kind].wanted = seq;
  }
  refreshFrames();
  $("pause").disabled = state.finished || state.paused;
  $("resume").disabled = state.finished || !state.paused;
  for (const id of ["skip", "cancel", "retry"]) $(id).disabled = state.finished;
}

// --- controls ---------------------------------------------------------------------------
function say(text, error) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}
async function control(request) {
  let url = "/api/control/" + request;
  if (request === "retry") {
    const target = $("retry-target").value;
    if (!target) return say("retry: no skipped or failed target to retry", true);
    url += "?target=" + encodeURIComponent(target);
  }
  const headers = token ? { Authorization: "Bearer " + token } : {};
  try {
    const res = await fetch(url, { method: "POST", headers });
    const body = await res.json().catch(() => ({}));
    if (res.status === 200) {
      say(`${request}: ${body.accepted ? "accepted" : "refused"}${body.message ? " \u2014 " + body.message : ""}`,
          !body.accepted);
    } else {
      say(`${request}: HTTP ${res.status}${body.error ? " \u2014 " + body.error : ""}` +
          (res.status === 401 ? " (check the token)" : ""), true);
    }
  } catch (err) {
    say(`${request}: no reply (${err.message})`, true);
  }
}
for (const id of ["pause", "resume", "cancel", "skip", "retry"]) {
  $(id).addEventListener("click", () => {
    if (id === "cancel" && !confirm("Cancel the tour?")) return;
    control(id);
  });
}

// --- the stream ---------------------------------------------------------------------------
function setConn(text, down) {
  $("conn").textContent = text;
  $("conn").className = "badge" + (down ? " down" : "");
}
function connect() {
  const stream = new EventSource("/api/stream");
  stream.addEventListener("open", () => setConn("live"));
  stream.addEventListener("state", (e) => onState(JSON.parse(e.data)));
  stream.addEventListener("events", (e) => queueEvents(JSON.parse(e.data)));
  stream.addEventListener("end", () => {
    ended = true;
    stream.close();
    setConn("run over");
  });
  // Reconnected by hand, after 2 s, so that a server gone for good is not hammered.
  stream.onerror = () => {
    stream.close();
    if (ended) return;
    setConn("reconnecting", true);
    setTimeout(connect, 2000);
  };
}

async function start() {
  try {
    const [machine, info] = await Promise.all([
      fetch("/api/machine").then((r) => r.json()), fetch("/api/map").then((r) => r.json())]);
    drawGraph(machine);
    map.info = info;
    const image = new Image();
    image.onload = () => { map.image = image; drawMap(monitor.lastState); };
    image.src = "/api/map.png";
  } catch (err) {
    say("could not load the machine or the map: " + err.message, true);
  }
  connect();
}
start();
