//! Protocol A's chart as an SVG string: RMS against label count, one line per method, a
//! bar of ± one standard deviation over draws at each point. Draws only what it is given.

use std::fmt::Write as _;

use reprise_artifact::retarget::Comparison;

/// Series colours, by method order.
const PALETTE: [&str; 8] = ["#7f7f7f", "#1f77b4", "#9467bd", "#ff7f0e", "#d62728", "#2ca02c", "#8c564b", "#e377c2"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The chart of `rows` (methods in their first appearance's order).
pub fn rms_against_labels(rows: &[Comparison]) -> String {
    let (w, h, left, right, top, bottom) = (720.0, 420.0, 60.0, 250.0, 30.0, 40.0);
    let mut methods: Vec<&str> = Vec::new();
    let mut labels: Vec<i64> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
        if !labels.contains(&r.labels) {
            labels.push(r.labels);
        }
    }
    labels.sort_unstable();
    let hi = rows.iter().map(|r| r.rms + r.sd).filter(|v| v.is_finite()).fold(0.0f64, f64::max).max(1e-12) * 1.05;
    let px = |l: i64| {
        let i = labels.iter().position(|&x| x == l).unwrap_or(0) as f64;
        left + (i + 0.5) / labels.len().max(1) as f64 * (w - left - right)
    };
    let py = |v: f64| top + (1.0 - v / hi) * (h - top - bottom);
    let mut s = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' viewBox='0 0 {w} {h}' role='img'>\
         <title>RMS target error against labelled pairs</title><rect width='100%' height='100%' fill='white'/>\
         <text x='6' y='16' font-size='13'>RMS target error against labelled pairs (mean ± sd over draws)</text>\
         <line x1='{left}' y1='{}' x2='{}' y2='{}' stroke='#333'/><line x1='{left}' y1='{top}' x2='{left}' y2='{}' stroke='#333'/>",
        h - bottom,
        w - right,
        h - bottom,
        h - bottom
    );
    for k in 0..=4 {
        let v = hi * f64::from(k) / 4.0;
        let _ = write!(
            s,
            "<text x='{}' y='{:.1}' font-size='10' text-anchor='end'>{v:.3}</text>\
             <line x1='{left}' y1='{y:.1}' x2='{}' y2='{y:.1}' stroke='#eee'/>",
            left - 4.0,
            py(v) + 3.0,
            w - right,
            y = py(v)
        );
    }
    for &l in &labels {
        let _ = write!(
            s,
            "<text x='{:.1}' y='{}' font-size='11' text-anchor='middle'>{l}</text>",
            px(l),
            h - bottom + 16.0
        );
    }
    let _ = write!(
        s,
        "<text x='{:.1}' y='{}' font-size='11' text-anchor='middle'>labelled pairs</text>",
        (left + w - right) / 2.0,
        h - 6.0
    );
    for (m, name) in methods.iter().enumerate() {
        let colour = PALETTE[m % PALETTE.len()];
        let mut pts: Vec<&Comparison> = rows.iter().filter(|r| r.method == *name).collect();
        pts.sort_by_key(|r| r.labels);
        // A small offset per method keeps the error bars apart.
        let dx = (m as f64 - methods.len() as f64 / 2.0) * 3.0;
        let line: Vec<String> = pts.iter().map(|r| format!("{:.1},{:.1}", px(r.labels) + dx, py(r.rms))).collect();
        let _ = write!(s, "<polyline fill='none' stroke='{colour}' stroke-width='2' points='{}'/>", line.join(" "));
        for r in &pts {
            let x = px(r.labels) + dx;
            let _ = write!(
                s,
                "<line x1='{x:.1}' y1='{:.1}' x2='{x:.1}' y2='{:.1}' stroke='{colour}'/><circle cx='{x:.1}' cy='{:.1}' r='3' fill='{colour}'/>",
                py((r.rms - r.sd).max(0.0)),
                py(r.rms + r.sd),
                py(r.rms)
            );
        }
        let ly = top + 10.0 + 18.0 * m as f64;
        let _ = write!(
            s,
            "<line x1='{}' y1='{ly}' x2='{}' y2='{ly}' stroke='{colour}' stroke-width='3'/><text x='{}' y='{}' font-size='11'>{}</text>",
            w - right + 10.0,
            w - right + 30.0,
            w - right + 36.0,
            ly + 4.0,
            esc(name)
        );
    }
    s + "</svg>"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_gets_a_line_and_a_legend_entry() {
        let row = |labels, method: &str, rms| Comparison { labels, method: method.into(), rms, sd: 0.01, draws: 3 };
        let rows = [row(5, "GPR", 0.08), row(10, "GPR", 0.06), row(5, "a <b>", 0.09), row(10, "a <b>", 0.05)];
        let svg = rms_against_labels(&rows);
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches("<circle").count(), 4);
        assert!(svg.contains("a &lt;b&gt;") && !svg.contains("a <b>"));
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
    }
}
