//! A scene's `params`: named numbers (`{"params": {"r": 0.3}}`) that any number of the
//! scene may reference as the string `"$r"`. They are substituted in the parsed value before
//! it is read as typed nodes, so a reference works wherever a number does — and nowhere
//! else: a reference where a vector, a name or a node is expected is the same type error a
//! misplaced number would be.
//!
//! A reference is a whole string `$` + an identifier (`[A-Za-z_][A-Za-z0-9_]*`); other strings
//! (paths, names, shading modes) are left alone. Integral values are substituted as integers,
//! so counts (`"count": "$n"`) take them too.

use serde_json::Value;
use std::collections::BTreeMap;

/// The identifier a string refers to (`"$r"` → `r`), if it is a reference.
fn reference(s: &str) -> Option<&str> {
    let name = s.strip_prefix('$')?;
    let mut chars = name.chars();
    let first = chars.next()?;
    ((first.is_ascii_alphabetic() || first == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_'))
    .then_some(name)
}

fn is_identifier(s: &str) -> bool {
    reference(&format!("${s}")).is_some()
}

/// The JSON number for a parameter's value: an integer when integral (and exact), so that
/// counts accept it.
fn number(x: f64) -> Value {
    if x.fract() == 0.0 && x.abs() < 9.0e15 {
        Value::from(x as i64)
    } else {
        Value::from(x)
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

/// Replaces every reference in `root` (but its `params` table) by its value, after applying
/// `overrides` to the table. Errors: `(node path, message)`.
pub(crate) fn substitute(
    root: &mut Value,
    overrides: &BTreeMap<String, f64>,
) -> Result<(), (String, String)> {
    let Some(obj) = root.as_object_mut() else {
        return Ok(());
    };
    let mut params = BTreeMap::new();
    if let Some(table) = obj.get_mut("params") {
        let Some(table) = table.as_object_mut() else {
            return Err((
                "params".to_owned(),
                "must be a table of named numbers, e.g. {\"r\": 0.3}".to_owned(),
            ));
        };
        for (name, v) in table.iter() {
            if !is_identifier(name) {
                return Err((
                    join("params", name),
                    "a parameter's name is a letter or `_` followed by letters, digits or `_`"
                        .to_owned(),
                ));
            }
            match v.as_f64() {
                Some(x) if x.is_finite() => {
                    params.insert(name.clone(), x);
                }
                _ => {
                    return Err((
                        join("params", name),
                        format!("{v} must be a number (parameters stand for numbers only)"),
                    ));
                }
            }
        }
        for (name, &x) in overrides {
            if !params.contains_key(name) {
                return Err(("params".to_owned(), unknown(name, &params)));
            }
            if !x.is_finite() {
                return Err((join("params", name), format!("{x} must be finite")));
            }
            params.insert(name.clone(), x);
            table.insert(name.clone(), Value::from(x));
        }
    } else if let Some(name) = overrides.keys().next() {
        return Err(("params".to_owned(), unknown(name, &params)));
    }
    for (key, v) in obj.iter_mut() {
        if key != "params" {
            walk(v, key.clone(), &params)?;
        }
    }
    Ok(())
}

fn unknown(name: &str, params: &BTreeMap<String, f64>) -> String {
    if params.is_empty() {
        format!("`${name}` refers to a parameter, but the scene has no `params` table")
    } else {
        let names: Vec<&str> = params.keys().map(String::as_str).collect();
        format!(
            "no parameter `{name}`; the scene's params are {}",
            names.join(", ")
        )
    }
}

fn walk(
    v: &mut Value,
    path: String,
    params: &BTreeMap<String, f64>,
) -> Result<(), (String, String)> {
    match v {
        Value::String(s) => {
            if let Some(name) = reference(s) {
                match params.get(name) {
                    Some(&x) => *v = number(x),
                    None => return Err((path, unknown(name, params))),
                }
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter_mut().enumerate() {
                walk(x, format!("{path}[{i}]"), params)?;
            }
        }
        Value::Object(o) => {
            for (k, x) in o.iter_mut() {
                walk(x, join(&path, k), params)?;
            }
        }
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn references_become_numbers_and_nothing_else_changes() {
        let mut v = json!({
            "params": {"r": 0.25, "n": 6},
            "shape": {"union": [
                {"sphere": {"radius": "$r", "center": ["$r", 0, 1]}},
                {"mesh": {"path": "$HOME/x.obj"}},
                {"circular_array": {"count": "$n", "of": {"circle": {}}}}
            ]}
        });
        substitute(&mut v, &BTreeMap::new()).unwrap();
        assert_eq!(v["shape"]["union"][0]["sphere"]["radius"], json!(0.25));
        assert_eq!(v["shape"]["union"][0]["sphere"]["center"][0], json!(0.25));
        assert_eq!(v["shape"]["union"][1]["mesh"]["path"], json!("$HOME/x.obj"));
        assert_eq!(v["shape"]["union"][2]["circular_array"]["count"], json!(6));
        let over = BTreeMap::from([("r".to_owned(), 0.5)]);
        let mut w = json!({"params": {"r": 0.25}, "shape": {"sphere": {"radius": "$r"}}});
        substitute(&mut w, &over).unwrap();
        assert_eq!(w["shape"]["sphere"]["radius"], json!(0.5));
        assert_eq!(w["params"]["r"], json!(0.5));
    }

    #[test]
    fn unknown_and_malformed_parameters_name_the_node() {
        let cases = [
            (
                json!({"shape": {"sphere": {"radius": "$r"}}}),
                "shape.sphere.radius",
                "no `params`",
            ),
            (
                json!({"params": {"a": 1}, "shape": {"union": [{"sphere": {"radius": "$b"}}]}}),
                "shape.union[0].sphere.radius",
                "params are a",
            ),
            (
                json!({"params": {"a": "x"}, "shape": {}}),
                "params.a",
                "number",
            ),
            (
                json!({"params": {"a": [1, 2]}, "shape": {}}),
                "params.a",
                "numbers only",
            ),
            (
                json!({"params": {"1a": 1}, "shape": {}}),
                "params.1a",
                "letter",
            ),
            (json!({"params": 3, "shape": {}}), "params", "table"),
        ];
        for (mut v, node, msg) in cases {
            let (n, m) = substitute(&mut v, &BTreeMap::new()).unwrap_err();
            assert_eq!(n, node);
            assert!(m.contains(msg), "{m}");
        }
        let over = BTreeMap::from([("zz".to_owned(), 1.0)]);
        let mut v = json!({"params": {"a": 1}, "shape": {}});
        assert!(
            substitute(&mut v, &over)
                .unwrap_err()
                .1
                .contains("no parameter `zz`")
        );
    }
}
