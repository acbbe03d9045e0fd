//! A standalone HTML page that plays baked tracks side by side: a front view (x right, y
//! up, looking down −z), flat shaded, triangles drawn back to front; play, pause, a frame
//! slider, and per-frame readouts (e.g. the mesh error of each frame). The data are
//! embedded (32-bit floats, base64), so the page needs nothing but a browser.

use base64::Engine as _;
use serde_json::json;

use crate::bake::Baked;

/// One per-frame number shown beside the slider.
#[derive(Debug, Clone, PartialEq)]
pub struct Readout {
    /// What it is (with its unit).
    pub label: String,
    /// Its value per frame.
    pub values: Vec<f64>,
}

/// What the page shows.
pub struct Page<'a> {
    /// The page's title.
    pub title: &'a str,
    /// A paragraph under it (plain text).
    pub caption: &'a str,
    /// The baked tracks.
    pub baked: &'a Baked,
    /// The mesh's triangles.
    pub triangles: &'a [[u32; 3]],
    /// One name per track.
    pub names: &'a [String],
    /// Frames per second.
    pub fps: f64,
    /// Per-frame readouts.
    pub readouts: &'a [Readout],
}

fn b64_f32(v: &[f64]) -> String {
    base64::engine::general_purpose::STANDARD
        .encode(v.iter().flat_map(|&x| (x as f32).to_le_bytes()).collect::<Vec<u8>>())
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The page's HTML.
pub fn html(p: &Page<'_>) -> String {
    let b = p.baked;
    let data = json!({
        "vertices": b.vertices,
        "k": b.k(),
        "fps": p.fps,
        "names": p.names,
        "mean": b64_f32(&b.mean),
        "targets": b64_f32(&b.targets),
        "weights": b.weights.iter().map(|w| b64_f32(w)).collect::<Vec<_>>(),
        "triangles": base64::engine::general_purpose::STANDARD
            .encode(p.triangles.iter().flatten().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()),
        "readouts": p.readouts.iter().map(|r| json!({"label": r.label, "values": r.values})).collect::<Vec<_>>(),
    });
    format!(
        "<!doctype html><html><head><meta charset='utf-8'><title>{t}</title><style>\
         body{{font-family:sans-serif;margin:16px;max-width:1100px}}canvas{{border:1px solid #ccc;margin-right:8px}}\
         .tracks{{display:flex;flex-wrap:wrap;gap:8px}}.track{{display:flex;flex-direction:column;align-items:center;font-size:13px}}#bar{{margin:8px 0}}\
         #slider{{width:60%;vertical-align:middle}}</style></head><body><h1>{t}</h1><p>{c}</p>\
         <div class='tracks' id='tracks'></div><div id='bar'><button id='play'>pause</button> \
         <input type='range' id='slider' min='0' value='0'> <span id='readout'></span></div>\
         <script id='data' type='application/json'>{d}</script><script>{js}</script></body></html>",
        t = esc(p.title),
        c = esc(p.caption),
        d = data.to_string().replace("</", "<\\/"),
        js = SCRIPT,
    )
}

/// The player's script: decodes the data, reconstructs each track's frame, draws it.
const SCRIPT: &str = r#"
const D = JSON.parse(document.getElementById('data').textContent);
const f32 = s => { const b = atob(s), u = new Uint8Array(b.length); for (let i = 0; i < b.length; i++) u[i] = b.charCodeAt(i); return new Float32Array(u.buffer); };
const u32 = s => { const b = atob(s), u = new Uint8Array(b.length); for (let i = 0; i < b.length; i++) u[i] = b.charCodeAt(i); return new Uint32Array(u.buffer); };
const V = D.vertices, K = D.k, M = 3 * V, mean = f32(D.mean), targets = f32(D.targets), tri = u32(D.triangles);
const W = D.weights.map(f32), frames = K > 0 ? W[0].length / K : 1;
const frame = (t, i) => { const f = Float32Array.from(mean); for (let k = 0; k < K; k++) { const w = W[t][i * K + k]; if (w === 0) continue; const o = k * M; for (let j = 0; j < M; j++) f[j] += w * targets[o + j]; } return f; };
let lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
for (let t = 0; t < W.length; t++) for (let i = 0; i < frames; i += Math.max(1, Math.floor(frames / 24))) { const f = frame(t, i); for (let v = 0; v < V; v++) for (let a = 0; a < 2; a++) { lo[a] = Math.min(lo[a], f[3 * v + a]); hi[a] = Math.max(hi[a], f[3 * v + a]); } }
const size = 400, pad = 12, span = Math.max(hi[0] - lo[0], hi[1] - lo[1]) || 1, s = (size - 2 * pad) / span;
const px = x => pad + (x - lo[0]) * s + (size - 2 * pad - (hi[0] - lo[0]) * s) / 2, py = y => size - pad - (y - lo[1]) * s - (size - 2 * pad - (hi[1] - lo[1]) * s) / 2;
const ctxs = D.names.map(n => { const d = document.createElement('div'); d.className = 'track'; const c = document.createElement('canvas'); c.width = c.height = size; d.appendChild(c); d.appendChild(document.createTextNode(n)); document.getElementById('tracks').appendChild(d); return c.getContext('2d'); });
const L = [0.3, 0.5, 1.0], ln = Math.hypot(...L);
function draw(i) {
  ctxs.forEach((g, t) => {
    const f = frame(t, i); g.fillStyle = '#fff'; g.fillRect(0, 0, size, size);
    const n = tri.length / 3, order = new Array(n), depth = new Float32Array(n);
    for (let k = 0; k < n; k++) { order[k] = k; depth[k] = f[3 * tri[3 * k] + 2] + f[3 * tri[3 * k + 1] + 2] + f[3 * tri[3 * k + 2] + 2]; }
    order.sort((a, b) => depth[a] - depth[b]);
    for (const k of order) {
      const [a, b, c] = [tri[3 * k], tri[3 * k + 1], tri[3 * k + 2]];
      const u = [f[3 * b] - f[3 * a], f[3 * b + 1] - f[3 * a + 1], f[3 * b + 2] - f[3 * a + 2]], v = [f[3 * c] - f[3 * a], f[3 * c + 1] - f[3 * a + 1], f[3 * c + 2] - f[3 * a + 2]];
      const nx = u[1] * v[2] - u[2] * v[1], ny = u[2] * v[0] - u[0] * v[2], nz = u[0] * v[1] - u[1] * v[0], nn = Math.hypot(nx, ny, nz) || 1;
      const lit = 0.3 + 0.7 * Math.abs(nx * L[0] + ny * L[1] + nz * L[2]) / (nn * ln), g8 = Math.round(80 + 150 * lit);
      g.fillStyle = g.strokeStyle = `rgb(${g8},${Math.round(g8 * 0.93)},${Math.round(g8 * 0.85)})`;
      g.beginPath(); g.moveTo(px(f[3 * a]), py(f[3 * a + 1])); g.lineTo(px(f[3 * b]), py(f[3 * b + 1])); g.lineTo(px(f[3 * c]), py(f[3 * c + 1])); g.closePath(); g.fill(); g.stroke();
    }
  });
  const r = D.readouts.map(o => `${o.label}: ${Number(o.values[i]).toPrecision(3)}`).join(' · ');
  document.getElementById('readout').textContent = `frame ${i} / ${frames - 1} (${(i / D.fps).toFixed(2)} s)` + (r ? ' · ' + r : '');
  slider.value = i;
}
const slider = document.getElementById('slider'), button = document.getElementById('play');
slider.max = frames - 1; let at = 0, playing = true, last = performance.now();
slider.oninput = () => { at = +slider.value; draw(at); };
button.onclick = () => { playing = !playing; button.textContent = playing ? 'pause' : 'play'; };
function tick(now) { if (playing && now - last >= 1000 / D.fps) { last = now; at = (at + 1) % frames; draw(at); } requestAnimationFrame(tick); }
draw(0); requestAnimationFrame(tick);
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::bake;

    #[test]
    fn the_page_embeds_every_track_and_escapes_text() {
        let frames: Vec<f64> =
            (0..4).flat_map(|i| vec![0.0, f64::from(i), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]).collect();
        let baked = bake(&[&frames, &frames], 3, 2).unwrap();
        let names = ["ours".to_string(), "known</script>".to_string()];
        let readouts = [Readout { label: "error".into(), values: vec![0.1, 0.2, 0.3, 0.4] }];
        let page = Page {
            title: "a <test>",
            caption: "x & y",
            baked: &baked,
            triangles: &[[0, 1, 2]],
            names: &names,
            fps: 24.0,
            readouts: &readouts,
        };
        let h = html(&page);
        assert!(h.contains("a &lt;test&gt;") && h.contains("x &amp; y"));
        assert!(!h.contains("known</script>"), "a name cannot close the data block");
        assert!(h.contains("\"k\":1") && h.contains("\"vertices\":3"));
        assert_eq!(h.matches("<script").count(), 2);
    }
}
