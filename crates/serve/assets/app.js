// reprise serve's page: connects a session, draws each system's mesh with WebGL2
// (flat-shaded from screen-space derivatives, an orbit camera shared by the views,
// frames interpolated at display rate), shows each frame's debug record, and sends
// commands. Frame layout: crates/serve/src/protocol.rs. After the first frame is drawn
// the page sets data-frames (frames drawn) and data-labels (each view's label) on
// <body>, for tests; the game sets data-game (its state as JSON). Command to pixels:
// for each command the page sends, the time from sending it to the first draw of the
// frame it is stamped with (the `ok` reply names it), in window.reprise.latencies (ms).
(function () {
  "use strict";
  var W = null, ws = null, views = [], systems = [], last = null, prev = null, lastAt = 0, frames = 0;
  var cam = { yaw: 0, pitch: 0, dist: 1.9 };
  // Commands sent and not yet answered (send times), and answered ones whose frame is not
  // yet drawn ({frame, sent}); the latencies measured (the last 1,000).
  var unanswered = [], undrawn = [], latencies = [];
  var $ = function (id) { return document.getElementById(id); };

  function log(text) {
    var el = $("log"), line = document.createElement("div");
    line.textContent = new Date().toISOString().slice(11, 23) + "  " + text;
    el.appendChild(line);
    el.scrollTop = el.scrollHeight;
    while (el.childNodes.length > 200) el.removeChild(el.firstChild);
  }

  function status(text) { $("status").textContent = text; }

  // ---- WebGL ----
  var VS = "#version 300 es\nin vec3 p; uniform mat4 mvp; uniform mat4 mv; out vec3 vp;\n" +
    "void main(){ vp = (mv * vec4(p,1.0)).xyz; gl_Position = mvp * vec4(p,1.0); }";
  var FS = "#version 300 es\nprecision highp float; in vec3 vp; uniform vec3 tint; uniform float lines; out vec4 o;\n" +
    "void main(){ if (lines > 0.5) { o = vec4(tint*0.6,1.0); return; }\n" +
    " vec3 n = normalize(cross(dFdx(vp), dFdy(vp))); vec3 l = normalize(vec3(0.3,0.5,1.0));\n" +
    " float s = 0.25 + 0.75*abs(dot(n,l)); o = vec4(tint*s,1.0); }";
  var TINTS = [[0.85, 0.6, 0.45], [0.45, 0.6, 0.85], [0.5, 0.75, 0.5], [0.8, 0.55, 0.75], [0.8, 0.7, 0.55]];

  function View(index, system) {
    var box = document.createElement("div");
    box.className = "view";
    box.innerHTML = "<h2></h2><canvas width=720 height=600></canvas><div class=debug></div>";
    box.querySelector("h2").textContent = system;
    $("views").appendChild(box);
    this.canvas = box.querySelector("canvas");
    this.debug = box.querySelector(".debug");
    this.tint = TINTS[index % TINTS.length];
    this.label = -1;
    this.search = null;
    var gl = this.canvas.getContext("webgl2", { antialias: true });
    this.gl = gl;
    if (!gl) { this.debug.textContent = "WebGL2 is not available in this browser"; return; }
    var sh = function (type, src) {
      var s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    var prog = gl.createProgram();
    gl.attachShader(prog, sh(gl.VERTEX_SHADER, VS)); gl.attachShader(prog, sh(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    this.prog = prog;
    this.u = { mvp: gl.getUniformLocation(prog, "mvp"), mv: gl.getUniformLocation(prog, "mv"),
      tint: gl.getUniformLocation(prog, "tint"), lines: gl.getUniformLocation(prog, "lines") };
    this.pos = gl.createBuffer();
    var tri = W.triangles.length > 0;
    this.count = tri ? W.triangles.length : W.bones.length;
    this.mode = tri ? gl.TRIANGLES : gl.LINES;
    this.idx = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.idx);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, new Uint32Array(tri ? W.triangles : W.bones), gl.STATIC_DRAW);
    this.mesh = new Float32Array(3 * W.vertices);
  }

  View.prototype.draw = function (a, b, t) {
    var gl = this.gl;
    if (!gl) return;
    var m = this.mesh;
    for (var i = 0; i < m.length; i++) m[i] = a[i] + (b[i] - a[i]) * t;
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.clearColor(0.96, 0.96, 0.96, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.prog);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.pos);
    gl.bufferData(gl.ARRAY_BUFFER, m, gl.STREAM_DRAW);
    var loc = gl.getAttribLocation(this.prog, "p");
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
    var mats = camera(this.canvas.width / this.canvas.height);
    gl.uniformMatrix4fv(this.u.mvp, false, mats.mvp);
    gl.uniformMatrix4fv(this.u.mv, false, mats.mv);
    gl.uniform3fv(this.u.tint, this.tint);
    gl.uniform1f(this.u.lines, this.mode === gl.LINES ? 1 : 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.idx);
    gl.drawElements(this.mode, this.count, gl.UNSIGNED_INT, 0);
  };

  function mul(a, b) { // column-major 4×4: a·b
    var o = new Float32Array(16);
    for (var c = 0; c < 4; c++) for (var r = 0; r < 4; r++) {
      var s = 0; for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k]; o[c * 4 + r] = s;
    }
    return o;
  }

  // Orbit camera about the box's centre: the box scaled to unit size, yaw about y,
  // pitch about x, pulled back by cam.dist, perspective 40°.
  function camera(aspect) {
    var lo = W.box.lo, hi = W.box.hi;
    var c = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    var s = 1.25 / Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    var model = new Float32Array([s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, -s * c[0], -s * c[1], -s * c[2], 1]);
    var cy = Math.cos(cam.yaw), sy = Math.sin(cam.yaw), cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
    var ry = new Float32Array([cy, 0, -sy, 0, 0, 1, 0, 0, sy, 0, cy, 0, 0, 0, 0, 1]);
    var rx = new Float32Array([1, 0, 0, 0, 0, cp, sp, 0, 0, -sp, cp, 0, 0, 0, 0, 1]);
    var tr = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -cam.dist, 1]);
    var mv = mul(tr, mul(rx, mul(ry, model)));
    var f = 1 / Math.tan(20 * Math.PI / 180), n = 0.05, fa = 50;
    var proj = new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (fa + n) / (n - fa), -1, 0, 0, 2 * fa * n / (n - fa), 0]);
    return { mv: mv, mvp: mul(proj, mv) };
  }

  function orbit(canvas) {
    var down = null;
    canvas.addEventListener("pointerdown", function (e) { down = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
    canvas.addEventListener("pointerup", function () { down = null; });
    canvas.addEventListener("pointermove", function (e) {
      if (!down) return;
      cam.yaw += (e.clientX - down[0]) * 0.01;
      cam.pitch = Math.max(-1.5, Math.min(1.5, cam.pitch + (e.clientY - down[1]) * 0.01));
      down = [e.clientX, e.clientY];
    });
    canvas.addEventListener("wheel", function (e) {
      e.preventDefault();
      cam.dist = Math.max(0.8, Math.min(10, cam.dist * Math.exp(e.deltaY * 0.001)));
    }, { passive: false });
  }

  // ---- frames ----
  function decode(buf) {
    var dv = new DataView(buf);
    var frame = dv.getUint32(0, true), j = dv.getUint32(4, true);
    var meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, j)));
    var n = 3 * W.vertices, q = new Int16Array(buf, 8 + j, meta.length * n), meshes = [];
    for (var s = 0; s < meta.length; s++) {
      var m = new Float32Array(n);
      for (var i = 0; i < n; i++) {
        var a = i % 3;
        m[i] = W.box.lo[a] + (q[s * n + i] + 32768) / 65535 * (W.box.hi[a] - W.box.lo[a]);
      }
      meshes.push(m);
    }
    return { frame: frame, meta: meta, meshes: meshes };
  }

  function fmt(x) { return x.map(function (v) { return v.toFixed(2); }).join(", "); }

  // The view's text for frame f's record m; motion matching's last search stays shown,
  // with its age, until the next one.
  function describe(v, f, m) {
    var d = m.debug, t = "label " + W.labels[m.label] + "  phase " + m.phase + "\n";
    if (d.kind === "reprise") t += "x = (" + fmt(d.x) + ")\n" + (d.aim ? "bridge x1 = (" + fmt(d.aim) + ")" : "no bridge aimed at");
    else if (d.kind === "motion-graphs") t += "node " + d.node + "\nplanned " + d.planned.length + (d.planned.length ? " → " + d.planned[d.planned.length - 1] : "");
    else if (d.kind === "motion-matching") {
      t += "frame " + d.frame + (d.switched ? "  (jumped)" : "");
      if (d.candidates.length) v.search = { at: f, candidates: d.candidates };
      if (v.search) t += "\nsearch " + (f - v.search.at) + " frame(s) ago (frame · label · cost):" + v.search.candidates.map(function (c) {
        return "\n  " + c[0] + " · " + W.labels[c[1]] + " · " + c[2].toFixed(3);
      }).join("");
    }
    else if (d.kind === "crossfade") t += "frame " + d.frame + "\nsource weight " + d.source_weight.toFixed(2);
    if (m.note) t += "\nnote: " + m.note;
    return t;
  }

  function onFrame(f) {
    prev = last || f;
    last = f;
    lastAt = performance.now();
    frames++;
    var labels = [];
    f.meta.forEach(function (m, i) {
      if (!views[i]) return;
      views[i].label = m.label;
      views[i].debug.textContent = describe(views[i], f.frame, m);
      if (m.note) log(m.system + ": " + m.note);
      labels.push(W.labels[m.label]);
    });
    document.body.dataset.frames = String(frames);
    document.body.dataset.labels = labels.join(",");
    status("frame " + f.frame + "  ·  " + systems.join(", "));
  }

  function render() {
    if (last) {
      var now = performance.now(), t = Math.min(1, (now - lastAt) * W.fps / 1000);
      views.forEach(function (v, i) { v.draw(prev.meshes[i], last.meshes[i], t); });
      undrawn = undrawn.filter(function (u) {
        if (last.frame < u.frame) return true;
        latencies.push(now - u.sent);
        if (latencies.length > 1000) latencies.shift();
        return false;
      });
    }
    requestAnimationFrame(render);
  }

  // ---- session ----
  function connect() {
    if (ws) ws.close();
    systems = [];
    document.querySelectorAll("#system-choice input:checked").forEach(function (c) { systems.push(c.value); });
    $("views").innerHTML = "";
    views = systems.map(function (s, i) { var v = new View(i, s); orbit(v.canvas); return v; });
    last = prev = null; frames = 0; unanswered = []; undrawn = [];
    var url = (location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/session?systems=" +
      encodeURIComponent(systems.join(",")) + "&start=" + encodeURIComponent($("start").value) + "&seed=" + encodeURIComponent($("seed").value || "0");
    ws = new WebSocket(url);
    ws.binaryType = "arraybuffer";
    ws.onopen = function () { log("session started: " + systems.join(", ")); };
    ws.onmessage = function (e) {
      if (typeof e.data === "string") {
        var r = JSON.parse(e.data);
        if (r.game) { showGame(r.game); return; }
        // An error may answer a game action as well: the pending commands are not matched.
        if (r.error) { unanswered = []; log("error: " + r.error); }
        else if (unanswered.length) undrawn.push({ frame: r.ok.frame, sent: unanswered.shift() });
        if (r.ok) r.ok.systems.forEach(function (s) { if (!s.taken) log(s.system + ": " + (s.ignored || s.refused)); });
        return;
      }
      onFrame(decode(e.data));
    };
    ws.onclose = function (e) { status("disconnected" + (e.reason ? ": " + e.reason : "")); };
  }

  function send(c) {
    if (ws && ws.readyState === 1) {
      if (c.type !== "mark" && c.type !== "new-game") unanswered.push(performance.now());
      ws.send(JSON.stringify(c));
    } else log("not connected");
  }

  // ---- the game ----
  var TURN = { player: "your turn", character: "the character ponders…", over: "game over" };

  function buildGame() {
    var board = $("game");
    for (var i = 0; i < 9; i++) {
      var b = document.createElement("button");
      b.dataset.cell = String(i);
      b.onclick = (function (cell) { return function () { send({ type: "mark", cell: cell }); }; })(i);
      board.appendChild(b);
    }
    $("new-game").onclick = function () { send({ type: "new-game", character_first: $("character-first").checked }); };
    if (!W.game) $("game-status").textContent = "no game file: the game plays, without reactions (reprise serve --game FILE)";
  }

  function showGame(g) {
    var cells = $("game").querySelectorAll("button");
    g.board.forEach(function (m, i) {
      cells[i].textContent = m === "." ? "" : m;
      cells[i].disabled = m !== "." || g.turn !== "player";
      cells[i].className = g.line && g.line.indexOf(i) >= 0 ? "line" : "";
    });
    var t = "game " + g.game + ": " + (g.outcome ? (g.outcome === "draw" ? "a draw" : g.outcome === "player" ? "you win" : "the character wins") : TURN[g.turn]);
    if (g.reaction) {
      var labels = W.game ? [].concat.apply([], W.game[g.reaction[0]] || []) : [];
      t += "\nreaction: " + g.reaction[0] + " (script " + g.reaction[1] + (labels.length ? ", to " + labels.join("/") : "") + ")";
    }
    if (g.mistake) t += "\nits last move was a deliberate slip";
    $("game-status").textContent = t;
    document.body.dataset.game = JSON.stringify(g);
  }

  function fillTakes() {
    var sel = $("take");
    W.labels.forEach(function (l, i) {
      var group = document.createElement("optgroup");
      group.label = l;
      (W.takes[i] || []).forEach(function (t) {
        var o = document.createElement("option"); o.value = t[0]; o.textContent = t[0]; group.appendChild(o);
      });
      sel.appendChild(group);
    });
    $("play").onclick = function () { send({ type: "play", clip: sel.value }); };
    $("move").onclick = function () {
      var l = views.length ? views[0].label : -1, takes = W.takes[l] || [];
      if (!takes.length) { log("no view shows a label yet"); return; }
      var t = takes[Math.floor(Math.random() * takes.length)], f = t[1][Math.floor(Math.random() * t[1].length)];
      send({ type: "move", to: { clip: t[0], frame: f }, duration: parseFloat($("duration").value) || 1 });
    };
  }

  window.reprise = { send: send, connect: connect, camera: cam, latencies: latencies, goTo: function (label) { send({ type: "transition", to: label }); } };

  fetch("/world").then(function (r) { return r.json(); }).then(function (w) {
    W = w;
    // A character whose motion graph leaves out every label cannot start Motion Graphs.
    var graph = W.startable.indexOf(true) >= 0, starts = graph ? W.startable : W.startable_without_graph;
    W.systems.forEach(function (s) {
      var l = document.createElement("label"), c = document.createElement("input");
      c.type = "checkbox"; c.value = s; c.checked = s !== "reprise-paper" && (graph || s !== "motion-graphs");
      l.appendChild(c); l.appendChild(document.createTextNode(" " + s + " "));
      $("system-choice").appendChild(l);
    });
    var first = starts.indexOf(true);
    W.labels.forEach(function (l, i) {
      var o = document.createElement("option"); o.textContent = l; $("start").appendChild(o);
      // A label the checked systems have no frame in cannot start a session.
      o.disabled = !starts[i]; o.selected = i === first;
      var b = document.createElement("button"); b.textContent = l; b.dataset.label = l;
      b.onclick = function () { send({ type: "transition", to: l }); };
      $("labels").appendChild(b);
    });
    $("connect").onclick = connect;
    $("idle").onclick = function () { send({ type: "idle", radius: parseFloat($("radius").value) }); };
    if (!graph) log("motion-graphs: no frame of any label is in its graph's largest strongly connected component; it cannot run on this character");
    buildGame();
    fillTakes();
    status(W.rig + " · " + W.labels.length + " labels · " + W.fps + " fps");
    connect();
    requestAnimationFrame(render);
  }).catch(function (e) { status("cannot load /world: " + e); });
})();
