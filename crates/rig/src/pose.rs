//! From a table's controls (possibly masked) to the rig's full control vector.

use crate::RigError;

/// Where each column of a frame table goes in the rig's control vector; controls the
/// table lacks (masked ones) stay at the rig's rest value.
#[derive(Debug, Clone)]
pub struct PoseLayout {
    /// For each table column, its index in the rig's control vector.
    slots: Vec<usize>,
    rest: Vec<f64>,
}

impl PoseLayout {
    /// Maps `table` control names onto `rig` control names. Every table control must be
    /// a rig control.
    pub fn new(rig: &[String], rest: Vec<f64>, table: &[String]) -> Result<Self, RigError> {
        let index: std::collections::HashMap<&str, usize> =
            rig.iter().enumerate().map(|(i, n)| (n.as_str(), i)).collect();
        let slots = table
            .iter()
            .map(|name| {
                index.get(name.as_str()).copied().ok_or_else(|| {
                    RigError::Controls(format!("control `{name}` of the frame table is not a control of the rig"))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { slots, rest })
    }

    /// Number of table columns.
    pub fn table_len(&self) -> usize {
        self.slots.len()
    }

    /// Number of rig controls.
    pub fn rig_len(&self) -> usize {
        self.rest.len()
    }

    /// The rig's pose for one table row.
    pub fn full(&self, row: &[f64]) -> Vec<f64> {
        let mut pose = self.rest.clone();
        self.fill(row, &mut pose);
        pose
    }

    /// Writes a table row into a rig pose (other controls untouched).
    pub fn fill(&self, row: &[f64], pose: &mut [f64]) {
        for (&slot, &v) in self.slots.iter().zip(row) {
            pose[slot] = v;
        }
    }

    /// Rig poses for many table rows (row-major in, row-major out).
    pub fn full_batch(&self, rows: &[f64]) -> Vec<f64> {
        rows.chunks(self.slots.len().max(1)).flat_map(|r| self.full(r)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masked_controls_stay_at_rest() {
        let rig: Vec<String> = ["a", "b", "c"].map(String::from).to_vec();
        let layout = PoseLayout::new(&rig, vec![1.0, 2.0, 3.0], &["c".into(), "a".into()]).unwrap();
        assert_eq!(layout.full(&[30.0, 10.0]), vec![10.0, 2.0, 30.0]);
        assert_eq!(layout.full_batch(&[30.0, 10.0, 0.0, 0.0]), vec![10.0, 2.0, 30.0, 0.0, 2.0, 0.0]);
        let err = PoseLayout::new(&rig, vec![0.0; 3], &["z".into()]).unwrap_err();
        assert!(err.to_string().contains("`z`"));
    }
}
