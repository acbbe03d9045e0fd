//! The parsed file: the hierarchy (joints and end sites in file order), the raw motion
//! values, and the list of rig controls derived from the hierarchy.
//!
//! Conventions (shared by ingest and the rig):
//! - Lengths are in file units (for CMU files, CMU's own length unit, not metres).
//! - A joint's local transform is `T · R` (column vectors, `world = parent_world · T · R`):
//!   `T` translates by the joint's OFFSET, **or, if the joint has any position channel, by
//!   its position channels instead** (they replace the OFFSET, as most BVH readers do for
//!   the root; axes without a position channel keep the OFFSET's component). This holds for
//!   every joint, root or not.
//! - `R` is the product of the rotation channels in their declared order, each a
//!   right-handed rotation about the joint's own (intrinsic) axis by the channel's value in
//!   degrees: channels `Zrotation Xrotation Yrotation` give `R = Rz · Rx · Ry`.

/// One BVH channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

impl Channel {
    /// The channel for a name as written in a file (case-sensitive, as BVH writers emit it).
    pub fn from_name(name: &str) -> Option<Channel> {
        Some(match name {
            "Xposition" => Channel::Xposition,
            "Yposition" => Channel::Yposition,
            "Zposition" => Channel::Zposition,
            "Xrotation" => Channel::Xrotation,
            "Yrotation" => Channel::Yrotation,
            "Zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }

    /// The axis (0 = X, 1 = Y, 2 = Z).
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }

    /// True for the three rotation channels.
    pub fn is_rotation(self) -> bool {
        matches!(self, Channel::Xrotation | Channel::Yrotation | Channel::Zrotation)
    }
}

/// A joint (ROOT or JOINT) or an End Site.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Unique name: the joint's name, with `#2`, `#3`, … appended to later duplicates;
    /// an end site is named `<parent>.end`.
    pub name: String,
    /// Index of the parent node in [`Bvh::nodes`]; `None` for a root. Parents come first.
    pub parent: Option<usize>,
    /// The OFFSET, in file units.
    pub offset: [f64; 3],
    /// The channels in declared order (always empty for an end site).
    pub channels: Vec<Channel>,
    /// Column of the first channel in a motion line.
    pub first_column: usize,
    /// True for an End Site.
    pub end_site: bool,
    /// 1-based line of the ROOT/JOINT/End Site keyword.
    pub line: usize,
}

impl Node {
    /// True if the joint has at least one position channel.
    pub fn has_position(&self) -> bool {
        self.channels.iter().any(|c| !c.is_rotation())
    }

    /// True if the joint has at least one rotation channel.
    pub fn has_rotation(&self) -> bool {
        self.channels.iter().any(|c| c.is_rotation())
    }
}

/// What one rig control drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControlKind {
    /// `<joint>.tx/.ty/.tz`: the joint's translation on one axis, file units.
    Translation,
    /// `<joint>.rx/.ry/.rz`: one component of the joint's local rotation vector, radians.
    Rotation,
}

/// One rig control: which node and which component it drives.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlSpec {
    pub name: String,
    pub node: usize,
    pub kind: ControlKind,
    pub axis: usize,
}

/// A whole BVH file.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// The file's name as used in error messages.
    pub file: String,
    /// Joints and end sites in file (hierarchy) order; parents precede children.
    pub nodes: Vec<Node>,
    /// Number of values on each motion line (the sum of all CHANNELS counts).
    pub channel_count: usize,
    /// Number of frames (`Frames:`), equal to the number of motion lines.
    pub frames: usize,
    /// `Frame Time:` in seconds, as written.
    pub frame_time: f64,
    /// 1-based line of `Frames:` (errors about the motion as a whole point here).
    pub frames_line: usize,
    /// The motion values, row-major `frames × channel_count`, as written (degrees for
    /// rotations, file units for positions).
    pub motion: Vec<f64>,
}

/// How far two takes' OFFSETs may differ and still be one skeleton: this share of the
/// skeleton's largest OFFSET component (2 %: a re-calibrated performer, not another one).
pub const OFFSET_TOLERANCE: f64 = 0.02;

impl Bvh {
    /// Number of ROOT/JOINT nodes (end sites excluded).
    pub fn joint_count(&self) -> usize {
        self.nodes.iter().filter(|n| !n.end_site).count()
    }

    /// Number of End Site nodes.
    pub fn end_site_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.end_site).count()
    }

    /// The values of one frame (`channel_count` numbers).
    pub fn frame(&self, frame: usize) -> &[f64] {
        &self.motion[frame * self.channel_count..(frame + 1) * self.channel_count]
    }

    /// The source rate in frames per second: `1 / frame_time`, snapped to the nearest
    /// integer when within a relative 1e-4 of it (files print `Frame Time` rounded, e.g.
    /// CMU's `.0083333` for 1/120 s, which is exactly 120 fps).
    pub fn source_fps(&self) -> f64 {
        let fps = 1.0 / self.frame_time;
        let nearest = fps.round();
        if nearest >= 1.0 && ((fps - nearest) / nearest).abs() < 1e-4 {
            nearest
        } else {
            fps
        }
    }

    /// The first way `other`'s skeleton differs from this one's, or `None` when both have
    /// the same joints and end sites (names, parents, channels in order) and OFFSETs
    /// within [`OFFSET_TOLERANCE`] of the largest OFFSET component (an axis a position
    /// channel sets is not compared): takes of one performer recorded on different days
    /// differ by a little calibration. Takes of one skeleton can share one rig (the first
    /// take's OFFSETs; [`Bvh::offset_gap`] says by how much another differs); different
    /// skeletons cannot.
    pub fn skeleton_difference(&self, other: &Bvh) -> Option<String> {
        if self.nodes.len() != other.nodes.len() {
            return Some(format!("{} joints and end sites, not {}", other.nodes.len(), self.nodes.len()));
        }
        let scale = self.nodes.iter().flat_map(|n| n.offset).fold(0.0_f64, |m, v| m.max(v.abs())).max(1.0);
        for (a, b) in self.nodes.iter().zip(&other.nodes) {
            let at = |what: String| Some(format!("line {}: {what}", b.line));
            if a.name != b.name || a.end_site != b.end_site {
                return at(format!("`{}` where the first file has `{}`", b.name, a.name));
            }
            if a.parent != b.parent {
                return at(format!("`{}` hangs from another parent", b.name));
            }
            if a.channels != b.channels {
                return at(format!("`{}` has channels {:?}, not {:?}", b.name, b.channels, a.channels));
            }
            let set = |axis: usize| a.channels.iter().any(|c| !c.is_rotation() && c.axis() == axis);
            if let Some(axis) =
                (0..3).find(|&k| !set(k) && (a.offset[k] - b.offset[k]).abs() > OFFSET_TOLERANCE * scale)
            {
                return at(format!(
                    "`{}` has OFFSET {:?}, not {:?} ({} differs by more than {} % of the largest OFFSET, {scale}): \
                     another skeleton",
                    b.name,
                    b.offset,
                    a.offset,
                    ["X", "Y", "Z"][axis],
                    OFFSET_TOLERANCE * 100.0
                ));
            }
        }
        None
    }

    /// The largest OFFSET difference between this skeleton and `other`'s (same structure
    /// assumed, as [`Bvh::skeleton_difference`] checks): the joint or end site and the
    /// difference (file units), or `None` when every OFFSET is equal. Axes set by a
    /// position channel are not compared.
    pub fn offset_gap(&self, other: &Bvh) -> Option<(String, f64)> {
        let mut worst: Option<(String, f64)> = None;
        for (a, b) in self.nodes.iter().zip(&other.nodes) {
            let set = |axis: usize| a.channels.iter().any(|c| !c.is_rotation() && c.axis() == axis);
            let gap = (0..3).filter(|&k| !set(k)).map(|k| (a.offset[k] - b.offset[k]).abs()).fold(0.0, f64::max);
            if gap > 0.0 && worst.as_ref().is_none_or(|w| gap > w.1) {
                worst = Some((b.name.clone(), gap));
            }
        }
        worst
    }

    /// The rig controls, in hierarchy order: per joint, `.tx .ty .tz` if it has any
    /// position channel, then `.rx .ry .rz` if it has any rotation channel.
    pub fn controls(&self) -> Vec<ControlSpec> {
        let mut out = Vec::new();
        for (index, node) in self.nodes.iter().enumerate() {
            if node.has_position() {
                for (axis, suffix) in ["tx", "ty", "tz"].iter().enumerate() {
                    let name = format!("{}.{suffix}", node.name);
                    out.push(ControlSpec { name, node: index, kind: ControlKind::Translation, axis });
                }
            }
            if node.has_rotation() {
                for (axis, suffix) in ["rx", "ry", "rz"].iter().enumerate() {
                    let name = format!("{}.{suffix}", node.name);
                    out.push(ControlSpec { name, node: index, kind: ControlKind::Rotation, axis });
                }
            }
        }
        out
    }
}
