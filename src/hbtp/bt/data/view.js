/* hbtp view: draws a behavior tree and steps through a trace. Everything it shows was computed by
   hbtp (src/hbtp/bt/html_view.py) and embedded in #hbtp-data; this script only draws it. */
(function () {
  "use strict";

  const DATA = JSON.parse(document.getElementById("hbtp-data").textContent);
  const STATUS = ["success", "failure", "running"];
  const KIND = { F: "Fallback", S: "Sequence", C: "Condition", A: "Action" };
  const SYMBOL = { F: "?", S: "\u2192", C: "C", A: "A" };
  const INITIAL_ROWS = 1500; // rows drawn when a tree is first shown (larger trees start collapsed)
  const CHUNK = 400; // children drawn at a time under one node
  const MAX_REVEAL = 200; // search matches expanded at once
  const RUNS = DATA.runs;
  const $ = (id) => document.getElementById(id);

  function el(tag, cls, text) {
    const node = document.createElement(tag);
    if (cls) node.className = cls;
    if (text !== undefined) node.textContent = text;
    return node;
  }

  // ------------------------------------------------------------------ trees
  const prepared = [];
  function tree(index) {
    if (prepared[index]) return prepared[index];
    const nodes = DATA.trees[index].nodes;
    const n = nodes.length;
    const t = {
      n: n, kind: new Array(n), label: new Array(n), lower: new Array(n),
      parent: new Int32Array(n), sib: new Int32Array(n), children: new Array(n), depth: 0,
    };
    const depth = new Int32Array(n);
    for (let i = 0; i < n; i++) {
      t.kind[i] = nodes[i][0];
      t.label[i] = nodes[i][1];
      t.lower[i] = nodes[i][1].toLowerCase();
      t.parent[i] = nodes[i][2];
      t.children[i] = [];
      const p = nodes[i][2];
      if (p >= 0) {
        t.sib[i] = t.children[p].length;
        t.children[p].push(i);
        depth[i] = depth[p] + 1;
      }
      t.depth = Math.max(t.depth, depth[i] + 1);
    }
    prepared[index] = t;
    return t;
  }

  let view = null; // the drawn tree: rows are created lazily, when their parent is expanded
  let cur = { code: null, active: null, leaf: -1, marked: [] }; // the marks of the current tick
  const search = { q: "", matches: [], pos: -1, set: null };

  function renderTree(index) {
    const t = tree(index);
    view = {
      index: index, t: t, li: new Array(t.n), row: new Array(t.n), ul: new Array(t.n),
      more: new Array(t.n), open: new Uint8Array(t.n),
    };
    cur = { code: new Int8Array(t.n).fill(-1), active: new Uint8Array(t.n), leaf: -1, marked: [] };
    const box = $("tree");
    box.textContent = "";
    box.dataset.tree = index;
    const top = el("ul");
    top.appendChild(makeNode(0));
    box.appendChild(top);
    initialExpand();
    runSearch($("search").value, false);
    writeMeta();
  }

  function makeNode(i) {
    const t = view.t;
    const li = el("li", "node");
    const row = el("div", "row k-" + t.kind[i]);
    row.dataset.id = i;
    row.setAttribute("role", "treeitem");
    const composite = t.children[i].length > 0;
    row.appendChild(el("span", composite ? "tog" : "tog none", composite ? "\u25B8" : "\u00B7"));
    const kind = el("span", "kind", SYMBOL[t.kind[i]]);
    kind.title = KIND[t.kind[i]];
    row.appendChild(kind);
    if (t.label[i]) row.appendChild(el("span", "label", t.label[i]));
    else row.appendChild(el("span", "label-kind muted", KIND[t.kind[i]]));
    if (composite) row.appendChild(el("span", "count", "(" + t.children[i].length + ")"));
    row.appendChild(el("span", "st"));
    li.appendChild(row);
    view.li[i] = li;
    view.row[i] = row;
    if (search.set && search.set[i]) row.classList.add("match");
    applyMarks(i);
    return li;
  }

  function expand(i) {
    const t = view.t;
    if (!t.children[i].length || view.open[i] || !view.li[i]) return;
    view.open[i] = 1;
    const li = view.li[i];
    li.classList.add("open");
    li.firstChild.firstChild.textContent = "\u25BE";
    li.firstChild.setAttribute("aria-expanded", "true");
    if (!view.ul[i]) {
      view.ul[i] = el("ul");
      view.ul[i].setAttribute("role", "group");
      li.appendChild(view.ul[i]);
      renderChildren(i);
    }
    view.ul[i].hidden = false;
    applyMarks(i);
  }

  function collapse(i) {
    if (!view.open[i]) return;
    view.open[i] = 0;
    const li = view.li[i];
    li.classList.remove("open");
    li.firstChild.firstChild.textContent = "\u25B8";
    li.firstChild.setAttribute("aria-expanded", "false");
    if (view.ul[i]) view.ul[i].hidden = true;
    applyMarks(i);
  }

  function toggle(i) {
    if (view.open[i]) collapse(i);
    else expand(i);
  }

  // Children are drawn CHUNK at a time: a node with more has one "show" placeholder per chunk not
  // drawn yet, so that a node far down a long list is drawn without drawing all those before it.
  function renderChildren(i) {
    const kids = view.t.children[i];
    const ul = view.ul[i];
    const fragment = document.createDocumentFragment();
    view.more[i] = [];
    for (let c = 0; c * CHUNK < kids.length; c++) {
      if (c === 0) {
        for (let k = 0; k < Math.min(CHUNK, kids.length); k++) fragment.appendChild(makeNode(kids[k]));
        view.more[i].push(null);
        continue;
      }
      const from = c * CHUNK;
      const to = Math.min(kids.length, from + CHUNK);
      const more = el("li", "more");
      const button = el("button", "", "show children " + (from + 1) + "\u2013" + to + " of " + kids.length);
      button.type = "button";
      button.dataset.parent = i;
      button.dataset.chunk = c;
      more.appendChild(button);
      fragment.appendChild(more);
      view.more[i].push(more);
    }
    ul.appendChild(fragment);
  }

  function renderChunk(i, c) {
    const placeholder = view.more[i] && view.more[i][c];
    if (!placeholder) return;
    const kids = view.t.children[i];
    const fragment = document.createDocumentFragment();
    for (let k = c * CHUNK; k < Math.min(kids.length, (c + 1) * CHUNK); k++) fragment.appendChild(makeNode(kids[k]));
    view.ul[i].insertBefore(fragment, placeholder);
    placeholder.remove();
    view.more[i][c] = null;
  }

  function initialExpand() {
    const t = view.t;
    let rows = 1;
    const queue = [0];
    for (let q = 0; q < queue.length; q++) {
      const i = queue[q];
      const count = Math.min(t.children[i].length, CHUNK);
      if (!count || (i !== 0 && rows + count > INITIAL_ROWS)) continue;
      expand(i);
      rows += count;
      for (let c = 0; c < count; c++) queue.push(t.children[i][c]);
    }
  }

  function reveal(i) {
    const t = view.t;
    const chain = [];
    for (let a = i; t.parent[a] >= 0; a = t.parent[a]) chain.push(a);
    for (let c = chain.length - 1; c >= 0; c--) {
      const node = chain[c];
      const p = t.parent[node];
      expand(p);
      if (!view.li[node]) renderChunk(p, Math.floor(t.sib[node] / CHUNK));
    }
  }

  function scrollTo(i, center, again) {
    // only when the row is out of sight or at an edge (or asked to centre): a third down the pane
    const row = view.row[i];
    if (!row) return;
    const box = $("tree");
    const r = row.getBoundingClientRect();
    const b = box.getBoundingClientRect();
    const margin = Math.min(48, box.clientHeight / 6);
    if ((center && !again) || r.top < b.top + margin || r.bottom > b.bottom - margin) {
      box.scrollTop += r.top - b.top - (center ? box.clientHeight / 2 : box.clientHeight / 3);
      // rows off screen have an estimated height (content-visibility) until they are drawn: once
      // those now in sight are drawn (after this frame), look again
      if (!again) requestAnimationFrame(() => setTimeout(() => view.row[i] === row && scrollTo(i, center, true), 0));
    }
    if (r.left < b.left || r.left > b.right - 80) box.scrollLeft += r.left - b.left - 40;
  }

  // ------------------------------------------------------------------ marks of a tick
  function applyMarks(i) {
    const row = view.row[i];
    if (!row) return;
    const c = cur.code[i];
    const cl = row.classList;
    cl.toggle("st-success", c === 0);
    cl.toggle("st-failure", c === 1);
    cl.toggle("st-running", c === 2);
    cl.toggle("active", cur.active[i] === 1);
    cl.toggle("active-leaf", i === cur.leaf);
    row.lastChild.textContent = c >= 0 ? STATUS[c] : "";
    const hides = cur.active[i] === 1 && view.t.children[i].length > 0 && !view.open[i];
    view.li[i].classList.toggle("hides-active", hides);
  }

  function setMarks(visit) {
    const old = cur.marked;
    for (const i of old) {
      cur.code[i] = -1;
      cur.active[i] = 0;
    }
    cur.leaf = -1;
    const ids = [];
    if (visit) {
      const flat = visit.ticked;
      for (let k = 0; k < flat.length; k += 2) {
        cur.code[flat[k]] = flat[k + 1];
        ids.push(flat[k]);
      }
      for (const p of visit.path) cur.active[p] = 1;
      cur.leaf = visit.path[visit.path.length - 1];
    }
    cur.marked = ids;
    for (const i of old) applyMarks(i);
    for (const i of ids) applyMarks(i);
  }

  // ------------------------------------------------------------------ search
  function runSearch(text, jump) {
    for (const i of search.matches) {
      if (view.row[i]) view.row[i].classList.remove("match", "focus");
    }
    const t = view.t;
    search.q = text.trim().toLowerCase();
    search.matches = [];
    search.set = new Uint8Array(t.n);
    search.pos = -1;
    if (search.q) {
      for (let i = 0; i < t.n; i++) {
        if (t.lower[i].includes(search.q)) {
          search.matches.push(i);
          search.set[i] = 1;
        }
      }
    }
    const shown = Math.min(search.matches.length, MAX_REVEAL);
    for (let k = 0; k < shown; k++) reveal(search.matches[k]);
    for (const i of search.matches) {
      if (view.row[i]) view.row[i].classList.add("match");
    }
    countMatches();
    if (jump && search.matches.length) goMatch(0);
  }

  function countMatches() {
    const total = search.matches.length;
    let text = "";
    if (search.q) {
      text = total === 1 ? "1 match" : total + " matches";
      if (search.pos >= 0) text = search.pos + 1 + " / " + total;
      if (total > MAX_REVEAL) text += " (first " + MAX_REVEAL + " expanded)";
    }
    $("search-count").textContent = text;
  }

  function goMatch(k) {
    const total = search.matches.length;
    if (!total) return;
    if (search.pos >= 0) {
      const old = view.row[search.matches[search.pos]];
      if (old) old.classList.remove("focus");
    }
    search.pos = ((k % total) + total) % total;
    const i = search.matches[search.pos];
    reveal(i);
    view.row[i].classList.add("match", "focus");
    scrollTo(i, true);
    countMatches();
  }

  // ------------------------------------------------------------------ zoom
  let zoom = 1;
  function setZoom(value) {
    zoom = Math.min(3, Math.max(0.3, Math.round(value * 100) / 100));
    document.documentElement.style.setProperty("--zoom", String(zoom));
    $("zoom-reset").textContent = Math.round(zoom * 100) + "%";
  }

  // ------------------------------------------------------------------ the trace
  let runIndex = 0;
  let pos = 0;
  let timelineRun = -1;

  function show(r, p) {
    const run = RUNS[r];
    if (!run) return;
    runIndex = r;
    const count = run.ticks.length;
    pos = Math.max(0, Math.min(count - 1, p));
    const step = count ? run.ticks[pos] : null;
    const treeIndex = step ? step.tree : 0;
    if (!view || view.index !== treeIndex) renderTree(treeIndex);
    setMarks(step ? DATA.visits[step.visit] : null);
    if (cur.leaf >= 0) {
      reveal(cur.leaf);
      scrollTo(cur.leaf, false);
    }
    $("run").value = String(r);
    const slider = $("slider");
    slider.max = String(Math.max(0, count - 1));
    slider.value = String(pos);
    const lastTick = count ? run.ticks[count - 1].tick : 0;
    $("tick-counter").textContent = step ? "tick " + step.tick + " / " + lastTick : "no ticks";
    $("first").disabled = $("prev").disabled = !step || pos === 0;
    $("last").disabled = $("next").disabled = !step || pos === count - 1;
    if (timelineRun !== r) buildTimeline(run);
    const cells = $("timeline").children;
    for (const cell of $("timeline").querySelectorAll(".cur")) cell.classList.remove("cur");
    if (cells[pos]) cells[pos].classList.add("cur");
    showInfo(run, step);
    showState(run, pos);
    writeHash(run, step);
    document.body.dataset.tick = step ? step.tick : "";
    document.body.dataset.run = run.run;
  }

  function buildTimeline(run) {
    const box = $("timeline");
    box.textContent = "";
    run.ticks.forEach(function (step, p) {
      const cell = el("span", "cell " + step.status);
      if (step.disturbance) cell.classList.add("dist");
      if (step.replans.length) cell.classList.add("replan");
      cell.dataset.pos = p;
      let title = "tick " + step.tick + ": " + step.status + (step.action ? " " + step.action : "");
      if (step.disturbance) title += "\ndisturbance: " + step.disturbance;
      if (step.replans.length) title += "\nre-planned";
      cell.title = title;
      box.appendChild(cell);
    });
    timelineRun = RUNS.indexOf(run);
  }

  function line(parent, cls) {
    const div = el("div", "line" + (cls ? " " + cls : ""));
    parent.appendChild(div);
    return div;
  }

  function showInfo(run, step) {
    const box = $("tick-info");
    box.textContent = "";
    if (!step) return;
    const head = line(box);
    head.appendChild(el("b", "", "Tick " + step.tick + " "));
    head.appendChild(el("span", "status " + step.status, step.status));
    if (step.action) {
      head.appendChild(document.createTextNode(" runs "));
      head.appendChild(el("code", "", step.action));
    }
    if (DATA.trees.length > 1) {
      line(box, "muted").textContent = "tree #" + step.tree + " (" + DATA.trees[step.tree].nodes.length + " nodes)";
    }
    if (step.disturbance) {
      const event = line(box, "event");
      event.appendChild(document.createTextNode("disturbance before this tick: "));
      event.appendChild(el("code", "", step.disturbance));
    }
    for (const k of step.replans) {
      const replan = run.replans[k];
      const div = line(box, "replan");
      let text = "re-planned at tick " + replan.tick;
      if (replan.reason) text += ": " + replan.reason;
      const facts = [];
      if (replan.status) facts.push(replan.status);
      if (typeof replan.seconds === "number") facts.push((replan.seconds * 1000).toFixed(1) + " ms");
      if (replan.cost !== null && replan.cost !== undefined) facts.push("cost " + replan.cost);
      if (facts.length) text += " (" + facts.join(", ") + ")";
      text += replan.tree === null ? "; no new tree" : "; from here on tree #" + replan.tree;
      if (replan.message) text += ": " + replan.message;
      div.textContent = text;
    }
    if (pos === run.ticks.length - 1) line(box, "end").textContent = run.label;
  }

  function showState(run, p) {
    const list = $("state");
    list.textContent = "";
    if (!run.ticks.length) {
      $("state-count").textContent = "";
      return;
    }
    const now = DATA.states[run.ticks[p].state];
    const before = p > 0 ? DATA.states[run.ticks[p - 1].state] : null;
    const nowSet = new Set(now);
    const beforeSet = new Set(before || []);
    const items = now.map((id) => [id, before && !beforeSet.has(id) ? "added" : ""]);
    if (before) for (const id of before) if (!nowSet.has(id)) items.push([id, "removed"]);
    items.sort((a, b) => (DATA.names[a[0]] < DATA.names[b[0]] ? -1 : DATA.names[a[0]] > DATA.names[b[0]] ? 1 : 0));
    const fragment = document.createDocumentFragment();
    for (const [id, cls] of items) fragment.appendChild(el("li", cls, DATA.names[id]));
    list.appendChild(fragment);
    const added = items.filter((item) => item[1] === "added").length;
    const removed = items.length - now.length;
    let text = now.length + " true";
    if (added || removed) text += " (+" + added + " \u2212" + removed + " since the tick before)";
    $("state-count").textContent = text;
    filterState();
  }

  function filterState() {
    const q = $("state-filter").value.trim().toLowerCase();
    for (const li of $("state").children) li.hidden = q !== "" && !li.textContent.toLowerCase().includes(q);
  }

  function step(delta) {
    if (RUNS.length) show(runIndex, pos + delta);
  }

  // ------------------------------------------------------------------ #run=R&tick=N
  function writeHash(run, step) {
    if (!step) return;
    const hash = "#" + (RUNS.length > 1 ? "run=" + run.run + "&" : "") + "tick=" + step.tick;
    if (location.hash === hash) return;
    try {
      history.replaceState(null, "", hash);
    } catch (error) {
      /* a browser that refuses it for file: URLs: the address just does not follow */
    }
  }

  function fromHash() {
    const values = {};
    for (const part of location.hash.replace(/^#/, "").split("&")) {
      const pair = part.split("=");
      if (pair[0]) values[pair[0]] = decodeURIComponent(pair[1] || "");
    }
    let r = runIndex;
    if (values.run !== undefined) {
      const found = RUNS.findIndex((run) => String(run.run) === values.run);
      if (found >= 0) r = found;
    }
    let p = 0;
    if (values.tick !== undefined) {
      const wanted = Number(values.tick);
      const ticks = RUNS[r].ticks;
      p = ticks.findIndex((s) => s.tick >= wanted);
      if (p < 0) p = ticks.length - 1;
    }
    show(r, p);
  }

  // ------------------------------------------------------------------ page
  function writeMeta() {
    const meta = $("meta");
    meta.textContent = "";
    const parts = [["scenario", DATA.scenario]];
    if (DATA.goal) parts.push(["goal", DATA.goal]);
    const t = view.t;
    parts.push(["tree", t.n + " nodes, depth " + t.depth + (DATA.trees.length > 1 ? " (tree #" + view.index + " of " + DATA.trees.length + ")" : "")]);
    if (DATA.trace) parts.push(["trace", DATA.trace + ": " + RUNS.length + " run(s)"]);
    parts.forEach(function (part, k) {
      if (k) meta.appendChild(document.createTextNode(" \u00B7 "));
      meta.appendChild(document.createTextNode(part[0] + " "));
      meta.appendChild(el("b", "", part[1]));
    });
  }

  function wire() {
    $("tree").addEventListener("click", function (event) {
      const more = event.target.closest("li.more > button");
      if (more) {
        renderChunk(Number(more.dataset.parent), Number(more.dataset.chunk));
        return;
      }
      const row = event.target.closest(".row");
      if (row && (event.target.closest(".tog") || event.detail === 2)) toggle(Number(row.dataset.id));
    });
    let pending = 0;
    $("search").addEventListener("input", function () {
      clearTimeout(pending);
      pending = setTimeout(() => runSearch($("search").value, true), 120);
    });
    $("search").addEventListener("keydown", function (event) {
      if (event.key === "Enter") {
        clearTimeout(pending);
        if (search.q !== $("search").value.trim().toLowerCase()) runSearch($("search").value, true);
        else goMatch(search.pos + (event.shiftKey ? -1 : 1));
        event.preventDefault();
      } else if (event.key === "Escape") {
        $("search").value = "";
        runSearch("", false);
      }
    });
    $("search-next").addEventListener("click", () => goMatch(search.pos + 1));
    $("search-prev").addEventListener("click", () => goMatch(search.pos - 1));
    $("expand-all").addEventListener("click", function () {
      for (let i = 0; i < view.t.n; i++) expand(i);
    });
    $("collapse-all").addEventListener("click", function () {
      for (let i = 1; i < view.t.n; i++) collapse(i);
      $("tree").scrollTop = 0;
    });
    $("zoom-in").addEventListener("click", () => setZoom(zoom * 1.2));
    $("zoom-out").addEventListener("click", () => setZoom(zoom / 1.2));
    $("zoom-reset").addEventListener("click", () => setZoom(1));
    $("first").addEventListener("click", () => show(runIndex, 0));
    $("prev").addEventListener("click", () => step(-1));
    $("next").addEventListener("click", () => step(1));
    $("last").addEventListener("click", () => show(runIndex, Infinity));
    $("slider").addEventListener("input", () => show(runIndex, Number($("slider").value)));
    $("run").addEventListener("change", () => show(Number($("run").value), 0));
    $("timeline").addEventListener("click", function (event) {
      const cell = event.target.closest(".cell");
      if (cell) show(runIndex, Number(cell.dataset.pos));
    });
    $("state-filter").addEventListener("input", filterState);
    window.addEventListener("hashchange", fromHash);
    document.addEventListener("keydown", keys);
  }

  function keys(event) {
    const tag = event.target && event.target.tagName;
    if (tag === "INPUT" || tag === "SELECT" || tag === "TEXTAREA") return;
    if (event.altKey || event.ctrlKey || event.metaKey) return;
    const actions = {
      ArrowRight: () => step(1), ArrowLeft: () => step(-1), n: () => step(1), p: () => step(-1),
      Home: () => RUNS.length && show(runIndex, 0), End: () => RUNS.length && show(runIndex, Infinity),
      "/": () => $("search").focus(), "+": () => setZoom(zoom * 1.2), "=": () => setZoom(zoom * 1.2),
      "-": () => setZoom(zoom / 1.2), "0": () => setZoom(1),
    };
    const action = actions[event.key];
    if (action) {
      action();
      event.preventDefault();
    }
  }

  function start() {
    $("title").textContent = DATA.title;
    wire();
    if (RUNS.length) {
      RUNS.forEach(function (run, r) {
        const option = el("option", "", run.label);
        option.value = String(r);
        $("run").appendChild(option);
      });
      $("run").disabled = RUNS.length < 2;
      fromHash();
    } else {
      renderTree(0);
      $("trace-controls").hidden = true;
      $("tick-info").hidden = true;
      $("state-panel").hidden = true;
      $("no-trace").hidden = false;
    }
    window.hbtpView = {
      show: show,
      where: () => ({ run: runIndex, pos: pos, tree: view.index, leaf: cur.leaf, rows: view.row.filter(Boolean).length }),
    };
    document.body.dataset.ready = "1";
  }

  start();
})();
