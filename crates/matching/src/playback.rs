//! [`Playback`]: the frames a transition produces, column-wise so a stage can write them
//! as a table directly.

/// Output of a transition: one entry per output frame $k = 0, 1, \dots$; frame 0 is the
/// first frame after the request, which arrived while the start frame was shown.
#[derive(Debug, Clone, PartialEq)]
pub struct Playback {
    /// Control dimension $C$.
    pub dim: usize,
    /// Row-major `len × C` output in scaled controls (the caller unscales).
    pub z: Vec<f64>,
    /// Database frame playing at each output frame (the destination's, during a blend).
    pub frames: Vec<usize>,
    /// Label of that frame.
    pub labels: Vec<u32>,
    /// Whether a transition started at this output frame (the first frame of a switch or
    /// of a crossfade).
    pub switches: Vec<bool>,
    /// Weight still on the motion being left: the crossfade's $\alpha(p)$; 0 for the
    /// controller (its residue is the inertialization offset, not a weight).
    pub source_weight: Vec<f64>,
    /// The requested label.
    pub target: u32,
    /// Frames of the window into the target: the continuation motion matching searched it
    /// with ([`crate::FeatureDb::continuation_of`]) or the crossfade's blend
    /// ([`crate::crossfade_blend`]). Shorter than asked for when every segment of the
    /// target is too short for the full window.
    pub window: usize,
    /// First output frame whose database frame has the target label (`None`: not reached
    /// within the frames played).
    pub latency: Option<usize>,
}

impl Playback {
    pub(crate) fn new(dim: usize, target: u32, window: usize, capacity: usize) -> Self {
        Self {
            dim,
            z: Vec::with_capacity(capacity * dim),
            frames: Vec::with_capacity(capacity),
            labels: Vec::with_capacity(capacity),
            switches: Vec::with_capacity(capacity),
            source_weight: Vec::with_capacity(capacity),
            target,
            window,
            latency: None,
        }
    }

    pub(crate) fn push(&mut self, z: &[f64], frame: usize, label: u32, switch: bool, w: f64) {
        if self.latency.is_none() && label == self.target {
            self.latency = Some(self.frames.len());
        }
        self.z.extend_from_slice(z);
        self.frames.push(frame);
        self.labels.push(label);
        self.switches.push(switch);
        self.source_weight.push(w);
    }

    /// Number of output frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame was produced.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Output controls of frame `k` (panics if `k >= len()`).
    pub fn row(&self, k: usize) -> &[f64] {
        &self.z[k * self.dim..(k + 1) * self.dim]
    }
}
