// kfio web page: the report views. Plain JavaScript, loaded before app.js, nothing from another host.
// The headline is always the exact verdict (Theorem 1 of Rohr, Marelli and Fu 2014): analyze computes
// it, a simulate report carries it in stationary.verdict, and for bounds the page asks analyze for it.
// Bounds and Monte Carlo are shown beside it as evidence, never as the verdict.
"use strict";

const THEOREM_1 = "Rohr, Marelli and Fu 2014, Theorem 1";

const MEANING = {
  stable: "The expected error covariance E[P_t] stays bounded: with this many packets arriving, the filter's "
    + "mean-square error settles.",
  unstable: "The expected error covariance E[P_t] grows without bound: too many measurements are lost "
    + "for this system.",
  boundary: "Exactly on the edge: some block has |alpha|^2 sigma = 1, the case the theorem leaves open. "
    + "Any better channel is stable, any worse one unstable.",
};

const BOUNDS_MEANING = {
  stable: "stable by the bounds: the stability LMI is feasible (Sinopoli et al. 2004, Theorem 5)",
  unstable: "unstable by the bounds: below the lower bound on the critical probability (Sinopoli et al. 2004, Theorem 3)",
  undecided: "undecided by the bounds: between the lower bound and the LMI upper bound on the critical probability "
    + "(Sinopoli et al. 2004)",
};

function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) prose(e, String(text), tag);
  if (cls) e.className = cls;
  return e;
}

/** ``text`` into ``e``: report texts mark code with Markdown backticks; those spans become <code>, no backtick shows. */
function prose(e, text, tag) {
  if (!text.includes("`") || ["code", "textarea", "option", "pre"].includes(tag)) {
    e.textContent = text;
    return;
  }
  text.split(/(`[^`]*`)/).forEach((part) => {
    if (part.length > 1 && part.startsWith("`") && part.endsWith("`")) e.append(el("code", part.slice(1, -1)));
    else if (part) e.append(part.replace(/`/g, ""));
  });
}

/** Append strings and nodes to ``parent`` (null and undefined are skipped). */
function put(parent, ...items) {
  for (const i of items) {
    if (i === null || i === undefined) continue;
    if (i instanceof Node) parent.append(i);
    else if (String(i).includes("`")) parent.append(el("span", String(i)));
    else parent.append(String(i));
  }
  return parent;
}

// ---------------------------------------------------------------- numbers: decimals first, exact on demand

/** A JSON number as a short decimal with ``digits`` significant digits (null: "-"). */
function dec(x, digits = 6) {
  if (x === null || x === undefined) return "-";
  if (typeof x !== "number") return String(x);
  if (!Number.isFinite(x)) return Number.isNaN(x) ? "NaN" : x > 0 ? "infinite" : "-infinite";
  const a = Math.abs(x);
  if (Number.isInteger(x) && a < 1e15) return String(x);
  if (a !== 0 && a < 1e-4) return x.toExponential(Math.max(0, digits - 1)).replace(/\.?0+e/, "e");
  if (a >= 10 ** digits) return a < 1e15 ? String(Math.round(x)) : x.toExponential(digits - 1);
  const s = x.toPrecision(digits);
  return s.includes(".") && !s.includes("e") ? s.replace(/0+$/, "").replace(/\.$/, "") : s;
}

/** The value of an exact rational text such as "3/5" (null if it is not one). */
function ratio(text) {
  const m = /^(-?\d+)(?:\/(\d+))?$/.exec(text || "");
  return m ? Number(m[1]) / Number(m[2] || 1) : null;
}

/** Exact forms up to this many characters stand beside the decimal (the CLI's cap, kfio._numbers). */
const EXACT_CAP = 24;

/** What a long exact text is, as kfio._numbers.show says it: from float data, a long fraction, algebraic. */
function exactNote(exact) {
  if (/\d0{10,}(?!\d)/.test(exact) || /^0{10,}/.test(exact)) return "from float data";
  const m = /^-?(\d+)\/(\d+)$/.exec(exact);
  if (m) return `${Math.max(m[1].length, m[2].length)}-digit fraction`;
  if (/log|exp|pi/.test(exact)) return "closed form";
  const roots = exact.match(/CRootOf\(([^,]*),/g) || [];
  if (roots.length === 1) {
    const powers = (roots[0].match(/x\*\*(\d+)/g) || []).map((p) => Number(p.slice(3)));
    return `algebraic, degree ${Math.max(1, ...powers)}`;
  }
  if (roots.length === 0 && (exact.match(/sqrt\(/g) || []).length === 1 && !exact.includes("**")) return "algebraic, degree 2";
  return "algebraic";
}

/**
 * A number for people, as the CLI prints it: the decimal first, the exact form beside it when it is
 * short ("0.36 = 9/25"), else what kind of number it is, with the exact text behind an "exact"
 * toggle (a <details>) and in the tooltip.
 */
function num(exact, value, digits = 6) {
  const span = el("span", null, "num");
  const hasExact = typeof exact === "string" && exact !== "";
  const known = value === null || value === undefined ? (hasExact ? ratio(exact) : null) : value;
  const d = known === null ? null : dec(known, digits);
  if (hasExact) span.title = `exact: ${exact}`;
  if (!hasExact) return put(span, d === null ? "-" : d);
  if (d === exact || (d !== null && /^-?\d+$/.test(exact) && Number(exact) === known)) return put(span, d);
  if (exact.length <= EXACT_CAP) return put(span, d === null ? exact : `${d} = ${exact}`);
  put(span, el("span", d === null ? "exact expression" : `${d} (${exactNote(exact)})`, "dec"), " ");
  const details = el("details", null, "exact");
  details.append(el("summary", "exact"), el("code", exact));
  return put(span, details);
}

// ---------------------------------------------------------------- building blocks

function headline(verdict, source, lines) {
  const box = el("div", null, `headline ${verdict || "none"}`);
  box.id = "verdict";
  box.dataset.verdict = verdict || "none";
  box.append(el("strong", verdict || "no exact verdict"));
  if (source) box.append(el("span", source, "source"));
  for (const line of lines) if (line) box.append(typeof line === "string" ? el("p", line) : line);
  return box;
}

function exactHeadline(verdict, lines) {
  return headline(verdict, `exact verdict (${THEOREM_1})`, [MEANING[verdict], ...lines]);
}

function facts(pairs) {
  const dl = el("dl", null, "facts");
  for (const [k, v] of pairs) {
    if (v === undefined) continue;
    dl.append(el("dt", k), put(el("dd"), v === null ? "-" : v));
  }
  return dl;
}

/** A table whose cells may be nodes; each cell carries its column name for the narrow (stacked) layout. */
function table(headers, rows, cls) {
  const wrap = el("div", null, "table-wrap");
  const t = el("table", null, cls || null);
  const tr = el("tr");
  headers.forEach((h) => { const th = el("th", h); th.scope = "col"; tr.append(th); });
  t.append(el("thead"));
  t.tHead.append(tr);
  const tb = el("tbody");
  rows.forEach((r) => {
    const row = el("tr");
    r.forEach((c, i) => { const td = put(el("td"), c === null || c === undefined ? "-" : c); td.dataset.label = headers[i]; row.append(td); });
    tb.append(row);
  });
  t.append(tb);
  wrap.append(t);
  return wrap;
}

function list(title, items, cls) {
  const frag = document.createDocumentFragment();
  frag.append(el("h3", title));
  if (!items || items.length === 0) { frag.append(el("p", "none", "note")); return frag; }
  const ul = el("ul", null, cls || "list");
  items.forEach((i) => ul.append(el("li", typeof i === "string" ? i : JSON.stringify(i))));
  frag.append(ul);
  return frag;
}

/** Warnings as visible text right under the headline (not only in a plot title). */
function warningBox(warnings) {
  if (!warnings || warnings.length === 0) return null;
  const box = el("div", null, "warnings");
  box.setAttribute("role", "note");
  warnings.forEach((w) => box.append(el("p", w)));
  return box;
}

const eigen = (text, numeric) => {
  if (text.length <= 14) return text;
  if (!Array.isArray(numeric)) return num(text, null);
  const [re, im] = numeric;
  const d = im === 0 ? dec(re, 5) : `${dec(re, 5)} ${im < 0 ? "-" : "+"} ${dec(Math.abs(im), 5)}i`;
  const span = put(el("span", null, "num"), el("span", d, "dec"), " ");
  const details = el("details", null, "exact");
  details.append(el("summary", "exact"), el("code", text));
  span.title = `exact: ${text}`;
  return put(span, details);
};

function eigenvalues(texts, numerics) {
  const span = el("span");
  (texts || []).forEach((t, i) => put(span, i ? ", " : null, eigen(t, numerics ? numerics[i] : null)));
  return span;
}

// ---------------------------------------------------------------- design answers of analyze

/** "unstable on (0, 0.4865); stable on (0.4865, 1)" for a line's labelled intervals. */
const intervalsText = (intervals, sym) => (intervals || [])
  .map((i) => `${i.label} for ${sym} in (${dec(i.lower, 4)}, ${dec(i.upper, 4)})`).join("; ");

/** The critical values along one line of the channel's parameters, or why there are none. */
function crossingsAnswer(crossings, status, exact) {
  const span = el("span", null, "answer");
  if (!crossings || crossings.length === 0) return put(span, status || "no critical value in (0, 1)");
  crossings.forEach((c, i) => put(span, i ? "; " : null, num(c.value_exact, c.value), ` (${c.below} below, ${c.above} above)`));
  if (exact === false) put(span, " (not exact: see the report)");
  return span;
}

function gilbertElliottSection(g, channel) {
  const frag = document.createDocumentFragment();
  frag.append(el("h3", "Critical rates of the Gilbert-Elliott channel (Theorem 1 on the (p, q) family; Wu, Shi, Anderson and Johansson 2018)"));
  const p = channel ? channel.failure_rate : "p", q = channel ? channel.recovery_rate : "q";
  const rec = g.critical_recovery_rate || {}, fail = g.critical_failure_rate || {};
  const d = facts([
    [`critical recovery rate q*(p = ${p})`, crossingsAnswer(rec.crossings, rec.status, rec.exact)],
    ["along q, at the request's p", intervalsText(rec.intervals, "q")],
    [`critical failure rate p*(q = ${q})`, crossingsAnswer(fail.crossings, fail.status, fail.exact)],
    ["along p, at the request's q", intervalsText(fail.intervals, "p")],
  ]);
  d.id = "ge-critical";
  frag.append(d);
  frag.append(el("p", "p = P(lost | arrived), q = P(arrived | lost). The region plot below marks the request's (q, p).", "note"));
  return frag;
}

function criticalParameterSection(c) {
  const frag = document.createDocumentFragment();
  frag.append(el("h3", `Critical value of ${c.pointer}, the rest of the channel fixed (Theorem 1 on a one-parameter family)`));
  const d = facts([
    ["the request's value", num(c.value, ratio(c.value))],
    ["critical value", crossingsAnswer(c.crossings, null, c.exact)],
    ["along the parameter", intervalsText(c.intervals, "x")],
    ["basis", `${c.basis}${c.exact ? "" : "; labels not exact"}`],
  ]);
  d.id = "critical-parameter";
  frag.append(d);
  return frag;
}

const MOMENT = {
  mean: { finite: "finite (kappa > 1)", boundary: "on the boundary (kappa = 1)", infinite: "infinite (kappa <= 1)" },
  variance: { finite: "finite (kappa > 2)", boundary: "on the boundary (kappa = 2)", infinite: "infinite (kappa <= 2)" },
};

function tailSection(t) {
  const frag = document.createDocumentFragment();
  frag.append(el("h3", `Tail of the error: P(trace P > M) ~ M^(-kappa) (${t.basis === "theorem" ? "Mo and Sinopoli 2012" : "kfio's extension of Mo and Sinopoli 2012"})`));
  const m = t.moments || {};
  const d = facts([
    ["tail exponent kappa", num(t.kappa_exact, t.kappa, 4)],
    ["mean of P_t", MOMENT.mean[m.mean] || m.mean],
    ["variance of P_t", MOMENT.variance[m.variance] || m.variance],
    ["what it means", `${t.statement}. ${m.mean !== "finite" ? "A simulated mean is dominated by rare long runs of losses: read quantiles, not the sample mean."
      : m.variance !== "finite" ? "The 95% band of a simulated mean is not to be trusted (infinite variance): read quantiles." : ""}`.trim()],
  ]);
  d.id = "tail";
  frag.append(d);
  if ((t.blocks || []).length > 1) {
    frag.append(table(["eigenvalues", "kappa", "mean", "variance", "basis"], t.blocks.map((b) => [
      eigenvalues(b.eigenvalues), num(b.kappa_exact, b.kappa, 4), b.moments.mean, b.moments.variance, b.basis,
    ])));
  }
  if ((t.notes || []).length) frag.append(list("Tail notes", t.notes));
  return frag;
}

function regionsSection(reg) {
  const frag = document.createDocumentFragment();
  frag.append(el("h3", "Critical arrival probability of each sensor, the others at the request's (kfio extension of Rohr, Marelli and Fu 2014)"));
  frag.append(table(["sensor", "arrival probability", "critical probability", "set by"], (reg.sensors || []).map((s) => [
    s.sensor,
    num(s.arrival_probability_exact, s.arrival_probability),
    s.critical_arrival_probability === null && s.critical_arrival_probability_exact === null
      ? s.status : num(s.critical_arrival_probability_exact, s.critical_arrival_probability),
    s.binding ? `block ${(s.binding.eigenvalues || []).join(", ")}, blind set ${JSON.stringify(s.binding.blind_set)}` : s.reason,
  ]), "sensors"));
  const imp = reg.sensor_improvement;
  if (imp) {
    frag.append(el("h3", "Which sensor to improve (kfio extension)"));
    const best = (imp.sensors || []).find((s) => s.sensor === imp.best);
    const advice = el("p", null, "advice");
    advice.id = "advice";
    if (best) {
      put(advice, el("strong", `Improve "${imp.best}" first:`),
        ` halving its loss probability lowers the worst rate |alpha|^2 sigma from ${dec(imp.worst_rate, 4)} to ${dec(best.worst_rate_if_loss_halved, 4)}`
        + ` (block ${(imp.worst_block || []).join(", ")}; below 1 is stable).`);
    } else {
      put(advice, `No single sensor's improvement lowers the worst rate ${dec(imp.worst_rate, 4)}.`);
    }
    frag.append(advice);
    frag.append(table(["sensor", "elasticity of the worst rate", "worst rate if its loss is halved"], (imp.sensors || []).map((s) => [
      s.sensor, num(s.elasticity_exact, s.elasticity, 4), dec(s.worst_rate_if_loss_halved, 4),
    ]), "improvement"));
    frag.append(el("p", imp.rule || "elasticity = d log(worst rate) / d log(1 - lambda_s)", "note"));
  }
  return frag;
}

/** "gilbert_elliott: failure_rate = 3/10, recovery_rate = 3/5"; Markov histories as P(arrival | 01); per-sensor in turn. */
function channelText(ch) {
  const history = (k) => /^[01]+$/.test(k);
  const params = (c) => {
    const keys = Object.keys(c).filter((k) => k !== "model" && k !== "channels" && !(k === "order" && c.model !== "markov"));
    return [...keys.filter((k) => !history(k)).map((k) => `${k} = ${typeof c[k] === "object" ? JSON.stringify(c[k]) : c[k]}`),
      ...keys.filter(history).sort().map((k) => `P(arrival | ${k}) = ${c[k]}`)].join(", ");
  };
  if (ch.model === "per_sensor" && ch.channels) {
    return `per sensor; ${Object.entries(ch.channels).map(([name, c]) => `${name}: ${c.model}, ${params(c)}`).join("; ")}`;
  }
  return `${ch.model}: ${params(ch)}`;
}

/** The fit block of a report whose channel was a measured trace: the verdict of the whole confidence region. */
function fitSection(f) {
  const out = document.createDocumentFragment();
  const level = `${f.level * 100}%`;
  out.append(el("h3", `Verdict at ${level} confidence: ${f.verdict.toUpperCase()}`));
  out.append(el("p", f.verdict === "undecided"
    ? `The ${level} confidence region of the channel fitted to ${f.samples} packets holds stable and unstable channels.`
      + (f.samples_needed ? ` About ${f.samples_needed} packets in all would decide, if the rate stays as measured.` : "")
    : `Every channel in the ${level} confidence region of the channel fitted to ${f.samples} packets is ${f.verdict}.`, "note"));
  out.append(table(
    ["parameter", "estimate (exact)", `${level} joint interval`],
    Object.entries(f.parameters).map(([k, v]) => [k, v, `[${dec(f.intervals[k][0])}, ${dec(f.intervals[k][1])}]`]),
    "fit",
  ));
  out.append(facts([["model", f.model + (f.model === "markov" ? ` of order ${f.order}` : "")], ["method", f.method],
    ["intervals", f.interval_method]]));
  out.append(warningBox(f.warnings) || "");
  return out;
}

function renderAnalyze(r) {
  const out = document.createDocumentFragment();
  out.append(exactHeadline(r.verdict, []));
  out.append(warningBox(r.warnings) || "");
  const ch = r.channel || {};
  const cap = r.critical_arrival_probability_exact === null && r.critical_arrival_probability === null;
  out.append(facts([
    ["critical arrival probability", cap
      ? (ch.model === "gilbert_elliott" ? "no single arrival probability: see the critical rates below"
        : ch.model === "per_sensor" ? "one per sensor: see below"
          : r.critical_parameter ? "no single arrival probability: see the critical value of the parameter below"
            : "not defined for this channel (it has no single arrival probability)")
      : num(r.critical_arrival_probability_exact, r.critical_arrival_probability)],
    ["channel", channelText(ch)],
    ["system", r.system ? `n = ${r.system.n}, p = ${r.system.p}` : null],
    ["theorem", r.theorem],
  ]));
  if (r.gilbert_elliott_region) out.append(gilbertElliottSection(r.gilbert_elliott_region, ch));
  else if (ch.model === "gilbert_elliott") out.append(el("p", "The critical rates were not computed for this channel: see the warnings.", "note"));
  if (r.critical_parameter) out.append(criticalParameterSection(r.critical_parameter));
  else if (ch.model === "markov") {
    out.append(el("p", "Ask for the critical value of one arrival probability with options.analyze.critical_parameter, "
      + 'for example "/channel/arrival_probability/01".', "note"));
  }
  if (r.fit) out.append(fitSection(r.fit));
  if (r.regions) out.append(regionsSection(r.regions));
  if (r.tail) out.append(tailSection(r.tail));
  out.append(el("h3", "Blocks (one per class of eigenvalues with the same modulus up to a root of unity)"));
  out.append(table(
    ["eigenvalues", "verdict", "rate |alpha|^2 sigma", "|alpha|", "sigma", "period", "basis"],
    (r.blocks || []).map((b) => [
      eigenvalues(b.eigenvalues, b.eigenvalues_numeric),
      b.verdict,
      dec(b.rate),
      num(b.modulus_exact, b.modulus),
      num(b.sigma_exact, b.sigma),
      b.degenerate ? `${b.period}, degenerate` : b.period,
      b.basis,
    ]),
    "blocks",
  ));
  out.append(list("Assumptions", r.assumptions));
  return out;
}

// ---------------------------------------------------------------- bounds and simulate: evidence beside the exact verdict

/** The headline when the exact verdict comes from a separate analyze (``exact``: its report or a problem). */
function headlineFrom(exact, lines) {
  if (exact && exact.verdict) return exactHeadline(exact.verdict, lines);
  const why = exact && (exact.detail || exact.title) ? exact.detail || exact.title : "the exact analysis was not run";
  return headline(null, `no exact verdict was computed: ${why}`, ["Run Analyze for the exact verdict.", ...lines]);
}

/** Significant digits that tell the two bounds apart (6 to 12). */
const boundDigits = (gap) => (typeof gap === "number" && gap > 0 ? Math.min(12, Math.max(6, Math.ceil(-Math.log10(gap)) + 2)) : 6);

function renderBounds(r, exact) {
  const out = document.createDocumentFragment();
  const op = r.operating_point || {};
  const byBounds = el("p", null, "evidence");
  put(byBounds, el("strong", "Bounds: "), op.reason ? `${op.verdict_by_bounds}; ${op.reason}.` : `${BOUNDS_MEANING[op.verdict_by_bounds] || op.verdict_by_bounds}.`);
  out.append(headlineFrom(exact, [byBounds]));
  const cp = r.critical_probability || {};
  const lo = cp.lower || {}, up = cp.upper || {};
  const digits = boundDigits(cp.gap);
  const bounds = facts([
    ["critical probability, lower bound", lo.value === undefined ? undefined : num(lo.exact, lo.value, digits)],
    ["critical probability, upper bound (LMI)", up.value === undefined ? undefined : num(up.exact, up.value, digits)],
    ["gap", cp.gap === undefined ? undefined : dec(cp.gap, 3)],
    ["exact critical arrival probability", exact && exact.verdict ? (exact.critical_arrival_probability === null && exact.critical_arrival_probability_exact === null
      ? "not defined for this channel" : num(exact.critical_arrival_probability_exact, exact.critical_arrival_probability)) : undefined],
    ["spectral radius of A", r.spectral_radius_A === undefined ? undefined : dec(r.spectral_radius_A)],
    ["variance threshold", r.variance_threshold ? `${dec(r.variance_threshold.value)} (${r.variance_threshold.meaning})` : undefined],
    ["trace S_bar (lower bound on E[P])", r.covariance && r.covariance.S_bar ? dec(r.covariance.S_bar.trace) : undefined],
    ["trace V_bar (upper bound on E[P])", r.covariance && r.covariance.V_bar ? dec(r.covariance.V_bar.trace) : undefined],
  ]);
  bounds.id = "bounds";
  out.append(bounds);
  if (Array.isArray(r.sensors) && r.sensors.length) {
    out.append(el("h3", "Critical probability of each sensor, the others held at their own (Liu and Goldsmith 2004)"));
    out.append(table(["sensor", "lower bound", "upper bound (LMI)", "gap"], r.sensors.map((s) => {
      const ci = s.critical_interval || {};
      const l = ci.lower || {}, u = ci.upper || {};
      const dg = boundDigits(ci.gap);
      return [s.name, num(l.exact, l.value, dg), num(u.exact, u.value, dg), ci.gap === undefined ? "-" : dec(ci.gap, 3)];
    }), "sensors"));
  }
  if (r.packets) out.append(el("h3", "Packets"), table(["name", "rows", "arrival probability"], r.packets.map((p) => [p.name || "-", JSON.stringify(p.rows), num(p.arrival_probability_exact, p.arrival_probability)])));
  out.append(list("Notes", r.notes));
  return out;
}

/** "Monte Carlo: sample mean unreliable, kappa = 0.44; read the quantiles." */
function monteCarloLine(r) {
  const st = r.stationary || {};
  let text;
  if (st.mean_unreliable) text = `sample mean unreliable, kappa = ${dec(st.tail_exponent_exact, 2)}; read the quantiles`;
  else if (r.diverged) text = `the sample mean of trace(P_t) diverged at step ${r.mean_diverged_at}`;
  else text = `the sample mean of trace(P_t) stayed finite over ${r.steps} steps (evidence, not proof)`;
  const p = el("p", null, "evidence");
  p.id = "monte-carlo";
  return put(p, el("strong", "Monte Carlo: "), `${text}.`);
}

/** The CLI's agreement line: steps inside the 95% band, the zero-width ones (every trajectory alike) apart. */
function agreementText(a) {
  const fixed = a.deterministic_steps || 0;
  const random = a.steps_compared - fixed;
  let text = `${a.within_ci95} of ${random} ${fixed ? "random " : ""}exact steps inside the 95% band`;
  if (fixed) {
    const equal = a.deterministic_equal === fixed ? "equal to the exact value" : `${fixed - a.deterministic_equal} of them NOT equal to the exact value`;
    text += `; ${fixed === 1 ? "1 step" : `${fixed} steps`} with a zero-width band (every trajectory alike) skipped: ${equal}`;
  }
  return text;
}

function renderSimulate(r, exact) {
  const out = document.createDocumentFragment();
  const last = (a) => (Array.isArray(a) && a.length ? a[a.length - 1] : null);
  const st = r.stationary || {};
  const verdict = st.verdict ? { verdict: st.verdict } : exact;
  out.append(headlineFrom(verdict, [monteCarloLine(r)]));
  out.append(warningBox(st.warnings) || "");
  const growth = st.exact_mean_growth_per_step;
  out.append(facts([
    ["steps x trajectories", `${r.steps} x ${r.trajectories} (seed ${r.seed})`],
    ["exact growth of E[P_t]", typeof growth === "number" ? `x${dec(growth, 4)} per step (${THEOREM_1} rate)` : undefined],
    ["tail exponent kappa", st.tail_exponent_exact === undefined ? undefined
      : put(el("span"), num(st.tail_exponent_exact_text, st.tail_exponent_exact, 4),
        typeof st.tail_exponent_hill === "number" ? `; Hill estimate from the samples ${dec(st.tail_exponent_hill, 3)}` : "")],
    [st.mean_unreliable ? "sample mean at the last step (unreliable)" : "sample mean at the last step", dec(last(r.mean_trace))],
    [st.mean_unreliable ? "its 95% band (not to be trusted)" : "its 95% band", `${dec(last(r.ci95_low))} to ${dec(last(r.ci95_high))}`],
    ["diverged trajectories", r.diverged_trajectories],
    ["exact agreement", r.checks && r.checks.exact_agreement ? agreementText(r.checks.exact_agreement) : undefined],
  ]));
  if (Array.isArray(st.quantiles) && st.quantiles.length) {
    out.append(el("h3", `Quantiles of trace(P_${st.step}) over ${st.samples} trajectories (Kar, Sinopoli and Moura 2012)`));
    out.append(table(["quantile", "trace(P_T)", "95% interval"], st.quantiles.map((q) => [
      `${dec(100 * q.q, 4)}%`, dec(q.trace), q.ci95 ? `${dec(q.ci95[0])} to ${q.ci95[1] === null ? "unbounded" : dec(q.ci95[1])}` : "-",
    ]), "quantiles"));
  }
  return out;
}

// ---------------------------------------------------------------- loop: a closed loop over lossy sensor and actuator links

const LOOP_THEOREM = "Costa, Fragoso and Marques 2005, Theorem 3.9";

const LOOP_MEANING = {
  stable: "The loop is mean-square stable: E[x x'] of the plant and the estimate settles, and the average cost is finite.",
  unstable: "The loop is not mean-square stable: the second moments grow without bound and the average cost is infinite.",
  boundary: "Exactly on the edge: the second-moment operator has spectral radius 1. Any better link is stable.",
};

/** A link's critical value: its decimal with the exact text, or why there is none. */
function loopCritical(value, exact, c) {
  if (value !== null && value !== undefined) return num(exact, value);
  return c && c.note ? c.note : "not defined for this link";
}

function renderLoop(r) {
  const out = document.createDocumentFragment();
  out.append(headline(r.verdict, `exact verdict (${LOOP_THEOREM})`, [LOOP_MEANING[r.verdict]]));
  const crit = (link) => (r.critical_values || []).find((c) => (link === "actuator") === (c.link === "actuator"));
  const est = r.estimator_alone || {};
  const d = facts([
    ["stationary cost lim E[x'Wx + a'Ua]", r.cost === null ? "unbounded (the loop is not mean-square stable)" : num(r.cost_exact, r.cost)],
    ["critical sensor arrival probability", loopCritical(r.critical_sensor_arrival_probability, r.critical_sensor_arrival_probability_exact, crit("sensor"))],
    ["critical actuator arrival probability", loopCritical(r.critical_actuator_arrival_probability, r.critical_actuator_arrival_probability_exact, crit("actuator"))],
    ["spectral radius of the second-moment operator", num(r.spectral_radius_exact, r.spectral_radius)],
    ["certificate", `${r.certificate}${r.certified ? " (certified)" : ""}; operator size ${r.operator_size}, ${r.modes} channel mode(s)`],
    ["loop", r.loop ? `${r.loop.protocol === "tcp" ? "TCP-like" : "UDP-like"}, lost input ${r.loop.on_loss === "zero" ? "set to zero" : "held"}, ${r.loop.form} gains` : undefined],
  ]);
  d.id = "loop";
  out.append(d);
  if (r.fit) out.append(fitSection(r.fit));
  out.append(el("h3", "The estimator alone, with the same fixed gain (no control)"));
  const cmp = el("p", est.statement ? `${est.statement.charAt(0).toUpperCase()}${est.statement.slice(1)}.` : (est.optimal_filter_note || "No comparison for this channel."), "advice");
  cmp.id = "estimator-alone";
  out.append(cmp);
  out.append(facts([
    ["verdict of the estimator alone", est.verdict],
    ["its stationary error trace", est.stationary_error_trace === null ? "unbounded" : num(est.stationary_error_trace_exact, est.stationary_error_trace)],
    ["its critical sensor arrival probability", loopCritical(est.critical_sensor_arrival_probability, est.critical_sensor_arrival_probability_exact, est.critical_value)],
    ["the optimal time-varying filter's (Rohr, Marelli and Fu 2014)", loopCritical(est.optimal_filter_critical_arrival_probability, est.optimal_filter_critical_arrival_probability_exact, { note: est.optimal_filter_note })],
  ]));
  if (r.lqg) out.append(...renderLqg(r.lqg));
  if (r.udp_region_bounds) out.append(...renderUdpBounds(r.udp_region_bounds));
  out.append(list("Notes", [r.theorem, r.model, ...(r.notes || [])]));
  return out;
}

/** The optimal TCP-like LQG part of a loop report: its verdict and critical values beside the stationary gains', and the cost bounds. */
function renderLqg(lqg) {
  const o = lqg.optimal || {};
  const nu = o.critical_actuator || {};
  const b = o.cost_bounds || {};
  const nuText = o.critical_actuator_arrival_probability !== null && o.critical_actuator_arrival_probability !== undefined
    ? num(o.critical_actuator_arrival_probability_exact, o.critical_actuator_arrival_probability)
    : nu.upper !== null && nu.upper !== undefined ? `between ${dec(nu.lower)} and ${dec(nu.upper)} (bracket)` : (nu.from || "not available");
  const lamText = o.critical_sensor_arrival_probability !== null && o.critical_sensor_arrival_probability !== undefined
    ? num(o.critical_sensor_arrival_probability_exact, o.critical_sensor_arrival_probability) : "no sensor arrival probability suffices";
  const bounds = b.lower !== null && b.lower !== undefined && b.upper !== null && b.upper !== undefined
    ? `between ${dec(b.lower)} and ${dec(b.upper)}` : `not available${b.reason ? `: ${b.reason}` : ""}`;
  const d = facts([
    ["verdict of the optimal TCP-like controller", o.verdict],
    ["the optimal filter needs a sensor arrival probability above (Rohr, Marelli and Fu 2014)", lamText],
    ["the control equation converges iff the actuator arrival probability exceeds", nuText],
    ["optimal TCP-like LQG cost J (bounds, Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. V)", bounds],
    ["lower bound from", b.lower_from],
    ["upper bound from", b.upper_from],
    ["the paper's upper bound", b.paper_upper === null || b.paper_upper === undefined ? undefined : dec(b.paper_upper)],
    ["stationary gains analyzed above", lqg.stationary_gains ? (lqg.stationary_gains.exist ? `${lqg.stationary_gains.form} form` : "none exist here") : undefined],
  ]);
  d.id = "loop-lqg";
  const src = el("p", [o.statement, ...(o.reasons || []), b.formula, b.applies_to].filter(Boolean).map(capitalized).join(". ") + ".", "note");
  return [el("h3", "Optimal LQG over the lossy links (TCP-like) beside the exact analysis of the stationary gains"), d, src];
}

/** Bounds on the optimal UDP-like controller's critical region (labelled as bounds). */
function renderUdpBounds(u) {
  const o = u.outer || {};
  const above = (v, exact) => (v === null || v === undefined ? "no bound here" : put(el("span"), "above ", num(exact, v)));
  const d = facts([
    ["sensor arrival probability", above(o.sensor_arrival_probability_above, o.sensor_arrival_probability_above_exact)],
    ["actuator arrival probability", above(o.actuator_arrival_probability_above, o.actuator_arrival_probability_above_exact)],
    ["the request's point inside the outer bound", u.request_point_inside_optimal_region === null || u.request_point_inside_optimal_region === undefined ? undefined : (u.request_point_inside_optimal_region ? "yes" : "no")],
  ]);
  d.id = "loop-udp";
  return [el("h3", "Optimal UDP-like controller: what any design needs (bounds)"), d, el("p", `${capitalized(u.kind || "")}. Inner bound: ${u.inner || ""}.`, "note")];
}

/** ``text`` with its first letter in upper case (report strings start a sentence on the page). */
function capitalized(text) {
  return text ? text.charAt(0).toUpperCase() + text.slice(1) : text;
}

// ---------------------------------------------------------------- plots beside the numbers

function plotsFor(endpoint, request) {
  if (endpoint === "loop") {
    return [["loop-region", "The loop's exact stable region over the two links' parameters, and its exact cost along each link, the request marked"]];
  }
  if (endpoint === "simulate") return [["simulation", "Simulated trace(P_t): mean, 95% band and percentiles"]];
  const ch = request && request.channel;
  if (!ch) return [];
  if (ch.model === "trace") return [["trace-region", "The confidence region of the channel fitted to the trace, over the exact stable region"]];
  if (ch.model === "bernoulli") return [["phase-transition", "trace(S_bar) and trace(V_bar) against the arrival probability, critical values marked (Sinopoli et al. 2004, Figs. 1-3)"]];
  if (ch.model === "gilbert_elliott") {
    return [["ge-region", "Exact stability region in the (recovery rate q, failure rate p) square, the request's point marked (Rohr, Marelli and Fu 2014, Theorem 1)"]];
  }
  if (ch.model === "per_sensor" && ch.channels && Object.keys(ch.channels).length === 2) {
    return [["region", "Stability region of the two arrival probabilities, exact boundary overlaid (Liu and Goldsmith 2004, Figs. 4-5)"]];
  }
  return [];
}
