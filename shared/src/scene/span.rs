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
/// `fluid.walls`), for a parse error that carries a span but no field name.
pub(super) fn field_at(text: &str, offset: usize) -> Option<String> {
    let root = DeTable::parse(text).ok()?;
    let inside = |r: std::ops::Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
    let mut path = String::new();
    let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
    let mut value: Option<&DeValue<'_>> = None;
    loop {
        let next = match (table, value) {
            (Some(t), _) => t
                .iter()
                .find(|(k, v)| inside(v.span()) || inside(k.span()))
                .map(|(k, v)| {
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(k.get_ref());
                    v
                }),
            (None, Some(DeValue::Array(a))) => a
                .iter()
                .enumerate()
                .find(|(_, v)| inside(v.span()))
                .map(|(i, v)| {
                    path.push_str(&format!("[{i}]"));
                    v
                }),
            _ => None,
        };
        let Some(next) = next else { break };
        value = Some(next.get_ref());
        table = match next.get_ref() {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    (!path.is_empty()).then_some(path)
}
