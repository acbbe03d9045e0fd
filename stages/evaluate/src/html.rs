//! The self-contained HTML report. Sections, in order: the conclusions (one sentence per
//! headline metric, from [`crate::model`]), what is missing from the inputs, the metric
//! tables (HTML, CIs shown, the long one sortable), the transition player and the
//! synthesized scripts (`assets/player.js`, data inline), the figures ([`crate::charts`],
//! PNG renders), the definitions and the provenance. No external resources; everything but
//! the player reads without JavaScript.
//!
//! The player's data: `<script type="application/json" id="player-data">` holds
//! [`Player`] plus `encoding` (`k`, `dim`, `frames`); `<script id="player-mesh">` holds
//! base64 of, little-endian and in order: mean (f32 × dim), coordinate scales (f32 × k),
//! basis row scales (f32 × k), basis (i16 × k·dim), codes (i16 × frames·k) — see
//! [`crate::encode`].

use std::fmt::Write as _;

use base64::Engine as _;

use crate::charts::{self, LatentPanel};
use crate::encode::Encoded;
use crate::measure::{Phase, PlausibilityReference as Reference, Space};
use crate::model;
use crate::player::{Player, PHASES};
use crate::render::{png, render, Camera, Shape};
use crate::report;
use crate::Metric;

/// One label's optimisation trace: (label, per iteration (iteration, objective)).
pub type Trace = (String, Vec<(i64, f64)>);

/// One label's GPLVM fit as the report shows it (a row of `gplvm_fits`).
#[derive(Debug, Clone, PartialEq)]
pub struct FitRow {
    /// Label, frames N and PCA dimension d.
    pub label: String,
    pub frames: i64,
    pub d: i64,
    /// How the connectivity prior entered the fit, and the optimiser.
    pub path: String,
    pub optimizer: String,
    /// Iterations (per stage, "i1+i2"), evaluations and seconds.
    pub iterations: String,
    pub evaluations: i64,
    pub seconds: f64,
    /// The minimised objective and its parts: −log p(Y|X), dynamics, connectivity (as the
    /// fit computed it), signal prior; and the exact connectivity prior at the optimum.
    pub objective: f64,
    pub likelihood: f64,
    pub dynamics: f64,
    pub connectivity: f64,
    pub signal: f64,
    pub connectivity_exact: Option<f64>,
    /// Inducing points of a sparse fit (0: the dense GPLVM).
    pub inducing: i64,
    /// Whether it converged, and why it stopped.
    pub converged: bool,
    pub stop_reason: String,
    /// The convergence rule's measures at the optimum.
    pub rel_decrease: f64,
    pub rel_gradient: f64,
}

/// A mesh with its caption.
pub type Picture = (String, Vec<f64>);

/// Everything the page shows besides the metric rows.
pub struct Page<'a> {
    /// Pipeline name.
    pub name: &'a str,
    /// The Markdown report (its definitions are shown).
    pub markdown: &'a str,
    /// Per label its latent space.
    pub latents: Vec<LatentPanel>,
    /// Rank-1 bridges: (index of A in `latents`, x1, index of B, x2).
    pub latent_bridges: Vec<(usize, [f64; 2], usize, [f64; 2])>,
    /// Bridge pose pairs: (caption, mesh of M1's pose, mesh of M2's pose).
    pub bridges: Vec<(String, Vec<f64>, Vec<f64>)>,
    /// Filmstrip: (caption, per frame (label, mesh)).
    pub filmstrip: Option<(String, Vec<Picture>)>,
    /// What the pictures draw of the rig's vertices.
    pub shape: Shape,
    /// A mesh that fixes the camera (a training pose).
    pub camera_mesh: &'a [f64],
    /// Mean peak vertex speed around transitions: (system, offsets from the first target
    /// frame, values).
    pub speed: Vec<(String, Vec<i64>, Vec<f64>)>,
    /// Per system: (shown name, perceived latencies in s, requests that never arrived).
    pub latencies: Vec<(String, Vec<f64>, usize)>,
    /// Per label the GPLVM objective by iteration.
    pub traces: Vec<Trace>,
    /// Per label the GPLVM fit's summary (from `gplvm_fits`).
    pub fits: Vec<FitRow>,
    /// Labels in order (for the coverage map).
    pub labels: &'a [String],
    /// The player's content (`None`: it could not be built; the reason is in `missing`).
    pub player: Option<Player>,
    /// What the inputs lack: one sentence each.
    pub missing: Vec<String>,
    /// Provenance lines.
    pub provenance: Vec<(String, String)>,
}

/// `s` with HTML's special characters escaped.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('\'', "&#39;")
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1240px;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
table{border-collapse:collapse;margin:.5em 0 1.2em}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;font-size:13px;vertical-align:top}\
th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}td.best{font-weight:bold;background:#eef7ee}\
.row{display:flex;flex-wrap:wrap;gap:10px}figure{margin:0;text-align:center;font-size:11px}.fig{border:1px solid #ddd;max-width:100%;height:auto}\
.missing{background:#fff4e0;border-left:4px solid #e8a33d;padding:.5em 1em}.conclusions li{margin:.3em 0}\
.player{border:1px solid #ccc;padding:.6em;margin:1em 0;background:#fafafa}.player .controls{display:flex;gap:8px;align-items:center;flex-wrap:wrap}\
.player input[type=range]{flex:1;min-width:200px}.player .panels{display:flex;flex-wrap:wrap;gap:8px;margin-top:.6em}\
.player .panel{text-align:left}.player canvas{border:1px solid #ddd;background:#f5f5f5}.player .cap{font-size:11.5px;margin-top:3px}\
.player .bridge{color:#7a3}code{background:#f3f3f3;padding:0 3px}nav a{margin-right:1em}";

/// Records script errors on the root element (`data-js-errors`, `data-js-error`) so a
/// headless run can read them from the DOM.
const ERROR_HOOK: &str = "<script>window.addEventListener('error',function(e){var r=document.documentElement;\
r.dataset.jsErrors=(+(r.dataset.jsErrors||0))+1;r.dataset.jsError=String(e.message);});</script>";

const PLAYER_JS: &str = include_str!("../assets/player.js");

/// The page.
pub fn page(p: &Page<'_>, metrics: &[Metric], ctx: &report::Context<'_>) -> String {
    let mut s = String::new();
    let others: Vec<&str> = ctx.systems.iter().skip(1).map(|(_, s)| s.as_str()).collect();
    let _ = write!(
        s,
        "<!doctype html><html lang='en'><head><meta charset='utf-8'><title>reprise — {n}</title><style>{STYLE}</style>{ERROR_HOOK}</head><body>\
         <h1>{n}: reprise against {o}</h1><nav><a href='#conclusions'>Conclusions</a><a href='#metrics'>Metrics</a>\
         <a href='#player'>Player</a><a href='#figures'>Figures</a><a href='#definitions'>Definitions</a><a href='#provenance'>Provenance</a></nav>",
        n = esc(p.name),
        o = esc(&others.join(", "))
    );
    conclusions(&mut s, metrics, ctx);
    missing(&mut s, &p.missing);
    tables(&mut s, metrics, ctx);
    player(&mut s, p.player.as_ref());
    figures(&mut s, p, metrics, ctx);
    definitions(&mut s, p.markdown);
    s += "<section id='provenance'><h2>Provenance</h2><table>";
    for (k, v) in &p.provenance {
        let _ = write!(s, "<tr><td>{}</td><td>{}</td></tr>", esc(k), esc(v));
    }
    s += "</table></section>";
    if let Some(pl) = &p.player {
        embed(&mut s, pl);
    }
    let _ = writeln!(s, "<script>{}</script></body></html>", PLAYER_JS.replace("</script", "<\\/script"));
    s
}

fn missing(s: &mut String, notes: &[String]) {
    if notes.is_empty() {
        return;
    }
    *s += "<section id='missing' class='missing'><h2>What is missing</h2><ul>";
    for n in notes {
        let _ = write!(s, "<li>{}</li>", esc(n));
    }
    *s += "</ul></section>";
}

fn conclusions(s: &mut String, m: &[Metric], ctx: &report::Context<'_>) {
    *s += "<section id='conclusions'><h2>Conclusions</h2><p>All label pairs; mean [95 % bootstrap CI] over requests. \
           One sentence per headline metric; the verdicts are the Markdown report's.</p><ul class='conclusions'>";
    for c in model::sentences(m, ctx) {
        let verdict = report::verdict_words(&c.verdict, |n| format!("<b>{}</b>", esc(n)));
        let values: Vec<String> = c.values.iter().map(|(n, v)| format!("{} {v}", esc(n))).collect();
        let _ = write!(s, "<li><code>{}</code> ({}): {verdict} — {}.</li>", c.metric, esc(&c.what), values.join("; "));
    }
    for n in model::notes(m, ctx) {
        let _ = write!(s, "<li>{}</li>", code(&esc(&n)));
    }
    *s += "</ul></section>";
}

/// Markdown's `code` spans as HTML.
fn code(s: &str) -> String {
    let mut out = String::new();
    for (i, part) in s.split('`').enumerate() {
        if i % 2 == 1 {
            let _ = write!(out, "<code>{part}</code>");
        } else {
            out += part;
        }
    }
    out
}

/// A table of the page model.
fn model_table(s: &mut String, t: &model::Table) {
    let _ = write!(s, "<h3 id='t-{}'>{}</h3>", t.id, esc(&t.title));
    let head: Vec<String> = t.head.iter().map(|h| esc(h)).collect();
    let rows: Vec<Vec<(String, bool, bool)>> =
        t.rows.iter().map(|r| r.iter().map(|c| (code(&esc(&c.text)), c.best, c.numeric)).collect()).collect();
    table(s, t.id, &head, &rows);
}

/// An HTML table: header cells, then rows of (cell, is-best, numeric) triples.
fn table(s: &mut String, class: &str, head: &[String], rows: &[Vec<(String, bool, bool)>]) {
    let _ = write!(s, "<table class='{class}'><thead><tr>");
    for h in head {
        let _ = write!(s, "<th>{h}</th>");
    }
    *s += "</tr></thead><tbody>";
    for r in rows {
        *s += "<tr>";
        for (c, best, num) in r {
            let cls = match (best, num) {
                (true, _) => " class='num best'",
                (false, true) => " class='num'",
                _ => "",
            };
            let _ = write!(s, "<td{cls}>{c}</td>");
        }
        *s += "</tr>";
    }
    *s += "</tbody></table>";
}

/// The per-label fit summaries: work done, the objective split into its parts, and
/// whether (and why) each fit stopped.
fn fit_table(s: &mut String, fits: &[FitRow]) {
    if fits.is_empty() {
        *s += "<p>No fit summaries given.</p>";
        return;
    }
    let converged = fits.iter().filter(|f| f.converged).count();
    let _ = write!(
        s,
        "<p>{converged} of {} labels converged (mean relative decrease per iteration over the rule's window, and \
         the scaled gradient, both under their tolerances; a fit stopped by the iteration cap is NOT converged). \
         E = −log p(Y|X) + dynamics + connectivity + signal prior, as minimised; <i>exact conn.</i> is the exact \
         connectivity prior at the same point (the reference for a cheaper path; – where it would cost more than \
         the fit). <i>GP</i>: the dense GPLVM, or the sparse one (DTC) with M inducing points, by the stage's \
         per-label rule.</p>",
        fits.len()
    );
    let head: Vec<String> = [
        "label",
        "N",
        "d",
        "GP",
        "path",
        "iterations",
        "evaluations",
        "seconds",
        "E",
        "−log p(Y|X)",
        "dynamics",
        "connectivity",
        "signal",
        "exact conn.",
        "rel. decrease",
        "rel. gradient",
        "stopped",
    ]
    .iter()
    .map(|h| h.to_string())
    .collect();
    let num = |v: String| (v, false, true);
    let rows: Vec<Vec<(String, bool, bool)>> = fits
        .iter()
        .map(|f| {
            let stop = if f.converged { f.stop_reason.clone() } else { format!("NOT converged: {}", f.stop_reason) };
            vec![
                text(&esc(&f.label)),
                num(f.frames.to_string()),
                num(f.d.to_string()),
                text(&if f.inducing > 0 { format!("sparse, M = {}", f.inducing) } else { "dense".into() }),
                text(&esc(&format!("{} ({})", f.path, f.optimizer))),
                num(esc(&f.iterations)),
                num(f.evaluations.to_string()),
                num(format!("{:.1}", f.seconds)),
                num(format!("{:.2}", f.objective)),
                num(format!("{:.2}", f.likelihood)),
                num(format!("{:.2}", f.dynamics)),
                num(format!("{:.2}", f.connectivity)),
                num(format!("{:.2}", f.signal)),
                num(f.connectivity_exact.map_or("–".into(), |c| format!("{c:.2}"))),
                num(format!("{:.1e}", f.rel_decrease)),
                num(format!("{:.1e}", f.rel_gradient)),
                text(&esc(&stop)),
            ]
        })
        .collect();
    table(s, "fits", &head, &rows);
}

fn text(c: &str) -> (String, bool, bool) {
    (c.to_string(), false, false)
}

fn tables(s: &mut String, m: &[Metric], ctx: &report::Context<'_>) {
    *s += "<section id='metrics'><h2>Metric tables</h2>";
    for t in model::metric_tables(m, ctx).iter().chain([&model::quality(m, ctx)]) {
        model_table(s, t);
    }

    *s += "<details><summary>Every overall row (click a header to sort)</summary>";
    let head: Vec<String> =
        ["system", "metric", "from", "to", "value", "95 % CI", "n", "unit"].map(String::from).to_vec();
    let rows: Vec<Vec<(String, bool, bool)>> = m
        .iter()
        .filter(|m| m.to == "all" || m.to.is_empty())
        .map(|m| {
            let ci = match (m.ci_low, m.ci_high) {
                (Some(a), Some(b)) => format!("[{a:.4}, {b:.4}]"),
                _ => String::new(),
            };
            vec![
                text(&esc(&m.system)),
                text(&esc(&m.metric)),
                text(&esc(&m.from)),
                text(&esc(&m.to)),
                (if m.value.is_finite() { format!("{:.4}", m.value) } else { "–".into() }, false, true),
                (ci, false, true),
                (m.n.to_string(), false, true),
                text(&esc(&m.unit)),
            ]
        })
        .collect();
    table(s, "sortable", &head, &rows);
    *s += "</details><p>Per-pair values are in metrics.parquet; the per-pair latency and coverage grids in report.md.</p></section>";
}

/// The player's HTML (controls; panels are built by the script).
fn player_box(id: &str, label: &str) -> String {
    format!(
        "<div class='player' id='{id}' data-ready='false' tabindex='0'><div class='controls'><label>{label} <select></select></label>\
         <button class='prev' title='previous frame (←)'>◀ frame</button><button class='play' title='play/pause (space)'>▶ play</button>\
         <button class='next' title='next frame (→)'>frame ▶</button><input type='range' step='1' aria-label='frame'>\
         <select class='speed' aria-label='speed'><option value='1'>1×</option><option value='0.5'>½×</option><option value='0.25'>¼×</option></select>\
         <span class='time'></span></div><div class='panels'></div>\
         <noscript><p>The player needs JavaScript; everything else on this page reads without it.</p></noscript></div>"
    )
}

fn player(s: &mut String, p: Option<&Player>) {
    *s += "<section id='player'><h2>Transitions, side by side</h2>";
    let Some(p) = p else {
        *s += "<p>No player: nothing to play (see the missing inputs above).</p></section>";
        return;
    };
    let _ = write!(
        s,
        "<p><b>Which requests.</b> {}</p><p>Each panel is one system answering the same request, aligned at the frame \
         the transition is asked. Step with ← →, play with space. The caption names the label whose model (or clip) \
         produced the frame, the phase (hold: before the request; reach: on the way to the target; blend: the first \
         frames of the target; settle: after), for reprise the bridge it went through, and the nearest training frame \
         (in mesh space, among the nearest in scaled control space) with its RMS vertex distance.</p>",
        esc(&p.rule)
    );
    if let Some(e) = &p.encoded {
        *s += &encoding_note(e, p.mesh_step);
    }
    if p.triangles.is_empty() {
        let what = if p.bones.is_empty() {
            "the rig gives neither triangles nor bones, so the panels draw its points as dots"
        } else {
            "the rig is a skeleton without triangles, so the panels draw its bones as sticks"
        };
        let _ = write!(s, "<p class='note'>{what}.</p>");
    }
    *s += &player_box("transition-player", "request");
    *s += "<h3>Synthesized scripts</h3><p>The synthesize stage's scripts (the <code>curves</code> input), played \
           with the model and command that produced each frame and the particle's latent point.</p>";
    if p.scripts.is_empty() {
        *s += "<p>No synthesized scripts in the curves input.</p>";
    } else {
        *s += &player_box("script-player", "script");
    }
    *s += "</section>";
}

fn encoding_note(e: &Encoded, mesh_step: f64) -> String {
    format!(
        "<p class='encoding'><b>Encoding.</b> {} frames of {} vertices as a mesh-space PCA basis of {} components \
         fitted to the shown frames (int16 per row), coordinates int16 per frame: {:.2} MB before base64. \
         Reconstruction RMS vertex error: mean {:.2e}, max {:.2e} mesh units (target {:.2e} = {:.0} % of the training \
         data's median per-frame motion, {:.2e}).</p>",
        e.codes.len() / e.k.max(1),
        e.dim / 3,
        e.k,
        e.bytes() as f64 / 1e6,
        e.mean_error,
        e.max_error,
        e.target,
        100.0 * crate::player::ERROR_SHARE,
        mesh_step
    )
}

/// The player's JSON and base64 payload (see the module doc for the layout).
fn embed(s: &mut String, p: &Player) {
    let Some(e) = &p.encoded else { return };
    let mut json = serde_json::to_value(p).unwrap_or_default();
    if let Some(o) = json.as_object_mut() {
        o.insert(
            "encoding".into(),
            serde_json::json!({ "k": e.k, "dim": e.dim, "frames": e.codes.len() / e.k.max(1) }),
        );
        o.insert("phases".into(), serde_json::json!(PHASES));
    }
    let mut bytes: Vec<u8> = Vec::with_capacity(e.bytes());
    for v in e.mean.iter().chain(&e.scale).chain(&e.basis_scale) {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for v in e.basis.iter().chain(&e.codes) {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let _ = write!(
        s,
        "<script type='application/json' id='player-data'>{}</script><script type='application/octet-stream' id='player-mesh'>{}</script>",
        json.to_string().replace("</", "<\\/"),
        base64::engine::general_purpose::STANDARD.encode(bytes)
    );
}

fn image(cam: &Camera, mesh: &[f64], shape: &Shape, tint: [f64; 3], size: usize, caption: &str) -> String {
    let rgb = render(cam, mesh, shape, tint);
    let (w, h) = cam.size();
    let b64 = base64::engine::general_purpose::STANDARD.encode(png(&rgb, w, h));
    format!("<figure><img alt='{c}' width='{size}' height='{size}' src='data:image/png;base64,{b64}'/><figcaption>{c}</figcaption></figure>", c = esc(caption))
}

fn figures(s: &mut String, p: &Page<'_>, m: &[Metric], ctx: &report::Context<'_>) {
    let shown: Vec<String> = ctx.systems.iter().map(|(_, n)| n.clone()).collect();
    *s += "<section id='figures'><h2>Figures</h2>";
    let _ = write!(
        s,
        "<h3>How long until each system looks like the target? (perceived latency)</h3><div id='latency'>{}</div>",
        charts::latency_histograms(&p.latencies)
    );
    *s += "<h3>Where in a transition do poses leave the training data?</h3><div class='row' id='plausibility'>";
    for r in Reference::ALL {
        for sp in Space::ALL {
            let values: Vec<Vec<charts::Bar>> = Phase::AFTER
                .iter()
                .map(|ph| {
                    let name = crate::measure::plausibility::metric_name(r, sp, Some(*ph));
                    ctx.systems
                        .iter()
                        .map(|(id, _)| {
                            report::find(m, id, &name, "all", "all")
                                .filter(|x| x.n > 0)
                                .map(|x| (x.value, x.ci_low.unwrap_or(x.value), x.ci_high.unwrap_or(x.value)))
                        })
                        .collect()
                })
                .collect();
            let title = format!("plausibility, {} reference, {} space", r.name(), sp.name());
            *s += &charts::grouped_bars(&title, &Phase::AFTER.map(Phase::name), &shown, &values);
        }
    }
    *s += "</div><h3>Which pairs does each system reach in time?</h3><div class='row' id='coverage'>";
    for (id, name) in ctx.systems {
        let cov = |a: &str, b: &str| {
            m.iter().find(|x| &x.system == id && x.metric == "coverage" && x.from == a && x.to == b).map(|x| x.value)
        };
        *s += &charts::heat(&format!("coverage within {} s — {name}", ctx.coverage_seconds), p.labels, cov);
    }
    let _ = write!(
        s,
        "</div><h3>How abrupt are the transitions?</h3><p>Mean over answered requests of the per-frame peak vertex \
         speed, aligned at the first frame of the target label.</p><div id='velocity'>{}</div>",
        charts::speed(&p.speed)
    );
    *s += "<h3>Did the GPLVM fits converge?</h3>";
    fit_table(s, &p.fits);
    let _ = write!(s, "<div id='traces'>{}</div>", charts::fit_traces(&p.traces));
    let _ = write!(
        s,
        "<h3>Latent spaces and the bridges between them (the paper's Fig. 2)</h3><p>Each label's training latents, \
         one polyline per segment; a line for the best bridge of every ordered pair from x1 (●, in A's space) to \
         x2 (○, in B's) — past {} bridges only their ends, as lines across dozens of panels hide them.</p>\
         <div id='latents'>{}</div>",
        charts::MAX_BRIDGE_LINES,
        charts::latents_with_bridges(&p.latents, &p.latent_bridges)
    );
    let cam = Camera::fit(&[p.camera_mesh], 280, 280);
    let _ = write!(
        s,
        "<h3>Bridge poses (Fig. 3)</h3><p>The closest bridges: M1's pose at x1 and M2's at x2, rendered through the \
         rig ({}).</p><div class='row' id='bridges'>",
        p.shape.drawn_as()
    );
    for (caption, a, b) in &p.bridges {
        *s += "<div class='row'>";
        *s += &image(&cam, a, &p.shape, [0.85, 0.6, 0.45], 280, &format!("{caption} — from"));
        *s += &image(&cam, b, &p.shape, [0.45, 0.6, 0.85], 280, &format!("{caption} — to"));
        *s += "</div>";
    }
    *s += "</div>";
    if let Some((caption, frames)) = &p.filmstrip {
        let cam = Camera::fit(&[p.camera_mesh], 120, 120);
        let _ =
            write!(s, "<h3>Synthesized sequence (Fig. 4)</h3><p>{}</p><div class='row' id='filmstrip'>", esc(caption));
        for (label, mesh) in frames {
            *s += &image(&cam, mesh, &p.shape, [0.8, 0.7, 0.55], 120, label);
        }
        *s += "</div>";
    }
    *s += "</section>";
}

/// The Markdown report's definitions, as HTML (bullets, `code`, **bold**).
fn definitions(s: &mut String, md: &str) {
    *s += "<section id='definitions'><h2>Definitions</h2>";
    let body = md.split("## Definitions").nth(1).unwrap_or("");
    let mut in_list = false;
    let mut table: Vec<Vec<String>> = Vec::new();
    for para in body.split('\n').map(str::trim).filter(|l| !l.is_empty()) {
        // A Markdown table (the metric catalogue): rows gathered, written at its end.
        if let Some(row) = para.strip_prefix('|').and_then(|r| r.strip_suffix('|')) {
            if !row.chars().all(|c| matches!(c, '-' | '|' | ':' | ' ')) {
                table.push(row.split(" | ").map(|c| inline_md(&esc(c.trim()))).collect());
            }
            continue;
        }
        if !table.is_empty() {
            let head: Vec<String> = table.remove(0);
            let rows: Vec<Vec<(String, bool, bool)>> =
                table.drain(..).map(|r| r.into_iter().map(|c| (c, false, false)).collect()).collect();
            crate::html::table(s, "definitions", &head, &rows);
        }
        let (item, line) = match para.strip_prefix("- ") {
            Some(rest) => (true, rest),
            None => (false, para),
        };
        if item != in_list {
            *s += if item { "<ul>" } else { "</ul>" };
            in_list = item;
        }
        let html = inline_md(&esc(line));
        let _ = write!(s, "{}", if item { format!("<li>{html}</li>") } else { format!("<p>{html}</p>") });
    }
    if in_list {
        *s += "</ul>";
    }
    *s += "</section>";
}

/// `code` and **bold** of one escaped Markdown line.
fn inline_md(line: &str) -> String {
    let mut out = String::new();
    for (i, part) in line.split('`').enumerate() {
        if i % 2 == 1 {
            let _ = write!(out, "<code>{part}</code>");
        } else {
            for (j, p) in part.split("**").enumerate() {
                let _ = write!(out, "{}", if j % 2 == 1 { format!("<b>{p}</b>") } else { p.to_string() });
            }
        }
    }
    out
}
