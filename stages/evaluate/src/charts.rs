//! The page's charts as inline SVG strings: latent spaces with the bridges between them,
//! GPLVM fit traces, latency distributions, plausibility by phase, mesh velocity and the
//! coverage heat maps. Each function draws one chart from values it is given; nothing here
//! measures or aggregates.

use std::fmt::Write as _;

use crate::html::esc;

/// Series colours, by system (or label) index.
pub const PALETTE: [&str; 10] =
    ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

fn svg_open(w: f64, h: f64, title: &str) -> String {
    format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' viewBox='0 0 {w} {h}' class='fig' role='img'>\
         <title>{t}</title><rect width='100%' height='100%' fill='white'/><text x='6' y='14' font-size='12'>{t}</text>",
        t = esc(title)
    )
}

/// A linear map of `[lo, hi]` onto `[a, b]` (a degenerate range maps to the middle).
fn scale(lo: f64, hi: f64, a: f64, b: f64) -> impl Fn(f64) -> f64 {
    move |v| if hi > lo { a + (v - lo) / (hi - lo) * (b - a) } else { (a + b) / 2.0 }
}

/// Smallest and largest finite value.
fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
}

/// Maps a latent point to its panel's pixel position.
type Place = Box<dyn Fn([f64; 2]) -> (f64, f64)>;

/// Panels per row of small multiples, and their size, for `n` panels of full size
/// `full`: four in a row up to a dozen, then eight in a row at 0.6 × the size, so that 48
/// labels take six rows rather than twelve.
fn small_multiples(n: usize, full: (f64, f64)) -> (usize, f64, f64) {
    if n <= 12 {
        (4, full.0, full.1)
    } else {
        (8, 0.6 * full.0, 0.6 * full.1)
    }
}

/// The most bridge lines the latent figure draws: past it, lines across dozens of panels
/// hide the panels, so only the bridges' ends are marked.
pub const MAX_BRIDGE_LINES: usize = 64;

/// Pixels per character of a label at `font` px (a sans-serif's mean advance).
fn text_width(text: &str, font: f64) -> f64 {
    text.chars().count() as f64 * font * 0.6
}

/// A bar: (mean, CI low, CI high); `None` where not measured.
pub type Bar = Option<(f64, f64, f64)>;

/// One label's latent space: its training latents (x0, x1), a polyline per segment.
pub struct LatentPanel {
    /// Label.
    pub label: String,
    /// Per segment, its points.
    pub segments: Vec<Vec<[f64; 2]>>,
}

/// All labels' latent spaces in a grid of panels ([`small_multiples`]), with the rank-1
/// bridges drawn between them: a line from $x_1$ in A's panel to $x_2$ in B's, coloured by
/// A, and the endpoints marked (● leaves, ○ arrives); past [`MAX_BRIDGE_LINES`] bridges
/// only the endpoints, and the title says so.
pub fn latents_with_bridges(panels: &[LatentPanel], bridges: &[(usize, [f64; 2], usize, [f64; 2])]) -> String {
    let (cols, pw, ph) = small_multiples(panels.len(), (250.0, 210.0));
    let rows = panels.len().div_ceil(cols).max(1);
    let (w, h) = (pw * cols as f64 + 20.0, ph * rows as f64 + 30.0);
    let lines = bridges.len() <= MAX_BRIDGE_LINES;
    let title = if lines {
        "Latent spaces (x0 against x1) and the best bridge of every ordered pair".to_string()
    } else {
        format!(
            "Latent spaces (x0 against x1) and where the best bridge of each of the {} ordered pairs leaves (●) and \
             arrives (○); lines omitted past {MAX_BRIDGE_LINES}",
            bridges.len()
        )
    };
    let mut s = svg_open(w, h, &title);
    let place: Vec<Place> = panels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (ox, oy) = (10.0 + pw * (i % cols) as f64, 24.0 + ph * (i / cols) as f64);
            // The panel frames its training latents and the bridge ends in its space.
            let ends = bridges.iter().flat_map(|(a, x1, b, x2)| [(*a, *x1), (*b, *x2)]).filter(|(l, _)| *l == i);
            let pts: Vec<[f64; 2]> = p.segments.iter().flatten().copied().chain(ends.map(|(_, x)| x)).collect();
            let (x0, x1) = range(pts.iter().map(|q| q[0]));
            let (y0, y1) = range(pts.iter().map(|q| q[1]));
            let (sx, sy) = (scale(x0, x1, ox + 10.0, ox + pw - 20.0), scale(y0, y1, oy + ph - 16.0, oy + 22.0));
            Box::new(move |q: [f64; 2]| (sx(q[0]), sy(q[1]))) as Place
        })
        .collect();
    for (i, p) in panels.iter().enumerate() {
        let (ox, oy) = (10.0 + pw * (i % cols) as f64, 24.0 + ph * (i / cols) as f64);
        let _ = write!(
            s,
            "<rect x='{ox}' y='{oy}' width='{}' height='{}' fill='none' stroke='#ccc'/><text x='{}' y='{}' font-size='12' fill='{}'>{}</text>",
            pw - 8.0,
            ph - 6.0,
            ox + 4.0,
            oy + 14.0,
            PALETTE[i % 10],
            esc(&p.label)
        );
        for seg in &p.segments {
            let pts: Vec<String> = seg.iter().map(|q| place[i](*q)).map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
            let _ = write!(
                s,
                "<polyline fill='none' stroke='{}' stroke-width='1' opacity='0.7' points='{}'/>",
                PALETTE[i % 10],
                pts.join(" ")
            );
        }
    }
    for &(a, x1, b, x2) in bridges.iter().filter(|(a, _, b, _)| *a < panels.len() && *b < panels.len()) {
        let ((ax, ay), (bx, by)) = (place[a](x1), place[b](x2));
        let c = PALETTE[a % 10];
        if lines {
            let _ = write!(
                s,
                "<line x1='{ax:.1}' y1='{ay:.1}' x2='{bx:.1}' y2='{by:.1}' stroke='{c}' stroke-width='0.8' opacity='0.35'/>"
            );
        }
        let _ = write!(
            s,
            "<circle cx='{ax:.1}' cy='{ay:.1}' r='2.5' fill='{c}'/><circle cx='{bx:.1}' cy='{by:.1}' r='2.5' fill='white' stroke='{c}'/>"
        );
    }
    s + "</svg>"
}

/// Small multiples of the GPLVM objective against iteration, one panel per label (its own
/// y axis, labelled with the first and last value).
pub fn fit_traces(traces: &[(String, Vec<(i64, f64)>)]) -> String {
    let (cols, pw, ph) = small_multiples(traces.len(), (250.0, 150.0));
    let rows = traces.len().div_ceil(cols).max(1);
    let mut s = svg_open(
        pw * cols as f64 + 20.0,
        ph * rows as f64 + 30.0,
        "GPLVM objective against iteration, per label: log₁₀(E − E_min), so the approach to convergence stays visible",
    );
    for (i, (label, raw)) in traces.iter().enumerate() {
        let (ox, oy) = (10.0 + pw * (i % cols) as f64, 24.0 + ph * (i / cols) as f64);
        let pts = gap_to_minimum(raw);
        let pts = &pts;
        let (i0, i1) = range(pts.iter().map(|p| p.0 as f64));
        let (v0, v1) = range(pts.iter().map(|p| p.1));
        let (sx, sy) = (scale(i0, i1, ox + 40.0, ox + pw - 14.0), scale(v0, v1, oy + ph - 26.0, oy + 20.0));
        let line: Vec<String> =
            pts.iter().filter(|p| p.1.is_finite()).map(|p| format!("{:.1},{:.1}", sx(p.0 as f64), sy(p.1))).collect();
        let (first, last) = (raw.first().map_or(f64::NAN, |p| p.1), raw.last().map_or(f64::NAN, |p| p.1));
        let _ = write!(
            s,
            "<rect x='{ox}' y='{oy}' width='{}' height='{}' fill='none' stroke='#ccc'/>\
             <text x='{}' y='{}' font-size='12'>{} — {} iterations</text>\
             <polyline fill='none' stroke='#1f77b4' stroke-width='1.5' points='{}'/>\
             <text x='{}' y='{}' font-size='10' fill='#555'>E: {first:.4e} → {last:.4e}</text>\
             <text x='{}' y='{}' font-size='10' fill='#555'>iteration</text>",
            pw - 8.0,
            ph - 6.0,
            ox + 4.0,
            oy + 14.0,
            esc(label),
            pts.len(),
            line.join(" "),
            ox + 40.0,
            oy + ph - 12.0,
            ox + pw - 60.0,
            oy + ph - 12.0
        );
    }
    if traces.is_empty() {
        let _ = write!(s, "<text x='20' y='50' font-size='12'>no fit trace given (--gplvm-trace)</text>");
    }
    s + "</svg>"
}

/// $\log_{10}(E_k - E_{min} + \delta)$ per iteration, $\delta = 10^{-9}\max(|E_{min}|, 1)$ (the
/// convergence rule's scale): the gap to the best value, so a fit that has converged ends
/// in a flat tail near $\log_{10}\delta$ and one still descending does not. Non-finite
/// values are dropped.
fn gap_to_minimum(pts: &[(i64, f64)]) -> Vec<(i64, f64)> {
    let min = pts.iter().map(|p| p.1).filter(|v| v.is_finite()).fold(f64::INFINITY, f64::min);
    let delta = 1e-9 * min.abs().max(1.0);
    pts.iter().filter(|p| p.1.is_finite()).map(|&(i, v)| (i, (v - min + delta).log10())).collect()
}

/// Perceived-latency distributions: one histogram row per system on a shared seconds axis,
/// with the count of requests that never arrived beside it. `series`: (system, perceived
/// latencies in s, requests that never arrived).
pub fn latency_histograms(series: &[(String, Vec<f64>, usize)]) -> String {
    let bins = 30;
    let (rw, rh) = (560.0, 60.0);
    let (lo, hi) = range(series.iter().flat_map(|s| s.1.iter().copied()));
    let (lo, hi) = if lo.is_finite() { (0.0_f64.min(lo), hi.max(lo + 1e-9)) } else { (0.0, 1.0) };
    let width = (hi - lo) / bins as f64;
    let h = 40.0 + rh * series.len() as f64 + 30.0;
    let stats: Vec<String> = series
        .iter()
        .map(|(_, v, unanswered)| {
            let median = reprise_motion_metrics::quantile(v, 0.5);
            format!("n = {}, median {median:.2} s, never arrived {unanswered}", v.len())
        })
        .collect();
    // The stats sit right of the rows: the picture is as wide as the longest of them
    // (11-px text, at most 0.62 em a character).
    let text_w = stats.iter().map(|t| t.chars().count()).max().unwrap_or(0) as f64 * 11.0 * 0.62;
    let mut s = svg_open(
        (150.0 + rw + text_w + 10.0).max(rw + 380.0),
        h,
        "Perceived latency per request (s), by system: histograms of the requests that arrived",
    );
    let sx = scale(lo, hi, 140.0, 140.0 + rw);
    for (i, (name, v, _)) in series.iter().enumerate() {
        let mut counts = vec![0usize; bins];
        for x in v {
            counts[(((x - lo) / width) as usize).min(bins - 1)] += 1;
        }
        let top = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
        let base = 40.0 + rh * (i + 1) as f64 - 6.0;
        let _ =
            write!(s, "<text x='6' y='{}' font-size='12' fill='{}'>{}</text>", base - 20.0, PALETTE[i % 10], esc(name));
        for (b, c) in counts.iter().enumerate() {
            let bh = *c as f64 / top * (rh - 14.0);
            let _ = write!(
                s,
                "<rect x='{:.1}' y='{:.1}' width='{:.1}' height='{bh:.1}' fill='{}'><title>{c} requests in [{:.2}, {:.2}) s</title></rect>",
                sx(lo + b as f64 * width),
                base - bh,
                (sx(lo + width) - sx(lo) - 1.0).max(1.0),
                PALETTE[i % 10],
                lo + b as f64 * width,
                lo + (b + 1) as f64 * width
            );
        }
        let _ = write!(
            s,
            "<line x1='140' y1='{base}' x2='{}' y2='{base}' stroke='#999'/><text x='{}' y='{}' font-size='11'>{}</text>",
            140.0 + rw,
            150.0 + rw,
            base - 20.0,
            stats[i]
        );
    }
    let _ = write!(
        s,
        "<text x='140' y='{y}' font-size='11'>{lo:.2} s</text><text x='{}' y='{y}' font-size='11' text-anchor='end'>{hi:.2} s</text>",
        140.0 + rw,
        y = h - 10.0
    );
    s + "</svg>"
}

/// Grouped bars with CI whiskers: per group (phase) one bar per system.
/// `values[group][system]`.
pub fn grouped_bars(title: &str, groups: &[&str], systems: &[String], values: &[Vec<Bar>]) -> String {
    let (w, h) = (420.0, 220.0);
    let mut s = svg_open(w, h, title);
    let top = values
        .iter()
        .flatten()
        .flatten()
        .map(|v| v.2.max(v.0))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-12);
    let sy = scale(0.0, top, h - 40.0, 30.0);
    let gw = (w - 60.0) / groups.len().max(1) as f64;
    let bw = (gw - 12.0) / systems.len().max(1) as f64;
    let _ = write!(s, "<line x1='40' y1='{y}' x2='{}' y2='{y}' stroke='#999'/><text x='4' y='34' font-size='10'>{top:.2}</text><text x='4' y='{y}' font-size='10'>0</text>", w - 10.0, y = h - 40.0);
    for (g, name) in groups.iter().enumerate() {
        let gx = 44.0 + g as f64 * gw;
        let _ = write!(
            s,
            "<text x='{:.1}' y='{}' font-size='11' text-anchor='middle'>{}</text>",
            gx + gw / 2.0 - 6.0,
            h - 24.0,
            esc(name)
        );
        for (k, sys) in systems.iter().enumerate() {
            let x = gx + k as f64 * bw;
            match values.get(g).and_then(|v| v.get(k)).copied().flatten() {
                Some((m, lo, hi)) if m.is_finite() => {
                    let _ = write!(
                        s,
                        "<rect x='{x:.1}' y='{:.1}' width='{:.1}' height='{:.1}' fill='{}'><title>{}: {m:.3} [{lo:.3}, {hi:.3}]</title></rect>\
                         <line x1='{c:.1}' x2='{c:.1}' y1='{:.1}' y2='{:.1}' stroke='#222'/>",
                        sy(m),
                        (bw - 2.0).max(1.0),
                        (h - 40.0 - sy(m)).max(0.0),
                        PALETTE[k % 10],
                        esc(sys),
                        sy(lo),
                        sy(hi),
                        c = x + bw / 2.0 - 1.0
                    );
                }
                _ => {
                    let _ = write!(s, "<text x='{x:.1}' y='{}' font-size='9'>–</text>", h - 44.0);
                }
            }
        }
    }
    for (k, sys) in systems.iter().enumerate() {
        let _ = write!(
            s,
            "<text x='{:.1}' y='{}' font-size='10' fill='{}'>■ {}</text>",
            44.0 + k as f64 * 95.0,
            h - 6.0,
            PALETTE[k % 10],
            esc(sys)
        );
    }
    s + "</svg>"
}

/// Mean peak vertex speed around transitions, one line per system:
/// (system, offsets from the first frame of B, values).
pub fn speed(series: &[(String, Vec<i64>, Vec<f64>)]) -> String {
    let (w, h) = (560.0, 240.0);
    let (_, max) = range(series.iter().flat_map(|s| s.2.iter().copied()));
    let max = max.max(1e-12);
    let (omin, omax) = range(series.iter().flat_map(|s| s.1.iter().map(|o| *o as f64)));
    let sx = scale(omin, omax, 40.0, w - 20.0);
    let sy = scale(0.0, max, h - 30.0, 20.0);
    let mut s = svg_open(w, h, &format!("peak vertex speed (max {max:.3} mesh units/s)"));
    let _ = write!(
        s,
        "<line x1='{x}' y1='20' x2='{x}' y2='{}' stroke='#999' stroke-dasharray='4'/>",
        h - 30.0,
        x = sx(0.0)
    );
    let _ = write!(
        s,
        "<text x='{}' y='{}' font-size='11'>frames from the first frame of the target label</text>",
        w / 2.0 - 120.0,
        h - 8.0
    );
    for (i, (name, off, vals)) in series.iter().enumerate() {
        let pts: Vec<String> = off
            .iter()
            .zip(vals)
            .filter(|(_, v)| v.is_finite())
            .map(|(o, v)| format!("{:.1},{:.1}", sx(*o as f64), sy(*v)))
            .collect();
        let _ = write!(
            s,
            "<polyline fill='none' stroke='{}' stroke-width='2' points='{}'/>",
            PALETTE[i % 10],
            pts.join(" ")
        );
        let _ = write!(
            s,
            "<text x='{}' y='{}' font-size='12' fill='{}'>{}</text>",
            w - 130.0,
            30.0 + 16.0 * i as f64,
            PALETTE[i % 10],
            esc(name)
        );
    }
    s + "</svg>"
}

/// A label × label heat map of shares in [0, 1] (`value(a, b)`; `None`: not measured).
/// Cells shrink with the label count (34 px down to 12) and carry their value as text
/// while it fits (else in the tooltip only); the margins fit the longest label.
pub fn heat(title: &str, labels: &[String], value: impl Fn(&str, &str) -> Option<f64>) -> String {
    let n = labels.len() as f64;
    let cell = (600.0 / n.max(1.0)).clamp(12.0, 34.0);
    let font = (cell - 2.0).min(11.0);
    let longest = labels.iter().map(|l| text_width(l, font)).fold(0.0, f64::max);
    // Column labels are turned 60°: they rise by sin 60° of their length.
    let (left, top) = (longest + 10.0, (longest * 0.87 + 14.0).max(24.0));
    let mut s = svg_open(left + n * cell + 10.0, top + n * cell + 10.0, title);
    for (i, a) in labels.iter().enumerate() {
        let _ = write!(
            s,
            "<text x='4' y='{:.1}' font-size='{font:.1}'>{}</text>",
            top + (i as f64 + 0.5) * cell + font * 0.35,
            esc(a)
        );
        let _ = write!(
            s,
            "<text x='{x:.1}' y='{y:.1}' font-size='{font:.1}' transform='rotate(-60 {x:.1} {y:.1})'>{}</text>",
            esc(a),
            x = left + (i as f64 + 0.5) * cell,
            y = top - 4.0
        );
        for (j, b) in labels.iter().enumerate() {
            let (x, y) = (left + j as f64 * cell, top + i as f64 * cell);
            let (fill, text) = match value(a, b) {
                Some(v) if a != b => {
                    let c = v.clamp(0.0, 1.0);
                    (
                        format!("rgb({g},{},{g})", 255 - (60.0 * c) as u8, g = (255.0 - 180.0 * c) as u8),
                        format!("{v:.2}"),
                    )
                }
                _ => ("#eee".into(), String::new()),
            };
            let shown = if cell >= 28.0 { text.as_str() } else { "" };
            let _ = write!(
                s,
                "<rect x='{x:.1}' y='{y:.1}' width='{cell:.1}' height='{cell:.1}' fill='{fill}' stroke='white'><title>{} → {}: {text}</title></rect><text x='{:.1}' y='{:.1}' font-size='10'>{shown}</text>",
                esc(a),
                esc(b),
                x + 4.0,
                y + 21.0
            );
        }
    }
    s + "</svg>"
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trace is drawn as the gap to its minimum on a log scale: known values, the
    /// minimum at log₁₀ δ, and NaN dropped.
    #[test]
    fn traces_are_gaps_to_the_minimum() {
        let g = gap_to_minimum(&[(1, 10.0), (2, 5.0), (3, f64::NAN), (4, 4.5)]);
        assert_eq!(g.iter().map(|p| p.0).collect::<Vec<_>>(), [1, 2, 4]);
        assert!((g[0].1 - (5.5f64 + 4.5e-9).log10()).abs() < 1e-12);
        assert!((g[1].1 - (0.5f64 + 4.5e-9).log10()).abs() < 1e-12);
        assert!((g[2].1 - 4.5e-9f64.log10()).abs() < 1e-12);
    }

    /// Every label of a 48-label heat map fits its margin and the cells shrink so the map
    /// stays within a screen's width; eight labels keep 34-px cells with their values.
    #[test]
    fn heat_maps_stay_readable_with_48_labels() {
        let labels: Vec<String> = (0..48).map(|i| format!("neutral_take{i:02}_b")).collect();
        let svg = heat("coverage", &labels, |_, _| Some(0.5));
        let width: f64 = svg.split("width='").nth(1).unwrap().split('\'').next().unwrap().parse().unwrap();
        assert!(width <= 800.0, "{width}");
        let font: f64 = svg.split("font-size='").nth(2).unwrap().split('\'').next().unwrap().parse().unwrap();
        let left: f64 = svg.split("<rect x='").nth(1).unwrap().split('\'').next().unwrap().parse().unwrap();
        assert!(4.0 + text_width(&labels[0], font) <= left, "row labels end before the first cell");
        assert!(font >= 10.0, "{font}");
        assert!(
            !svg.contains(">0.50</text>") && svg.contains("<title>neutral_take00_b → neutral_take01_b: 0.50</title>")
        );
        let few = heat("coverage", &labels[..8], |_, _| Some(0.5));
        assert!(few.contains("width='34.0'") && few.contains(">0.50</text>"), "{few}");
    }

    /// Up to 64 bridges are drawn as lines; past that, only their ends, and the title
    /// says so; 48 panels go eight to a row.
    #[test]
    fn many_bridges_are_drawn_as_ends_only() {
        let panels: Vec<LatentPanel> = (0..48)
            .map(|i| LatentPanel { label: format!("l{i}"), segments: vec![vec![[0.0, 0.0], [1.0, 1.0]]] })
            .collect();
        let bridges: Vec<_> = (0..48)
            .flat_map(|a| (0..48).filter(move |&b| b != a).map(move |b| (a, [0.5, 0.5], b, [0.2, 0.8])))
            .collect();
        let svg = latents_with_bridges(&panels, &bridges);
        assert!(!svg.contains("<line") && svg.matches("<circle").count() == 2 * bridges.len());
        assert!(svg.contains("each of the 2256 ordered pairs") && svg.contains("lines omitted past 64"), "title");
        assert_eq!(small_multiples(48, (250.0, 210.0)), (8, 150.0, 126.0));
        let few = latents_with_bridges(&panels[..3], &bridges[..4]);
        assert!(few.matches("<line").count() == 2 && few.contains("the best bridge of every ordered pair"), "{few}");
    }

    /// The per-system stats beside the histograms fit inside the picture, however many
    /// requests there are (they were cut at the right edge: "780" for 7,806).
    #[test]
    fn latency_stats_fit_the_picture() {
        let many: Vec<f64> = (0..11_280).map(|i| f64::from(i % 97) / 24.0).collect();
        let svg = latency_histograms(&[("motion-matching".into(), many, 12_345)]);
        let width: f64 = svg.split("width='").nth(1).unwrap().split('\'').next().unwrap().parse().unwrap();
        let text = "n = 11280, median 2.00 s, never arrived 12345";
        assert!(svg.contains(text), "{svg}");
        let x: f64 = svg.split("<text x='").filter_map(|t| t.split('\'').next()?.parse().ok()).fold(0.0, f64::max);
        assert!(x + text.len() as f64 * 11.0 * 0.6 <= width, "text from {x} overruns the width {width}");
    }
}
