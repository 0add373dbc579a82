// Helpers both pages use (the full page, app.js, and the operator's page, operator.js):
// building elements, the toast, a value as text, a JSON POST with the token, the sign-in.
"use strict";

window.softplcShared = (() => {
  // `data-*`, `aria-*` and `inputmode` are attributes; every other key is the element's
  // property of that name (`hidden`, `disabled`, `type`, `title`, ...).
  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === undefined || v === null || v === false) continue;
      if (k === "class") e.className = v;
      else if (k === "text") e.textContent = v;
      else if (k.startsWith("data-") || k.startsWith("aria-") || k === "inputmode") e.setAttribute(k, v);
      else if (k === "for") e.htmlFor = v;
      else e[k] = v;
    }
    for (const c of children) {
      if (c === null || c === undefined) continue;
      e.append(c instanceof Node ? c : document.createTextNode(String(c)));
    }
    return e;
  }

  function fmtValue(v, type) {
    if (v === null || v === undefined) return "NaN";
    if (typeof v === "boolean") return v ? "1" : "0";
    if (type === "f32") {
      const t = Number(v).toPrecision(6);
      return t.includes("e") ? t : String(Number(t));
    }
    return String(v);
  }

  function toast(text, error) {
    const t = document.getElementById("toast");
    t.textContent = text;
    t.className = "toast show" + (error ? " error" : "");
    clearTimeout(toast.timer);
    toast.timer = setTimeout(() => { t.className = "toast" + (error ? " error" : ""); }, error ? 6000 : 3000);
  }

  // The server's JSON answer, or one saying why there is none.
  async function post(path, body, token) {
    let r;
    try {
      r = await fetch(path, {
        method: "POST",
        headers: { "Content-Type": "application/json", Authorization: "Bearer " + token },
        body: JSON.stringify(body),
      });
    } catch (e) {
      return { ok: false, error: "the PLC cannot be reached" };
    }
    const j = await r.json().catch(() => null);
    return j || { ok: false, error: r.status + " " + r.statusText };
  }

  // The sign-in form: the token is checked (POST /api/auth), kept in this tab's
  // sessionStorage with its role, and handed to `done(token, role)`.
  function signInForm(done) {
    const form = el("form", { id: "login" });
    const input = el("input", { type: "password", placeholder: "token", id: "token", autocomplete: "current-password", "aria-label": "token" });
    form.append(input, el("button", { type: "submit", class: "primary", text: "Sign in" }));
    form.addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const token = input.value.trim();
      if (!token) return;
      const r = await post("/api/auth", {}, token);
      if (!r.ok) {
        toast("Sign-in refused: " + r.error, true);
        return;
      }
      const role = r.role || "engineer";
      sessionStorage.setItem("softplc-token", token);
      sessionStorage.setItem("softplc-role", role);
      done(token, role);
      toast("Signed in as " + role);
    });
    return form;
  }

  return { el, fmtValue, toast, post, signInForm };
})();
