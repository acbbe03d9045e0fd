//! The crossfade baseline — the floor every transition method must beat.
//!
//! On a request while start frame $s$ is shown, pick the target frame $j$ nearest the
//! current pose in scaled control space, $j = \arg\min_t \lVert z_t - z_s\rVert^2$ over the
//! target's frames with `blend_frames` $= k$ frames of continuation in their segment
//! ($t + \max(k,1) \le$ segment end), lowest index on ties. Then for $p = 0,\dots,k-1$
//! output
//! $$\alpha(p)\,z^A_p + (1-\alpha(p))\,z_{j+1+p},$$
//! with $\alpha$ the Motion Graphs ease ([`reprise_motiongraph::blend_weight`]: $\alpha(-1) =
//! 1$, $\alpha(k-1) = 0$, zero slope at both ends) so both baselines blend alike, and
//! $z^A_p = z_{\min(s+1+p,\ \text{segment\_end}(s))}$: the source **keeps playing** while it
//! has frames and holds its last frame after. From $p = k$ on, $B$ plays on ($z_{j+1+p}$).
//! When $B$'s segment ends the same rule chains a new crossfade from its last (held)
//! frame. $k = 0$ is a hard cut.

use crate::database::{Database, FrameSet};
use crate::error::{check_finite, check_len, MatchError, Result};
use crate::playback::Playback;
use crate::search::Match;
use reprise_motiongraph::blend_weight;

/// The frames of `label` a crossfade of `blend_frames` may start from.
pub fn crossfade_candidates(db: &Database, label: u32, blend_frames: usize) -> FrameSet {
    let need = blend_frames.max(1);
    FrameSet::from_predicate(db.len(), |t| db.label(t) == label && t + need <= db.segment_end(t))
}

/// The candidate nearest `pose` in squared Euclidean distance on $z$ (lowest index on
/// ties), `None` if `candidates` is empty.
///
/// # Errors
/// [`MatchError::Length`] / [`MatchError::NonFinite`] for a bad pose,
/// [`MatchError::Mismatch`] if `candidates` belongs to another database.
pub fn nearest_pose(db: &Database, pose: &[f64], candidates: &FrameSet) -> Result<Option<Match>> {
    check_len("pose", db.dim(), pose.len())?;
    check_finite("pose", pose, db.dim())?;
    if candidates.universe() != db.len() {
        return Err(MatchError::Mismatch {
            what: "candidate frames",
            expected: db.len(),
            actual: candidates.universe(),
        });
    }
    let mut best: Option<Match> = None;
    for t in candidates.iter() {
        let cost: f64 = db.row(t).iter().zip(pose).map(|(a, b)| (a - b) * (a - b)).sum();
        if best.is_none_or(|m| cost < m.cost) {
            best = Some(Match { frame: t, cost });
        }
    }
    Ok(best)
}

/// Crossfades from `start` into label `target` over `blend_frames`, producing `frames`
/// output frames (frame 0 follows the request).
///
/// # Errors
/// [`MatchError::FrameOutOfRange`], [`MatchError::NoSearchableFrames`] if `target` has no
/// frame with `blend_frames` frames of continuation.
pub fn crossfade(
    db: &Database,
    start: usize,
    target: u32,
    blend_frames: usize,
    frames: usize,
) -> Result<Playback> {
    db.check_frame(start)?;
    let candidates = crossfade_candidates(db, target, blend_frames);
    let pick = |from: usize| -> Result<usize> {
        let m = nearest_pose(db, db.row(from), &candidates)?;
        m.map(|m| m.frame + 1).ok_or(MatchError::NoSearchableFrames {
            label: target,
            needed: blend_frames.max(1),
        })
    };
    let mut out = Playback::new(db.dim(), target, frames);
    let mut row = vec![0.0; db.dim()];
    // `a`: the frame being left; `b`: the target frame playing; `p`: frames into the blend.
    let (mut a, mut b, mut p) = (start, pick(start)?, 0);
    for _ in 0..frames {
        let alpha = if p < blend_frames {
            if db.has_next(a) {
                a += 1;
            }
            #[allow(clippy::cast_precision_loss)] // p < blend_frames, a frame count
            let alpha = blend_weight(p as f64, blend_frames);
            for ((o, za), zb) in row.iter_mut().zip(db.row(a)).zip(db.row(b)) {
                *o = alpha * za + (1.0 - alpha) * zb;
            }
            alpha
        } else {
            row.copy_from_slice(db.row(b));
            0.0
        };
        out.push(&row, b, db.label(b), p == 0, alpha);
        p += 1;
        if db.has_next(b) {
            b += 1;
        } else {
            (a, b, p) = (b, pick(b)?, 0);
        }
    }
    Ok(out)
}
