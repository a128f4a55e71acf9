// Submit a scene: a file or pasted JSON, checked by the advisor first; the rules it breaks are
// listed with their field paths.

import { api } from "./api.js";
import { el, show } from "./ui.js";

export async function submitPage() {
  const text = el("textarea", { id: "scene-text", "aria-label": "Scene (JSON)", spellcheck: "false", placeholder: "{ \"name\": ..., \"dimension\": 2, ... }  (docs/scene-format.md)" });
  const file = el("input", { type: "file", id: "scene-file", accept: ".json,application/json", "aria-label": "Scene file" });
  const name = el("input", { id: "job-name", "aria-label": "Job name (optional)", placeholder: "job name (optional)" });
  const out = el("div", { id: "submit-result", "aria-live": "polite" });
  file.addEventListener("change", async () => { if (file.files[0]) text.value = await file.files[0].text(); });

  function parsed() {
    try { return JSON.parse(text.value); } catch (e) {
      out.replaceChildren(el("div", { class: "error-box", role: "alert" }, `Not JSON: ${e.message}`));
      return null;
    }
  }
  // `wrapped`: the page wrapped the user's scene as {"scene": ...}, so the service's paths
  // start with "scene."; they are shown relative to the scene the user gave.
  function rejected(e, wrapped) {
    const path = (f) => (wrapped ? f.replace(/^scene\.?/, "") : f) || "(the scene)";
    out.replaceChildren(el("div", { class: "error-box", role: "alert" }, el("strong", {}, e.message),
      (e.details || []).length ? el("ul", { class: "violations", id: "violations" }, e.details.map((v) => el("li", {}, el("code", {}, path(v.field)), ": ", v.rule))) : null));
  }
  async function validate() {
    const scene = parsed();
    if (!scene) return;
    try {
      const a = await api.advice(scene.scene ?? scene);
      out.replaceChildren(el("p", { id: "valid" }, "Valid. The advisor would run it with ", el("strong", {}, a.method), "."), el("ul", {}, a.reasons.map((r) => el("li", {}, r))));
    } catch (e) { rejected(e, !scene.scene); }
  }
  async function submit(ev) {
    ev.preventDefault();
    const scene = parsed();
    if (!scene) return;
    const body = scene.scene ? scene : { scene };
    if (name.value.trim()) body.name = name.value.trim();
    try {
      const job = await api.submit(body);
      location.hash = `#/jobs/${job.id}`;
    } catch (e) { rejected(e, !scene.scene); }
  }
  show(el("h1", {}, "Submit a scene"),
    el("p", { class: "muted" }, "A scene file (docs/scene-format.md; examples in scenes/), or the JSON pasted below. It is validated by the service before it is queued; nothing is stored for a rejected scene."),
    el("form", { id: "submit-form", onsubmit: submit },
      el("div", { class: "toolbar" }, el("label", {}, "File ", file), name),
      text,
      el("div", { class: "toolbar" }, el("button", { type: "button", id: "validate", onclick: validate }, "Validate"), el("button", { type: "submit", id: "submit" }, "Submit"))),
    out);
}
