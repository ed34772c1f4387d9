"use strict";
// voiopt show: the plan viewer. Every number comes from the embedded data, which voiopt's
// simulator wrote; nothing is computed here but drawing. API: docs/viewer.md.
(function () {
  const DATA = JSON.parse(document.getElementById("voiopt-data").textContent);
  const num = (v) => (v === null || v === undefined ? null : Number(v)); // "Infinity" -> Infinity
  const inst = DATA.instance;
  const T = inst.T;
  const results = DATA.results.map((r) => ({
    ...r,
    voi: r.voi.map((row) => row.map(num)),
    value: num(r.value), bound: num(r.bound), gap: num(r.gap),
  }));
  const NS = document.getElementById("svg-namespace").namespaceURI; // the page names no URL, not even this one
  const ROBOT = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#17becf"];
  const SENSOR = ["#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#bab0ac"];
  const VIRIDIS = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];
  const SPEEDS = [1, 2, 4, 8, 16];

  // ---------------------------------------------------------------- helpers
  function el(tag, attrs, parent, text) {
    const e = document.createElementNS(NS, tag);
    for (const k in attrs || {}) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }
  function html(tag, cls, parent, text) {
    const e = document.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }
  function fmt(v, digits) {
    if (v === null || v === undefined) return "\u2014";
    if (!isFinite(v)) return String(v);
    const a = Math.abs(v);
    if (a !== 0 && (a >= 1e6 || a < 1e-3)) return v.toExponential((digits || 4) - 1);
    return Number(v.toPrecision(digits || 4)).toLocaleString("en-US", { maximumFractionDigits: 6 });
  }
  function rate(v) { // bit/s with an SI prefix
    if (v === null || !isFinite(v)) return fmt(v);
    const units = [[1e9, "Gbit/s"], [1e6, "Mbit/s"], [1e3, "kbit/s"], [1, "bit/s"]];
    for (const [f, u] of units) if (Math.abs(v) >= f) return fmt(v / f) + " " + u;
    return fmt(v) + " bit/s";
  }
  function hex(c) { return [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16)); }
  function viridis(f) {
    f = Math.min(1, Math.max(0, isFinite(f) ? f : 1)) * (VIRIDIS.length - 1);
    const i = Math.min(VIRIDIS.length - 2, Math.floor(f)), w = f - i;
    const a = hex(VIRIDIS[i]), b = hex(VIRIDIS[i + 1]);
    return "rgb(" + a.map((x, k) => Math.round(x + (b[k] - x) * w)).join(",") + ")";
  }
  // one log scale of VoI for every map and chart on the page
  const finiteVoi = results.flatMap((r) => r.voi.flat()).filter((v) => isFinite(v) && v > 0);
  const lowest = finiteVoi.reduce((a, b) => Math.min(a, b), Infinity);
  const highest = finiteVoi.reduce((a, b) => Math.max(a, b), 0);
  const LOG_LO = finiteVoi.length ? Math.floor(Math.log10(lowest)) : 0;
  const LOG_HI = Math.max(LOG_LO + 1, finiteVoi.length ? Math.ceil(Math.log10(highest)) : 1);
  const voiColour = (v) => viridis((Math.log10(v) - LOG_LO) / (LOG_HI - LOG_LO));

  // ---------------------------------------------------------------- the page
  document.getElementById("title").textContent = "voiopt \u00b7 " + inst.name;
  const K = inst.robots.length, N = inst.sensors.length;
  document.getElementById("about").textContent =
    `${inst.width} \u00d7 ${inst.height} m, step ${inst.step} m, T = ${T} slots, ${N} sensor${N > 1 ? "s" : ""}, ` +
    `${K} robot${K > 1 ? "s" : ""}, d_th = ${inst.d_th} m` + (inst.blocked.length ? `, ${inst.blocked.length} blocked points` : "") +
    (results.length > 1 ? ` \u2014 ${results.length} ${results.some((r) => r.kind === "policy") ? "results" : "plans"} on one timeline` : "");
  const sampled = results.find((r) => r.run);
  document.getElementById("note").textContent =
    "Slot t shows p_k(t), A_i(t) and V_i(t) before slot t's upload takes effect (MODEL.md sections 3, 4, 10). " +
    (sampled ? `Lossy links: the map, the charts and the table show one sampled run (seed ${sampled.run.seed}; ` +
      "every result on the page meets the same outcomes), simulated by voiopt; the value in each header is the " +
      "expected objective, exact or a Monte Carlo estimate as labelled. "
      : "Every value is voiopt's simulation of the plan. ") +
    "Gaps: proven = an exact value and a proven bound; estimate = a Monte Carlo value's gap (with the range " +
    "its CI implies); statistical = to a bound estimated from samples (information relaxation), never proven.";

  const cards = results.map((r, j) => buildCard(r, j));
  buildScale(document.getElementById("scale"));

  function buildCard(r, j) {
    const card = html("section", "card", document.getElementById("results"));
    const h = html("h2", "", card);
    html("span", "", h, r.method ? r.method : "plan");
    if (r.status) html("span", "badge status", h, r.status);
    if (r.kind === "policy") html("span", "badge status", h, "policy: adapts to outcomes");
    html("span", "file", h, r.label);
    const facts = html("p", "facts", card);
    const fact = (k, v) => { const s = html("span", "", facts); html("b", "", s, k + " "); s.append(v); return s; };
    const sim = r.simulated[r.objective];
    if (r.evaluation) { // lossy links: the expected objective, exact or estimated, and this run's own value
      fact(r.objective, fmt(r.value, 6) + (r.evaluation === "exact" ? " (exact expectation)" : " (Monte Carlo estimate" +
        (r.valueCi ? `, 95 % CI [${fmt(num(r.valueCi[0]), 6)}, ${fmt(num(r.valueCi[1]), 6)}]` : "") +
        (r.samples ? `, ${r.samples} samples` : "") + ")"));
      if (r.run) fact("this sampled run", fmt(sim, 6));
    } else {
      fact(r.objective, fmt(r.run ? r.value : sim, 6));
    }
    if (r.status) {
      fact("bound", r.bound === null ? "none" : fmt(r.bound, 6) + (r.boundKind ? ` (${r.boundKind})` : ""));
      const g = fact("gap", r.gap === null ? "none" : r.gapText + (r.gapRange ? ` [${r.gapRange[0]}, ${r.gapRange[1]}]` : ""));
      if (r.gap !== null) { g.append(" "); html("span", "badge " + r.gapKind, g, r.gapKind); }
    }
    if (r.run) {
      const failures = r.run.failed.flat().filter(Boolean).length;
      fact("sampled run", `seed ${r.run.seed}, ${failures} failed upload${failures === 1 ? "" : "s"} marked \u00d7`);
    }
    const body = html("div", "body", card);
    const mapBox = html("div", "map", body);
    const map = buildMap(mapBox, r, j);
    html("p", "legend", mapBox, "\u25a1 start \u00b7 \u25c7 end (dock) \u00b7 \u25cf red: upload" + (r.run ? " that succeeded" : "") + " \u00b7 dashed red: uploading now" +
      (inst.blocked.length ? " \u00b7 \u25a0 blocked" : "") + (r.run ? " \u00b7 \u00d7 failed upload" : "") +
      " \u00b7 dashed circle: range d_th");
    const side = html("div", "side", body);
    const ofRun = r.run ? ` \u00b7 the sampled run (seed ${r.run.seed})` : "";
    html("h3", "", side, "VoI V_i(t), bit/s, log scale \u00b7 black: least VoI" + ofRun);
    const voiChart = buildChart(side, r.voi, true, (t) => Math.min(...r.voi[t]));
    html("h3", "", side, "AoI A_i(t), slots" + ofRun);
    const aoiChart = buildChart(side, r.aoi, false, null);
    const now = html("p", "now", side);
    const box = html("div", "table", side);
    const table = html("table", "", box);
    const head = html("tr", "", html("thead", "", table));
    ["sensor", "rho", "V_i(t)", "A_i(t)"].forEach((c) => html("th", "", head, c));
    const tbody = html("tbody", "", table);
    const rows = inst.sensors.map((s, i) => {
      const tr = html("tr", "", tbody);
      const name = html("td", "", tr);
      html("span", "swatch", name).style.background = SENSOR[i % SENSOR.length];
      name.append("s" + i);
      html("td", "", tr, s.rho.toFixed(3));
      return [tr, html("td", "", tr), html("td", "", tr)];
    });
    return { r, map, voiChart, aoiChart, now, rows };
  }

  // ---------------------------------------------------------------- the map
  function buildMap(holder, r, j) {
    const pad = Math.max(0.6 * inst.step, Math.min(inst.d_th + 0.15, 0.35 * Math.max(inst.width, inst.height)));
    const W = inst.width + 2 * pad, H = inst.height + 2 * pad;
    const S = 460 / Math.max(W, H);
    const X = (x) => (x + pad) * S, Y = (y) => (inst.height + pad - y) * S;
    const svg = el("svg", { viewBox: `0 0 ${W * S} ${H * S}`, role: "img", "aria-label": "area, sensors and paths" }, holder);
    const st = inst.step;
    el("rect", { x: X(0), y: Y(inst.height), width: inst.width * S, height: inst.height * S, fill: "#fbfcfe", stroke: "#c5ccd8" }, svg);
    const grid = el("g", { fill: "#c9d0dc" }, svg);
    const nx = Math.round(inst.width / st), ny = Math.round(inst.height / st);
    const dot = Math.max(0.9, Math.min(2.2, 0.05 * st * S));
    for (let a = 0; a <= nx; a++) for (let b = 0; b <= ny; b++) el("circle", { cx: X(a * st), cy: Y(b * st), r: dot }, grid);
    const blocked = el("g", { fill: "#4a5160" }, svg);
    for (const [x, y] of inst.blocked) el("rect", { x: X(x - st / 2), y: Y(y + st / 2), width: st * S, height: st * S, rx: 1.5 }, blocked);
    const ranges = el("g", { fill: "none", stroke: "#9aa6b8", "stroke-dasharray": "3 3", "stroke-width": 0.8 }, svg);
    for (const s of inst.sensors) el("circle", { cx: X(s.x), cy: Y(s.y), r: inst.d_th * S }, ranges);
    const fixed = el("g", {}, svg);
    inst.robots.forEach((rb, k) => {
      const c = K > 1 ? ROBOT[k % ROBOT.length] : "#1d2330", q = 0.28 * st * S;
      el("rect", { x: X(rb.start[0]) - q / 2, y: Y(rb.start[1]) - q / 2, width: q, height: q, fill: "none", stroke: c, "stroke-width": 1.6 }, fixed)
        .appendChild(el("title", {}, null, `robot ${k} start`));
      if (rb.end) {
        const e = el("path", { d: `M ${X(rb.end[0])} ${Y(rb.end[1]) - q * 0.8} l ${q * 0.8} ${q * 0.8} l ${-q * 0.8} ${q * 0.8} l ${-q * 0.8} ${-q * 0.8} z`,
          fill: "none", stroke: K > 1 ? c : "#1f7a44", "stroke-width": 1.8 }, fixed);
        el("title", {}, e, `robot ${k} end (dock)`);
      }
    });
    const paths = el("g", { fill: "none", "stroke-linejoin": "round", "stroke-linecap": "round" }, svg);
    const marks = el("g", {}, svg);
    const fails = el("g", {}, svg); // over the dots: a failure where an upload also succeeded stays seen
    const sensors = el("g", {}, svg);
    const robots = el("g", {}, svg);
    const sensorDots = inst.sensors.map((s, i) => {
      const g = el("g", {}, sensors);
      const c = el("circle", { cx: X(s.x), cy: Y(s.y), r: Math.max(4.5, Math.min(9, 0.2 * st * S)), stroke: "white", "stroke-width": 1.4 }, g);
      const label = el("text", { x: X(s.x) + 7, y: Y(s.y) - 6, "font-size": 10, fill: "#2b3240", "paint-order": "stroke", stroke: "white", "stroke-width": 3 }, g, "s" + i);
      const tip = el("title", {}, c);
      return { c, label, tip };
    });
    const shift = (k) => (K > 1 ? (k - (K - 1) / 2) * 0.08 * st : 0);
    return {
      draw(t) {
        paths.replaceChildren(); marks.replaceChildren(); fails.replaceChildren(); robots.replaceChildren();
        sensorDots.forEach((d, i) => {
          d.c.setAttribute("fill", voiColour(r.voi[t][i]));
          d.tip.textContent = `sensor ${i}: V = ${rate(r.voi[t][i])}, A = ${r.aoi[t][i]}`;
        });
        for (let k = 0; k < K; k++) {
          const c = ROBOT[k % ROBOT.length], dx = shift(k);
          const xs = r.x[k], ys = r.y[k], us = r.u[k];
          const pts = [];
          for (let s = 0; s <= t; s++) pts.push(`${X(xs[s] + dx).toFixed(1)},${Y(ys[s] + dx).toFixed(1)}`);
          el("polyline", { points: pts.join(" "), stroke: c, "stroke-width": 2.6, opacity: 0.85 }, paths);
          const failed = r.run ? r.run.failed[k] : null;
          for (let s = 0; s <= t; s++) {
            if (us[s] < 0) continue;
            const cx = X(xs[s] + dx), cy = Y(ys[s] + dx), sn = inst.sensors[us[s]];
            if (s === t) { // uploading now: takes effect in slot t + 1
              el("line", { x1: cx, y1: cy, x2: X(sn.x), y2: Y(sn.y), stroke: "#d62728", "stroke-width": 2, "stroke-dasharray": "4 3" }, marks);
            }
            if (failed && failed[s]) {
              const d = `M ${cx - 5} ${cy - 5} L ${cx + 5} ${cy + 5} M ${cx - 5} ${cy + 5} L ${cx + 5} ${cy - 5}`;
              el("path", { d, stroke: "white", "stroke-width": 4.6, "stroke-linecap": "round" }, fails);
              el("path", { d, stroke: "#d62728", "stroke-width": 2.2 }, fails)
                .appendChild(el("title", {}, null, `slot ${s}: upload of sensor ${us[s]} failed`));
            } else {
              el("circle", { cx, cy, r: 4.2, fill: "#d62728", stroke: "white", "stroke-width": 1 }, marks)
                .appendChild(el("title", {}, null, `slot ${s}: robot ${k} uploads sensor ${us[s]}`));
            }
          }
          const g = el("g", {}, robots);
          el("circle", { cx: X(xs[t] + dx), cy: Y(ys[t] + dx), r: 8.5, fill: c, stroke: "white", "stroke-width": 2 }, g);
          el("text", { x: X(xs[t] + dx), y: Y(ys[t] + dx) + 3.5, "font-size": 10, "font-weight": 700, fill: "white", "text-anchor": "middle" }, g, K > 1 ? String(k) : "R");
        }
      },
    };
  }

  // ---------------------------------------------------------------- the charts
  function buildChart(holder, rows, log, least) {
    const Wc = 420, Hc = 150, L = 46, R = 8, Tp = 8, B = 20;
    const svg = el("svg", { viewBox: `0 0 ${Wc} ${Hc}`, role: "img" }, holder);
    const n = rows.length - 1; // slots 0..T
    const vals = rows.flat().filter((v) => isFinite(v) && (!log || v > 0));
    const lo = log ? LOG_LO : 0, hi = log ? LOG_HI : vals.reduce((a, b) => Math.max(a, b), 1);
    const X = (t) => L + (t / Math.max(1, n)) * (Wc - L - R);
    const Y = (v) => {
      const f = log ? (Math.log10(Math.max(v, 10 ** lo)) - lo) / (hi - lo) : (v - lo) / (hi - lo);
      return Tp + (1 - Math.min(1, Math.max(0, isFinite(f) ? f : 1))) * (Hc - Tp - B);
    };
    const axes = el("g", { "font-size": 9, fill: "#5b6475" }, svg);
    const ticks = log ? niceLogTicks(lo, hi) : niceTicks(lo, hi);
    for (const v of ticks) {
      el("line", { x1: L, x2: Wc - R, y1: Y(v), y2: Y(v), stroke: "#edf0f4" }, axes);
      el("text", { x: L - 4, y: Y(v) + 3, "text-anchor": "end" }, axes, log ? "1e" + Math.round(Math.log10(v)) : String(v));
    }
    for (const t of niceTicks(0, n)) el("text", { x: X(t), y: Hc - 6, "text-anchor": "middle" }, axes, String(t));
    el("line", { x1: L, x2: L, y1: Tp, y2: Hc - B, stroke: "#aab3c2" }, axes);
    const lines = el("g", { fill: "none", "stroke-width": 1.1, opacity: 0.75 }, svg);
    const N = rows[0].length;
    for (let i = 0; i < N; i++) {
      const d = rows.map((row, t) => `${t ? "L" : "M"}${X(t).toFixed(1)} ${Y(row[i]).toFixed(1)}`).join("");
      el("path", { d, stroke: SENSOR[i % SENSOR.length] }, lines);
    }
    if (least) {
      const d = rows.map((_, t) => `${t ? "L" : "M"}${X(t).toFixed(1)} ${Y(least(t)).toFixed(1)}`).join("");
      el("path", { d, stroke: "#111", "stroke-width": 2.2, fill: "none" }, svg);
    }
    const cursor = el("line", { y1: Tp, y2: Hc - B, stroke: "#d62728", "stroke-width": 1.5 }, svg);
    return { draw(t) { cursor.setAttribute("x1", X(t)); cursor.setAttribute("x2", X(t)); } };
  }
  function niceTicks(lo, hi) {
    const span = Math.max(1, hi - lo), raw = span / 4, p = 10 ** Math.floor(Math.log10(raw));
    const step = [1, 2, 5, 10].map((m) => m * p).find((s) => s >= raw);
    const out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9; v += step) out.push(Math.round(v));
    return out;
  }
  function niceLogTicks(lo, hi) {
    const every = Math.max(1, Math.ceil((hi - lo) / 5)), out = [];
    for (let e = lo; e <= hi; e += every) out.push(10 ** e);
    return out;
  }
  function buildScale(holder) {
    holder.append("sensor colour: V_i(t), bit/s ");
    const svg = el("svg", { width: 272, height: 26, viewBox: "-6 0 272 26", style: "vertical-align: middle" }, holder);
    const bands = 62; // the colour bar as bands: no gradient reference, the page names nothing outside itself
    for (let b = 0; b < bands; b++) el("rect", { x: 6 + 248 * b / bands, y: 2, width: 248 / bands + 0.4, height: 10, fill: viridis(b / (bands - 1)) }, svg);
    for (const v of niceLogTicks(LOG_LO, LOG_HI)) {
      const x = 6 + 248 * (Math.log10(v) - LOG_LO) / (LOG_HI - LOG_LO);
      el("text", { x, y: 24, "font-size": 9, "text-anchor": "middle", fill: "#5b6475" }, svg, "1e" + Math.round(Math.log10(v)));
    }
  }

  // ---------------------------------------------------------------- the timeline
  const slider = document.getElementById("slider"), label = document.getElementById("slot-label");
  const playButton = document.getElementById("play"), speed = document.getElementById("speed");
  slider.max = String(T - 1);
  SPEEDS.forEach((s) => { const o = html("option", "", speed, s + " slot/s"); o.value = String(s); });
  speed.value = String(T > 60 ? 8 : 2);
  let slot = 0, timer = null;

  function setSlot(t) {
    if (!Number.isInteger(t) || t < 0 || t >= T) throw new RangeError(`setSlot: t must be an integer in 0..${T - 1}, got ${t}`);
    slot = t;
    slider.value = String(t);
    label.textContent = `slot ${t} of 0\u2013${T - 1}`;
    for (const c of cards) {
      c.map.draw(t); c.voiChart.draw(t); c.aoiChart.draw(t);
      const v = c.r.voi[t], least = Math.min(...v), who = v.indexOf(least);
      const up = c.r.u.map((us, k) => (us[t] < 0 ? null : `robot ${K > 1 ? k + " " : ""}uploads s${us[t]}` +
        (c.r.run && c.r.run.failed[k][t] ? " (fails in this sampled run)" : ` (takes effect in slot ${t + 1})`))).filter(Boolean);
      c.now.innerHTML = "";
      c.now.append("least VoI ");
      html("b", "", c.now, rate(least));
      c.now.append(` (s${who}) \u00b7 ` + (up.length ? up.join(", ") : "no upload in this slot"));
      c.rows.forEach(([tr, vc, ac], i) => {
        vc.textContent = rate(v[i]); ac.textContent = String(c.r.aoi[t][i]);
        tr.className = i === who ? "least" : "";
      });
    }
    return slot;
  }
  function state() {
    const r = results[0];
    return {
      slot,
      positions: r.x.map((xs, k) => [xs[slot], r.y[k][slot]]),
      aoi: r.aoi[slot].slice(),
      voi: r.voi[slot].slice(),
    };
  }
  const ICONS = {
    first: "M5 4h2v12H5z M16 4v12L8 10z", back: "M14 4v12L6 10z", play: "M6 4v12l10-6z",
    pause: "M5 4h4v12H5z M11 4h4v12h-4z", next: "M6 4v12l8-6z", last: "M4 4v12l8-6z M13 4h2v12h-2z",
  };
  const icon = (button, name) => { button.replaceChildren(); el("path", { d: ICONS[name] }, el("svg", { viewBox: "0 0 20 20", width: 16, height: 16, fill: "currentColor" }, button)); };
  ["first", "back", "next", "last"].forEach((b) => icon(document.getElementById(b), b));
  function pause() { if (timer) clearInterval(timer); timer = null; icon(playButton, "play"); playButton.classList.remove("on"); }
  function play() {
    pause();
    if (slot >= T - 1) setSlot(0);
    icon(playButton, "pause"); playButton.classList.add("on");
    timer = setInterval(() => { if (slot >= T - 1) pause(); else setSlot(slot + 1); }, 1000 / Number(speed.value));
  }
  const step = (d) => { pause(); setSlot(Math.min(T - 1, Math.max(0, slot + d))); };
  slider.addEventListener("input", () => { pause(); setSlot(Number(slider.value)); });
  playButton.addEventListener("click", () => (timer ? pause() : play()));
  document.getElementById("back").addEventListener("click", () => step(-1));
  document.getElementById("next").addEventListener("click", () => step(1));
  document.getElementById("first").addEventListener("click", () => { pause(); setSlot(0); });
  document.getElementById("last").addEventListener("click", () => { pause(); setSlot(T - 1); });
  speed.addEventListener("change", () => { if (timer) play(); });
  const faster = (d) => {
    const i = Math.min(SPEEDS.length - 1, Math.max(0, SPEEDS.indexOf(Number(speed.value)) + d));
    speed.value = String(SPEEDS[i]); if (timer) play();
  };
  document.addEventListener("keydown", (e) => {
    if (e.target === speed) return;
    const keys = {
      " ": () => (timer ? pause() : play()), ArrowRight: () => step(1), ArrowLeft: () => step(-1),
      Home: () => { pause(); setSlot(0); }, End: () => { pause(); setSlot(T - 1); },
      "+": () => faster(1), "=": () => faster(1), "-": () => faster(-1),
    };
    if (keys[e.key]) { e.preventDefault(); keys[e.key](); }
  });

  icon(playButton, "play");
  setSlot(0);
  window.voiopt = Object.freeze({ setSlot, state, play, pause, slot: () => slot, T, results: results.length });
})();
