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

async function call(method, path, body) {
  const init = { method, headers: {} };
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = typeof body === "string" ? body : JSON.stringify(body);
  }
  const r = await fetch(path, init);
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
    const r = await fetch(`/v1/jobs/${id}/snapshots/${index}/${part}`);
    if (!r.ok) throw new ApiError(r.status, await r.json().catch(() => null));
    return r.text();
  },
  state: (id) => call("GET", `/v1/jobs/${id}/state`),
  advice: (scene) => call("POST", "/v1/advice", typeof scene === "string" ? scene : { scene }),
  submit: (body) => call("POST", "/v1/jobs", body),
  studies: () => call("GET", "/v1/studies"),
  study: (id) => call("GET", `/v1/studies/${id}`),
  events: (id, after) => new EventSource(`/v1/jobs/${id}/events?after_seq=${after}`),
};
