// The dashboard's router: #/ jobs, #/jobs/ID, #/studies, #/studies/ID, #/submit.

import { jobsPage } from "./jobs.js";
import { jobPage } from "./job.js";
import { studiesPage, studyPage } from "./studies.js";
import { submitPage } from "./submit.js";
import { show, el } from "./ui.js";

// The page being shown stops its timers and streams when another replaces it.
let leave = () => {};

function route() {
  leave();
  leave = () => {};
  const hash = location.hash.replace(/^#/, "") || "/";
  const parts = hash.split("/").filter(Boolean);
  const onLeave = (f) => { leave = f; };
  let page;
  if (parts.length === 0) page = jobsPage(onLeave);
  else if (parts[0] === "jobs" && parts[1]) page = jobPage(Number(parts[1]), onLeave);
  else if (parts[0] === "studies" && parts[1]) page = studyPage(Number(parts[1]));
  else if (parts[0] === "studies") page = studiesPage();
  else if (parts[0] === "submit") page = submitPage();
  else page = Promise.resolve(show(el("h1", {}, "Not found"), el("p", {}, el("a", { href: "#/" }, "Back to the jobs"))));
  for (const a of document.querySelectorAll("header nav a")) {
    const target = a.getAttribute("href").replace(/^#/, "");
    const here = target === "/" ? (parts.length === 0 || parts[0] === "jobs") : hash.startsWith(target);
    if (here) a.setAttribute("aria-current", "page"); else a.removeAttribute("aria-current");
  }
  Promise.resolve(page).catch((e) => {
    console.error(e);
    show(el("h1", {}, "Error"), el("div", { class: "error-box" }, String(e.message || e)));
  });
}

// The skip link moves the focus to the content without touching the hash the router reads.
document.querySelector(".skip").addEventListener("click", (e) => {
  e.preventDefault();
  document.getElementById("main").focus();
});

window.addEventListener("hashchange", route);
route();
