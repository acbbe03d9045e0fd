//! The rig's control list: names, groups, units, defaults and ranges (742 controls).
//!
//! Order (and counts): head 9, jaw 5, tongue 12, nostrils 12, ears 30, brows 18, eyelids 10,
//! eyes 6, shapes_coarse 44, shapes_fine 380, lattice 192, tweak 24.
//! Naming: `L` is the character's left side (+x), `R` its right (−x).

/// Physical unit of a control.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Bone rotation angle in degrees.
    Degrees,
    /// Dimensionless blendshape weight, 0..1 (or −1..1).
    Slider,
    /// Translation in centimetres (bones, lattice points, tweak offsets).
    Centimetres,
}

impl Unit {
    /// Short unit string: `"deg"`, `"slider"`, `"cm"`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Unit::Degrees => "deg",
            Unit::Slider => "slider",
            Unit::Centimetres => "cm",
        }
    }
}

/// One rig control: a named scalar with a unit, a default and an animator-facing range.
#[derive(Clone, Debug, PartialEq)]
pub struct ControlSpec {
    /// Unique snake_case name, e.g. `"jaw_open"`, `"ear_L_01_rx"`, `"eye_L_yaw"`.
    pub name: String,
    /// Control group, e.g. `"jaw"`, `"ears"`, `"shapes_fine"`, `"lattice"`, `"tweak"`.
    pub group: String,
    pub unit: Unit,
    pub default: f64,
    pub min: f64,
    pub max: f64,
}

/// Sides with the sign of their x coordinate.
pub(crate) const SIDES: [(&str, f64); 2] = [("L", 1.0), ("R", -1.0)];

/// The coarse (intermediate) blendshape sliders, 0..1.
pub(crate) const COARSE_SHAPES: [&str; 44] = [
    "smile_L",
    "smile_R",
    "frown_L",
    "frown_R",
    "snarl_L",
    "snarl_R",
    "jaw_open_shape",
    "cheek_puff_L",
    "cheek_puff_R",
    "cheek_raise_L",
    "cheek_raise_R",
    "cheek_suck_L",
    "cheek_suck_R",
    "lip_pucker",
    "lip_funnel",
    "lip_press",
    "lip_roll_upper",
    "lip_roll_lower",
    "mouth_wide_L",
    "mouth_wide_R",
    "mouth_narrow_L",
    "mouth_narrow_R",
    "mouth_left",
    "mouth_right",
    "nose_wrinkle_L",
    "nose_wrinkle_R",
    "upper_lip_raise_L",
    "upper_lip_raise_R",
    "lower_lip_depress_L",
    "lower_lip_depress_R",
    "squint_L",
    "squint_R",
    "eye_wide_L",
    "eye_wide_R",
    "chin_raise",
    "dimple_L",
    "dimple_R",
    "lip_stretch_L",
    "lip_stretch_R",
    "jowl_L",
    "jowl_R",
    "throat_swallow",
    "snout_scrunch",
    "forehead_raise",
];

/// A family of fine blendshapes: `count` localised bumps along a facial feature, each in
/// several directions. Names: `{prefix}[_{side}]_{NN}_{dir}` (`{prefix}_{side}_{dir}` when
/// `count == 1`).
pub(crate) struct FineFamily {
    pub prefix: &'static str,
    pub sided: bool,
    pub count: usize,
    pub dirs: &'static [&'static str],
}

const UDOI: &[&str] = &["up", "down", "out", "in"];
const UD: &[&str] = &["up", "down"];
const IO: &[&str] = &["in", "out"];

/// The fine blendshape families (380 sliders in all).
pub(crate) const FINE_FAMILIES: [FineFamily; 12] = [
    FineFamily { prefix: "lip_upper", sided: false, count: 16, dirs: UDOI },
    FineFamily { prefix: "lip_lower", sided: false, count: 16, dirs: UDOI },
    FineFamily { prefix: "brow_seg", sided: true, count: 10, dirs: &["up", "down", "in"] },
    FineFamily { prefix: "lid_upper", sided: true, count: 6, dirs: UD },
    FineFamily { prefix: "lid_lower", sided: true, count: 6, dirs: UD },
    FineFamily { prefix: "cheek", sided: true, count: 8, dirs: IO },
    FineFamily { prefix: "snout_ridge", sided: false, count: 12, dirs: UD },
    FineFamily { prefix: "nostril_seg", sided: true, count: 4, dirs: &["flare", "narrow"] },
    FineFamily { prefix: "chin", sided: false, count: 8, dirs: UD },
    FineFamily { prefix: "mouth_corner", sided: true, count: 1, dirs: UDOI },
    FineFamily { prefix: "jawline", sided: true, count: 6, dirs: IO },
    FineFamily { prefix: "forehead", sided: false, count: 12, dirs: UD },
];

impl FineFamily {
    /// Control name of segment `seg` (0-based) in direction `dir` on side `side` (ignored
    /// when the family is not sided).
    pub(crate) fn name(&self, side: &str, seg: usize, dir: &str) -> String {
        let mut s = String::from(self.prefix);
        if self.sided {
            s.push('_');
            s.push_str(side);
        }
        if self.count > 1 {
            s.push_str(&format!("_{:02}", seg + 1));
        }
        s.push('_');
        s.push_str(dir);
        s
    }

    /// The sides this family is instanced on.
    pub(crate) fn sides(&self) -> &'static [(&'static str, f64)] {
        if self.sided {
            &SIDES
        } else {
            &SIDES[..1]
        }
    }
}

/// Lattice resolution per axis (cubic Bernstein: 4 control points per axis).
pub(crate) const LATTICE_N: usize = 4;

/// Lattice control name for point (i, j, k) (x, y, z indices) and axis 0..3.
pub(crate) fn lattice_name(i: usize, j: usize, k: usize, axis: usize) -> String {
    format!("lattice_{i}{j}{k}_t{}", ["x", "y", "z"][axis])
}

/// Tweak regions: small cm offsets that exist on the rig but are never animated.
pub(crate) const TWEAK_REGIONS: [&str; 8] =
    ["brow_L", "brow_R", "cheek_L", "cheek_R", "snout", "chin", "mouth_corner_L", "mouth_corner_R"];

/// Ear chain length (bones per ear) and tongue chain length.
pub(crate) const EAR_BONES: usize = 5;
pub(crate) const TONGUE_BONES: usize = 4;
pub(crate) const BROW_BONES: [&str; 3] = ["inner", "mid", "outer"];

struct Builder(Vec<ControlSpec>);

impl Builder {
    fn push(&mut self, name: impl Into<String>, group: &str, unit: Unit, min: f64, max: f64) {
        self.0.push(ControlSpec { name: name.into(), group: group.to_string(), unit, default: 0.0, min, max });
    }
    fn rot3(&mut self, base: &str, group: &str, lim: [f64; 3]) {
        for (ax, l) in ["rx", "ry", "rz"].iter().zip(lim) {
            self.push(format!("{base}_{ax}"), group, Unit::Degrees, -l, l);
        }
    }
}

/// Build the full, ordered control list.
pub(crate) fn build_controls() -> Vec<ControlSpec> {
    use Unit::*;
    let mut b = Builder(Vec::with_capacity(742));
    // head (9)
    b.rot3("neck", "head", [30.0, 45.0, 25.0]);
    b.rot3("head", "head", [40.0, 80.0, 35.0]);
    for ax in ["tx", "ty", "tz"] {
        b.push(format!("head_{ax}"), "head", Centimetres, -6.0, 6.0);
    }
    // jaw (5)
    b.push("jaw_open", "jaw", Degrees, -5.0, 45.0);
    b.push("jaw_side", "jaw", Degrees, -12.0, 12.0);
    b.push("jaw_twist", "jaw", Degrees, -10.0, 10.0);
    b.push("jaw_fwd", "jaw", Centimetres, -2.0, 2.0);
    b.push("jaw_clench", "jaw", Slider, 0.0, 1.0);
    // tongue (12): tiny bones hidden inside the mouth
    for i in 1..=TONGUE_BONES {
        b.rot3(&format!("tongue_{i:02}"), "tongue", [45.0; 3]);
    }
    // nostrils (12): flare bones with tiny skin weights
    for (s, _) in SIDES {
        for i in 1..=2 {
            b.rot3(&format!("nostril_{s}_{i:02}"), "nostrils", [45.0; 3]);
        }
    }
    // ears (30)
    for (s, _) in SIDES {
        for i in 1..=EAR_BONES {
            b.rot3(&format!("ear_{s}_{i:02}"), "ears", [70.0, 60.0, 45.0]);
        }
    }
    // brows (18): 6 blendshape sliders + 6 bones × (ty cm, rz deg)
    for shape in ["brow_up", "brow_down", "brow_squeeze"] {
        for (s, _) in SIDES {
            b.push(format!("{shape}_{s}"), "brows", Slider, 0.0, 1.0);
        }
    }
    for (s, _) in SIDES {
        for seg in BROW_BONES {
            b.push(format!("brow_{s}_{seg}_ty"), "brows", Centimetres, -2.0, 2.0);
            b.push(format!("brow_{s}_{seg}_rz"), "brows", Degrees, -25.0, 25.0);
        }
    }
    // eyelids (10)
    for (s, _) in SIDES {
        b.push(format!("eyelid_{s}_upper_rx"), "eyelids", Degrees, -30.0, 60.0);
        b.push(format!("eyelid_{s}_upper_rz"), "eyelids", Degrees, -20.0, 20.0);
        b.push(format!("eyelid_{s}_lower_rx"), "eyelids", Degrees, -40.0, 25.0);
        b.push(format!("eyelid_{s}_lower_rz"), "eyelids", Degrees, -20.0, 20.0);
    }
    for (s, _) in SIDES {
        b.push(format!("eyelid_{s}_blink"), "eyelids", Slider, 0.0, 1.0);
    }
    // eyes (6)
    for (s, _) in SIDES {
        b.push(format!("eye_{s}_yaw"), "eyes", Degrees, -35.0, 35.0);
        b.push(format!("eye_{s}_pitch"), "eyes", Degrees, -25.0, 25.0);
    }
    for (s, _) in SIDES {
        b.push(format!("eye_{s}_dilate"), "eyes", Slider, -1.0, 1.0);
    }
    // coarse shapes (44)
    for name in COARSE_SHAPES {
        b.push(name, "shapes_coarse", Slider, 0.0, 1.0);
    }
    // fine shapes (380)
    for fam in &FINE_FAMILIES {
        for (s, _) in fam.sides() {
            for seg in 0..fam.count {
                for dir in fam.dirs {
                    b.push(fam.name(s, seg, dir), "shapes_fine", Slider, 0.0, 1.0);
                }
            }
        }
    }
    // lattice (192)
    for i in 0..LATTICE_N {
        for j in 0..LATTICE_N {
            for k in 0..LATTICE_N {
                for axis in 0..3 {
                    b.push(lattice_name(i, j, k, axis), "lattice", Centimetres, -3.0, 3.0);
                }
            }
        }
    }
    // tweak (24)
    for region in TWEAK_REGIONS {
        for ax in ["tx", "ty", "tz"] {
            b.push(format!("tweak_{region}_{ax}"), "tweak", Centimetres, -2.0, 2.0);
        }
    }
    b.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{BTreeMap, HashSet};

    #[test]
    fn control_list_shape() {
        let c = build_controls();
        assert_eq!(c.len(), 742);
        let names: HashSet<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names.len(), c.len(), "control names must be unique");
        let mut groups: BTreeMap<&str, usize> = BTreeMap::new();
        for s in &c {
            *groups.entry(s.group.as_str()).or_default() += 1;
            assert!(s.min < s.max && s.default >= s.min && s.default <= s.max, "{}", s.name);
            assert!(s.name.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_'), "{}", s.name);
        }
        assert_eq!(groups["shapes_fine"], 380);
        assert_eq!(groups["shapes_coarse"], 44);
        assert_eq!(groups["lattice"], 192);
        assert_eq!(groups["eyes"], 6);
        for n in ["jaw_open", "ear_L_01_rx", "eye_L_yaw", "eye_R_pitch", "lattice_333_tz"] {
            assert!(names.contains(n), "{n}");
        }
        assert_eq!(Unit::Degrees.as_str(), "deg");
        assert_eq!(Unit::Centimetres.as_str(), "cm");
        assert_eq!(Unit::Slider.as_str(), "slider");
    }
}
