// proxyshade edit: the page. Plain JS, no build step. Protocol: proxyshade/live/server.py.
"use strict";
const token = document.body.dataset.token;
const image = document.getElementById("image");
const overlay = document.getElementById("overlay");
const ctx = image.getContext("2d");
const octx = overlay.getContext("2d");
const $ = (id) => document.getElementById(id);
// what the page has seen, for people (the status line) and for tests (window.live)
const live = window.live = { pixels: 0, edits: 0, errors: [], lastBox: null, lastMs: null, state: null, saved: [] };
let ws, frame = 1, view = "frame", drag = null, flash = null;

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws?token=${encodeURIComponent(token)}`);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => status("connected");
  ws.onclose = () => { status("disconnected: is proxyshade edit still running? (reload the page to reconnect)"); };
  ws.onmessage = (ev) => (typeof ev.data === "string" ? onJson(JSON.parse(ev.data)) : onPixels(ev.data));
}

function send(msg) {
  if (ws.readyState !== WebSocket.OPEN) { showError("not connected"); return; }
  ws.send(JSON.stringify(msg));
}

function status(text) { $("status").textContent = text; }
function showError(text) { $("error").textContent = text; live.errors.push(text); }

function onJson(m) {
  if (m.type === "state") {
    live.state = m;
    frame = m.frame; view = m.view;
    $("scene").textContent = m.scene;
    const sel = $("label");
    if (!sel.options.length) {
      for (const l of m.labels) sel.add(new Option(l, l));
      if (m.labels.includes("tree")) sel.value = "tree";
    }
    const vs = $("views");
    vs.replaceChildren(...m.views.map((v) => {
      const b = document.createElement("button");
      b.textContent = v; b.dataset.view = v; b.className = v === view ? "on" : "";
      b.onclick = () => send({ type: "view", view: v });
      return b;
    }));
    const fr = $("frame");
    fr.min = m.frames[0]; fr.max = m.frames[1]; fr.value = frame; $("frame_v").textContent = frame;
    $("frames").hidden = m.frames[0] === m.frames[1];
    undoRedo(m);
  } else if (m.type === "edit") {
    live.edits += 1; live.lastMs = m.ms;
    $("error").textContent = "";
    status(`${m.what}: ${m.ms.toFixed(0)} ms`);
    undoRedo(m);
  } else if (m.type === "error") {
    showError(m.message); status("refused");
  } else if (m.type === "busy") {
    status(m.message);
  } else if (m.type === "saved") {
    live.saved = m.files;
    if (m.files.length) status(`${$("status").textContent.split(" — ")[0]} — wrote ${m.files.map((f) => f.split("/").pop()).join(", ")}`);
  }
}

function undoRedo(m) {
  $("undo").disabled = !m.undo; $("redo").disabled = !m.redo;
  $("undo").title = m.undo_what ? `undo ${m.undo_what} (Ctrl+Z)` : "nothing to undo";
  $("redo").title = m.redo_what ? `redo ${m.redo_what} (Ctrl+Shift+Z)` : "nothing to redo";
}

function onPixels(buf) {
  const n = new DataView(buf).getUint32(0, true);
  const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  if (head.frame !== frame || head.view !== view) return;  // another frame or view, sent before a switch
  if (image.width !== head.width || image.height !== head.height) {
    image.width = overlay.width = head.width; image.height = overlay.height = head.height;
  }
  const rgba = new Uint8ClampedArray(buf, 4 + n, head.w * head.h * 4);
  ctx.putImageData(new ImageData(rgba, head.w, head.h), head.x, head.y);
  live.pixels += 1;
  const whole = head.w === head.width && head.h === head.height;
  live.lastBox = [head.x, head.y, head.w, head.h];
  if (!whole) { flash = live.lastBox; drawOverlay(); setTimeout(() => { flash = null; drawOverlay(); }, 700); }
}

function drawOverlay() {
  octx.clearRect(0, 0, overlay.width, overlay.height);
  if (flash) { octx.strokeStyle = "#ff40ff"; octx.lineWidth = 2; octx.strokeRect(...flash); }
  if (drag) {
    octx.strokeStyle = tool() === "lower" ? "#4fc3f7" : "#ffd54f"; octx.lineWidth = 2;
    for (const [x, y] of drag.points) { octx.beginPath(); octx.arc(x, y, 6, 0, 2 * Math.PI); octx.stroke(); }
  }
}

const tool = () => document.querySelector("input[name=tool]:checked").value;

function pixel(ev) {
  const r = overlay.getBoundingClientRect();
  return [(ev.clientX - r.left) * overlay.width / r.width, (ev.clientY - r.top) * overlay.height / r.height];
}

overlay.addEventListener("pointerdown", (ev) => {
  if (ev.button !== 0) return;
  const p = pixel(ev), t = tool();
  if (t === "sphere") { send({ type: "sphere", frame, at: p, radius: +$("radius").value / 2, label: $("label").value }); return; }
  if (t === "remove") { send({ type: "remove", frame, at: p }); return; }
  overlay.setPointerCapture(ev.pointerId);
  drag = { points: [p] }; drawOverlay();
});
overlay.addEventListener("pointermove", (ev) => {
  if (!drag) return;
  const p = pixel(ev), q = drag.points[drag.points.length - 1];
  if (Math.hypot(p[0] - q[0], p[1] - q[1]) >= 4 && drag.points.length < 256) { drag.points.push(p); drawOverlay(); }
});
overlay.addEventListener("pointerup", () => {
  if (!drag) return;
  const strength = +$("strength").value * (tool() === "lower" ? -1 : 1);
  send({ type: "stroke", frame, points: drag.points, radius: +$("radius").value, strength });
  drag = null; drawOverlay();
});

for (const id of ["radius", "strength"]) $(id).oninput = () => { $(id + "_v").textContent = $(id).value; };
$("undo").onclick = () => send({ type: "undo" });
$("redo").onclick = () => send({ type: "redo" });
$("save").onclick = () => send({ type: "save" });
$("frame").oninput = () => { $("frame_v").textContent = $("frame").value; };
$("frame").onchange = () => { frame = +$("frame").value; send({ type: "frame", frame }); };
document.addEventListener("keydown", (ev) => {
  if ((ev.ctrlKey || ev.metaKey) && ev.key.toLowerCase() === "z") { ev.preventDefault(); send({ type: ev.shiftKey ? "redo" : "undo" }); }
  if ((ev.ctrlKey || ev.metaKey) && ev.key.toLowerCase() === "y") { ev.preventDefault(); send({ type: "redo" }); }
});
connect();
