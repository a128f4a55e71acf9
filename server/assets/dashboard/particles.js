// The particles of a job's latest snapshot (or, without snapshots, of its final state) drawn on a
// canvas: disks coloured by a chosen field, and the contact forces as lines whose width is the
// normal force (the force chains). Deformable grains (mpm) are drawn as their material points'
// quads. 3D scenes are seen from a side (or from above), nearest last, whole or as a slice two
// diameters thick through the middle.

import { api } from "./api.js";
import { el, num } from "./ui.js";

const UNITS = { radius: "m", speed: "m/s", coordination: "—", force: "N", material: "—", grain: "—", jacobian: "—", pressure: "Pa", mises: "Pa" };

// Viridis, sampled.
const VIRIDIS = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];
function colour(t) {
  if (!Number.isFinite(t)) return "#888";
  const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  const a = parseInt(VIRIDIS[i].slice(1), 16), b = parseInt(VIRIDIS[i + 1].slice(1), 16);
  const mix = (s) => Math.round(((a >> s) & 255) * (1 - f) + ((b >> s) & 255) * f);
  return `rgb(${mix(16)},${mix(8)},${mix(0)})`;
}

/** A VTK XML PolyData file (ASCII, as the service writes it) as arrays. */
export function parsePolyData(text) {
  const doc = new DOMParser().parseFromString(text, "application/xml");
  const piece = doc.querySelector("PolyData > Piece");
  if (!piece) throw new Error("not a VTK PolyData file");
  const values = (e) => {
    const t = (e.textContent || "").trim();
    return t ? Float64Array.from(t.split(/\s+/), Number) : new Float64Array();
  };
  const arrays = (sel) => {
    const out = {};
    for (const e of piece.querySelectorAll(sel)) out[e.getAttribute("Name")] = { values: values(e), components: Number(e.getAttribute("NumberOfComponents") || 1) };
    return out;
  };
  const pts = piece.querySelector("Points > DataArray");
  const cells = {};
  for (const kind of ["Verts", "Lines", "Polys"]) {
    const c = piece.querySelector(`${kind} > DataArray[Name=connectivity]`), o = piece.querySelector(`${kind} > DataArray[Name=offsets]`);
    if (!c || !o) continue;
    const conn = values(c), offs = values(o);
    const list = [];
    let start = 0;
    for (const end of offs) { list.push(conn.subarray(start, end)); start = end; }
    cells[kind.toLowerCase()] = list;
  }
  return { points: pts ? values(pts) : new Float64Array(), pointData: arrays("PointData > DataArray"), cellData: arrays("CellData > DataArray"), cells };
}

function magnitude(a, k) {
  let s = 0;
  for (let c = 0; c < a.components; c++) s += a.values[k * a.components + c] ** 2;
  return Math.sqrt(s);
}

/** The particles as one drawable: centres, radii, fields to colour by, and contacts or quads. */
async function load(job) {
  const snaps = (await api.snapshots(job.id)).snapshots;
  if (snaps.length) {
    const last = snaps[snaps.length - 1];
    const [p, c] = await Promise.all([api.snapshotFile(job.id, last.index, "particles"), api.snapshotFile(job.id, last.index, "contacts")]);
    const parts = parsePolyData(p), contacts = parsePolyData(c);
    const n = parts.points.length / 3;
    const d = { source: `snapshot ${last.index} at step ${last.step.toLocaleString()}, t = ${num(last.time)} s`, n, xyz: parts.points, fields: {}, contacts: null, polys: null, dim3: job.scene.dimension === 3 };
    if (parts.cells.polys && parts.cells.polys.length) {
      d.polys = parts.cells.polys;
      for (const [name, a] of Object.entries(parts.cellData)) d.fields[name] = Array.from({ length: d.polys.length }, (_, k) => magnitude(a, k));
      d.n = d.polys.length;
    } else {
      d.radius = parts.pointData.radius ? parts.pointData.radius.values : new Float64Array(n);
      if (parts.pointData.radius) d.fields.radius = Array.from(d.radius);
      if (parts.pointData.velocity) d.fields.speed = Array.from({ length: n }, (_, k) => magnitude(parts.pointData.velocity, k));
      if (parts.pointData.coordination) d.fields.coordination = Array.from(parts.pointData.coordination.values);
      if (parts.pointData.force) d.fields.force = Array.from({ length: n }, (_, k) => magnitude(parts.pointData.force, k));
    }
    if (contacts.cells.lines && contacts.cellData.normal_force) {
      d.contacts = { xyz: contacts.points, lines: contacts.cells.lines, force: contacts.cellData.normal_force.values };
    }
    return d;
  }
  if (job.state !== "succeeded") return null;
  const st = await api.state(job.id);
  const dim = st.dimension, p = st.particles, n = p.radius.length;
  const xyz = new Float64Array(3 * n);
  p.position.forEach((x, k) => { xyz[3 * k] = x[0]; xyz[3 * k + 1] = x[1]; xyz[3 * k + 2] = dim === 3 ? x[2] : 0; });
  return {
    source: `final state at step ${st.steps.toLocaleString()}, t = ${num(st.time)} s (no snapshots: no contact forces)`,
    n, xyz, radius: Float64Array.from(p.radius), contacts: null, polys: null, dim3: dim === 3,
    fields: { radius: p.radius, speed: p.velocity.map((v) => Math.hypot(...v)), material: p.material },
  };
}

/** The view of a 3D scene: the screen's axes (indices into x, y, z) and the depth axis. */
const VIEWS = { "x–z": [0, 2, 1], "y–z": [1, 2, 0], "x–y": [0, 1, 2] };

function draw(canvas, d, field, showContacts, view, slice) {
  const ctx = canvas.getContext("2d");
  const xyz = d.xyz;
  const [ax, ay, az] = d.dim3 ? VIEWS[view] : VIEWS["x–y"];
  let rmax = 0;
  if (d.radius) for (const r of d.radius) rmax = Math.max(rmax, r);
  // A slice keeps what lies within two largest diameters of the middle along the depth axis.
  let zlo = -Infinity, zhi = Infinity;
  if (d.dim3 && slice) {
    let a = Infinity, b = -Infinity;
    for (let k = az; k < xyz.length; k += 3) { a = Math.min(a, xyz[k]); b = Math.max(b, xyz[k]); }
    zlo = (a + b) / 2 - 2 * rmax; zhi = (a + b) / 2 + 2 * rmax;
  }
  const inside = (i) => xyz[3 * i + az] >= zlo && xyz[3 * i + az] <= zhi;
  let [x0, y0, x1, y1] = [Infinity, Infinity, -Infinity, -Infinity];
  for (let k = 0; k < xyz.length; k += 3) { x0 = Math.min(x0, xyz[k + ax]); x1 = Math.max(x1, xyz[k + ax]); y0 = Math.min(y0, xyz[k + ay]); y1 = Math.max(y1, xyz[k + ay]); }
  x0 -= rmax; y0 -= rmax; x1 += rmax; y1 += rmax;
  const w = canvas.width, h = canvas.height, pad = 8;
  const s = Math.min((w - 2 * pad) / (x1 - x0 || 1), (h - 2 * pad) / (y1 - y0 || 1));
  const X = (p, i) => pad + (p[3 * i + ax] - x0) * s, Y = (p, i) => h - pad - (p[3 * i + ay] - y0) * s;
  ctx.clearRect(0, 0, w, h);
  const values = d.fields[field] || [];
  let lo = Infinity, hi = -Infinity;
  for (const v of values) { if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); } }
  const t = (v) => (hi > lo ? (v - lo) / (hi - lo) : 0.5);
  if (d.polys) {
    d.polys.forEach((poly, k) => {
      ctx.beginPath();
      poly.forEach((i, j) => (j ? ctx.lineTo : ctx.moveTo).call(ctx, X(xyz, i), Y(xyz, i)));
      ctx.closePath();
      ctx.fillStyle = colour(t(values[k]));
      ctx.fill();
    });
  } else {
    // Far first: seen from above, the lowest; from a side (looking along +depth), the deepest.
    const toward = d.dim3 && view !== "x–y" ? -1 : 1;
    const order = Array.from({ length: d.n }, (_, k) => k).filter(inside).sort((a, b) => toward * (xyz[3 * a + az] - xyz[3 * b + az]));
    ctx.strokeStyle = "rgba(0,0,0,.35)";
    ctx.lineWidth = 0.5;
    for (const k of order) {
      ctx.beginPath();
      ctx.arc(X(xyz, k), Y(xyz, k), Math.max(d.radius[k] * s, 0.5), 0, 2 * Math.PI);
      ctx.fillStyle = colour(t(values[k]));
      ctx.fill();
      ctx.stroke();
    }
  }
  if (showContacts && d.contacts) {
    const f = d.contacts.force;
    let fmax = 0;
    for (const v of f) fmax = Math.max(fmax, Math.abs(v));
    ctx.strokeStyle = getComputedStyle(document.body).color;
    ctx.lineCap = "round";
    const cx = d.contacts.xyz;
    const near = (i) => cx[3 * i + az] >= zlo && cx[3 * i + az] <= zhi;
    d.contacts.lines.forEach((line, k) => {
      if (!fmax || !(Math.abs(f[k]) > 0)) return;
      const [a, b] = [line[0], line[line.length - 1]];
      if (!near(a) || !near(b)) return;
      ctx.lineWidth = 0.5 + 5 * Math.abs(f[k]) / fmax;
      ctx.beginPath();
      ctx.moveTo(X(cx, a), Y(cx, a));
      ctx.lineTo(X(cx, b), Y(cx, b));
      ctx.stroke();
    });
  }
  return { lo, hi, aspect: (y1 - y0) / (x1 - x0 || 1) };
}

/** Fills `box` with the particle view of `job` (a button loads it again: the latest snapshot). */
export async function particleView(box, job) {
  const canvas = el("canvas", { id: "particles", width: 720, height: 540, role: "img", "aria-label": "The particles, coloured by the chosen field" });
  const fieldSelect = el("select", { id: "colour-by", "aria-label": "Colour by" });
  const contacts = el("input", { type: "checkbox", id: "show-contacts", checked: true });
  const legend = el("div", { id: "particles-legend" });
  const caption = el("p", { class: "muted", id: "particles-source" });
  const reload = el("button", { id: "load-particles", onclick: () => refresh() }, "Load the latest");
  const view = el("select", { id: "view", "aria-label": "View of a 3D scene" }, Object.keys(VIEWS).map((v) => el("option", { value: v }, v === "x–y" ? "x–y (from above)" : `${v} (side)`)));
  const slice = el("input", { type: "checkbox", id: "slice", checked: true });
  const view3d = el("span", { class: "toolbar", hidden: true }, el("label", {}, "View ", view), el("label", {}, slice, " a slice through the middle"));
  box.replaceChildren(el("h2", {}, "Particles"),
    el("div", { class: "toolbar" }, el("label", {}, "Colour by ", fieldSelect), el("label", {}, contacts, " contact forces (line width ∝ normal force)"), view3d, reload),
    caption, el("div", { class: "particles" }, canvas, legend));
  let data = null;
  function paint() {
    if (!data) return;
    view3d.hidden = !data.dim3;
    const r = draw(canvas, data, fieldSelect.value, contacts.checked, view.value, slice.checked);
    const unit = UNITS[fieldSelect.value] || "—";
    legend.replaceChildren(el("div", {}, `${fieldSelect.value} (${unit})`),
      el("div", { class: "legend-bar", style: `background: linear-gradient(to right, ${VIRIDIS.join(",")})` }),
      el("div", { class: "toolbar" }, el("span", {}, num(r.lo)), el("span", { style: "margin-left:auto" }, num(r.hi))),
      el("p", { class: "muted" }, `${data.n.toLocaleString()} ${data.polys ? "material points" : "particles"}${data.contacts ? `, ${data.contacts.lines.length.toLocaleString()} contacts` : ""}`));
    canvas.dataset.drawn = String(data.n);
  }
  async function refresh() {
    caption.textContent = "loading…";
    try {
      data = await load(job);
    } catch (e) {
      caption.textContent = `cannot load the particles: ${e.message}`;
      return;
    }
    if (!data) { caption.textContent = "No snapshot yet, and no final state (the scene's snapshots section takes them)."; return; }
    caption.textContent = data.source;
    const names = Object.keys(data.fields);
    const old = fieldSelect.value;
    fieldSelect.replaceChildren(...names.map((n) => el("option", { value: n }, n)));
    fieldSelect.value = names.includes(old) ? old : names.includes("force") ? "force" : names[0];
    contacts.disabled = !data.contacts;
    paint();
  }
  for (const control of [fieldSelect, contacts, view, slice]) control.addEventListener("change", paint);
  await refresh();
}
