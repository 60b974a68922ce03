//! Finds the line of a field in the scene text, so a validation error can point at it.

use super::error::{FieldError, Seg, render_path};
use toml::de::{DeTable, DeValue};

/// Fills `line` of each error with the line of its field (or of the nearest enclosing table
/// when the field itself is absent, e.g. a missing `motion`).
pub(super) fn locate(text: &str, errors: &mut [FieldError]) {
    let Ok(root) = DeTable::parse(text) else {
        return;
    };
    for e in errors.iter_mut() {
        let mut span = root.span();
        let mut value: Option<&DeValue<'_>> = None;
        let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
        for seg in &e.segments {
            let next = match (seg, table, value) {
                (Seg::Key(k), Some(t), _) => {
                    t.iter().find(|(key, _)| key.get_ref() == k).map(|(_, v)| v)
                }
                (Seg::Index(i), _, Some(DeValue::Array(a))) => a.get(*i),
                _ => None,
            };
            let Some(next) = next else { break };
            span = next.span();
            value = Some(next.get_ref());
            table = match next.get_ref() {
                DeValue::Table(t) => Some(t),
                _ => None,
            };
        }
        e.line = Some(text[..span.start.min(text.len())].matches('\n').count() + 1);
    }
}

/// The dotted path of the innermost field whose value holds byte `offset` of the text (e.g.
/// `fluid.walls`), for a parse error that carries a span but no field name. Searched depth
/// first: a `[table]`'s own span covers its header only, not the keys under it.
pub(super) fn field_at(text: &str, offset: usize) -> Option<String> {
    let root = DeTable::parse(text).ok()?;
    search(root.get_ref(), "", offset)
}

fn search(table: &DeTable<'_>, prefix: &str, offset: usize) -> Option<String> {
    let inside = |r: std::ops::Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
    for (key, value) in table.iter() {
        let path = if prefix.is_empty() {
            key.get_ref().to_string()
        } else {
            format!("{prefix}.{}", key.get_ref())
        };
        let found = match value.get_ref() {
            DeValue::Table(t) => search(t, &path, offset),
            DeValue::Array(a) => a.iter().enumerate().find_map(|(i, v)| match v.get_ref() {
                DeValue::Table(t) => search(t, &format!("{path}[{i}]"), offset),
                _ => inside(v.span()).then(|| format!("{path}[{i}]")),
            }),
            _ => None,
        };
        if found.is_some() {
            return found;
        }
        if inside(value.span()) {
            return Some(path);
        }
    }
    None
}

/// The length every fixed-size array field must have: serde reads `[f64; 3]` from the first
/// three elements of a TOML array and ignores the rest, so `min = [0, 0, 0, 7]` would be
/// silently truncated. `Some((n, true))`: each element of the array is an array of `n`.
/// `table` is the top-level table the key is in (a `[[runup]]` box is in plan: 2 numbers).
fn fixed_length(table: Option<&str>, key: &str) -> Option<(usize, bool)> {
    match key {
        "min" | "max" if table == Some("runup") => Some((2, false)),
        "gravity" | "min" | "max" | "velocity" | "angular_velocity" | "amplitude" | "position" => {
            Some((3, false))
        }
        "extent" => Some((2, false)),
        "vertices" => Some((3, true)),
        "profile" => Some((2, true)),
        _ => None,
    }
}

/// Every fixed-size array of the scene text with another number of elements than its field
/// has (solver parameter tables, `[fluid.<name>]` and `[solid.<name>]`, are the solvers' own).
pub(super) fn array_lengths(text: &str) -> Vec<FieldError> {
    let mut errors = Vec::new();
    if let Ok(root) = DeTable::parse(text) {
        walk(root.get_ref(), &mut Vec::new(), &mut errors);
    }
    errors
}

fn walk(table: &DeTable<'_>, path: &mut Vec<Seg>, errors: &mut Vec<FieldError>) {
    let solver_table = |path: &[Seg], key: &str| matches!(path, [Seg::Key(r)] if (r == "fluid" && key != "water") || (r == "solid" && key != "contact"));
    for (key, value) in table.iter() {
        let key = key.get_ref();
        if solver_table(path, key) && matches!(value.get_ref(), DeValue::Table(_)) {
            continue;
        }
        path.push(Seg::Key(key.to_string()));
        let top = match path.first() {
            Some(Seg::Key(t)) => Some(t.as_str()),
            _ => None,
        };
        match (value.get_ref(), fixed_length(top, key)) {
            (DeValue::Array(a), Some((n, nested))) => {
                let bad = if nested {
                    a.iter().enumerate().find_map(|(i, v)| match v.get_ref() {
                        DeValue::Array(inner) if inner.len() != n => Some((i, inner.len())),
                        _ => None,
                    })
                } else {
                    (a.len() != n).then_some((usize::MAX, a.len()))
                };
                if let Some((i, len)) = bad {
                    let mut segments = path.clone();
                    if i != usize::MAX {
                        segments.push(Seg::Index(i));
                    }
                    errors.push(FieldError {
                        path: render_path(&segments),
                        segments,
                        value: format!("{len} numbers"),
                        problem: format!(
                            "must hold exactly {n} numbers{}",
                            match (n, top) {
                                (2, Some("runup")) => " (x, y)",
                                (3, _) => " (x, y, z)",
                                _ => "",
                            }
                        ),
                        fix: format!("give {n} numbers; extra ones are not ignored silently"),
                        line: None,
                    });
                }
            }
            (DeValue::Table(t), _) => walk(t, path, errors),
            (DeValue::Array(a), None) => {
                for (i, v) in a.iter().enumerate() {
                    if let DeValue::Table(t) = v.get_ref() {
                        path.push(Seg::Index(i));
                        walk(t, path, errors);
                        path.pop();
                    }
                }
            }
            _ => {}
        }
        path.pop();
    }
}
