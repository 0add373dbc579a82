// softplc web page: plain JavaScript, no libraries, nothing loaded from elsewhere.
//
// Data: GET /api/info once (project, lines, modules, tags, program), GET /api/state and
// /api/trend to start, then the server-sent events `state` (every cycle) and `stats` (every
// refresh of the statistics) from /api/events. Writes: POST /api/force, /api/write and /api/unforce with
// `Authorization: Bearer TOKEN`; the token stays in this tab's sessionStorage.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const SVG = "http://www.w3.org/2000/svg";
  const TREND_WINDOW_MS = 60000;
  const PALETTE = ["#2f6fde", "#17a34a", "#d98a06", "#a43fd1", "#d33a2c", "#0e9aa7", "#7a5c2e", "#db4fa0"];
  const PHASE_TITLES = {
    cycle: ["Cycle time", "start of the input phase to the end of the boundary (or of the writes, if later)"],
    read: ["Input phase", "every line read, in parallel"],
    logic: ["Logic phase", "the program"],
    write: ["Output phase", "changed outputs written, to the modules' acknowledgement"],
    boundary: ["Boundary", "traces, control requests, the services' changes, a reload"],
    lateness: ["Wake-up lateness", "start of a cycle after its deadline"],
  };
  const QUALITY = ["good", "stale", "bad"];
  // A service's state drawn as a quality: running good, degraded stale, stopped bad.
  const SERVICE_QUALITY = { running: "good", degraded: "stale", stopped: "bad" };

  const app = {
    info: null,
    state: null,
    stats: null,
    rate: null, // { at, requests: [] } for requests per second
    trend: { tags: [], t: [], series: [] },
    rtt: { t: [], series: [] }, // per module, from the stats events
    token: sessionStorage.getItem("softplc-token") || "",
    // "operator" (writes values once) or "engineer" (also forces and arms traces): what the
    // server said the token is, at sign-in. The server checks every request anyway.
    role: sessionStorage.getItem("softplc-role") || "",
    cells: [], // per tag: the I/O table's cells
    codeTags: [], // per program tag occurrence: { tag, span, val }
    ladders: [], // the ladder view of each ladder program: { update(state) }
    lastEvent: 0,
    connected: false,
  };

  // ---- DOM helpers ----

  const { el, fmtValue, toast } = window.softplcShared;

  function svg(tag, attrs, text) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  // ---- Formatting ----

  function fmtMs(ms) {
    if (ms === null || ms === undefined || !isFinite(ms)) return "–";
    if (ms < 1) return Math.round(ms * 1000) + " µs";
    if (ms < 10) return ms.toFixed(2) + " ms";
    if (ms < 100) return ms.toFixed(1) + " ms";
    if (ms < 10000) return ms.toFixed(0) + " ms";
    return (ms / 1000).toFixed(1) + " s";
  }

  function fmtAge(ms) {
    if (!isFinite(ms)) return "–";
    if (ms < 1000) return Math.round(ms) + " ms";
    if (ms < 60000) return (ms / 1000).toFixed(1) + " s";
    if (ms < 3600000) return Math.floor(ms / 60000) + " min " + Math.floor((ms % 60000) / 1000) + " s";
    return (ms / 3600000).toFixed(1) + " h";
  }

  function fmtUptime(ms) {
    const s = Math.floor(ms / 1000);
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), r = s % 60;
    if (h > 0) return h + " h " + String(m).padStart(2, "0") + " min";
    if (m > 0) return m + " min " + String(r).padStart(2, "0") + " s";
    return (ms / 1000).toFixed(1) + " s";
  }


  function asNumber(v) {
    if (typeof v === "boolean") return v ? 1 : 0;
    return typeof v === "number" ? v : null;
  }


  async function getJSON(path) {
    const r = await fetch(path, { cache: "no-store" });
    if (!r.ok) throw new Error(path + ": " + r.status);
    return r.json();
  }

  // ---- Views ----

  function showView() {
    let v = (location.hash || "#overview").slice(1);
    if (!document.querySelector('.view[data-view="' + v + '"]')) v = "overview";
    for (const s of document.querySelectorAll(".view")) s.classList.toggle("active", s.dataset.view === v);
    for (const a of document.querySelectorAll(".tabs a")) a.classList.toggle("active", a.dataset.view === v);
    document.body.dataset.view = v;
    if (v === "overview") renderTrend();
    if (v === "bus") renderRtt();
    if (v === "trace") renderTraceView();
  }

  // ---- Writes ----

  function signedIn() {
    return app.info && app.info.writes && app.token !== "";
  }

  // Signed in with the operator's token: the controls it may not use are hidden.
  function operatorOnly() {
    return signedIn() && app.role === "operator";
  }

  function post(path, body, token) {
    return window.softplcShared.post(path, body, token ?? app.token);
  }

  async function force(tag, value) {
    const r = await post("/api/force", { tag, value });
    toast(r.ok ? r.message : "Not forced: " + r.error, !r.ok);
    renderAudit();
  }

  // A write sets the value once, at the next cycle boundary; the program (or the module) owns
  // the tag again from its next scan.
  async function write(tag, value) {
    const r = await post("/api/write", { tag, value });
    toast(r.ok ? r.message : "Not written: " + r.error, !r.ok);
    renderAudit();
  }

  async function unforce(tag) {
    const r = await post("/api/unforce", { tag });
    toast(r.ok ? (tag + " unforced") : "Not unforced: " + r.error, !r.ok);
    renderAudit();
  }

  function renderAuth() {
    const box = $("auth");
    box.replaceChildren();
    if (!app.info.writes) {
      box.append(el("span", { class: "off", text: "read-only", title: "Forcing is off for this project (service.web.writes: false)" }));
      return;
    }
    if (signedIn()) {
      const out = el("button", { text: "Sign out", type: "button" });
      out.addEventListener("click", () => {
        app.token = "";
        app.role = "";
        sessionStorage.removeItem("softplc-token");
        sessionStorage.removeItem("softplc-role");
        renderAuth();
        refreshForceControls();
      });
      const can = app.role === "operator" ? "writes values" : "writes and forces";
      box.append(el("span", { class: "who", "data-role": app.role, text: "signed in as " + (app.role || "engineer") + " · " + can }), out);
      return;
    }
    box.append(window.softplcShared.signInForm((token, role) => {
      app.token = token;
      app.role = role;
      renderAuth();
      refreshForceControls();
      renderTraceView();
    }));
  }

  // ---- I/O tables ----

  function forceControls(i) {
    const t = app.info.tags[i];
    const box = el("div", { class: "force" });
    if (t.pushed) {
      box.append(el("span", { class: "doc", text: "driven by the module's logic" }));
      return box;
    }
    const buttons = [];
    // Inputs are their module's: a write would be overwritten by the next read (the PLC
    // refuses it), so only outputs and memory tags offer one.
    const writable = t.kind === "output" || t.kind === "memory";
    if (t.type === "bool") {
      for (const v of ["1", "0"]) {
        const b = el("button", { type: "button", text: "Force " + v, "data-force": t.name, "data-value": v });
        b.addEventListener("click", () => force(t.name, v));
        buttons.push(b);
      }
      if (writable) {
        for (const v of ["1", "0"]) {
          const b = el("button", { type: "button", class: "write", text: "Write " + v, "data-write": t.name, "data-value": v });
          b.addEventListener("click", () => write(t.name, v));
          buttons.push(b);
        }
      }
    } else {
      const input = el("input", { type: "text", placeholder: t.type, "aria-label": "value for " + t.name, "data-input": t.name });
      const b = el("button", { type: "button", text: "Force", "data-force": t.name });
      const go = () => { if (input.value.trim() !== "") force(t.name, input.value.trim()); };
      b.addEventListener("click", go);
      input.addEventListener("keydown", (e) => { if (e.key === "Enter") go(); });
      buttons.push(input, b);
      if (writable) {
        const w = el("button", { type: "button", class: "write", text: "Write", "data-write": t.name });
        w.addEventListener("click", () => { if (input.value.trim() !== "") write(t.name, input.value.trim()); });
        buttons.push(w);
      }
    }
    const u = el("button", { type: "button", class: "unforce", text: "Unforce", "data-unforce": t.name });
    u.addEventListener("click", () => unforce(t.name));
    buttons.push(u);
    box.append(...buttons);
    return box;
  }

  function ioNote() {
    const info = app.info;
    $("io-note").textContent = !info.writes
      ? "Forcing is off for this project (service.web.writes: false). Values update live."
      : operatorOnly()
        ? "Signed in as operator: a write sets an output or memory tag once, at the next cycle boundary; the program may change it from its next scan. Forcing needs the engineer's token."
        : signedIn()
        ? "A force holds a value, whatever the modules or the program say, until it is removed or the PLC restarts. A write sets an output or memory tag once, at the next cycle boundary; the program may change it from its next scan."
        : "Sign in (top right) with the engineer's token to force tags, or the operator's to write values.";
  }

  function refreshForceControls() {
    const on = signedIn();
    ioNote();
    const operator = operatorOnly();
    for (const b of document.querySelectorAll(".force button, .force input")) {
      b.disabled = !on;
      b.title = on ? "" : (app.info.writes ? "Sign in with a token of the project to write or force" : "Forcing is off for this project");
      // The operator's token may write, not force: its page shows no force buttons.
      if (b.matches("[data-force]")) b.hidden = operator;
    }
    for (const c of app.cells) {
      if (c && c.unforce) c.unforce.hidden = !(c.forced) || operator;
    }
  }

  function buildIo() {
    const info = app.info;
    const root = $("io-tables");
    root.replaceChildren();
    const withForce = info.writes;
    const head = () => el("tr", {},
      el("th", { text: "Tag" }), el("th", { text: "Point" }), el("th", { text: "Dir" }), el("th", { text: "Type" }),
      el("th", { text: "Value" }), el("th", { text: "Quality" }), el("th", { class: "num", text: "Age" }),
      withForce ? el("th", { text: "Force" }) : null);
    const row = (i) => {
      const t = info.tags[i];
      const value = el("td", { id: "value-" + t.name });
      const q = el("td");
      const age = el("td", { class: "num", id: "age-" + t.name });
      const badges = el("span");
      const name = el("td", {}, el("span", { class: "tag-name", text: t.name }), badges,
        t.description ? el("div", { class: "tag-desc", text: t.description }) : null);
      if (t.pushed) badges.append(el("span", { class: "badge pushed", text: "module logic", title: "pushed down: the module's own logic drives it" }));
      if (t.retain) badges.append(el("span", { class: "badge retain", text: "retained" }));
      const forcedBadge = el("span", { class: "badge forced", text: "FORCED", hidden: true });
      badges.append(forcedBadge);
      const tr = el("tr", { "data-tag": t.name },
        name,
        el("td", {}, t.point ? el("span", { class: "mono", text: t.point, title: t.doc || "" }) : el("span", { class: "doc", text: "memory" })),
        el("td", {}, el("span", { class: "dir " + t.kind, text: t.kind })),
        el("td", { class: "mono", text: t.type }),
        value, q, age);
      let controls = null;
      if (withForce) {
        controls = forceControls(i);
        tr.append(el("td", {}, controls));
      }
      app.cells[i] = { tr, value, q, age, forcedBadge, unforce: controls && controls.querySelector(".unforce"), last: undefined };
      return tr;
    };
    const widths = withForce ? [20, 8, 8, 7, 10, 10, 9, 28] : [26, 10, 10, 8, 14, 14, 18];
    const cols = () => el("colgroup", {}, ...widths.map((w) => { const c = el("col"); c.style.width = w + "%"; return c; }));
    const table = (rows) => el("table", { class: "grid io" }, cols(), el("thead", {}, head()), el("tbody", {}, ...rows));
    info.buses.forEach((bus, b) => {
      if (info.buses.length > 1) {
        root.append(el("h3", { class: "line-head", text: "Line " + bus.name + " · " + bus.port + " · " + bus.settings }));
      }
      info.modules.forEach((m, mi) => {
        if (m.bus !== b) return;
        const tags = info.tags.map((t, i) => i).filter((i) => info.tags[i].module === mi);
        const mq = el("span", { class: "q", id: "module-q-" + m.name, text: "…" });
        root.append(el("div", { class: "panel" },
          el("div", { class: "panel-head" },
            el("h2", { text: m.name }),
            m.description ? el("span", { class: "module-desc", text: m.description }) : null,
            el("span", { class: "sub", text: m.model + " @" + m.address + " · " + m.protocol + " · line " + bus.name + " (" + bus.port + ", " + bus.settings + ")" }),
            el("span", { class: "hint" }, mq)),
          tags.length ? table(tags.map(row)) : el("div", { class: "empty", text: "No tags on this module." })));
      });
    });
    const memory = info.tags.map((t, i) => i).filter((i) => info.tags[i].kind === "memory");
    if (memory.length) {
      root.append(el("div", { class: "panel" },
        el("div", { class: "panel-head" }, el("h2", { text: "Memory" }), el("span", { class: "sub", text: "tags of the program, not on a module" })),
        table(memory.map(row))));
    }
    refreshForceControls();
  }

  function updateIo(s) {
    const info = app.info;
    const forced = new Set(s.forced);
    info.tags.forEach((t, i) => {
      const c = app.cells[i];
      if (!c) return;
      const v = s.v[i];
      const key = JSON.stringify(v);
      if (c.last !== key) {
        c.last = key;
        c.value.dataset.value = fmtValue(v, t.type);
        if (t.type === "bool") {
          c.value.replaceChildren(el("span", { class: "led" + (v ? " on" : ""), text: v ? "ON" : "OFF" }));
        } else {
          c.value.replaceChildren(el("span", { class: "num-value", text: fmtValue(v, t.type) }));
        }
      }
      const q = QUALITY[s.q[i]] || "bad";
      if (c.q.dataset.q !== q) {
        c.q.dataset.q = q;
        c.q.replaceChildren(el("span", { class: "q " + q, text: q }));
      }
      c.age.textContent = t.kind === "memory" || t.kind === "output" ? "" : fmtAge(s.age[i]);
      const f = forced.has(i);
      if (c.forced !== f) {
        c.forced = f;
        c.forcedBadge.hidden = !f;
        c.tr.classList.toggle("forced", f);
        if (c.unforce) c.unforce.hidden = !f;
      }
    });
  }

  // ---- Program ----

  // A task of several programs shows each, in running order, under its file's name; the
  // first keeps the ids a single program has (`ladder`, `rung-N`, `line-N`). A PLC of several
  // tasks shows each task's programs under the task's name and period, each ladder lit by its
  // own task's blocks.
  function buildProgram() {
    const programs = app.info.programs;
    const tasks = app.info.tasks || [];
    const root = $("program");
    root.replaceChildren();
    app.codeTags = [];
    app.ladders = [];
    const named = (p) => (p.task != null && tasks[p.task] ? tasks[p.task].name + ": " : "") + p.file;
    $("program-title").textContent = programs.map(named).join(" + ");
    let shownTask = null;
    const hints = programs.map((p, i) => {
      if (p.task != null && p.task !== shownTask && tasks[p.task]) {
        shownTask = p.task;
        const t = tasks[p.task];
        root.append(el("h3", { class: "program-task", "data-task": t.name, text: "Task " + t.name + " · every " + fmtMs(t.period_us / 1000) }));
      }
      const part = el("div", { class: "program-part", "data-program": p.file });
      if (p.task != null) part.dataset.task = tasks[p.task] ? tasks[p.task].name : "";
      // Numbered in running order: the task's, with several tasks.
      const mates = programs.filter((q) => q.task === p.task);
      if (mates.length > 1) {
        root.append(el("h3", { class: "program-file", text: (mates.indexOf(p) + 1) + ". " + p.file + " · " + p.kind }));
      }
      root.append(part);
      return (p.task != null ? named(p) + ": " : "") + buildOne(p, part, i === 0 ? "" : "p" + (i + 1) + "-");
    });
    $("program-hint").textContent = hints.join(" | ");
  }

  // The state as program `p` sees it: with several tasks, its own task's block outputs.
  function stateOf(p, s) {
    if (p.task == null) return s;
    return Object.assign({}, s, { b: (s.tb && s.tb[p.task]) || [] });
  }

  // One program into `root`; `prefix` keeps its element ids apart from the other programs'.
  function buildOne(p, root, prefix) {
    if (p.error) {
      root.append(el("div", { class: "empty", text: p.error }));
      return p.file + ": " + p.error;
    }
    const marks = p.lines.some((l) => l.rungs);
    let pushed = 0, central = 0;
    p.lines.forEach((line, n) => {
      const src = el("span", { class: "src" });
      for (const part of line.parts) {
        if (part.k === "tag") {
          const described = app.info.tags[part.tag] && app.info.tags[part.tag].description;
          const span = el("span", { class: "tag", text: part.s, "data-tag": part.s, title: described || undefined });
          const val = el("span", { class: "val" });
          src.append(span, val);
          app.codeTags.push({ tag: part.tag, span, val });
        } else if (part.k === "comment" || part.k === "string") {
          src.append(el("span", { class: part.k, text: part.s }));
        } else {
          src.append(part.s);
        }
      }
      const ln = el("div", { class: "ln", id: prefix + "line-" + (n + 1) }, el("span", { class: "no", text: n + 1 }));
      if (marks) {
        const mark = el("span", { class: "mark" });
        for (const r of line.rungs || []) {
          const coil = (r.title ? "“" + r.title + "”: " : "") + (app.info.tags[r.coil] ? app.info.tags[r.coil].name : "?");
          if (r.module) {
            pushed++;
            ln.classList.add("pushed");
            mark.append(el("span", {
              class: "rung-pushed", text: "⇣ in " + r.module, "data-pushed": r.module,
              title: coil + " runs in module " + r.module + " (" + r.feature + "): pushed down, it reacts without the scan",
            }));
          } else {
            central++;
            mark.append(el("span", { class: "rung-central", text: "scan", title: coil + " runs in the scan: " + r.central }));
          }
        }
        ln.append(mark);
      }
      ln.append(src);
      root.append(ln);
    });
    root.classList.toggle("narrow", pushed === 0);
    // A ladder program is drawn as ladder diagrams (ladder.js); its text stays one click away.
    const ladder = p.diagram && window.softplcLadder ? window.softplcLadder.build(root, p, app.info, prefix) : null;
    if (ladder) app.ladders.push({ update: (s) => ladder.update(stateOf(p, s)) });
    return p.kind + " · " + (marks
      ? pushed + " rung" + (pushed === 1 ? "" : "s") + " pushed down into modules, " + central + " in the scan"
      : "live values beside each tag") + (p.no_diagram ? " · " + p.no_diagram : "");
  }

  function updateProgram(s) {
    for (const ladder of app.ladders || []) ladder.update(s);
    const forced = new Set(s.forced);
    for (const c of app.codeTags) {
      const t = app.info.tags[c.tag];
      const v = s.v[c.tag];
      const text = fmtValue(v, t.type);
      if (c.text !== text) {
        c.text = text;
        c.val.textContent = text;
        if (t.type === "bool") {
          c.span.classList.toggle("on", v === true);
          c.span.classList.toggle("off", v !== true);
        }
      }
      c.span.classList.toggle("forced", forced.has(c.tag));
    }
  }

  // ---- Overview ----

  function card(label, big, small, bar) {
    const c = el("div", { class: "card" }, el("div", { class: "label", text: label }));
    if (big !== null) c.append(el("div", { class: "big", text: big }));
    if (small) c.append(small instanceof Node ? small : el("div", { class: "small", text: small }));
    if (bar !== undefined) {
      const fill = el("span");
      fill.style.width = Math.max(0, Math.min(100, bar * 100)).toFixed(1) + "%";
      c.append(el("div", { class: "bar" }, fill));
    }
    return c;
  }

  function busTotals() {
    const t = { requests: 0, errors: 0, timeouts: 0, crc: 0, bad: 0, exceptions: 0 };
    for (const m of (app.stats && app.stats.modules) || []) {
      t.requests += m.requests; t.timeouts += m.timeouts; t.crc += m.crc; t.bad += m.bad; t.exceptions += m.exceptions;
    }
    t.errors = t.timeouts + t.crc + t.bad + t.exceptions;
    return t;
  }

  function renderOverview() {
    const s = app.state, st = app.stats, info = app.info;
    if (!s) return;
    const period = info.period_us / 1000;
    const cycle = st ? st.phases[0] : null;
    const cards = [];
    const load = el("div", { class: "small" },
      cycle ? "p99 " + fmtMs(cycle.p99) + " · max " + fmtMs(cycle.max) : "",
      el("br"), cycle ? "p99 is " + Math.round((100 * cycle.p99) / period) + " % of the " + fmtMs(period) + " period" : "");
    cards.push(card("Cycle time (p50)", cycle ? fmtMs(cycle.p50) : "–", load, cycle ? cycle.p99 / period : 0));
    cards.push(card("Scans", s.cycles.toLocaleString("en"), "overruns " + s.overruns + " · up " + fmtUptime(s.now)));
    // A PLC of several tasks: a row per task (the figures above are the first task's).
    const tasks = (st && st.tasks) || [];
    if (tasks.length) {
      const tlist = el("ul");
      for (const t of tasks) {
        const text = fmtMs(t.period_us / 1000) + " · scans " + t.scans.toLocaleString("en") + " · overruns " + t.overruns +
          " · p99 " + fmtMs(t.cycle.p99_us / 1000) + " · max " + fmtMs(t.cycle.max_us / 1000) + " · late p99 " + fmtMs(t.lateness.p99_us / 1000);
        tlist.append(el("li", { "data-task": t.name }, el("span", { class: "q " + (t.overruns > 0 ? "stale" : "good"), text: t.name }), el("span", { class: "doc", text })));
      }
      cards.push(card("Tasks", String(tasks.length), tlist));
    }
    const list = el("ul");
    info.modules.forEach((m, i) => {
      const q = st && st.modules[i] ? QUALITY[st.modules[i].q] : "bad";
      list.append(el("li", {}, el("span", { class: "q " + q, text: m.name }), el("span", { class: "doc", text: m.model + " @" + m.address })));
    });
    cards.push(card("Modules", null, list));
    const forcedNames = s.forced.map((i) => info.tags[i].name);
    cards.push(card("Forces", String(forcedNames.length), forcedNames.length ? forcedNames.join(", ") : "none"));
    const bus = busTotals();
    cards.push(card("Bus", bus.requests.toLocaleString("en"), "requests · " + bus.errors + " errors"));
    const services = ((st && st.services) || []).filter((v) => v.state !== "off");
    if (services.length) {
      const slist = el("ul");
      for (const v of services) {
        const li = el("li", {}, el("span", { class: "q " + SERVICE_QUALITY[v.state], text: v.service }), el("span", { class: "doc", text: v.state }));
        if (v.reason) li.title = v.reason;
        slist.append(li);
      }
      cards.push(card("Services", null, slist));
    }
    $("overview-cards").replaceChildren(...cards);
    renderFaults();
  }

  function renderFaults() {
    const s = app.state, st = app.stats, info = app.info;
    const items = [];
    const add = (sev, text) => items.push(el("li", {}, el("span", { class: "sev " + sev, text: sev === "ok" ? "ok" : sev === "bad" ? "fault" : "warning" }), el("span", { text })));
    if (s.stopped) add((s.stop_reason === "stopped on request" || s.stop_reason === "stopped at the end of its run time") ? "warn" : "bad", "The run has ended (" + (s.stop_reason || "stopped") + "); the outputs were set to their safe values.");
    else if (!app.connected) add("bad", "No news from the PLC: it stopped, or this page lost its connection (it retries by itself).");
    if (st) {
      info.modules.forEach((m, i) => {
        const mm = st.modules[i];
        if (mm && mm.q !== 0) add(mm.q === 2 ? "bad" : "warn", "Module " + m.name + " (line " + info.buses[m.bus].name + ") is " + QUALITY[mm.q] + (mm.error ? ": " + mm.error : ""));
      });
      for (const v of st.services || []) {
        if (v.state === "degraded" || v.state === "stopped") add(v.state === "stopped" ? "bad" : "warn", "Service " + v.service + " is " + v.state + ": " + v.reason);
      }
      const bus = busTotals();
      if (bus.errors > 0) add("warn", bus.errors + " bus errors since start: " + bus.timeouts + " timeouts, " + bus.crc + " CRC, " + bus.bad + " bad replies, " + bus.exceptions + " exceptions.");
    }
    if (s.overruns > 0) add("warn", s.overruns + " overruns: cycles ran past their deadline (see Timing).");
    for (const i of s.forced) add("warn", info.tags[i].name + " is forced to " + fmtValue(s.v[i], info.tags[i].type) + ".");
    const badTags = s.q.filter((q) => q === 2).length;
    if (badTags > 0 && s.published) add("warn", badTags + " tag" + (badTags === 1 ? " has" : "s have") + " bad quality.");
    if (!items.length) add("ok", "No faults: every module answers, nothing is forced, no overruns.");
    $("faults").replaceChildren(...items);
  }

  function renderTop() {
    const s = app.state, st = app.stats;
    const pill = $("state");
    let state, text;
    if (s && s.stopped) { state = "stopped"; text = (s.stop_reason === "stopped on request" || s.stop_reason === "stopped at the end of its run time") ? "stopped" : "faulted"; }
    else if (!app.connected && app.lastEvent) { state = "lost"; text = "no connection"; }
    else if (!s || !s.published) { state = "connecting"; text = "starting"; }
    else if (st && st.modules.some((m) => m.q !== 0)) { state = "faulty"; text = "running · faults"; }
    else { state = "running"; text = "running"; }
    pill.dataset.state = state;
    pill.textContent = text;
    if (s) {
      const cycle = st ? st.phases[0] : null;
      $("scan-figures").replaceChildren(
        "scan ", el("b", { text: s.cycles.toLocaleString("en") }),
        cycle ? " · cycle " : "", cycle ? el("b", { text: fmtMs(cycle.p50) }) : "",
        " · period ", el("b", { text: fmtMs(app.info.period_us / 1000) }));
    }
  }

  // ---- Trend ----

  function trendAppend(s) {
    const tr = app.trend;
    if (!tr.tags.length) return;
    // Several tasks: a sample when a task owning a trend tag completed a cycle, at the
    // latest of those tasks' times (as /api/trend samples).
    let now = s.now;
    if (s.task_now) {
      const owners = [...new Set(tr.tags.map((t) => (app.info.tags[t] && app.info.tags[t].task) || 0))];
      const key = owners.map((o) => s.task_cycles[o]).join(",");
      if (key === tr.cycles) return;
      tr.cycles = key;
      now = Math.max(...owners.map((o) => s.task_now[o] || 0));
    }
    if (tr.t.length && now <= tr.t[tr.t.length - 1]) return;
    tr.t.push(now);
    tr.tags.forEach((tag, k) => tr.series[k].push(asNumber(s.v[tag])));
    const from = now - TREND_WINDOW_MS - 1000;
    while (tr.t.length > 2 && (tr.t[1] < from || tr.t.length > 3000)) {
      tr.t.shift();
      for (const ser of tr.series) ser.shift();
    }
  }

  function renderTrend() {
    const box = $("trend");
    const tr = app.trend;
    const info = app.info;
    if (!info || document.body.dataset.view !== "overview") return;
    if (!tr.tags.length) {
      box.replaceChildren(el("div", { class: "empty", text: "No trend tags (service.web.trend)." }));
      return;
    }
    $("trend-hint").textContent = "last " + TREND_WINDOW_MS / 1000 + " s of scan time";
    const now = tr.t.length ? tr.t[tr.t.length - 1] : 0;
    const signals = tr.tags.map((tag, k) => ({ name: info.tags[tag].name, type: info.tags[tag].type, values: tr.series[k] }));
    const tick = (k) => (k === 6 ? "now" : "−" + (60 - k * 10) + " s");
    box.replaceChildren(lanes(Math.max(600, box.clientWidth - 24), signals, tr.t, now - TREND_WINDOW_MS, TREND_WINDOW_MS, tick));
  }

  // Signals over time, one lane each (the trend's look, also the Trace view's plot): bools as
  // filled steps, numbers as steps scaled to what is visible, the last value by the name.
  // `signals`: [{ name, type, values }] with one value per time of `t` (ms); the window is
  // [t0, t0 + span]; `tick(k)` labels the k-th of 7 grid lines; `mark`, a time to draw a line at.
  function lanes(W, signals, t, t0, span, tick, mark) {
    const labelW = 170, right = 14, axisH = 22;
    const plotW = W - labelW - right;
    const heights = signals.map((s) => (s.type === "bool" ? 30 : 78));
    const H = heights.reduce((a, b) => a + b + 8, 0) + axisH;
    const g = svg("svg", { viewBox: "0 0 " + W + " " + H, height: H, role: "img", "aria-label": "trend" });
    const xOf = (x) => labelW + ((x - t0) / span) * plotW;
    for (let k = 0; k <= 6; k++) {
      const x = labelW + (k / 6) * plotW;
      g.append(svg("line", { x1: x, x2: x, y1: 0, y2: H - axisH, class: "gridline" }));
      g.append(svg("text", { x, y: H - 6, "text-anchor": k === 6 ? "end" : k === 0 ? "start" : "middle", class: "axis" }, tick(k)));
    }
    if (mark !== undefined) g.append(svg("line", { x1: xOf(mark), x2: xOf(mark), y1: 0, y2: H - axisH, class: "trigger-mark" }));
    let y = 4;
    signals.forEach((sig, k) => {
      const h = heights[k];
      const color = PALETTE[k % PALETTE.length];
      const ser = sig.values;
      g.append(svg("rect", { x: labelW, y, width: plotW, height: h, class: "lane" }));
      const last = ser.length ? ser[ser.length - 1] : null;
      g.append(svg("text", { x: 8, y: y + Math.min(h / 2, 18) + 4, class: "trace-label", fill: color }, sig.name));
      g.append(svg("text", { x: 8, y: y + Math.min(h / 2, 18) + 19, class: "trace-value" },
        last === null ? "" : sig.type === "bool" ? (last ? "ON" : "OFF") : fmtValue(last, sig.type)));
      let lo = 0, hi = 1;
      if (sig.type !== "bool") {
        const vis = ser.filter((v, i) => v !== null && t[i] >= t0);
        lo = vis.length ? Math.min(...vis) : 0;
        hi = vis.length ? Math.max(...vis) : 1;
        if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
        const pad = (hi - lo) * 0.1;
        lo -= pad; hi += pad;
        g.append(svg("text", { x: labelW + plotW - 4, y: y + 11, "text-anchor": "end", class: "axis" }, fmtValue(+(hi - pad).toPrecision(4), "f32")));
        g.append(svg("text", { x: labelW + plotW - 4, y: y + h - 4, "text-anchor": "end", class: "axis" }, fmtValue(+(lo + pad).toPrecision(4), "f32")));
      }
      const top = y + 4, bottom = y + h - 4;
      const yOf = (v) => bottom - ((v - lo) / (hi - lo)) * (bottom - top);
      let d = "", fill = "", prev = null;
      for (let i = 0; i < t.length; i++) {
        const v = ser[i];
        if (v === null) { prev = null; continue; }
        if (t[i] < t0 && !(i + 1 < t.length && t[i + 1] >= t0)) continue;
        const x = Math.max(labelW, xOf(t[i]));
        const yy = yOf(v);
        if (prev === null) d += "M" + x.toFixed(1) + " " + yy.toFixed(1);
        else d += "H" + x.toFixed(1) + "V" + yy.toFixed(1);
        prev = v;
      }
      if (d) {
        d += "H" + (labelW + plotW).toFixed(1);
        if (sig.type === "bool") {
          fill = d + "V" + bottom + "H" + labelW + "Z";
          g.append(svg("path", { d: fill, class: "trace-fill", fill: color }));
        }
        g.append(svg("path", { d, class: "trace", stroke: color }));
      }
      y += h + 8;
    });
    return g;
  }

  // ---- Trace ----

  // The traces' table (GET /api/trace), the selected trace's plot (GET /api/trace/data),
  // polled while the view is open; arming takes the token, as forcing does.
  const traceView = { selected: null, timer: null };

  async function renderTraceView() {
    if (document.body.dataset.view !== "trace") {
      clearInterval(traceView.timer);
      traceView.timer = null;
      return;
    }
    if (!traceView.timer) traceView.timer = setInterval(renderTraceView, 500);
    let list;
    try {
      list = (await getJSON("/api/trace")).traces || [];
    } catch (e) {
      return;
    }
    const table = $("trace-table");
    const head = el("tr", {}, ...["trace", "state", "samples", "pre / post", "triggered at", "signals", ""].map((h) => el("th", { text: h })));
    const rows = list.map((s) => {
      const enc = encodeURIComponent(s.name);
      const actions = el("td", { class: "actions" },
        operatorOnly() ? null : el("button", { type: "button", text: "Arm", onclick: () => armTrace({ name: s.name }) }),
        s.state ? el("button", { type: "button", text: "Plot", onclick: () => { traceView.selected = s.name; renderTraceView(); } }) : null,
        s.state ? el("a", { href: "/api/trace/csv?name=" + enc, download: s.name + ".csv", text: "CSV" }) : null,
        s.state ? el("a", { href: "/api/trace/vcd?name=" + enc, download: s.name + ".vcd", text: "VCD" }) : null);
      return el("tr", { "data-trace": s.name },
        // With several tasks, whose cycles it samples.
        el("td", { text: s.task ? s.name + " (task " + s.task + ")" : s.name }),
        el("td", { class: "trace-state", "data-state": s.state || "idle", text: s.state || "not armed" }),
        el("td", { class: "num", text: s.samples + " / " + s.depth }),
        el("td", { class: "num", text: s.pre + " / " + s.post }),
        el("td", { class: "num", text: s.triggered_at ? "cycle " + s.triggered_at : "" }),
        el("td", { text: s.signals.join(", ") }),
        actions);
    });
    table.replaceChildren(head, ...rows);
    $("trace-form").hidden = operatorOnly();
    $("trace-hint").textContent = list.length ? "" : "No traces defined (traces: in the project); arm one below.";
    if (!traceView.selected || !list.some((s) => s.name === traceView.selected && s.state)) {
      const armed = list.find((s) => s.state);
      traceView.selected = armed ? armed.name : null;
    }
    if (traceView.selected) plotTrace(traceView.selected);
  }

  async function plotTrace(name) {
    let d;
    try {
      d = (await getJSON("/api/trace/data?name=" + encodeURIComponent(name))).trace;
    } catch (e) {
      return;
    }
    const box = $("trace-plot");
    $("trace-plot-title").textContent = "Trace " + d.name + (d.task ? " · task " + d.task : "") + " · " + d.state + " · " + d.time_ns.length + " samples";
    if (!d.time_ns.length) {
      $("trace-plot-hint").textContent = "";
      box.replaceChildren(el("div", { class: "empty", text: "No samples yet." }));
      return;
    }
    const t = d.time_ns.map((ns) => ns / 1e6);
    const t0 = t[0];
    const span = Math.max(t[t.length - 1] - t0, 1e-3);
    const triggered = d.trigger !== undefined && d.trigger !== null;
    const origin = triggered ? t[d.trigger] : t0;
    // Say what the times count from: the trigger only once there is one.
    $("trace-plot-hint").textContent = triggered ? "times from the trigger" : "times from the first sample";
    const signals = d.signals.map((s, k) => ({ name: s.name, type: s.type, values: d.values.map((row) => row[k]) }));
    // Times from the trigger sample (from the first sample before a trigger).
    const tick = (k) => {
      const rel = t0 + (k / 6) * span - origin;
      const a = fmtTick(Math.abs(rel));
      return rel < 0 ? "−" + a : rel > 0 ? "+" + a : a;
    };
    box.replaceChildren(lanes(Math.max(600, box.clientWidth - 24), signals, t, t0, span, tick, d.trigger != null ? origin : undefined));
  }

  async function armTrace(body) {
    const r = await post("/api/trace/arm", body);
    toast(r.ok ? r.message : "Not armed: " + r.error, !r.ok);
    if (r.ok && r.traces && r.traces.length) traceView.selected = r.traces[0].name;
    renderTraceView();
  }

  // The task a trace of `signals` and `trigger` samples when none is named, as the server's
  // router picks it: the owner of the trigger's signal, else of the first signal with one (a
  // tag's writing task, a module's line's task), else the first task.
  function traceHome(signals, trigger) {
    const info = app.info;
    const owner = (name) => {
      const tag = info.tags.find((t) => t.name === name);
      if (tag) return tag.task;
      const module = info.modules.find((m) => name.startsWith(m.name + "."));
      return module && info.buses[module.bus] ? info.buses[module.bus].task : undefined;
    };
    const first = trigger.split(/[\s<>=!]/)[0];
    const names = (first ? [first] : []).concat(signals);
    for (const n of names) {
      const t = owner(n);
      if (t != null) return t;
    }
    return 0;
  }

  function bindTraceForm() {
    const tasks = app.info.tasks || [];
    const pick = $("trace-task");
    // Several tasks: whose cycles the trace samples; it follows the signals typed until the
    // engineer picks one.
    $("trace-task-label").hidden = tasks.length === 0;
    pick.replaceChildren(...tasks.map((t, i) => el("option", { value: t.name, text: t.name + " (" + fmtMs(t.period_us / 1000) + ")", "data-index": i })));
    const follow = () => {
      if (!tasks.length || pick.dataset.chosen) return;
      const signals = $("trace-tags").value.split(",").map((s) => s.trim()).filter(Boolean);
      const home = tasks[traceHome(signals, $("trace-trigger").value.trim())];
      if (home) pick.value = home.name;
    };
    pick.addEventListener("change", () => { pick.dataset.chosen = "1"; });
    $("trace-tags").addEventListener("input", follow);
    $("trace-trigger").addEventListener("input", follow);
    follow();
    $("trace-form").addEventListener("submit", (e) => {
      e.preventDefault();
      const num = (id) => ($(id).value === "" ? undefined : Number($(id).value));
      const spec = {
        // Empty: the server names it as the command line does.
        name: $("trace-name").value.trim(),
        tags: $("trace-tags").value.split(",").map((s) => s.trim()).filter(Boolean),
        pre: num("trace-pre"),
        post: num("trace-post"),
      };
      const trigger = $("trace-trigger").value.trim();
      if (trigger) spec.trigger = trigger;
      armTrace(tasks.length ? { spec, task: pick.value } : { spec });
    });
  }

  // ---- Timing ----

  function niceTicks(lo, hi, log) {
    const ticks = [];
    if (log) {
      for (let e = Math.floor(Math.log10(lo)); e <= Math.ceil(Math.log10(hi)); e++) {
        for (const m of [1, 2, 5]) {
          const v = m * Math.pow(10, e);
          if (v >= lo && v <= hi) ticks.push(v);
        }
      }
      return ticks;
    }
    const span = hi - lo;
    const step0 = span / 5;
    const mag = Math.pow(10, Math.floor(Math.log10(step0)));
    const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => span / s <= 6) || step0;
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-12; v += step) ticks.push(v);
    return ticks;
  }

  // A tick label: as few digits as the value needs (`2 ms`, `250 µs`, `1.5 s`).
  function fmtTick(ms) {
    if (ms === 0) return "0";
    const trim = (x, unit) => String(+x.toPrecision(3)) + " " + unit;
    if (ms < 1) return trim(ms * 1000, "µs");
    if (ms < 1000) return trim(ms, "ms");
    return trim(ms / 1000, "s");
  }

  function histogram(phase) {
    const h = phase.hist;
    if (!h || !h.counts.length) return el("div", { class: "empty", text: "No samples yet." });
    const W = 560, H = 200, L = 44, R = 14, T = 22, B = 28;
    const pw = W - L - R, ph = H - T - B;
    const g = svg("svg", { viewBox: "0 0 " + W + " " + H, role: "img", "aria-label": phase.name + " histogram" });
    const n = h.counts.length;
    const maxC = Math.max(...h.counts, 1);
    const frac = (ms) => (h.log ? Math.log(ms / h.lo) / Math.log(h.hi / h.lo) : (ms - h.lo) / (h.hi - h.lo));
    const xOf = (ms) => L + Math.max(0, Math.min(1, frac(ms))) * pw;
    for (let k = 0; k <= 4; k++) {
      const yy = T + (k / 4) * ph;
      g.append(svg("line", { x1: L, x2: L + pw, y1: yy, y2: yy, class: "gridline" }));
    }
    g.append(svg("text", { x: L - 6, y: T + 4, "text-anchor": "end", class: "axis" }, String(maxC)));
    g.append(svg("text", { x: L - 6, y: T + ph, "text-anchor": "end", class: "axis" }, "0"));
    const bw = pw / n;
    h.counts.forEach((c, i) => {
      if (!c) return;
      const bh = Math.max(1.5, (c / maxC) * ph);
      const edge = h.log ? h.lo * Math.pow(h.hi / h.lo, i / n) : h.lo + ((h.hi - h.lo) * i) / n;
      g.append(svg("rect", {
        x: (L + i * bw + 0.5).toFixed(1), y: (T + ph - bh).toFixed(1), width: Math.max(1, bw - 1).toFixed(1), height: bh.toFixed(1),
        class: "bar" + (edge >= phase.p99 ? " tail" : ""),
      }, undefined));
    });
    g.append(svg("line", { x1: L, x2: L + pw, y1: T + ph, y2: T + ph, class: "axis-line" }));
    let free = 0; // the first x a next tick label may use
    for (const v of niceTicks(h.lo, h.hi, h.log)) {
      const x = xOf(v);
      const text = fmtTick(v);
      const half = text.length * 3.1;
      const anchor = x + half > W - 2 ? "end" : "middle";
      const left = anchor === "end" ? x - 2 * half : x - half;
      if (left < free) continue;
      free = left + 2 * half + 8;
      g.append(svg("line", { x1: x, x2: x, y1: T + ph, y2: T + ph + 4, class: "axis-line" }));
      g.append(svg("text", { x, y: H - 8, "text-anchor": anchor, class: "axis" }, text));
    }
    // Percentile markers; labels of markers at the same place are merged, the others kept
    // apart from right to left.
    const marks = [];
    for (const key of ["max", "p99", "p50"]) {
      const x = xOf(phase[key]);
      const same = marks.find((m) => Math.abs(m.x - x) < 2);
      if (same) same.label = key + " = " + same.label;
      else marks.push({ key, x, label: key });
    }
    let room = W - 4;
    for (const m of marks) {
      g.append(svg("line", { x1: m.x, x2: m.x, y1: T - 4, y2: T + ph, class: "pline " + m.key }));
      const half = m.label.length * 3.2 + 2;
      const lx = Math.max(L + half, Math.min(m.x, room - half));
      g.append(svg("text", { x: lx, y: T - 8, "text-anchor": "middle", class: "plabel " + m.key }, m.label));
      room = lx - half - 6;
    }
    return el("div", { class: "hist" }, g);
  }

  function renderTiming() {
    const st = app.stats;
    if (!st) return;
    const grid = $("histograms");
    grid.replaceChildren(...st.phases.map((p) => {
      const [title, sub] = PHASE_TITLES[p.name] || [p.name, ""];
      return el("div", { class: "panel", id: "hist-" + p.name },
        el("div", { class: "panel-head" }, el("h2", { text: title }), el("span", { class: "sub", text: sub }),
          el("span", { class: "hint", text: p.count.toLocaleString("en") + " samples" + (p.hist && p.hist.log ? " · log scale" : "") })),
        histogram(p));
    }));
    const head = el("tr", {}, ...["Phase", "Samples", "p50", "p99", "p99.9", "Max", "Mean"].map((h, i) => el("th", { class: i ? "num" : "", text: h })));
    const rows = st.phases.map((p) => el("tr", {},
      el("td", { text: (PHASE_TITLES[p.name] || [p.name])[0] }),
      el("td", { class: "num", text: p.count.toLocaleString("en") }),
      el("td", { class: "num", text: fmtMs(p.p50) }), el("td", { class: "num", text: fmtMs(p.p99) }),
      el("td", { class: "num", text: fmtMs(p.p999) }), el("td", { class: "num", text: fmtMs(p.max) }),
      el("td", { class: "num", text: fmtMs(p.mean) })));
    $("percentiles").replaceChildren(el("thead", {}, head), el("tbody", {}, ...rows));
  }

  // ---- Bus ----

  function renderBus() {
    const st = app.stats, info = app.info;
    if (!st) return;
    const now = performance.now();
    const rates = info.modules.map((m, i) => {
      if (!app.rate || !st.modules[i]) return null;
      const dt = (now - app.rate.at) / 1000;
      return dt > 0.1 ? (st.modules[i].requests - app.rate.requests[i]) / dt : null;
    });
    // A line's Collect broadcasts (event mode) are addressed to no module: the line's rate
    // counts them beside its modules' requests.
    const sent = (m) => m.requests + (m.collect || 0);
    const lineRates = info.modules.map((m, i) => {
      if (!app.rate || !st.modules[i]) return null;
      const dt = (now - app.rate.at) / 1000;
      return dt > 0.1 ? (sent(st.modules[i]) - app.rate.sent[i]) / dt : null;
    });
    if (!app.rate || now - app.rate.at > 2000) {
      app.rate = { at: now, requests: st.modules.map((m) => m.requests), sent: st.modules.map(sent), shown: rates, lineShown: lineRates };
    }
    const shown = app.rate.shown || rates;
    const lineShown = app.rate.lineShown || lineRates;
    const cols = ["Module", "Line", "Model", "Quality", "Requests", "Req/s", "Timeouts", "CRC", "Bad replies", "Exceptions", "Error rate", "Round trip", "Last error"];
    const head = el("tr", {}, ...cols.map((c, i) => el("th", { class: i >= 4 && i <= 11 ? "num" : "", text: c })));
    const rows = info.modules.map((m, i) => {
      const c = st.modules[i] || { q: 2, requests: 0, timeouts: 0, crc: 0, bad: 0, exceptions: 0, rtt: 0, error: null };
      const errors = c.timeouts + c.crc + c.bad + c.exceptions;
      const q = QUALITY[c.q];
      const r = shown[i];
      return el("tr", { "data-module": m.name },
        el("td", {}, el("span", { class: "tag-name", text: m.name })),
        el("td", { text: info.buses[m.bus].name }),
        el("td", { class: "mono", text: m.model + " @" + m.address }),
        el("td", {}, el("span", { class: "q " + q, text: q })),
        el("td", { class: "num", text: c.requests.toLocaleString("en") }),
        el("td", { class: "num", text: r === null || r === undefined ? "–" : r.toFixed(1) }),
        el("td", { class: "num", text: c.timeouts }), el("td", { class: "num", text: c.crc }),
        el("td", { class: "num", text: c.bad }), el("td", { class: "num", text: c.exceptions }),
        el("td", { class: "num", text: c.requests ? ((100 * errors) / c.requests).toFixed(2) + " %" : "–" }),
        el("td", { class: "num", text: fmtMs(c.rtt) }),
        el("td", { class: "doc", text: c.error || "" }));
    });
    $("bus-table").replaceChildren(el("thead", {}, head), el("tbody", {}, ...rows));
    $("bus-lines").replaceChildren(...info.buses.map((bus, b) => {
      const mods = info.modules.map((m, i) => i).filter((i) => info.modules[i].bus === b);
      const rate = mods.reduce((a, i) => a + (lineShown[i] || 0), 0);
      const errors = mods.reduce((a, i) => {
        const c = st.modules[i];
        return a + (c ? c.timeouts + c.crc + c.bad + c.exceptions : 0);
      }, 0);
      const good = mods.filter((i) => st.modules[i] && st.modules[i].q === 0).length;
      return card(bus.name + " · " + bus.settings, rate.toFixed(1) + " req/s",
        bus.port + " · " + good + "/" + mods.length + " modules good · " + errors + " errors");
    }));
    renderRtt();
    for (const [i, m] of info.modules.entries()) {
      const q = $("module-q-" + m.name);
      if (q && st.modules[i]) {
        const name = QUALITY[st.modules[i].q];
        q.className = "q " + name;
        q.textContent = name + (st.modules[i].error ? ": " + st.modules[i].error : "");
      }
    }
  }

  function rttAppend(st) {
    if (!app.state) return;
    const r = app.rtt;
    const now = app.state.now;
    if (r.t.length && now <= r.t[r.t.length - 1]) return;
    r.t.push(now);
    app.info.modules.forEach((m, i) => {
      (r.series[i] = r.series[i] || []).push(st.modules[i] && st.modules[i].q === 0 ? st.modules[i].rtt : null);
    });
    while (r.t.length > 2 && r.t[1] < now - TREND_WINDOW_MS - 1000) {
      r.t.shift();
      for (const ser of r.series) ser.shift();
    }
  }

  function renderRtt() {
    const box = $("rtt-chart");
    const r = app.rtt;
    if (document.body.dataset.view !== "bus") return;
    const W = Math.max(600, box.clientWidth - 24), H = 190, L = 56, R = 120, T = 10, B = 24;
    const pw = W - L - R, ph = H - T - B;
    const g = svg("svg", { viewBox: "0 0 " + W + " " + H, height: H, role: "img", "aria-label": "round trip" });
    const now = r.t.length ? r.t[r.t.length - 1] : 0;
    const t0 = now - TREND_WINDOW_MS;
    const all = r.series.flat().filter((v) => v !== null && v !== undefined);
    const top = all.length ? Math.max(...all) * 1.1 : 1;
    const mag = Math.pow(10, Math.floor(Math.log10(top)));
    const hi = [1, 2, 2.5, 4, 5, 8, 10].map((m) => m * mag).find((m) => m >= top) || top;
    const xOf = (t) => L + Math.max(0, (t - t0) / TREND_WINDOW_MS) * pw;
    const yOf = (v) => T + ph - (v / hi) * ph;
    for (let k = 0; k <= 4; k++) {
      const v = (hi * k) / 4, y = yOf(v);
      g.append(svg("line", { x1: L, x2: L + pw, y1: y, y2: y, class: "gridline" }));
      g.append(svg("text", { x: L - 6, y: y + 4, "text-anchor": "end", class: "axis" }, fmtTick(v)));
    }
    for (let k = 0; k <= 6; k++) {
      const x = L + (k / 6) * pw;
      g.append(svg("text", { x, y: H - 6, "text-anchor": k === 6 ? "end" : "middle", class: "axis" }, k === 6 ? "now" : "−" + (60 - k * 10) + " s"));
    }
    app.info.modules.forEach((m, i) => {
      const color = PALETTE[i % PALETTE.length];
      const ser = r.series[i] || [];
      let d = "";
      let pen = false;
      for (let k = 0; k < r.t.length; k++) {
        const v = ser[k];
        if (v === null || v === undefined || r.t[k] < t0) { pen = false; continue; }
        d += (pen ? "L" : "M") + xOf(r.t[k]).toFixed(1) + " " + yOf(v).toFixed(1);
        pen = true;
      }
      if (d) g.append(svg("path", { d, class: "trace", stroke: color }));
      const last = ser.length ? ser[ser.length - 1] : null;
      g.append(svg("text", { x: L + pw + 12, y: T + 14 + i * 18, class: "trace-label", fill: color }, m.name));
      g.append(svg("text", { x: L + pw + 56, y: T + 14 + i * 18, class: "trace-value" }, last === null ? "lost" : fmtMs(last)));
    });
    box.replaceChildren(g);
  }

  // ---- Audit ----

  // The audit file's latest entries (GET /api/audit), refreshed every few seconds and after
  // each of this page's own writes.
  async function renderAudit() {
    let j;
    try {
      j = await getJSON("/api/audit");
    } catch (e) {
      return;
    }
    const box = $("audit");
    const rows = j.entries.map((e) => {
      const li = el("li", { "data-action": e.action, "data-source": e.source });
      li.append(
        el("span", { class: "sev " + (e.ok ? "ok" : "bad"), text: e.action }),
        el("span", { text: e.utc.replace("T", " ").replace("Z", " UTC") + " · cycle " + e.cycle + " · " + e.source }),
        el("span", { text: (e.what ? e.what + ": " : "") + (e.ok ? "" : "refused: ") + e.result }));
      return li;
    });
    if (rows.length === 0) rows.push(el("li", { text: "nothing written, forced or reloaded yet" }));
    box.replaceChildren(...rows);
  }

  // The simulated plant's panel: the model's states, live (docs/plant.md).
  function renderPlant(s) {
    const p = s.plant;
    $("plant-panel").hidden = !p;
    if (!p) return;
    $("plant-title").textContent = "Plant " + p.model;
    $("plant-hint").textContent = p.state === "running" ? "simulated, running" : "stopped: " + (p.error || "");
    $("plant-hint").classList.toggle("bad", p.state !== "running");
    const rows = p.states.map(([name, value]) =>
      el("tr", { "data-state": name }, el("td", { text: name }), el("td", { class: "num", text: value })));
    $("plant-states").replaceChildren(...rows);
  }

  // ---- Alarms ----

  // The current alarms (GET /api/alarms), those waiting first, each with its acknowledge
  // button for a signed-in page (the operator's token may).
  async function renderAlarms() {
    let j;
    try {
      const r = await fetch("/api/alarms");
      if (!r.ok) return;
      j = await r.json();
    } catch (e) {
      return;
    }
    const rows = j.current.map((a) => {
      const li = el("li", { "data-alarm": a.name });
      const sev = a.active ? "bad" : "warn";
      const ack = el("button", { type: "button", "data-ack": a.name, text: "Acknowledge" });
      ack.hidden = a.acknowledged;
      ack.disabled = !signedIn();
      ack.addEventListener("click", async () => {
        const r = await post("/api/alarms/ack", { alarm: a.name });
        toast(r.ok ? r.message : "Not acknowledged: " + r.error, !r.ok);
        renderAlarms();
        renderAudit();
      });
      const raised = a.raised ? a.raised.utc.replace("T", " ").replace("Z", " UTC") + " · cycle " + a.raised.cycle : "";
      li.append(
        el("span", { class: "sev " + sev, text: a.level }),
        el("span", { text: a.text + " (" + a.name + ")" + (a.active ? "" : " · gone") }),
        el("span", { text: raised }),
        ack);
      return li;
    });
    if (rows.length === 0) rows.push(el("li", { text: "no alarm" }));
    $("alarms").replaceChildren(...rows);
  }

  // ---- Live data ----

  function onState(s) {
    app.state = s;
    app.lastEvent = Date.now();
    app.connected = true;
    updateIo(s);
    updateProgram(s);
    renderPlant(s);
    trendAppend(s);
    renderTop();
    renderOverview();
    renderTrend();
    refreshForceControls();
  }

  function onStats(st) {
    app.stats = st;
    rttAppend(st);
    renderTiming();
    renderBus();
    renderTop();
    renderOverview();
  }

  function connect() {
    const es = new EventSource("/api/events");
    es.addEventListener("state", (e) => onState(JSON.parse(e.data)));
    es.addEventListener("stats", (e) => onStats(JSON.parse(e.data)));
    es.addEventListener("open", () => { app.connected = true; renderTop(); });
    es.addEventListener("error", () => { app.connected = false; renderTop(); if (app.state) renderFaults(); });
  }

  // A quiet stream is a stopped scan or a lost connection, even while the socket looks open.
  function watchdog() {
    const period = app.info ? app.info.period_us / 1000 : 1000;
    const quiet = Date.now() - app.lastEvent > Math.max(3000, 5 * period);
    if (app.lastEvent && quiet && app.connected && !(app.state && app.state.stopped)) {
      app.connected = false;
      renderTop();
      renderFaults();
    }
  }

  async function boot() {
    window.addEventListener("hashchange", showView);
    showView();
    try {
      app.info = await getJSON("/api/info");
    } catch (e) {
      $("state").textContent = "no connection";
      $("state").dataset.state = "lost";
      setTimeout(boot, 2000);
      return;
    }
    document.title = app.info.project + " · softplc";
    $("project").textContent = app.info.project;
    renderAuth();
    bindTraceForm();
    buildIo();
    buildProgram();
    try {
      app.trend = await getJSON("/api/trend");
      const both = await getJSON("/api/state");
      onStats(both.stats);
      if (both.state.published) onState(both.state);
    } catch (e) {
      // The event stream brings the same soon.
    }
    connect();
    setInterval(watchdog, 1000);
    renderAudit();
    setInterval(renderAudit, 5000);
    renderAlarms();
    setInterval(renderAlarms, 2000);
    window.addEventListener("resize", renderTrend);
  }

  document.addEventListener("DOMContentLoaded", boot);
})();
