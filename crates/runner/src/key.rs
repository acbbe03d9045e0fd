//! The cache key: blake3 of a canonical serialisation of everything that decides a stage's
//! result — its name, its binary's identity (its code, or its bytes), its parameters (keys sorted, values
//! type-tagged), each input's content hash and each output's path.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::params::{canonical_tagged, Params, Tagged};

/// Bumped whenever the serialisation below changes, so old keys never match new ones.
const KEY_FORMAT: &str = "reprise-cache-key/2";

/// What the key hashes. Field order and sorted maps make the JSON canonical.
#[derive(Serialize)]
struct KeyMaterial<'a> {
    format: &'static str,
    stage: &'a str,
    bin_identity: &'a str,
    params: BTreeMap<&'a str, Tagged>,
    inputs: &'a BTreeMap<String, String>,
    outputs: BTreeMap<&'a str, &'a str>,
}

/// The hex cache key of a stage.
///
/// `bin_identity` is [`crate::lock::BinRecord::identity`]; `inputs` maps input name to the blake3 of its content; `outputs` gives each output's
/// name and normalised path.
#[must_use]
pub fn cache_key<'a>(
    stage: &str,
    bin_identity: &str,
    params: &Params,
    inputs: &BTreeMap<String, String>,
    outputs: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> String {
    let material = KeyMaterial {
        format: KEY_FORMAT,
        stage,
        bin_identity,
        params: canonical_tagged(params),
        inputs,
        outputs: outputs.into_iter().collect(),
    };
    // Serialising plain strings, integers and maps with string keys cannot fail.
    let bytes = serde_json::to_vec(&material).unwrap_or_default();
    blake3::hash(&bytes).to_hex().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{ParamValue, Scalar};

    fn p(pairs: &[(&str, i64)]) -> Params {
        pairs.iter().map(|(k, v)| ((*k).to_string(), ParamValue::Scalar(Scalar::Int(*v)))).collect()
    }

    fn key(params: &Params, input_hash: &str, out: &str) -> String {
        let inputs = BTreeMap::from([("frames".to_string(), input_hash.to_string())]);
        cache_key("label", "binhash", params, &inputs, [("segments", out)])
    }

    #[test]
    fn parameter_order_does_not_matter() {
        assert_eq!(key(&p(&[("a", 1), ("b", 2)]), "h", "o"), key(&p(&[("b", 2), ("a", 1)]), "h", "o"));
    }

    #[test]
    fn every_ingredient_changes_the_key() {
        let base = key(&p(&[("a", 1)]), "h", "o");
        assert_ne!(base, key(&p(&[("a", 2)]), "h", "o"), "parameter value");
        assert_ne!(base, key(&p(&[("b", 1)]), "h", "o"), "parameter name");
        assert_ne!(base, key(&p(&[]), "h", "o"), "parameter removed");
        assert_ne!(base, key(&p(&[("a", 1)]), "h2", "o"), "input content");
        assert_ne!(base, key(&p(&[("a", 1)]), "h", "o2"), "output path");
        let inputs = BTreeMap::from([("frames".to_string(), "h".to_string())]);
        assert_ne!(base, cache_key("label", "other", &p(&[("a", 1)]), &inputs, [("segments", "o")]), "binary");
        assert_ne!(base, cache_key("other", "binhash", &p(&[("a", 1)]), &inputs, [("segments", "o")]), "stage");
    }
}
