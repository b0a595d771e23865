// The planning page of rap-farm serve (plain JavaScript, no build step, no other host).
//
// A file chosen or dropped (DXF, SVG or assembly JSON) goes as it is to POST /inspect?name=FILE,
// which reads it on the service (rap.io.load_assembly) and answers the assembly JSON and its NDBG
// cells with the partitions each admits; the page draws the parts with their ids and the NDBG
// circle (arcs shaded by those counts, as `rap-farm show`). "Plan" sends that assembly to the
// JSON API's POST /plan with the chosen method and seed, and the answer (the `rap-farm plan --out`
// document) becomes a storyboard: each step's fixed parts in place, its moving parts drawn back
// along the insertion direction and in place, the direction, the score and its source. The plan
// JSON and the storyboard (PNG through a canvas, or SVG) can be downloaded. The "Robot cell"
// fieldset (shown once a file is read) sets the request's "constraints" (base part, one arm,
// insertion cones, gravity, friction, layers: rap.plan.constraints; tooltips from the API's own
// schema, the CLI's help); they are sent only when one is set, and a plan that no sequence under
// them admits is the service's one line in the status line. "or try an example:" offers a button
// per assembly shipped in the package (GET /examples, no token needed); a click fetches its JSON
// (GET /examples/NAME) and reads it exactly as a dropped NAME.json. Every request carries
// the token typed in the header (kept in sessionStorage) as "Authorization: Bearer <token>".
// Beside the storyboard, "robot program" asks POST /export for the chosen arm's program of the plan
// shown (URScript for a UR, a joint trajectory for the Panda, or waypoints; checked by that arm's
// kinematics) and saves the answer under the name the
// service gives; a refusal (a plan made without a base part in the fixture, a step out of reach)
// is the service's one line where the page shows its errors. body[data-program] says how the last
// one went: asking, saved, refused.
// body[data-state] says where the page is: idle, reading, inspected, planning, planned, error.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const TOKEN_KEY = "rap-farm-token";
  const SVG_NS = "http://www.w3.org/2000/svg"; // an XML namespace name: never fetched
  // matplotlib's tab20, chosen per part as rap.render.pictures.part_colors does
  const TAB20 = ["#1f77b4", "#aec7e8", "#ff7f0e", "#ffbb78", "#2ca02c", "#98df8a", "#d62728",
    "#ff9896", "#9467bd", "#c5b0d5", "#8c564b", "#c49c94", "#e377c2", "#f7b6d2", "#7f7f7f",
    "#c7c7c7", "#bcbd22", "#dbdb8d", "#17becf", "#9edae5"];
  const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const ROBUST = 0.95; // steps scored below it are marked, as in rap-farm's storyboard
  const SOURCE_TEXT = { model: "model", cnn: "model", sim: "simulator", random: "random",
    free: "free: no contact" };
  const PLAY_MS = 1400;

  // gen: bumped by every file and plan asked for, so that a late answer to an older one is dropped
  // planText: the plan as the service answered it, sent back to POST /export unchanged
  const state = { inspected: null, geom: null, plan: null, planText: null, details: null,
    step: 0, timer: null, fileAt: null, gen: 0 };

  // -- requests -----------------------------------------------------------------------------------
  function token() { return sessionStorage.getItem(TOKEN_KEY) || ""; }

  async function request(path, init = {}) {
    const headers = Object.assign({}, init.headers || {});
    if (token()) headers.Authorization = "Bearer " + token();
    const resp = await fetch(path, Object.assign({}, init, { headers }));
    const text = await resp.text();
    let doc = null;
    try { doc = JSON.parse(text); } catch (e) { doc = null; }
    if (!resp.ok) {
      let msg = doc && doc.error ? doc.error : `HTTP ${resp.status}`;
      if (resp.status === 401) msg += ": type the service's token at the top";
      const err = new Error(msg);
      err.status = resp.status;
      throw err;
    }
    return { doc, text, headers: resp.headers };
  }

  function say(text) {
    const m = $("message");
    m.textContent = text || "";
    m.hidden = !text;
  }

  function setState(s) { document.body.dataset.state = s; }

  async function health() {
    try {
      const { doc } = await request("/health");
      $("health").textContent = `ready: model ${doc.model || "none"}, ${doc.workers} simulation ` +
        `workers, ${doc.trials} trials per score`;
    } catch (e) {
      $("health").textContent = e.status === 401 ? "the service needs its token"
        : "service not answering: " + e.message;
    }
  }

  async function methods() { // the JSON API's own list and defaults, from its OpenAPI document
    const { doc } = await request("/openapi.json");
    const props = doc.paths["/plan"].post.requestBody.content["application/json"].schema.properties;
    const select = $("method");
    const chosen = select.value; // read again (a new token): keep what the user chose meanwhile
    select.textContent = "";
    for (const m of props.method.enum) {
      const o = document.createElement("option");
      o.value = o.textContent = m;
      select.appendChild(o);
    }
    select.value = props.method.enum.includes(chosen) ? chosen : props.method.default;
    if (!$("seed").value) $("seed").value = String(props.seed.default);
    const cell = props.constraints.properties; // the CLI's help texts (rap.plan.cell_help)
    for (const label of document.querySelectorAll("#cell label[data-help]")) {
      label.title = cell[label.dataset.help].description + (label.dataset.help === "directions"
        ? " Here: several cones separated by spaces, e.g. 0,-1:30 -1,0:30." : "");
    }
    $("cell-friction").placeholder = String(cell.friction.default);
    $("perturbed-label").title = props.perturbed_candidate.description;
    searchOnly();
  }

  function searchOnly() { // the perturbed candidate is the search's (POST /plan refuses it else)
    $("perturbed").disabled = $("method").value !== "search";
  }

  // -- the robot cell -----------------------------------------------------------------------------
  function fillBase(ids) { // "none" and the assembly's parts; the chosen part kept where it is one
    const select = $("cell-base"), chosen = select.value;
    select.textContent = "";
    for (const [value, text] of [["", "none"]].concat(ids.map((id) => [id, id]))) {
      const o = document.createElement("option");
      o.value = value;
      o.textContent = text;
      select.appendChild(o);
    }
    select.value = ids.includes(chosen) ? chosen : "";
    $("cell").hidden = false;
  }

  // the insertion cones typed, as the CLI's repeated --directions DX,DY:DEG: separated by spaces
  // (or commas after a DEG); what is not a cone goes as typed, for the service to name
  function cones(text) {
    const out = [];
    for (const chunk of text.replace(/\s*([,:])\s*/g, "$1").split(/[\s;]+/).filter(Boolean)) {
      let acc = [];
      for (const piece of chunk.split(",").filter(Boolean)) {
        acc.push(piece);
        if (piece.includes(":")) { out.push(acc.join(",")); acc = []; }
      }
      if (acc.length) out.push(acc.join(","));
    }
    return out;
  }

  // the request's "constraints": only what is set (null when nothing is); the service checks it
  function constraints() {
    const c = {};
    if ($("cell-base").value) c.base = $("cell-base").value;
    if ($("cell-linear").checked) c.linear = true;
    const dirs = cones($("cell-directions").value);
    if (dirs.length) c.directions = dirs;
    const gravity = $("cell-gravity").value.trim();
    if (gravity) c.gravity = gravity;
    const friction = $("cell-friction");
    if (friction.validity.badInput) throw new Error("friction: type a number >= 0, or leave it " +
      "blank for the service's default " + friction.placeholder);
    if (friction.value !== "") c.friction = Number(friction.value);
    if ($("cell-layers").checked) c.layers = true;
    return Object.keys(c).length ? c : null;
  }

  // a plan's constraints in words, as CellConstraints.describe() says them on the command line
  function cellText(c) {
    const out = [];
    if (c.base !== null && c.base !== undefined) out.push(`${c.base} fixed in the fixture`);
    if (c.linear) out.push("one part per step");
    if (c.directions && c.directions.length) {
      out.push("insertion within " + c.directions.map((t) => {
        const [vec, deg] = t.split(":");
        return `${deg}\u00b0 of (${vec})`;
      }).join(" or "));
    }
    if (c.gravity) out.push(`stable under gravity (${c.gravity}), friction ${c.friction}`);
    if (c.layers) out.push("in layers against gravity");
    return out.join(", ");
  }

  // -- geometry -------------------------------------------------------------------------------------
  function geometry(asm) {
    const ids = asm.parts.map((p) => p.id);
    const rings = {}, colors = {};
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    asm.parts.forEach((p, i) => {
      rings[p.id] = [p.polygon].concat(p.holes || []);
      colors[p.id] = TAB20[i < 10 ? (2 * i) % 20 : (2 * i + 1) % 20];
      for (const [x, y] of p.polygon) {
        x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
      }
    });
    return { name: asm.name, ids, rings, colors, bounds: [x0, y0, x1, y1],
      size: Math.max(x1 - x0, y1 - y0) || 1 };
  }

  function boundsOf(geom, ids) {
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (const id of ids) {
      for (const [x, y] of geom.rings[id][0]) {
        x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
      }
    }
    return [x0, y0, x1, y1];
  }

  // a point well inside a part: the middle of the widest span on a few horizontal lines
  function labelPoint(rings) {
    const outer = rings[0];
    const ys = outer.map((v) => v[1]);
    const lo = Math.min(...ys), hi = Math.max(...ys);
    let best = null;
    for (const f of [0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8]) {
      const y = lo + f * (hi - lo);
      const xs = [];
      for (const ring of rings) {
        for (let i = 0; i < ring.length; i++) {
          const a = ring[i], b = ring[(i + 1) % ring.length];
          if ((a[1] > y) !== (b[1] > y)) xs.push(a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]));
        }
      }
      xs.sort((p, q) => p - q);
      for (let i = 0; i + 1 < xs.length; i += 2) {
        const span = xs[i + 1] - xs[i];
        if (!best || span > best.span * 1.05) best = { span, x: (xs[i] + xs[i + 1]) / 2, y };
      }
    }
    return best ? [best.x, best.y] : outer[0];
  }

  const esc = (s) => String(s).replace(/[&<>"']/g,
    (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
  const num = (v) => +v.toFixed(6);

  // SVG y grows downwards: every y is drawn as -y
  function partPath(rings, dx, dy) {
    return rings.map((r) => "M" + r.map(([x, y]) => `${num(x + dx)},${num(-(y + dy))}`)
      .join("L") + "Z").join("");
  }

  function partsSvg(geom, ids, opt = {}) {
    const dx = opt.offset ? opt.offset[0] : 0, dy = opt.offset ? opt.offset[1] : 0;
    const font = geom.size * (opt.font || 0.032);
    let out = "";
    for (const id of ids) {
      const fill = opt.ghost ? "#eef0f3" : geom.colors[id];
      const stroke = opt.ghost ? "#b8bec8" : "#222";
      const dash = opt.dashed ? ` stroke-dasharray="${num(geom.size * 0.015)}"` : "";
      out += `<path d="${partPath(geom.rings[id], dx, dy)}" fill="${fill}" fill-rule="evenodd" ` +
        `fill-opacity="${opt.alpha || 1}" stroke="${stroke}" stroke-width="${num(geom.size * 0.004)}"` +
        `${dash}><title>${esc(id)}</title></path>`;
    }
    if (opt.labels) {
      for (const id of ids) {
        const [x, y] = labelPoint(geom.rings[id]);
        out += `<text x="${num(x + dx)}" y="${num(-(y + dy))}" font-size="${num(font)}" ` +
          `text-anchor="middle" dominant-baseline="central" font-family="sans-serif" ` +
          `stroke="#fff" stroke-width="${num(font * 0.18)}" paint-order="stroke" ` +
          `fill="#111">${esc(id)}</text>`;
      }
    }
    return out;
  }

  function viewBox(b, pad) {
    const p = pad * Math.max(b[2] - b[0], b[3] - b[1]);
    return [b[0] - p, -b[3] - p, b[2] - b[0] + 2 * p, b[3] - b[1] + 2 * p].map(num).join(" ");
  }

  function svg(box, inner, attrs = "") {
    return `<svg xmlns="${SVG_NS}" viewBox="${box}" ${attrs}>${inner}</svg>`;
  }

  // -- the assembly and its NDBG circle -------------------------------------------------------------
  function viridis(t) {
    const x = Math.max(0, Math.min(1, t)) * (VIRIDIS.length - 1);
    const i = Math.min(VIRIDIS.length - 2, Math.floor(x)), f = x - i;
    const c = VIRIDIS[i].map((v, k) => Math.round(v + f * (VIRIDIS[i + 1][k] - v)));
    return `rgb(${c.join(",")})`;
  }

  function cellColour(count, top) { return count === 0 ? "#ffffff" : viridis(0.15 + 0.85 * count / top); }

  function xy(deg, r) {
    const a = deg * Math.PI / 180;
    return [num(r * Math.cos(a)), num(-r * Math.sin(a))];
  }

  function polar(deg, r) { return xy(deg, r).join(","); }

  function ringSector(start, end, r0, r1) {
    if (end - start >= 359.999) { // the whole ring
      return `M${polar(0, r1)}A${r1},${r1} 0 1 0 ${polar(180, r1)}A${r1},${r1} 0 1 0 ${polar(0, r1)}Z` +
        `M${polar(0, r0)}A${r0},${r0} 0 1 0 ${polar(180, r0)}A${r0},${r0} 0 1 0 ${polar(0, r0)}Z`;
    }
    const large = end - start > 180 ? 1 : 0;
    return `M${polar(start, r1)}A${r1},${r1} 0 ${large} 0 ${polar(end, r1)}` +
      `L${polar(end, r0)}A${r0},${r0} 0 ${large} 1 ${polar(start, r0)}Z`;
  }

  // as rap.render.pictures.assembly_figure: arcs between the vertex cells, shaded by the number
  // of partitions of the whole assembly the cell admits (white: none); vertices as ticks
  function ndbgSvg(cells) {
    const n = cells.length;
    const top = Math.max(1, ...cells.map((c) => c.partitions));
    const angle = cells.map((c) => ((Math.atan2(c.direction[1], c.direction[0]) * 180 / Math.PI) + 360) % 360);
    const vertex = cells.map((c) => c.kind === "vertex");
    const anyVertex = vertex.some(Boolean);
    let out = "";
    cells.forEach((c, i) => {
      if (c.kind !== "arc") return;
      let start = 0, end = 360;
      if (anyVertex) {
        start = vertex[(i - 1 + n) % n] ? angle[(i - 1 + n) % n] : angle[i] - 1;
        end = vertex[(i + 1) % n] ? angle[(i + 1) % n] : angle[i] + 1;
        if (end <= start) end += 360;
      }
      out += `<path d="${ringSector(start, end, 0.72, 1)}" fill="${cellColour(c.partitions, top)}" ` +
        `fill-rule="evenodd" stroke="#999" stroke-width="0.004"><title>arc ${num(start)}&#176;` +
        `&#8211;${num(end % 360)}&#176;: ${c.partitions} partitions</title></path>`;
    });
    cells.forEach((c, i) => {
      if (c.kind !== "vertex") return;
      const colour = c.partitions === 0 ? "#d9d9d9" : cellColour(c.partitions, top);
      const [x1, y1] = xy(angle[i], 0.66), [x2, y2] = xy(angle[i], 1.08);
      out += `<g><title>vertex ${num(angle[i])}&#176;: ${c.partitions} partitions</title>` +
        `<line x1="${x1}" y1="${y1}" x2="${x2}" y2="${y2}" stroke="${colour}" stroke-width="0.018"/>` +
        `<line x1="${x1}" y1="${y1}" x2="${x2}" y2="${y2}" stroke="#000" stroke-width="0.004"/></g>`;
    });
    out += `<line x1="0" y1="0" x2="0.45" y2="0" stroke="#777" stroke-width="0.008"/>` +
      `<path d="M0.5,0L0.44,-0.025L0.44,0.025Z" fill="#777"/>` +
      `<text x="0.52" y="-0.03" font-size="0.07" fill="#777" font-family="sans-serif">0&#176;</text>`;
    return { svg: svg("-1.15 -1.15 2.3 2.3", out, 'preserveAspectRatio="xMidYMid meet"'), top,
      vertices: vertex.filter(Boolean).length, arcs: n - vertex.filter(Boolean).length };
  }

  function showAssembly(doc) {
    const geom = state.geom = geometry(doc.assembly);
    $("parts-title").textContent = `${geom.name}: ${geom.ids.length} parts`;
    $("parts-view").innerHTML = svg(viewBox(geom.bounds, 0.06),
      partsSvg(geom, geom.ids, { labels: true }), 'preserveAspectRatio="xMidYMid meet"');
    const circle = ndbgSvg(doc.cells);
    $("ndbg-title").textContent =
      `NDBG: ${circle.vertices} vertices, ${circle.arcs} arcs (removal directions; removal = -insertion)`;
    $("ndbg-view").innerHTML = circle.svg;
    $("ndbg-legend").innerHTML = `<span>0</span><span class="bar" style="background: linear-gradient(` +
      `to right, ${[0, 0.25, 0.5, 0.75, 1].map((t) => viridis(0.15 + 0.85 * t)).join(", ")})"></span>` +
      `<span>${circle.top}</span><span>partitions of the whole assembly each direction admits` +
      ` (white: none)</span>`;
    $("assembly-section").hidden = false;
    fillBase(geom.ids);
    $("plan").disabled = false;
  }

  // -- the file -------------------------------------------------------------------------------------
  async function readFile(file) {
    const gen = ++state.gen;
    stop();
    say("");
    state.fileAt = performance.now();
    state.plan = state.planText = null;
    state.inspected = null;
    $("plan").disabled = true;
    $("plan-status").textContent = "";
    $("story-section").hidden = true;
    $("file-status").textContent = `reading ${file.name} (${file.size} bytes) ...`;
    setState("reading");
    try {
      const body = await file.arrayBuffer();
      const { doc } = await request("/inspect?name=" + encodeURIComponent(file.name), {
        method: "POST", body, headers: { "Content-Type": "application/octet-stream" } });
      if (gen !== state.gen) return;
      state.inspected = doc;
      showAssembly(doc);
      $("file-status").textContent = `${file.name}: ${doc.assembly.parts.length} parts, ` +
        `${doc.cells.length} NDBG cells`;
      setState("inspected");
    } catch (e) {
      if (gen !== state.gen) return;
      $("file-status").textContent = `${file.name}: not read`;
      say(e.message);
      setState("error");
      return;
    }
    if ($("auto-plan").checked) await plan();
  }

  // -- the shipped examples -------------------------------------------------------------------------
  async function examples() { // a button per example: public data, as the page is
    const { doc } = await request("/examples");
    const row = $("example-buttons");
    row.textContent = "";
    for (const ex of doc) {
      const b = document.createElement("button");
      b.type = "button";
      b.textContent = ex.name;
      b.dataset.example = ex.name;
      b.title = `${ex.name}.json: ${ex.parts} parts, shipped with rap-farm`;
      b.addEventListener("click", () => readExample(ex.name));
      row.appendChild(b);
    }
    $("examples").hidden = doc.length === 0;
  }

  // an example goes the way of a dropped file: its JSON, as it came, is NAME.json
  async function readExample(name) {
    const gen = ++state.gen;
    say("");
    $("file-status").textContent = `fetching the example ${name} ...`;
    setState("reading");
    let text;
    try {
      ({ text } = await request("/examples/" + encodeURIComponent(name)));
    } catch (e) {
      if (gen !== state.gen) return;
      $("file-status").textContent = `${name}: not read`;
      say(e.message);
      setState("error");
      return;
    }
    if (gen !== state.gen) return;
    await readFile(new File([text], name + ".json", { type: "application/json" }));
  }

  // -- planning -------------------------------------------------------------------------------------
  async function plan() {
    if (!state.inspected) return;
    const seed = $("seed").value.trim();
    if (!/^-?[0-9]+$/.test(seed)) { say(`seed ${JSON.stringify(seed)}: must be an integer`); return; }
    let cell;
    try { cell = constraints(); } catch (e) { say(e.message); return; }
    const gen = ++state.gen;
    stop();
    say("");
    setState("planning");
    $("plan").disabled = true;
    $("plan-status").textContent = `planning with ${$("method").value}` +
      (cell ? " in the robot cell" : "") + " ...";
    $("plan-status").title = "";
    const asked = performance.now();
    // the seed is spliced as typed: JSON numbers past 2^53 would lose digits in JavaScript
    const perturbed = $("perturbed").checked && $("method").value === "search";
    const body = `{"assembly":${JSON.stringify(state.inspected.assembly)},` +
      `"method":${JSON.stringify($("method").value)},"seed":${seed}` +
      (cell ? `,"constraints":${JSON.stringify(cell)}` : "") +
      (perturbed ? `,"perturbed_candidate":true` : "") + "}";
    try {
      const { doc, text, headers } = await request("/plan", { method: "POST", body,
        headers: { "Content-Type": "application/json" } });
      if (gen !== state.gen) return;
      try { state.details = JSON.parse(headers.get("X-Plan-Details") || "null"); }
      catch (e) { state.details = null; }
      state.plan = doc;
      state.planText = text;
      showPlan(doc, (performance.now() - asked) / 1000);
      setState("planned");
    } catch (e) {
      if (gen !== state.gen) return;
      $("plan-status").textContent = "";
      say(e.message);
      setState("error");
    } finally {
      $("plan").disabled = state.inspected === null;
    }
  }

  function showPlan(doc, roundTrip) {
    const total = state.fileAt === null ? null : (performance.now() - state.fileAt) / 1000;
    state.fileAt = null;
    const timing = `answered in ${roundTrip.toFixed(2)} s` +
      (total === null ? "" : `, ${total.toFixed(2)} s from the file to this plan`);
    document.body.dataset.fileToPlanS = total === null ? "" : total.toFixed(3);
    delete document.body.dataset.program;
    // the robot cell the plan obeys, and what its scores cover (the plan's "score_note")
    const cell = doc.constraints ? ` (robot cell: ${cellText(doc.constraints)})` : "";
    $("plan-status").title = doc.score_note || "";
    if (doc.feasible !== true) {
      $("story-section").hidden = true;
      // under constraints the service's line names the rule that blocks (or the interlock)
      // the service's own line: it names an interlock only where nothing separates the parts
      const why = doc.feasible === false
        ? (doc.message || `no assembly sequence: the subassembly {${doc.interlocked.join(", ")}} is interlocked`)
        : `no plan: ${doc.status} (${doc.message})`;
      $("plan-status").textContent = `${doc.method}: ${why}; ${timing}`;
      return;
    }
    const r = (doc.robustness === null ? "?" : doc.robustness.toFixed(3)) +
      (doc.robustness_interval ? ` (95% CI ${doc.robustness_interval[0].toFixed(3)}-` +
        `${doc.robustness_interval[1].toFixed(3)})` : "");
    const evaluated = state.details && typeof state.details.eval_seconds === "number"
      ? `, evaluated by the simulator in ${state.details.eval_seconds.toFixed(2)} s` : "";
    // beside R, what a long plan's reader can weigh: the expected failed steps and the weakest
    const weak = (doc.weakest_steps || []).map((i) => `${i} (${doc.steps[i - 1].score.toFixed(2)})`);
    // and the expected attempts when a failed step is retried (null: a step scores 0)
    const tries = typeof doc.expected_attempts === "number"
      ? `, expected attempts with retries ${doc.expected_attempts.toFixed(2)}` : "";
    const failures = typeof doc.expected_failures === "number"
      ? `; expected failed steps ${doc.expected_failures.toFixed(2)}${tries}` +
        (weak.length ? `, weakest: step ${weak.join(", ")}` : "") : "";
    // plan format 3: what the rollouts measured under the cell's errors, and the flagged steps
    const seq = doc.sequence_success;
    const flagged = doc.steps.map((st, k) => (st.execution && st.execution.below_budget ? k + 1 : 0))
      .filter((k) => k > 0);
    const measured = seq ? `; sequence success ${seq.rate.toFixed(3)} (95% CI ` +
      `${seq.interval[0].toFixed(3)}-${seq.interval[1].toFixed(3)}, ${seq.rollouts} rollouts, ` +
      `chosen by ${seq.chosen_by})` + (flagged.length ? `; tolerance below the cell's error ` +
      `budget: step ${flagged.join(", ")}` : "") : "";
    // what became of the perturbed candidate (the answer's details: rap.plan._with_perturbed)
    const stats = (state.details && state.details.stats) || {};
    const fate = stats.perturbed_outcome === "offered"
      ? (seq && seq.candidates.some((c) => c.perturbed_starts && c.chosen) ? "chosen"
        : "measured, not chosen")
      : { duplicate: "one of the search's own", none: "none succeeds from perturbed starts",
          "too large": "not sought (over 3,000 operations)",
          "over budget": "not finished within the request's budget (a later request goes on)" }
        [stats.perturbed_outcome];
    const perturbed = fate ? `; the best plan on perturbed starts: ${fate} ` +
      `(${stats.perturbed_simulated} operations simulated` + (stats.perturbed_cached
        ? `, ${stats.perturbed_cached} from the score cache` : "") + ")" : "";
    // the default scorer's guard: the assembly looked unlike the training data, and what it did
    const g = doc.guard;
    const guard = g ? `; unfamiliar assembly (${Math.round(100 * g.outside)}% of ` +
      `${g.operations} sampled operations far from the training data): ${g.action}` : "";
    $("plan-status").textContent = `${doc.method} plan of ${doc.assembly}: robustness R = ${r} ` +
      `over ${doc.steps.length} steps${measured}${perturbed}${failures}${guard}${cell}, planned in ` +
      `${doc.seconds.toFixed(2)} s${evaluated}; ${timing}`;
    const tbody = $("steps").querySelector("tbody");
    tbody.textContent = "";
    doc.steps.forEach((st, k) => {
      const tr = document.createElement("tr");
      tr.dataset.step = JSON.stringify(st);
      const cells = [String(k + 1), st.moving.join(", "), st.fixed.join(", "), degrees(insertion(st)),
        st.score === null ? "?" : st.score.toFixed(2), SOURCE_TEXT[st.source] || st.source];
      for (const [i, text] of cells.entries()) {
        const td = document.createElement("td");
        td.textContent = text;
        if (i === 4 && st.score !== null && st.score < ROBUST) td.className = "bad";
        if (i === 0 && st.execution && st.execution.below_budget) {
          td.className = "bad";
          td.title = `tolerance ${st.execution.tolerance_mm} mm: below the cell's error budget`;
        }
        tr.appendChild(td);
      }
      tr.addEventListener("click", () => { stop(); showStep(k); });
      tbody.appendChild(tr);
    });
    $("scrub").max = String(doc.steps.length);
    $("story-section").hidden = doc.steps.length === 0;
    if (doc.steps.length) showStep(0);
  }

  function degrees(d) {
    return `${(((Math.atan2(d[1], d[0]) * 180 / Math.PI) + 360) % 360).toFixed(1)}\u00b0`;
  }

  // a plan step's insertion direction ("direction" in plan documents of earlier versions)
  function insertion(st) { return st.insertion || st.direction; }
  function dirText(d) { return `(${d[0].toFixed(3)}, ${d[1].toFixed(3)}), ${degrees(d)}`; }

  // one step as rap.render.pictures.storyboard draws it: the fixed parts, the moving ones back
  // along the direction (dashed) and in place, an arrow; the parts of neither in grey
  function stepContent(k) {
    const geom = state.geom, st = state.plan.steps[k];
    const [dx, dy] = insertion(st), gap = 0.45 * geom.size;
    const back = [-dx * gap, -dy * gap];
    const placed = new Set(st.moving.concat(st.fixed));
    const rest = geom.ids.filter((id) => !placed.has(id));
    let inner = partsSvg(geom, rest, { ghost: true, alpha: 0.9 });
    inner += partsSvg(geom, st.fixed, { labels: true, font: 0.04 });
    inner += partsSvg(geom, st.moving, { offset: back, alpha: 0.35, dashed: true });
    inner += partsSvg(geom, st.moving, { labels: true, font: 0.04 });
    const b = boundsOf(geom, st.moving.concat(st.fixed));
    const cx = (b[0] + b[2]) / 2, cy = (b[1] + b[3]) / 2;
    const sx = cx + back[0], sy = cy + back[1];
    const len = Math.hypot(back[0], back[1]) || 1, head = geom.size * 0.05;
    const ux = -back[0] / len, uy = -back[1] / len;
    const hx = cx - ux * head, hy = cy - uy * head;
    inner += `<line x1="${num(sx)}" y1="${num(-sy)}" x2="${num(hx)}" y2="${num(-hy)}" ` +
      `stroke="#111" stroke-width="${num(geom.size * 0.008)}"/>` +
      `<path d="M${num(cx)},${num(-cy)}L${num(hx - uy * head * 0.45)},${num(-(hy + ux * head * 0.45))}` +
      `L${num(hx + uy * head * 0.45)},${num(-(hy - ux * head * 0.45))}Z" fill="#111"/>`;
    const g = geom.bounds;
    const frame = [Math.min(g[0], g[0] + back[0]), Math.min(g[1], g[1] + back[1]),
      Math.max(g[2], g[2] + back[0]), Math.max(g[3], g[3] + back[1])];
    const score = st.score === null ? "?" : st.score.toFixed(2);
    const bad = st.score !== null && st.score < ROBUST;
    const title = `step ${k + 1} of ${state.plan.steps.length}: r = ${score} ` +
      `[${SOURCE_TEXT[st.source] || st.source}]` + (bad ? "  NOT ROBUST" : "");
    return { inner, box: viewBox(frame, 0.06), title, bad };
  }

  function showStep(k) {
    const steps = state.plan.steps;
    state.step = Math.max(0, Math.min(steps.length - 1, k));
    const st = steps[state.step];
    const c = stepContent(state.step);
    $("step-view").innerHTML = svg(c.box, c.inner, 'preserveAspectRatio="xMidYMid meet"');
    $("step-title").textContent = c.title;
    $("step-title").className = c.bad ? "bad" : "";
    $("step-count").textContent = `step ${state.step + 1} of ${steps.length}`;
    $("scrub").value = String(state.step + 1);
    const facts = [
      ["moving", st.moving.join(", ")],
      ["fixed", st.fixed.join(", ")],
      ["insertion", dirText(insertion(st)) + " (the moving parts travel along it to their place; " +
        "removal = -insertion)"],
      ["score", (st.score === null ? "?" : st.score.toFixed(3)) +
        (st.score_interval ? ` (95% CI ${st.score_interval[0].toFixed(2)}-${st.score_interval[1].toFixed(2)})` : "") +
        (st.score !== null && st.score < ROBUST ? `, below ${ROBUST}: not robust` : "") +
        " (the simulator's robustness of this operation)"],
      ...(st.reason ? [["limited by", st.reason]] : []),
      ...(st.execution ? [["executed", `succeeds ${st.execution.success_when_reached === null ? "?"
        : st.execution.success_when_reached.toFixed(3)} of the ${st.execution.reached} rollouts ` +
        `that reach it; clearance ${st.execution.clearance_mm === null ? "none across"
          : st.execution.clearance_mm + " mm"}; tolerance ${st.execution.tolerance_mm} mm` +
        (st.execution.below_budget ? ": below the cell's error budget" : "")]] : []),
      ["source", (SOURCE_TEXT[st.source] || st.source) + (st.source === "cnn" || st.source === "model"
        ? `: chosen on the model's score, P(high) = ${st.confidence === null ? "?" : st.confidence.toFixed(3)}`
        : st.source === "sim" ? ": chosen on the simulator's score" : ": chosen at random")],
    ];
    const dl = $("step-facts");
    dl.textContent = "";
    for (const [term, text] of facts) {
      const dt = document.createElement("dt"), dd = document.createElement("dd");
      dt.textContent = term;
      dd.textContent = text;
      dd.dataset.fact = term;
      dl.append(dt, dd);
    }
    $("steps").querySelectorAll("tbody tr").forEach((tr, i) =>
      tr.classList.toggle("current", i === state.step));
    $("prev").disabled = state.step === 0;
    $("next").disabled = state.step === steps.length - 1;
  }

  function play() {
    if (state.timer !== null) { stop(); return; }
    if (!state.plan || !state.plan.steps.length) return;
    if (state.step >= state.plan.steps.length - 1) showStep(0);
    $("play").innerHTML = "&#10074;&#10074; pause";
    state.timer = setInterval(() => {
      if (state.step >= state.plan.steps.length - 1) { stop(); return; }
      showStep(state.step + 1);
    }, PLAY_MS);
  }

  function stop() {
    if (state.timer !== null) clearInterval(state.timer);
    state.timer = null;
    $("play").innerHTML = "&#9654; play";
  }

  // -- downloads ------------------------------------------------------------------------------------
  function save(blob, name) {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = name;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  }

  function stem() { return `${state.plan.assembly}-${state.plan.method}`.replace(/[^\w.-]+/g, "_"); }

  function storyboardSvg() { // every step in a grid of four columns, as `rap-farm plan --picture`
    const k = state.plan.steps.length, cols = Math.min(4, k), rows = Math.ceil(k / cols);
    const w = 300, h = 300, title = 26;
    const cell = state.plan.constraints ? "robot cell: " + cellText(state.plan.constraints) : "";
    const head = cell ? 52 : 34; // a second line names the robot cell
    let inner = `<rect width="${cols * w}" height="${rows * (h + title) + head}" fill="#fff"/>` +
      `<text x="${cols * w / 2}" y="22" text-anchor="middle" font-family="sans-serif" ` +
      `font-size="16">${esc(`${state.plan.assembly}: ${state.plan.method} plan, R = ` +
      (state.plan.robustness === null ? "?" : state.plan.robustness.toFixed(3)))}</text>` +
      (cell ? `<text x="${cols * w / 2}" y="42" text-anchor="middle" font-family="sans-serif" ` +
        `font-size="12" fill="#444">${esc(cell)}</text>` : "");
    for (let i = 0; i < k; i++) {
      const c = stepContent(i), x = (i % cols) * w, y = head + Math.floor(i / cols) * (h + title);
      inner += `<text x="${x + w / 2}" y="${y + 17}" text-anchor="middle" font-family="sans-serif" ` +
        `font-size="13" fill="${c.bad ? "#c62828" : "#111"}">${esc(c.title)}</text>` +
        `<svg x="${x + 6}" y="${y + title}" width="${w - 12}" height="${h - 12}" viewBox="${c.box}">` +
        `${c.inner}</svg>`;
    }
    const width = cols * w, height = rows * (h + title) + head;
    return { text: svg(`0 0 ${width} ${height}`, inner, `width="${width}" height="${height}"`),
      width, height };
  }

  function downloadPng() {
    const sb = storyboardSvg();
    const img = new Image();
    img.onload = () => {
      const canvas = document.createElement("canvas");
      canvas.width = sb.width * 2;
      canvas.height = sb.height * 2;
      const ctx = canvas.getContext("2d");
      ctx.scale(2, 2);
      ctx.drawImage(img, 0, 0);
      canvas.toBlob((blob) => save(blob, stem() + "-storyboard.png"), "image/png");
    };
    img.onerror = () => say("the storyboard could not be drawn as a PNG; download the SVG");
    img.src = "data:image/svg+xml;charset=utf-8," + encodeURIComponent(sb.text);
  }

  // -- the robot program ----------------------------------------------------------------------------
  // the formats each arm takes, its first the default (rap/robot/arms/registry.py: ArmSpec.formats)
  const ARM_FORMATS = {
    ur5e: [["urscript", "URScript"], ["waypoints-csv", "CSV"], ["waypoints-json", "JSON"]],
    ur10e: [["urscript", "URScript"], ["waypoints-csv", "CSV"], ["waypoints-json", "JSON"]],
    panda: [["joint-trajectory-yaml", "trajectory YAML"], ["joint-trajectory-json",
      "trajectory JSON"], ["waypoints-csv", "CSV"], ["waypoints-json", "JSON"]],
  };
  function armFormats() { // the format select follows the arm; a format both take is kept
    const sel = $("program-format"), was = sel.value;
    const formats = ARM_FORMATS[$("program-arm").value] || [];
    sel.replaceChildren(...formats.map(([value, label]) => {
      const o = document.createElement("option");
      o.value = value;
      o.textContent = label;
      return o;
    }));
    if (formats.some(([value]) => value === was)) sel.value = was;
  }

  // POST /export with the assembly, the plan's own text (no number changes on the way) and the
  // chosen arm and format; the answer is the program file, saved under the name its
  // Content-Disposition gives
  async function downloadProgram() {
    if (!state.plan || !state.planText || !state.inspected) return;
    const gen = state.gen, format = $("program-format").value, arm = $("program-arm").value;
    say("");
    document.body.dataset.program = "asking";
    $("dl-program").disabled = true;
    const body = `{"assembly":${JSON.stringify(state.inspected.assembly)},` +
      `"plan":${state.planText},"arm":${JSON.stringify(arm)},"format":${JSON.stringify(format)}}`;
    try {
      const { text, headers } = await request("/export", { method: "POST", body,
        headers: { "Content-Type": "application/json" } });
      if (gen !== state.gen) return;
      const named = /filename="([^"]+)"/.exec(headers.get("Content-Disposition") || "");
      save(new Blob([text], { type: headers.get("Content-Type") || "text/plain" }),
        named ? named[1] : `${stem()}-${format}.txt`);
      document.body.dataset.program = "saved";
    } catch (e) {
      if (gen !== state.gen) return;
      say("robot program: " + e.message);
      document.body.dataset.program = "refused";
    } finally {
      $("dl-program").disabled = false;
    }
  }

  // -- wiring ---------------------------------------------------------------------------------------
  function wire() {
    $("token").value = token();
    $("token-form").addEventListener("submit", (e) => { e.preventDefault(); $("token").blur(); });
    $("token").addEventListener("change", () => {
      sessionStorage.setItem(TOKEN_KEY, $("token").value.trim());
      say("");
      health();
      methods().catch((e) => say(e.message));
    });
    $("method").addEventListener("change", searchOnly);
    $("file").addEventListener("change", () => {
      const f = $("file").files[0];
      if (f) readFile(f);
      $("file").value = "";
    });
    const drop = $("drop");
    for (const ev of ["dragover", "drop"]) window.addEventListener(ev, (e) => e.preventDefault());
    drop.addEventListener("dragover", () => drop.classList.add("over"));
    drop.addEventListener("dragleave", () => drop.classList.remove("over"));
    drop.addEventListener("drop", (e) => {
      drop.classList.remove("over");
      const f = e.dataTransfer.files[0];
      if (f) readFile(f);
    });
    $("plan-form").addEventListener("submit", (e) => { e.preventDefault(); plan(); });
    $("prev").addEventListener("click", () => { stop(); showStep(state.step - 1); });
    $("next").addEventListener("click", () => { stop(); showStep(state.step + 1); });
    $("play").addEventListener("click", play);
    $("scrub").addEventListener("input", () => { stop(); showStep(Number($("scrub").value) - 1); });
    document.addEventListener("keydown", (e) => {
      if (!state.plan || $("story-section").hidden || e.target.matches("input, select")) return;
      if (e.key === "ArrowLeft") { stop(); showStep(state.step - 1); }
      else if (e.key === "ArrowRight") { stop(); showStep(state.step + 1); }
      else if (e.key === " ") { e.preventDefault(); play(); }
    });
    $("dl-json").addEventListener("click", () => save(new Blob([JSON.stringify(state.plan, null, 2) + "\n"],
      { type: "application/json" }), stem() + "-plan.json"));
    $("dl-svg").addEventListener("click", () => save(new Blob([storyboardSvg().text],
      { type: "image/svg+xml" }), stem() + "-storyboard.svg"));
    $("dl-png").addEventListener("click", downloadPng);
    $("dl-program").addEventListener("click", downloadProgram);
    $("program-arm").addEventListener("change", armFormats);
  }

  wire();
  health();
  methods().catch((e) => say(e.status === 401 ? e.message : "methods not read: " + e.message));
  examples().catch(() => {}); // none offered: the row stays hidden
})();
