// The job list: newest first, 50 a page, filtered by state. The running jobs shown follow
// their event streams (progress, steps and samples as each sample arrives, from the job's
// current event on); the page is read again every five seconds for new jobs and states. A
// refresh keeps the keyboard focus where it was (the same job's link, the same button).

import { api } from "./api.js";
import { el, num, show, stateBadge, when, status } from "./ui.js";

const STATES = ["", "queued", "running", "succeeded", "failed", "cancelled"];
const TERMINAL = new Set(["succeeded", "failed", "cancelled"]);
const PAGE = 50;
const REFRESH_MS = 5000;

export async function jobsPage(onLeave) {
  const filter = el("select", { id: "state-filter", "aria-label": "Show jobs in state" },
    STATES.map((s) => el("option", { value: s }, s || "all states")));
  const body = el("tbody");
  const table = el("table", { id: "jobs", "aria-label": "Jobs" },
    el("thead", {}, el("tr", {},
      el("th", { class: "num", scope: "col" }, "id"), el("th", { scope: "col" }, "name"), el("th", { scope: "col" }, "state"),
      el("th", { scope: "col" }, "method"), el("th", { scope: "col" }, "progress"), el("th", { class: "num", scope: "col" }, "steps"),
      el("th", { class: "num", scope: "col" }, "samples"), el("th", { class: "num", scope: "col" }, "CPU s"), el("th", { scope: "col" }, "created"))),
    body);
  // The pages seen so far, by their tokens, so that "newer" goes back; the next page's token.
  let tokens = [""];
  let next = "";
  const newer = el("button", { id: "newer", onclick: () => { tokens.pop(); refresh(); } }, "← Newer");
  const older = el("button", { id: "older", onclick: () => { tokens.push(next); refresh(); } }, "Older →");
  show(el("h1", {}, "Jobs"), el("div", { class: "toolbar" }, el("label", {}, "State ", filter)), table, el("div", { class: "pager" }, newer, older));

  let timer = null;
  let stopped = false;
  // The event stream of each running job shown (null while it opens).
  const streams = new Map();
  function follow(id) {
    if (streams.has(id)) return;
    streams.set(id, null);
    api.samples(id, 1).then((read) => {
      if (stopped || !streams.has(id)) return;
      const source = api.events(id, read.events_seq);
      streams.set(id, source);
      source.addEventListener("sample", (e) => {
        const d = JSON.parse(e.data);
        const tr = body.querySelector(`tr[data-job="${id}"]`);
        if (!tr) return;
        tr.querySelector("progress").value = d.fraction;
        tr.querySelector(".pct").textContent = ` ${Math.round(d.fraction * 100)}%`;
        tr.querySelector(".steps").textContent = d.sample.step.toLocaleString();
        const n = tr.querySelector(".samples");
        n.textContent = (Number(n.dataset.n) + 1).toLocaleString();
        n.dataset.n = String(Number(n.dataset.n) + 1);
      });
      source.addEventListener("state", (e) => {
        if (TERMINAL.has(JSON.parse(e.data).state)) { unfollow(id); refresh().catch(() => {}); }
      });
    }).catch(() => streams.delete(id));
  }
  function unfollow(id) {
    streams.get(id)?.close();
    streams.delete(id);
  }
  async function refresh() {
    const query = { page_size: PAGE };
    if (filter.value) query.state = filter.value;
    const token = tokens[tokens.length - 1];
    if (token) query.page_token = token;
    const page = await api.jobs(query);
    if (stopped) return;
    const focused = document.activeElement && body.contains(document.activeElement) ? document.activeElement.closest("tr")?.dataset.job : null;
    body.replaceChildren(...page.jobs.map(row));
    if (!page.jobs.length) body.append(el("tr", {}, el("td", { colspan: 9, class: "muted" }, "No jobs.")));
    if (focused) body.querySelector(`tr[data-job="${focused}"] a`)?.focus();
    const running = new Set(page.jobs.filter((j) => j.state === "running").map((j) => j.id));
    for (const id of [...streams.keys()]) if (!running.has(id)) unfollow(id);
    for (const id of running) follow(id);
    next = page.next_page_token;
    newer.disabled = tokens.length === 1;
    older.disabled = !next;
    status("");
  }
  function row(j) {
    return el("tr", { "data-job": j.id },
      el("td", { class: "num" }, j.id),
      el("td", {}, el("a", { href: `#/jobs/${j.id}` }, j.name)),
      el("td", {}, stateBadge(j.state)),
      el("td", {}, j.method),
      el("td", {}, el("progress", { max: 1, value: j.progress, "aria-label": `progress of job ${j.id}` }), el("span", { class: "pct" }, ` ${Math.round(j.progress * 100)}%`)),
      el("td", { class: "num steps" }, j.steps.toLocaleString()),
      el("td", { class: "num samples", "data-n": j.sample_count }, j.sample_count.toLocaleString()),
      el("td", { class: "num" }, num(j.cpu_seconds)),
      el("td", {}, when(j.created_at)));
  }
  filter.addEventListener("change", () => { tokens = [""]; refresh(); });
  const tick = async () => {
    try { await refresh(); } catch (e) { status(`cannot reach the service: ${e.message}`); }
    if (!stopped) timer = setTimeout(tick, REFRESH_MS);
  };
  onLeave(() => { stopped = true; clearTimeout(timer); for (const id of [...streams.keys()]) unfollow(id); });
  await tick();
}
