//! Arrival as a viewer sees it: the first frame from which the pose looks like B and
//! keeps looking like B — the same rule for every system, whatever it labels its frames.
//!
//! A frame looks like label B when its nearest training pose on the mesh — among the
//! training frames and their projections through their own label's PCA, so neither a
//! replaying nor a PCA-based system is favoured — is a frame of B. Arrival is the first
//! frame after the request that starts a run of `h` such frames in a row.

use super::nearest::Cache;

/// The arrival frame of an answer asked at frame `asked`, into label `b` (an index into
/// the training labels), needing `h` B-like frames in a row (`h = 0` counts as 1); `None`
/// if the answer never arrives.
pub fn find(near: &mut Cache<'_>, asked: usize, b: usize, h: usize) -> Option<usize> {
    let h = h.max(1);
    let mut run = 0;
    for t in asked + 1..near.frames() {
        if near.label(t) == Some(b) {
            run += 1;
            if run == h {
                return Some(t + 1 - h);
            }
        } else {
            run = 0;
        }
    }
    None
}
