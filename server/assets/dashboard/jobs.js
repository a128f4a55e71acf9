// The job list: newest first, 50 a page, filtered by state; refreshed every two seconds. A
// refresh keeps the keyboard focus where it was (the same job's link, the same button).

import { api } from "./api.js";
import { el, num, show, stateBadge, when, status } from "./ui.js";

const STATES = ["", "queued", "running", "succeeded", "failed", "cancelled"];
const PAGE = 50;

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
      el("td", {}, el("progress", { max: 1, value: j.progress, "aria-label": `progress of job ${j.id}` }), ` ${Math.round(j.progress * 100)}%`),
      el("td", { class: "num" }, j.steps.toLocaleString()),
      el("td", { class: "num" }, j.sample_count.toLocaleString()),
      el("td", { class: "num" }, num(j.cpu_seconds)),
      el("td", {}, when(j.created_at)));
  }
  filter.addEventListener("change", () => { tokens = [""]; refresh(); });
  const tick = async () => {
    try { await refresh(); } catch (e) { status(`cannot reach the service: ${e.message}`); }
    if (!stopped) timer = setTimeout(tick, 2000);
  };
  onLeave(() => { stopped = true; clearTimeout(timer); });
  await tick();
}
