//! Finds the line of a field in the scene text, so a validation error can point at it.

use super::validate::{FieldError, Seg};
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
