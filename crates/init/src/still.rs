//! Labels that barely move. A label's motion is the median, over consecutive frames of its
//! segments, of the frame step $\lVert w \odot (p_{t+1} - p_t)\rVert$ in scaled control
//! space ($w$: each control's mean weight from `scale`, its effect on the mesh, so a step is
//! about a mesh distance). A label whose motion is under [`STILL_SHARE`] of the median
//! label's barely moves: its GPLVM would model noise, and no bridge threshold measured in
//! its motion can be met.

use std::collections::BTreeMap;

use reprise_artifact::frames::LabeledFrames;

/// A label barely moves when its median frame step is under this share of the median
/// label's (5 %).
pub const STILL_SHARE: f64 = 0.05;

/// Each label's median frame step (scaled control units), in order of first appearance.
pub fn label_motion(lf: &LabeledFrames, weights: &[f64]) -> Vec<(String, f64)> {
    let mut steps: Vec<(String, Vec<f64>)> = Vec::new();
    for (start, end) in lf.segment_runs() {
        let label = &lf.label[start];
        let i = match steps.iter().position(|(l, _)| l == label) {
            Some(i) => i,
            None => {
                steps.push((label.clone(), Vec::new()));
                steps.len() - 1
            }
        };
        for r in start..end.saturating_sub(1) {
            let (a, b) = (lf.frames.row(r), lf.frames.row(r + 1));
            let step = a.iter().zip(b).zip(weights).map(|((x, y), w)| (w * (y - x)).powi(2)).sum::<f64>().sqrt();
            steps[i].1.push(step);
        }
    }
    steps.into_iter().map(|(l, s)| (l, median(s))).collect()
}

/// The labels whose motion is under [`STILL_SHARE`] of the median label's, with why.
pub fn still_labels(motion: &[(String, f64)]) -> BTreeMap<String, String> {
    let typical = median(motion.iter().map(|m| m.1).collect());
    motion
        .iter()
        .filter(|(_, m)| *m < STILL_SHARE * typical)
        .map(|(l, m)| {
            let why = format!(
                "barely moves: its median frame step is {m:.3e}, under {:.0} % of the median label's ({typical:.3e}; \
                 scaled control units, about mesh units)",
                STILL_SHARE * 100.0
            );
            (l.clone(), why)
        })
        .collect()
}

/// The median (the mean of the middle two of an even count; 0 for none).
fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use reprise_artifact::frames::{Frames, LabeledFrames};

    use super::{label_motion, still_labels};

    /// Three labels of one control: steps 1.0, 0.8 and 0.01 (× weight 2). The third,
    /// under 5 % of the median label's motion, is named with its measure; a weight of
    /// zero makes a control's motion not count.
    #[test]
    fn a_label_that_barely_moves_is_named() {
        let rows: Vec<(i64, &str, f64)> = (0..10)
            .map(|i| (0, "walk", f64::from(i)))
            .chain((0..10).map(|i| (1, "wave", 0.8 * f64::from(i))))
            .chain((0..10).map(|i| (2, "idle", 0.01 * f64::from(i))))
            .collect();
        let lf = LabeledFrames {
            segment_id: rows.iter().map(|r| r.0).collect(),
            label: rows.iter().map(|r| r.1.to_string()).collect(),
            frames: Frames {
                fps: 24.0,
                controls: vec!["c".into(), "dead".into()],
                clip: rows.iter().map(|r| format!("clip{}", r.0)).collect(),
                frame: (0..30).map(|r| r % 10).collect(),
                time: (0..30).map(|r| f64::from(r % 10) / 24.0).collect(),
                values: rows.iter().flat_map(|r| [r.2, 100.0 * r.2]).collect(),
            },
            masked_controls: vec![],
        };
        let motion = label_motion(&lf, &[2.0, 0.0]);
        let names: Vec<&str> = motion.iter().map(|m| m.0.as_str()).collect();
        assert_eq!(names, ["walk", "wave", "idle"]);
        assert!((motion[0].1 - 2.0).abs() < 1e-12 && (motion[2].1 - 0.02).abs() < 1e-12, "{motion:?}");
        let still = still_labels(&motion);
        assert_eq!(still.keys().collect::<Vec<_>>(), ["idle"]);
        assert!(still["idle"].contains("barely moves: its median frame step is 2.000e-2, under 5 %"), "{still:?}");
    }
}
