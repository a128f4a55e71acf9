// Studies: the list, and one study with its speed-against-accuracy chart and its runs.

import { api, withToken } from "./api.js";
import { el, num, show, stateBadge, when } from "./ui.js";

export async function studiesPage() {
  const studies = await api.studies();
  show(el("h1", {}, "Studies"),
    el("p", { class: "muted" }, "Runs of one scene swept over parameters, charted as error against CPU time, or stability searches (docs/studies.md). Submit them with ", el("code", {}, "sable study FILE"), " or POST /v1/studies."),
    el("table", { id: "studies" },
      el("thead", {}, el("tr", {}, ["id", "name", "kind", "state", "runs", "created"].map((h) => el("th", { scope: "col" }, h)))),
      el("tbody", {}, studies.length ? studies.map((s) => el("tr", {},
        el("td", { class: "num" }, s.id), el("td", {}, el("a", { href: `#/studies/${s.id}` }, s.name)), el("td", {}, s.kind),
        el("td", {}, stateBadge(s.state)), el("td", { class: "num" }, `${s.runs_done}/${s.runs}`), el("td", {}, when(s.created_at))))
        : el("tr", {}, el("td", { colspan: 6, class: "muted" }, "No studies.")))));
}

export async function studyPage(id) {
  const s = await api.study(id);
  const report = s.report || {};
  const points = report.points || [];
  show(el("h1", {}, `Study ${s.id}: ${s.name}`),
    el("div", { class: "toolbar" }, stateBadge(s.state), `${s.runs_done} of ${s.runs} runs ended`),
    s.error ? el("div", { class: "error-box" }, s.error) : null,
    el("p", {}, `Measure: ${report.measure ?? "—"}; reference: ${report.reference_source ?? "—"} ${report.reference != null ? `(${num(report.reference)})` : ""}`),
    el("img", { class: "chart", src: withToken(`/v1/studies/${id}/chart.svg`), alt: `Error against CPU time of the runs of study ${id}` }),
    el("h2", {}, "Runs"),
    el("table", { id: "runs" },
      el("thead", {}, el("tr", {}, ["series", "run", "job", "state", "measured", "reference", "relative error", "CPU s", "Pareto", "note"].map((h) => el("th", { scope: "col" }, h)))),
      el("tbody", {}, points.map((p) => el("tr", {},
        el("td", {}, p.series), el("td", {}, p.label || (p.value !== undefined ? num(p.value) : "")),
        el("td", {}, el("a", { href: `#/jobs/${p.job_id}` }, p.job_id)), el("td", {}, stateBadge(p.state)),
        el("td", { class: "num" }, num(p.measured)), el("td", { class: "num" }, num(p.reference)),
        el("td", { class: "num" }, num(p.relative_error ?? p.error)), el("td", { class: "num" }, num(p.cost && p.cost.cpu_seconds)),
        el("td", {}, p.pareto ? "yes" : ""), el("td", {}, p.failure ? `${p.failure}: ${p.note ?? ""}` : (p.note ?? "")))))));
}
