// kfio web page: plain JavaScript, no framework, nothing loaded from another host.
// The request is edited as one text field per member (/system/A, /channel, ...), each holding the
// member's JSON text exactly as typed: the body sent is those texts put together, so numbers keep
// their decimal text (1.1 stays 11/10) and no value ever goes through a JavaScript double.
"use strict";

const $ = (id) => document.getElementById(id);
const state = { endpoint: null, report: null, reportText: null, requestText: null, job: null, examples: [], preferred: null, primary: "analyze" };

// ---------------------------------------------------------------- JSON with source spans

class JsonSyntaxError extends Error {
  constructor(message, pos) { super(message); this.pos = pos; }
}

/** Parse JSON text into nodes {type, start, end, members|items}; every node keeps its source span. */
function scanJson(text) {
  let i = 0;
  const ws = () => { while (i < text.length && " \t\n\r".includes(text[i])) i++; };
  const fail = (msg) => { throw new JsonSyntaxError(msg, i); };
  function value() {
    ws();
    const start = i, c = text[i];
    if (c === "{") {
      i++; const members = []; ws();
      if (text[i] === "}") { i++; return { type: "object", start, end: i, members }; }
      for (;;) {
        ws(); if (text[i] !== '"') fail("expected a quoted member name");
        const keyNode = string(); ws();
        if (text[i] !== ":") fail("expected ':' after a member name");
        i++;
        members.push({ key: JSON.parse(text.slice(keyNode.start, keyNode.end)), node: value() });
        ws();
        if (text[i] === ",") { i++; continue; }
        if (text[i] === "}") { i++; return { type: "object", start, end: i, members }; }
        fail("expected ',' or '}'");
      }
    }
    if (c === "[") {
      i++; const items = []; ws();
      if (text[i] === "]") { i++; return { type: "array", start, end: i, items }; }
      for (;;) {
        items.push(value()); ws();
        if (text[i] === ",") { i++; continue; }
        if (text[i] === "]") { i++; return { type: "array", start, end: i, items }; }
        fail("expected ',' or ']'");
      }
    }
    if (c === '"') return string();
    const m = /^-?(0|[1-9]\d*)(\.\d+)?([eE][+-]?\d+)?/.exec(text.slice(i, i + 400));
    if (m && m[0]) { i += m[0].length; return { type: "number", start, end: i }; }
    for (const word of ["true", "false", "null"]) {
      if (text.startsWith(word, i)) { i += word.length; return { type: word === "null" ? "null" : "bool", start, end: i }; }
    }
    fail(i >= text.length ? "unexpected end of text" : `unexpected character ${JSON.stringify(c)}`);
  }
  function string() {
    const start = i; i++;
    while (i < text.length && text[i] !== '"') { if (text[i] === "\\") i++; i++; }
    if (i >= text.length) fail("unterminated string");
    i++;
    return { type: "string", start, end: i };
  }
  const root = value(); ws();
  if (i < text.length) fail("unexpected text after the JSON value");
  return root;
}

function where(text, pos) {
  const before = text.slice(0, pos);
  const line = before.split("\n").length;
  return `line ${line}, column ${pos - before.lastIndexOf("\n")}`;
}

/** The member's text, matrices laid out one row per line (entries keep their source text). */
function layout(text, node) {
  const raw = (n) => text.slice(n.start, n.end);
  const isMatrix = node.type === "array" && node.items.length > 0 && node.items.every((r) => r.type === "array");
  if (!isMatrix) return raw(node);
  return "[" + node.items.map((row) => "[" + row.items.map(raw).join(", ") + "]").join(",\n ") + "]";
}

const escapePointer = (key) => key.replace(/~/g, "~0").replace(/\//g, "~1");

// ---------------------------------------------------------------- the request as fields

/** Replace the fields with the members of the request ``text`` (throws JsonSyntaxError). */
function setRequestText(text) {
  const root = scanJson(text);
  if (root.type !== "object") throw new JsonSyntaxError("the request must be a JSON object", root.start);
  const fields = [];
  for (const { key, node } of root.members) {
    if (key === "system" && node.type === "object") {
      for (const m of node.members) fields.push({ path: ["system", m.key], text: layout(text, m.node) });
    } else {
      fields.push({ path: [key], text: layout(text, node) });
    }
  }
  renderFields(fields);
}

const FIELD_HELP = {
  "/system/A": "state matrix A (n x n)",
  "/system/C": "output matrix C (p x n)",
  "/system/Q": "process noise covariance Q (n x n, positive semidefinite): bounds, simulate and loop need it; "
    + "analyze runs without it (given, it checks that (A, Q^1/2) is controllable)",
  "/system/R": "measurement noise covariance R (p x p, positive definite): bounds, simulate and loop need it; "
    + "analyze does not use it",
  "/system/sensors": "sensors: which rows of C each packet carries",
  "/channel": "packet channel: bernoulli, gilbert_elliott, markov, or per_sensor",
  "/system/B": "input matrix B (n x m; loop requests)",
  "/actuator_channel": "actuator packet channel of a loop: bernoulli, gilbert_elliott or markov",
  "/controller": "loop controller: fixed estimator and feedback gains, or {\"lqg\": {\"W\": ..., \"U\": ...}} (see the loop docs)",
  "/cost": "loop cost weights: x' W x + a' U a",
  "/options": "options (time_budget_s, bounds, simulate, loop, ...)",
};

function renderFields(fields) {
  const list = $("field-list");
  list.replaceChildren();
  list.dataset.version = String(Number(list.dataset.version || 0) + 1); // lets tests see a reload
  fields.forEach((f, n) => {
    const pointer = "/" + f.path.map(escapePointer).join("/");
    const div = document.createElement("div");
    div.className = "field";
    div.dataset.pointer = pointer;
    div.dataset.path = JSON.stringify(f.path);
    const label = document.createElement("label");
    label.htmlFor = `field-${n}`;
    label.textContent = pointer;
    const help = FIELD_HELP[pointer];
    if (help) {
      const span = document.createElement("span");
      span.className = "note";
      span.textContent = " - " + help;
      label.append(span);
    }
    const area = document.createElement("textarea");
    area.id = `field-${n}`;
    area.spellcheck = false;
    area.value = f.text;
    area.rows = Math.min(12, Math.max(f.text.split("\n").length, Math.ceil(f.text.length / 60)));
    const err = document.createElement("p");
    err.className = "field-error";
    err.id = `field-${n}-error`;
    err.setAttribute("role", "alert");
    err.hidden = true;
    area.setAttribute("aria-describedby", err.id);
    area.addEventListener("input", () => { clearError(div); if (pointer === "/channel") updateButtons(); });
    div.append(label, area, err);
    list.append(div);
  });
  offerMissingNoise();
  updateButtons();
}

// ---------------------------------------------------------------- which command fits the request

const pointers = () => new Set([...document.querySelectorAll("#field-list .field")].map((d) => d.dataset.pointer));

/** "loop" when the request has a loop's members (input matrix, actuator channel or controller), else "filter". */
function requestKind(have = pointers()) {
  return ["/system/B", "/actuator_channel", "/controller"].some((p) => have.has(p)) ? "loop" : "filter";
}

const LABEL = { analyze: "Analyze", bounds: "Bounds", simulate: "Simulate", loop: "Loop" };

/** Why ``endpoint`` cannot run the loaded request (said before any request is sent), or null. */
function unfitReason(endpoint, have = pointers()) {
  const why = unfitWhy(endpoint, have);
  return why === null ? null : `${LABEL[endpoint]}: ${why}`;
}

/** The reason without the button's name, so that the note under the buttons says it once for several. */
function unfitWhy(endpoint, have) {
  const kind = requestKind(have);
  if (kind === "loop" && endpoint !== "loop") {
    const parts = ["/system/B", "/actuator_channel", "/controller"].filter((p) => have.has(p)).join(", ");
    return `for filter requests (system and channel); this is a closed-loop request (it has ${parts}): use Loop.`;
  }
  if (kind === "filter" && endpoint === "loop") {
    return "for closed-loop requests; this one has no /system/B, /actuator_channel or /controller.";
  }
  if (endpoint === "bounds" && channelIid() === false) {
    return "for i.i.d. (Bernoulli) packet losses (Sinopoli et al. 2004; Liu and Goldsmith 2004); "
      + "this channel has memory: use Analyze for its exact verdict, or Simulate.";
  }
  if (endpoint !== "analyze") {
    const missing = ["/system/Q", "/system/R"].filter((p) => !have.has(p));
    if (missing.length) {
      return `needs ${missing.join(" and ")} (no default): add ${missing.length > 1 ? "them" : "it"} with the button below the fields.`;
    }
  }
  return null;
}

/** A number of the request's JSON (a number, "3/10" or "0.3"), as a double: only to read the channel's shape. */
function approx(v) {
  if (typeof v === "number") return v;
  const m = /^\s*(-?[\d.eE+-]+)\s*(?:\/\s*([\d.eE+-]+))?\s*$/.exec(String(v));
  return m ? Number(m[1]) / (m[2] === undefined ? 1 : Number(m[2])) : NaN;
}

/** Whether the /channel field's packets are i.i.d. (what the bounds assume); null when it cannot be read. */
function channelIid() {
  const div = document.querySelector('#field-list .field[data-pointer="/channel"]');
  let ch;
  try { ch = JSON.parse(div.querySelector("textarea").value); } catch (e) { return null; }
  const iid = (c) => {
    if (!c || typeof c !== "object") return null;
    if (c.model === "bernoulli") return true;
    if (c.model === "gilbert_elliott") return Math.abs(approx(c.failure_rate) + approx(c.recovery_rate) - 1) < 1e-12;
    if (c.model === "markov") {
      const table = c.arrival_probability && typeof c.arrival_probability === "object" ? c.arrival_probability : c;
      const values = Object.keys(table).filter((k) => /^[01]+$/.test(k)).map((k) => approx(table[k]));
      return values.every((v) => Math.abs(v - values[0]) < 1e-12);
    }
    if (c.model === "per_sensor" && c.channels) {
      const all = Object.values(c.channels).map(iid);
      return all.includes(null) ? null : all.every(Boolean);
    }
    return null;
  };
  return div ? iid(ch) : null;
}

/** The primary button is the command that fits the request; the others say why they cannot run it. */
function updateButtons() {
  const have = pointers();
  const reasons = new Map(); // the reason -> the buttons it holds for
  const preferred = requestKind(have) === "loop" ? "loop" : state.preferred && !unfitReason(state.preferred, have) ? state.preferred : "analyze";
  document.querySelectorAll("fieldset.run button[data-endpoint]").forEach((b) => {
    const endpoint = b.dataset.endpoint;
    const why = unfitReason(endpoint, have);
    b.classList.toggle("primary", endpoint === preferred);
    b.classList.toggle("unfit", why !== null);
    if (why) {
      b.setAttribute("aria-disabled", "true");
      b.title = why;
      const tail = unfitWhy(endpoint, have);
      reasons.set(tail, [...(reasons.get(tail) || []), LABEL[endpoint]]);
    } else {
      b.removeAttribute("aria-disabled");
      b.removeAttribute("title");
    }
  });
  $("run-note").textContent = [...reasons].map(([tail, names]) => `${names.join(", ")}: ${tail}`).join(" ");
  $("run-note").hidden = reasons.size === 0;
  state.primary = preferred;
}

/** Buttons that add /system/Q or /system/R (identity of the right size) when the request has none. */
function offerMissingNoise() {
  const box = $("add-fields");
  box.replaceChildren();
  const have = pointers();
  const size = (pointer) => {
    const div = document.querySelector(`#field-list .field[data-pointer="${pointer}"]`);
    if (!div) return null;
    try {
      const node = scanJson(div.querySelector("textarea").value);
      return node.type === "array" ? node.items.length : null;
    } catch (e) {
      return null;
    }
  };
  for (const [pointer, from, what] of [["/system/Q", "/system/A", "process noise covariance"], ["/system/R", "/system/C", "measurement noise covariance"]]) {
    if (have.has(pointer) || !have.has(from)) continue;
    const n = size(from);
    if (!n) continue;
    const b = el("button", `Add ${pointer} (${what}, identity ${n} x ${n} to edit)`);
    b.type = "button";
    b.dataset.add = pointer;
    b.addEventListener("click", () => addField(pointer, identityText(n)));
    box.append(b);
  }
  box.hidden = box.childElementCount === 0;
}

const identityText = (n) => "[" + Array.from({ length: n }, (_, i) => "[" + Array.from({ length: n }, (_, j) => (i === j ? "1" : "0")).join(", ") + "]").join(",\n ") + "]";

/** Add a field (after the other /system/... fields), keeping every field's text as edited. */
function addField(pointer, text) {
  const fields = [...document.querySelectorAll("#field-list .field")].map((d) => ({ path: JSON.parse(d.dataset.path), text: d.querySelector("textarea").value }));
  const path = pointer.slice(1).split("/");
  const lastSystem = fields.map((f) => f.path.length === 2).lastIndexOf(true);
  fields.splice(lastSystem + 1, 0, { path, text });
  renderFields(fields);
  const div = document.querySelector(`#field-list .field[data-pointer="${pointer}"]`);
  if (div) div.querySelector("textarea").focus();
  setStatus(`Added ${pointer}: edit it, then run.`);
}

/** The request body: the fields' texts put together (throws with the field that is not JSON). */
function assembleRequest() {
  const top = [];
  const system = [];
  for (const div of document.querySelectorAll("#field-list .field")) {
    const path = JSON.parse(div.dataset.path);
    const area = div.querySelector("textarea");
    const text = area.value.trim();
    try {
      if (!text) throw new JsonSyntaxError("empty: give a JSON value", 0);
      scanJson(text);
    } catch (e) {
      if (e instanceof JsonSyntaxError) {
        showFieldError(div, `not valid JSON (${where(text, e.pos)}): ${e.message}`);
        const err = new Error("invalid field");
        err.shown = true;
        throw err;
      }
      throw e;
    }
    const member = `${JSON.stringify(path[path.length - 1])}: ${text}`;
    if (path.length === 2) {
      if (system.length === 0) top.push(null); // the place of "system" among the members
      system.push(member);
    } else {
      top.push(member);
    }
  }
  const systemText = `"system": {${system.join(",\n  ")}}`;
  const members = top.map((m) => (m === null ? systemText : m));
  return "{" + members.join(",\n ") + "}\n";
}

// ---------------------------------------------------------------- errors beside fields

function clearError(div) {
  const err = div.querySelector(".field-error");
  err.hidden = true;
  err.textContent = "";
  div.querySelector("textarea").removeAttribute("aria-invalid");
}

function clearErrors() {
  document.querySelectorAll("#field-list .field").forEach(clearError);
  for (const id of ["general-error", "source-error"]) { $(id).hidden = true; $(id).textContent = ""; }
}

function showFieldError(div, message) {
  const err = div.querySelector(".field-error");
  err.textContent = message;
  err.hidden = false;
  const area = div.querySelector("textarea");
  area.setAttribute("aria-invalid", "true");
  area.focus();
}

/** Show a problem document beside the field its JSON pointer names (the longest matching field). */
function showProblem(problem) {
  const pointer = typeof problem.field === "string" && problem.in !== "query" ? problem.field : null;
  const message = problem.rule ? `${problem.field}: ${problem.rule}` : problem.detail || problem.title;
  let best = null;
  if (pointer !== null) {
    for (const div of document.querySelectorAll("#field-list .field")) {
      const p = div.dataset.pointer;
      if ((pointer === p || pointer.startsWith(p + "/")) && (!best || p.length > best.dataset.pointer.length)) best = div;
    }
  }
  if (best) {
    showFieldError(best, message);
  } else {
    $("general-error").textContent = `${problem.title || "Error"}: ${message}`;
    $("general-error").hidden = false;
  }
  setStatus(`Refused (${problem.status} ${problem.title || ""}): ${message}`);
}

function setStatus(text) { $("status").textContent = text; }

// ---------------------------------------------------------------- running

async function run(endpoint) {
  clearErrors();
  let body;
  try {
    body = assembleRequest();
  } catch (e) {
    if (e.shown) { setStatus("Fix the field marked in red, then run again."); return; }
    throw e;
  }
  state.requestText = body;
  state.endpoint = endpoint;
  $("report").replaceChildren();
  $("plots").replaceChildren();
  $("actions").hidden = true;
  setBusy(true);
  try {
    if ($("as-job").checked) await runJob(endpoint, body);
    else await runNow(endpoint, body);
  } catch (e) {
    setStatus(`The server could not be reached: ${e.message}`);
  } finally {
    setBusy(false);
  }
}

function setBusy(busy) {
  document.querySelectorAll("fieldset.run button").forEach((b) => { b.disabled = busy; });
}

// A server with access tokens answers 401: ask for the token once, keep it for this tab (sessionStorage, never
// localStorage: it goes when the tab closes) and send it as "Authorization: Bearer" with every API request.
const TOKEN_KEY = "kfio-api-token";

async function api(path, init = {}) {
  for (let asked = 0; ; asked++) {
    const headers = new Headers(init.headers || {});
    const token = sessionStorage.getItem(TOKEN_KEY);
    if (token) headers.set("Authorization", `Bearer ${token}`);
    const response = await fetch(path, { ...init, headers });
    if (response.status !== 401 || asked >= 3) return response;
    const given = window.prompt(
      token ? "That access token was refused. Access token of this kfio server:"
        : "This kfio server needs an access token (its operator has it; kfio serve prints one at start):");
    if (!given || !given.trim()) return response;
    sessionStorage.setItem(TOKEN_KEY, given.trim());
  }
}

const post = (path, body) => api(path, { method: "POST", headers: { "Content-Type": "application/json", Accept: "application/json" }, body });

async function readAnswer(response) {
  const text = await response.text();
  let doc = null;
  try { doc = JSON.parse(text); } catch (e) { /* not JSON */ }
  return { ok: response.ok, status: response.status, text, doc };
}

async function runNow(endpoint, body) {
  setStatus(`Running ${endpoint}...`);
  const answer = await readAnswer(await post(`/v1/${endpoint}`, body));
  if (!answer.ok) return showProblem(answer.doc || { status: answer.status, title: "Error", detail: answer.text });
  await showReport(endpoint, answer.text, answer.doc, body);
}

async function runJob(endpoint, body) {
  setStatus(`Submitting ${endpoint} as a job...`);
  const response = await post(`/v1/jobs/${endpoint}`, body);
  const answer = await readAnswer(response);
  if (response.status !== 202) return showProblem(answer.doc || { status: answer.status, title: "Error", detail: answer.text });
  const location = response.headers.get("Location");
  state.job = location;
  $("job-box").hidden = false;
  $("job-progress").removeAttribute("value");
  for (;;) {
    const poll = await readAnswer(await api(location, { headers: { Accept: "application/json" } }));
    if (!poll.ok) { showProblem(poll.doc); break; }
    const job = poll.doc;
    const p = job.progress || {};
    if (typeof p.fraction === "number") $("job-progress").value = p.fraction;
    const pct = typeof p.fraction === "number" ? ` (${(100 * p.fraction).toFixed(1)}%)` : "";
    $("job-text").textContent = `job ${job.status}` + (p.stage ? `: ${p.stage}, ${p.steps} steps, ${p.elapsed_s} s${pct}` : "");
    setStatus(`Job ${job.id}: ${job.status}`);
    if (job.status === "done") {
      const result = await api(`${location}/result`);
      await showReport(endpoint, await result.text(), job.result, body);
      break;
    }
    if (job.status === "failed") { showProblem(job.problem); break; }
    if (job.status === "cancelled") { setStatus(`Job ${job.id} was cancelled.`); break; }
    if (state.job !== location) break;
    await new Promise((r) => setTimeout(r, 500));
  }
  $("job-box").hidden = true;
  state.job = null;
}

async function cancelJob() {
  if (!state.job) return;
  const location = state.job;
  const answer = await readAnswer(await api(location, { method: "DELETE" }));
  setStatus(answer.ok ? "Cancelling..." : `Could not cancel: ${answer.doc ? answer.doc.detail : answer.status}`);
}

// ---------------------------------------------------------------- the report

/** The exact verdict for a report that lacks one: analyze of the same request (its report, or the problem). */
async function exactFor(body) {
  try {
    const answer = await readAnswer(await post("/v1/analyze", body));
    return answer.doc || { detail: `HTTP ${answer.status}` };
  } catch (e) {
    return { detail: e.message };
  }
}

async function showReport(endpoint, text, doc, body) {
  state.report = doc;
  state.reportText = text;
  let exact = null;
  const needsExact = endpoint === "bounds" || (endpoint === "simulate" && !(doc.stationary && doc.stationary.verdict));
  if (needsExact) {
    setStatus("Running analyze for the exact verdict...");
    exact = await exactFor(body);
  }
  const report = $("report");
  report.replaceChildren();
  const render = { analyze: renderAnalyze, bounds: renderBounds, simulate: renderSimulate, loop: renderLoop }[endpoint];
  report.append(render(doc, exact));
  setStatus(`Done: ${endpoint}.`);
  showCommands(endpoint, body);
  $("actions").hidden = false;
  drawPlots(endpoint, body);
  $("results").focus();
}

// ---------------------------------------------------------------- plots

async function drawPlots(endpoint, body) {
  let request = null;
  try { request = JSON.parse(body); } catch (e) { return; } // doubles are fine here: only the channel's shape is read
  for (const [name, title] of plotsFor(endpoint, request)) {
    const fig = el("figure", null, "plot");
    const cap = el("figcaption", title);
    const wait = el("p", "drawing...", "note");
    fig.append(cap, wait);
    $("plots").append(fig);
    const response = await post(`/v1/plots/${name}`, body);
    if (response.ok) {
      const img = el("img");
      img.alt = title;
      img.src = URL.createObjectURL(await response.blob());
      wait.replaceWith(img);
    } else {
      const answer = await readAnswer(response);
      wait.textContent = `no plot: ${answer.doc ? answer.doc.detail : answer.status}`;
    }
  }
}

// ---------------------------------------------------------------- commands and downloads

const shellQuote = (s) => "'" + s.replace(/'/g, "'\\''") + "'";

function showCommands(endpoint, body) {
  const compact = body.replace(/\s*\n\s*/g, " ").trim();
  // the token itself is not shown on the page: the command reads it from the shell's environment
  const auth = sessionStorage.getItem(TOKEN_KEY) ? ` -H "Authorization: Bearer $KFIO_API_TOKEN"` : "";
  $("curl-cmd").value = `curl -s ${location.origin}/v1/${endpoint} -H 'Content-Type: application/json'${auth} --data-binary ${shellQuote(compact)}`;
  $("kfio-cmd").value = `kfio ${endpoint} --json request.json`;
}

function download(name, text) {
  const a = el("a");
  a.href = URL.createObjectURL(new Blob([text], { type: "application/json" }));
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
}

async function copy(id) {
  const area = $(id);
  area.select();
  try { await navigator.clipboard.writeText(area.value); setStatus("Copied."); } catch (e) { document.execCommand("copy"); setStatus("Copied."); }
}

// ---------------------------------------------------------------- sources: examples, upload, paste

function loadText(text, what) {
  clearErrors();
  try {
    setRequestText(text);
    setStatus(`Loaded ${what}. Edit the fields, then run.`);
    return true;
  } catch (e) {
    if (!(e instanceof JsonSyntaxError)) throw e;
    $("source-error").textContent = `${what} is not valid JSON (${where(text, e.pos)}): ${e.message}`;
    $("source-error").hidden = false;
    return false;
  }
}

/** Fit an uploaded trace (POST /v1/fit) and put it in the /channel field as a trace channel. */
async function loadTrace(text, name) {
  clearErrors();
  const arrivals = text.split(/\r?\n/).map((l) => l.trim()).filter((l) => l && !l.startsWith("#")).join("");
  const answer = await readAnswer(await post("/v1/fit", JSON.stringify({ arrivals })));
  if (!answer.ok) {
    const doc = answer.doc || {};
    $("source-error").textContent = `trace ${name}: ${doc.detail || answer.text}`;
    $("source-error").hidden = false;
    return;
  }
  const fit = answer.doc;
  const params = Object.entries(fit.parameters).map(([k, v]) => {
    const [lo, hi] = fit.intervals[k];
    return `${k} = ${v} [${lo.toPrecision(4)}, ${hi.toPrecision(4)}]`;
  });
  const field = document.querySelector('#field-list .field[data-pointer="/channel"] textarea');
  if (field) field.value = JSON.stringify({ model: "trace", arrivals });
  $("trace-note").textContent = `${name}: ${fit.samples} packets, ${fit.model}${fit.model === "markov" ? ` order ${fit.order}` : ""} `
    + `(chosen by BIC): ${params.join(", ")}. `
    + (field ? "The channel field now holds the trace: Analyze gives the verdict at 95% confidence."
      : "Load a request first: its channel field takes the trace.")
    + (fit.warnings.length ? ` Warning: ${fit.warnings.join(" ")}` : "");
}

async function loadExample() {
  const id = $("example").value;
  const meta = state.examples.find((e) => e.id === id);
  const text = await (await fetch(`/static/requests/${id}.json`)).text();
  $("example-note").textContent = meta ? meta.note : "";
  state.preferred = meta ? meta.endpoint : null;
  loadText(text, `example "${meta ? meta.title : id}"`);
}

async function init() {
  state.examples = await (await fetch("/static/requests/index.json")).json();
  const select = $("example");
  for (const e of state.examples) {
    const o = el("option", `${e.title} [${e.endpoint}]`);
    o.value = e.id;
    select.append(o);
  }
  $("load-example").addEventListener("click", loadExample);
  $("upload").addEventListener("change", async (ev) => {
    const file = ev.target.files[0];
    state.preferred = null;
    if (file) loadText(await file.text(), `file ${file.name}`);
  });
  $("trace-upload").addEventListener("change", async (ev) => {
    const file = ev.target.files[0];
    if (file) await loadTrace(await file.text(), file.name);
  });
  $("use-paste").addEventListener("click", () => {
    state.preferred = null;
    if (loadText($("paste").value, "the pasted JSON")) $("paste-box").open = false;
  });
  $("fields").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const endpoint = ev.submitter && ev.submitter.dataset.endpoint ? ev.submitter.dataset.endpoint : state.primary || "analyze";
    const why = unfitReason(endpoint);
    if (why) {  // said here, before any round trip to the server
      clearErrors();
      $("general-error").textContent = why;
      $("general-error").hidden = false;
      setStatus(`Not sent: ${why}`);
      return;
    }
    run(endpoint);
  });
  $("job-cancel").addEventListener("click", cancelJob);
  $("download").addEventListener("click", () => download(`kfio-${state.endpoint}.json`, state.reportText));
  $("download-request").addEventListener("click", () => download("request.json", state.requestText));
  document.querySelectorAll("[data-copy]").forEach((b) => b.addEventListener("click", () => copy(b.dataset.copy)));
  await loadExample();
}

init();
