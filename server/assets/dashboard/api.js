// The REST API of the service, as the pages use it. Errors become ApiError with the service's
// code, message and violations (field paths).

export class ApiError extends Error {
  constructor(status, body) {
    super(body && body.message ? body.message : `HTTP ${status}`);
    this.status = status;
    this.code = body && body.code;
    this.details = (body && body.details) || [];
  }
}

// A server started with --user-tokens needs a user's token: asked once, kept in this browser
// (localStorage), sent as Authorization: Bearer; event streams and images, which cannot send
// headers, carry it as the access_token query parameter.
const TOKEN_KEY = "sable.token";

function token() {
  try { return localStorage.getItem(TOKEN_KEY) || ""; } catch { return ""; }
}

function authHeaders() {
  const t = token();
  return t ? { Authorization: `Bearer ${t}` } : {};
}

/** `path` with the token as its access_token query parameter (for EventSource and <img>). */
export function withToken(path) {
  const t = token();
  if (!t) return path;
  return path + (path.includes("?") ? "&" : "?") + "access_token=" + encodeURIComponent(t);
}

/** Asks for a token after a 401 or 403; true if one was given. */
function askToken(status) {
  const why = status === 403
    ? "This token is not a user's token. Give a user's token (sable serve --user-tokens):"
    : "This server needs a user's token (sable serve --user-tokens):";
  const t = window.prompt(why, "");
  if (!t) return false;
  try { localStorage.setItem(TOKEN_KEY, t.trim()); } catch { return false; }
  return true;
}

async function authFetch(path, init) {
  const go = () => fetch(path, { ...init, headers: { ...(init.headers || {}), ...authHeaders() } });
  let r = await go();
  if ((r.status === 401 || r.status === 403) && askToken(r.status)) r = await go();
  return r;
}

async function call(method, path, body) {
  const init = { method, headers: {} };
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = typeof body === "string" ? body : JSON.stringify(body);
  }
  const r = await authFetch(path, init);
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch { data = text; }
  if (!r.ok) throw new ApiError(r.status, typeof data === "object" ? data : { message: String(data).slice(0, 300) });
  return data;
}

export const api = {
  jobs: (query) => call("GET", "/v1/jobs?" + new URLSearchParams(query)),
  job: (id) => call("GET", `/v1/jobs/${id}`),
  cancel: (id) => call("POST", `/v1/jobs/${id}:cancel`),
  samples: (id, maxPoints) => call("GET", `/v1/jobs/${id}/samples?max_points=${maxPoints}`),
  snapshots: (id) => call("GET", `/v1/jobs/${id}/snapshots`),
  snapshotFile: async (id, index, part) => {
    const r = await authFetch(`/v1/jobs/${id}/snapshots/${index}/${part}`, {});
    if (!r.ok) throw new ApiError(r.status, await r.json().catch(() => null));
    return r.text();
  },
  state: (id) => call("GET", `/v1/jobs/${id}/state`),
  advice: (scene) => call("POST", "/v1/advice", typeof scene === "string" ? scene : { scene }),
  submit: (body) => call("POST", "/v1/jobs", body),
  studies: () => call("GET", "/v1/studies"),
  study: (id) => call("GET", `/v1/studies/${id}`),
  events: (id, after) => new EventSource(withToken(`/v1/jobs/${id}/events?after_seq=${after}`)),
};
