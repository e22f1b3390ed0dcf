//! A render's scene as its JSON summary records it (`scene`): every setting by the name of its
//! `host render` flag, with the flag's value. The command line writes and reads the same table
//! as a TOML scene file; `host render --scene out/render.json` renders it again.

use std::collections::BTreeMap;

/// One setting's value: a switch, a number, a text (names, paths), or a list (a comma list of
/// numbers, or the values of a flag given several times).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum SceneValue {
    Switch(bool),
    Integer(i64),
    Number(f64),
    Text(String),
    List(Vec<SceneValue>),
}

/// The settings of a render by flag name (without the leading dashes), in name order.
pub type SceneRecord = BTreeMap<String, SceneValue>;

/// Whether two settings have the same value however they are spelled: numbers compare as
/// numbers (`40`, `40.0` and `4e1` are one value, as the flag parses them), lists item by item,
/// anything else as written.
pub fn same_value(a: &SceneValue, b: &SceneValue) -> bool {
    match (a, b) {
        (SceneValue::List(x), SceneValue::List(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_value(p, q))
        }
        _ => match (as_number(a), as_number(b)) {
            (Some(x), Some(y)) => x == y,
            _ => a == b,
        },
    }
}

/// A scalar setting's number (an integer, a number, or a text that spells a finite number).
fn as_number(v: &SceneValue) -> Option<f64> {
    match v {
        SceneValue::Integer(i) => Some(*i as f64),
        SceneValue::Number(x) => Some(*x),
        SceneValue::Text(t) => t.trim().parse::<f64>().ok().filter(|x| x.is_finite()),
        _ => None,
    }
}

/// The keys whose values differ between two scenes by [`same_value`] (a key in one only
/// included), in name order.
pub fn differing_keys(a: &SceneRecord, b: &SceneRecord) -> Vec<String> {
    let mut keys: Vec<String> = a
        .iter()
        .filter(|(k, v)| b.get(*k).is_none_or(|w| !same_value(v, w)))
        .map(|(k, _)| k.clone())
        .chain(b.keys().filter(|k| !a.contains_key(*k)).cloned())
        .collect();
    keys.sort();
    keys
}

/// The TOML text of a resolved scene.
pub fn to_toml(rec: &SceneRecord) -> String {
    let mut doc = toml_edit::DocumentMut::new();
    for (k, v) in rec {
        doc.insert(k, toml_edit::value(to_toml_value(v)));
    }
    format!(
        "# A host render scene: every key is a flag of `host render` without the dashes \
         (docs/reference/cli.md).\n# Render it with `host render THIS.toml`; flags given there \
         override these settings.\n{doc}"
    )
}

fn to_toml_value(v: &SceneValue) -> toml_edit::Value {
    match v {
        SceneValue::Switch(b) => (*b).into(),
        SceneValue::Integer(i) => (*i).into(),
        SceneValue::Number(x) => (*x).into(),
        SceneValue::Text(t) => t.as_str().into(),
        SceneValue::List(items) => {
            toml_edit::Value::Array(items.iter().map(to_toml_value).collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values spelled differently compare equal where the flag reads one number; names and
    /// different numbers do not.
    #[test]
    fn settings_compare_by_value() {
        let t = |s: &str| SceneValue::Text(s.into());
        assert!(same_value(&SceneValue::Integer(40), &t("40.0")));
        assert!(same_value(&SceneValue::Integer(1000), &t("1e3")));
        assert!(same_value(&SceneValue::Number(0.5), &t("5e-1")));
        assert!(same_value(
            &SceneValue::List(vec![SceneValue::Integer(1), t("2.0")]),
            &SceneValue::List(vec![t("1"), SceneValue::Integer(2)])
        ));
        assert!(!same_value(
            &SceneValue::Integer(40),
            &SceneValue::Integer(41)
        ));
        assert!(!same_value(&t("cloud"), &t("explosion")));
        let a: SceneRecord = [("seed".to_owned(), SceneValue::Integer(3))].into();
        let b: SceneRecord = [("seed".to_owned(), t("3.0")), ("spp".to_owned(), t("4"))].into();
        assert_eq!(differing_keys(&a, &b), ["spp"]);
    }
}
