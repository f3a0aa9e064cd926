// plab view's player (kit/view/viewer.js), inlined into the page by `plab view`
// (kit/cli/view.cpp), which also inlines the run's data: a JSON header (#plab-meta) and a base64
// blob (#plab-data) of typed arrays, each named in the header by [byte offset, count].
// Frame f shows the state printed at the start of step meta.steps[f]; the disks that collide
// during that step are coloured by the event (from the stage's events file).
"use strict";
(function () {
  const meta = JSON.parse(document.getElementById("plab-meta").textContent);
  const text = document.getElementById("plab-data").textContent.trim();
  let bytes;
  if (typeof Uint8Array.fromBase64 === "function") {
    bytes = Uint8Array.fromBase64(text);
  } else {
    const s = atob(text);
    bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
  }
  const typed = (T, where) => new T(bytes.buffer, where[0], where[1]);

  const N = meta.n, L = meta.L, R = meta.r, F = meta.steps.length;
  const runs = meta.runs.map((r) => ({
    label: r.label, vscale: r.vscale,
    pos: typed(Float32Array, r.pos), vel: typed(Int16Array, r.vel),
  }));
  // The events of frame f are evStart[f] .. evStart[f + 1] - 1: particle, partner (-1 a wall,
  // -2 a pair whose partner was not found), time in 65534ths of the step (65535: not known).
  const evStart = typed(Int32Array, meta.events.start);
  const ev = {
    particle: typed(Int32Array, meta.events.particle),
    partner: typed(Int32Array, meta.events.partner),
    time: typed(Uint16Array, meta.events.time), frame: new Int32Array(meta.events.particle[1]),
  };
  for (let f = 0; f < F; f++) ev.frame.fill(f, evStart[f], evStart[f + 1]);
  const cmp = meta.compare && {
    offsets: typed(Int32Array, meta.compare.offsets), which: typed(Int32Array, meta.compare.which),
    counts: typed(Int32Array, meta.compare.counts), first: meta.compare.first || null,
  };
  const firstFrame = cmp && cmp.first ? meta.steps.indexOf(cmp.first.step) : -1;

  const COLOUR = { none: "#4c72b0", wall: "#ff9f1c", pair: "#9467bd", differs: "#d62728",
                   other: "#555555", selected: "#2ca02c" };
  const $ = (id) => document.getElementById(id);
  const canvas = $("view"), ctx = canvas.getContext("2d");
  const slider = $("slider");
  const state = { frame: 0, playing: false, fps: 5, arrows: false, layout: "overlay",
                  scale: 1, panX: 0, panY: 0, selected: -1, dirty: true, last: 0 };
  const drawTimes = [];

  // -- the header and the controls -------------------------------------------------------------
  const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;",
                                                          '"': "&quot;" }[c]));
  const key = (c, what) => `<span class="key" style="background:${c}"></span>${what}`;
  const count = (n, one, many) => `${n} ${n === 1 ? one : many}`;
  let title = `<b>${esc(runs[0].label)}</b>` +
      (runs.length > 1 ? ` compared with <b>${esc(runs[1].label)}</b>` : "") +
      ` &middot; N = ${N}, L = ${L}, r = ${R}, ${F} steps shown` +
      (meta.every > 1 ? ` (one in ${meta.every} of ${meta.printed}: the page holds at most ` +
                        `${meta.max_mb} MB of run data)` : "") +
      " &middot; " + key(COLOUR.none, "no event") + key(COLOUR.wall, "wall") +
      key(COLOUR.pair, "pair") +
      (runs.length > 1 ? key(COLOUR.differs, "differs") + key(COLOUR.other, "the compared run")
                       : "") +
      (meta.events.given ? "" : " &middot; no events file") +
      (meta.scene_steps !== undefined
          ? `<br><b>this output ends at step ${meta.last_step}, its scene has ` +
            `${meta.scene_steps} steps</b>: cut short (a crash, a time limit) or run with --steps`
          : "");
  // A first difference at a step the two runs do not both print (one ends before it) is shown
  // at the last step they share.
  const beyond = cmp && cmp.first && firstFrame < 0;
  if (cmp) {
    title += cmp.first
        ? `<br>first difference: <a class="jump" id="first-link">step ${cmp.first.step}</a>` +
          (beyond ? ` (past step ${meta.steps[F - 1]}, the last both runs print: one of them ` +
                    "ends early)" : "") +
          `, particle ${esc(cmp.first.particle)}, ${esc(cmp.first.field)}: ` +
          `${esc(cmp.first.a)} in the first run, ${esc(cmp.first.b)} expected ` +
          "(the compared run); " + count(cmp.first.lines, "line differs", "lines differ") +
          (cmp.first.step === 0 ? " (step 0 is the initial state: two different scenes, or one " +
                                  "printed wrong from the start?)" : "")
        : "<br>the two runs are equal";
  }
  $("title").innerHTML = title;
  slider.max = String(F - 1);
  if (!cmp) $("layout-box").style.display = "none";
  const sliderMark = beyond ? F - 1 : firstFrame;  // where the slider marks it
  if (sliderMark < 0) $("goto-first").style.display = "none";
  else {
    const mark = $("first-mark");
    mark.style.display = "block";
    mark.style.left = `calc(8px + (100% - 16px) * ${F > 1 ? sliderMark / (F - 1) : 0} - 1px)`;
  }

  function setFrame(f) {
    state.frame = Math.max(0, Math.min(F - 1, f | 0));
    slider.value = String(state.frame);
    state.dirty = true;
  }
  function gotoFirst() {
    setFrame(beyond ? F - 1 : firstFrame > 0 ? firstFrame - 1 : firstFrame);
  }
  function togglePlay() {
    if (!state.playing && state.frame === F - 1) setFrame(0);
    state.playing = !state.playing;
    $("play").innerHTML = state.playing ? "&#10074;&#10074;" : "&#9654;";
    state.last = performance.now();
  }
  $("back").onclick = () => setFrame(state.frame - 1);
  $("forward").onclick = () => setFrame(state.frame + 1);
  $("play").onclick = togglePlay;
  slider.oninput = () => setFrame(Number(slider.value));
  $("speed").onchange = (e) => { state.fps = Number(e.target.value); };
  $("arrows").onchange = (e) => { state.arrows = e.target.checked; state.dirty = true; };
  $("layout").onchange = (e) => { state.layout = e.target.value; fit(); };
  $("goto-first").onclick = gotoFirst;
  if ($("first-link")) $("first-link").onclick = gotoFirst;
  $("fit").onclick = fit;
  document.addEventListener("keydown", (e) => {
    if (e.target.tagName === "SELECT" || e.target.tagName === "INPUT" && e.target.type !== "range")
      return;
    if (e.key === " ") { togglePlay(); e.preventDefault(); }
    else if (e.key === "ArrowLeft") { setFrame(state.frame - 1); e.preventDefault(); }
    else if (e.key === "ArrowRight") { setFrame(state.frame + 1); e.preventDefault(); }
    else if (e.key === "Home") setFrame(0);
    else if (e.key === "End") setFrame(F - 1);
  });

  // -- the view: one panel, or two side by side, sharing zoom and pan ---------------------------
  function panels() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (runs.length > 1 && state.layout === "side")
      return [{ x0: 0, w: w / 2, h, run: 0 }, { x0: w / 2, w: w / 2, h, run: 1 }];
    return [{ x0: 0, w, h, run: 0, overlay: runs.length > 1 }];
  }
  function fit() {
    const p = panels()[0];
    state.scale = 0.94 * Math.min(p.w, p.h) / L;
    state.panX = (p.w - L * state.scale) / 2;
    state.panY = (p.h - L * state.scale) / 2;
    state.dirty = true;
  }
  // Panel-local pixels of a world point (y grows upwards in the box, downwards on screen).
  const sx = (x) => state.panX + x * state.scale;
  const sy = (y) => state.panY + (L - y) * state.scale;

  const kind = new Uint8Array(N);   // 0 none, 1 wall, 2 pair: the events of the frame's step
  const differs = new Uint8Array(N);
  function markFrame(f) {
    kind.fill(0);
    for (let e = evStart[f]; e < evStart[f + 1]; e++)
      if (ev.particle[e] < N) kind[ev.particle[e]] = ev.partner[e] === -1 ? 1 : 2;
    differs.fill(0);
    if (cmp) for (let k = cmp.offsets[f]; k < cmp.offsets[f + 1]; k++) differs[cmp.which[k]] = 1;
  }

  // Every disk of `run` whose class(i) is `c`, as one path (a pixel square when under a pixel).
  function disks(p, run, f, c, classOf, fill, stroke) {
    const pos = runs[run].pos, base = f * N * 2, rad = R * state.scale;
    const small = rad < 1.2;
    ctx.beginPath();
    for (let i = 0; i < N; i++) {
      if (classOf(i) !== c) continue;
      const x = sx(pos[base + 2 * i]), y = sy(pos[base + 2 * i + 1]);
      if (x < -rad || y < -rad || x > p.w + rad || y > p.h + rad) continue;
      if (small) ctx.rect(x - 1, y - 1, 2, 2);
      else { ctx.moveTo(x + rad, y); ctx.arc(x, y, rad, 0, 2 * Math.PI); }
    }
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    if (stroke) { ctx.strokeStyle = stroke; ctx.stroke(); }
  }
  function arrows(p, run, f) {
    const pos = runs[run].pos, vel = runs[run].vel, vs = runs[run].vscale, base = f * N * 2;
    ctx.beginPath();
    for (let i = 0; i < N; i++) {
      const x = pos[base + 2 * i], y = pos[base + 2 * i + 1];
      const vx = vel[base + 2 * i] * vs, vy = vel[base + 2 * i + 1] * vs;
      const x0 = sx(x), y0 = sy(y), x1 = sx(x + vx), y1 = sy(y + vy);
      if (Math.max(x0, x1) < 0 || Math.max(y0, y1) < 0 || Math.min(x0, x1) > p.w ||
          Math.min(y0, y1) > p.h) continue;
      const len = Math.hypot(x1 - x0, y1 - y0);
      if (len < 1) continue;
      const ux = (x1 - x0) / len, uy = (y1 - y0) / len, head = Math.min(6, len / 3);
      ctx.moveTo(x0, y0); ctx.lineTo(x1, y1);
      ctx.lineTo(x1 - head * (ux - uy / 2), y1 - head * (uy + ux / 2));
      ctx.moveTo(x1, y1);
      ctx.lineTo(x1 - head * (ux + uy / 2), y1 - head * (uy - ux / 2));
    }
    ctx.strokeStyle = "#222"; ctx.lineWidth = 1; ctx.stroke();
  }

  function draw() {
    const t0 = performance.now();
    const dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
    }
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    const f = state.frame;
    markFrame(f);
    const byKind = (i) => kind[i], byDiff = (i) => differs[i];
    for (const p of panels()) {
      ctx.setTransform(dpr, 0, 0, dpr, p.x0 * dpr, 0);
      ctx.save();
      ctx.beginPath(); ctx.rect(0, 0, p.w, p.h); ctx.clip();
      ctx.lineWidth = 1.5; ctx.strokeStyle = "#000";
      ctx.strokeRect(sx(0), sy(L), L * state.scale, L * state.scale);
      ctx.lineWidth = 1;
      if (p.overlay) disks(p, 1, f, 0, () => 0, null, COLOUR.other);
      const own = p.run === 0 ? byKind : () => 0;  // the events belong to the first run
      disks(p, p.run, f, 0, own, p.run === 0 ? COLOUR.none : COLOUR.other, null);
      disks(p, p.run, f, 1, own, COLOUR.wall, null);
      disks(p, p.run, f, 2, own, COLOUR.pair, null);
      if (cmp) {
        ctx.lineWidth = 3;
        disks(p, p.run, f, 1, byDiff, null, COLOUR.differs);
        if (p.overlay) disks(p, 1, f, 1, byDiff, null, COLOUR.differs);
        ctx.lineWidth = 1;
      }
      if (state.arrows) arrows(p, p.run, f);
      if (state.selected >= 0) {
        ctx.lineWidth = 3;
        disks(p, p.run, f, 1, (i) => (i === state.selected ? 1 : 0), null, COLOUR.selected);
        ctx.lineWidth = 1;
      }
      if (p.overlay === undefined && runs.length > 1) {
        ctx.fillStyle = "#000";
        ctx.fillText(runs[p.run].label, 6, 14);
        if (p.run === 1) { ctx.fillStyle = "#999"; ctx.fillRect(0, 0, 1, p.h); }
      }
      ctx.restore();
    }
    const dt = performance.now() - t0;
    drawTimes.push(dt);
    if (drawTimes.length > 400) drawTimes.shift();
    const sorted = drawTimes.slice().sort((a, b) => a - b);
    $("step-label").textContent = `step ${meta.steps[f]} (frame ${f + 1} of ${F})`;
    const median = sorted[sorted.length >> 1];
    $("status").textContent =
        `drawing a frame: ${dt.toFixed(1)} ms (median ${median.toFixed(1)} ms ` +
        `over the last ${sorted.length}) · ${bytes.length.toLocaleString()} bytes of run data ` +
        `· zoom: wheel, pan: drag, click a disk for what it does`;
    info();
  }

  // -- what the selected disk does --------------------------------------------------------------
  const num = (v) => (Number.isFinite(v) ? String(Number(v.toPrecision(9))) : String(v));
  function stateOf(run, f, i) {
    const r = runs[run], b = f * N * 2 + 2 * i;
    return { x: r.pos[b], y: r.pos[b + 1], vx: r.vel[b] * r.vscale, vy: r.vel[b + 1] * r.vscale };
  }
  function eventText(e) {
    const t = ev.time[e] !== 65535 ? ` at t = ${(ev.time[e] / 65534).toFixed(4)}` : "";
    if (ev.partner[e] === -1) return `wall${t}`;
    if (ev.partner[e] === -2) return "pair (partner not found)";
    return `pair with <a class="jump" data-select="${ev.partner[e]}">${ev.partner[e]}</a>${t}`;
  }
  function info() {
    const box = $("info"), i = state.selected, f = state.frame;
    if (i < 0) {
      box.innerHTML = "<p>Click a disk: its index, position and velocity at this step, and its " +
                      "collisions.</p><p>Keys: space plays or pauses, the arrows step.</p>" +
                      (cmp ? `<p>${count(cmp.counts[f], "particle differs", "particles differ")} ` +
                             "at this step.</p>" : "");
      return;
    }
    let html = `<h3>disk ${i} at step ${meta.steps[f]}</h3><table>`;
    const states = runs.map((_, run) => stateOf(run, f, i));
    for (const field of ["x", "y", "vx", "vy"]) {
      const d = runs.length > 1 && states[0][field] !== states[1][field];
      html += `<tr><td>${field}</td>` + states.map((s) =>
          `<td class="${d ? "differs" : ""}">${num(s[field])}</td>`).join("") + "</tr>";
    }
    html += "</table>";
    if (runs.length > 1)
      html += `<p>columns: first run, compared run${differs[i] ? "; <span class=differs>" +
              "differs at this step</span>" : ""}</p>`;
    const here = [];
    for (let e = evStart[f]; e < evStart[f + 1]; e++) if (ev.particle[e] === i) here.push(e);
    html += `<p><b>this step:</b> ${here.length ? here.map(eventText).join("; ")
        : meta.steps[f] >= meta.last_step ? "none (the run's last state: no step follows)"
        : !meta.events.given ? "not known (no events file)"
        : "no collision (moves freely)"}</p>`;
    const all = [];
    for (let e = 0; e < ev.particle.length && all.length < 40; e++)
      if (ev.particle[e] === i) all.push(e);
    if (all.length) {
      html += "<p><b>its collisions</b> (the step's start; time within the step):</p><ul>" +
          all.map((e) => `<li><a class="jump" data-frame="${ev.frame[e]}">step ` +
                         `${meta.steps[ev.frame[e]]}</a>: ${eventText(e)}</li>`).join("") + "</ul>";
    }
    html += "<p style='color:#777'>positions as float32, velocities to 1/32767 of the run's " +
            "largest; the exact values are in the output file.</p>";
    box.innerHTML = html;
  }
  $("info").addEventListener("click", (e) => {
    const a = e.target.closest("a.jump");
    if (!a) return;
    if (a.dataset.select !== undefined) {
      state.selected = Number(a.dataset.select);
      state.dirty = true;
    }
    if (a.dataset.frame !== undefined) setFrame(Number(a.dataset.frame));
  });

  // -- mouse: wheel zooms at the pointer, a drag pans, a click picks a disk ----------------------
  function panelAt(px) {
    const ps = panels();
    return ps.find((p) => px >= p.x0 && px < p.x0 + p.w) || ps[0];
  }
  function local(e) {
    const rect = canvas.getBoundingClientRect();
    const px = e.clientX - rect.left, py = e.clientY - rect.top, p = panelAt(px);
    return { p, x: px - p.x0, y: py };
  }
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const m = local(e);
    const wx = (m.x - state.panX) / state.scale, wy = L - (m.y - state.panY) / state.scale;
    state.scale *= Math.pow(1.0015, -e.deltaY);
    state.panX = m.x - wx * state.scale;
    state.panY = m.y - (L - wy) * state.scale;
    state.dirty = true;
  }, { passive: false });
  let drag = null;
  canvas.addEventListener("mousedown", (e) => {
    drag = { x: e.clientX, y: e.clientY, panX: state.panX, panY: state.panY, moved: false };
  });
  window.addEventListener("mousemove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
    if (drag.moved) {
      state.panX = drag.panX + dx; state.panY = drag.panY + dy; state.dirty = true;
    }
  });
  window.addEventListener("mouseup", (e) => {
    if (drag && !drag.moved) pick(e);
    drag = null;
  });
  function pick(e) {
    const m = local(e);
    const wx = (m.x - state.panX) / state.scale, wy = L - (m.y - state.panY) / state.scale;
    const pos = runs[m.p.run].pos, base = state.frame * N * 2;
    let best = -1, bestD = Math.max(R, 4 / state.scale);
    for (let i = 0; i < N; i++) {
      const d = Math.hypot(pos[base + 2 * i] - wx, pos[base + 2 * i + 1] - wy);
      if (d <= bestD) { best = i; bestD = d; }
    }
    state.selected = best;
    state.dirty = true;
  }

  // -- the loop: a frame is drawn when something changed; playing advances at the chosen speed --
  function tick(now) {
    if (state.playing && now - state.last >= 1000 / state.fps) {
      state.last = now;
      if (state.frame >= F - 1) togglePlay(); else setFrame(state.frame + 1);
    }
    if (state.dirty) { state.dirty = false; draw(); }
    requestAnimationFrame(tick);
  }
  window.addEventListener("resize", () => { state.dirty = true; });
  fit();
  requestAnimationFrame(tick);

  // For the browser test (tests/view_check.py) and the console: where things are, and timings.
  window.plab = {
    meta, setFrame, frame: () => state.frame, frameOfStep: (s) => meta.steps.indexOf(s),
    firstFrame, drawTimes, draw,
    // The client (page) coordinates of disk i's centre in the first panel at the current frame.
    clientOf(i) {
      const rect = canvas.getBoundingClientRect(), b = state.frame * N * 2 + 2 * i;
      return [rect.left + sx(runs[0].pos[b]), rect.top + sy(runs[0].pos[b + 1])];
    },
  };
})();
