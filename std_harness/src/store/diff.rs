//! The fields by which two configurations (JSON values) differ, for error messages that
//! say what to fix: a field path, the value on record and the value asked for.

use serde_json::Value;

/// One differing field.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// Dotted path, array positions in brackets (`protocol.steps`, `source_records[1]`).
    pub path: String,
    /// The value on record (`None`: the field is absent there).
    pub old: Option<Value>,
    /// The value asked for (`None`: absent).
    pub new: Option<Value>,
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let show = |v: &Option<Value>| v.as_ref().map_or("(absent)".to_string(), Value::to_string);
        write!(
            f,
            "{}: {} → {}",
            self.path,
            show(&self.old),
            show(&self.new)
        )
    }
}

/// Every leaf where `old` and `new` differ, under the path `prefix`, in document order
/// (objects by key). Arrays of different lengths differ at each position one lacks.
pub fn differences(prefix: &str, old: &Value, new: &Value) -> Vec<Difference> {
    let mut out = Vec::new();
    walk(prefix, Some(old), Some(new), &mut out);
    out
}

fn walk(path: &str, old: Option<&Value>, new: Option<&Value>, out: &mut Vec<Difference>) {
    // Equal subtrees (the usual case) cost one comparison and no path strings.
    if old == new {
        return;
    }
    let join = |key: &str| {
        if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        }
    };
    match (old, new) {
        (Some(Value::Object(a)), Some(Value::Object(b))) => {
            let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                walk(&join(k), a.get(k), b.get(k), out);
            }
        }
        (Some(Value::Array(a)), Some(Value::Array(b))) => {
            for i in 0..a.len().max(b.len()) {
                walk(&format!("{path}[{i}]"), a.get(i), b.get(i), out);
            }
        }
        (a, b) => out.push(Difference {
            path: path.to_string(),
            old: a.cloned(),
            new: b.cloned(),
        }),
    }
}

/// The differences as indented lines, at most `limit` of them (then a count of the rest).
pub fn describe(differences: &[Difference], limit: usize) -> String {
    let mut lines: Vec<String> = differences
        .iter()
        .take(limit)
        .map(|d| format!("  {d}"))
        .collect();
    if differences.len() > limit {
        lines.push(format!("  … and {} more", differences.len() - limit));
    }
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn differences_name_the_path_and_both_values() {
        let old = json!({"seed": 0, "protocol": {"steps": 1, "epsilon": 0.1}, "records": [3, 4]});
        let new = json!({"seed": 0, "protocol": {"steps": 2, "epsilon": 0.1, "joint": true}, "records": [3]});
        let d = differences("experiment", &old, &new);
        let shown: Vec<String> = d.iter().map(ToString::to_string).collect();
        assert_eq!(
            shown,
            [
                "experiment.protocol.joint: (absent) → true",
                "experiment.protocol.steps: 1 → 2",
                "experiment.records[1]: 4 → (absent)",
            ]
        );
        assert!(differences("", &old, &old).is_empty());
        // A type change is one difference at that field.
        let d = differences("", &json!({"a": {"b": 1}}), &json!({"a": "b"}));
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].path, "a");
        assert_eq!(describe(&d, 0), "  … and 1 more");
    }
}
