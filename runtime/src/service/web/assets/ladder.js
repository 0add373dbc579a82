// softplc web page: a ladder program drawn as ladder diagrams (SVG), power flow lit live.
//
// The diagrams come from /api/info's `program.diagram` (the compiler's own parse of each rung:
// series and parallel elements, coils, math boxes, function blocks); the page never parses a
// rung. `softplcLadder.build(root, program, info, prefix)` draws them into the Program view (the text
// view stays one click away) and returns `{ update(state) }`, called with every `state` event.
//
// Lighting: a contact is lit while it passes power (NO with its tag true, NC with it false), a
// wire while power reaches it, a coil while energised. An edge passes power for one scan only;
// the page lights it when it sees its input change between two states. A block's outputs are
// read from the live state when it carries them (`b`), else from a coil it drives; otherwise
// they are drawn unknown (grey). A block of one's own (`own`) reads every pin from its
// instance's tags (`s1.done`); clicking it (or its rung's "body" button) shows its body drawn
// with that instance's live values.
"use strict";

window.softplcLadder = (() => {
  const SVG = "http://www.w3.org/2000/svg";
  const CW = 96; // one cell's width
  const RH = 58; // one row's height
  const MID = 30; // the wire's height in a row
  const RAIL = 14; // room for a rail

  function svg(tag, attrs, text) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function html(tag, attrs, text) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  // ---- Reading live values ----

  // `ctx` holds the info, the state now and the one before, and the block outputs inferred from
  // the coils they drive.
  function operandText(o) {
    if (o.k === "tag") return o.name;
    if (o.k === "member") return o.instance + "." + o.member;
    return o.text;
  }

  function literalValue(text) {
    if (text === "true") return true;
    if (text === "false") return false;
    const m = /^(-?[0-9.]+)\s*([a-z]*)$/.exec(text);
    if (!m) return null;
    const n = parseFloat(m[1]);
    const scale = { "": 1, ms: 1, s: 1000, min: 60000, m: 60000, h: 3600000 }[m[2]];
    // A duration compares with ET in milliseconds.
    return scale === undefined ? n : n * scale;
  }

  function memberValue(ctx, s, inst, member) {
    if (!s) return null;
    // A task's later programs number their instances after the earlier ones' (`inst_base`).
    const live = s.b && s.b[(ctx.base || 0) + inst];
    if (live && live[member] !== undefined) return live[member];
    const inferred = ctx.inferred[inst + "." + member];
    if (inferred) {
      const v = s.v[inferred.tag];
      return inferred.negated ? v !== true : v === true;
    }
    return null;
  }

  // The tag of variable `name` of a block of one's own's instance.
  function ownTag(b, name) {
    for (const [n, t] of b.own.tags) if (n === name) return t;
    return undefined;
  }

  // An output of a block: a block of one's own's from its instance's tag.
  function blockValue(ctx, s, b, member) {
    if (!b.own) return memberValue(ctx, s, b.inst, member);
    const t = ownTag(b, member);
    return s && t !== undefined && s.v[t] !== undefined ? s.v[t] : null;
  }

  function value(ctx, s, o) {
    if (o.k === "literal") return literalValue(o.text);
    if (!s) return null;
    if (o.k === "tag") return s.v[o.tag];
    return memberValue(ctx, s, o.inst, o.member);
  }

  function truthy(v) {
    return v === true || (typeof v === "number" && v !== 0);
  }

  function fmt(v) {
    if (v === null || v === undefined) return "?";
    if (typeof v === "boolean") return v ? "1" : "0";
    return Number.isInteger(v) ? String(v) : v.toFixed(2);
  }

  function compare(op, a, b) {
    if (a === null || b === null || a === undefined || b === undefined) return null;
    const x = Number(a), y = Number(b);
    switch (op) {
      case "<": return x < y;
      case "<=": return x <= y;
      case ">": return x > y;
      case ">=": return x >= y;
      case "==": return x === y;
      case "!=": return x !== y;
    }
    return null;
  }

  // ---- Layout: each node knows its size (cells, rows), draws itself once and lights itself ----
  //
  // node = { w, h, draw(g, x, y), value(ctx) -> bool|null, paint(ctx, powered) -> powered out }

  function wire(g, x1, y1, x2, y2) {
    const l = svg("line", { x1, y1, x2, y2, class: "lad-wire" });
    g.append(l);
    return l;
  }

  function lit(e, on, unknown) {
    if (!e) return;
    e.classList.toggle("lit", on === true);
    e.classList.toggle("unknown", unknown === true);
  }

  // One cell with a symbol between two wire stubs, a label above and a live value below.
  function cell(label, symbol, opts) {
    const node = { w: 1, h: 1, parts: {} };
    node.draw = (g, x, y) => {
      const p = node.parts;
      const m = y + MID;
      p.group = svg("g", { class: "lad-el " + (opts.cls || ""), "data-kind": opts.kind, "data-tag": opts.tag || "", "data-negated": opts.negated ? "1" : "0" });
      p.left = wire(p.group, x, m, x + 30, m);
      p.right = wire(p.group, x + 66, m, x + CW, m);
      symbol(p.group, x + 30, m);
      p.group.append(svg("text", { x: x + 48, y: y + 12, class: "lad-label" }, label));
      p.value = svg("text", { x: x + 48, y: y + MID + 24, class: "lad-value" }, "");
      p.group.append(p.value);
      g.append(p.group);
    };
    node.value = opts.value;
    node.paint = (ctx, powered) => {
      const v = node.value(ctx);
      const passes = v === true;
      const out = powered && passes;
      const p = node.parts;
      p.group.classList.toggle("pass", passes);
      p.group.classList.toggle("unknown", v === null);
      p.group.dataset.passes = passes ? "1" : "0";
      p.group.classList.toggle("forced", opts.forced !== undefined && forced(ctx, opts.forced));
      lit(p.left, powered);
      lit(p.right, out);
      if (opts.shown) p.value.textContent = opts.shown(ctx);
      return out;
    };
    return node;
  }

  function contactSymbol(negated, letter) {
    return (g, x, m) => {
      g.append(svg("line", { x1: x, y1: m - 12, x2: x, y2: m + 12, class: "lad-sym" }));
      g.append(svg("line", { x1: x + 36, y1: m - 12, x2: x + 36, y2: m + 12, class: "lad-sym" }));
      if (negated) g.append(svg("line", { x1: x + 6, y1: m + 11, x2: x + 30, y2: m - 11, class: "lad-sym" }));
      if (letter) g.append(svg("text", { x: x + 18, y: m + 5, class: "lad-letter" }, letter));
    };
  }

  function boxSymbol(text) {
    return (g, x, m) => {
      g.append(svg("rect", { x: x - 4, y: m - 13, width: 44, height: 26, rx: 3, class: "lad-sym lad-box" }));
      g.append(svg("text", { x: x + 18, y: m + 4, class: "lad-letter" }, text));
    };
  }

  // Whether tag `tag` is forced now (a force holds the value the diagram is lit by).
  function forced(ctx, tag) {
    return !!ctx.s && Array.isArray(ctx.s.forced) && ctx.s.forced.includes(tag);
  }

  function contact(e) {
    const o = e.of;
    return cell(operandText(o), contactSymbol(e.negated), {
      kind: e.negated ? "nc" : "no", tag: operandText(o), negated: e.negated,
      forced: o.k === "tag" ? o.tag : undefined,
      value: (ctx) => {
        const v = value(ctx, ctx.s, o);
        if (v === null || v === undefined) return null;
        return truthy(v) !== e.negated;
      },
      shown: (ctx) => (o.k === "literal" ? "" : fmt(value(ctx, ctx.s, o))),
    });
  }

  function quality(e) {
    const o = e.of;
    const name = (e.good ? "good(" : "bad(") + o.name + ")";
    return cell(name, contactSymbol(e.negated, e.good ? "G" : "B"), {
      kind: "quality", tag: o.name, negated: e.negated,
      value: (ctx) => {
        if (!ctx.s) return null;
        const q = ctx.s.q[o.tag];
        return (e.good ? q === 0 : q === 2) !== e.negated;
      },
      shown: (ctx) => (ctx.s ? ["good", "stale", "bad"][ctx.s.q[o.tag]] || "?" : ""),
    });
  }

  function comparison(e) {
    const text = operandText(e.lhs) + " " + e.op + " " + operandText(e.rhs);
    return cell(text, boxSymbol((e.negated ? "/" : "") + e.op), {
      kind: "compare", tag: operandText(e.lhs), negated: e.negated,
      value: (ctx) => {
        const r = compare(e.op, value(ctx, ctx.s, e.lhs), value(ctx, ctx.s, e.rhs));
        return r === null ? null : r !== e.negated;
      },
      shown: (ctx) => [e.lhs, e.rhs].filter((o) => o.k !== "literal").map((o) => fmt(value(ctx, ctx.s, o))).join(" · "),
    });
  }

  // An edge of a single contact is a P/N contact on it; of a group, the group then a P/N cell.
  function edge(e) {
    const letter = e.rising ? "P" : "N";
    const single = e.of.k === "contact" && !e.of.negated ? e.of.of : null;
    const inner = single ? null : layout(e.of);
    const seen = (ctx) => {
      // The input's value now and in the state before, as this page saw them.
      const now = single ? truthy(value(ctx, ctx.s, single)) : inner.value(ctx) === true;
      const before = single ? truthy(value(ctx, ctx.prev, single)) : inner.value({ ...ctx, s: ctx.prev }) === true;
      if (!ctx.prev) return false;
      const changed = e.rising ? now && !before : !now && before;
      return changed !== e.negated;
    };
    const label = single ? operandText(single) : (e.rising ? "rising" : "falling");
    const c = cell(label, contactSymbol(e.negated, letter), {
      kind: e.rising ? "rising" : "falling", tag: single ? operandText(single) : "", negated: e.negated,
      value: seen,
      shown: (ctx) => (single ? fmt(value(ctx, ctx.s, single)) : ""),
    });
    if (single) return c;
    return series([inner, c], (ctx) => seen(ctx));
  }

  // Items side by side; `own` replaces the value (an edge of a group).
  function series(items, own) {
    const node = {
      w: items.reduce((a, i) => a + i.w, 0),
      h: items.reduce((a, i) => Math.max(a, i.h), 1),
    };
    node.draw = (g, x, y) => {
      let at = x;
      for (const i of items) {
        i.draw(g, at, y);
        at += i.w * CW;
      }
    };
    node.value = own || ((ctx) => {
      let all = true;
      for (const i of items) {
        const v = i.value(ctx);
        if (v === null) return null;
        all = all && v;
      }
      return all;
    });
    node.paint = (ctx, powered) => {
      let p = powered;
      for (const i of items) p = i.paint(ctx, p);
      return own ? powered && own(ctx) === true : p;
    };
    return node;
  }

  function parallel(branches) {
    const node = {
      w: branches.reduce((a, b) => Math.max(a, b.w), 1),
      h: branches.reduce((a, b) => a + b.h, 0),
      fill: [],
    };
    node.draw = (g, x, y) => {
      let row = 0;
      const last = branches.reduce((a, b, i) => (i < branches.length - 1 ? a + b.h : a), 0);
      node.leftRail = wire(g, x + 1, y + MID, x + 1, y + last * RH + MID);
      node.rightRail = wire(g, x + node.w * CW - 1, y + MID, x + node.w * CW - 1, y + last * RH + MID);
      node.leftRail.classList.add("lad-branch");
      node.rightRail.classList.add("lad-branch");
      for (const b of branches) {
        b.draw(g, x, y + row * RH);
        node.fill.push(b.w < node.w ? wire(g, x + b.w * CW, y + row * RH + MID, x + node.w * CW, y + row * RH + MID) : null);
        row += b.h;
      }
    };
    node.value = (ctx) => {
      let any = false, unknown = false;
      for (const b of branches) {
        const v = b.value(ctx);
        if (v === true) any = true;
        if (v === null) unknown = true;
      }
      return any ? true : unknown ? null : false;
    };
    node.paint = (ctx, powered) => {
      let out = false;
      branches.forEach((b, i) => {
        const o = b.paint(ctx, powered);
        lit(node.fill[i], o);
        out = out || o;
      });
      lit(node.leftRail, powered);
      lit(node.rightRail, out);
      return out;
    };
    return node;
  }

  // `/(group)`: the group, then a cell that passes power when the group does not.
  function negatedGroup(e) {
    const inner = layout(e.of);
    const not = cell("NOT", boxSymbol("NOT"), {
      kind: "not",
      value: (ctx) => {
        const v = inner.value(ctx);
        return v === null ? null : !v;
      },
    });
    return series([inner, not], (ctx) => not.value(ctx));
  }

  function layout(e) {
    switch (e.k) {
      case "contact": return contact(e);
      case "quality": return quality(e);
      case "compare": return comparison(e);
      case "edge": return edge(e);
      case "series": return series(e.items.map(layout));
      case "parallel": return parallel(e.branches.map(layout));
      case "not": return negatedGroup(e);
    }
    return cell("?", boxSymbol("?"), { kind: "unknown", value: () => null });
  }

  // An always-powered condition: a plain wire.
  function straight() {
    const node = { w: 1, h: 1 };
    node.draw = (g, x, y) => { node.line = wire(g, x, y + MID, x + CW, y + MID); };
    node.value = () => true;
    node.paint = (ctx, powered) => { lit(node.line, powered); return powered; };
    return node;
  }

  // ---- Outputs: coils, math boxes, a block ----

  const COIL_MARK = { normal: "", negated: "/", set: "S", reset: "R" };

  // A coil, drawn at the right end of its row; lit while energised (power reaches it).
  function coil(c) {
    const node = { w: 1, h: 1 };
    node.draw = (g, x, y) => {
      const m = y + MID;
      node.group = svg("g", { class: "lad-el lad-coil", "data-kind": "coil-" + c.kind, "data-tag": c.of.name });
      node.left = wire(node.group, x, m, x + 30, m);
      node.group.append(svg("path", { d: `M ${x + 38} ${m - 13} A 14 14 0 0 0 ${x + 38} ${m + 13}`, class: "lad-sym" }));
      node.group.append(svg("path", { d: `M ${x + 58} ${m - 13} A 14 14 0 0 1 ${x + 58} ${m + 13}`, class: "lad-sym" }));
      if (COIL_MARK[c.kind]) node.group.append(svg("text", { x: x + 48, y: m + 5, class: "lad-letter" }, COIL_MARK[c.kind]));
      node.right = wire(node.group, x + 66, m, x + CW, m);
      node.group.append(svg("text", { x: x + 48, y: y + 12, class: "lad-label" }, c.of.name));
      node.value = svg("text", { x: x + 48, y: m + 24, class: "lad-value" }, "");
      node.group.append(node.value);
      g.append(node.group);
    };
    node.paint = (ctx, powered) => {
      node.group.classList.toggle("energised", powered);
      node.group.dataset.energised = powered ? "1" : "0";
      node.group.classList.toggle("forced", forced(ctx, c.of.tag));
      lit(node.left, powered);
      lit(node.right, powered);
      node.value.textContent = ctx.s ? fmt(ctx.s.v[c.of.tag]) : "";
      return powered;
    };
    return node;
  }

  function mathBox(b) {
    const node = { w: 2, h: 1 };
    node.draw = (g, x, y) => {
      const m = y + MID;
      node.group = svg("g", { class: "lad-el lad-math", "data-kind": "math", "data-tag": b.dest.name });
      node.left = wire(node.group, x, m, x + 16, m);
      node.group.append(svg("rect", { x: x + 16, y: y + 6, width: 2 * CW - 32, height: RH - 14, rx: 4, class: "lad-sym lad-box" }));
      node.group.append(svg("text", { x: x + CW, y: y + 18, class: "lad-letter" }, b.op));
      node.group.append(svg("text", { x: x + CW, y: y + 31, class: "lad-label" },
        b.args.map(operandText).join(", ") + " ⇒ " + b.dest.name));
      node.value = svg("text", { x: x + CW, y: y + 44, class: "lad-value" }, "");
      node.group.append(node.value);
      g.append(node.group);
    };
    node.paint = (ctx, powered) => {
      node.group.classList.toggle("energised", powered);
      lit(node.left, powered);
      node.value.textContent = ctx.s ? b.dest.name + " = " + fmt(ctx.s.v[b.dest.tag]) : "";
      return powered;
    };
    return node;
  }

  // Outputs stacked on the right, each on its own row, joined by a vertical wire.
  function outputs(list) {
    const nodes = list.map((o) => (o.k === "math" ? mathBox(o) : coil(o)));
    const node = { w: nodes.reduce((a, n) => Math.max(a, n.w), 1), h: Math.max(nodes.length, 1), fill: [] };
    node.draw = (g, x, y) => {
      if (nodes.length > 1) node.join = wire(g, x + 1, y + MID, x + 1, y + (nodes.length - 1) * RH + MID);
      nodes.forEach((n, i) => {
        const left = x + (node.w - n.w) * CW;
        node.fill.push(left > x ? wire(g, x, y + i * RH + MID, left, y + i * RH + MID) : null);
        n.draw(g, left, y + i * RH);
      });
    };
    node.paint = (ctx, powered) => {
      lit(node.join, powered);
      nodes.forEach((n, i) => { lit(node.fill[i], powered); n.paint(ctx, powered); });
    };
    return node;
  }

  // A block: the condition feeds its first pin; bool inputs are drawn below the condition and
  // wired to their pins; value inputs are written at their pins; the main output feeds the coils.
  function block(b, condition) {
    const powerInputs = b.inputs.filter((i) => i.k === "power").map((i) => ({ pin: i.pin, node: layout(i.of) }));
    const valueInputs = b.inputs.filter((i) => i.k === "value");
    const pinsLeft = 1 + powerInputs.length + valueInputs.length;
    const rows = Math.max(pinsLeft, b.outputs.length);
    const leftW = Math.max(condition.w, ...powerInputs.map((p) => p.node.w));
    const coils = b.coils.length ? outputs(b.coils) : null;
    const node = { w: leftW + 2 + (coils ? coils.w : 0), parts: {} };
    // Rows of the left side: the condition, then each power input.
    let row = condition.h;
    for (const p of powerInputs) { p.row = row; row += p.node.h; }
    node.h = Math.max(row, rows, coils ? coils.h : 1);
    node.draw = (g, x, y) => {
      const p = node.parts;
      condition.draw(g, x, y);
      p.condFill = condition.w < leftW ? wire(g, x + condition.w * CW, y + MID, x + leftW * CW, y + MID) : null;
      const bx = x + leftW * CW + 16;
      const bw = 2 * CW - 32;
      p.group = svg("g", { class: "lad-el lad-block" + (b.own ? " lad-own" : ""), "data-kind": "block", "data-instance": b.instance, "data-block": b.kind });
      if (b.own) p.group.append(svg("title", {}, b.kind + " " + b.instance + ": a block of your own; click to show its body"));
      p.group.append(svg("rect", { x: bx, y: y + 16, width: bw, height: rows * RH - 22, rx: 4, class: "lad-sym lad-box" }));
      p.group.append(svg("text", { x: bx + bw / 2, y: y + 12, class: "lad-label" }, b.instance));
      p.group.append(svg("text", { x: bx + bw / 2, y: y + 32, class: "lad-letter" }, b.kind));
      p.inWire = wire(p.group, x + leftW * CW, y + MID, bx, y + MID);
      // Pins: the power flow's, each power input's (at its own row), each value's.
      p.group.append(svg("text", { x: bx + 4, y: y + MID + 14, class: "lad-pin" }, b.input));
      p.powerWires = powerInputs.map((pi, k) => {
        const py = y + (k + 1) * RH + MID;
        const iy = y + pi.row * RH + MID;
        pi.node.draw(g, x, y + pi.row * RH);
        const w1 = wire(g, x + pi.node.w * CW, iy, bx - 8, iy);
        const w2 = wire(g, bx - 8, iy, bx - 8, py);
        const w3 = wire(g, bx - 8, py, bx, py);
        p.group.append(svg("text", { x: bx + 4, y: py + 4, class: "lad-pin" }, pi.pin));
        return [w1, w2, w3];
      });
      valueInputs.forEach((vi, k) => {
        const py = y + (1 + powerInputs.length + k) * RH + MID;
        p.group.append(svg("text", { x: bx + 4, y: py + 4, class: "lad-pin" }, vi.pin + " " + operandText(vi.of)));
      });
      p.outs = b.outputs.map((m, k) => {
        const t = svg("text", { x: bx + bw - 4, y: y + k * RH + MID + 14, class: "lad-pin lad-out" }, m);
        p.group.append(t);
        return t;
      });
      g.append(p.group);
      p.outWire = wire(g, bx + bw, y + MID, x + (leftW + 2) * CW, y + MID);
      if (coils) coils.draw(g, x + (leftW + 2) * CW, y);
    };
    node.value = () => null;
    node.paint = (ctx, powered) => {
      const p = node.parts;
      const fed = condition.paint(ctx, powered);
      lit(p.condFill, fed);
      lit(p.inWire, fed);
      powerInputs.forEach((pi, k) => {
        const o = pi.node.paint(ctx, powered);
        for (const w of p.powerWires[k]) lit(w, o);
      });
      const q = blockValue(ctx, ctx.s, b, b.main);
      b.outputs.forEach((m, k) => {
        const v = blockValue(ctx, ctx.s, b, m);
        p.outs[k].textContent = m + " " + (v === null ? "?" : typeof v === "boolean" ? (v ? "1" : "0") : m === "ET" ? Math.round(v) + "ms" : fmt(v));
      });
      p.group.classList.toggle("energised", q === true);
      p.group.classList.toggle("unknown", q === null);
      p.group.dataset.q = q === null ? "" : q ? "1" : "0";
      lit(p.outWire, q === true);
      if (coils) coils.paint(ctx, q === true);
      return q === true;
    };
    return node;
  }

  // ---- A rung ----

  function rungNode(r) {
    const condition = r.cond ? layout(r.cond) : straight();
    if (r.block) return block(r.block, condition);
    const outs = outputs(r.outputs);
    const node = { w: condition.w + 1 + outs.w, h: Math.max(condition.h, outs.h) };
    node.draw = (g, x, y) => {
      condition.draw(g, x, y);
      node.gap = wire(g, x + condition.w * CW, y + MID, x + (condition.w + 1) * CW, y + MID);
      outs.draw(g, x + (condition.w + 1) * CW, y);
    };
    node.paint = (ctx, powered) => {
      const p = condition.paint(ctx, powered);
      lit(node.gap, p);
      outs.paint(ctx, p);
    };
    return node;
  }

  // Block outputs known from the coils they drive everywhere in the program.
  function inferOutputs(diagram) {
    const inferred = {};
    for (const r of diagram) {
      if (!r.block) continue;
      for (const c of r.block.coils) {
        if (c.kind === "normal" || c.kind === "negated") {
          inferred[r.block.inst + "." + r.block.main] = { tag: c.of.tag, negated: c.kind === "negated" };
        }
      }
    }
    return inferred;
  }

  // A rung's diagram as an SVG: rails, the first wire, the rung's node.
  function rungPicture(node, r, n) {
    const width = node.w * CW + 2 * RAIL + 8;
    const height = node.h * RH + 6;
    const pic = svg("svg", { class: "lad-svg", width, height, viewBox: `0 0 ${width} ${height}`, "data-rung": n + 1 });
    pic.append(svg("title", {}, "line " + r.line + ": " + r.text));
    const left = RAIL, right = RAIL + 8 + node.w * CW;
    const railL = svg("line", { x1: left, y1: 2, x2: left, y2: height - 2, class: "lad-rail lit" });
    const railR = svg("line", { x1: right, y1: 2, x2: right, y2: height - 2, class: "lad-rail" });
    pic.append(railL, railR);
    const g = svg("g", {});
    g.append(svg("line", { x1: left, y1: MID + 2, x2: left + 8, y2: MID + 2, class: "lad-wire lit" }));
    node.draw(g, left + 8, 2);
    pic.append(g);
    return pic;
  }

  // The body of a block of one's own, for one instance: its rungs drawn over the instance's
  // tags (a Rhai body: its text), and every variable's value, painted with the program.
  function ownBody(b) {
    const el = html("div", { class: "lad-body", hidden: "", "data-instance": b.instance });
    el.append(html("div", { class: "lad-body-head" }, "body of " + b.kind + " " + b.instance + " · " + b.own.body_file));
    const vars = html("div", { class: "lad-vars" });
    const cells = b.own.tags.map(([name, tag]) => {
      const cell = html("span", { class: "lad-var", "data-var": name }, name + " ?");
      vars.append(cell);
      return { name, tag, cell };
    });
    el.append(vars);
    const nodes = [];
    // Bodies of the instances this body calls (`p1.la`), each shown on a click of its box,
    // painted with what this body was last painted with (it is shown, so it was).
    const nested = [];
    let last = null;
    if (b.own.body_kind === "ladder") {
      const inferred = inferOutputs(b.own.body);
      b.own.body.forEach((r, n) => {
        const node = rungNode(r);
        el.append(rungPicture(node, r, n));
        nodes.push(node);
        if (r.block && r.block.own) {
          const inner = ownBody(r.block);
          el.append(inner.el);
          nested.push(inner);
          if (node.parts && node.parts.group) {
            node.parts.group.addEventListener("click", (ev) => {
              ev.stopPropagation();
              inner.el.hidden = !inner.el.hidden;
              if (last) inner.paint(last);
            });
          }
        }
      });
      return {
        el,
        paint(ctx) {
          last = ctx;
          if (el.hidden) return;
          for (const c of cells) c.cell.textContent = c.name + " " + fmt(ctx.s ? ctx.s.v[c.tag] : null);
          const inner = { info: ctx.info, s: ctx.s, prev: ctx.prev, inferred };
          for (const node of nodes) node.paint(inner, true);
          for (const n of nested) n.paint(ctx);
        },
      };
    }
    el.append(html("pre", { class: "lad-src" }, b.own.body_text || ""));
    return {
      el,
      paint(ctx) {
        if (el.hidden) return;
        for (const c of cells) c.cell.textContent = c.name + " " + fmt(ctx.s ? ctx.s.v[c.tag] : null);
      },
    };
  }

  function build(root, program, info, prefix) {
    const pre = prefix || "";
    const ctx = { info, s: null, prev: null, inferred: inferOutputs(program.diagram), base: program.inst_base || 0 };
    const textView = html("div", { class: "lad-text", hidden: "" });
    textView.append(...root.childNodes);
    const view = html("div", { class: "ladder", id: pre + "ladder" });
    const rungs = [];
    const bodies = [];
    program.diagram.forEach((r, n) => {
      const node = rungNode(r);
      const box = html("div", { class: "lad-rung", id: pre + "rung-" + (n + 1), "data-line": r.line });
      const head = html("div", { class: "lad-head" });
      head.append(html("span", { class: "no" }, "rung " + (n + 1) + " · line " + r.line));
      if (r.title) head.append(html("span", { class: "lad-title" }, r.title));
      const line = program.lines[r.line - 1];
      for (const m of (line && line.rungs) || []) {
        const coilName = info.tags[m.coil] ? info.tags[m.coil].name : "?";
        if (m.module) {
          box.classList.add("pushed");
          head.append(html("span", {
            class: "rung-pushed", "data-pushed": m.module,
            title: coilName + " runs in module " + m.module + " (" + m.feature + "): pushed down, it reacts without the scan",
          }, "⇣ in " + m.module));
        }
      }
      const src = html("pre", { class: "lad-src", hidden: "" }, r.text);
      const toggle = html("button", { class: "lad-toggle", type: "button", title: "show the rung's source line" }, "source");
      toggle.addEventListener("click", () => {
        src.hidden = !src.hidden;
        toggle.classList.toggle("on", !src.hidden);
      });
      head.append(toggle);
      const pic = rungPicture(node, r, n);
      // The rung's comment under its head, as a printed ladder has it above the rung.
      const comment = r.comment ? html("p", { class: "lad-comment" }, r.comment) : null;
      let body = null;
      if (r.block && r.block.own) {
        body = ownBody(r.block);
        const show = html("button", { class: "lad-toggle lad-body-toggle", type: "button", title: "show the body of " + r.block.instance + " with its live values" }, "body");
        const flip = () => {
          body.el.hidden = !body.el.hidden;
          show.classList.toggle("on", !body.el.hidden);
          body.paint(ctx);
        };
        show.addEventListener("click", flip);
        if (node.parts && node.parts.group) node.parts.group.addEventListener("click", flip);
        head.append(show);
        bodies.push(body);
      }
      box.append(...[head, comment, pic, src, body && body.el].filter(Boolean));
      view.append(box);
      rungs.push(node);
    });
    const switcher = html("button", { class: "lad-switch", type: "button", id: pre + "ladder-switch" }, "show as text");
    switcher.addEventListener("click", () => {
      textView.hidden = !textView.hidden;
      view.hidden = !textView.hidden;
      switcher.textContent = textView.hidden ? "show as text" : "show as ladder";
    });
    root.append(switcher, view, textView);
    return {
      update(s) {
        ctx.prev = ctx.s;
        ctx.s = s;
        for (const node of rungs) node.paint(ctx, true);
        for (const body of bodies) body.paint(ctx);
      },
    };
  }

  return { build };
})();
