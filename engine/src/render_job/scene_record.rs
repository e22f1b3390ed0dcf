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
