// One job: its facts, live plots of the samples as they arrive, the advisor's reasons, the
// derived results, the error of a failed job, the scene, and the particle view.

import { api } from "./api.js";
import { particleView } from "./particles.js";
import { el, flatten, num, seconds, show, stateBadge, status, when } from "./ui.js";

/** Samples fetched at first (the server downsamples), and kept at most while live. */
const FIRST_POINTS = 2000;
const MAX_POINTS = 4000;

/** The plots: a title, its y unit, and the series (sample paths with their labels). */
const PLOTS = [
  { id: "phi", title: "Packing fraction Φ", y: "Φ (—)", series: [["phi", "Φ"]] },
  { id: "z", title: "Coordination Z", y: "Z (—)", series: [["z", "Z"], ["z_no_rattlers", "Z without rattlers"]] },
  { id: "zeta", title: "Stress ratio ζ = q/p; friction μ = τ/σ_n under shear", y: "ζ, μ (—)", series: [["zeta", "ζ"], ["mu", "μ"]] },
  { id: "stress", title: "Mean and deviatoric stress", y: "p, q (Pa)", series: [["p", "p"], ["q", "q"]] },
  { id: "energy", title: "Energies", y: "E (J; J/m in 2D)", series: [["kinetic_energy", "kinetic"], ["elastic_energy", "elastic"], ["deformable.dissipated_energy", "dissipated"]] },
];
const COLOURS = ["#2557c7", "#d1495b", "#1d7a3a", "#9a6700"];
const TERMINAL = new Set(["succeeded", "failed", "cancelled"]);

function get(sample, path) {
  let v = sample;
  for (const k of path.split(".")) { if (v == null) return null; v = v[k]; }
  return typeof v === "number" ? v : null;
}

export async function jobPage(id, onLeave) {
  let job = null;
  const head = el("section", { "aria-label": "Job" });
  const xSelect = el("select", { id: "x-axis", "aria-label": "Plot against" });
  const plotsBox = el("div", { class: "plots", id: "plots" });
  const info = el("p", { class: "muted", id: "plot-info" });
  const extra = el("section", { "aria-label": "Advice, results and scene" });
  const particles = el("section", { id: "particles-section", "aria-label": "Particles" });
  show(head,
    el("h2", {}, "Measures"),
    el("div", { class: "toolbar" }, el("label", {}, "Against ", xSelect), info),
    plotsBox, particles, extra);

  let samples = [];
  let source = null;
  let plots = [];
  let pending = false;
  // Set when another page replaces this one: what is still loading then stops.
  let left = false;
  onLeave(() => { left = true; if (source) source.close(); for (const p of plots) p.plot.destroy(); });

  // -- header --
  function drawHead() {
    const running = !TERMINAL.has(job.state);
    head.replaceChildren(...[
      el("h1", {}, `Job ${job.id}: ${job.name}`),
      el("div", { class: "toolbar" },
        stateBadge(job.state),
        el("progress", { max: 1, value: job.progress, "aria-label": "progress" }), ` ${Math.round(job.progress * 100)}%`,
        running ? el("button", { class: "danger", id: "cancel", onclick: cancel }, "Cancel") : null),
      el("dl", { class: "facts" },
        el("dt", {}, "method"), el("dd", {}, `${job.method} — ${job.method_reason}`),
        el("dt", {}, "steps"), el("dd", {}, job.steps.toLocaleString()),
        el("dt", {}, "samples"), el("dd", {}, job.sample_count.toLocaleString()),
        el("dt", {}, "time"), el("dd", {}, `${seconds(job.wall_seconds)} wall, ${seconds(job.cpu_seconds)} CPU`),
        el("dt", {}, "created"), el("dd", {}, when(job.created_at)),
        el("dt", {}, "finished"), el("dd", {}, when(job.finished_at))),
      job.error ? el("div", { class: "error-box", id: "job-error", role: "alert" }, el("strong", {}, job.error.code), ": ", job.error.message) : null,
    ].filter(Boolean));
  }
  async function cancel() {
    try { job = await api.cancel(id); drawHead(); } catch (e) { status(e.message); }
  }

  // -- plots --
  function xOptions() {
    const keys = new Set(["time", "step"]);
    for (const s of samples) if (s.strain) for (const [k, v] of flatten(s.strain, "strain.")) if (typeof v === "number") keys.add(k);
    const old = xSelect.value || "time";
    xSelect.replaceChildren(...[...keys].map((k) => el("option", { value: k }, k === "time" ? "time (s)" : k === "step" ? "step" : `${k} (—), last stage`)));
    xSelect.value = keys.has(old) ? old : "time";
  }
  function columns() {
    const x = xSelect.value || "time";
    let rows = samples;
    if (x.startsWith("strain.")) {
      const last = samples.length ? samples[samples.length - 1].stage : null;
      rows = samples.filter((s) => s.stage === last && get(s, x) !== null);
    }
    let order = rows.map((_, i) => i);
    const xs = rows.map((s) => get(s, x));
    if (xs.some((v, i) => i > 0 && v < xs[i - 1])) order.sort((a, b) => xs[a] - xs[b]);
    return { x, rows: order.map((i) => rows[i]), xs: order.map((i) => xs[i]) };
  }
  function build() {
    for (const p of plots) p.plot.destroy();
    plotsBox.replaceChildren();
    const { x, rows, xs } = columns();
    const width = Math.max(360, Math.min(640, plotsBox.clientWidth / (plotsBox.clientWidth > 900 ? 2 : 1) - 20));
    plots = PLOTS.filter((d) => d.series.some(([path]) => samples.some((s) => get(s, path) !== null))).map((d) => {
      const box = el("div", { class: "plot", id: `plot-${d.id}`, role: "img", "aria-label": d.title });
      plotsBox.append(box);
      const series = d.series.filter(([path]) => samples.some((s) => get(s, path) !== null));
      const opts = {
        title: d.title, width, height: 240,
        scales: { x: { time: false } },
        axes: [
          { label: x === "time" ? "time (s)" : x === "step" ? "step" : `${x} (—)`, stroke: "currentColor", grid: { stroke: "rgba(128,128,128,.2)" } },
          { label: d.y, stroke: "currentColor", size: 70, grid: { stroke: "rgba(128,128,128,.2)" }, values: (_, ticks) => ticks.map(num) },
        ],
        series: [{ label: x }, ...series.map(([, label], k) => ({ label, stroke: COLOURS[k], width: 1.5, points: { show: false } }))],
      };
      const data = [xs, ...series.map(([path]) => rows.map((s) => get(s, path)))];
      const plot = new uPlot(opts, data, box);
      return { plot, series, box };
    });
    info.textContent = `${samples.length.toLocaleString()} points shown${job.sample_count > samples.length ? ` of ${job.sample_count.toLocaleString()} (downsampled by the server)` : ""}`;
    plotsBox.dataset.points = String(samples.length);
  }
  function redraw() {
    pending = false;
    const { rows, xs } = columns();
    for (const p of plots) p.plot.setData([xs, ...p.series.map(([path]) => rows.map((s) => get(s, path)))]);
    info.textContent = `${samples.length.toLocaleString()} points shown${job.sample_count > samples.length ? ` of ${job.sample_count.toLocaleString()}` : ""}`;
    plotsBox.dataset.points = String(samples.length);
  }
  xSelect.addEventListener("change", build);

  // -- live samples --
  function listen(after) {
    if (left || TERMINAL.has(job.state)) return;
    source = api.events(id, after);
    source.addEventListener("sample", (e) => {
      const data = JSON.parse(e.data);
      samples.push(data.sample);
      if (samples.length > MAX_POINTS) samples = samples.filter((_, i) => i % 2 === 0 || i === samples.length - 1);
      job.progress = data.fraction ?? job.progress;
      job.sample_count += 1;
      const hadStrain = xSelect.options.length;
      if (samples.length === 1 || (data.sample.strain && hadStrain <= 2)) { xOptions(); build(); return; }
      if (!pending) { pending = true; setTimeout(redraw, 250); }
      const bar = head.querySelector("progress");
      if (bar) bar.value = job.progress;
    });
    source.addEventListener("state", async (e) => {
      const data = JSON.parse(e.data);
      // The stream ends after the final state: closed first, the browser does not reconnect.
      if (TERMINAL.has(data.state)) source.close();
      job = await api.job(id);
      drawHead();
      if (TERMINAL.has(data.state)) await finished();
    });
    // The browser reconnects by itself, sending the last event's id, which the service resumes
    // after.
    source.onerror = () => status("event stream interrupted; reconnecting");
    source.onopen = () => status("");
  }

  async function finished() {
    drawExtra();
    await particleView(particles, job);
  }

  // -- advice, results, scene --
  async function drawExtra() {
    const parts = [];
    if (job.result) {
      parts.push(el("h2", {}, "Derived results"), el("table", { id: "results" }, el("tbody", {},
        flatten(job.result).map(([k, v]) => el("tr", {}, el("th", { scope: "row" }, k), el("td", { class: "num" }, typeof v === "number" ? num(v) : JSON.stringify(v)))))));
    }
    const advice = el("div", { id: "advice" }, el("span", { class: "muted" }, "asking the advisor…"));
    parts.push(el("h2", {}, "The advisor"), advice);
    parts.push(el("h2", {}, "Scene"), el("details", {}, el("summary", {}, "The scene as stored (JSON)"), el("pre", {}, JSON.stringify(job.scene, null, 2))));
    extra.replaceChildren(...parts);
    try {
      const a = await api.advice(job.scene);
      advice.replaceChildren(...[
        el("p", {}, "Method: ", el("strong", {}, a.method), ` (the scene asks for ${a.requested}); regime: ${a.regime}`),
        el("ul", {}, a.reasons.map((r) => el("li", {}, r))),
        a.suggestions?.length ? el("p", {}, "Suggestions:") : null,
        a.suggestions?.length ? el("ul", {}, a.suggestions.map((s) => el("li", {}, s))) : null,
      ].filter(Boolean));
    } catch (e) {
      advice.replaceChildren(el("span", { class: "muted" }, `the advisor cannot answer for this scene: ${e.message}`));
    }
  }

  const first = await api.samples(id, FIRST_POINTS);
  // Read after the samples, the job is at least as new as their last event: a state change
  // before it is in the job, one after it comes through the stream.
  job = await api.job(id);
  if (left) return;
  drawHead();
  samples = first.samples;
  xOptions();
  build();
  drawExtra();
  if (TERMINAL.has(job.state)) await particleView(particles, job);
  else { particles.replaceChildren(el("h2", {}, "Particles"), el("p", { class: "muted" }, "Shown when the job ends (its last snapshot or final state).")); listen(first.events_seq); }
}
