//! The self-contained HTML report: figures as inline SVG and PNG data URIs, no scripts,
//! no external resources.

use std::fmt::Write as _;

use base64::Engine as _;

use crate::render::{png, render, Camera};
use crate::Metric;

/// A mesh with its caption.
pub type Picture = (String, Vec<f64>);

/// Everything the page shows besides the metric rows.
pub struct Page<'a> {
    /// Pipeline name.
    pub name: &'a str,
    /// The Markdown report's overall table and conclusions, as HTML-escaped Markdown.
    pub summary_md: &'a str,
    /// Per label: (label, per segment: latent points (x0, x1)).
    pub latents: Vec<(String, Vec<Vec<[f64; 2]>>)>,
    /// Bridge pose pairs: (caption, mesh of M1's pose, mesh of M2's pose).
    pub bridges: Vec<(String, Vec<f64>, Vec<f64>)>,
    /// Filmstrip: (caption, per frame (label, mesh)).
    pub filmstrip: Option<(String, Vec<Picture>)>,
    /// Triangles of the rig's mesh.
    pub triangles: &'a [[u32; 3]],
    /// A mesh that fixes the camera (a training pose).
    pub camera_mesh: &'a [f64],
    /// Mean peak vertex speed around transitions: (system, offsets from the first target
    /// frame, values).
    pub speed: Vec<(String, Vec<i64>, Vec<f64>)>,
    /// Labels in order (for the coverage map).
    pub labels: &'a [String],
    /// Systems compared: (id, shown name).
    pub systems: &'a [(String, String)],
    /// Provenance lines.
    pub provenance: Vec<(String, String)>,
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

const PALETTE: [&str; 10] =
    ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

fn latent_svg(label: &str, segs: &[Vec<[f64; 2]>]) -> String {
    let (w, h) = (260.0, 220.0);
    let pts = segs.iter().flatten();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let sx = |v: f64| 10.0 + (v - lo[0]) / (hi[0] - lo[0]).max(1e-12) * (w - 20.0);
    let sy = |v: f64| h - 20.0 - (v - lo[1]) / (hi[1] - lo[1]).max(1e-12) * (h - 40.0);
    let mut s = format!("<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' class='fig'><rect width='100%' height='100%' fill='white'/><text x='8' y='14' font-size='12'>{}</text>", esc(label));
    for (i, seg) in segs.iter().enumerate() {
        let path: Vec<String> = seg.iter().map(|p| format!("{:.1},{:.1}", sx(p[0]), sy(p[1]))).collect();
        let _ = write!(
            s,
            "<polyline fill='none' stroke='{}' stroke-width='1.2' points='{}'/>",
            PALETTE[i % 10],
            path.join(" ")
        );
    }
    s + "</svg>"
}

fn image(cam: &Camera, mesh: &[f64], tris: &[[u32; 3]], tint: [f64; 3], size: usize, caption: &str) -> String {
    let rgb = render(cam, mesh, tris, tint);
    let (w, h) = cam.size();
    let b64 = base64::engine::general_purpose::STANDARD.encode(png(&rgb, w, h));
    format!("<figure><img alt='{c}' width='{size}' height='{size}' src='data:image/png;base64,{b64}'/><figcaption>{c}</figcaption></figure>", c = esc(caption))
}

fn speed_svg(series: &[(String, Vec<i64>, Vec<f64>)]) -> String {
    let (w, h) = (560.0, 240.0);
    let all: Vec<f64> = series.iter().flat_map(|s| s.2.iter().copied()).filter(|v| v.is_finite()).collect();
    let max = all.iter().copied().fold(0.0, f64::max).max(1e-12);
    let (omin, omax) =
        series.iter().flat_map(|s| s.1.iter().copied()).fold((i64::MAX, i64::MIN), |(a, b), o| (a.min(o), b.max(o)));
    let sx = |o: i64| 40.0 + (o - omin) as f64 / ((omax - omin).max(1)) as f64 * (w - 60.0);
    let sy = |v: f64| h - 30.0 - v / max * (h - 50.0);
    let mut s = format!("<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' class='fig'><rect width='100%' height='100%' fill='white'/>");
    let _ =
        write!(s, "<line x1='{x}' y1='20' x2='{x}' y2='{}' stroke='#999' stroke-dasharray='4'/>", h - 30.0, x = sx(0));
    let _ = write!(
        s,
        "<text x='{}' y='{}' font-size='11'>frames from the first frame of the target label</text>",
        w / 2.0 - 120.0,
        h - 8.0
    );
    let _ = write!(s, "<text x='4' y='14' font-size='11'>peak vertex speed (max {max:.3} mesh units/s)</text>");
    for (i, (name, off, vals)) in series.iter().enumerate() {
        let pts: Vec<String> = off
            .iter()
            .zip(vals)
            .filter(|(_, v)| v.is_finite())
            .map(|(o, v)| format!("{:.1},{:.1}", sx(*o), sy(*v)))
            .collect();
        let _ =
            write!(s, "<polyline fill='none' stroke='{}' stroke-width='2' points='{}'/>", PALETTE[i], pts.join(" "));
        let _ = write!(
            s,
            "<text x='{}' y='{}' font-size='12' fill='{}'>{}</text>",
            w - 130.0,
            30.0 + 16.0 * i as f64,
            PALETTE[i],
            esc(name)
        );
    }
    s + "</svg>"
}

fn heat_svg(title: &str, labels: &[String], value: impl Fn(&str, &str) -> Option<f64>) -> String {
    let cell = 34.0;
    let left = 90.0;
    let top = 90.0;
    let n = labels.len() as f64;
    let mut s = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' class='fig'><rect width='100%' height='100%' fill='white'/><text x='4' y='14' font-size='12'>{}</text>",
        left + n * cell + 10.0,
        top + n * cell + 10.0,
        esc(title)
    );
    for (i, a) in labels.iter().enumerate() {
        let _ = write!(s, "<text x='4' y='{}' font-size='11'>{}</text>", top + i as f64 * cell + 21.0, esc(a));
        let _ = write!(
            s,
            "<text x='{x}' y='{y}' font-size='11' transform='rotate(-60 {x} {y})'>{}</text>",
            esc(a),
            x = left + i as f64 * cell + 14.0,
            y = top - 6.0
        );
        for (j, b) in labels.iter().enumerate() {
            let (x, y) = (left + j as f64 * cell, top + i as f64 * cell);
            let (fill, text) = match value(a, b) {
                Some(v) => {
                    let g = (255.0 - 180.0 * v.clamp(0.0, 1.0)) as u8;
                    (format!("rgb({g},{},{g})", 255 - (60.0 * v.clamp(0.0, 1.0)) as u8), format!("{v:.2}"))
                }
                None => ("#eee".into(), String::new()),
            };
            let _ = write!(s, "<rect x='{x}' y='{y}' width='{cell}' height='{cell}' fill='{fill}' stroke='white'/><text x='{}' y='{}' font-size='10'>{text}</text>", x + 4.0, y + 21.0);
        }
    }
    s + "</svg>"
}

/// The page.
pub fn page(p: &Page<'_>, metrics: &[Metric]) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!doctype html><html lang='en'><head><meta charset='utf-8'><title>reprise — {n}</title><style>\
         body{{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:left;font-size:13px}}\
         .row{{display:flex;flex-wrap:wrap;gap:10px}}figure{{margin:0;text-align:center;font-size:11px}}\
         .fig{{border:1px solid #ddd}}pre{{white-space:pre-wrap;background:#f7f7f7;padding:1em}}</style></head><body>\
         <h1>reprise against {others} — {n}</h1>",
        n = esc(p.name),
        others = esc(&p.systems.iter().skip(1).map(|(_, s)| s.as_str()).collect::<Vec<_>>().join(", "))
    );
    let _ = write!(s, "<h2>Summary</h2><pre>{}</pre>", esc(p.summary_md));
    let _ = write!(s, "<h2>Latent spaces (the paper's Fig. 2)</h2><p>Each label's training latents (x0 against x1), one polyline per segment.</p><div class='row' id='latents'>");
    for (label, segs) in &p.latents {
        s += &latent_svg(label, segs);
    }
    s += "</div>";
    let cam = Camera::fit(&[p.camera_mesh], 160, 160);
    let _ = write!(s, "<h2>Bridges (Fig. 3)</h2><p>The closest bridges: M1's pose at x1 and M2's at x2, rendered through the rig.</p><div class='row' id='bridges'>");
    for (caption, a, b) in &p.bridges {
        s += "<div class='row'>";
        s += &image(&cam, a, p.triangles, [0.85, 0.6, 0.45], 160, &format!("{caption} — from"));
        s += &image(&cam, b, p.triangles, [0.45, 0.6, 0.85], 160, &format!("{caption} — to"));
        s += "</div>";
    }
    s += "</div>";
    if let Some((caption, frames)) = &p.filmstrip {
        let _ =
            write!(s, "<h2>Synthesized sequence (Fig. 4)</h2><p>{}</p><div class='row' id='filmstrip'>", esc(caption));
        for (label, mesh) in frames {
            s += &image(&cam, mesh, p.triangles, [0.8, 0.7, 0.55], 120, label);
        }
        s += "</div>";
    }
    let _ = write!(s, "<h2>Mesh velocity around transitions</h2><p>Mean over answered requests of the per-frame peak vertex speed, aligned at the first frame of the target label.</p><div id='velocity'>{}</div>", speed_svg(&p.speed));
    let cov = |sys: &str| {
        let sys = sys.to_string();
        move |a: &str, b: &str| {
            metrics
                .iter()
                .find(|m| m.system == sys && m.metric == "coverage" && m.from == a && m.to == b)
                .map(|m| m.value)
        }
    };
    s += "<h2>Coverage (label × label)</h2><div class='row' id='coverage'>";
    for (id, shown) in p.systems {
        s += &heat_svg(shown, p.labels, cov(id));
    }
    s += "</div>";
    s += "<h2>All metrics</h2><table><tr><th>system</th><th>metric</th><th>from</th><th>to</th><th>value</th><th>95 % CI</th><th>n</th><th>unit</th></tr>";
    for m in metrics.iter().filter(|m| m.to == "all" || m.to.is_empty()) {
        let ci = match (m.ci_low, m.ci_high) {
            (Some(a), Some(b)) => format!("[{a:.4}, {b:.4}]"),
            _ => String::new(),
        };
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.4}</td><td>{ci}</td><td>{}</td><td>{}</td></tr>",
            esc(&m.system),
            esc(&m.metric),
            esc(&m.from),
            esc(&m.to),
            m.value,
            m.n,
            esc(&m.unit)
        );
    }
    s += "</table><p>Per-pair values are in metrics.parquet.</p><h2>Provenance</h2><table>";
    for (k, v) in &p.provenance {
        let _ = write!(s, "<tr><td>{}</td><td>{}</td></tr>", esc(k), esc(v));
    }
    s + "</table></body></html>\n"
}
