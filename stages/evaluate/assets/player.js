// The report's transition player and table sorting. Reads the JSON in #player-data and
// the base64 meshes in #player-mesh (layout: see stages/evaluate/src/encode.rs and
// html.rs), decodes a frame as mean + basis · (scale ⊙ codes), and draws it with a small
// z-buffered software rasteriser into a 2D canvas (orthographic front view, flat two-sided
// Lambert shading — the same picture as the Rust renderer of the static figures). No WebGL,
// so it runs the same in headless Chromium. After a player has drawn its first frame it
// sets data-ready="true" and data-first-frame-ms (ms since navigation start) on itself.
(function () {
  "use strict";
  var root = document.documentElement;
  var dataEl = document.getElementById("player-data");
  var meshEl = document.getElementById("player-mesh");
  sortableTables();
  if (!dataEl || !meshEl) return;
  var D = JSON.parse(dataEl.textContent);
  var enc = D.encoding;
  if (!enc) return;
  var bin = atob(meshEl.textContent.trim());
  var buf = new ArrayBuffer(bin.length);
  var u8 = new Uint8Array(buf);
  for (var i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  var dim = enc.dim, K = enc.k, off = 0;
  var mean = new Float32Array(buf, off, dim); off += 4 * dim;
  var scale = new Float32Array(buf, off, K); off += 4 * K;
  var bscale = new Float32Array(buf, off, K); off += 4 * K;
  var basisQ = new Int16Array(buf, off, K * dim); off += 2 * K * dim;
  var codes = new Int16Array(buf, off, enc.frames * K);
  var basis = new Float32Array(K * dim);
  for (var r = 0; r < K; r++) for (var j = 0; j < dim; j++) basis[r * dim + j] = basisQ[r * dim + j] * bscale[r];
  var tris = D.triangles, bones = D.bones || [];
  var V = dim / 3;

  function decode(t, out) {
    out.set(mean);
    for (var r = 0; r < K; r++) {
      var c = codes[t * K + r] * scale[r];
      if (c === 0) continue;
      var o = r * dim;
      for (var j = 0; j < dim; j++) out[j] += c * basis[o + j];
    }
    return out;
  }

  var TINTS = [[0.85, 0.6, 0.45], [0.45, 0.6, 0.85], [0.5, 0.75, 0.5], [0.8, 0.55, 0.75], [0.8, 0.7, 0.55]];

  // One canvas: a z-buffered, flat-shaded orthographic front view of a mesh.
  function Panel(canvas, tint) {
    var w = canvas.width, h = canvas.height;
    var ctx = canvas.getContext("2d");
    var img = ctx.createImageData(w, h);
    var depth = new Float32Array(w * h);
    var b = D.bounds, span = Math.max(b[2] - b[0], b[3] - b[1], 1e-12);
    var s = 0.9 * Math.min(w, h) / span, cx = (b[0] + b[2]) / 2, cy = (b[1] + b[3]) / 2;
    var px = new Float32Array(V), py = new Float32Array(V);
    var mesh = new Float32Array(dim);
    var L = [0.3, 0.5, 1.0], ln = Math.hypot(L[0], L[1], L[2]);
    L = [L[0] / ln, L[1] / ln, L[2] / ln];
    this.clear = function (text) {
      ctx.fillStyle = "#f5f5f5"; ctx.fillRect(0, 0, w, h);
      if (text) { ctx.fillStyle = "#555"; ctx.font = "13px sans-serif"; wrap(ctx, text, 10, 24, w - 20, 16); }
    };
    this.draw = function (t) {
      decode(t, mesh);
      var d = img.data;
      for (var i = 0; i < w * h; i++) { d[4 * i] = d[4 * i + 1] = d[4 * i + 2] = 245; d[4 * i + 3] = 255; depth[i] = -Infinity; }
      for (var v = 0; v < V; v++) { px[v] = (mesh[3 * v] - cx) * s + w / 2; py[v] = h / 2 - (mesh[3 * v + 1] - cy) * s; }
      for (var q = 0; q < tris.length; q += 3) {
        var a = tris[q], bb = tris[q + 1], c = tris[q + 2];
        var ax = mesh[3 * a], ay = mesh[3 * a + 1], az = mesh[3 * a + 2];
        var e1x = mesh[3 * bb] - ax, e1y = mesh[3 * bb + 1] - ay, e1z = mesh[3 * bb + 2] - az;
        var e2x = mesh[3 * c] - ax, e2y = mesh[3 * c + 1] - ay, e2z = mesh[3 * c + 2] - az;
        var nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
        var nl = Math.hypot(nx, ny, nz);
        if (nl === 0) continue;
        var shade = 0.25 + 0.75 * Math.abs((nx * L[0] + ny * L[1] + nz * L[2]) / nl);
        var R = Math.min(255, tint[0] * shade * 255) | 0, G = Math.min(255, tint[1] * shade * 255) | 0, B = Math.min(255, tint[2] * shade * 255) | 0;
        var pax = px[a], pay = py[a], pbx = px[bb], pby = py[bb], pcx = px[c], pcy = py[c];
        var area = (pbx - pax) * (pcy - pay) - (pby - pay) * (pcx - pax);
        if (Math.abs(area) < 1e-12) continue;
        var x0 = Math.max(0, Math.floor(Math.min(pax, pbx, pcx))), x1 = Math.min(w - 1, Math.ceil(Math.max(pax, pbx, pcx)));
        var y0 = Math.max(0, Math.floor(Math.min(pay, pby, pcy))), y1 = Math.min(h - 1, Math.ceil(Math.max(pay, pby, pcy)));
        var za = az, zb = mesh[3 * bb + 2], zc = mesh[3 * c + 2];
        for (var y = y0; y <= y1; y++) {
          var yy = y + 0.5;
          for (var x = x0; x <= x1; x++) {
            var xx = x + 0.5;
            var w0 = ((pbx - xx) * (pcy - yy) - (pby - yy) * (pcx - xx)) / area;
            var w1 = ((pcx - xx) * (pay - yy) - (pcy - yy) * (pax - xx)) / area;
            var w2 = 1 - w0 - w1;
            if (w0 < 0 || w1 < 0 || w2 < 0) continue;
            var z = w0 * za + w1 * zb + w2 * zc, k = y * w + x;
            if (z > depth[k]) { depth[k] = z; d[4 * k] = R; d[4 * k + 1] = G; d[4 * k + 2] = B; }
          }
        }
      }
      ctx.putImageData(img, 0, 0);
      if (tris.length === 0) sticks(ctx, px, py, mesh, tint, Math.max(1.5, 0.012 * Math.min(w, h)));
    };
  }

  // A rig without triangles: its bones as round-capped sticks (a skeleton), else every
  // point as a dot; back to front by depth (larger z is nearer, as in the z-buffer).
  function sticks(ctx, px, py, mesh, tint, r) {
    var segs = [], i;
    if (bones.length) for (i = 0; i < bones.length; i += 2) segs.push([bones[i], bones[i + 1]]);
    else for (i = 0; i < V; i++) segs.push([i, i]);
    segs.sort(function (p, q) {
      return (mesh[3 * p[0] + 2] + mesh[3 * p[1] + 2]) - (mesh[3 * q[0] + 2] + mesh[3 * q[1] + 2]);
    });
    ctx.lineCap = "round"; ctx.lineWidth = 2 * r;
    ctx.strokeStyle = "rgb(" + Math.round(tint[0] * 204) + "," + Math.round(tint[1] * 204) + "," + Math.round(tint[2] * 204) + ")";
    for (i = 0; i < segs.length; i++) {
      var a = segs[i][0], b = segs[i][1];
      ctx.beginPath(); ctx.moveTo(px[a], py[a]); ctx.lineTo(px[b] + (a === b ? 0.01 : 0), py[b]); ctx.stroke();
    }
  }

  function wrap(ctx, text, x, y, width, lh) {
    var words = text.split(" "), line = "";
    for (var i = 0; i < words.length; i++) {
      var t = line ? line + " " + words[i] : words[i];
      if (ctx.measureText(t).width > width && line) { ctx.fillText(line, x, y); line = words[i]; y += lh; } else line = t;
    }
    if (line) ctx.fillText(line, x, y);
  }

  function fmt(v, n) { return (Math.round(v * Math.pow(10, n)) / Math.pow(10, n)).toFixed(n); }

  function caption(clip, f, tau) {
    var parts = [];
    var shown = "frame " + f + " of " + clip.frames;
    if (clip.phase[f] !== 4) shown += " · " + (tau >= 0 ? "+" : "") + fmt(tau / D.fps, 2) + " s from the request";
    else shown += " · " + fmt(f / D.fps, 2) + " s · command " + clip.command[f];
    parts.push("<b>" + esc(clip.system) + "</b> · " + shown);
    var label = D.labels[clip.model[f]];
    parts.push("model/label producing it: <b>" + esc(label === undefined ? "?" : label) + "</b> · phase: <b>" + D.phases[clip.phase[f]] + "</b>");
    for (var i = 0; i < clip.bridges.length; i++) {
      var br = clip.bridges[i];
      if (f >= br[0] && f <= br[1]) parts.push("<span class='bridge'>" + esc(br[2]) + "</span>");
    }
    var n = clip.nearest[f];
    if (n && n[0] < D.training.length) {
      var tr = D.training[n[0]];
      parts.push("nearest training frame: " + esc(tr[0]) + " frame " + tr[1] + " (" + esc(tr[2]) + "), " + fmt(n[1], 4) + " mesh units (" + fmt(n[1] / D.mesh_step, 2) + " frame steps)");
    }
    var x = clip.latent[f];
    parts.push(x && x.length ? "latent point: (" + x.map(function (v) { return fmt(v, 3); }).join(", ") + ")" : "latent point: not recorded in these curves");
    return parts.join("<br>");
  }

  function esc(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;"); }

  // A player over groups of clips (one panel per clip), aligned at each clip's `asked`.
  function Player(el, groups, width) {
    var sel = el.querySelector("select"), play = el.querySelector(".play"), prev = el.querySelector(".prev"),
      next = el.querySelector(".next"), range = el.querySelector("input[type=range]"), time = el.querySelector(".time"),
      speed = el.querySelector(".speed"), panelsEl = el.querySelector(".panels");
    var g = 0, tau = 0, lo = 0, hi = 0, panels = [], playing = false, last = 0, acc = 0;
    groups.forEach(function (gr, i) { var o = document.createElement("option"); o.value = i; o.textContent = gr.title; sel.appendChild(o); });
    function setup(i) {
      g = i; sel.value = i; panelsEl.innerHTML = ""; panels = [];
      var clips = groups[g].clips;
      lo = 0; hi = 0;
      clips.forEach(function (c, ci) {
        lo = Math.min(lo, -c.asked); hi = Math.max(hi, c.frames - 1 - c.asked);
        var fig = document.createElement("figure"); fig.className = "panel"; fig.style.width = Math.max(width + 2, 282) + "px";
        var cv = document.createElement("canvas"); cv.width = width; cv.height = width;
        var cap = document.createElement("figcaption"); cap.className = "cap";
        fig.appendChild(cv); fig.appendChild(cap); panelsEl.appendChild(fig);
        panels.push({ clip: c, panel: new Panel(cv, TINTS[ci % TINTS.length]), cap: cap });
      });
      range.min = lo; range.max = hi; tau = Math.max(lo, Math.min(tau, hi));
    }
    function show() {
      range.value = tau;
      time.textContent = (tau >= 0 ? "+" : "") + fmt(tau / D.fps, 2) + " s (frame " + tau + " of " + lo + "…" + hi + ")";
      panels.forEach(function (p) {
        var c = p.clip;
        if (c.frames === 0) { p.panel.clear(c.system + ": " + (c.note || "no frames")); p.cap.innerHTML = "<b>" + esc(c.system) + "</b> · " + esc(c.note || "no frames"); return; }
        var f = Math.max(0, Math.min(c.frames - 1, tau + c.asked));
        p.panel.draw(c.offset + f);
        var extra = tau + c.asked < 0 ? " (before its start: first frame held)" : tau + c.asked >= c.frames ? " (after its end: last frame held)" : "";
        var lat = c.phase[0] === 4 ? "" : c.latency === null ? "no answer" + (c.note ? ": " + esc(c.note) : "") : "latency " + fmt(c.latency / D.fps, 2) + " s";
        p.cap.innerHTML = caption(c, f, tau) + (lat ? "<br>" + lat : "") + extra;
      });
    }
    function step(d) { tau = Math.max(lo, Math.min(hi, tau + d)); show(); }
    function tick(now) {
      if (!playing) return;
      acc += (now - last) / 1000 * D.fps * parseFloat(speed.value); last = now;
      var n = Math.floor(acc);
      if (n > 0) { acc -= n; if (tau + n > hi) tau = lo; else tau += n; show(); }
      requestAnimationFrame(tick);
    }
    function toggle() {
      playing = !playing; play.textContent = playing ? "❚❚ pause" : "▶ play";
      if (playing) { last = performance.now(); acc = 0; requestAnimationFrame(tick); }
    }
    sel.addEventListener("change", function () { setup(+sel.value); show(); });
    play.addEventListener("click", toggle);
    prev.addEventListener("click", function () { step(-1); });
    next.addEventListener("click", function () { step(1); });
    range.addEventListener("input", function () { tau = +range.value; show(); });
    el.addEventListener("keydown", function (e) {
      if (e.key === "ArrowLeft") { step(-1); e.preventDefault(); }
      else if (e.key === "ArrowRight") { step(1); e.preventDefault(); }
      else if (e.key === " ") { toggle(); e.preventDefault(); }
    });
    this.go = function (i, t) { setup(Math.max(0, Math.min(groups.length - 1, i))); tau = Math.max(lo, Math.min(hi, t)); show(); };
    setup(0); tau = 0; show();
    el.dataset.ready = "true";
    el.dataset.firstFrameMs = performance.now().toFixed(0);
  }

  var players = {};
  [["transition-player", D.groups, 240], ["script-player", D.scripts, 360]].forEach(function (p) {
    var el = document.getElementById(p[0]);
    if (el && p[1].length) players[p[0]] = new Player(el, p[1], p[2]);
  });
  // #transition-player=<group>,<frames from the request> (or script-player): shows that
  // player alone, opened at that group and frame, paused (a link to one moment of one
  // transition; the screenshot test uses it).
  var m = /^#(transition-player|script-player)=(\d+),(-?\d+)$/.exec(location.hash);
  if (m && players[m[1]]) {
    var solo = document.getElementById(m[1]);
    players[m[1]].go(+m[2], +m[3]);
    Array.prototype.forEach.call(document.querySelectorAll("body > *, #player > *"), function (e) {
      if (e !== solo && !e.contains(solo) && e.tagName !== "SCRIPT") e.style.display = "none";
    });
  }
  root.dataset.playersReady = Object.keys(players).length;

  // Click a header of a table.sortable to sort by that column (numbers by their leading value).
  function sortableTables() {
    var tables = document.querySelectorAll("table.sortable");
    Array.prototype.forEach.call(tables, function (t) {
      var ths = t.querySelectorAll("thead th");
      Array.prototype.forEach.call(ths, function (th, col) {
        th.style.cursor = "pointer"; th.title = "sort";
        th.addEventListener("click", function () {
          var body = t.tBodies[0], rows = Array.prototype.slice.call(body.rows);
          var dir = th.dataset.dir === "asc" ? -1 : 1; th.dataset.dir = dir === 1 ? "asc" : "desc";
          var key = function (r) { var s = r.cells[col] ? r.cells[col].textContent : ""; var v = parseFloat(s); return isNaN(v) ? s : v; };
          rows.sort(function (a, b) { var x = key(a), y = key(b); return (x < y ? -1 : x > y ? 1 : 0) * dir; });
          rows.forEach(function (r) { body.appendChild(r); });
        });
      });
    });
  }
})();
