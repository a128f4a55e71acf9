// Small DOM and formatting helpers shared by the pages.

/** An element: el("td", {class: "num"}, "3.2", child, ...). Strings become text nodes. */
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (k === "class") e.className = v;
    else e.setAttribute(k, v === true ? "" : String(v));
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

/** A number in a short form: 4 significant digits, exponent when far from 1. */
export function num(x) {
  if (x === null || x === undefined || Number.isNaN(x)) return "—";
  if (typeof x !== "number") return String(x);
  if (x === 0) return "0";
  const a = Math.abs(x);
  if (a >= 1e5 || a < 1e-3) return x.toExponential(3);
  return Number(x.toPrecision(4)).toString();
}

/** A job or study state as a coloured badge. */
export function stateBadge(state) {
  return el("span", { class: `state state-${state}` }, state);
}

/** An RFC 3339 time as the browser's local date and time. */
export function when(t) {
  if (!t) return "—";
  const d = new Date(t);
  return Number.isNaN(d.getTime()) ? t : d.toLocaleString();
}

/** Seconds in a short form. */
export function seconds(s) {
  if (!s && s !== 0) return "—";
  if (s < 59.5) return `${num(s)} s`;
  const r = Math.round(s);
  if (r < 3600) return `${Math.floor(r / 60)} min ${r % 60} s`;
  const m = Math.round(s / 60);
  return `${Math.floor(m / 60)} h ${m % 60} min`;
}

/** A nested object flattened to [dotted.path, value] rows. */
export function flatten(obj, prefix = "", out = []) {
  for (const [k, v] of Object.entries(obj || {})) {
    const name = prefix + k;
    if (v && typeof v === "object" && !Array.isArray(v)) flatten(v, name + ".", out);
    else out.push([name, v]);
  }
  return out;
}

/** Replaces the page's content (null children are left out). */
export function show(...children) {
  const main = document.getElementById("main");
  main.replaceChildren(...children.filter((c) => c !== null && c !== undefined && c !== false));
  return main;
}

/** The page's status line (bottom right of the header). */
export function status(text) {
  const line = document.getElementById("status");
  if (line.textContent !== text) line.textContent = text;
}
