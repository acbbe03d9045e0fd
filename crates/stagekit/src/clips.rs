//! Choosing clips by name.

use globset::{Glob, GlobSet, GlobSetBuilder};

use crate::{StageError, StageResult};

/// Clip-name glob patterns as one matcher; `None` for no patterns.
///
/// # Errors
/// [`StageError::Config`] naming `flag` and the bad pattern.
pub fn matcher(patterns: &[String], flag: &str) -> StageResult<Option<GlobSet>> {
    if patterns.is_empty() {
        return Ok(None);
    }
    let mut b = GlobSetBuilder::new();
    for p in patterns {
        b.add(Glob::new(p).map_err(|e| StageError::Config(format!("{flag}: bad pattern `{p}`: {e}")))?);
    }
    b.build().map(Some).map_err(|e| StageError::Config(format!("{flag}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_clip_names_and_a_bad_one_is_named() {
        let m = matcher(&["roar_take*".into(), "Dance".into()], "--clips").unwrap().unwrap();
        assert!(m.is_match("roar_take3") && m.is_match("Dance") && !m.is_match("happy_take1"));
        assert!(matcher(&[], "--clips").unwrap().is_none());
        let err = matcher(&["[".into()], "--hold-out").unwrap_err().to_string();
        assert!(err.contains("--hold-out") && err.contains("`[`"), "{err}");
    }
}
