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
