// softplc operator's page: the alarms (GET /api/alarms, every second) with their
// acknowledge buttons (POST /api/alarms/ack), and the tags the project marks `operator: true`
// with their live values (server-sent events from /api/events) and, where a tag may be
// written, a write-once control (POST /api/write). The token stays in this tab's
// sessionStorage, shared with the full page; the operator's token suffices for all of it.
"use strict";

(() => {
  const op = {
    info: null,
    token: sessionStorage.getItem("softplc-token") || "",
    role: sessionStorage.getItem("softplc-role") || "",
    values: null,
    alarms: null,
    lastEvent: 0,
  };

  const $ = (id) => document.getElementById(id);

  const { el, fmtValue, toast } = window.softplcShared;

  function signedIn() {
    return op.info && op.info.writes && op.token !== "";
  }

  function post(path, body, token) {
    return window.softplcShared.post(path, body, token ?? op.token);
  }

  // ---- Sign-in ----

  function renderAuth() {
    const box = $("auth");
    box.replaceChildren();
    if (!op.info.writes) {
      box.append(el("span", { class: "who", text: "read-only" }));
      return;
    }
    if (signedIn()) {
      const out = el("button", { type: "button", text: "Sign out" });
      out.addEventListener("click", () => {
        op.token = "";
        op.role = "";
        sessionStorage.removeItem("softplc-token");
        sessionStorage.removeItem("softplc-role");
        refresh();
      });
      box.append(el("span", { class: "who", "data-role": op.role, text: op.role || "engineer" }), out);
      return;
    }
    box.append(window.softplcShared.signInForm((token, role) => {
      op.token = token;
      op.role = role;
      refresh();
    }));
  }

  function refresh() {
    renderAuth();
    renderAlarms();
    buildTags();
    updateTags();
  }

  // ---- Alarms ----

  function when(a) {
    const parts = [];
    if (a.raised) parts.push("raised " + a.raised.utc.replace("T", " ").replace(/\.\d+Z$/, " UTC"));
    if (a.cleared) parts.push("cleared " + a.cleared.utc.slice(11, 19));
    parts.push(a.active ? "active" : "gone");
    return parts.join(" · ");
  }

  async function acknowledge(alarm) {
    const r = await post("/api/alarms/ack", { alarm });
    toast(r.ok ? r.message : "Not acknowledged: " + r.error, !r.ok);
    pollAlarms();
  }

  function renderAlarms() {
    const list = op.alarms;
    const box = $("alarms");
    if (!list) {
      box.replaceChildren(el("li", { class: "empty", text: "no alarm service" }));
      return;
    }
    const c = list.counts;
    const active = c.active.reduce((a, x) => a + x, 0);
    $("alarm-counts").textContent = active + " active · " + c.unacknowledged + " to acknowledge";
    $("ack-all").disabled = !signedIn() || c.unacknowledged === 0;
    const rows = list.current.map((a) => {
      const li = el("li", {
        class: "alarm" + (a.active ? " active" : "") + (a.acknowledged ? "" : " waiting"),
        "data-alarm": a.name,
      });
      const ack = el("button", {
        type: "button", class: "primary", "data-ack": a.name, text: "Acknowledge",
        hidden: a.acknowledged, disabled: !signedIn(),
        title: signedIn() ? "" : "Sign in with the operator's token to acknowledge",
      });
      ack.addEventListener("click", () => acknowledge(a.name));
      li.append(
        el("span", { class: "level", "data-level": a.level, text: a.level }),
        el("span", { class: "text", text: a.text }),
        ack,
        el("span", { class: "when", text: a.name + " · " + when(a) }));
      return li;
    });
    if (rows.length === 0) rows.push(el("li", { class: "empty", text: "no alarm" }));
    box.replaceChildren(...rows);
  }

  async function pollAlarms() {
    try {
      const r = await fetch("/api/alarms");
      op.alarms = r.ok ? await r.json() : null;
    } catch (e) {
      return;
    }
    renderAlarms();
  }

  // ---- The operator's tags ----

  // Inputs belong to their module, and a pushed-down output to the module's own logic: the
  // scan refuses a write to either, so the page offers none.
  function writable(t) {
    return t.kind !== "input" && !t.pushed;
  }

  async function write(tag, value) {
    const r = await post("/api/write", { tag, value });
    toast(r.ok ? r.message : "Not written: " + r.error, !r.ok);
  }

  function buildTags() {
    const box = $("tags");
    const cards = op.info.operator.map((i) => {
      const t = op.info.tags[i];
      const card = el("div", { class: "tag", "data-tag": t.name });
      card.append(el("span", { class: "name", text: t.name }));
      if (t.description) card.append(el("span", { class: "desc", text: t.description }));
      card.append(el("span", { class: "value", "data-value": t.name, text: "…" }));
      if (writable(t) && op.info.writes) {
        const form = el("form", { "data-write": t.name });
        if (t.type === "bool") {
          for (const v of ["1", "0"]) {
            const b = el("button", { type: "button", "data-value": v, text: "Set " + v, disabled: !signedIn() });
            b.addEventListener("click", () => write(t.name, v));
            form.append(b);
          }
        } else {
          const input = el("input", { type: "text", inputmode: "decimal", "aria-label": t.name + " value", disabled: !signedIn() });
          form.append(input, el("button", { type: "submit", class: "primary", text: "Write", disabled: !signedIn() }));
          form.addEventListener("submit", (ev) => {
            ev.preventDefault();
            if (input.value.trim() !== "") write(t.name, input.value.trim());
          });
        }
        card.append(form);
      }
      return card;
    });
    if (cards.length === 0) cards.push(el("div", { class: "empty", text: "no tag is marked operator: true in the project" }));
    box.replaceChildren(...cards);
  }

  function updateTags() {
    const s = op.values;
    if (!s) return;
    for (const i of op.info.operator) {
      const t = op.info.tags[i];
      const v = document.querySelector(`.value[data-value="${t.name}"]`);
      if (!v) continue;
      v.textContent = fmtValue(s.v[i], t.type);
      v.dataset.quality = ["good", "stale", "bad"][s.q[i]] || "bad";
    }
  }

  function renderState() {
    const s = op.values;
    const st = $("state");
    const quiet = Date.now() - op.lastEvent > 3000;
    const word = !s ? "connecting" : s.stopped ? "stopped" : quiet ? "lost" : "running";
    st.dataset.state = word;
    st.textContent = word === "lost" ? "no connection" : word;
  }

  function connect() {
    const es = new EventSource("/api/events");
    es.addEventListener("state", (e) => {
      op.values = JSON.parse(e.data);
      op.lastEvent = Date.now();
      updateTags();
      renderState();
    });
  }

  async function boot() {
    try {
      op.info = await (await fetch("/api/info")).json();
    } catch (e) {
      $("state").textContent = "no connection";
      setTimeout(boot, 2000);
      return;
    }
    document.title = op.info.project + " · operator";
    $("project").textContent = op.info.project;
    $("ack-all").addEventListener("click", () => acknowledge("all"));
    refresh();
    connect();
    pollAlarms();
    setInterval(pollAlarms, 1000);
    setInterval(renderState, 1000);
  }

  document.addEventListener("DOMContentLoaded", boot);
})();
